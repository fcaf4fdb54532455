"""The recovery file, without a window: what it holds, an exact replay of the pose and selection it
kept, and every way a damaged or foreign one is refused in one line naming it."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import hybridedit as he
from hybridedit.viewer.model.recovery import (RecoveryError, RecoveryFile, _edit_of_json, orphans, process_alive,
                                              read_recovery, recover)
from hybridedit.viewer.model.session import Session
from shapes import capsule_blob

CAGE = 150


@pytest.fixture(scope="module")
def shape():
    return capsule_blob()


def session(shape) -> Session:
    return Session(he.HybridEditor(shape, CAGE), cage_size=CAGE)


def posed(shape) -> Session:
    """Two selections and drags (the second polished: two steps), then a third selection not dragged yet."""
    s = session(shape)
    P = s.editor.cage.vertices
    for roi, handle, move in ((P[:, 0] > 0.0, P[:, 0] > 1.4, [0.0, 0.3, 0.1]),
                              (P[:, 0] < 0.0, P[:, 0] < -1.4, [0.0, -0.2, 0.0])):
        s.selection.set_mask("roi", roi)
        s.selection.set_mask("handle", handle)
        s.begin_drag()
        T = np.eye(4)
        T[:3, 3] = move
        s.drag_to(T)
        s.end_drag()
        s.finish_settle()
    s.editor.polish(iterations=5)
    s.selection.set_mask("handle", P[:, 1] > P[:, 1].max() - 0.1)
    return s


def dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def orphaned_copy(path, **changes):
    data = json.loads(path.read_text())
    data.update(pid=dead_pid(), **changes)
    out = path.with_name(f"{path.stem.split('-')[0]}-{data['pid']}.json")
    out.write_text(json.dumps(data))
    return out


def test_a_recovery_replays_the_pose_and_selection_exactly(shape, tmp_path):
    lost = posed(shape)
    keeper = RecoveryFile(folder=tmp_path)
    path = keeper.write(lost)
    assert path.name.endswith(f"-{os.getpid()}.json") and path.parent == tmp_path
    rec = read_recovery(path)
    assert rec.steps == len(lost.editor.edit.steps) and rec.cage_vertices == lost.editor.cage.n_vertices
    assert not rec.orphaned  # this process is alive: never offered
    assert orphans(folder=tmp_path) == ([], [])
    s = session(shape)
    recover(s, rec)
    np.testing.assert_array_equal(s.shown_positions, lost.shown_positions)
    np.testing.assert_array_equal(s.selection.roi, lost.selection.roi)
    np.testing.assert_array_equal(s.selection.handle_group, lost.selection.handle_group)
    # one more drag goes on from it as it would have gone on from the lost pose
    T = np.eye(4)
    T[:3, 3] = [0.05, 0.0, 0.0]
    for x in (lost, s):
        x.begin_drag()
        x.drag_to(T)
        x.end_drag()
        x.finish_settle()
    np.testing.assert_array_equal(s.shown_positions, lost.shown_positions)
    keeper.remove()
    assert not path.exists() and keeper.path is None


def test_the_kept_poses_are_recovered_exactly_and_an_old_file_without_them_still_reads(shape, tmp_path):
    lost = posed(shape)
    first = lost.poses.keep(lost, "arm up")  # (the third selection not dragged yet: the pose as it is)
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.15, 0.0]
    lost.begin_drag()
    lost.drag_to(T)
    lost.end_drag()
    lost.finish_settle()
    second = lost.poses.keep(lost)
    path = RecoveryFile(folder=tmp_path).write(lost)
    rec = read_recovery(path)
    assert [n for n, _ in rec.poses] == ["arm up", "Pose 2"] and ", 2 kept poses, " in rec.summary()
    s = session(shape)
    recover(s, rec)
    assert s.poses.names == ["arm up", "Pose 2"] and s.poses.unsaved  # (saved nowhere yet)
    np.testing.assert_array_equal(s.poses[0].positions, first.positions)
    np.testing.assert_array_equal(s.poses[1].positions, second.positions)
    np.testing.assert_array_equal(s.shown_positions, lost.shown_positions)
    s.poses.continue_from(s, 0)
    np.testing.assert_array_equal(s.shown_positions, first.positions)
    # a file written before there were kept poses reads as one without them
    data = json.loads(path.read_text())
    del data["poses"]
    path.write_text(json.dumps(data))
    assert read_recovery(path).poses == ()


def test_the_edit_is_written_packed_reads_back_as_the_engines_and_a_version_1_file_still_reads(shape, tmp_path):
    lost = posed(shape)
    path = RecoveryFile(folder=tmp_path).write(lost)
    data = json.loads(path.read_text())
    assert data["version"] == 2
    step = data["edit"]["steps"][0]
    assert isinstance(step["roi"] if "roi" in step else step["fixed"], dict)  # (packed: no list of ints)
    assert isinstance(step["handles"][0]["indices"], dict)
    # unpacked, the edit JSON is the engine's edit file JSON, step for step
    want = lost.editor.edit.to_json()
    assert _edit_of_json(data["edit"], 2) == want
    # a version 1 file (the lists as lists) reads as it did
    data.update(version=1, edit=want)
    path.write_text(json.dumps(data))
    rec = read_recovery(path)
    s = session(shape)
    recover(s, rec)
    np.testing.assert_array_equal(s.shown_positions, lost.shown_positions)


def test_orphans_are_the_files_of_dead_processes_newest_first_and_damaged_ones_said(shape, tmp_path):
    keeper = RecoveryFile(folder=tmp_path)
    path = keeper.write(posed(shape))
    old = orphaned_copy(path, saved_at=1000.0)
    new = orphaned_copy(path, saved_at=2000.0)
    bad = tmp_path / "0123456789abcdef-1.json"
    bad.write_text("{ not json")
    found, problems = orphans(folder=tmp_path)
    assert [r.file for r in found] == [new, old]
    assert problems == [(bad, f"{bad}: damaged, not a recovery file (JSONDecodeError)")]
    topology = keeper.fingerprint(shape)["topology"]
    assert [r.file for r in orphans(folder=tmp_path, topology=topology)[0]] == [new, old]
    assert orphans(folder=tmp_path, topology="f" * 16) == ([], [])
    assert found[0].summary().startswith(f"{shape.name or 'shape'} (2 steps, ")


@pytest.mark.parametrize("damage, says", [
    (lambda d: d.update(format="something else"), "not a hybridedit recovery file"),
    (lambda d: d.update(version=99), "version 99"),
    (lambda d: d.pop("selection"), "a field is missing or malformed"),
    (lambda d: d["edit"].update(steps="x"), "damaged edit"),
    (lambda d: d["edit"]["steps"][0]["handles"][0]["indices"].update(packed="not base64!"), "malformed"),
    (lambda d: d["edit"]["steps"][0]["handles"][0]["indices"].update(packed="AAAA"), "malformed"),
    (lambda d: d["edit"]["steps"][0]["handles"][0]["indices"].update(size="x"), "malformed"),
    (lambda d: d.update(poses=[{"name": "", "steps": []}]), "damaged edit"),
    (lambda d: d.update(cage_size="big"), "malformed"),
])
def test_a_damaged_file_is_refused_in_one_line_naming_it(shape, tmp_path, damage, says):
    path = RecoveryFile(folder=tmp_path).write(posed(shape))
    data = json.loads(path.read_text())
    damage(data)
    path.write_text(json.dumps(data))
    with pytest.raises(RecoveryError) as e:
        read_recovery(path)
    assert str(e.value).startswith(f"{path}: ") and says in str(e.value) and "\n" not in str(e.value)


def test_a_recovery_of_another_shape_or_cage_is_refused_and_changes_nothing(shape, tmp_path):
    rec = read_recovery(RecoveryFile(folder=tmp_path).write(posed(shape)))
    other = session(capsule_blob(3))
    before = other.shown_positions.copy()
    with pytest.raises(RecoveryError, match="another shape"):
        recover(other, rec)
    np.testing.assert_array_equal(other.shown_positions, before)
    coarse = Session(he.HybridEditor(shape, 60), cage_size=60)
    with pytest.raises(RecoveryError, match="cage of"):
        recover(coarse, rec)
    assert not coarse.is_posed()


def test_process_alive():
    assert process_alive(os.getpid())
    assert not process_alive(dead_pid())
    assert not process_alive(os.getpid(), host="another-machine")

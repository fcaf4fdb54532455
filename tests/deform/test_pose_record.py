"""The record of how a pose was made (hybridedit.deform.pose_record) and the editor's use of it."""

from __future__ import annotations

import json

import numpy as np
import pytest

import hybridedit as he
from hybridedit.core.held_bytes import held_buffers
from hybridedit.fileio.editfile import Edit, HandleEdit
from hybridedit.deform.packed_step import PackedStep, unpack_step_json
from hybridedit.deform.pose_record import PoseRecord

from shapes import bumpy_blob


def test_a_step_is_settled_while_every_drag_runs_at_one_transform():
    r = PoseRecord().restarted()
    r = r.after_drag(same_transforms=False, iterations=2)  # the first drag: nothing before it to differ from
    assert r.settled and r.iterations == 2 and r.dragged
    r = r.after_drag(same_transforms=True, iterations=2)
    assert r.settled and r.iterations == 4
    r = r.after_drag(same_transforms=False, iterations=2)
    assert not r.settled and not r.replayable
    assert r.restarted().settled and r.restarted().iterations == 0 and r.restarted().done == r.done


def test_closing_a_step_keeps_it_and_starts_another():
    step = Edit(handle=[1], iterations=4)
    r = PoseRecord().after_drag(same_transforms=True, iterations=4).closed(step)
    assert [e.to_json() for e in r.done] == [step.to_json()] and not r.dragged and r.iterations == 0 and r.replayable
    assert not r.closed(Edit(handle=[2])).replayable  # a step with no iteration count: its pose is unknown
    assert not PoseRecord.from_outside("set by hand").replayable


@pytest.mark.parametrize("indices", [[], [0], [3, 7, 8, 9, 4000], [5, 2, 2, 9], list(range(10, 60000, 3))])
def test_a_closed_step_keeps_its_index_lists_exactly(indices):
    fixed = np.arange(0, 2000, 7)
    step = Edit(handles=[HandleEdit(np.asarray(indices, dtype=np.int64), translate=np.array([0.0, 1.0, 2.0]))],
                fixed=fixed, iterations=60, polish=3)
    back = PoseRecord().closed(step).done[0]
    assert back.handle.dtype == np.int64 and np.array_equal(back.handle, indices)
    assert np.array_equal(back.fixed, fixed) and back.roi is None
    assert back.to_json() == step.to_json()


@pytest.mark.parametrize("indices", [[], [0], [3, 7, 8, 9, 4000], [5, 2, 2, 9], list(range(10, 60000, 3))])
@pytest.mark.parametrize("continues", [False, True])
def test_a_packed_steps_json_unpacks_to_the_edit_files_own(indices, continues):
    step = Edit(handles=[HandleEdit(np.asarray(indices, dtype=np.int64), translate=np.array([0.0, 1.0, 2.0])),
                         HandleEdit(np.array([40_000, 40_001]), translate=np.zeros(3))],
                roi=np.arange(0, 50_000, 2), iterations=60, polish=3, continues=continues,
                cage={"size": 0.05, "vertices": 900})
    packed = PackedStep.of(step)
    d = json.loads(json.dumps(packed.to_json()))  # (through the text, as a recovery file holds it)
    want = step.to_json()["steps"][0]
    if not continues:
        assert isinstance(d["roi"], dict) and all(isinstance(h["indices"], dict) for h in d["handles"])
        assert len(json.dumps(d)) * 20 < len(json.dumps(want))  # (the region's list: runs, packed)
    assert unpack_step_json(d) == want


def test_a_closed_step_is_kept_small():
    roi = np.flatnonzero(np.sin(np.arange(100_000) / 900.0) > 0.3)  # a few runs, as a region of a mesh is
    step = Edit(handle=roi[:500], roi=roi, iterations=60)
    kept = sum(held_buffers(PoseRecord().closed(step)).values())
    assert kept * 50 < roi.nbytes  # (int64 lists: 8 bytes an index)


@pytest.fixture(scope="module")
def shape():
    return bumpy_blob(3)


def test_the_editor_says_when_its_edit_does_not_give_its_pose(shape):
    ed = he.HybridEditor(shape, 120)
    x = shape.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > x.max() - 0.3), roi=np.flatnonzero(x > -0.5))
    for t in (0.1, 0.2, 0.3):  # interactive frames at changing transforms
        ed.drag(translate=(0, t, 0))
    assert not ed.replayable and ed.edit.iterations is None
    ed.reset()
    assert ed.replayable and ed.record == PoseRecord()
    ed.drag(translate=(0, 0.3, 0))
    assert ed.replayable and ed.edit.iterations == ed.iterations
    state = ed.save_state()
    ed.set_pose(ed.deformed_vertices * 1.01)
    assert not ed.replayable and ed.record.unknown == "the pose was set by set_pose"
    ed.restore_state(state)  # undo takes the record back with the pose
    assert ed.replayable


def test_a_polish_of_a_pose_that_is_gone_is_refused(shape):
    ed = he.HybridEditor(shape, 120)
    x = shape.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > x.max() - 0.3), roi=np.flatnonzero(x > -0.5))
    ed.drag(translate=(0, 0.3, 0))
    job = ed.polish_job()
    from hybridedit.deform.polish import ShapeARAP

    result = job.run(ShapeARAP(shape))
    ed.drag(translate=(0, 0.4, 0))
    with pytest.raises(ValueError, match="pose changed"):
        ed.adopt_polish(job, result)
    with pytest.raises(he.SelectionError):
        he.HybridEditor(shape, 120).polish_job()

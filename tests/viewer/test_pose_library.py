"""The pose library (no Qt): kept poses by unique names, continued from exactly, read back by replay."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.core.transforms import rigid_transform
from hybridedit.viewer.model.pose_library import PoseLibrary, PoseLibraryError, replay_poses
from hybridedit.viewer.model.selection_masks import HANDLE, ROI


def select(s, sign: float = 1.0) -> None:
    """ROI: one half of the test shape's cage (+x, or -x with ``sign`` -1); handle: that end."""
    P = s.cage_positions
    s.selection.set_mask(ROI, sign * P[:, 0] > 0.0)
    s.selection.set_mask(HANDLE, sign * P[:, 0] > 1.4)


def drag(s, translate) -> np.ndarray:
    T0 = s.begin_drag()
    s.drag_to(rigid_transform(translate=translate) @ T0)
    s.end_drag()
    s.finish_settle()
    return s.shown_positions.copy()


@pytest.fixture
def two(session):
    """The session with two poses kept: the +x end up, then the -x end down as well."""
    select(session)
    up = drag(session, (0, 0.3, 0))
    session.poses.keep(session)
    select(session, -1.0)
    both = drag(session, (0, -0.25, 0))
    session.poses.keep(session)
    return session, up, both


def test_keep_holds_the_edit_and_a_frozen_copy_of_the_positions(two):
    s, up, both = two
    lib = s.poses
    assert lib.names == ["Pose 1", "Pose 2"] and lib.unsaved and lib.revision == 2
    assert np.array_equal(lib[0].positions, up) and np.array_equal(lib[1].positions, both)
    assert not np.array_equal(up, both)
    assert len(lib[0].edit.steps) == 1 and len(lib[1].edit.steps) == 2
    with pytest.raises(ValueError):
        lib[1].positions[0, 0] = 9.0  # read-only
    drag(s, (0.2, 0, 0))  # editing on changes the kept poses not at all
    assert np.array_equal(lib[1].positions, both)
    lib.mark_saved()
    assert not lib.unsaved


def test_names_are_unique_and_rename_refuses_empty_or_taken_in_one_line(two):
    s, _, _ = two
    lib = s.poses
    for bad, words in (("  ", "A pose needs a name."), ("Pose 1", "There is a pose named 'Pose 1' already."),
                       ("a\nb", "one line")):
        with pytest.raises(PoseLibraryError) as err:
            lib.rename(1, bad)
        assert words in str(err.value) and "\n" not in str(err.value)
    assert lib.names == ["Pose 1", "Pose 2"]
    revision = lib.revision
    assert lib.rename(0, " Pose 1 ").name == "Pose 1" and lib.revision == revision  # the same name: no change
    assert lib.rename(0, "  arm up ").name == "arm up" and lib.revision == revision + 1
    # the next default name is the first "Pose N" free from the length on
    assert lib.default_name() == "Pose 3"
    lib.rename(0, "Pose 3")
    assert lib.default_name() == "Pose 4"
    with pytest.raises(PoseLibraryError, match="already"):
        lib.keep(s, "Pose 2")


def test_remove_and_move(two):
    s, up, both = two
    lib = s.poses
    lib.keep(s, "third")
    assert lib.move(2, -1) == 1 and lib.names == ["Pose 1", "third", "Pose 2"]
    assert lib.move(0, -1) == 0 and lib.move(2, 5) == 2  # at the ends: stays
    assert lib.remove(1).name == "third" and lib.names == ["Pose 1", "Pose 2"]
    assert np.array_equal(lib[1].positions, both)


def test_continue_from_gives_the_pose_exactly_as_one_undo_step_and_editing_goes_on(two):
    s, up, both = two
    before = len(s.history)
    s.poses.continue_from(s, 0)
    assert np.array_equal(s.shown_positions, up)
    assert s.history.current.label == "continue from Pose 1" and len(s.history) == before + 1
    # the next drag goes on from it: its edit is the pose's steps and the new drag
    on = drag(s, (0, 0.1, 0))
    assert not np.array_equal(on, up) and len(s.to_edit().steps) == 1  # (the same selection dragged on)
    s.undo()
    s.undo()
    assert np.array_equal(s.shown_positions, both)  # back to the pose it was continued on
    s.poses.continue_from(s, 1)
    assert np.array_equal(s.shown_positions, both)


def test_replay_poses_reads_them_back_exactly_and_leaves_the_session_as_it_was(two):
    s, up, both = two
    select(s)
    here = drag(s, (0.1, 0.1, 0))
    steps = len(s.history)
    back = replay_poses(s, s.poses.entries(), path="kept.json")
    assert [p.name for p in back] == ["Pose 1", "Pose 2"]
    assert np.array_equal(back[0].positions, up) and np.array_equal(back[1].positions, both)
    assert np.array_equal(s.shown_positions, here) and len(s.history) == steps
    # the session goes on as if nothing happened: the next drag is the same one
    again = s.history.current
    s.cancel_drag()
    assert s.history.current is again and np.array_equal(s.shown_positions, here)


def test_take_replaces_a_saved_library_and_adds_to_an_unsaved_one(two):
    s, up, both = two
    read = replay_poses(s, s.poses.entries(), path="kept.json")
    fresh = PoseLibrary()
    assert fresh.take(read, saved=True) and fresh.names == ["Pose 1", "Pose 2"] and not fresh.unsaved
    assert fresh.take(read[:1], saved=True) and fresh.names == ["Pose 1"]  # saved: replaced, nothing lost
    fresh.keep(s, "mine")  # unsaved now: what is read is added after, its taken names made free
    assert not fresh.take(read, saved=True)
    assert fresh.names == ["Pose 1", "mine", "Pose 1 (2)", "Pose 2"] and fresh.unsaved
    assert np.array_equal(fresh[2].positions, up)
    recovered = PoseLibrary()
    assert recovered.take(read, saved=False) and recovered.unsaved  # (a recovery: not saved anywhere)


def test_nothing_to_keep_at_rest_without_a_selection(session):
    with pytest.raises(PoseLibraryError, match="Nothing to keep") as err:
        session.poses.keep(session)
    assert "\n" not in str(err.value) and len(session.poses) == 0 and not session.poses.unsaved

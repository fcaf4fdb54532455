"""The one replay loop: an edit's steps give the pose the editor made, exactly."""

from __future__ import annotations

import json

import numpy as np
import pytest

import hybridedit as he
from hybridedit.fileio.editfile import Edit, EditFileError, HandleEdit, parse_edit
from hybridedit.deform.replay import cage_of, replay

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def shape():
    return bumpy_blob(3)


def ends(shape):
    x = shape.vertices[:, 0]
    return {"right": np.flatnonzero(x > x.max() - 0.3), "right_roi": np.flatnonzero(x > -0.5),
            "left": np.flatnonzero(x < x.min() + 0.3), "left_roi": np.flatnonzero(x < 0.3)}


def three_steps(ed, shape):
    """A settled drag and its polish, the same selection dragged on, another selection turned."""
    e = ends(shape)
    ed.set_selection(e["right"], roi=e["right_roi"])
    for _ in range(30):
        ed.drag(translate=(0, 0.5, 0.1))
    ed.polish()
    for _ in range(20):
        ed.drag(translate=(0.2, 0, 0))
    ed.set_selection(e["left"], roi=e["left_roi"])
    for _ in range(30):
        ed.drag(rotate={"axis": [0, 0, 1], "degrees": 20})
    return ed.deformed_vertices.copy()


def test_the_steps_of_a_pose_replay_to_it_exactly_through_a_file(shape):
    ed = he.HybridEditor(shape, 120)
    V = three_steps(ed, shape)
    edit = ed.edit
    assert ed.replayable
    assert [(s.iterations, s.polish is not None, s.continues) for s in edit.steps] == [
        (60, True, False), (40, False, True), (60, False, False)]
    back = parse_edit(json.loads(json.dumps(edit.to_json())))  # through JSON
    again = he.HybridEditor(shape, 120)
    assert np.array_equal(again.apply_edit(back), V)


def test_progress_rises_from_0_to_1_and_never_beyond(shape):
    ed = he.HybridEditor(shape, 120)
    three_steps(ed, shape)
    said = []
    again = he.HybridEditor(shape, 120)
    replay(again, ed.edit, iterations=7, progress=lambda stage, f: said.append((stage, f)))
    fractions = [f for _, f in said]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0
    assert all(0.0 <= a <= b <= 1.0 for a, b in zip(fractions, fractions[1:]))
    assert {"deforming", "polishing"} <= {stage for stage, _ in said}
    assert fractions[-2] > 0.8  # the count covers the work: the last unit starts near the end


def test_the_split_into_drags_does_not_change_the_pose(shape):
    """What the settle's slices and the replay's drags rely on: k iterations are k iterations."""
    e = ends(shape)
    a, b = he.HybridEditor(shape, 120), he.HybridEditor(shape, 120)
    for ed in (a, b):
        ed.set_selection(e["right"], roi=e["right_roi"])
    a.drag(translate=(0, 0.4, 0), iterations=60)
    for k in (1, 7, 2, 50):
        b.drag(translate=(0, 0.4, 0), iterations=k)
    assert np.array_equal(a.deformed_vertices, b.deformed_vertices)
    assert a.edit.iterations == b.edit.iterations == 60


def test_frames_zero_sets_the_last_selection_after_the_steps_before(shape):
    ed = he.HybridEditor(shape, 120)
    three_steps(ed, shape)
    edit = ed.edit
    before_last = he.HybridEditor(shape, 120)
    before_last.apply_edit(Edit(handles=edit.before[-1].handles, roi=edit.before[-1].roi, continues=True,
                                iterations=edit.before[-1].iterations, before=edit.before[:-1]))
    again = he.HybridEditor(shape, 120)
    V = again.apply_edit(edit, frames=0)
    assert np.array_equal(V, before_last.deformed_vertices)  # the last step's drags are not run
    assert np.array_equal(again.vertex_roles, ed.vertex_roles)  # its selection is set


def test_a_version_2_edit_runs_frames_times_iterations(shape):
    e = ends(shape)
    edit = Edit(handle=e["right"], roi=e["right_roi"], translate=np.array([0, 0.3, 0]))
    a = he.HybridEditor(shape, 120)
    A = a.apply_edit(edit, frames=12, iterations=3).copy()
    b = he.HybridEditor(shape, 120)
    b.set_selection(e["right"], roi=e["right_roi"])
    for _ in range(12):
        B = b.drag(translate=(0, 0.3, 0), iterations=3)
    assert np.array_equal(A, B)


def test_an_edit_across_a_rebuild_replays_on_the_cages_it_ran_on(shape):
    e = ends(shape)
    first = he.HybridEditor(shape, 120)
    first.set_selection(e["right"], roi=e["right_roi"])
    for _ in range(30):
        first.drag(translate=(0, 0.5, 0))
    second = he.HybridEditor(shape, 80)  # a rebuild: the pose and its steps carried over
    second.carry_pose(first)
    assert np.array_equal(second.deformed_vertices, first.deformed_vertices)
    second.set_selection(e["left"], roi=e["left_roi"])
    for _ in range(30):
        V = second.drag(translate=(0, -0.3, 0))
    edit = second.edit
    assert [s.cage for s in edit.steps] == [cage_of(first), cage_of(second)]
    made = {}

    def editor_for(cage):
        made[cage["vertices"]] = he.HybridEditor(shape, cage["size"])
        return made[cage["vertices"]]

    home = he.HybridEditor(shape, 80)
    assert np.array_equal(home.apply_edit(edit, editor_for_cage=editor_for), V)
    assert list(made) == [first.cage.n_vertices]
    # without editors of the other cages every step runs on this one: close, not the same
    near = he.HybridEditor(shape, 80).apply_edit(edit)
    assert 0 < np.abs(near - V).max() < 0.1 * shape.bbox_diagonal()


def test_a_step_that_continues_must_match_the_groups_before(shape):
    e = ends(shape)
    first = Edit(handles=[HandleEdit(e["right"])], roi=e["right_roi"], iterations=4)
    bad = Edit(handles=[HandleEdit(e["right"]), HandleEdit(e["left"])], continues=True, iterations=2,
               before=[first])
    with pytest.raises(EditFileError, match="continues a selection of 2 handle groups"):
        he.HybridEditor(shape, 120).apply_edit(bad)


def test_an_edit_of_another_mesh_is_refused(shape):
    ed = he.HybridEditor(shape, 120)
    three_steps(ed, shape)
    other = bumpy_blob(2)
    with pytest.raises(EditFileError, match="refused"):
        he.HybridEditor(other, 60).apply_edit(ed.edit, path="pose.json")


def test_replay_takes_its_arguments_by_keyword_and_checks_them(shape):
    ed = he.HybridEditor(shape, 120)
    edit = Edit(handle=ends(shape)["right"])
    with pytest.raises(ValueError, match="frames"):
        replay(ed, edit, frames=-1)
    with pytest.raises(ValueError, match="iterations"):
        replay(ed, edit, iterations=-2)

"""HybridEditor.converge: the cage's ARAP to its fixed point (L-BFGS, by a bound), then one
propagation; exact constraints, determinism, cancel, the cap, and an exact replay of its record."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest

import hybridedit as he
from hybridedit.core.transforms import apply_transform, rigid_transform
from hybridedit.deform.lbfgs import converge as converge_map
from hybridedit.deform.frame_steps import cage_targets
from hybridedit.deform.local_global import local_global_map
from hybridedit.fileio.editfile import EditFileError, parse_edit

from shapes import arm_edit


def plain_fixed_point(ed, move, *, step: float = 1e-11):
    """Plain drags at ``move`` until one moves no cage vertex by more than ``step`` of the diagonal:
    the reference (cage (c, 3), shape (n, 3))."""
    diag = ed.mesh.bbox_diagonal()
    before = ed.cage_positions
    for _ in range(20000):
        ed.drag(**move, iterations=10)
        now = ed.cage_positions
        if np.abs(now - before).max() <= step * diag:
            return now, ed.deformed_vertices.copy()
        before = now
    raise AssertionError("the plain iterations did not converge")


def blob_arm(blob_rig, blob):
    ed = he.HybridEditor(blob_rig)
    return ed, arm_edit(ed, blob)


@pytest.fixture(scope="module")
def reference(blob_rig, blob):
    ed, move = blob_arm(blob_rig, blob)
    return plain_fixed_point(ed, move)


@pytest.mark.parametrize("tolerance", [1e-4, 1e-6, 1e-8])
def test_the_result_is_within_the_tolerance_of_the_fixed_point(blob_rig, blob, reference, tolerance):
    ed, move = blob_arm(blob_rig, blob)
    diag = blob.bbox_diagonal()
    r = ed.converge(**move, tolerance=tolerance)
    assert r.converged and r.stopped == "converged" and r.distance <= tolerance
    cage, shape = reference
    assert np.abs(ed.cage_positions - cage).max() <= tolerance * diag
    assert np.abs(r.vertices - shape).max() <= tolerance * diag
    assert not r.vertices.flags.writeable and np.shares_memory(r.vertices, ed.deformed_vertices)


def test_it_takes_far_fewer_iterations_than_the_plain_ones(blob_rig, blob):
    a, move = blob_arm(blob_rig, blob)
    r = a.converge(**move)
    b, _ = blob_arm(blob_rig, blob)
    diag = blob.bbox_diagonal()
    plain = 0
    while np.abs(b.cage_positions - a.cage_positions).max() > 1e-6 * diag:  # where the converge stopped
        b.drag(**move, iterations=1)
        plain += 1
    assert r.iterations < plain


def test_the_map_is_one_plain_iteration_bit_for_bit(blob_rig, blob):
    """The local/global map on the region's part of the cage is the solver's own iteration."""
    ed, move = blob_arm(blob_rig, blob)
    internal = ed._sel.group_transforms([rigid_transform(translate=move["translate"], **move["rotate"])])
    slots, target = cage_targets(ed._base.cage, ed._sel, internal, scale=ed._scale)
    gmap = local_global_map(ed.arap, target, slots=slots)
    x = gmap.start()
    for _ in range(3):
        gmap.rotate(x)
        x = gmap.step()
        ed.arap.solve(target, 1, slots=slots)
        assert np.array_equal(ed.arap.positions[ed.arap.free], x)
        assert np.array_equal(ed.arap.rotations[ed.arap.active], gmap.rotations())


def test_the_bound_holds_along_the_way(blob_rig, blob, reference):
    """The stopping rule bounds the distance to the fixed point, not the last step: at every
    tolerance it stops at, the cage is within it."""
    diag = blob.bbox_diagonal()
    cage, _ = reference
    for tolerance in (1e-3, 1e-5, 1e-7, 1e-9):
        ed, move = blob_arm(blob_rig, blob)
        internal = ed._sel.group_transforms([rigid_transform(translate=move["translate"], **move["rotate"])])
        slots, target = cage_targets(ed._base.cage, ed._sel, internal, scale=ed._scale)
        gmap = local_global_map(ed.arap, target, slots=slots)
        x, stats = converge_map(gmap, tolerance=tolerance * diag)
        assert stats.converged and stats.distance <= tolerance * diag
        assert np.abs(x - cage[ed.arap.free]).max() <= tolerance * diag


class _Watched:
    """A map that records the energy of each point a global step is taken from (the points the run
    accepts: the last local step before each global one)."""

    def __init__(self, gmap):
        self._m, self.taken, self._last = gmap, [], None

    def start(self):
        return self._m.start()

    def rotate(self, x):
        self._last = self._m.rotate(x)
        return self._last

    def step(self):
        self.taken.append(self._last)
        return self._m.step()

    def metric(self, v):
        return self._m.metric(v)


@pytest.mark.parametrize("degrees", [35, 120])
def test_every_point_taken_lowers_the_energy(blob_rig, blob, degrees):
    """The line search keeps the run a descent (a step that raises the energy is halved, then
    replaced by the plain step), so it cannot be drawn to a saddle of the energy."""
    ed, move = blob_arm(blob_rig, blob)
    T = rigid_transform(translate=move["translate"], axis=(0, 0, 1), degrees=degrees,
                        center=blob.vertices[ed.vertex_roles == 1].mean(axis=0))
    slots, target = cage_targets(ed._base.cage, ed._sel, ed._sel.group_transforms([T]), scale=ed._scale)
    watched = _Watched(local_global_map(ed.arap, target, slots=slots))
    _, stats = converge_map(watched, tolerance=1e-8 * blob.bbox_diagonal())
    e = np.array(watched.taken)
    assert stats.converged and len(e) == stats.iterations
    assert np.all(e[1:] <= e[:-1] * (1 + 1e-12))
    assert e[-1] < e[0]


def test_the_handle_is_at_its_transform_and_the_fixed_part_at_rest_exactly(blob_rig, blob):
    ed, move = blob_arm(blob_rig, blob)
    T = rigid_transform(translate=move["translate"], **move["rotate"])
    V = ed.converge(transform=T).vertices
    roles = ed.vertex_roles
    diag = blob.bbox_diagonal()
    fixed, hand = roles == -1, roles == 1
    assert fixed.any() and hand.any()
    assert np.array_equal(V[fixed], blob.vertices[fixed])
    assert np.abs(V[hand] - apply_transform(T, blob.vertices[hand])).max() <= 1e-16 * diag


def test_a_rigid_move_of_a_shape_with_nothing_fixed_moves_it_rigidly(blob_rig, blob):
    ed = he.HybridEditor(blob_rig)
    x = blob.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > 1.6))  # nothing fixed
    T = rigid_transform(translate=(0.3, -0.2, 0.5), axis=(1, 2, 0.5), degrees=70, center=(0.2, 0, 0))
    r = ed.converge(transform=T)
    assert r.converged
    assert np.abs(r.vertices - apply_transform(T, blob.vertices)).max() <= 1e-6 * blob.bbox_diagonal()


def test_the_identity_leaves_the_rest_pose(blob_rig, blob):
    ed, _ = blob_arm(blob_rig, blob)
    r = ed.converge(transform=np.eye(4))
    assert r.converged and r.iterations <= 2 and r.distance <= 1e-6
    assert np.abs(r.vertices - blob.vertices).max() <= 1e-12 * blob.bbox_diagonal()


def test_the_same_start_gives_the_same_pose_bit_for_bit(blob_rig, blob):
    a, move = blob_arm(blob_rig, blob)
    b, _ = blob_arm(blob_rig, blob)
    for _ in range(5):  # the same warm start on both
        a.drag(translate=(0, 0.1, 0))
        b.drag(translate=(0, 0.1, 0))
    ra, rb = a.converge(**move), b.converge(**move)
    assert ra.iterations == rb.iterations
    assert np.array_equal(ra.vertices, rb.vertices) and np.array_equal(a.cage_positions, b.cage_positions)


def test_from_the_base_the_pose_does_not_depend_on_what_ran_before(blob_rig, blob):
    """An animation frame: its transforms solved from the start pose, whatever frames came before
    (by ``start="base"``, or by restoring the state the selection was set in)."""
    fresh, move = blob_arm(blob_rig, blob)
    want = fresh.converge(**move).vertices.copy()
    ed, _ = blob_arm(blob_rig, blob)
    bound = ed.save_state()
    for k in range(4):  # other frames: converged, dragged, converged from the base
        ed.converge(translate=(0.1 * k, 0.2, 0), rotate={"axis": (1, 0, 0), "degrees": 10 * k})
        ed.drag(translate=(0, -0.3, 0.1))
        ed.converge(rotate={"axis": (0, 1, 0), "degrees": 25}, start="base")
    assert np.array_equal(ed.converge(**move, start="base").vertices, want)
    ed.drag(translate=(0.2, 0.2, 0.2))
    ed.restore_state(bound)
    assert np.array_equal(ed.converge(**move).vertices, want)
    assert ed.replayable


def test_a_cancel_stops_it_and_changes_nothing(blob_rig, blob):
    ed, move = blob_arm(blob_rig, blob)
    ed.drag(translate=(0, 0.1, 0))
    V, cage, record, transforms = ed.deformed_vertices.copy(), ed.cage_positions, ed.record, ed.transforms
    stop = threading.Event()
    stop.set()
    r = ed.converge(**move, cancel=stop)
    assert r.stopped == "cancelled" and not r.converged and r.iterations == 1
    calls = []
    r = ed.converge(**move, cancel=lambda: calls.append(1) or len(calls) >= 4)
    assert r.stopped == "cancelled" and r.iterations == 4
    assert np.array_equal(ed.deformed_vertices, V) and np.array_equal(ed.cage_positions, cage)
    assert ed.record == record and all(np.array_equal(a, b) for a, b in zip(ed.transforms, transforms))


#: a move whose transform an edit file gives back bit for bit (a rotation about the group's centre)
HAND_MOVE = {"translate": (0, 0.2, 0), "rotate": {"axis": [0, 0, 1], "degrees": 35}}


def test_a_cap_says_not_converged_and_replays(blob_rig, blob):
    ed, _ = blob_arm(blob_rig, blob)
    r = ed.converge(**HAND_MOVE, max_iterations=3)
    assert not r.converged and r.stopped == "iterations" and r.iterations == 3 and r.distance > 1e-6
    assert ed.edit.converge == {"tolerance": 1e-6, "max_iterations": 3}
    again = he.HybridEditor(blob_rig)
    assert np.array_equal(again.apply_edit(ed.edit), r.vertices)


def test_progress_rises_to_1_by_the_residual(blob_rig, blob):
    ed, move = blob_arm(blob_rig, blob)
    said = []
    r = ed.converge(**move, progress=lambda stage, f: said.append((stage, f)))
    fractions = [f for _, f in said]
    assert {s for s, _ in said} == {"converging"}
    assert len(fractions) == r.iterations  # (each iteration before the last, then 1.0)
    assert all(0.0 <= a <= b <= 1.0 for a, b in zip(fractions, fractions[1:])) and fractions[-1] == 1.0


def test_bad_arguments_are_refused(blob_rig, blob):
    ed = he.HybridEditor(blob_rig)
    with pytest.raises(he.SelectionError, match="selection"):
        ed.converge(translate=(0, 1, 0))
    move = arm_edit(ed, blob)
    for bad in ({"tolerance": 0.0}, {"tolerance": float("nan")}, {"max_iterations": 0}, {"start": "rest"}):
        with pytest.raises(ValueError, match="tolerance|start"):
            ed.converge(**move, **bad)
    with pytest.raises(ValueError, match="non-finite"):
        ed.converge(translate=(np.inf, 0, 0))


# --------------------------------------------------------------------------- the record and its replay


def replayed(rig, edit):
    """``edit`` through its JSON text, replayed on a fresh editor."""
    return he.HybridEditor(rig).apply_edit(parse_edit(json.loads(json.dumps(edit.to_json()))))


def test_a_converge_replays_to_the_same_pose(blob_rig, blob):
    ed = he.HybridEditor(blob_rig)
    x = blob.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > 1.6), roi=np.flatnonzero(x > 0.3))
    for _ in range(3):  # iterations at the transforms, then the converge from there
        ed.drag(translate=(0, 0.5, 0.1))
    ed.converge(translate=(0, 0.5, 0.1))
    ed.set_selection(np.flatnonzero(x < -1.6), roi=np.flatnonzero(x < -0.3))
    V = ed.converge(translate=(0, 0.25, 0), rotate={"axis": [0, 0, 1], "degrees": 40},
                    tolerance=1e-8).vertices.copy()
    edit = ed.edit
    assert ed.replayable
    assert [(s.iterations, s.converge) for s in edit.steps] == [
        (6, {"tolerance": 1e-6, "max_iterations": 10000}), (0, {"tolerance": 1e-8, "max_iterations": 10000})]
    assert np.array_equal(replayed(blob_rig, edit), V)


def test_a_warm_started_converge_replays_from_the_start_to_the_tolerance(blob_rig, blob):
    ed, move = blob_arm(blob_rig, blob)
    for k in range(1, 6):  # interactive frames on the way
        ed.drag(translate=(0, 0.04 * k, 0))
    V = ed.converge(**move).vertices.copy()
    assert not ed.replayable and ed.edit.iterations is None
    again = replayed(blob_rig, ed.edit)
    assert np.abs(again - V).max() <= 2e-6 * blob.bbox_diagonal()
    ed.drag(**move)  # a drag after a converge: the replay still ends with the converge
    assert ed.edit.converge is not None and not ed.replayable


def test_the_edit_file_reads_and_writes_converge(tmp_path):
    step = {"handles": [{"indices": [0, 1], "translate": [0, 1, 0]}], "iterations": 4,
            "converge": {"tolerance": 1e-7}}
    e = parse_edit({"format": "hybridedit-edit", "version": 3, "steps": [step]})
    assert e.iterations == 4 and e.converge == {"tolerance": 1e-7, "max_iterations": 10000}
    assert e.to_json()["steps"][0]["converge"] == {"tolerance": 1e-7, "max_iterations": 10000}
    plain = parse_edit({"version": 3, "steps": [{"handles": [{"indices": [0], "translate": [0, 1, 0]}]}]})
    assert plain.converge is None and "converge" not in plain.to_json()["steps"][0]  # old files as they were
    for bad in ({}, {"tolerance": 0}, {"tolerance": "1e-6"}, {"tolerance": 1e-6, "max_iterations": 0},
                {"tolerance": 1e-6, "max_iterations": 2.5}, {"tolerance": 1e-6, "every": 1}, 1e-6):
        with pytest.raises(EditFileError, match=r"^pose\.json: \"steps\[0\]\.converge\" must be"):
            parse_edit({"version": 3, "steps": [{**step, "converge": bad}]}, "pose.json")


# --------------------------------------------------------------------------- a scan


def experiment_edit(ed):
    """The issue's edit: the right hand moved 12% of the diagonal up, turned 30 and 20 degrees."""
    from scipy.spatial.transform import Rotation

    P = ed.mesh.vertices
    X, Y = P[:, 0], P[:, 1]
    upper = Y > Y.min() + 0.55 * np.ptp(Y)
    handle = np.flatnonzero((X > X.max() - 0.06 * np.ptp(X)) & upper)
    roi = np.flatnonzero((X > X.max() - 0.35 * np.ptp(X)) & upper)
    ed.set_selection(handle, roi=roi)
    c = P[handle].mean(axis=0)
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xy", [30, 20], degrees=True).as_matrix()
    T[:3, 3] = c - T[:3, :3] @ c + np.array([0, 0.12 * ed.mesh.bbox_diagonal(), 0])
    return {"transforms": {0: T}}


@pytest.mark.slow
def test_on_the_armadillo_it_is_within_the_tolerance_of_the_fixed_point(armadillo_path):
    rig = he.build_rig(he.read_mesh(armadillo_path), cage_size=0.05)
    ed = he.HybridEditor(rig)
    move = experiment_edit(ed)
    r = ed.converge(**move)
    assert r.converged
    ref = he.HybridEditor(rig)
    experiment_edit(ref)
    cage, shape = plain_fixed_point(ref, move)
    diag = rig.mesh.bbox_diagonal()
    assert np.abs(ed.cage_positions - cage).max() <= 1e-6 * diag
    assert np.abs(r.vertices - shape).max() <= 1e-6 * diag
    # (its transform comes back from the edit within rounding: the replay is within the tolerance)
    assert np.abs(he.HybridEditor(rig).apply_edit(ed.edit) - r.vertices).max() <= 2e-6 * diag

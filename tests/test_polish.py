import numpy as np
import pytest

from hybridedit import HybridEditor, Mesh, rrms_edge_error
from hybridedit.polish import ShapeARAP, polish

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def posed():
    shape = bumpy_blob(3)
    ed = HybridEditor(shape, 120)
    x = shape.vertices[:, 0]
    handle = np.flatnonzero(x > x.max() - 0.3)
    roi = np.flatnonzero(x > -0.5)
    ed.set_selection(handle, roi=roi)
    for _ in range(10):
        V = ed.drag(translate=(0, 0.7, 0.2))
    return shape, ed, V.copy()


def test_polish_lowers_energy_and_holds_the_rest(posed):
    shape, ed, V = posed
    sa = ShapeARAP(shape)
    free = ed.free_mask
    assert 0 < free.sum() < shape.n_vertices
    r = polish(sa, V, free, seconds=10.0, max_iterations=300)
    assert r.energy_after < r.energy_before
    assert r.stopped in ("converged", "iterations")
    assert np.array_equal(r.vertices[~free], V[~free])  # handle and fixed part untouched
    assert rrms_edge_error(shape.vertices, r.vertices, shape.edges()) < rrms_edge_error(
        shape.vertices, V, shape.edges())
    # every single iteration lowers (or keeps) the energy
    energies = [sa.energy(V)]
    W = V
    for _ in range(5):
        W = polish(sa, W, free, max_iterations=1).vertices
        energies.append(sa.energy(W))
    assert all(b <= a * (1 + 1e-12) for a, b in zip(energies, energies[1:]))


def test_polish_stops_on_cancel_and_on_time(posed):
    shape, ed, V = posed
    sa = ShapeARAP(shape)
    free = ed.free_mask
    r = polish(sa, V, free, should_stop=lambda: True)
    assert r.stopped == "cancelled" and r.iterations == 1
    assert r.energy_after <= r.energy_before
    r = polish(sa, V, free, seconds=0.0, tolerance=0.0)  # set up already, but no time for an iteration
    assert r.stopped == "time" and r.iterations == 0 and np.array_equal(r.vertices, V)
    fresh = ShapeARAP(shape)
    r = polish(fresh, V, free, seconds=0.0)  # no time for the set-up: it is not even started
    assert r.stopped == "time" and r.iterations == 0 and fresh.solver is None


def test_polish_of_the_rest_pose_is_the_rest_pose(posed):
    shape, ed, _ = posed
    sa = ShapeARAP(shape)
    free = np.zeros(shape.n_vertices, bool)
    free[: shape.n_vertices // 2] = True
    r = polish(sa, shape.vertices, free)
    assert np.abs(r.vertices - shape.vertices).max() < 1e-12
    assert r.energy_after < 1e-20


def test_bad_arguments(posed):
    shape, ed, V = posed
    sa = ShapeARAP(shape)
    with pytest.raises(ValueError):
        polish(sa, V[:10], np.ones(10, bool))


def test_polish_honours_its_budget_set_up_included():
    import time

    from shapes import icosphere

    shape = icosphere(6)  # 40,962 vertices
    v = shape.vertices
    V = v + 0.05 * np.sin(3 * v[:, [1, 2, 0]])  # a pose to polish
    free = v[:, 0] > -0.5
    V[~free] = v[~free]
    probe = ShapeARAP(shape)
    probe.prepare(free)  # what a set-up takes on this machine now (later estimates learn from it)
    setup = probe.setup_seconds
    for budget in (0.3 * setup, 3.0 * setup + 0.5):
        sa = ShapeARAP(shape)  # a fresh set-up each time: it must fit in the budget too
        t0 = time.perf_counter()
        r = polish(sa, V, free, seconds=budget, tolerance=0.0)
        wall = time.perf_counter() - t0
        # generous: machines here vary by +-50% and more under load; the bug was 10 s for a 2 s budget
        assert wall <= 1.5 * budget + 0.5, (budget, wall, r.stopped, setup, sa.setup_seconds)
        assert r.stopped == "time" or r.iterations == 200
        assert np.array_equal(r.vertices[~free], V[~free])
        if budget < setup:
            assert r.iterations == 0 and sa.solver is None  # no time for the set-up: not even started


def test_a_wholly_free_loose_part_is_left_alone():
    from shapes import icosphere

    a, b = icosphere(2), icosphere(2)
    shape = Mesh(np.vstack([a.vertices, b.vertices + [3, 0, 0]]), np.vstack([a.faces, b.faces + a.n_vertices]))
    V = shape.vertices * 1.1  # stretched
    free = np.zeros(shape.n_vertices, bool)
    free[: a.n_vertices] = a.vertices[:, 0] > 0  # half of the first sphere
    free[a.n_vertices:] = True  # all of the second: nothing holds it
    r = polish(ShapeARAP(shape), V, free, seconds=5.0)
    assert r.iterations >= 1 and r.energy_after < r.energy_before
    assert np.array_equal(r.vertices[a.n_vertices:], V[a.n_vertices:])
    assert np.array_equal(r.vertices[: a.n_vertices][~free[: a.n_vertices]], V[: a.n_vertices][~free[: a.n_vertices]])


def test_polish_keeps_every_held_vertex_where_the_editor_put_it():

    shape = bumpy_blob(3)
    ed = HybridEditor(shape, 120)
    x = shape.vertices[:, 0]
    ed.set_selection([np.flatnonzero(x > x.max() - 0.3), np.flatnonzero(x < x.min() + 0.3)],
                     roi=np.flatnonzero(np.abs(x) > 0.5))  # two handle groups, the middle fixed
    for _ in range(5):
        V = ed.drag(transforms={0: np.eye(4) + np.pad([[0, 0, 0, 0.1], [0, 0, 0, 0.4]], ((0, 2), (0, 0))),
                                1: np.eye(4) + np.pad([[0, 0, 0, -0.3]], ((1, 2), (0, 0)))})
    free = ed.free_mask
    roles = ed.vertex_roles
    assert free.any() and not free[roles != 0].any()
    assert set(np.flatnonzero(free)) <= set(ed.moving_vertices)
    r = polish(ShapeARAP(shape), V, free, seconds=5.0)
    assert r.iterations >= 1
    assert np.array_equal(r.vertices[roles != 0], V[roles != 0])

import numpy as np
import pytest

from hybridedit import HybridEditor, Mesh, rrms_edge_error
from hybridedit.deform.polish import ShapeARAP, polish

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
    r = polish(sa, V, free, max_iterations=300)
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


def test_polish_stops_on_cancel_on_its_count_and_on_convergence(posed):
    shape, ed, V = posed
    sa = ShapeARAP(shape)
    free = ed.free_mask
    r = polish(sa, V, free, should_stop=lambda: True)
    assert r.stopped == "cancelled" and r.iterations == 1
    assert r.energy_after <= r.energy_before
    r = polish(sa, V, free, max_iterations=0)
    assert r.iterations == 0 and np.array_equal(r.vertices, V)
    r = polish(sa, V, free, max_iterations=7, tolerance=0.0)
    assert r.stopped == "iterations" and r.iterations == 7
    r = polish(sa, V, free, tolerance=1e-4)
    assert r.stopped == "converged" and 1 <= r.iterations < 200


def test_a_polish_is_the_same_however_often_its_set_up_is_reused(posed):
    """What a replay relies on: k iterations from a pose give the same pose with a fresh set-up,
    with one reused from other polishes of the same region, and run as a job."""
    from hybridedit.deform.polish import PolishJob

    shape, ed, V = posed
    free = ed.free_mask
    used = ShapeARAP(shape)
    polish(used, V * 1.01, free, max_iterations=5)  # another pose first
    a = polish(ShapeARAP(shape), V, free, max_iterations=12, tolerance=0.0).vertices
    b = polish(used, V, free, max_iterations=12, tolerance=0.0).vertices
    c = PolishJob(V.copy(), free, 12, 0.0).run(used).vertices
    assert np.array_equal(a, b) and np.array_equal(a, c)


def test_two_polish_jobs_share_no_state(posed):
    """Each polish thread has its own set-up (the window's worker, a script's polish): one job's
    set-up, region, timing or result is never another's, run one after the other or at once, and
    preparing writes nothing on the class (no estimate or cache shared by every instance)."""
    import threading

    from hybridedit.deform.polish import PolishJob

    shape, ed, V = posed
    free_a = ed.free_mask
    free_b = free_a.copy()
    free_b[np.flatnonzero(free_a)[::2]] = False  # another region: half of the first one held
    jobs = [PolishJob(V.copy(), free_a, 15, 0.0), PolishJob(V * 1.01, free_b, 9, 0.0)]
    before = dict(vars(ShapeARAP))
    alone = [job.run(ShapeARAP(shape)).vertices for job in jobs]
    sets = [ShapeARAP(shape), ShapeARAP(shape)]
    results = [None, None]
    start = threading.Barrier(2)

    def run(k):
        start.wait()
        results[k] = jobs[k].run(sets[k])

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert dict(vars(ShapeARAP)) == before  # nothing was set on the class
    for k in range(2):
        assert np.array_equal(results[k].vertices, alone[k])
        assert sets[k].prepared_for(jobs[k].free) and not sets[k].prepared_for(jobs[1 - k].free)
    assert results[0].iterations == 15 and results[1].iterations == 9
    assert sets[0].solver is not sets[1].solver and not np.array_equal(sets[0].region, sets[1].region)
    for name in ("solver", "region", "setup_seconds", "_free_key"):
        assert name in vars(sets[0]) and name in vars(sets[1])  # each instance's own


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


def test_a_wholly_free_loose_part_is_left_alone():
    from shapes import icosphere

    a, b = icosphere(2), icosphere(2)
    shape = Mesh(np.vstack([a.vertices, b.vertices + [3, 0, 0]]), np.vstack([a.faces, b.faces + a.n_vertices]))
    V = shape.vertices * 1.1  # stretched
    free = np.zeros(shape.n_vertices, bool)
    free[: a.n_vertices] = a.vertices[:, 0] > 0  # half of the first sphere
    free[a.n_vertices:] = True  # all of the second: nothing holds it
    r = polish(ShapeARAP(shape), V, free)
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
    r = polish(ShapeARAP(shape), V, free)
    assert r.iterations >= 1
    assert np.array_equal(r.vertices[roles != 0], V[roles != 0])

import numpy as np
import pytest

from hybridedit import HybridEditor, SelectionError
from hybridedit.propagate import propagate
from hybridedit.transforms import apply_transform, rigid_transform


@pytest.fixture(scope="module")
def editor(blob):
    # the paper's propagation, x' = M y'
    return HybridEditor(blob, cage_size=300, propagation="linear")


@pytest.fixture(scope="module")
def editor_res(blob):
    # the default: residual detail added back, rotated
    return HybridEditor(blob, cage_size=300)


@pytest.fixture
def ed(editor):
    editor.reset()
    return editor


def ends(mesh, frac=0.2):
    x = mesh.vertices[:, 0]
    span = x.max() - x.min()
    return np.flatnonzero(x < x.min() + frac * span), np.flatnonzero(x > x.max() - frac * span)


def test_cage_and_binding_shapes(ed, blob):
    assert abs(ed.cage.n_vertices - 300) <= 6
    assert ed.M.shape == (blob.n_vertices, ed.cage.n_vertices)
    assert np.allclose(np.asarray(ed.M.sum(axis=1)).ravel(), 1.0, atol=1e-12)
    assert 1 <= ed.nnz_per_row < 60


def test_no_edit_output_is_M_times_cage(ed):
    assert np.array_equal(ed.deformed_vertices, propagate(ed.M, ed.cage.vertices))
    assert np.allclose(ed.deformed_vertices, ed.M @ ed.cage.vertices, atol=1e-13)
    a, b = ends(ed.mesh)
    ed.set_selection(b, fixed=a)
    V = ed.drag(translate=(0, 0, 0))
    assert np.allclose(V, ed.M @ ed.cage.vertices, atol=1e-12)


def test_rigid_motion_of_the_whole_cage_moves_the_shape_rigidly(ed):
    T = rigid_transform(translate=(1.0, -2.0, 0.5), axis=(1, 1, 0), degrees=35, center=(0.2, 0.1, 0))
    ed.set_selection(np.arange(ed.cage.n_vertices), space="cage")
    V = ed.drag(transform=T)
    expect = apply_transform(T, ed.M @ ed.cage.vertices)
    assert np.abs(V - expect).max() < 1e-10


def test_rigid_motion_of_all_handles_converges_to_rigid(ed):
    a, b = ends(ed.mesh)
    T = rigid_transform(translate=(0.5, 0.3, -0.2), axis=(0, 0, 1), degrees=40, center=(0, 0, 0))
    ed.set_selection(np.union1d(a, b), fixed=None)
    for _ in range(200):
        V = ed.drag(transform=T, iterations=5)
    expect = apply_transform(T, ed.M @ ed.cage.vertices)
    assert np.abs(V - expect).max() < 1e-8 * ed.mesh.bbox_diagonal()


def test_drag_moves_the_handle_and_not_the_fixed_part(ed):
    a, b = ends(ed.mesh)
    ed.set_selection(b, fixed=a)
    d = np.array([0.0, 0.8, 0.0])
    for _ in range(30):
        V = ed.drag(translate=d)
    rest = ed.M @ ed.cage.vertices
    # shape vertices bound only to fixed cage vertices do not move at all
    fixed_mask = np.zeros(ed.cage.n_vertices, bool)
    fixed_mask[ed.fixed] = True
    rows_fixed = np.array([fixed_mask[ed.M.indices[ed.M.indptr[i]:ed.M.indptr[i + 1]]].all()
                           for i in range(ed.M.shape[0])])
    assert rows_fixed.sum() > 10
    assert np.abs(V[rows_fixed] - rest[rows_fixed]).max() < 1e-12
    # the handle cage vertices moved exactly by d; the handle's shape vertices nearly so
    assert np.allclose(ed.arap.positions[ed.handle], ed.cage.vertices[ed.handle] + d)
    moved = (V[b] - rest[b]).mean(axis=0)
    assert np.linalg.norm(moved - d) < 0.25 * np.linalg.norm(d)
    # the middle bends smoothly: it moves somewhere in between
    mid = np.flatnonzero(np.abs(ed.mesh.vertices[:, 0]) < 0.1)
    dy = (V[mid] - rest[mid])[:, 1].mean()
    assert 0.05 * d[1] < dy < 0.95 * d[1]


def test_roi_means_everything_outside_is_fixed(ed):
    a, b = ends(ed.mesh, 0.1)
    roi = np.flatnonzero(ed.mesh.vertices[:, 0] > 0)
    ed.set_selection(b, roi=roi)
    x_cage = ed.cage.vertices[:, 0]
    assert set(ed.fixed) <= set(np.flatnonzero(x_cage < 0.3))
    assert np.intersect1d(ed.fixed, ed.handle).size == 0
    assert len(ed.fixed) + len(ed.handle) < ed.cage.n_vertices


def test_reset_and_cage_positions(ed):
    a, b = ends(ed.mesh)
    ed.set_selection(b, fixed=a)
    ed.drag(translate=(0, 0.5, 0))
    pose = ed.cage_positions
    shape = ed.deformed_vertices.copy()
    ed.reset()
    assert np.allclose(ed.deformed_vertices, ed.M @ ed.cage.vertices)
    ed.set_cage_positions(pose)
    assert np.allclose(ed.deformed_vertices, shape)
    m = ed.deformed
    assert m.faces is ed.mesh.faces or np.array_equal(m.faces, ed.mesh.faces)


def test_selection_errors(ed):
    a, b = ends(ed.mesh)
    with pytest.raises(SelectionError, match="empty"):
        ed.set_selection([], fixed=a)
    with pytest.raises(SelectionError, match="out of range"):
        ed.set_selection([ed.mesh.n_vertices + 5], fixed=a)
    with pytest.raises(SelectionError, match="share"):
        ed.set_selection(b, fixed=np.union1d(a, b))
    with pytest.raises(SelectionError, match="not both"):
        ed.set_selection(b, fixed=a, roi=a)
    with pytest.raises(SelectionError, match="space"):
        ed.set_selection(b, space="world")


def test_tiny_handle_still_maps_to_the_cage(ed):
    a, b = ends(ed.mesh)
    one = [int(b[0])]
    ed.set_selection(one, fixed=a)
    assert ed.handle.size >= 1
    row = ed.M[one[0]]
    assert ed.handle[0] in row.indices


def test_drag_before_selection_is_refused(blob):
    e = HybridEditor(blob, cage_size=100)
    with pytest.raises(SelectionError, match="selection"):
        e.drag(translate=(1, 0, 0))


def test_residual_mode_reproduces_the_input_exactly(editor_res, blob):
    ed = editor_res
    ed.reset()
    tol = 1e-9 * blob.bbox_diagonal()
    assert np.abs(ed.deformed_vertices - blob.vertices).max() < tol
    # truncation alone is far from exact: that is what the residual fixes
    assert np.abs(ed.M @ ed.cage.vertices - blob.vertices).max() > 100 * tol
    a, b = ends(blob)
    ed.set_selection(b, fixed=a)
    V = ed.drag(translate=(0, 0, 0), iterations=3)
    assert np.abs(V - blob.vertices).max() < tol


def test_residual_mode_moves_rigidly_with_a_rigid_cage(editor_res, blob):
    ed = editor_res
    ed.reset()
    T = rigid_transform(translate=(0.3, 1.0, -0.5), axis=(1, -1, 2), degrees=75, center=(0.5, 0, 0))
    ed.set_selection(np.arange(ed.cage.n_vertices), space="cage")
    V = ed.drag(transform=T)
    assert np.abs(V - apply_transform(T, blob.vertices)).max() < 1e-9 * blob.bbox_diagonal()
    # undo-style restore recomputes rotations, so the shape is right again
    pose = ed.cage_positions
    ed.reset()
    assert np.abs(ed.deformed_vertices - blob.vertices).max() < 1e-9 * blob.bbox_diagonal()
    V2 = ed.set_cage_positions(pose)
    assert np.abs(V2 - apply_transform(T, blob.vertices)).max() < 1e-9 * blob.bbox_diagonal()


def test_residual_mode_reduces_edge_error_of_a_bend(editor, editor_res, blob):
    from hybridedit import rrms_edge_error

    errs = []
    for ed in (editor, editor_res):
        ed.reset()
        a, b = ends(blob)
        ed.set_selection(b, fixed=a)
        for _ in range(20):
            V = ed.drag(translate=(0, 0.6, 0))
        errs.append(rrms_edge_error(blob.vertices, V, blob.edges()))
    assert errs[1] < 0.9 * errs[0]


def test_bad_propagation_name(blob):
    with pytest.raises(ValueError, match="propagation"):
        HybridEditor(blob, 50, propagation="magic")


@pytest.mark.parametrize("fixture", ["editor", "editor_res"])
def test_partial_updates_equal_a_full_recomputation(request, fixture, blob):
    """A drag recomputes only the rotations and shape rows that can change; the
    result must equal recomputing everything from the cage pose."""
    from hybridedit.residual import propagate_with_residual

    ed = request.getfixturevalue(fixture)
    ed.reset()
    a, b = ends(blob, 0.15)
    roi = np.flatnonzero(blob.vertices[:, 0] > 0.5)
    ed.set_selection(b, roi=roi)
    assert 0 < len(ed._rows) < blob.n_vertices  # the optimisation is in play
    T = rigid_transform(translate=(0.1, 0.5, 0.2), axis=(0, 0, 1), degrees=30, center=blob.vertices[b].mean(0))
    for _ in range(5):
        V = ed.drag(transform=T)
    y = ed.arap.positions
    rot = ed.arap.rotations.copy()
    ed.arap.local_step()  # all rotations from the current pose
    if ed.propagation == "linear":
        full = ed.M @ y
    else:
        # rotations of vertices outside the active set must already be current
        others = np.setdiff1d(np.arange(ed.cage.n_vertices), ed.arap.active)
        assert np.abs(rot[others] - ed.arap.rotations[others]).max() < 1e-12
        d, idx, w = ed._residual
        full = propagate_with_residual(ed.M, y, rot, d, idx, w)
    assert np.abs(V - full).max() < 1e-12


# ------------------------------------------------------------------ refusals leave the state intact


def editor_state(e):
    return (
        e.cage_positions,
        e.arap.rotations.copy(),
        e.deformed_vertices.copy(),
        e.handle.copy(),
        e.fixed.copy(),
        e._constrained.copy(),
        e._anchor.copy(),
        e.transform.copy(),
        len(e.frame_seconds),
    )


def assert_same_state(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        if isinstance(x, np.ndarray):
            assert x.shape == y.shape and np.array_equal(x, y)
        else:
            assert x == y


def test_refused_calls_leave_the_state_intact(ed, blob):
    fixed, handle = ends(blob)
    ed.set_selection(handle, fixed=fixed)
    ed.drag(translate=(0, 0.4, 0))
    before = editor_state(ed)
    n = blob.n_vertices
    refused_selections = [
        dict(handle=[]),  # empty handle
        dict(handle=handle, fixed=handle[:3]),  # overlap
        dict(handle=[n + 5]),  # out of range
        dict(handle=[-1]),
        dict(handle=[0.5]),  # not an integer
        dict(handle=handle, fixed=fixed, roi=fixed),  # both
        dict(handle=handle, space="world"),
    ]
    for kw in refused_selections:
        with pytest.raises(SelectionError):
            ed.set_selection(**kw)
        assert_same_state(before, editor_state(ed))
    diag = blob.bbox_diagonal()
    bad_drags = [
        dict(translate=(np.nan, 0, 0)),
        dict(translate=(0, np.inf, 0)),
        dict(translate=(2e6 * diag, 0, 0)),  # farther than a million diagonals
        dict(transform=np.diag([1e7 * diag, 1, 1, 1])),  # a huge scale
        dict(transform=np.full((4, 4), np.nan)),
        dict(translate=(0, 1, 0), transform=np.eye(4)),
        dict(translate=(0, 1, 0), iterations=-1),
    ]
    for kw in bad_drags:
        with pytest.raises(ValueError):
            ed.drag(**kw)
        assert_same_state(before, editor_state(ed))
    with pytest.raises(ValueError):
        ed.set_cage_positions(np.full_like(ed.cage_positions, np.nan))
    assert_same_state(before, editor_state(ed))
    # a large but sane drag is fine, and a refused one after it still leaves it as it was
    ed.drag(translate=(0, 10 * diag, 0))
    assert np.all(np.isfinite(ed.deformed_vertices))


def test_free_cage_component_is_refused_and_state_kept():
    import trimesh

    from hybridedit.mesh import Mesh

    a = trimesh.creation.icosphere(subdivisions=2)
    v = np.vstack([a.vertices, a.vertices + [3, 0, 0]])
    f = np.vstack([a.faces, a.faces + len(a.vertices)])
    e = HybridEditor(Mesh(v, f, name="two"), cage_size=60)
    assert e.notes == ["2 disconnected parts"]
    before = editor_state(e)
    with pytest.raises(SelectionError, match="1 of 2 connected parts of the cage have no fixed or handle vertex"):
        e.set_selection([0], roi=np.arange(len(v)))
    assert_same_state(before, editor_state(e))
    e.set_selection([0], roi=np.arange(len(a.vertices)))  # the other sphere stays fixed
    V = e.drag(translate=(0, 0.2, 0))
    k = len(a.vertices)
    # the fixed sphere's cage does not move; its shape moves only through the (global)
    # coordinates with respect to the other sphere's cage, much less than the handle
    assert np.abs(V[k:] - v[k:]).max() < 0.25 * np.abs(V[:k] - v[:k]).max()


def test_notes_and_input_order_for_a_messy_shape(blob):
    """Duplicates and stray vertices: the editor binds every input vertex and keeps the order."""
    from hybridedit.mesh import Mesh

    n = blob.n_vertices
    v = np.vstack([blob.vertices, blob.vertices[:10], [[9.0, 9.0, 9.0]]])
    f = blob.faces.copy()
    f[:5, 0] = np.where(f[:5, 0] < 10, f[:5, 0] + n, f[:5, 0])
    f = np.vstack([f[:, [0, 2, 1]], [[0, 0, 1]]])  # inside out, and one repeated-index face
    e = HybridEditor(Mesh(v, f), cage_size=200)
    assert e.notes == [
        "ignored 10 unreferenced vertices for the cage (they still follow the deformation)",  # 9 + the stray one
        "merged 1 duplicate vertex",
        "dropped 1 degenerate face (zero area or a repeated vertex)",
        f"re-oriented {len(f) - 1:,} faces",
    ]
    assert e.M.shape == (len(v), e.cage.n_vertices)
    assert np.allclose(e.deformed_vertices, v, rtol=0, atol=1e-12)  # residual: the rest pose is the input
    assert np.array_equal(e.deformed.faces, f)
    assert HybridEditor(blob, cage_size=200).notes == []

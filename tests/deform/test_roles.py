import numpy as np

from hybridedit.deform import roles


def test_the_code_is_fixed_free_then_one_per_handle_group():
    assert (roles.FIXED, roles.FREE, roles.FIRST_HANDLE) == (-1, 0, 1)
    g = np.arange(5)
    assert np.array_equal(roles.group(roles.handle(g)), g)
    assert roles.is_handle(roles.handle(3)) and not roles.is_handle(roles.FREE) and not roles.is_handle(roles.FIXED)
    assert roles.is_handle(np.array([-1, 0, 1, 7])).tolist() == [False, False, True, True]


def test_the_editor_reports_roles_in_this_code(blob):
    import hybridedit as he

    ed = he.HybridEditor(blob, cage_size=0.2)
    x = blob.vertices[:, 0]
    ed.set_selection(handle=[np.flatnonzero(x > 0.8 * x.max()), np.flatnonzero(x < 0.8 * x.min())],
                     roi=np.flatnonzero(np.abs(x) > 0.2 * x.max()))
    r = ed.vertex_roles
    assert set(np.unique(r)) == {roles.FIXED, roles.FREE, roles.handle(0), roles.handle(1)}
    assert np.all(r[x > 0.8 * x.max()] == roles.handle(0))

"""What a selection makes of each vertex, asked of the editor (hybridedit.deform.role_queries)."""

import numpy as np
import pytest

from hybridedit import HybridEditor


@pytest.fixture(scope="module")
def ed(blob):
    return HybridEditor(blob, cage_size=300, propagation="linear")


def test_dominant_cage_vertex_is_each_rows_largest_weight_and_read_only(ed):
    dom = ed.dominant_cage_vertex
    M = abs(ed.M).tocsr()
    assert dom.shape == (ed.mesh.n_vertices,)
    assert np.array_equal(dom, np.asarray(M.argmax(axis=1)).ravel())
    with pytest.raises(ValueError):
        dom[0] = 1
    # a cage-space selection gives each shape vertex the role of its dominant cage vertex
    ed.reset()
    ed.set_selection(handle=[0], roi=np.arange(ed.cage.n_vertices), space="cage")
    assert np.array_equal(ed.vertex_roles, ed.cage_roles[dom])

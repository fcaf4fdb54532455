import numpy as np
import pytest

from hybridedit.core.spatial_order import _radix_argsort, _spread_one, morton_order


def test_the_key_interleaves_the_bits_of_the_three_coordinates():
    q = np.array([0, 1, 2, 3, 0x1FFFFF, 0x155555], dtype=np.uint64)
    want = []
    for v in q.tolist():
        want.append(sum(((v >> k) & 1) << (3 * k) for k in range(21)))
    assert [int(_spread_one(v)) for v in q] == want


def test_the_radix_sort_is_numpys_stable_argsort():
    rng = np.random.default_rng(2)
    for bits in (1, 11, 12, 30, 63):
        key = rng.integers(0, 2**bits, 5000, dtype=np.uint64)
        key[100:400] = key[7]  # ties keep their order
        assert np.array_equal(_radix_argsort(key, bits), np.argsort(key, kind="stable"))
    assert _radix_argsort(np.zeros(0, dtype=np.uint64), 30).shape == (0,)


def test_a_grid_in_morton_order_visits_each_octant_whole():
    g = np.stack(np.meshgrid(*[np.arange(4.0)] * 3, indexing="ij"), -1).reshape(-1, 3)
    rng = np.random.default_rng(0)
    shuffled = g[rng.permutation(len(g))]
    o = morton_order(shuffled)
    assert np.array_equal(np.sort(o), np.arange(len(g)))
    p = shuffled[o]
    octant = (p >= 2).astype(int) @ np.array([1, 2, 4])
    # the first 8 points fill the lowest octant, each next 8 one other octant
    assert all(len(set(octant[k:k + 8])) == 1 for k in range(0, 64, 8))
    assert octant[:8].tolist() == [0] * 8 and sorted(set(octant)) == list(range(8))
    assert p[0].tolist() == [0.0, 0.0, 0.0] and p[-1].tolist() == [3.0, 3.0, 3.0]


def test_ties_flat_sets_and_empty_input():
    same = np.ones((5, 3))
    assert morton_order(same).tolist() == [0, 1, 2, 3, 4]  # one key: the order given
    flat = np.c_[np.arange(6.0)[::-1], np.zeros(6), np.zeros(6)]  # a box of zero height and depth
    assert morton_order(flat).tolist() == [5, 4, 3, 2, 1, 0]
    assert morton_order(np.zeros((0, 3))).shape == (0,)


def test_near_points_end_up_near_in_memory():
    rng = np.random.default_rng(1)
    p = rng.random((20000, 3))
    o = morton_order(p)
    step = np.linalg.norm(np.diff(p[o], axis=0), axis=1)
    assert np.median(step) < 0.1 * np.median(np.linalg.norm(np.diff(p, axis=0), axis=1))


def test_cells_shaped_like_the_box_and_fewer_bits():
    # a long flat box, 10 x 1 x 0, two cells a side: cubic cells (10 wide) put every point with
    # x < 10 in the first cell; cells shaped like the box split y too, and x = 10 comes before y = 1
    p = np.array([[0.0, 0.9, 0.0], [10.0, 0.0, 0.0], [6.0, 0.1, 0.0], [0.0, 1.0, 0.0]])
    assert morton_order(p, bits=1).tolist() == [0, 2, 3, 1]
    assert morton_order(p, bits=1, per_axis=True).tolist() == [0, 2, 1, 3]
    with pytest.raises(ValueError, match="bits"):
        morton_order(p, bits=22)

"""Tests of hybridedit/selection.py (named apart from tests/viewer/test_selection.py)."""

import numpy as np
import pytest

from hybridedit.selection import SelectionError, as_groups, as_indices


def test_masks_and_indices_name_the_same_vertices():
    mask = np.zeros(6, dtype=bool)
    mask[[1, 4]] = True
    want = [1, 4]
    assert as_indices(mask, 6).tolist() == want
    assert as_indices(mask.tolist(), 6).tolist() == want
    assert as_indices([4, 1, 4], 6).tolist() == want
    assert as_indices((1, 4), 6).tolist() == want
    assert as_indices(np.array([4, 1], dtype=np.int32), 6).tolist() == want
    assert as_indices(np.array([4, 1], dtype=np.uint16), 6).tolist() == want
    assert as_indices(range(1, 5, 3), 6).tolist() == want
    # a boolean mask of length 2 is a mask, not the indices 0 and 1
    assert as_indices(np.array([False, True]), 2).tolist() == [1]


@pytest.mark.parametrize(
    "sel, words",
    [
        (None, "got NoneType"),
        ("0,1", "got str"),
        (np.array([True, False]), "boolean mask of length 2"),
        ([True, False, True], "boolean list of length 3"),
        ([[0, 1], [2]], "nested list"),
        ([0, 1.5], "list holding float"),
        (np.array([0.0, 1.0]), "array of float64"),
        (np.zeros((2, 2), dtype=int), "2-dimensional array"),
        ({0, 1}, "got set"),
        ([0, 2 ** 70], "out of range"),
        ([-1], "out of range"),
        ([6], "out of range [0, 5], e.g. 6"),
    ],
)
def test_anything_else_is_one_line_selection_error(sel, words):
    with pytest.raises(SelectionError) as e:
        as_indices(sel, 6, role="fixed")
    msg = str(e.value)
    assert words in msg and "\n" not in msg and msg.startswith("fixed")


def test_groups():
    assert [g.tolist() for g in as_groups([0, 2], 5)] == [[0, 2]]  # one list of ints: one group
    assert [g.tolist() for g in as_groups([[0], np.array([2, 3])], 5)] == [[0], [2, 3]]
    mask = np.array([True, False, False, False, True])
    assert [g.tolist() for g in as_groups([mask, [2]], 5)] == [[0, 4], [2]]
    with pytest.raises(SelectionError, match="share 1 vertices"):
        as_groups([[0, 1], [1, 2]], 5)
    with pytest.raises(SelectionError, match="handle group 1 is empty"):
        as_groups([[0], []], 5)
    with pytest.raises(SelectionError, match="the handle is empty"):
        as_groups([], 5)

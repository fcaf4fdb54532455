"""Reading a vertex selection as a user gives it: a boolean mask or indices.

One rule for every selection the engine takes (handle groups, fixed, region of
interest): a boolean array or list of length n is a mask; a list, tuple, range
or integer numpy array is a list of vertex indices; anything else (None, a
string, floats, a mask of the wrong length, nested lists) is refused with a
one-line :class:`SelectionError` saying what was expected.
"""

from __future__ import annotations

import numbers

import numpy as np


class SelectionError(ValueError):
    """A selection (handle / fixed / ROI) that cannot be used; the message says why."""


def _expected(role: str, n: int, space: str) -> str:
    return f"{role} must be a boolean mask of length {n:,} or a list of {space} vertex indices"


def _is_int(x) -> bool:
    return isinstance(x, (numbers.Integral, np.integer)) and not isinstance(x, (bool, np.bool_))


def _is_bool(x) -> bool:
    return isinstance(x, (bool, np.bool_))


def as_indices(selection, n: int, *, role: str = "selection", space: str = "shape") -> np.ndarray:
    """The vertex indices a selection names.

    Parameters
    ----------
    selection : (n,) bool array or list (a mask), or (k,) int array, list, tuple or range
        (indices, repeats allowed).
    n : int
        Number of vertices the indices refer to.
    role, space : str
        Words for the error message ("handle", "shape").

    Returns
    -------
    (k,) int64 array of sorted unique indices in [0, n).

    Raises
    ------
    SelectionError

    Examples
    --------
    >>> as_indices([3, 1, 3], 5)
    array([1, 3])
    >>> as_indices(np.array([True, False, True]), 3)
    array([0, 2])
    """
    what = _expected(role, n, space)
    if selection is None or isinstance(selection, (str, bytes, dict, set, frozenset)):
        raise SelectionError(f"{what}, got {type(selection).__name__}")
    if isinstance(selection, range):
        idx = np.arange(selection.start, selection.stop, selection.step, dtype=np.int64)
    elif isinstance(selection, np.ndarray):
        if selection.ndim != 1:
            raise SelectionError(f"{what}, got a {selection.ndim}-dimensional array")
        if selection.dtype == np.bool_:
            if selection.shape[0] != n:
                raise SelectionError(f"{what}, got a boolean mask of length {selection.shape[0]:,}")
            return np.flatnonzero(selection).astype(np.int64)
        if not np.issubdtype(selection.dtype, np.integer):
            raise SelectionError(f"{what}, got an array of {selection.dtype}")
        idx = selection.astype(np.int64, copy=False)
        if selection.dtype == np.uint64 and selection.size and int(selection.max()) >= 2 ** 63:
            raise SelectionError(f"{role} has {space} vertex indices out of range [0, {n - 1:,}]")
    elif isinstance(selection, (list, tuple)):
        items = list(selection)
        if items and all(_is_bool(x) for x in items):
            if len(items) != n:
                raise SelectionError(f"{what}, got a boolean list of length {len(items):,}")
            return np.flatnonzero(np.asarray(items, dtype=bool)).astype(np.int64)
        bad = next((x for x in items if not _is_int(x)), None)
        if bad is not None:
            kind = "a nested list" if isinstance(bad, (list, tuple, np.ndarray, range)) else type(bad).__name__
            raise SelectionError(f"{what}, got a list holding {kind}")
        big = [x for x in items if not (-(2 ** 63) <= int(x) < 2 ** 63)]
        if big:
            raise SelectionError(f"{role} has {len(big):,} {space} vertex indices out of range "
                                 f"[0, {n - 1:,}], e.g. {int(big[0])}")
        idx = np.asarray([int(x) for x in items], dtype=np.int64)
    else:
        raise SelectionError(f"{what}, got {type(selection).__name__}")
    bad = (idx < 0) | (idx >= n)
    if np.any(bad):
        raise SelectionError(
            f"{role} has {int(bad.sum()):,} {space} vertex indices out of range [0, {n - 1:,}], "
            f"e.g. {int(idx[bad][0])}"
        )
    return np.unique(idx)


def _is_collection(x) -> bool:
    return isinstance(x, (list, tuple, range, np.ndarray))


def as_groups(handle, n: int, *, space: str = "shape") -> list[np.ndarray]:
    """Handle groups: one selection, or a list of selections (one per group).

    Parameters
    ----------
    handle : a selection (see :func:`as_indices`), or a list/tuple of selections.
    n : int
        Number of vertices the indices refer to.

    Returns
    -------
    list of (k_g,) int64 arrays, one per group, each non-empty.

    Raises
    ------
    SelectionError
        An empty group, a malformed selection, or groups sharing vertices.

    Examples
    --------
    >>> [g.tolist() for g in as_groups([[0, 1], range(3, 5)], 6)]
    [[0, 1], [3, 4]]
    """
    if isinstance(handle, (list, tuple)) and handle and all(_is_collection(g) for g in handle):
        raw = list(handle)
        groups = [as_indices(g, n, role="handle" if len(raw) == 1 else f"handle group {k}", space=space)
                  for k, g in enumerate(raw)]
    else:
        groups = [as_indices(handle, n, role="handle", space=space)]
    for k, g in enumerate(groups):
        if g.size == 0:
            name = "the handle" if len(groups) == 1 else f"handle group {k}"
            raise SelectionError(f"{name} is empty: select at least one vertex to drag")
    seen = np.full(n, -1, dtype=np.int64)
    for k, g in enumerate(groups):
        prev = seen[g]
        clash = prev[prev >= 0]
        if clash.size:
            raise SelectionError(f"handle groups {int(clash[0])} and {k} share "
                                 f"{clash.size:,} vertices; a vertex can be in one group only")
        seen[g] = k
    return groups

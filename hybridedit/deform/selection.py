"""The selection model: a user's selection read, and who is what in an edit, on the shape and on the cage.

A selection (handle groups, fixed, region of interest) is read by one rule
(:func:`as_indices`, :func:`as_groups`): a boolean array or list of length n is a
mask; a list, tuple, range or integer numpy array is a list of vertex indices;
anything else is refused with a one-line :class:`SelectionError`.

A user's selection (handle groups, fixed or region of interest, in shape or cage
vertices, optionally mirrored) becomes, in three steps:

1. :func:`user_roles`: one role per shape vertex, as the user gave them;
2. :func:`choose_roles`: the internal roles (each handle group's mirror image is a
   group of its own) and the roles of the cage vertices, i.e. what the cage ARAP
   holds and moves (:class:`Roles`);
3. :func:`build_selection`: once ARAP is factored for those roles (it decides
   which cage vertices are free), the shape rows a drag can move, the seam, the
   rows averaged with their mirror image (:class:`Selection`).

Roles are small integers, the same for shape and cage vertices (those of
:mod:`hybridedit.deform.constraints`): ``-1`` fixed, ``0`` free, ``k + 1`` group ``k``.
Everything here is computed once per selection and never modified; nothing here
depends on the pose an edit starts from.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit, prange

from typing import TYPE_CHECKING

from ..core.index_sets import union_in_range, unique_in_range
from ..core.parallel import pick
from ..core.twins import twins
from .roles import FIXED, FREE

if TYPE_CHECKING:  # (annotations only: symmetry.py reads SelectionError from here)
    from .symmetry import Mirror


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
    return unique_in_range(idx, n)


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


__all__ = ["SPACES", "CageMap", "UserRoles", "Roles", "Selection", "user_roles", "mirrored_roles", "choose_roles",
           "rows_that_can_move", "build_selection"]

SPACES = ("shape", "cage")


@dataclass(frozen=True)
class CageMap:
    """How shape vertices and cage vertices stand for each other in a selection.

    Parameters
    ----------
    nearest : (c,) int64
        The shape vertex nearest each cage vertex (a cage vertex takes its role).
    dominant : (n,) int64
        The cage vertex each shape vertex depends on most (the row argmax of the
        binding's magnitudes, :func:`hybridedit.binding.bind.dominant_cage_vertex`).
    """

    nearest: np.ndarray
    dominant: np.ndarray

    @property
    def n_shape(self) -> int:
        return int(self.dominant.shape[0])

    @property
    def n_cage(self) -> int:
        return int(self.nearest.shape[0])

    def count(self, space: str) -> int:
        """Vertex count of ``space`` ("shape" or "cage")."""
        if space not in SPACES:
            raise SelectionError(f"space must be one of {SPACES}, got {space!r}")
        return self.n_shape if space == "shape" else self.n_cage

    def to_cage(self, indices, *, space: str = "shape", role: str = "selection") -> np.ndarray:
        """(j,) int64 sorted unique cage vertices of a vertex selection (see
        :meth:`hybridedit.HybridEditor.to_cage`): the cage vertices whose nearest
        shape vertex is selected, else the dominant cage vertex of each selected one."""
        idx = as_indices(indices, self.count(space), role=role, space=space)
        if space == "cage" or idx.size == 0:
            return idx
        selected = np.zeros(self.n_shape, dtype=bool)
        selected[idx] = True
        cage_idx = np.flatnonzero(selected[self.nearest])
        if cage_idx.size == 0:
            cage_idx = unique_in_range(self.dominant[idx], self.n_cage)
        return cage_idx.astype(np.int64)

    def shape_roles(self, cage_roles) -> np.ndarray:
        """(n,) int8 shape roles that select exactly the (c,) integer ``cage_roles``
        (see :meth:`hybridedit.HybridEditor.shape_roles`)."""
        r = np.asarray(cage_roles)
        if r.shape != (self.n_cage,) or not np.issubdtype(r.dtype, np.integer):
            raise SelectionError(f"cage roles must be {self.n_cage:,} integers")
        roles = r[self.dominant].astype(np.int8)
        roles[self.nearest] = r
        return roles


@dataclass(frozen=True)
class UserRoles:
    """The selection as the user gave it.

    given : (m,) int32 roles in ``space`` (m = n or c).
    roles : (n,) int32 roles of the shape vertices (``given`` itself in shape space;
        in cage space each shape vertex takes its dominant cage vertex's role).
    n_groups : the user's handle groups. space : "shape" or "cage".
    roi_mode : the fixed set is the outside of a region of interest.
    """

    given: np.ndarray
    roles: np.ndarray
    n_groups: int
    space: str
    roi_mode: bool


def user_roles(handle, fixed=None, roi=None, *, space: str = "shape", maps: CageMap) -> UserRoles:
    """Check and encode a user's selection (the arguments of
    :meth:`hybridedit.HybridEditor.set_selection`).

    Raises
    ------
    SelectionError
        Both ``fixed`` and ``roi``, an unknown space, a malformed or empty
        selection, overlapping groups, handle and fixed sharing vertices.
    """
    if fixed is not None and roi is not None:
        raise SelectionError("give either fixed or roi, not both")
    count = maps.count(space)
    groups = as_groups(handle, count, space=space)
    given = np.zeros(count, dtype=np.int32)
    if roi is not None:
        inside = np.zeros(count, dtype=bool)
        inside[as_indices(roi, count, role="roi", space=space)] = True
        given[~inside] = FIXED
    elif fixed is not None:
        f = as_indices(fixed, count, role="fixed", space=space)
        given[f] = FIXED
    for k, g in enumerate(groups):
        if fixed is not None and np.any(given[g] == FIXED):
            both = int(np.count_nonzero(given[g] == FIXED))
            raise SelectionError(f"handle and fixed share {both:,} {space} vertices; a vertex cannot be both")
        given[g] = k + 1
    roles = given if space == "shape" else given[maps.dominant]
    return UserRoles(given=given, roles=roles, n_groups=len(groups), space=space, roi_mode=roi is not None)


def mirrored_roles(user: np.ndarray, *, n_groups: int, mirror: Mirror | None, roi_mode: bool = False):
    """Internal roles after mirroring.

    A vertex takes the role of its mirror image where it has none of its own
    (the pull-back through ``mirror.map``, so that every vertex on the other side
    is covered even where the mesh is only nearly symmetric). With a region of
    interest the region is mirrored (a vertex stays fixed only when its mirror
    image is fixed too); with fixed vertices the fixed set is mirrored.

    Parameters
    ----------
    user : (n,) int roles of the shape vertices as the user gave them.
    n_groups : the user's handle groups. mirror : the shape's mirror, or None.

    Returns
    -------
    roles : (n,) int32 internal roles (group k + 1 is internal group k).
    source : list of int, the user group each internal group follows.
    kind : list of str, "same", "mirror" (a group's mirror image) or "self" (a group
        that straddles the plane: its own mirror image).
    """
    roles = user.astype(np.int32).copy()
    source = list(range(n_groups))
    kind = ["same"] * n_groups
    if mirror is None:
        return roles, source, kind
    image = user[mirror.map]  # the role of each vertex's mirror image
    if roi_mode:
        roles[(roles == FIXED) & (image != FIXED)] = FREE
    else:
        roles[(roles == FREE) & (image == FIXED)] = FIXED
    for k in range(n_groups):
        own = user == k + 1
        pulled = (image == k + 1) & ~own & (user <= FREE)
        if np.count_nonzero(own & (image == k + 1)) > 0.5 * np.count_nonzero(own):
            kind[k] = "self"  # straddles the plane: its own mirror image
            roles[pulled] = k + 1
        elif np.any(pulled):
            source.append(k)
            kind.append("mirror")
            roles[pulled] = len(source)
    return roles, source, kind


@dataclass(frozen=True)
class Roles:
    """Who is what, on the shape and on the cage (:func:`choose_roles`).

    Internal groups are the user's handle groups, then their mirror images
    (``source[k]`` is the user group internal group k follows; ``kind[k]`` is
    "same", "mirror" or "self" for a group that is its own mirror image).
    """

    user_roles: np.ndarray  # (n,) int8 roles before mirroring
    roles: np.ndarray  # (n,) int32 internal roles: -1 fixed, 0 free, k + 1 internal group k
    cage_roles: np.ndarray  # (c,) int32 internal roles of cage vertices
    core: np.ndarray  # (c,) the user's cage roles before the handles' own vertices were added
    source: tuple[int, ...]
    kind: tuple[str, ...]
    n_groups: int  # the user's groups
    mirror: Mirror | None
    constrained: np.ndarray  # (k,) int64 sorted cage vertices given to ARAP (fixed and handle)
    moving: np.ndarray  # (h,) int64 sorted cage vertices that follow a handle transform
    roi_mode: bool  # the fixed set was given as the outside of a region of interest (mirrors differ)

    def group_transforms(self, transforms) -> list[np.ndarray]:
        """The (4, 4) transform of each internal group when the user's groups have
        ``transforms`` (a mirror image follows the mirrored transform, a group that
        is its own mirror image the symmetric part of its transform)."""
        out = []
        for k, g in enumerate(self.source):
            T = transforms[g]
            if self.kind[k] == "mirror":
                T = self.mirror.mirrored(T)
            elif self.kind[k] == "self":
                T = self.mirror.symmetric_part(T)
            out.append(T)
        return out

    def centers(self, *, shape: np.ndarray, cage: np.ndarray) -> tuple[np.ndarray, ...]:
        """The default rotation centre (3,) of each user group in a pose ((n, 3) ``shape``,
        (c, 3) ``cage``): its shape vertices' centroid (its cage vertices' for a group
        with no shape vertex of its own)."""
        return tuple(shape[self.user_roles == k + 1].mean(axis=0) if np.any(self.user_roles == k + 1)
                     else cage[self.core == k + 1].mean(axis=0) for k in range(self.n_groups))

    def public(self, internal: np.ndarray) -> np.ndarray:
        """int8 user roles of internal ``roles`` (a mirror image counts in its group)."""
        lut = np.array([FIXED, FREE] + [s + 1 for s in self.source], dtype=np.int8)
        return lut[np.asarray(internal) + 1]


def choose_roles(user: UserRoles, *, mirror: Mirror | None, maps: CageMap) -> Roles:
    """The internal roles of the shape and cage vertices of a user's selection.

    Cage vertices held by ARAP are those whose nearest shape vertex is constrained
    (or, for a selection made on the cage, the user's own picks, except where the
    mirror gave the vertex's side a role); each handle group with no such cage
    vertex gets the cage vertices its shape vertices depend on most.

    Raises
    ------
    SelectionError
        A handle group has no cage vertex of its own.
    """
    roles, source, kind = mirrored_roles(user.roles, n_groups=user.n_groups, mirror=mirror, roi_mode=user.roi_mode)
    near = roles[maps.nearest]
    if user.space == "shape":
        core = near
    else:  # the user's own picks, but a role the mirror gave a vertex's side wins over a pick there
        mirrored = (roles != user.roles)[maps.nearest]
        core = np.where((user.given != FREE) & ~mirrored, user.given, near)
    cage_roles = core.astype(np.int32)
    for k in range(len(source)):
        if not np.any(cage_roles == k + 1):
            rows = np.flatnonzero(roles == k + 1)
            dom = unique_in_range(maps.dominant[rows], len(cage_roles))
            dom = dom[cage_roles[dom] <= FREE]  # a handle takes precedence over fixed
            if dom.size == 0:
                raise SelectionError(
                    f"handle group {source[k]} has no cage vertex of its own (its neighbours claim them "
                    "all); select a larger handle or use a finer cage")
            cage_roles[dom] = k + 1
    return Roles(user_roles=user.roles.astype(np.int8), roles=roles, cage_roles=cage_roles, core=core,
                 source=tuple(source), kind=tuple(kind), n_groups=user.n_groups, mirror=mirror,
                 constrained=np.flatnonzero(cage_roles != FREE).astype(np.int64),
                 moving=np.flatnonzero(cage_roles > 0).astype(np.int64), roi_mode=user.roi_mode)


def rows_that_can_move(binding: sp.csr_matrix, changing: np.ndarray, *, blend_idx: np.ndarray | None = None
                       ) -> np.ndarray:
    """(r,) int64 sorted shape vertices bound to a cage vertex that can change
    (``changing``, (c,) bool), or turning with one (``blend_idx``, (n, k), the
    residual's rotation blend; None for the linear propagation)."""
    M = binding
    n = M.shape[0]
    mask = np.zeros(n, dtype=bool)
    blend = np.zeros((n, 0), dtype=np.int64) if blend_idx is None else blend_idx
    kernel = pick("propagate", *_rows_touching, n)
    kernel(M.indptr, M.indices, np.ascontiguousarray(changing, dtype=np.bool_), blend, mask)
    return np.flatnonzero(mask).astype(np.int64)


@njit(cache=True, inline="always")
def _row_touches(i, indptr, indices, changing, blend, mask):
    for k in range(indptr[i], indptr[i + 1]):
        if changing[indices[k]]:
            mask[i] = True
            return
    for t in range(blend.shape[1]):
        if changing[blend[i, t]]:
            mask[i] = True
            return


@twins()
def _rows_touching(indptr, indices, changing, blend, mask):  # pragma: no cover - compiled
    for i in prange(mask.shape[0]):
        _row_touches(i, indptr, indices, changing, blend, mask)


@dataclass(frozen=True)
class Selection(Roles):
    """Everything a selection decides (:func:`build_selection`; never modified later)."""

    shape_groups: tuple[np.ndarray, ...]  # shape vertices of each internal group
    cage_groups: tuple[np.ndarray, ...]  # cage vertices of each internal group
    slots: tuple[np.ndarray, ...]  # positions of each cage group within ``constrained``
    free_cage: np.ndarray  # (f,) int64 cage vertices ARAP moves
    held: np.ndarray  # (h,) int64 cage vertices of parts with no constraint, held still by ARAP
    rows: np.ndarray  # (r,) int64 free shape vertices a drag can move
    seam: np.ndarray  # (s,) int64 constrained shape vertices whose rows lean on moving cage vertices
    seam_role: np.ndarray  # (s,) their internal roles
    sym_rows: np.ndarray  # rows whose displacement is averaged with their mirror image

    @property
    def public_cage_roles(self) -> np.ndarray:
        """(c,) int8 user roles of the cage vertices, parts held still counting as fixed."""
        roles = self.cage_roles.copy()
        roles[self.held] = FIXED
        return self.public(roles)

    @property
    def moving_vertices(self) -> np.ndarray:
        """(k,) int64 sorted shape vertices a drag can move (free rows and handles)."""
        return union_in_range(self.rows, np.flatnonzero(self.roles > 0), len(self.roles))


def build_selection(roles: Roles, *, free_cage: np.ndarray, held: np.ndarray, binding: sp.csr_matrix,
                    blend_idx: np.ndarray | None = None) -> Selection:
    """The selection of ``roles`` once ARAP is factored for them.

    Parameters
    ----------
    roles : from :func:`choose_roles`.
    free_cage : (f,) int64 cage vertices ARAP moves; held : (h,) int64 those it holds
        still (parts with no constraint), both from :meth:`hybridedit.deform.arap.ARAPSolver.set_constrained`.
    binding : (n, c) CSR binding M.
    blend_idx : (n, k) int array, cage vertices of each shape vertex's rotation blend (the
        residual propagation: a row turning with a moving cage vertex moves), or None.
    """
    n_int = len(roles.source)
    cage_roles = roles.cage_roles
    constrained = roles.constrained
    changing = cage_roles > 0
    changing[free_cage] = True
    rows = rows_that_can_move(binding, changing, blend_idx=blend_idx)
    r = roles.roles
    seam = rows[r[rows] != FREE]
    rows = rows[r[rows] == FREE]
    sym_rows = np.zeros(0, dtype=np.int64)
    mirror = roles.mirror
    if mirror is not None:
        partners = mirror.map[rows]
        rows = union_in_range(rows, partners[r[partners] == FREE], len(r))
        sym_rows = rows[r[mirror.map[rows]] == FREE]
    return Selection(
        **{name: getattr(roles, name) for name in Roles.__dataclass_fields__},
        shape_groups=tuple(np.flatnonzero(r == k + 1) for k in range(n_int)),
        cage_groups=tuple(np.flatnonzero(cage_roles == k + 1) for k in range(n_int)),
        slots=tuple(np.searchsorted(constrained, np.flatnonzero(cage_roles == k + 1)) for k in range(n_int)),
        free_cage=free_cage, held=held, rows=rows, seam=seam, seam_role=r[seam], sym_rows=sym_rows,
    )

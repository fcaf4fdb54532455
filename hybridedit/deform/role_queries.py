"""What a selection makes of each vertex, asked of the editor: the roles of shape and cage vertices
(fixed, free, handle group), the vertices a drag can move, selections mapped between shape and cage,
the roles a selection takes once mirrored, and the shape's mirrors (the :class:`RoleQueries` part of
:class:`~hybridedit.HybridEditor`)."""

from __future__ import annotations

import numpy as np

from .roles import FIXED, FREE
from .selection import SelectionError, mirrored_roles
from .symmetry import Mirror

__all__ = ["RoleQueries"]


class RoleQueries:
    """:class:`~hybridedit.HybridEditor`'s questions about roles, mixed into it: they read its
    selection ``_sel`` (None before one is set), its shape ``mesh`` and ``cage``, the map between
    their vertices ``_maps`` (:class:`~hybridedit.deform.selection.CageMap`) and keep the shape's
    mirrors in ``_mirrors`` ({repr(plane): Mirror})."""

    @property
    def n_groups(self) -> int:
        """Number of handle groups of the selection (0 before one is set)."""
        return 0 if self._sel is None else self._sel.n_groups

    @property
    def vertex_roles(self) -> np.ndarray:
        """(n,) int8 role of each shape vertex: -1 fixed, 0 free, g + 1 in handle group g
        (mirror images count in their group). This is what is held exactly."""
        if self._sel is None:
            return np.zeros(self.mesh.n_vertices, dtype=np.int8)
        return self._sel.public(self._sel.roles)

    @property
    def dominant_cage_vertex(self) -> np.ndarray:
        """(n,) int64, read-only: the cage vertex each shape vertex depends on most (the largest
        magnitude in its row of the binding), the cage vertex that stands for it in a selection."""
        v = self._maps.dominant.view()
        v.flags.writeable = False
        return v

    @property
    def cage_roles(self) -> np.ndarray:
        """(c,) int8 role of each cage vertex, as :attr:`vertex_roles`; cage parts
        with no constraint, held still, count as fixed."""
        if self._sel is None:
            return np.zeros(self.cage.n_vertices, dtype=np.int8)
        return self._sel.public_cage_roles

    @property
    def handle(self) -> np.ndarray:
        """(h,) int64 cage vertices that follow a handle transform (all groups)."""
        if self._sel is None:
            return np.zeros(0, dtype=np.int64)
        return self._sel.moving.copy()

    @property
    def fixed(self) -> np.ndarray:
        """(f,) int64 cage vertices held where they are (fixed, and parts held still)."""
        if self._sel is None:
            return np.zeros(0, dtype=np.int64)
        return np.flatnonzero(self.cage_roles == FIXED).astype(np.int64)

    @property
    def moving_vertices(self) -> np.ndarray:
        """(k,) int64 sorted shape vertices a drag can move: the edited region
        (free vertices bound to moving cage vertices, and the handles)."""
        if self._sel is None:
            return np.zeros(0, dtype=np.int64)
        return self._sel.moving_vertices

    @property
    def free_mask(self) -> np.ndarray:
        """(n,) bool: the free shape vertices a drag can move, i.e. the edited region
        less its constraints; what a full-resolution polish may move."""
        mask = np.zeros(self.mesh.n_vertices, dtype=bool)
        if self._sel is not None:
            mask[self._sel.rows] = True
        return mask

    @property
    def symmetry(self) -> Mirror | None:
        """The mirror of a symmetric selection, else None."""
        return None if self._sel is None else self._sel.mirror

    def to_cage(self, indices, space: str = "shape", role: str = "selection") -> np.ndarray:
        """Map a vertex selection to cage vertex indices.

        Shape vertices map to the cage vertices whose nearest shape vertex is
        selected; a small selection that contains no such vertex maps to the cage
        vertex with the largest coordinate of each selected shape vertex.

        Parameters
        ----------
        indices : (k,) int array of vertex indices, or a boolean mask, in ``space``.
        space : "shape" or "cage".

        Returns
        -------
        (j,) int64 array of sorted unique cage vertex indices.
        """
        return self._maps.to_cage(indices, space=space, role=role)

    def shape_roles(self, cage_roles) -> np.ndarray:
        """Shape vertex roles that select exactly the given cage vertex roles.

        A selection made on the cage (as in the window) given in shape vertices, so
        that the edit it makes is a shape-space edit that replays the same on this
        cage: each shape vertex takes the role of the cage vertex it depends on most,
        and the shape vertex nearest each cage vertex (whose role the cage vertex
        takes, see :meth:`set_selection`) takes that cage vertex's own role.

        Parameters
        ----------
        cage_roles : (c,) int array, -1 fixed, 0 free, g + 1 handle group g.

        Returns
        -------
        (n,) int8 shape vertex roles, the same code.
        """
        return self._maps.shape_roles(cage_roles)

    def preview_roles(self, roles, *, symmetry=None) -> tuple[np.ndarray, np.ndarray]:
        """The roles a selection takes once mirrored, without setting it (nothing is
        factored: a few milliseconds), to draw a selection on both sides as it is made.

        Parameters
        ----------
        roles : (n,) int shape vertex roles, -1 fixed, 0 free, g + 1 handle group g
            (e.g. from :meth:`shape_roles`); groups may be empty.
        symmetry : None, "x", "y", "z" or (point, normal), as :meth:`set_selection`
            takes it with ``roi`` (a vertex stays fixed only where its mirror image is fixed too).

        Returns
        -------
        vertex_roles : (n,) int8, cage_roles : (c,) int8
            The same code, mirror images counted in their group; a cage vertex takes
            the role of its nearest shape vertex.

        Raises
        ------
        SelectionError
            Roles of the wrong length, or a shape not symmetric enough.
        """
        r = np.asarray(roles)
        if r.shape != (self.mesh.n_vertices,) or not np.issubdtype(r.dtype, np.integer):
            raise SelectionError(f"roles must be {self.mesh.n_vertices:,} integers")
        r = r.astype(np.int32)
        mirror = self._mirror(symmetry) if symmetry is not None else None
        internal, source, _ = mirrored_roles(r, n_groups=int(r.max(initial=0)), mirror=mirror, roi_mode=True)
        lut = np.array([FIXED, FREE] + [g + 1 for g in source], dtype=np.int8)
        shape = lut[internal + 1]
        return shape, shape[self._maps.nearest]

    def mirror(self, symmetry) -> Mirror:
        """The shape's mirror across a plane ("x", "y", "z" or (point, normal)), as
        :meth:`set_selection` would use it: check a shape before offering to mirror it.

        Raises
        ------
        SelectionError
            The shape is not symmetric enough across that plane (the message gives its
            measured asymmetry), or the plane is malformed.
        """
        return self._mirror(symmetry)

    def _mirror(self, symmetry) -> Mirror:
        key = repr(symmetry)
        m = self._mirrors.get(key)
        if m is None:
            m = self._mirrors[key] = Mirror(self.mesh.vertices, symmetry)
        return m

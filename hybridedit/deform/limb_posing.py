"""A shape posed by its limbs: the limbs found on the editor's cage at rest, the limb under a vertex,
a limb selected at its joint and turned about it (the :class:`LimbPosing` part of
:class:`~hybridedit.HybridEditor`; the limbs themselves are :mod:`hybridedit.deform.limbs`').

A Pose tool hovers :meth:`~LimbPosing.limb_at`, selects with :meth:`~LimbPosing.select_limb` when
the drag starts and then drags ``rotate={"axis": ..., "degrees": ..., "center": parts.joint}`` each
frame; a script calls :meth:`~LimbPosing.pose_limb`, which does both and solves the pose.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..core.face_geometry import centre_of_mass
from .limbs import HOVER_MARGIN, Limb, LimbPose, find_limbs, limb_at, swing_axis
from .roles import FIXED, FREE, handle as handle_role
from .selection import SelectionError

if TYPE_CHECKING:
    from .editor import HybridEditor  # noqa: F401

__all__ = ["LimbPosing"]


class LimbPosing:
    """:class:`~hybridedit.HybridEditor`'s limbs, mixed into it: it reads the shape ``mesh``, the
    ``cage`` at rest and the ``rig``'s links, the binding ``M`` and the cage's current pose
    (``arap.positions``); it sets a selection (:meth:`set_selection`) and solves a
    pose (:meth:`pose`) as any caller would, so that :attr:`edit` records what it did."""

    #: the limbs found by the first :meth:`limbs` call (a tuple; None before)
    _limbs: tuple[Limb, ...] | None = None

    def limbs(self) -> list[Limb]:
        """The shape's limbs, found on the cage at rest (:func:`hybridedit.deform.limbs.find_limbs`,
        the shape's centre of mass as its centre); found once per editor.

        Returns
        -------
        list of Limb
            Farthest extremity first (each :attr:`~hybridedit.deform.limbs.Limb.index` its place);
            empty for a shape with none (a ball).

        Examples
        --------
        >>> arm = max(ed.limbs(), key=lambda limb: limb.tip[0])  # the one reaching farthest to +X  # doctest: +SKIP
        >>> ed.pose_limb(arm, degrees=40)  # doctest: +SKIP
        """
        if self._limbs is None:
            m = self.mesh
            self._limbs = tuple(find_limbs(self.cage.vertices, self.cage.edges(), cage_faces=self.cage.faces,
                                           centre_point=centre_of_mass(m.vertices, m.faces), links=self.rig.links))
        return list(self._limbs)

    def limb_distance(self, limb: Limb) -> np.ndarray:
        """Each shape vertex's geodesic distance from a limb's tip: the binding's blend of its cage
        vertices' (``M @ limb.cage_distance``), smooth across the cage's faces, where the cage vertex
        a shape vertex depends on most would give the same distance to a whole cage edge's worth.

        Parameters
        ----------
        limb : Limb
            One of :meth:`limbs`.

        Returns
        -------
        (n,) float64
            inf for a vertex bound to a cage vertex the tip does not reach (another part).
        """
        self._check_limb(limb)
        d = limb.cage_distance
        finite = np.isfinite(d)
        out = self.M @ np.where(finite, d, 0.0)
        if not finite.all():
            out[abs(self.M) @ (~finite).astype(np.float64) > 0] = np.inf
        return out

    def limb_roles(self, limb: Limb, *, at: float = 1.0) -> np.ndarray:
        """The roles :meth:`select_limb` gives the shape's vertices (for showing what a pose of the limb
        would move before it is made): by :meth:`limb_distance`, the handle (group 0) what lies within
        the parts' ``inner`` of the tip, the free band what lies within ``outer``, the rest fixed
        (:meth:`hybridedit.deform.limbs.Limb.parts`); never an empty handle or band.

        Parameters
        ----------
        limb : Limb
            One of :meth:`limbs`.
        at : float
            The joint's place along the limb from the tip, as a fraction of its length.

        Returns
        -------
        (n,) int8
            -1 fixed, 0 free, 1 handle (:mod:`hybridedit.deform.roles`).
        """
        parts = limb.parts(at=at)
        d = self.limb_distance(limb)
        hand = d <= parts.inner
        if not hand.any():  # (a handle smaller than the shape's spacing: its vertex nearest the tip)
            hand[np.argmin(d)] = True
        roi = hand | (d <= parts.outer)
        if not (roi & ~hand).any():  # (a band thinner than the spacing: out to the next vertex)
            beyond = np.where(hand, np.inf, d)
            roi |= beyond <= beyond.min()
        roles = np.full(len(d), FIXED, dtype=np.int8)
        roles[roi] = FREE
        roles[hand] = handle_role(0)
        return roles

    def limb_at(self, vertex: int, *, space: str = "shape", margin: float = HOVER_MARGIN) -> Limb | None:
        """The limb a vertex lies on, for a hover (:func:`hybridedit.deform.limbs.limb_at`; a shape
        vertex at its :meth:`limb_distance`, from its row of the binding alone: no time at all).

        Parameters
        ----------
        vertex : int
            A vertex index in ``space``.
        space : "shape" or "cage"
        margin : float
            How far past a limb's joint, as a fraction of its length, a vertex still counts as on it.

        Returns
        -------
        Limb or None
        """
        if space not in ("shape", "cage"):
            raise ValueError(f"space must be 'shape' or 'cage', got {space!r}")
        n = self.mesh.n_vertices if space == "shape" else self.cage.n_vertices
        if not isinstance(vertex, (int, np.integer)) or not 0 <= int(vertex) < n:
            raise SelectionError(f"vertex must be a {space} vertex index in [0, {n - 1:,}], got {vertex!r}")
        if space == "cage":
            return limb_at(self.limbs(), int(vertex), margin=margin)
        row = self.M[int(vertex)]
        best, along = None, np.inf
        for limb in self.limbs():
            d = limb.cage_distance[row.indices]
            f = float(row.data @ d) / limb.length if np.isfinite(d).all() and limb.length > 0 else np.inf
            if f <= margin and f < along:
                best, along = limb, f
        return best

    def limb_parts(self, limb: Limb, *, at: float = 1.0) -> LimbPose:
        """A limb's parts (:meth:`hybridedit.deform.limbs.Limb.parts`) with its joint and axis where
        the current pose puts them (the cage's current positions), for drawing them.

        Parameters
        ----------
        limb : Limb
            One of :meth:`limbs`.
        at : float
            The joint's place along the limb from the tip, as a fraction of its length.

        Returns
        -------
        LimbPose
        """
        self._check_limb(limb)
        return limb.parts(at=at).placed(self.arap.positions)

    def select_limb(self, limb: Limb, *, at: float = 1.0) -> LimbPose:
        """Select a limb for posing: its handle (the limb beyond the band about the joint) as handle
        group 0, the band free, the rest fixed (:meth:`limb_roles`), given in shape vertices, so that
        an edit saved afterwards replays with ``hybridedit deform``. The current pose becomes the
        reference of the next drags, as for any :meth:`set_selection`.

        Then ``drag(rotate={"axis": a, "degrees": d, "center": parts.joint})`` bends it at the joint.

        Parameters
        ----------
        limb : Limb
            One of :meth:`limbs`.
        at : float
            The joint's place along the limb from the tip, as a fraction of its length.

        Returns
        -------
        LimbPose
            Its joint and axis in the current pose (:meth:`limb_parts`).
        """
        parts = self.limb_parts(limb, at=at)
        roles = self.limb_roles(limb, at=at)
        self.set_selection(np.flatnonzero(roles == handle_role(0)), roi=np.flatnonzero(roles >= FREE))
        return parts

    def pose_limb(self, limb: Limb, *, degrees: float, axis=None, at: float = 1.0, translate=None,
                  up: str = "+Y") -> np.ndarray:
        """Bend a limb at its joint: :meth:`select_limb`, then :meth:`pose` turning its handle by
        ``degrees`` about ``axis`` through the joint (then moving it by ``translate``).

        Parameters
        ----------
        limb : Limb
            One of :meth:`limbs`.
        degrees : float
            The turn, right-handed about ``axis``, from the current pose (successive calls compose).
        axis : (3,) float64, optional
            The axis of the turn. By default the limb's swing axis
            (:func:`hybridedit.deform.limbs.swing_axis`): perpendicular to the limb (joint to tip, in
            the current pose) and to ``up``, so that an arm held out sideways goes up for positive
            degrees; a limb within 30 degrees of vertical (a leg) turns about limb x front instead,
            forward for positive degrees.
        at : float
            The joint's place along the limb from the tip, as a fraction of its length.
        translate : (3,) float64, optional
            A translation of the handle after the turn.
        up : str
            The shape's up axis ("+Y", "+Z", ...), for the default axis.

        Returns
        -------
        (n, 3) float64 array, the posed shape (a copy of its own). The fixed vertices are where they
        were; the handle's are exactly turned about the joint.

        Examples
        --------
        >>> import hybridedit as he
        >>> ed = he.open("creature.ply")  # doctest: +SKIP
        >>> arm = max(ed.limbs(), key=lambda limb: limb.tip[0])  # the one reaching farthest to +X  # doctest: +SKIP
        >>> V = ed.pose_limb(arm, degrees=40)  # doctest: +SKIP
        """
        if not np.isfinite(float(degrees)):
            raise ValueError(f"degrees must be a finite number, got {degrees!r}")
        parts = self.select_limb(limb, at=at)
        turn = swing_axis(parts.axis, up=up) if axis is None else np.asarray(axis, dtype=np.float64)
        return self.pose(translate, rotate={"axis": turn, "degrees": float(degrees), "center": parts.joint})

    def _check_limb(self, limb: Limb) -> None:
        """Refuse a limb found on another cage."""
        if not isinstance(limb, Limb) or len(limb.cage_distance) != self.cage.n_vertices or not (
                limb.cage_vertices is self.cage.vertices or np.array_equal(limb.cage_vertices, self.cage.vertices)):
            raise ValueError("limb must be one of this editor's limbs() (found on its cage)")

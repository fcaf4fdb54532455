"""The selection of a session: which cage vertices are in the ROI and in each handle group, the
gestures and commands that change it, and the roles it gives the cage and the shape.

No Qt here; :class:`~.session.Session` builds on :class:`SelectionState` (the engine, the pose,
the drags and undo are the session's).

Vocabulary
----------
targets
    A selection gesture or command acts on one target: the ROI (``ROI``) or the active handle group
    (``HANDLE``).
masks
    ``roi`` is a boolean mask over the cage vertices; ``handle_group`` gives each cage vertex the role
    of the handle group it is in (:func:`hybridedit.deform.roles.handle`), or ``NO_GROUP``. Fixed =
    outside the ROI and in no handle group.
roles
    What the selection makes of each vertex, in the engine's code (:mod:`hybridedit.deform.roles`):
    the engine's own once it has the selection, else what it will take (mirror images included).
"""

from __future__ import annotations

import numpy as np

from ...core.index_sets import unique_sorted
from ...deform.roles import FIXED, group, handle as handle_role, is_handle
from .picking import combine, selection_roles

ROI, HANDLE = "roi", "handle"
TARGETS = (ROI, HANDLE)
NO_GROUP = 0
"""``handle_group`` of a cage vertex in no handle group."""


class SelectionState:
    """The ROI and the handle groups of a :class:`~.session.Session` (a mixin).

    The session provides ``editor`` (the engine), ``mesh``, ``transforms`` and ``_bases`` (one (4, 4) per
    handle group: kept in step here as groups come and go) and the hooks ``finish_settle()``,
    ``_push(label)`` (record an undo step), ``_identity_transforms()`` and ``_selection_changed(label)``
    (the masks changed: one undo step); it sets ``_engine_masks`` to :meth:`_mask_key` when it gives
    the engine the selection.

    Attributes
    ----------
    roi : (c,) bool, the region of interest (the handle groups count in it).
    handle_group : (c,) int8, ``roles.handle(g)`` for a cage vertex in handle group g, else ``NO_GROUP``.
    n_groups : how many handle groups there are (at least 1; the last may be empty).
    active : the handle group that selections and drags act on.
    symmetry : mirror the selection across this axis's mid-plane ("x", "y", "z"), or None.
    """

    def _init_selection(self, c: int, roi: np.ndarray | None, handle_mask: np.ndarray | None,
                        symmetry: str | None) -> None:
        """The selection of a new session on a cage of ``c`` vertices (see :class:`~.session.Session`)."""
        self.roi = np.zeros(c, dtype=bool) if roi is None else np.asarray(roi, dtype=bool).copy()
        self.handle_group = np.full(c, NO_GROUP, dtype=np.int8)
        self.n_groups = 1
        self.active = 0
        if handle_mask is not None:
            self.handle = handle_mask
        if self.roi.shape != (c,):
            raise ValueError(f"selection masks must have {c} entries (the cage vertex count)")
        self._stroke: tuple[str, np.ndarray] | None = None
        self._engine_masks: tuple | None = None
        self._preview_cache: tuple | None = None
        if symmetry is not None:
            self.editor.mirror(symmetry)  # a shape too asymmetric is refused now, not at the first drag
        self.symmetry: str | None = symmetry

    # ------------------------------------------------------------------ masks
    @property
    def n_cage(self) -> int:
        """The cage's vertex count (the masks' length)."""
        return self.editor.cage.n_vertices

    @property
    def handle(self) -> np.ndarray:
        """(c,) bool: the cage vertices of the active handle group."""
        return self.handle_group == handle_role(self.active)

    @handle.setter
    def handle(self, mask) -> None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != self.handle_group.shape:
            raise ValueError(f"a handle mask must have {len(self.handle_group)} entries (the cage vertex count)")
        g = self.handle_group.copy()
        g[g == handle_role(self.active)] = NO_GROUP
        g[m] = handle_role(self.active)  # a vertex belongs to one group: the active one takes it
        self.handle_group = g

    @property
    def all_handles(self) -> np.ndarray:
        """(c,) bool: the cage vertices of every handle group."""
        return is_handle(self.handle_group)

    def mask(self, target: str) -> np.ndarray:
        """(c,) bool: the ROI, or the active handle group (``target``: ``ROI`` or ``HANDLE``)."""
        if target not in TARGETS:
            raise ValueError(f"target must be one of {TARGETS}, got {target!r}")
        return self.roi if target == ROI else self.handle

    def _mask_key(self) -> tuple:
        return (np.packbits(self.roi).tobytes(), self.handle_group.tobytes(), self.symmetry)

    def _engine_has_masks(self) -> bool:
        """The engine's selection was set from the masks (and mirror) as they are now."""
        return self._engine_masks == self._mask_key()

    # ------------------------------------------------------------------ handle groups
    def new_group(self) -> bool:
        """Start a new, empty handle group and make it the active one (False: the active one is empty)."""
        self.finish_settle()
        if not self.handle.any():
            return False
        self.n_groups += 1
        self.active = self.n_groups - 1
        self.transforms = list(self.transforms) + [np.eye(4)]
        self._bases = list(self._bases) + [np.eye(4)]
        self._push("new handle group")
        return True

    def next_group(self) -> int:
        """Make the next handle group the active one (cycling); returns its index."""
        self.finish_settle()
        self.active = (self.active + 1) % self.n_groups
        return self.active

    def _compact_groups(self) -> None:
        """Drop empty handle groups (the engine numbers groups 0..G-1, all non-empty)."""
        used = [g for g in range(self.n_groups) if np.any(self.handle_group == handle_role(g))]
        if len(used) == self.n_groups:
            return
        lut = np.full(handle_role(self.n_groups), NO_GROUP, dtype=np.int8)  # old role -> new role
        for k, g in enumerate(used):
            lut[handle_role(g)] = handle_role(k)
        self.handle_group = lut[self.handle_group]
        self.active = used.index(self.active) if self.active in used else 0
        self.transforms = [self.transforms[g] for g in used] or [np.eye(4)]
        self._bases = [self._bases[g] if g < len(self._bases) else np.eye(4) for g in used] or [np.eye(4)]
        self.n_groups = max(len(used), 1)

    # ------------------------------------------------------------------ commands (one undo step each)
    def set_symmetry(self, axis: str | None) -> None:
        """Mirror the selection across the shape's mid-plane normal to ``axis`` ("x", "y", "z"), or not (None).

        Applied with the next drag. A shape that is not symmetric enough is refused now
        (a SelectionError with its measured asymmetry), and nothing changes."""
        if axis not in (None, "x", "y", "z"):
            raise ValueError(f"symmetry must be None, 'x', 'y' or 'z', got {axis!r}")
        if axis is not None:
            self.editor.mirror(axis)  # raises SelectionError for a shape too asymmetric
        if axis != self.symmetry:
            self.symmetry = axis
            self._selection_changed(f"mirror {axis.upper()}" if axis else "no mirror")

    def set_mask(self, target: str, mask: np.ndarray, label: str | None = None) -> bool:
        """Replace the ROI or handle mask ((c,) bool); returns False when nothing changed."""
        new = np.asarray(mask, dtype=bool).copy()
        if new.shape != (self.n_cage,):
            raise ValueError(f"a {target} mask must have {self.n_cage} entries")
        if np.array_equal(new, self.mask(target)):
            return False
        if target == ROI:
            self.roi = new
        else:
            self.handle = new
        self._selection_changed(label or f"select {'ROI' if target == ROI else 'handle'}")
        return True

    def select(self, target: str, hits: np.ndarray, op: str) -> bool:
        """Apply hit-tested cage vertices ((c,) bool) to the ROI or the handle (replace / add / remove)."""
        return self.set_mask(target, combine(self.mask(target), hits, op))

    def clear(self, target: str) -> bool:
        """Empty the ROI or the active handle group; returns False when it was empty."""
        return self.set_mask(target, np.zeros(self.n_cage, dtype=bool), f"clear {target}")

    def clear_all(self) -> bool:
        """Empty the ROI and every handle group, back to one (empty) handle group, as one undo step;
        returns False when there was nothing to clear."""
        if not self.roi.any() and not self.all_handles.any():
            return False
        self.roi = np.zeros(self.n_cage, dtype=bool)
        self.handle_group = np.full(self.n_cage, NO_GROUP, dtype=np.int8)
        self.n_groups, self.active = 1, 0
        self._identity_transforms()
        self._selection_changed("clear selection")
        return True

    def invert(self, target: str) -> bool:
        """Invert the ROI or the active handle group (one undo step)."""
        return self.set_mask(target, ~self.mask(target), f"invert {target}")

    def select_all(self, target: str) -> bool:
        """Every cage vertex into the ROI or the active handle group; returns False when all were."""
        return self.set_mask(target, np.ones(self.n_cage, dtype=bool), f"select all {target}")

    # ------------------------------------------------------------------ gestures (one undo step each)
    def begin_stroke(self, target: str) -> None:
        """Start a selection gesture on ``target``: :meth:`stroke` changes the mask
        without recording; :meth:`end_stroke` records the whole gesture as one undo step."""
        self._stroke = (target, self.mask(target).copy())

    def stroke(self, hits: np.ndarray, op: str) -> None:
        """Apply hit-tested cage vertices ((c,) bool) to the gesture's target, unrecorded."""
        if self._stroke is None:
            raise RuntimeError("begin_stroke first")
        target = self._stroke[0]
        new = combine(self.mask(target), hits, op)
        if target == ROI:
            self.roi = new
        else:
            self.handle = new

    def end_stroke(self) -> bool:
        """Finish the gesture; returns True when the selection changed."""
        if self._stroke is None:
            return False
        target, before = self._stroke
        self._stroke = None
        if np.array_equal(before, self.mask(target)):
            return False
        self._selection_changed(f"select {'ROI' if target == ROI else 'handle'}")
        return True

    # ------------------------------------------------------------------ the roles it gives
    def cage_roles(self) -> np.ndarray:
        """(c,) int8 role of each cage vertex (:mod:`hybridedit.deform.roles`): the engine's cage roles
        once it has the selection, else the masks'; mirror images included in both cases."""
        if self._engine_has_masks() and (self.roi.any() or self.all_handles.any()):
            roles = self.editor.cage_roles
        elif self.symmetry is not None and (self.roi.any() or self.all_handles.any()):
            roles = self._preview()[1]  # the mirrored selection, drawn on both sides as it is made
        else:
            return selection_roles(self.roi, self.handle_group)  # one role (colour) per handle group
        return roles.astype(np.int8)

    def shape_roles(self) -> np.ndarray:
        """(n,) int8 role of each shape vertex (:mod:`hybridedit.deform.roles`); all FREE with no selection.

        Once the engine has the selection these are its roles (what it holds exactly); before,
        what it will hold (:meth:`~hybridedit.HybridEditor.preview_roles`, mirror images included).
        """
        if not self.roi.any() and not self.all_handles.any():
            return np.zeros(self.mesh.n_vertices, dtype=np.int8)
        if self._engine_has_masks():
            return self.editor.vertex_roles
        return self._preview()[0]

    def _engine_shape_roles(self) -> np.ndarray:
        """(n,) the shape-space roles the engine is given for the current masks (see
        :meth:`~.session.Session.apply_selection`)."""
        return self.editor.shape_roles(selection_roles(self.roi, self.handle_group))

    def _preview(self) -> tuple[np.ndarray, np.ndarray]:
        """(shape roles, cage roles) the engine will take for the current masks and mirror (cached)."""
        key = self._mask_key()
        if self._preview_cache is None or self._preview_cache[0] != key:
            self._preview_cache = (key, self.editor.preview_roles(self._engine_shape_roles(), symmetry=self.symmetry))
        return self._preview_cache[1]

    def tearing(self) -> dict[int, int]:
        """{handle group: cage points of the group that share a cage edge with a held (fixed) point}: with
        no free point between them, a drag stretches those edges and tears the shape there (the front of a
        limb taken as handle, its back left fixed). Mirror images count in their group; empty when none."""
        r = self.cage_roles()
        e = self.editor.cage_edges
        touching = np.zeros(len(r), dtype=bool)
        for x, y in ((e[:, 0], e[:, 1]), (e[:, 1], e[:, 0])):
            touching[x[is_handle(r[x]) & (r[y] == FIXED)]] = True
        return {int(group(g)): int(np.count_nonzero(touching & (r == g))) for g in unique_sorted(r[touching])}

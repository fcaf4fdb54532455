"""The selection of a session: which cage vertices are in the ROI and in each handle group, the
gestures and commands that change it, and the roles it gives the cage and the shape.

No Qt here; a :class:`~.session.Session` holds a :class:`Selection` (``session.selection``), which
sees the session only as a :class:`SelectionOwner` (the engine, the pose, the drags and undo are the
session's).

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

import weakref
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ...core.index_sets import unique_sorted
from ...core.normals import vertex_normals
from ...deform.roles import FIXED, group, handle as handle_role, is_handle
from ...deform.skeleton import edge_graph
from .picking import combine, selection_roles
from .surface_pick import thickness

if TYPE_CHECKING:
    from ...deform.editor import HybridEditor
    from .history import Snapshot

ROI, HANDLE = "roi", "handle"
TARGETS = (ROI, HANDLE)
NO_GROUP = 0
"""``handle_group`` of a cage vertex in no handle group."""


def touching_held(roles: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(c,) bool: the handle points (of any group) that share a cage edge with a held (fixed) point, for
    cage roles ``roles`` (c,) and cage ``edges`` (e, 2): where a drag would tear the shape."""
    touching = np.zeros(len(roles), dtype=bool)
    held = roles == FIXED
    for x, y in ((edges[:, 0], edges[:, 1]), (edges[:, 1], edges[:, 0])):
        touching[x[is_handle(roles[x]) & held[y]]] = True
    return touching


@runtime_checkable
class SelectionOwner(Protocol):
    """What a :class:`Selection` needs of the session that holds it (:class:`~.session.Session`).

    The selection owns the masks; the engine, the pose and undo are the owner's. Each handle group has
    a transform in the owner, so the owner hears when groups come and go.
    """

    @property
    def editor(self) -> HybridEditor:
        """The engine: the cage the masks are over, the roles it gives them, the mirror it checks."""
        ...

    def finish_settle(self) -> None:
        """Complete a settle under way (before the active handle group changes)."""
        ...

    def group_added(self, label: str) -> None:
        """A handle group was added (the active one now): its transform starts at the identity; one
        undo step called ``label``."""
        ...

    def reset_transforms(self) -> None:
        """Every handle group's transform back to the identity (the groups were cleared)."""
        ...

    def selection_changed(self, label: str) -> None:
        """The masks changed: one undo step called ``label``."""
        ...


class Selection:
    """The ROI and the handle groups of a :class:`~.session.Session`, and the gestures and commands that
    change them.

    Parameters
    ----------
    owner : the session that holds it (see :class:`SelectionOwner`); held weakly, so that a session
        dropped is freed at once with its engine, as with no selection (no reference cycle).
    roi, handle : initial masks over the cage vertices (default: empty).
    symmetry : mirror the selection across this axis's mid-plane ("x", "y", "z"), or None.

    Attributes
    ----------
    roi : (c,) bool, the region of interest (the handle groups count in it).
    handle_group : (c,) int8, ``roles.handle(g)`` for a cage vertex in handle group g, else ``NO_GROUP``.
    n_groups : how many handle groups there are (at least 1; the last may be empty).
    active : the handle group that selections and drags act on.
    symmetry : mirror the selection across this axis's mid-plane ("x", "y", "z"), or None.
    given : the masks the engine was given (:meth:`give_to_engine`), as a key; None when not yet (or
        another engine). The engine's roles are the masks' while it equals :meth:`key`.

    Raises
    ------
    SelectionError
        ``symmetry`` given for a shape that is not symmetric enough across it.
    """

    def __init__(self, owner: SelectionOwner, roi: np.ndarray | None = None,
                 handle: np.ndarray | None = None, symmetry: str | None = None) -> None:
        self._owner_ref = weakref.ref(owner)
        c = owner.editor.cage.n_vertices
        self.roi = np.zeros(c, dtype=bool) if roi is None else np.asarray(roi, dtype=bool).copy()
        self.handle_group = np.full(c, NO_GROUP, dtype=np.int8)
        self.n_groups = 1
        self.active = 0
        if handle is not None:
            self.handle = handle
        if self.roi.shape != (c,):
            raise ValueError(f"selection masks must have {c} entries (the cage vertex count)")
        self._stroke: tuple[str, np.ndarray] | None = None
        self.given: tuple | None = None
        self._preview_cache: tuple | None = None
        self._thickness: tuple | None = None  # (engine, the thickness of its cage)
        if symmetry is not None:
            owner.editor.mirror(symmetry)  # a shape too asymmetric is refused now, not at the first drag
        self.symmetry: str | None = symmetry

    @property
    def _owner(self) -> SelectionOwner:
        owner = self._owner_ref()
        if owner is None:
            raise ReferenceError("the session that held this selection is gone")
        return owner

    @property
    def _editor(self) -> HybridEditor:
        return self._owner.editor

    # ------------------------------------------------------------------ masks
    @property
    def _n_cage(self) -> int:
        """The cage's vertex count (the masks' length)."""
        return self._editor.cage.n_vertices

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

    def key(self) -> tuple:
        """The masks and mirror as they are now, as a key (what :attr:`given` is compared with)."""
        return (np.packbits(self.roi).tobytes(), self.handle_group.tobytes(), self.symmetry)

    def engine_has_masks(self) -> bool:
        """The engine's selection was set from the masks (and mirror) as they are now."""
        return self.given == self.key()

    # ------------------------------------------------------------------ the engine's side
    def give_to_engine(self) -> list[int] | None:
        """Give the engine the selection as it is now (empty handle groups dropped first); returns the
        groups kept when some were dropped (see :meth:`compact_groups`), else None."""
        kept = self.compact_groups()
        # given in shape vertices (the cage picks exactly, see HybridEditor.shape_roles), so that the edit
        # file it saves replays with ``hybridedit deform`` to the same vertices
        roles = self._engine_shape_roles()
        handles = [np.flatnonzero(roles == handle_role(g)) for g in range(self.n_groups)]
        self._editor.set_selection(handles, roi=np.flatnonzero(roles != FIXED), symmetry=self.symmetry)
        self.given = self.key()
        return kept

    def take_from_engine(self, n_groups: int) -> None:
        """The engine's selection (after it replayed an edit) as the masks: ``n_groups`` handle groups,
        the first one active; the engine has them."""
        roles = self._editor.cage_roles
        self.roi = roles != FIXED
        self.handle_group = np.where(is_handle(roles), roles, NO_GROUP).astype(np.int8)
        self.n_groups = max(n_groups, 1)
        self.active = 0
        self.given = self.key()

    def engine_replaced(self) -> None:
        """The owner has a new engine: it has no selection from these masks yet."""
        self.given = self._preview_cache = self._thickness = None

    def cage_thickness(self) -> np.ndarray:
        """(c,) how thick the shape is at each cage point, at rest (:func:`~.surface_pick.thickness`): how far
        a selection grows through a part, and how wide a band :meth:`free_around_handles` frees."""
        editor = self._editor
        if self._thickness is None or self._thickness[0] is not editor:
            cage = editor.cage
            self._thickness = (editor, thickness(cage.vertices, vertex_normals(cage.vertices, cage.faces)))
        return self._thickness[1]

    def carry_over(self, dominant: np.ndarray) -> None:
        """Carry the masks over to the owner's new engine (a rebuild) through the shape: ``dominant`` gives
        the old cage vertex of each shape vertex; the groups keep their numbers."""
        roi_s = np.flatnonzero(self.roi[dominant])
        groups_s = self.handle_group[dominant]
        editor = self._editor
        c = editor.cage.n_vertices
        self.roi = np.zeros(c, dtype=bool)
        self.roi[editor.to_cage(roi_s, "shape")] = True
        self.handle_group = np.full(c, NO_GROUP, dtype=np.int8)
        for g in range(self.n_groups):
            self.handle_group[editor.to_cage(np.flatnonzero(groups_s == handle_role(g)), "shape")] = handle_role(g)

    def restore(self, snap: Snapshot) -> None:
        """The masks, groups, mirror and :attr:`given` of an undo snapshot (one group per transform it
        holds, at least)."""
        self.roi = snap.roi.copy()
        self.handle_group = np.asarray(snap.handle).astype(np.int8)
        n_transforms = len(np.asarray(snap.transform).reshape(-1, 4, 4))
        self.n_groups = max(n_transforms, int(self.handle_group.max(initial=0)), 1)
        self.active = min(snap.active, self.n_groups - 1)
        self.symmetry = snap.symmetry
        self.given = snap.engine_masks

    # ------------------------------------------------------------------ handle groups
    def new_group(self) -> bool:
        """Start a new, empty handle group and make it the active one (False: the active one is empty)."""
        self._owner.finish_settle()
        if not self.handle.any():
            return False
        self.n_groups += 1
        self.active = self.n_groups - 1
        self._owner.group_added("new handle group")
        return True

    def next_group(self) -> int:
        """Make the next handle group the active one (cycling); returns its index."""
        self._owner.finish_settle()
        self.active = (self.active + 1) % self.n_groups
        return self.active

    def compact_groups(self) -> list[int] | None:
        """Drop empty handle groups (the engine numbers groups 0..G-1, all non-empty); returns the groups
        kept, in their old numbers (the new group k was group ``kept[k]``), or None when none was empty."""
        used = [g for g in range(self.n_groups) if np.any(self.handle_group == handle_role(g))]
        if len(used) == self.n_groups:
            return None
        lut = np.full(handle_role(self.n_groups), NO_GROUP, dtype=np.int8)  # old role -> new role
        for k, g in enumerate(used):
            lut[handle_role(g)] = handle_role(k)
        self.handle_group = lut[self.handle_group]
        self.active = used.index(self.active) if self.active in used else 0
        self.n_groups = max(len(used), 1)
        return used

    # ------------------------------------------------------------------ commands (one undo step each)
    def set_symmetry(self, axis: str | None) -> None:
        """Mirror the selection across the shape's mid-plane normal to ``axis`` ("x", "y", "z"), or not (None).

        Applied with the next drag. A shape that is not symmetric enough is refused now
        (a SelectionError with its measured asymmetry), and nothing changes."""
        if axis not in (None, "x", "y", "z"):
            raise ValueError(f"symmetry must be None, 'x', 'y' or 'z', got {axis!r}")
        if axis is not None:
            self._editor.mirror(axis)  # raises SelectionError for a shape too asymmetric
        if axis != self.symmetry:
            self.symmetry = axis
            self._owner.selection_changed(f"mirror {axis.upper()}" if axis else "no mirror")

    def set_mask(self, target: str, mask: np.ndarray, label: str | None = None) -> bool:
        """Replace the ROI or handle mask ((c,) bool); returns False when nothing changed."""
        new = np.asarray(mask, dtype=bool).copy()
        if new.shape != (self._n_cage,):
            raise ValueError(f"a {target} mask must have {self._n_cage} entries")
        if np.array_equal(new, self.mask(target)):
            return False
        if target == ROI:
            self.roi = new
        else:
            self.handle = new
        self._owner.selection_changed(label or f"select {'ROI' if target == ROI else 'handle'}")
        return True

    def replace(self, roi: np.ndarray, handle: np.ndarray, label: str) -> bool:
        """The ROI and one handle group, replacing the whole selection (every handle group) as one undo
        step called ``label`` (the Pose tool's limb); returns False when it was that already."""
        r = np.asarray(roi, dtype=bool)
        h = np.asarray(handle, dtype=bool)
        if r.shape != (self._n_cage,) or h.shape != (self._n_cage,):
            raise ValueError(f"selection masks must have {self._n_cage} entries (the cage vertex count)")
        groups = np.where(h, handle_role(0), NO_GROUP).astype(np.int8)
        if self.n_groups == 1 and np.array_equal(r, self.roi) and np.array_equal(groups, self.handle_group):
            return False
        self.roi, self.handle_group = r.copy(), groups
        self.n_groups, self.active = 1, 0
        self._owner.reset_transforms()
        self._owner.selection_changed(label)
        return True

    def recovered(self, roi: np.ndarray, handle_group: np.ndarray, *, n_groups: int, active: int,
                  symmetry: str | None) -> bool:
        """The masks, handle groups and mirror of a recovered session (:func:`~.recovery.recover`), as one
        undo step when they are not the ones the replayed edit left; returns False when they are.

        Raises
        ------
        ValueError
            Masks of another size than the cage, or a role that is not a handle group.
        SelectionError
            A mirror the shape is not symmetric enough for.
        """
        r = np.asarray(roi, dtype=bool)
        g = np.asarray(handle_group, dtype=np.int8)
        if r.shape != (self._n_cage,) or g.shape != (self._n_cage,):
            raise ValueError(f"selection masks must have {self._n_cage} entries (the cage vertex count)")
        if g.size and (g.min() < NO_GROUP or g.max() > handle_role(max(int(n_groups), 1) - 1)):
            raise ValueError("a handle group role out of range")
        n = max(int(n_groups), 1)
        if symmetry is not None:
            self._editor.mirror(symmetry)
        self.active = min(max(int(active), 0), n - 1)
        if (np.array_equal(r, self.roi) and np.array_equal(g, self.handle_group) and n == self.n_groups
                and symmetry == self.symmetry):
            return False
        self.roi, self.handle_group, self.n_groups, self.symmetry = r.copy(), g.copy(), n, symmetry
        self._owner.selection_changed("recovered selection")
        return True

    def select(self, target: str, hits: np.ndarray, op: str) -> bool:
        """Apply hit-tested cage vertices ((c,) bool) to the ROI or the handle (replace / add / remove)."""
        return self.set_mask(target, combine(self.mask(target), hits, op))

    def clear(self, target: str) -> bool:
        """Empty the ROI or the active handle group; returns False when it was empty."""
        return self.set_mask(target, np.zeros(self._n_cage, dtype=bool), f"clear {target}")

    def clear_all(self) -> bool:
        """Empty the ROI and every handle group, back to one (empty) handle group, as one undo step;
        returns False when there was nothing to clear."""
        if not self.roi.any() and not self.all_handles.any():
            return False
        self.roi = np.zeros(self._n_cage, dtype=bool)
        self.handle_group = np.full(self._n_cage, NO_GROUP, dtype=np.int8)
        self.n_groups, self.active = 1, 0
        self._owner.reset_transforms()
        self._owner.selection_changed("clear selection")
        return True

    def invert(self, target: str) -> bool:
        """Invert the ROI or the active handle group (one undo step)."""
        return self.set_mask(target, ~self.mask(target), f"invert {target}")

    def select_all(self, target: str) -> bool:
        """Every cage vertex into the ROI or the active handle group; returns False when all were."""
        return self.set_mask(target, np.ones(self._n_cage, dtype=bool), f"select all {target}")

    def free_around_handles(self) -> int:
        """Free the held cage points around the handle groups where they touch (what :meth:`tearing`
        finds): the held points within the part's thickness of a touching handle point, along the cage,
        join the ROI, so that a band of free points lies between the handle and the held part. One undo
        step; returns how many points were freed (0: nothing touched).

        Mirror images follow with the mirror, as the rest of the selection does."""
        r = selection_roles(self.roi, self.handle_group)
        e = self._editor.cage_edges
        held = r == FIXED
        touching = touching_held(r, e)
        if not touching.any():
            return 0
        from scipy.sparse.csgraph import dijkstra

        reach = float(np.median(self.cage_thickness()[touching]))
        d = dijkstra(edge_graph(self._editor.cage.vertices, e), directed=False, indices=np.flatnonzero(touching),
                     min_only=True, limit=reach)
        band = held & (d <= reach)
        for x, y in ((e[:, 0], e[:, 1]), (e[:, 1], e[:, 0])):  # at least every held neighbour
            band[y[touching[x] & held[y]]] = True
        self.roi = self.roi | band
        self._owner.selection_changed("free around handle")
        return int(np.count_nonzero(band))

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
        self._owner.selection_changed(f"select {'ROI' if target == ROI else 'handle'}")
        return True

    # ------------------------------------------------------------------ the roles it gives
    def cage_roles(self) -> np.ndarray:
        """(c,) int8 role of each cage vertex (:mod:`hybridedit.deform.roles`): the engine's cage roles
        once it has the selection, else the masks'; mirror images included in both cases."""
        if self.engine_has_masks() and (self.roi.any() or self.all_handles.any()):
            roles = self._editor.cage_roles
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
            return np.zeros(self._editor.mesh.n_vertices, dtype=np.int8)
        if self.engine_has_masks():
            return self._editor.vertex_roles
        return self._preview()[0]

    def _engine_shape_roles(self) -> np.ndarray:
        """(n,) the shape-space roles the engine is given for the current masks (see
        :meth:`give_to_engine`)."""
        return self._editor.shape_roles(selection_roles(self.roi, self.handle_group))

    def _preview(self) -> tuple[np.ndarray, np.ndarray]:
        """(shape roles, cage roles) the engine will take for the current masks and mirror (cached)."""
        key = self.key()
        if self._preview_cache is None or self._preview_cache[0] != key:
            self._preview_cache = (key, self._editor.preview_roles(self._engine_shape_roles(), symmetry=self.symmetry))
        return self._preview_cache[1]

    def tearing_warning(self) -> str | None:
        """What to tell the user when a handle group touches held cage points (:meth:`tearing`, the group
        touching most), offering the fix (Free Around Handle, Shift+F); None when nothing would tear."""
        tears = self.tearing() if self.all_handles.any() and self.roi.any() else {}
        if not tears:
            return None
        g, n = max(tears.items(), key=lambda kv: kv[1])
        who = f"Handle group {g + 1}" if self.n_groups > 1 else "The handle"
        # (short enough for the window's status bar's two lines at its smallest width: never cut off)
        return (f"{who} touches {n} held cage point{'s' if n != 1 else ''}: a drag would tear the shape there. "
                "Shift+F frees the held points around it.")

    def tearing(self) -> dict[int, int]:
        """{handle group: cage points of the group that share a cage edge with a held (fixed) point}: with
        no free point between them, a drag stretches those edges and tears the shape there (the front of a
        limb taken as handle, its back left fixed). Mirror images count in their group; empty when none."""
        r = self.cage_roles()
        touching = touching_held(r, self._editor.cage_edges)
        return {int(group(g)): int(np.count_nonzero(touching & (r == g))) for g in unique_sorted(r[touching])}

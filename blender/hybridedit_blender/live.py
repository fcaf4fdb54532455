"""Following the Empties: a depsgraph handler runs one engine frame when an Empty moved and
writes the positions; a timer then settles the pose (HybridEditor.pose's rule) in slices of
at most 40 ms, so the viewport stays responsive. After an undo or redo, a session takes
what the mesh and the Empties hold as the pose its next drags start from."""

from __future__ import annotations

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import session as S
from .bind import SESSIONS

_busy = False  # our own write triggers a depsgraph update: ignore it


def empties_of(s: S.Session) -> dict[str, np.ndarray] | str:
    """Each handle's Empty world matrix now, or a one-line problem."""
    out = {}
    for h in s.handles:
        e = bpy.data.objects.get(h.empty)
        if e is None:
            return f"the Empty '{h.empty}' driving '{h.group}' is gone: Bind again"
        out[h.empty] = S.matrix_np(e.matrix_world)
    return out


def stop(s: S.Session, problem: str) -> None:
    """Stop following (the session is dropped) and say why in the status bar and the info log."""
    SESSIONS.pop(s.object_name, None)
    s.problem = problem
    obj = bpy.data.objects.get(s.object_name)
    if obj is not None:
        obj.hybrid_arap.bound = ""
        obj.hybrid_arap.problem = problem
    LAST_PROBLEMS.append(problem)
    if not bpy.app.timers.is_registered(_say):
        bpy.app.timers.register(_say, first_interval=0.0)


LAST_PROBLEMS: list[str] = []


def _say():
    while LAST_PROBLEMS:
        msg = LAST_PROBLEMS.pop(0)
        try:
            bpy.ops.hybrid_arap.report("EXEC_DEFAULT", message=msg, level="ERROR")
        except RuntimeError:
            print(f"Hybrid ARAP: {msg}")
    return None


def step(s: S.Session) -> bool:
    """One live frame for a session if its Empties moved; True when it wrote positions."""
    obj = bpy.data.objects.get(s.object_name)
    if obj is None or obj.type != "MESH":
        SESSIONS.pop(s.object_name, None)
        return False
    if s.needs_rebase:
        rebase(s, obj)
        return False
    if not obj.hybrid_arap.live:
        return False
    empties = empties_of(s)
    if isinstance(empties, str):
        stop(s, empties)
        return False
    T = s.transforms_from(S.matrix_np(obj.matrix_world), empties)
    if not s.changed(T):
        return False
    problem = s.mesh_changed(obj.data)
    if problem:
        stop(s, problem)
        return False
    s.live(obj.data, T)
    if not bpy.app.timers.is_registered(settle_tick):
        bpy.app.timers.register(settle_tick, first_interval=0.05)
    return True


@persistent
def on_depsgraph_update(scene, depsgraph):
    global _busy
    if _busy or not SESSIONS:
        return
    _busy = True
    try:
        for s in list(SESSIONS.values()):
            step(s)
    finally:
        _busy = False


def settle_tick():
    """Timer: settle every session whose pose is not converged; None when all are."""
    global _busy
    pending = False
    _busy = True
    try:
        for s in list(SESSIONS.values()):
            if s.settled:
                continue
            obj = bpy.data.objects.get(s.object_name)
            if obj is None:
                SESSIONS.pop(s.object_name, None)
                continue
            if not s.settle(obj.data):
                pending = True
    finally:
        _busy = False
    return 0.02 if pending else None


@persistent
def before_undo_redo(scene, *args):
    """The undo restores the Empties before undo_post: no live frame may run in between."""
    global _busy
    _busy = True


@persistent
def on_undo_redo(scene, *args):
    """Undo / redo restored the mesh and the Empties together: the next depsgraph update (when the
    Empties' matrices are evaluated) takes them as the pose the next drags start from."""
    global _busy
    for s in list(SESSIONS.values()):
        obj = bpy.data.objects.get(s.object_name)
        if obj is None or obj.type != "MESH" or not obj.hybrid_arap.bound:
            SESSIONS.pop(s.object_name, None)  # undone past its Bind
        else:
            s.needs_rebase = True
    _busy = False
    bpy.context.view_layer.update()


def rebase(s: S.Session, obj) -> None:
    s.needs_rebase = False
    if S.topology_counts(obj.data) != s.counts:
        stop(s, f"'{s.object_name}' changed since Bind: Bind again")
        return
    empties = empties_of(s)
    if isinstance(empties, str):
        stop(s, empties)
        return
    now = S.read_positions(obj.data)
    T = s.transforms_from(S.matrix_np(obj.matrix_world), empties)
    if np.array_equal(now, s.buf) and not s.changed(T):
        return
    try:
        s.rebase(now, empties)
    except S.BindError as e:
        stop(s, str(e))
        return
    s.last_transforms = s.transforms_from(S.matrix_np(obj.matrix_world), empties)


@persistent
def on_load(*args):
    SESSIONS.clear()  # bindings live in memory (and in the on-disk cache): Bind again after opening a file


def register():
    bpy.app.handlers.depsgraph_update_post.append(on_depsgraph_update)
    bpy.app.handlers.undo_pre.append(before_undo_redo)
    bpy.app.handlers.redo_pre.append(before_undo_redo)
    bpy.app.handlers.undo_post.append(on_undo_redo)
    bpy.app.handlers.redo_post.append(on_undo_redo)
    bpy.app.handlers.load_pre.append(on_load)


def unregister():
    for lst, fn in ((bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
                    (bpy.app.handlers.undo_post, on_undo_redo), (bpy.app.handlers.redo_post, on_undo_redo),
                    (bpy.app.handlers.undo_pre, before_undo_redo), (bpy.app.handlers.redo_pre, before_undo_redo),
                    (bpy.app.handlers.load_pre, on_load)):
        while fn in lst:
            lst.remove(fn)
    if bpy.app.timers.is_registered(settle_tick):
        bpy.app.timers.unregister(settle_tick)
    SESSIONS.clear()

"""Following the Empties.

- A ``depsgraph_update_post`` handler runs one engine frame when an Empty moved (a live frame)
  and writes the pose key; once the Empty is still, a worker thread converges the pose on the
  cage alone (HybridEditor.converge: the mesh is propagated and written once, not every
  iteration) while Blender's main thread stays free, and a timer writes it with the progress
  in the status bar.
- A ``frame_change_post`` handler (the viewport's frame changes and every frame a render
  evaluates) solves each frame from the base pose to that frame's Empty matrices, converged
  (``converge(start="base")``), so a frame gives the same pose bit for bit whatever frames came
  before; poses are cached by transforms.
- After an undo or redo the pose key is solved again for the Empties undo restored (from the
  cache when it was settled before): an unconverged pose is never kept.
- After opening a .blend, bound objects are bound again in the background (their rest is the
  shape-key mix without the pose key, so the original rest is kept); the pose the file holds is
  shown meanwhile.
- In Edit Mode nothing is written (Blender would discard it on leaving); the pose follows when
  the object is back in Object Mode, after a full check that the mesh was not edited.
"""

from __future__ import annotations

import contextlib
import threading
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import session as S
from .bind import SESSIONS, BindJob

_busy = False  # our own writes (and an undo in progress) trigger depsgraph updates: ignore them
_object_count = -1
LAST_PROBLEMS: list[tuple[str, str]] = []  # (level, message) waiting for the report timer
BACKGROUND_BINDS: list[tuple[BindJob, threading.Thread]] = []


@contextlib.contextmanager
def own_writes():
    """Inside: the depsgraph updates our own writes trigger are ignored (``_busy``), restored after."""
    global _busy
    was, _busy = _busy, True
    try:
        yield
    finally:
        _busy = was


# ------------------------------------------------------------------ messages
def say(message: str, level: str = "ERROR") -> None:
    """One line in the status bar's report and the Info log (from a timer: handlers cannot report)."""
    LAST_PROBLEMS.append((level, message))
    if not bpy.app.timers.is_registered(_say):
        bpy.app.timers.register(_say, first_interval=0.0)


def _say():
    while LAST_PROBLEMS:
        level, msg = LAST_PROBLEMS.pop(0)
        try:
            bpy.ops.hybrid_arap.report("EXEC_DEFAULT", message=msg, level=level)
        except RuntimeError:
            print(f"Hybrid ARAP: {msg}")
    return None


def status(text: str | None) -> None:
    """The status bar's text in every window (none in background mode)."""
    wm = bpy.context.window_manager
    for w in getattr(wm, "windows", ()):
        try:
            w.workspace.status_text_set(text)
        except (AttributeError, RuntimeError):
            pass


def stop(s: S.Session, problem: str) -> None:
    """Stop following (the session is dropped; the pose key stays as it is) and say why."""
    stop_worker(s)
    SESSIONS.pop(s.uid, None)
    s.problem = problem
    obj = object_of(s, drop=False)
    if obj is not None:
        obj.hybrid_arap.bound = ""
        obj.hybrid_arap.problem = problem
    say(problem)


# ------------------------------------------------------------------ finding things
def object_of(s: S.Session, drop: bool = True):
    """The session's object, found again by its uid after a rename; None (and the session dropped)
    when it is gone."""
    obj = bpy.data.objects.get(s.object_name)
    if obj is not None and obj.type == "MESH" and obj.hybrid_arap.uid == s.uid:
        return obj
    for o in bpy.data.objects:
        if o.type == "MESH" and o.hybrid_arap.uid == s.uid:
            s.object_name = o.name  # renamed
            return o
    if drop:
        stop_worker(s)
        SESSIONS.pop(s.uid, None)
    return None


def transforms_now(s: S.Session, obj, depsgraph=None) -> dict | str:
    """Each group's engine transform from its Empty now (evaluated in ``depsgraph`` when given:
    a render's), or a one-line problem."""
    st = obj.hybrid_arap
    if [h.group for h in st.handles] != s.groups:
        return f"the handles of '{obj.name}' changed since Bind: Bind again"
    E, E0 = [], []
    for h in st.handles:
        e = h.empty
        if e is None or e.name not in bpy.data.objects:
            return f"the Empty driving '{h.group}' of '{obj.name}' is gone: Bind again"
        if depsgraph is not None:
            e = e.evaluated_get(depsgraph)
        E.append(S.matrix_np(e.matrix_world))
        r = S.matrix_np(h.rest)
        if r[3, 3] != 1.0:
            return f"the handle '{h.group}' of '{obj.name}' has no rest: Bind again"
        E0.append(r)
    o = obj.evaluated_get(depsgraph) if depsgraph is not None else obj
    return s.engine_transforms(S.matrix_np(o.matrix_world), E, E0)


# ------------------------------------------------------------------ the worker
def stop_worker(s: S.Session) -> None:
    """Cancel the session's worker and wait for it (at most one engine frame)."""
    s.settle_due = 0.0
    t = s.thread
    if t is not None:
        s.cancel.set()
        t.join()
        s.thread = None
    s.busy = ""


def _run(s: S.Session, cancel: threading.Event, work) -> None:
    try:
        work(cancel)
    except Exception as e:  # noqa: BLE001 -- said in one line by the timer
        s.problem = f"'{s.object_name}': {s.busy or 'working'} failed: {type(e).__name__}: {e}".splitlines()[0]


def start_worker(s: S.Session, busy: str, work) -> None:
    """Run ``work(cancel)`` on a thread (it takes S.ENGINE for each engine call); the tick timer
    writes what it leaves in the buffer and says the progress."""
    stop_worker(s)
    s.cancel = threading.Event()
    s.busy = busy
    s.progress = 0.0
    s.problem = ""
    s.thread = threading.Thread(target=_run, args=(s, s.cancel, work), name="hybridedit-" + busy.split()[0],
                                daemon=True)
    s.thread.start()
    if not bpy.app.timers.is_registered(tick):
        bpy.app.timers.register(tick, first_interval=0.1, persistent=True)


def _converge_async(s: S.Session, converge) -> None:
    """``converge(cancel)`` (a Session method's converge) on the worker, holding the engine."""

    def work(cancel):
        with S.ENGINE:
            if not cancel.is_set():
                converge(cancel)

    start_worker(s, "settling", work)


def settle_async(s: S.Session) -> None:
    """Converge the pose at the last transforms from where the live frames left it: the cage's
    iterations alone (HybridEditor.converge), the shape propagated and written once."""
    T = {g: M.copy() for g, M in s.last_transforms.items()}
    _converge_async(s, lambda cancel: s.settle(T, cancel))


def solve_async(s: S.Session, T: dict) -> None:
    """The converged pose for T from the base pose (or the cache), on the worker."""
    _converge_async(s, lambda cancel: s.solve(T, cancel))


def _say_note(s: S.Session) -> None:
    """The session's warning (a converge that reached its cap), once."""
    if s.note:
        say(s.note, "WARNING")
        s.note = ""


def _write_if_dirty(s: S.Session, obj) -> None:
    if s.dirty and obj is not None and obj.mode != "EDIT":
        with own_writes(), S.ENGINE:
            s.write(obj)


def tick():
    """Timer: write what the workers computed, say their progress; stops when none is left."""
    working, waiting = [], False
    for s in list(SESSIONS.values()):
        obj = object_of(s)
        if obj is None:
            continue
        if s.settle_due and time.monotonic() >= s.settle_due and s.thread is None:
            s.settle_due = 0.0
            settle_async(s)
        elif s.settle_due:
            waiting = True
        alive = s.thread is not None and s.thread.is_alive()
        _write_if_dirty(s, obj)
        if alive:
            working.append(f"{s.busy} '{s.object_name}' {int(100 * s.progress)}%")
        elif s.thread is not None:
            s.thread.join()
            s.thread, s.busy = None, ""
            if s.problem:
                stop(s, s.problem)
            else:
                _say_note(s)
    _poll_binds()
    if BACKGROUND_BINDS:
        working += [job.status() for job, _ in BACKGROUND_BINDS]
    status("Hybrid ARAP: " + "; ".join(w.replace("Hybrid ARAP: ", "") for w in working) if working else None)
    return 0.1 if working or waiting else None


def finish(s: S.Session | None = None) -> None:
    """Wait for the workers (of ``s``, or of every session) and the background binds, and write
    their result (Settle, Apply, a save and the tests use it)."""
    for job, t in list(BACKGROUND_BINDS):
        t.join()
    _poll_binds()
    for x in ([s] if s is not None else list(SESSIONS.values())):
        if x.settle_due and x.thread is None:
            settle_async(x)
        x.settle_due = 0.0
        if x.thread is not None:
            x.thread.join()
            x.thread, x.busy = None, ""
        obj = object_of(x)
        if x.problem and x.uid in SESSIONS:
            stop(x, x.problem)
            continue
        _say_note(x)
        _write_if_dirty(x, obj)
    status(None)


# ------------------------------------------------------------------ live frames
def catch_up(s: S.Session, obj) -> None:
    """After a bind: the Empties where they are now. A fresh bind starts at rest; a binding restored
    (reopened, bound again) solves the pose for the Empties' matrices now on the worker."""
    T = transforms_now(s, obj)
    if isinstance(T, str):
        stop(s, T)
        return
    if all(np.allclose(M, np.eye(4), rtol=0, atol=1e-12) for M in T.values()):
        s.last_transforms = T
        return
    solve_async(s, T)


def step(s: S.Session) -> bool:
    """One live frame for a session if its Empties moved; True when it wrote the pose."""
    obj = object_of(s)
    if obj is None:
        return False
    st = obj.hybrid_arap
    if s.needs_restore:
        restore(s, obj)
        return False
    if s.busy and not s.busy.startswith("settling"):
        return False  # preparing the next pose (after Apply): the move is taken when it is ready
    if not st.live:
        return False
    T = transforms_now(s, obj)
    if isinstance(T, str):
        stop(s, T)
        return False
    if not s.changed(T):
        return False
    if obj.mode == "EDIT":
        if "edit" not in s.said:
            s.said.add("edit")
            say(f"'{obj.name}' is in Edit Mode: its pose follows the Empties when you leave Edit Mode", "WARNING")
        return False
    s.said.discard("edit")
    stop_worker(s)
    problem = s.edited(obj)
    if problem:
        stop(s, problem)
        return False
    if not S.ENGINE.acquire(timeout=0.05):  # a bind holds the engine: try again shortly
        if not bpy.app.timers.is_registered(_retry):
            bpy.app.timers.register(_retry, first_interval=0.2)
        return False
    try:
        s.live_frame(T)
        s.write(obj)
    finally:
        S.ENGINE.release()
    if not s.settled:
        # settle once the Empty has been still for a moment: while it moves, every live frame would
        # first wait for the worker's frame in progress
        s.settle_due = time.monotonic() + SETTLE_DELAY
        if not bpy.app.timers.is_registered(tick):
            bpy.app.timers.register(tick, first_interval=0.1, persistent=True)
    return True


#: seconds an Empty stays still before the worker settles its pose
SETTLE_DELAY = 0.15


def _retry():
    on_depsgraph_update(bpy.context.scene, None)
    return None


def _check_copies() -> None:
    """A duplicated bound object shares its uid: the copy is told it is not bound (its pose stays in
    its shape key)."""
    global _object_count
    if len(bpy.data.objects) == _object_count:
        return
    _object_count = len(bpy.data.objects)
    for s in list(SESSIONS.values()):
        copies = [o for o in bpy.data.objects if o.type == "MESH" and o.hybrid_arap.uid == s.uid]
        if len(copies) < 2:
            continue
        original = next((o for o in copies if o.name == s.object_name), copies[0])
        for o in copies:
            if o is original:
                continue
            o.hybrid_arap.uid = ""
            o.hybrid_arap.bound = ""
            msg = (f"'{o.name}' is a copy of the bound '{original.name}': it keeps its pose as the '{S.KEY}' "
                   "shape key and is not bound; Bind it to pose it")
            o.hybrid_arap.problem = msg
            say(msg, "WARNING")


@persistent
def on_depsgraph_update(scene, depsgraph):
    if _busy or not SESSIONS:
        return
    with own_writes():
        _check_copies()
        for s in list(SESSIONS.values()):
            step(s)


# ------------------------------------------------------------------ animation and renders
def pose_frame(s: S.Session, obj, depsgraph) -> bool:
    """The converged pose for the Empties' matrices of this frame (cached by transforms); True when
    it wrote the pose key."""
    if not obj.hybrid_arap.live or obj.mode == "EDIT" or s.needs_restore or (s.busy and not s.busy.startswith("settling")):
        return False
    T = transforms_now(s, obj, depsgraph)
    if isinstance(T, str):
        stop(s, T)
        return False
    if not s.changed(T) and s.settled and s.thread is None:
        return False
    stop_worker(s)
    problem = s.edited(obj)
    if problem:
        stop(s, problem)
        return False
    with S.ENGINE:
        s.solve(T)
        s.write(obj)
    _say_note(s)
    return True


@persistent
def on_frame_change(scene, depsgraph=None):
    """Every frame the viewport or a render evaluates (Blender evaluates again what this tags)."""
    if not SESSIONS:
        return
    with own_writes():
        for s in list(SESSIONS.values()):
            obj = object_of(s)
            if obj is not None and scene.objects.get(obj.name) is not None:
                pose_frame(s, obj, depsgraph)


# ------------------------------------------------------------------ undo, redo
@persistent
def before_undo_redo(scene, *args):
    """No worker may write while undo restores the data; no live frame may run in between."""
    global _busy
    _busy = True
    for s in SESSIONS.values():
        stop_worker(s)


@persistent
def on_undo_redo(scene, *args):
    """Undo / redo restored the pose key, the Empties and the handles' rests together: the pose key
    is solved again for them (the cache has it when it was settled), so an unconverged pose is
    never kept."""
    global _busy
    _busy = False
    for s in list(SESSIONS.values()):
        s.needs_restore = True
    # the restored Empties' matrices are evaluated by the next depsgraph update (before it they may
    # read as the identity): restore() runs from there (step), or here after it
    bpy.context.view_layer.update()
    for s in list(SESSIONS.values()):
        if s.needs_restore:
            obj = object_of(s)
            if obj is not None:
                restore(s, obj)


def restore(s: S.Session, obj) -> None:
    s.needs_restore = False
    st = obj.hybrid_arap
    if not st.bound or st.uid != s.uid:
        stop_worker(s)
        SESSIONS.pop(s.uid, None)  # undone past its Bind
        return
    if st.bound != s.base.digest:  # undone past an Apply (or redone)
        base = s.bases.get(st.bound)
        if base is None or base.state is None:
            stop(s, f"'{obj.name}': undo went back to a binding that is gone: Bind again")
            return
        with S.ENGINE:
            s.base = base
            s.editor.restore_state(base.state)
            s._set_offset()
    if obj.mode == "EDIT":
        return
    if S.topology_counts(obj.data) != s.counts:
        stop(s, f"'{obj.name}' changed since Bind: Bind again")
        return
    keys = obj.data.shape_keys
    basis = S.read_key(keys.reference_key, s.n) if keys is not None else S.read_positions(obj.data)
    if not np.array_equal(basis, s.base.basis32):
        stop(s, f"'{obj.name}': undo restored a mesh that is not the one bound: Bind again")
        return
    T = transforms_now(s, obj)
    if isinstance(T, str):
        stop(s, T)
        return
    kb = S.pose_key(obj)
    if kb is not None:
        s.buf = S.read_key(kb, s.n)  # what undo restored, until the solve replaces it
        s.written = s.buf.copy()
    with own_writes(), S.ENGINE:
        hit = s.from_cache(T)
        if hit:
            s.write(obj)
    if not hit:
        solve_async(s, T)


# ------------------------------------------------------------------ files
@persistent
def on_save(*args):
    """The file gets the converged pose, not a slice of a settle."""
    finish()


@persistent
def on_load_pre(*args):
    for s in list(SESSIONS.values()):
        stop_worker(s)
    SESSIONS.clear()
    for job, t in BACKGROUND_BINDS:
        job.cancel.set()
    BACKGROUND_BINDS.clear()


@persistent
def on_load_post(*args):
    """Bound objects in the file are bound again in the background (from the binding cache when the
    mesh was bound on this machine), their rest checked against the one they were bound with."""
    global _object_count
    _object_count = -1
    for obj in bpy.data.objects:
        if obj.type != "MESH" or not obj.hybrid_arap.bound:
            continue
        try:
            job = BindJob(obj)
        except S.BindError as e:
            obj.hybrid_arap.problem = str(e)
            say(f"{e} (bound in this file: Bind again)")
            continue
        if job.digest != obj.hybrid_arap.bound:
            msg = (f"'{obj.name}' is not the mesh that was bound (its rest changed outside the add-on): "
                   "its pose stays in its shape key; Bind again")
            obj.hybrid_arap.bound = ""
            obj.hybrid_arap.problem = msg
            say(msg)
            continue
        t = threading.Thread(target=job.run, name="hybridedit-rebind", daemon=True)
        t.start()
        BACKGROUND_BINDS.append((job, t))
    if BACKGROUND_BINDS and not bpy.app.timers.is_registered(tick):
        bpy.app.timers.register(tick, first_interval=0.1, persistent=True)


def _poll_binds() -> None:
    for job, t in list(BACKGROUND_BINDS):
        if t.is_alive():
            continue
        BACKGROUND_BINDS.remove((job, t))
        kind, line = job.install()
        say(line.replace("Hybrid ARAP: ", "").replace("bound '", "bound again '", 1),
            "INFO" if kind == {"INFO"} else next(iter(kind)))


# ------------------------------------------------------------------ registration
_HANDLERS = (("depsgraph_update_post", on_depsgraph_update), ("frame_change_post", on_frame_change),
             ("undo_pre", before_undo_redo), ("redo_pre", before_undo_redo), ("undo_post", on_undo_redo),
             ("redo_post", on_undo_redo), ("save_pre", on_save), ("load_pre", on_load_pre),
             ("load_post", on_load_post))


def register():
    for name, fn in _HANDLERS:
        getattr(bpy.app.handlers, name).append(fn)


def unregister():
    for name, fn in _HANDLERS:
        lst = getattr(bpy.app.handlers, name)
        while fn in lst:
            lst.remove(fn)
    for t in (tick, _say, _retry):
        if bpy.app.timers.is_registered(t):
            bpy.app.timers.unregister(t)
    for s in list(SESSIONS.values()):
        stop_worker(s)
    SESSIONS.clear()

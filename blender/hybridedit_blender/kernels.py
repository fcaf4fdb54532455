"""The engine's kernels compiled in the background from the moment the extension is enabled.

:func:`start` (from ``register``) runs :mod:`.precompile` in a process of its own, unless numba's
cache folder holds its stamp for these sources (:func:`ready`): Blender's own Python, Blender's
import path, the extension's ``NUMBA_CACHE_DIR``, so that Blender's process then loads every kernel
from that folder instead of compiling it. A timer shows its progress in the status bar; a Bind
started meanwhile waits for it (:func:`wait`) with its progress, and does not compile the same
kernels beside it. A compile that fails or is killed leaves everything as without it: the first
Bind compiles what it needs itself, and one line says so.

Where the zip ships kernels compiled for any CPU of the platform (:mod:`.portable_kernels`), the
sessions before the compile has finished use those: a Bind does not wait, and the compile goes on
for this machine's CPU, into :data:`NATIVE_DIR`.

Disabling the extension does not stop it (a factory-settings reload disables and enables again):
it ends with Blender (its stdin closes).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time

from . import portable_kernels, precompile

#: the compile running or last run in this Blender (None: none was needed)
CURRENT: "Compile | None" = None
#: numba's cache folder for the kernels compiled for this CPU (set at enabling; None: the environment's)
NATIVE_DIR: str | None = None

#: a compile that printed nothing for this long is taken as hung: killed, and Bind compiles itself
#: (one kernel takes seconds to a minute on a busy machine; the progress moves with each)
STALL_SECONDS = 600.0

#: names of CPython interpreters (python, python3.11, python.exe): only these are started with a
#: script (as hybridedit.cage.qem's helper: Blender's own binary never is)
_PYTHON_NAME = re.compile(r"python(\d+(\.\d+)*)?[dmtw]*(\.exe)?", re.IGNORECASE)


def python() -> str | None:
    """Blender's Python interpreter (``sys.executable`` since Blender 2.91), or None."""
    exe = sys.executable or ""
    names = {os.path.basename(exe), os.path.basename(os.path.realpath(exe))}
    ok = os.path.isfile(exe) and os.access(exe, os.X_OK) and any(_PYTHON_NAME.fullmatch(n) for n in names)
    return exe if ok else None


def native_dir() -> str | None:
    """numba's cache folder for the kernels compiled for this CPU."""
    return NATIVE_DIR or os.environ.get("NUMBA_CACHE_DIR")


def native_ready(cache_dir: str | None = None) -> bool:
    """The cache folder (default :func:`native_dir`) holds every kernel compiled for this CPU for
    these sources (the stamp of a finished compile)."""
    cache_dir = cache_dir or native_dir()
    path = precompile.stamp_path(cache_dir) if cache_dir else None
    return path is not None and os.path.isfile(path)


def ready() -> bool:
    """A Bind has every kernel to load: the portable ones are in use, or the compile finished."""
    return portable_kernels.IN_USE is not None or native_ready()


class Compile:
    """One :mod:`.precompile` process: its progress (``fraction``, ``stage``) read from its output on
    a thread, its log in ``log_path``, ``done`` set when it ended (``returncode``)."""

    def __init__(self, command: list[str], *, cache_dir: str, log_path: str) -> None:
        self.cache_dir, self.log_path = cache_dir, log_path
        self.fraction, self.stage = 0.0, "starting"
        self.started, self.seconds = time.monotonic(), 0.0
        self.heard = self.started  # when it last printed a line
        self.returncode: int | None = None
        self.done = threading.Event()
        self.waiting = 0  # Binds waiting for it (they show its progress themselves)
        self.said = False
        env = portable_kernels.child_environment(dict(os.environ))  # (compiled for this CPU)
        env["NUMBA_CACHE_DIR"] = cache_dir
        paths = [p for p in sys.path if p and os.path.exists(p)]
        old = env.get("PYTHONPATH")
        env["PYTHONPATH"] = os.pathsep.join(paths + ([old] if old else []))
        flags = 0
        if sys.platform == "win32":  # no console window; below Blender's priority (POSIX: nice 5, itself)
            flags = subprocess.CREATE_NO_WINDOW | subprocess.BELOW_NORMAL_PRIORITY_CLASS
        self._log = open(log_path, "w", encoding="utf-8")  # noqa: SIM115 -- closed when it ends
        try:
            self.proc = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
                                         env=env, text=True, encoding="utf-8", errors="replace",
                                         creationflags=flags)
        except OSError:
            self._log.close()
            raise
        threading.Thread(target=self._read, name="hybridedit-precompile", daemon=True).start()

    def _read(self) -> None:
        try:
            for line in self.proc.stdout:
                self.heard = time.monotonic()
                parts = line.split(" ", 2)
                if len(parts) == 3 and parts[0] == "progress":
                    try:
                        self.fraction = float(parts[1])
                    except ValueError:
                        continue
                    self.stage = parts[2].strip()
        except (OSError, ValueError):
            pass
        finally:  # (whatever happened, a waiting Bind goes on)
            self.returncode = self.proc.wait()
            self.seconds = time.monotonic() - self.started
            self._log.close()
            self.done.set()

    @property
    def running(self) -> bool:
        return not self.done.is_set()

    @property
    def ok(self) -> bool:
        return self.done.is_set() and self.returncode == 0

    def wait(self, progress=None, *, poll: float = 0.1) -> None:
        """Until it ends; ``progress(stage, fraction)`` every ``poll`` seconds meanwhile (it may raise
        to stop waiting: a cancelled Bind)."""
        self.waiting += 1
        try:
            while not self.done.is_set():
                if progress is not None:
                    progress("waiting for the engine's kernels, compiled in the background", self.fraction)
                if time.monotonic() - self.heard > STALL_SECONDS:
                    self.kill()  # hung: the Bind compiles what it needs itself
                self.done.wait(poll)
        finally:
            self.waiting -= 1

    def kill(self) -> None:
        """End it now (tests; a compile that must not go on)."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.done.wait()

    def status(self) -> str:
        if portable_kernels.IN_USE is not None:
            return (f"Hybrid ARAP: compiling the engine for this CPU in the background (once after installing): "
                    f"{int(100 * self.fraction)}%; used from the next start")
        return (f"Hybrid ARAP: compiling the engine in the background (once after installing): "
                f"{int(100 * self.fraction)}%; Bind waits for it")

    def outcome(self) -> tuple[str, str]:
        """(level, line) once it ended."""
        if self.ok and portable_kernels.IN_USE is not None:
            return "INFO", (f"the engine is compiled for this CPU ({self.seconds:.0f} s in the background): "
                            "used from the next start of Blender")
        if self.ok:
            return "INFO", f"the engine is compiled ({self.seconds:.0f} s in the background): Bind is quick now"
        code = self.returncode
        how = f"was killed (signal {-code})" if code < 0 else f"failed (exit code {code})"
        if portable_kernels.IN_USE is not None:
            return "WARNING", (f"compiling the engine for this CPU in the background {how}, see {self.log_path}: "
                               "the portable kernels go on serving")
        return "WARNING", (f"compiling the engine in the background {how}, see {self.log_path}: the first Bind "
                           "compiles it instead (a minute or two)")


def start(*, command: list[str] | None = None) -> Compile | None:
    """Start the background compile unless the kernels are ready or it runs already; returns it
    (None when there is nothing to do or no Python to run it with). ``command`` replaces the
    process (tests)."""
    global CURRENT
    cache_dir = native_dir()
    if not cache_dir:
        return None
    if CURRENT is not None and CURRENT.running:
        return CURRENT
    if command is None:
        if native_ready(cache_dir):
            return None
        exe = python()
        if exe is None:
            return None  # (an embedded Python with no interpreter to start: the first Bind compiles)
        command = [exe, "-s", os.path.join(os.path.dirname(os.path.abspath(__file__)), "precompile.py")]
    os.makedirs(cache_dir, exist_ok=True)
    try:
        CURRENT = Compile(command, cache_dir=cache_dir, log_path=os.path.join(cache_dir, "hybrid-arap-precompile.log"))
    except OSError as e:
        print(f"Hybrid ARAP: the background compile could not start ({e}): the first Bind compiles the engine")
        CURRENT = None
        return None
    _watch()
    return CURRENT


def wait(progress=None) -> None:
    """Until the background compile ends (at once when none runs, or the portable kernels serve): a
    Bind calls it before it touches the engine, so that it loads the kernels the compile writes
    instead of compiling them."""
    c = CURRENT
    if c is not None and c.running and portable_kernels.IN_USE is None:
        c.wait(progress)


def must_wait() -> bool:
    """A Bind now would wait for the background compile (:func:`wait`)."""
    return running() is not None and portable_kernels.IN_USE is None


def running() -> Compile | None:
    c = CURRENT
    return c if c is not None and c.running else None


# ------------------------------------------------------------------ the status bar
def _watch() -> None:
    import bpy

    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=0.5, persistent=True)


def _tick():
    """Timer: the progress in the status bar (unless a Bind shows it), then one line when it ends."""
    from . import live

    c = CURRENT
    if c is None:
        return None
    if c.running:
        if not c.waiting:
            live.status(c.status())
        _redraw_panels()
        return 0.5
    if not c.said:
        c.said = True
        live.status(None)
        level, line = c.outcome()
        live.say(line, level)
        _redraw_panels()
    return None


def _redraw_panels() -> None:
    import bpy

    for w in getattr(bpy.context.window_manager, "windows", ()):
        for area in w.screen.areas if w.screen else ():
            if area.type == "VIEW_3D":
                area.tag_redraw()

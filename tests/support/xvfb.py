"""A private virtual X server (Xvfb) for the window tests and benchmarks on a machine with no display.

The tests import it as ``support.xvfb`` (tests/ is on their path); the window benchmarks put tests/ on
``sys.path`` first.
"""

from __future__ import annotations

import ctypes
import os
import shutil
import signal
import subprocess
import sys


def _end_with_parent() -> None:
    """In the child before exec: the kernel stops Xvfb when the process that started it ends
    (after Qt has closed its connection; stopping it earlier makes Qt exit with an X I/O error)."""
    if sys.platform.startswith("linux"):
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass


class VirtualDisplay:
    """Xvfb on a display number it picks itself (``-displayfd``); it ends with this process
    (or at :meth:`stop`, once no window uses it any more).

    Attributes
    ----------
    display : ":N" on success, else "".
    problem : why it could not start (empty on success).
    """

    def __init__(self, screen: str = "1920x1200x24") -> None:
        self.proc: subprocess.Popen | None = None
        self.display = ""
        self.problem = ""
        exe = shutil.which("Xvfb")
        if exe is None:
            self.problem = "Xvfb is not installed (apt-get install xvfb, or run scripts/setup.sh test)"
            return
        r, w = os.pipe()
        try:
            proc = subprocess.Popen([exe, "-displayfd", str(w), "-screen", "0", screen, "-nolisten", "tcp"],
                                    pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                    preexec_fn=_end_with_parent)
        finally:
            os.close(w)
        data = b""
        with os.fdopen(r, "rb") as fh:
            while not data.endswith(b"\n"):
                chunk = fh.read(1)
                if not chunk:
                    break
                data += chunk
        if not data.strip().isdigit():
            proc.kill()
            proc.wait()
            self.problem = "Xvfb did not start"
            return
        self.proc = proc
        self.display = f":{int(data)}"

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
            self.proc = None


def ensure_display(screen: str = "1920x1200x24") -> VirtualDisplay | None:
    """With no DISPLAY, start Xvfb and export DISPLAY (returns it; check ``problem``); else None."""
    if os.environ.get("DISPLAY"):
        return None
    vd = VirtualDisplay(screen)
    if vd.display:
        os.environ["DISPLAY"] = vd.display
    return vd

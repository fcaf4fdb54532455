"""The editor window tests run on a real X server: Xvfb is started here when DISPLAY is unset.

Xvfb picks a free display itself (-displayfd) and is stopped when the test
session ends. Qt uses its xcb platform (VTK renders through GLX).
"""

from __future__ import annotations

import atexit
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

_XVFB: subprocess.Popen | None = None
_XVFB_PROBLEM = ""


def _start_xvfb() -> None:
    """Start Xvfb on a free display and export DISPLAY; remember why not on failure."""
    global _XVFB, _XVFB_PROBLEM
    exe = shutil.which("Xvfb")
    if exe is None:
        _XVFB_PROBLEM = "Xvfb is not installed (apt-get install xvfb, or run scripts/setup.sh test)"
        return
    r, w = os.pipe()
    try:
        proc = subprocess.Popen(
            [exe, "-displayfd", str(w), "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
            pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
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
        _XVFB_PROBLEM = "Xvfb did not start"
        return
    _XVFB = proc
    os.environ["DISPLAY"] = f":{int(data)}"
    atexit.register(_stop_xvfb)


def _stop_xvfb() -> None:
    global _XVFB
    if _XVFB is not None:
        _XVFB.terminate()
        try:
            _XVFB.wait(5)
        except subprocess.TimeoutExpired:
            _XVFB.kill()
            _XVFB.wait()
        _XVFB = None


if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    _start_xvfb()
os.environ["QT_QPA_PLATFORM"] = "xcb"


def pytest_unconfigure(config) -> None:  # noqa: ARG001
    _stop_xvfb()


@pytest.fixture(scope="session", autouse=True)
def _display() -> None:
    if not os.environ.get("DISPLAY"):
        pytest.skip(f"no X display for the window tests: {_XVFB_PROBLEM or 'DISPLAY is unset'}")


# ---------------------------------------------------------------------------- test shapes


def capsule_blob(subdivisions: int = 4):
    """A closed, bumpy capsule about 4 long along X, 2.5K vertices at subdivision 4."""
    import trimesh

    from hybridedit.mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = np.asarray(s.vertices).copy()
    x, y, z = v.T
    r = 1.0 + 0.06 * np.sin(6 * x) * np.cos(4 * y) + 0.04 * np.sin(9 * z)
    v *= r[:, None]
    v[:, 0] *= 2.0
    v[:, 1] += 0.15 * np.cos(1.2 * v[:, 0])
    return Mesh(v, np.asarray(s.faces), name="blob")


@pytest.fixture(scope="session")
def make_blob():
    """The test shape generator: ``make_blob(subdivisions)``."""
    return capsule_blob


@pytest.fixture(scope="session")
def blob_file(tmp_path_factory) -> Path:
    """The test shape written to an OBJ file (exact %.17g coordinates)."""
    from hybridedit.io import write_mesh

    p = tmp_path_factory.mktemp("meshes") / "blob.obj"
    write_mesh(p, capsule_blob())
    return p

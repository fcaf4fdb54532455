"""The editor window tests run on a real X server: Xvfb is started here when DISPLAY is unset.

Xvfb picks a free display itself (-displayfd) and ends with the test process. Qt uses its xcb platform (VTK renders through GLX).

The fixtures the window tests share: the test shapes, the window with one loaded (``win``), a session
without a window, and a build held at its binding stage (``gate``). Driving the window with the mouse
and the keyboard is :mod:`support.window_driving`'s.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from shapes import capsule_blob
from support.window_driving import CAGE, opened_window
from support.xvfb import ensure_display

_XVFB = ensure_display("1280x1024x24") if sys.platform.startswith("linux") else None
_XVFB_PROBLEM = _XVFB.problem if _XVFB is not None else ""
os.environ["QT_QPA_PLATFORM"] = "xcb"


_EXIT_STATUS = [0]


def pytest_sessionfinish(session, exitstatus) -> None:
    _EXIT_STATUS[0] = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config) -> None:
    """Once pytest has reported everything, end the process with its status without the
    interpreter's teardown of Qt and VTK (see hybridedit.viewer.shutdown)."""
    from hybridedit.viewer.shutdown import leave, uses_window

    if uses_window():
        leave(_EXIT_STATUS[0])


@pytest.fixture(scope="session", autouse=True)
def _display() -> None:
    if not os.environ.get("DISPLAY"):
        pytest.skip(f"no X display for the window tests: {_XVFB_PROBLEM or 'DISPLAY is unset'}")


# ---------------------------------------------------------------------------- test shapes


@pytest.fixture(scope="session")
def make_blob():
    """The test shape generator: ``make_blob(subdivisions)``."""
    return capsule_blob


@pytest.fixture(scope="session")
def blob_file(tmp_path_factory) -> Path:
    """The test shape written to an OBJ file (exact %.17g coordinates)."""
    from hybridedit.fileio.meshfiles import write_mesh

    p = tmp_path_factory.mktemp("meshes") / "blob.obj"
    write_mesh(p, capsule_blob())
    return p


def symmetric_capsule(subdivisions: int = 4):
    """A bumpy capsule along X, its own mirror image across x = 0."""
    import trimesh

    from hybridedit.core.mesh import Mesh

    t = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = np.asarray(t.vertices).copy()
    x, y, z = v.T
    v *= (1.0 + 0.06 * np.cos(6 * x) * np.cos(4 * y) + 0.04 * np.sin(9 * z))[:, None]
    v[:, 0] *= 2.0
    v[:, 1] += 0.15 * np.cos(1.2 * v[:, 0])
    v[:, 0] -= 0.5 * (v[:, 0].max() + v[:, 0].min())  # the mirror plane at x = 0, through the box's centre
    return Mesh(v, np.asarray(t.faces), name="capsule")


@pytest.fixture(scope="module")
def capsule_file(tmp_path_factory) -> Path:
    """The symmetric capsule written to an OBJ file (Mirror X works on it)."""
    from hybridedit.fileio.meshfiles import write_mesh

    p = tmp_path_factory.mktemp("sym") / "capsule.obj"
    write_mesh(p, symmetric_capsule())
    return p


# ---------------------------------------------------------------------------- the window and its parts


@pytest.fixture
def win(qtbot, blob_file):
    """The window with the test shape loaded, front view (looking down -Z, Y up)."""
    with opened_window(qtbot, cage_size=CAGE, path=blob_file) as w:
        w.scene.reset_camera(tilted=False)
        w.view.request_render()
        qtbot.wait(30)
        yield w


@pytest.fixture
def gate(monkeypatch) -> threading.Event:
    """Builds report "building the cage" then "binding" and wait there (still reporting) until the
    gate is set, then build for real; a cancel stops them at their next report."""
    from hybridedit.viewer.model import building

    real = building.build_rig
    gate = threading.Event()

    def build_rig(mesh, *, cage_size, cache, progress):
        progress("building the cage", 0.5)
        time.sleep(0.06)  # (reports of one stage closer than 50 ms apart are merged)
        progress("binding", 0.25)
        while not gate.wait(0.02):
            progress("binding", 0.25)  # raises Cancelled once cancelled
        return real(mesh, cage_size=cage_size, cache=cache, progress=progress)

    monkeypatch.setattr(building, "build_rig", build_rig)
    yield gate
    gate.set()  # never leave a thread waiting


@pytest.fixture(scope="module")
def editor_parts(make_blob):
    """The test shape (4 subdivisions), its cage and binding at 150 vertices, built once per module."""
    from hybridedit.deform.editor import HybridEditor

    mesh = make_blob(4)
    ed = HybridEditor(mesh, 150)
    return mesh, ed.cage, ed.M


@pytest.fixture
def session(editor_parts):
    """A session on the test shape, no window (its engine made from :func:`editor_parts`)."""
    from hybridedit.deform.editor import HybridEditor
    from hybridedit.viewer.model.session import Session

    mesh, cage, M = editor_parts
    return Session(HybridEditor(mesh, 150, cage=cage, binding=M), cage_size=150)

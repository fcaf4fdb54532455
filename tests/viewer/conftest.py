"""The editor window tests run on a real X server: Xvfb is started here when DISPLAY is unset.

Xvfb picks a free display itself (-displayfd) and ends with the test process. Qt uses its xcb platform (VTK renders through GLX).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from hybridedit.viewer.xvfb import ensure_display

from shapes import capsule_blob

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

"""Entry point of the editor window, and the off-screen screenshot mode.

``hybridedit [mesh]`` calls :func:`main`; ``hybridedit --screenshot out.png mesh``
renders the scene (shape + cage overlay) off-screen and exits without showing a
window.
"""

from __future__ import annotations

import os
import signal
import sys
import traceback
from pathlib import Path

from ..defaults import CAGE_SIZE
from ..core.mesh import MeshError

SCREENSHOT_SIZE = (1280, 960)


def _error(msg: str) -> int:
    print(f"hybridedit: error: {msg}", file=sys.stderr)
    return 2


def _headless_render_window() -> None:
    """With no X display (Linux), name EGL as VTK's render window when the library is there: VTK's
    default X window would first fail with a "bad X server connection" warning on the terminal, and
    only then fall back to EGL. A choice made by the user (VTK_DEFAULT_OPENGL_WINDOW) stays."""
    import ctypes.util

    if (sys.platform.startswith("linux") and not os.environ.get("DISPLAY")
            and "VTK_DEFAULT_OPENGL_WINDOW" not in os.environ and ctypes.util.find_library("EGL")):
        os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"


def render_screenshot(path: str | os.PathLike, out: str | os.PathLike, cage: int | float = CAGE_SIZE,
                      size: tuple[int, int] = SCREENSHOT_SIZE, show_cage: bool = False) -> int:
    """Render a mesh as the window first shows it, off-screen, to a PNG; returns the exit status.

    The file is read as the window reads it (:func:`hybridedit.read_document`) and drawn with the
    same look: its textures, material colours or vertex colours (:func:`.model.look.shown_look`).

    Parameters
    ----------
    path : mesh file; out : PNG file to write.
    cage : cage size (vertex count or fraction).
    size : image size in pixels; show_cage : also draw the cage wireframe (View > Show Cage Wireframe).
    """
    import pyvista as pv

    from .model.opening import open_session
    from .render.scene import Scene

    out = Path(out)
    if out.suffix.lower() != ".png":
        return _error(f"{out}: the screenshot must be a .png file")
    if not out.parent.is_dir():
        return _error(f"{out}: the folder {out.parent} does not exist")
    try:
        opened = open_session(path, cage_size=cage)
    except (MeshError, ValueError, OSError) as e:
        return _error(str(e))
    session = opened.session
    mesh, editor = session.mesh, session.editor
    for note in opened.notes:
        print(f"hybridedit: note: {Path(path).name}: {note}", file=sys.stderr)
    _headless_render_window()
    pl = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        scene = Scene(pl)
        scene.up_axis = opened.up_axis  # as the window opens it: remembered, else guessed
        scene.load(session.metrics, session.shape_positions, session.cage_positions, editor.cage.faces,
                   session.selection.cage_roles(), session.selection.shape_roles(), look=session.look)
        scene.set_cage_visible(show_cage)
        scene.reset_camera()
        pl.add_text(f"{Path(path).name}: {mesh.n_vertices:,} vertices, cage {editor.cage.n_vertices:,}",
                    position="upper_left", font_size=11, color="black")
        pl.screenshot(str(out))
    except Exception as e:  # noqa: BLE001 -- one line, never a traceback
        return _error(f"{out}: cannot write the screenshot ({e.__class__.__name__}: {e})")
    finally:
        pl.close()
    if not out.exists():
        return _error(f"{out}: the screenshot was not written")
    return 0


def _quit_on_interrupt(app):
    """Ctrl+C in the terminal closes the window (Python only sees signals between Qt events).

    Returns what to call to undo it.
    """
    from qtpy import QtCore

    previous = signal.signal(signal.SIGINT, lambda *_: app.closeAllWindows())
    timer = QtCore.QTimer(app)
    timer.timeout.connect(lambda: None)
    timer.start(250)

    def undo() -> None:
        timer.stop()
        timer.deleteLater()
        signal.signal(signal.SIGINT, previous)

    return undo


def _install_excepthook(window):
    """Unexpected errors in Qt callbacks go to a message box naming their crash report (written to the
    user cache folder, :mod:`.model.crash_reports`) and one line on stderr, not a traceback (set
    HYBRIDEDIT_DEBUG=1 for the traceback too). Returns what to call to undo it."""
    from .model.crash_reports import describe, is_crash, session_details, write_crash_report

    previous = sys.excepthook

    def hook(etype, value, tb):
        if os.environ.get("HYBRIDEDIT_DEBUG"):
            traceback.print_exception(etype, value, tb, file=sys.stderr)
        text = describe(value)
        if is_crash(value):
            if value.__traceback__ is None and tb is not None:
                value = value.with_traceback(tb)
            report = write_crash_report(value, context="unexpected error",
                                        details=session_details(getattr(window, "session", None)))
            text += f". Report: {report}" if report is not None else ". No crash report could be written."
        print(f"hybridedit: unexpected error: {text}", file=sys.stderr)
        try:
            window.status.show_error("Unexpected error", text)
        except Exception:  # noqa: BLE001
            previous(etype, value, tb)

    sys.excepthook = hook

    def undo() -> None:
        sys.excepthook = previous

    return undo


def main(path: str | os.PathLike | None = None, screenshot: str | os.PathLike | None = None,
         cage: int | float = CAGE_SIZE) -> int:
    """Open the editor window on ``path`` (or render a screenshot); returns the exit status."""
    if screenshot:
        if path is None:
            return _error("--screenshot needs a mesh file")
        return render_screenshot(path, screenshot, cage)
    if sys.platform.startswith("linux") and not os.environ.get("QT_QPA_PLATFORM"):
        if os.environ.get("DISPLAY"):
            os.environ["QT_QPA_PLATFORM"] = "xcb"  # VTK renders through GLX
        elif not os.environ.get("WAYLAND_DISPLAY"):
            return _error("no display: set DISPLAY (or use --screenshot out.png for off-screen rendering)")
    from qtpy import QtWidgets

    from .window.main_window import MainWindow

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    app.setApplicationName("hybridedit")
    window = MainWindow(cage_size=cage)
    undo_signal = _quit_on_interrupt(app)
    undo_hook = _install_excepthook(window)
    try:
        window.show()
        if path is not None:
            p = Path(path)
            if not p.is_file():
                window.status.show_error("Could not open the mesh", f"{p}: no such file")
            else:
                window.loading.open_path(p)
        return int(app.exec())
    finally:
        undo_hook()
        undo_signal()

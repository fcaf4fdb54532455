"""The 3D view widget: VTK rendering straight into a native child window, once per frame, timed.

The render window is VTK's own (GLX on X11), embedded in the Qt window
(``vtkmodules.qt.QVTKRenderWindowInteractor``, native widget): a frame is
rendered and swapped by VTK exactly as a bare pyvista plotter does, with no
off-screen framebuffer for Qt to compose afterwards (that composition cost
40-60 ms a frame with software OpenGL). :attr:`View.plotter` is a pyvista
plotter object holding the renderers of that window, for the scene.

VTK interactor renders (camera moves) only schedule a repaint, so every frame
is rendered exactly once, in ``paintEvent``, where it is timed.

Also: the brush circle overlay, the depth buffer of the shape's layer for the
selection's visibility test (:class:`DepthGrab`), and coordinate conversion
between Qt widget coordinates (logical pixels, y down) and VTK display
coordinates (device pixels, y up).
"""

from __future__ import annotations

import time
from collections import deque

import vtkmodules.qt
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401 (the OpenGL render window classes)
from pyvista.plotting.plotter import BasePlotter
from qtpy import QtCore, QtGui, QtWidgets
from vtkmodules.vtkInteractionStyle import vtkInteractorStyleTrackballCamera
from vtkmodules.vtkRenderingCore import vtkRenderWindow

from .depth_grab import DepthGrab
from .stage_times import FrameSplit
from .gl_renderer import SAMPLES, is_software, renderer_name

vtkmodules.qt.PyQtImpl = "PySide6"  # the binding qtpy uses here (pyproject: PySide6-Essentials)
vtkmodules.qt.QVTKRWIBase = "QWidget"  # a native window VTK renders into, not an OpenGL widget Qt composes
from vtkmodules.qt.QVTKRenderWindowInteractor import QVTKRenderWindowInteractor  # noqa: E402


class OutlineOverlay(QtWidgets.QWidget):
    """A thin outline (rectangle or circle) over the 3D view: a small native window masked to the line
    itself, since nothing Qt paints shows through the view's native render window."""

    WIDTH = 3

    def __init__(self, parent: QtWidgets.QWidget, circle: bool) -> None:
        super().__init__(parent)
        self.circle = circle
        self.color = QtGui.QColor(255, 255, 255)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_NativeWindow)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self.hide()

    def _shape(self, inset: int) -> QtGui.QRegion:
        r = self.rect().adjusted(inset, inset, -inset, -inset)
        kind = QtGui.QRegion.RegionType.Ellipse if self.circle else QtGui.QRegion.RegionType.Rectangle
        return QtGui.QRegion(r, kind)

    def resizeEvent(self, _ev) -> None:  # noqa: N802
        self.setMask(self._shape(0).subtracted(self._shape(self.WIDTH)))

    def paintEvent(self, _ev: QtGui.QPaintEvent) -> None:  # noqa: N802
        p = QtGui.QPainter(self)
        p.fillRect(self.rect(), QtGui.QColor(0, 0, 0))
        p.setPen(QtGui.QPen(self.color, 1.0))
        r = self.rect().adjusted(1, 1, -2, -2)
        if self.circle:
            p.drawEllipse(r)
        else:
            p.drawRect(r)
        p.end()


class BrushOverlay(OutlineOverlay):
    """The brush circle at the cursor."""

    def __init__(self, parent: QtWidgets.QWidget) -> None:
        super().__init__(parent, circle=True)
        self.center = QtCore.QPointF(0, 0)
        self.radius = 30.0

    def show_at(self, pos: QtCore.QPointF, radius: float, color: QtGui.QColor) -> None:
        self.center, self.radius, self.color = QtCore.QPointF(pos), float(radius), color
        r = int(round(radius)) + self.WIDTH
        self.setGeometry(QtCore.QRect(int(round(pos.x())) - r, int(round(pos.y())) - r, 2 * r + 1, 2 * r + 1))
        self.show()
        self.raise_()
        self.update()


class ScenePlotter(BasePlotter):
    """A pyvista plotter whose renderers draw into a given (embedded) render window."""

    def __init__(self, ren_win: vtkRenderWindow) -> None:
        super().__init__()
        self.ren_win = ren_win
        for renderer in self.renderers:
            ren_win.AddRenderer(renderer)


class View(QVTKRenderWindowInteractor):
    """The editor's 3D view.

    Multisample anti-aliasing is switched on after the first frame unless the
    OpenGL driver renders in software (llvmpipe and the like), where it would
    triple the cost of every frame.

    Attributes
    ----------
    plotter : the pyvista plotter of the view's renderers.
    render_seconds : duration of the last render (VTK render and buffer swap).
    split : where the frames' time went (the render stage is recorded here; compose stays 0:
        VTK swaps the window's buffers itself).
    gl_renderer : the OpenGL renderer string (known after the first frame).
    """

    rendered = QtCore.Signal(float)
    """Emitted after each frame with its duration in seconds."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        ren_win = vtkRenderWindow()
        ren_win.SetMultiSamples(0)
        super().__init__(parent, rw=ren_win)
        self.ren_win = ren_win
        self.plotter = ScenePlotter(ren_win)
        self.setAcceptDrops(False)  # the main window takes dropped files
        self.gl_renderer = ""
        self.antialiasing: bool | None = None  # None: decide after the first frame
        self.render_seconds = 0.0
        self.render_pending = False  # a render was requested and has not run yet
        self._paint_times: deque[float] = deque(maxlen=120)
        self._painting = False
        self.split = FrameSplit()
        iren = self._Iren
        iren.SetInteractorStyle(vtkInteractorStyleTrackballCamera())
        iren.Initialize()
        iren.EnableRenderOff()
        iren.AddObserver("RenderEvent", self._on_interactor_render)
        self.brush = BrushOverlay(self)
        self.depth = DepthGrab(ren_win, self.plotter.renderer)

    # ------------------------------------------------------------------ rendering
    def _on_interactor_render(self, *_args) -> None:
        if not self._painting:
            self.request_render()

    def request_render(self) -> None:
        """Schedule one render (coalesced with any other pending request)."""
        self.render_pending = True
        self.update()

    def render(self) -> None:
        """Render now (outside the event loop)."""
        self.paintEvent(None)

    def paintEvent(self, _ev) -> None:  # noqa: N802
        if not self.isVisible():
            return
        t0 = time.perf_counter()
        self.render_pending = False
        self._painting = True
        try:
            # the render window's Render lets go of Python's lock while it draws (the interactor's
            # Render does not), so the window's frame thread computes the next frame meanwhile
            self.ren_win.Render()
        finally:
            self._painting = False
        t1 = time.perf_counter()
        self.render_seconds = t1 - t0
        self.split.add("render", self.render_seconds)
        self._paint_times.append(t1)
        if self.antialiasing is None:
            self._choose_antialiasing()
        self.rendered.emit(self.render_seconds)

    def fresh_depth(self) -> DepthGrab | None:
        """The depth of the shape's layer in the view's present state, rendering once now if the one
        on hand is out of date; None when it cannot be had (the view is not shown)."""
        d = self.depth
        if d.current():
            return d
        wanted, d.wanted = d.wanted, True
        try:
            self.render()
        finally:
            d.wanted = wanted
        return d if d.current() else None

    def screenshot(self, filename=None, *, return_img: bool = False):
        """The view's image as a PNG file (``filename``) and/or an (h, w, 3) uint8 array."""
        self.render()
        return self.plotter.screenshot(filename, return_img=return_img)

    def close(self) -> bool:
        self.Finalize()
        return super().close()

    def _choose_antialiasing(self) -> None:
        self.gl_renderer = renderer_name(self.ren_win)
        self.set_antialiasing(not is_software(self.gl_renderer))

    def set_antialiasing(self, on: bool) -> None:
        """Multisample anti-aliasing (4 samples) on or off."""
        self.antialiasing = bool(on)
        self.ren_win.SetMultiSamples(SAMPLES if on else 0)
        self.update()

    def display_fps(self, window: float = 1.0) -> float:
        """Frames put on screen per second over the last ``window`` seconds (0 when idle)."""
        now = time.perf_counter()
        ts = [t for t in self._paint_times if now - t <= window]
        if len(ts) < 2:
            return 0.0
        return (len(ts) - 1) / max(ts[-1] - ts[0], 1e-9)

    # ------------------------------------------------------------------ coordinates
    def to_display(self, pos: QtCore.QPointF) -> tuple[float, float]:
        """Qt widget position -> VTK display pixels (as the interactor reports events)."""
        s = self.devicePixelRatioF()
        return float(pos.x()) * s, (self.height() - float(pos.y()) - 1.0) * s

    def to_widget(self, x: float, y: float) -> QtCore.QPoint:
        """VTK display pixels -> nearest Qt widget position."""
        s = self.devicePixelRatioF()
        return QtCore.QPoint(int(round(x / s)), int(round(self.height() - 1.0 - y / s)))

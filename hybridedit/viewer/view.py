"""The 3D view widget: a pyvistaqt ``QtInteractor`` that renders once per frame and times it.

pyvistaqt renders in ``paintGL``; a VTK interactor ``Render()`` (camera moves)
would render a second time into the render window before scheduling that
paint. Here interactor renders only schedule a repaint, so every frame is
rendered exactly once, in ``paintGL``, where it is timed.

Also: the brush circle overlay, and coordinate conversion between Qt widget
coordinates (logical pixels, y down) and VTK display coordinates (device
pixels, y up).
"""

from __future__ import annotations

import time
from collections import deque

from pyvistaqt import QtInteractor
from qtpy import QtCore, QtGui, QtWidgets

from .frames import FrameSplit


class BrushOverlay(QtWidgets.QWidget):
    """A transparent child widget drawing the brush circle at the cursor."""

    def __init__(self, parent: QtWidgets.QWidget) -> None:
        super().__init__(parent)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_NoSystemBackground)
        self.setAttribute(QtCore.Qt.WidgetAttribute.WA_TranslucentBackground)
        self.center = QtCore.QPointF(0, 0)
        self.radius = 30.0
        self.color = QtGui.QColor(255, 255, 255)
        self.hide()

    def show_at(self, pos: QtCore.QPointF, radius: float, color: QtGui.QColor) -> None:
        self.center, self.radius, self.color = QtCore.QPointF(pos), float(radius), color
        self.setGeometry(self.parentWidget().rect())
        self.show()
        self.raise_()
        self.update()

    def paintEvent(self, _ev: QtGui.QPaintEvent) -> None:  # noqa: N802
        p = QtGui.QPainter(self)
        p.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing)
        pen = QtGui.QPen(QtGui.QColor(0, 0, 0, 160), 3.0)
        p.setPen(pen)
        p.drawEllipse(self.center, self.radius, self.radius)
        pen = QtGui.QPen(self.color, 1.5)
        p.setPen(pen)
        p.drawEllipse(self.center, self.radius, self.radius)
        p.end()


SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "software", "lavapipe")


class View(QtInteractor):
    """The editor's 3D view.

    Multisample anti-aliasing is switched on after the first frame unless the
    OpenGL driver renders in software (llvmpipe and the like), where it would
    triple the cost of every frame.

    Attributes
    ----------
    render_seconds : duration of the last render (paintGL: VTK render + blit).
    split : where the frames' time went (the render and compose stages are recorded here).
    gl_renderer : the OpenGL renderer string (known after the first frame).
    """

    rendered = QtCore.Signal(float)
    """Emitted after each paint with its duration in seconds."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent, auto_update=False, multi_samples=0)
        self.setAcceptDrops(False)  # the main window takes dropped files
        self.gl_renderer = ""
        self.antialiasing: bool | None = None  # None: decide after the first frame
        self.render_seconds = 0.0
        self._paint_times: deque[float] = deque(maxlen=120)
        self._painting = False
        self._paint_end = 0.0
        self.split = FrameSplit()
        self.frameSwapped.connect(self._swapped)
        iren = self._Iren
        iren.EnableRenderOff()
        iren.AddObserver("RenderEvent", self._on_interactor_render)
        self.brush = BrushOverlay(self)

    # ------------------------------------------------------------------ rendering
    def _on_interactor_render(self, *_args) -> None:
        if not self._painting:
            self.update()

    def request_render(self) -> None:
        """Schedule one render (coalesced with any other pending request)."""
        self.update()

    def paintGL(self) -> None:  # noqa: N802
        t0 = time.perf_counter()
        self._painting = True
        iren = self._Iren
        iren.EnableRenderOn()
        try:
            super().paintGL()
        finally:
            iren.EnableRenderOff()
            self._painting = False
        t1 = time.perf_counter()
        self.render_seconds = t1 - t0
        self._paint_end = t1
        self.split.add("render", self.render_seconds)
        if self.antialiasing is None:
            self._choose_antialiasing()
        self.rendered.emit(self.render_seconds)

    def _swapped(self) -> None:
        """The frame is on screen (Qt composed the widget into its window)."""
        now = time.perf_counter()
        if self._paint_end:
            self.split.add("compose", now - self._paint_end)
            self._paint_end = 0.0
        self._paint_times.append(now)

    def _choose_antialiasing(self) -> None:
        for line in self.ren_win.ReportCapabilities().splitlines():
            if "renderer string" in line:
                self.gl_renderer = line.split(":", 1)[1].strip()
                break
        software = any(k in self.gl_renderer.lower() for k in SOFTWARE_GL)
        self.set_antialiasing(not software)

    def set_antialiasing(self, on: bool) -> None:
        """Multisample anti-aliasing (4 samples) on or off."""
        self.antialiasing = bool(on)
        self.ren_win.SetMultiSamples(4 if on else 0)
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

"""The depth buffer of the shape's layer, read at the end of that layer's render (:class:`DepthGrab`):
what a selection checks to take only the cage points in sight. No Qt: the window's view and the
browser's off-screen plotter both keep one."""

from __future__ import annotations

import time
from typing import Callable, Hashable

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkFloatArray
from vtkmodules.vtkRenderingCore import vtkRenderer, vtkRenderWindow


class DepthGrab:
    """The depth buffer of the first layer (the shape: without the overlay's cage points, ghost
    wireframe and gizmo, which are drawn on top), read at the end of that layer's render.

    It is read while :attr:`wanted` (the view controller wants it in Select mode) and only when
    the view's state, as :attr:`key_fn` tells it (camera, size, shape pose), differs from the one
    already read: a camera that does not move costs nothing. After a move the read waits for the
    layer's drawing to finish, which the frame waited for anyway (the copy itself takes about 1 ms
    on the creature): frames reading it take as long as frames that do not. :meth:`~View.fresh_depth`
    renders once when the depth on hand is out of date.

    Attributes
    ----------
    depth : (h, w) float32 window depth in [0, 1] of the renderer's viewport (1: background),
        row 0 at the bottom, or None.
    origin : display pixel (x0, y0) of ``depth[0, 0]``.
    composite, size : the camera's world -> NDC matrix and the viewport size when it was read.
    key : the view state it was read in.
    serial : counts the reads.
    seconds : duration of the last read.
    """

    def __init__(self, ren_win: vtkRenderWindow, renderer: vtkRenderer) -> None:
        self.ren_win = ren_win
        self.renderer = renderer
        self.wanted = False
        self.key_fn: Callable[[], Hashable | None] | None = None
        self.on_grab: Callable[[], None] | None = None
        self.depth: np.ndarray | None = None
        self.origin = (0, 0)
        self.composite = np.eye(4)
        self.size = (0, 0)
        self.key: Hashable | None = None
        self.serial = 0
        self.seconds = 0.0
        self._array = vtkFloatArray()
        renderer.AddObserver("EndEvent", self._on_end)

    def current(self) -> bool:
        """The depth on hand was read in the view's present state."""
        return self.depth is not None and self.key_fn is not None and self.key == self.key_fn()

    def _on_end(self, *_args) -> None:
        if not self.wanted or self.key_fn is None:
            return
        key = self.key_fn()
        if key is None or (key == self.key and self.depth is not None):
            return
        t0 = time.perf_counter()
        x0, y0 = (int(v) for v in self.renderer.GetOrigin())
        w, h = (int(v) for v in self.renderer.GetSize())
        if w < 1 or h < 1:
            return
        self.ren_win.GetZbufferData(x0, y0, x0 + w - 1, y0 + h - 1, self._array)
        self.depth = vtk_to_numpy(self._array).reshape(h, w).copy()
        self.origin, self.size = (x0, y0), (w, h)
        cam = self.renderer.GetActiveCamera()
        m = cam.GetCompositeProjectionTransformMatrix(self.renderer.GetTiledAspectRatio(), -1, 1)
        self.composite = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
        self.key = key
        self.serial += 1
        self.seconds = time.perf_counter() - t0
        if self.on_grab is not None:
            self.on_grab()

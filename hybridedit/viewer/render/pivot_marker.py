"""The Pose tool's marks on top of the scene: a ball at the joint a limb turns about, and a line from
it to the limb's tip (:class:`~..window.limb_posing.LimbPosing` places them)."""

from __future__ import annotations

import numpy as np
import pyvista as pv

PIVOT_COLOR = (1.0, 0.85, 0.1)


class PivotMarker:
    """A ball at a pivot and a line along its limb, drawn on top of the scene (the overlay renderer).

    Parameters
    ----------
    renderer : the vtkRenderer to draw in.
    """

    def __init__(self, renderer) -> None:
        self.renderer = renderer
        self.visible = False
        self._line = pv.PolyData(np.zeros((2, 3)), lines=np.array([2, 0, 1]))
        self._ball: pv.Actor | None = None
        self._axis = pv.Actor(mapper=pv.DataSetMapper(self._line))
        self._setup(self._axis)
        self._axis.prop.line_width = 3.0
        renderer.AddActor(self._axis)

    @staticmethod
    def _setup(actor: pv.Actor) -> None:
        actor.mapper.scalar_visibility = False
        actor.prop.color = PIVOT_COLOR
        actor.prop.lighting = False
        actor.SetPickable(False)
        actor.SetVisibility(False)

    def build(self, radius: float) -> None:
        """(Re)make the ball at ``radius`` world units (a shape's new size)."""
        if self._ball is not None:
            self.renderer.RemoveActor(self._ball)
        self._ball = pv.Actor(mapper=pv.DataSetMapper(pv.Sphere(radius=float(radius), theta_resolution=16,
                                                                phi_resolution=12)))
        self._setup(self._ball)
        self.renderer.AddActor(self._ball)
        self.place(None)

    def place(self, pivot: np.ndarray | None, tip: np.ndarray | None = None) -> bool:
        """Show the ball at ``pivot`` and the line to ``tip`` (None: hide them); True when that changed."""
        was = self.visible
        self.visible = pivot is not None
        if pivot is not None:
            if self._ball is not None:
                self._ball.SetPosition(*np.asarray(pivot, dtype=np.float64))
            self._line.points = np.vstack([pivot, pivot if tip is None else tip]).astype(np.float64)
        for actor in (self._ball, self._axis):
            if actor is not None:
                actor.SetVisibility(self.visible)
        return was or self.visible

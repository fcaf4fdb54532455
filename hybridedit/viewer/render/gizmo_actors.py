"""The handle gizmo's actors: the arrows, rings and centre ball of
:mod:`~hybridedit.viewer.model.gizmo`, drawn on top of the scene, and the part under the mouse
highlighted."""

from __future__ import annotations

import numpy as np
import pyvista as pv

from ..model.gizmo import AXES, RING_RATIO, RING_SAMPLES, Part, hit_test, ring_points

AXIS_COLORS = ((0.90, 0.20, 0.20), (0.25, 0.75, 0.25), (0.25, 0.45, 0.95))
HOVER_COLOR = (1.0, 0.85, 0.1)
FREE_COLOR = (0.97, 0.97, 0.97)


def _color(part: Part) -> tuple[float, float, float]:
    return FREE_COLOR if part.kind == "free" else AXIS_COLORS[part.axis]


class Gizmo:
    """The gizmo's actors, drawn on top of the scene (in the overlay renderer).

    Parameters
    ----------
    renderer : the vtkRenderer to draw in.
    """

    def __init__(self, renderer) -> None:
        self.renderer = renderer
        self.length = 1.0
        self.center = np.zeros(3)
        self.visible = False
        self.suppressed = False  # hidden whatever is placed (the Pose tool turns limbs, not the handle)
        self.hover: Part | None = None
        self._actors: dict[Part, pv.Actor] = {}
        self._placed = False  # a centre was placed (shown unless suppressed)

    def build(self, length: float) -> None:
        """(Re)create the actors for an arrow length in world units."""
        self.remove()
        self.length = float(length)
        for i in range(3):
            arrow = pv.Arrow(start=(0, 0, 0), direction=AXES[i], scale=self.length,
                             tip_length=0.22, tip_radius=0.07, shaft_radius=0.022, shaft_resolution=16)
            ring = pv.PolyData(ring_points(np.zeros(3), i, RING_RATIO * self.length))
            n = RING_SAMPLES
            ring.lines = np.concatenate([[n + 1], np.arange(n), [0]])
            for part, mesh in ((Part("move", i), arrow), (Part("rotate", i), ring)):
                actor = pv.Actor(mapper=pv.DataSetMapper(mesh))
                actor.mapper.scalar_visibility = False
                actor.prop.color = AXIS_COLORS[i]
                actor.prop.lighting = False
                if part.kind == "rotate":
                    actor.prop.line_width = 4.0
                actor.SetPickable(False)
                actor.SetVisibility(self.visible)
                actor.SetPosition(*self.center)
                self.renderer.AddActor(actor)
                self._actors[part] = actor
        ball = pv.Actor(mapper=pv.DataSetMapper(pv.Sphere(radius=0.07 * self.length, theta_resolution=16,
                                                          phi_resolution=12)))
        ball.mapper.scalar_visibility = False
        ball.prop.color = FREE_COLOR
        ball.prop.lighting = False
        ball.SetPickable(False)
        ball.SetVisibility(self.visible)
        ball.SetPosition(*self.center)
        self.renderer.AddActor(ball)
        self._actors[Part("free", -1)] = ball

    def remove(self) -> None:
        for actor in self._actors.values():
            self.renderer.RemoveActor(actor)
        self._actors.clear()
        self.hover = None

    def suppress(self, on: bool) -> None:
        """Hide the gizmo wherever it is placed (True), or show it again where it was (False)."""
        self.suppressed = bool(on)
        self.place(self.center if self._placed else None)

    def place(self, center: np.ndarray | None) -> None:
        """Move the gizmo to ``center``, or hide it for None (hidden anyway while suppressed)."""
        self._placed = center is not None
        self.visible = center is not None and not self.suppressed
        if center is not None:
            self.center = np.asarray(center, dtype=np.float64).copy()
        for actor in self._actors.values():
            actor.SetVisibility(self.visible)
            if self.visible:
                actor.SetPosition(*self.center)

    def set_hover(self, part: Part | None) -> bool:
        """Highlight a part (None: none); returns True when the highlight changed."""
        if part == self.hover:
            return False
        for p, actor in self._actors.items():
            actor.prop.color = HOVER_COLOR if p == part else _color(p)
        self.hover = part
        return True

    def hit(self, mouse: tuple[float, float], composite: np.ndarray, size: tuple[int, int]) -> Part | None:
        """The part under the mouse when the gizmo is shown."""
        if not self.visible or not self._actors:
            return None
        return hit_test(mouse, self.center, self.length, composite, size)

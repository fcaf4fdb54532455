"""The Pose tool (Mode ▸ Pose, ``P``): a limb under the cursor shown with its joint, made the selection
and turned about that joint by a drag, as Blender's Pose brush does.

The limbs are the engine's (:meth:`hybridedit.HybridEditor.limbs`: extremities of the shape's cage and
where each meets the body); hovering one shows its region (the handle in the handle's colour, the
band that bends about the joint free, the rest held) and its pivot; ``[`` / ``]`` or the wheel move the
joint along the limb before the drag. A drag on it replaces the selection with the limb (one undo
step) and the view controller turns it (:func:`~..model.gizmo.swept_rotation`); the release settles
and polishes as any drag, and Save Edit writes it as any edit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ..model.limb_joints import LimbJoints
from .interfaces import Renders

if TYPE_CHECKING:
    from ...deform.limbs import Limb, LimbPose
    from ..model.session import Session


@runtime_checkable
class Draws(Protocol):
    """The scene as the Pose tool sees it: the roles' colours and the pivot's marks."""

    def update_roles(self, cage_roles: np.ndarray, shape_roles: np.ndarray) -> None: ...
    @property
    def pivot(self): ...  # :class:`~..render.pivot_marker.PivotMarker`


@runtime_checkable
class Redraws(Protocol):
    """The scene's upkeep as the Pose tool sees it (:class:`~.scene_sync.SceneSync`): the selection drawn."""

    def refresh_selection(self) -> None: ...


@runtime_checkable
class Guard(Protocol):
    """The pose side as the Pose tool sees it (:class:`~.posing.Posing`): a settle done, a polish stopped."""

    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the Pose tool sees it."""

    def message(self, text: str) -> None: ...


@runtime_checkable
class Hint(Protocol):
    """The first-steps hint as the Pose tool sees it: a limb grabbed is a selection made."""

    def selected(self) -> None: ...


@runtime_checkable
class PoseHost(Protocol):
    """What :class:`LimbPosing` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def scene(self) -> Draws: ...
    @property
    def view(self) -> Renders: ...
    @property
    def sync(self) -> Redraws: ...
    @property
    def posing(self) -> Guard: ...
    @property
    def status(self) -> Says: ...
    @property
    def first_steps(self) -> Hint: ...


class LimbPosing:
    """The Pose tool of a :class:`~.main_window.MainWindow`: what the view controller's Pose mode calls
    (:class:`~..input.mouse_gestures.PoseHandler`).

    Parameters
    ----------
    window : the window, as far as the Pose tool needs it (:class:`PoseHost`).

    Attributes
    ----------
    shown : the limb shown under the cursor, or None.
    """

    def __init__(self, window: PoseHost) -> None:
        self.w = window
        self.shown: Limb | None = None
        self.joints = LimbJoints()  # each limb's joint, as moved with [ ] (per engine)
        self._engine = None

    # ------------------------------------------------------------------ the limbs
    def _limb_at(self, cage_vertex: int | None) -> Limb | None:
        """The engine's limb the cage point ``cage_vertex`` lies on (:meth:`hybridedit.HybridEditor.limb_at`),
        or None (no shape, no point, no limb there)."""
        s = self.w.session
        if s is None:
            return None
        if s.editor is not self._engine:  # another shape or cage: its own joints
            self._engine, self.shown = s.editor, None
        return self.joints.limb_at(s.editor, cage_vertex)

    def at(self, limb: Limb) -> float:
        """Where ``limb``'s joint is now, as a fraction of its length from the tip (1: where it meets the body)."""
        return self.joints.at(limb)

    def parts(self, limb: Limb) -> LimbPose:
        """How ``limb`` is posed with its joint where it is now, in the pose on display."""
        return self.joints.parts(limb, self.w.session.cage_positions)

    # ------------------------------------------------------------------ what the controller calls
    def hover(self, cage_vertex: int | None) -> bool:
        """Show the limb the cage point ``cage_vertex`` lies on (None or no limb there: the selection as it
        is); True when a limb is shown."""
        limb = self._limb_at(cage_vertex)
        if limb is self.shown:
            return limb is not None
        self.shown = limb
        self._draw()
        return limb is not None

    def grab(self, cage_vertex: int | None) -> np.ndarray | None:
        """A press on the cage point ``cage_vertex`` (None: on empty space): its limb becomes the selection
        (one undo step) and its pivot (3,) in the pose on display is returned; None (and said why) when no
        limb is there."""
        w = self.w
        limb = self._limb_at(cage_vertex)
        if limb is None:
            w.status.message("No limb there: the Pose tool turns a limb (an arm, a leg, a tail, a head) about "
                             "its joint; hover one to see it")
            return None
        w.posing.settle_and_stop_polish()
        pose = self.parts(limb)
        w.session.selection.replace(pose.cage_roi, pose.cage_handle, "pose limb")
        self.shown = None
        w.sync.refresh_selection()
        w.scene.pivot.place(pose.joint, w.session.cage_positions[pose.extremity])
        w.first_steps.selected()
        w.status.message("Turning the limb about its joint (Shift+drag moves it); release to settle")
        return pose.joint

    def move_joint(self, steps: int) -> None:
        """Move the shown limb's joint ``steps`` notches along it (+: toward the body, -: toward the tip)."""
        limb = self.shown
        if limb is None:
            return
        at = self.joints.move(limb, steps)
        self._draw()
        self.w.status.message(f"Joint at {at:.0%} of the limb's length from its tip ([ ] or the wheel move it)")

    # ------------------------------------------------------------------ drawing
    def _draw(self) -> None:
        """The shown limb's roles and pivot on the scene, or the selection's roles and no pivot."""
        w = self.w
        s = w.session
        limb = self.shown
        if s is None or limb is None:
            w.scene.pivot.place(None)
            if s is not None:
                w.sync.refresh_selection()
            w.view.request_render()
            return
        pose = self.parts(limb)
        roles = pose.cage_roles
        w.scene.update_roles(roles, s.editor.shape_roles(roles))  # (what the drag will hold and move)
        w.scene.pivot.place(pose.joint, s.cage_positions[pose.extremity])
        w.view.request_render()

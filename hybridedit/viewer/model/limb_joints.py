"""Where each limb's joint is for the Pose tool, with no Qt: the engine's limbs (:meth:`hybridedit.HybridEditor.
limb_at`) bend where they meet the body until ``[`` / ``]`` (or the wheel) move a joint along its limb;
the window's and the browser's Pose tools keep their joints here."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ...deform.limbs import Limb, LimbPose

__all__ = ["AT_RANGE", "LimbJoints", "STEP"]

STEP = 0.1
"""A notch moves the joint by this fraction of the limb's length."""
AT_RANGE = (0.2, 1.5)
"""Where the joint may be, as a fraction of the limb's length from its tip."""


class LimbJoints:
    """The joints of one engine's limbs (a new engine, another shape or cage, starts them afresh)."""

    def __init__(self) -> None:
        self._at: dict[int, float] = {}
        self._engine = None

    def limb_at(self, editor, cage_vertex: int | None) -> Limb | None:
        """The limb of ``editor`` the cage point ``cage_vertex`` lies on, or None (no point, no limb)."""
        if editor is not self._engine:
            self._engine, self._at = editor, {}
        return None if cage_vertex is None else editor.limb_at(int(cage_vertex), space="cage")

    def at(self, limb: Limb) -> float:
        """Where ``limb``'s joint is now, as a fraction of its length from the tip (1: where it meets the body)."""
        return self._at.get(limb.index, 1.0)

    def parts(self, limb: Limb, cage_positions: np.ndarray) -> LimbPose:
        """How ``limb`` is posed with its joint where it is now, placed in the cage pose ``cage_positions``."""
        return limb.parts(at=self.at(limb)).placed(cage_positions)

    def move(self, limb: Limb, steps: int) -> float:
        """Move ``limb``'s joint ``steps`` notches along it (+: toward the body, -: toward the tip), within
        :data:`AT_RANGE`; returns where it is now.

        Examples
        --------
        >>> from types import SimpleNamespace
        >>> joints, arm = LimbJoints(), SimpleNamespace(index=0)
        >>> joints.move(arm, -3), joints.move(arm, -20), joints.move(arm, 100)
        (0.7, 0.2, 1.5)
        """
        lo, hi = AT_RANGE
        at = float(np.clip(round(self.at(limb) + STEP * steps, 6), lo, hi))
        self._at[limb.index] = at
        return at

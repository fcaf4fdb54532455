"""Polish on release without a thread of its own: the request, its outcome, and the run that turns
one into the other; the window's worker thread (:mod:`..jobs.polish_worker`) and the browser editor
both run :func:`polish`.

A polish is full-resolution ARAP of the edited region (:class:`~hybridedit.deform.polish.PolishJob`),
cancellable between iterations, with the shape's factorized set-up kept for the next one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...core.mesh import Mesh, rrms_edge_error

__all__ = ["PolishOutcome", "PolishRequest", "ShapeARAPHolder", "polish"]


class ShapeARAPHolder:
    """The full-resolution ARAP set-up of one loaded shape, built lazily by the first polish.

    Only one polish uses it at a time (they run one after the other).
    """

    def __init__(self, mesh: Mesh) -> None:
        self.mesh = mesh
        self.shape_arap = None
        self.build_seconds = 0.0

    def get(self):
        if self.shape_arap is None:
            from ...deform.polish import ShapeARAP

            t0 = time.perf_counter()
            self.shape_arap = ShapeARAP(self.mesh)
            self.build_seconds = time.perf_counter() - t0
        return self.shape_arap


@dataclass
class PolishRequest:
    """One polish: the engine's ``job`` (:class:`~hybridedit.deform.polish.PolishJob`: the start pose, the
    free vertices, the stopping rule), run with the shape's set-up in ``holder``.

    ``token`` identifies the request; a result whose token is stale is dropped.
    """

    holder: ShapeARAPHolder
    job: object  # hybridedit.deform.polish.PolishJob
    edges: np.ndarray
    token: int = 0

    @property
    def vertices(self) -> np.ndarray:
        """(n, 3) the pose polished."""
        return self.job.start


@dataclass
class PolishOutcome:
    request: PolishRequest
    result: object  # polish.PolishResult
    error_before: float  # relative RMS edge error in percent, hybrid pose
    error_after: float  # the same, polished pose
    setup_seconds: float  # ShapeARAP set-up and factorization for this free set
    seconds: float  # wall time of the whole job


def polish(request: PolishRequest, should_stop: Callable[[], bool]) -> PolishOutcome | None:
    """Run one polish (off the UI thread); None when ``should_stop`` said so before it ended.

    Raises what the polish raises (MemoryError: a message of its own).
    """
    t0 = time.perf_counter()
    try:
        sa = request.holder.get()
        if should_stop():
            return None
        sa.prepare(request.job.free)  # factor once per free set (cached by ShapeARAP)
        setup = time.perf_counter() - t0
        if should_stop():
            return None
        res = request.job.run(sa, should_stop=should_stop)
    except MemoryError:
        raise MemoryError("not enough memory to polish this shape") from None
    if should_stop() or res.stopped == "cancelled":
        return None
    rest = request.holder.mesh.vertices
    e0 = rrms_edge_error(rest, request.vertices, request.edges)
    e1 = rrms_edge_error(rest, res.vertices, request.edges)
    return PolishOutcome(request, res, e0, e1, setup, time.perf_counter() - t0)

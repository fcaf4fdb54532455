"""Settings that several parts of hybridedit share, each written once (no Qt, no numba: cheap to import)."""

from __future__ import annotations

#: Most iterations a full-resolution polish runs (the window's polish on release, ``deform --polish``).
POLISH_MAX_ITERATIONS = 200
#: A polish has converged when an iteration moves no vertex by more than this fraction of the diagonal.
POLISH_TOLERANCE = 1e-6

"""ARAP's local/global iterations run to convergence, accelerated (Anderson, energy-safeguarded).

The plain iteration ``x <- G(x)`` (:class:`~hybridedit.deform.local_global.LocalGlobalMap`)
converges linearly, and slowly on a big cage: at the 692K armadillo's 34.6K cage the
error shrinks by 0.995 an iteration. Anderson acceleration (type II, Walker & Ni
2011) extrapolates from the last ``window`` iterates: with ``f_i = G(x_i) - x_i`` and
the differences ``dF``, ``dG`` of successive f and G(x), the next point is
``G(x_k) - dG gamma``, gamma the least-squares fit of ``f_k`` by ``dF`` (solved through
its small normal equations, regularized by 1e-10 of their trace). The energy safeguard
of Peng et al. 2018 ("Anderson Acceleration for Geometry Optimization and Physics
Simulation") keeps it safe: an extrapolated point is taken only if its ARAP energy
is below that of the last point taken; otherwise the plain step ``G(x_k)`` is taken
and the history cleared. The local step of the point gives that energy at no cost.

Stopping rule: a bound on the distance to the fixed point, never the last step
-------------------------------------------------------------------------------
Near the fixed point x*, ``f(x) ~ -(I - J)(x - x*)`` with J the map's Jacobian, whose
eigenvalues lie in [0, rho], rho < 1 the plain iteration's rate (``I - J = L^-1 H / 2``
is symmetric in the metric of the free Laplacian L). So ``|x - x*| <= kappa |f(x)|`` with
``kappa = 1 / (1 - rho)``. The history gives kappa: in L's metric, the Ritz values of
``I - J`` on the span of the last steps (``dX^T L (-dF) c = theta dX^T L dX c``, an m x m
problem) lie in [1 - rho, 1], the smallest tending to 1 - rho as the slow directions
enter the steps (the error is mostly in them). The run keeps the largest ``1 / theta``
of a full window whose Ritz values all lie in (0, 1.5) (outside: a region where the
linear model does not hold), and stops when

    ``distance = SAFETY * kappa * max |f(x_k)| <= tolerance``

(``SAFETY`` = 2, the coordinate max over vertices, as the tolerance is measured) with a
full window of ``window`` steps since the last reset, and an estimate that rose by at
most 10% over the last window (a slow direction entering the steps late raises it: the
692K edit's first estimate is 76, its last 207). It returns ``G(x_k)``, which is closer
still. A residual below 1e-9 of the tolerance stops it whatever the estimate (a start
at the fixed point, whose steps are rounding noise: the bound then assumes kappa <= 1e9).

Measured on the 173K and 692K armadillos (cages 8.6K and 34.6K), a jump to the issue's
edit and a settle after 10 to 100 live frames, tolerances 1e-3 to 1e-9 of the diagonal,
and on a 1M sphere (a 50K cage) at 1e-6: the true distance at the stop was 0.02 to 0.6
of the tolerance, and the ratio of the true distance to ``max |f|`` at most 1.3 times the
kappa the rule uses before its SAFETY factor (benchmarks/converge.py prints the distances).

A run is deterministic: a rule, never the clock; the same start gives the same iterates
bit for bit. ``max_iterations`` caps it: a run stopped there says so (``converged`` False).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np
import scipy.linalg

# the cap a converge stops at (then not converged), and its default tolerance (a fraction of the diagonal)
from ..defaults import CONVERGE_MAX_ITERATIONS as MAX_ITERATIONS
from ..defaults import CONVERGE_TOLERANCE as TOLERANCE

__all__ = ["ConvergeResult", "ConvergeStats", "LocalGlobal", "converge", "SAFETY", "WINDOW", "MAX_ITERATIONS",
           "TOLERANCE"]

#: the factor on the estimated 1 / (1 - rho) of the stopping rule
SAFETY = 2.0
#: iterates the extrapolation remembers
WINDOW = 10
#: Ritz values of I - J above this come from a region where the linear model does not hold
_RITZ_MAX = 1.5
#: the rule stops only once its estimate rose by at most this factor over the last window of iterations
_STEADY = 1.1
#: relative regularization of the least-squares normal equations
_REGULARIZATION = 1e-10
#: energies closer than this fraction are equal to the safeguard (the sum's rounding): near the fixed
#: point the energy stops telling iterates apart, and the extrapolation is then taken
_ROUNDING = 1e-12
#: a residual below this fraction of the tolerance is converged whatever the estimate (the history's
#: differences are then rounding noise: a start at the fixed point)
_FLOOR = 1e-9


class LocalGlobal(Protocol):
    """What :func:`converge` iterates (:class:`~hybridedit.deform.local_global.LocalGlobalMap`)."""

    def start(self) -> np.ndarray: ...

    def rotate(self, x: np.ndarray) -> float: ...

    def step(self) -> np.ndarray: ...

    def metric(self, v: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class ConvergeStats:
    """What a :func:`converge` run did.

    Attributes
    ----------
    iterations : local/global iterations run (global steps)
    rejected : extrapolated points the energy safeguard refused (each cost one more local step)
    converged : the stopping rule's bound reached the tolerance
    stopped : "converged", "iterations" (``max_iterations`` ran) or "cancelled"
    distance : the bound on the distance to the fixed point at the end (the positions' units;
        inf before an estimate; a run stopped by the residual floor gives residual / 1e-9)
    kappa : the estimated 1 / (1 - rho) the bound used (before :data:`SAFETY`)
    seconds : wall time (reported only: it never decides anything)
    """

    iterations: int
    rejected: int
    converged: bool
    stopped: str
    distance: float
    kappa: float
    seconds: float


#: columns a block of :func:`_dots` spans: (30 x 2048) times (2048 x 3) is below OpenBLAS's
#: threading threshold, so each product runs on the calling thread (a threaded call beside a busy
#: core waits for a time slice: 10 ms for the products a 4 ms iteration needs) and sums in one order
_BLOCK = 2048
#: columns a block of :func:`_combine` spans (a matrix-vector product, below its threading threshold)
_COMBINE_BLOCK = 900


def _dots(A: np.ndarray, V: np.ndarray) -> np.ndarray:
    """``A @ V.T``, (r, s), for (r, N) ``A`` and (s, N) ``V``, summed over column blocks in order."""
    out = np.zeros((A.shape[0], V.shape[0]))
    for j in range(0, A.shape[1], _BLOCK):
        out += A[:, j:j + _BLOCK] @ V[:, j:j + _BLOCK].T
    return out


def _combine(gamma: np.ndarray, A: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``gamma @ A`` into ``out`` (N,), for (k,) ``gamma`` and (k, N) ``A``, in column blocks."""
    for j in range(0, A.shape[1], _COMBINE_BLOCK):
        np.dot(gamma, A[:, j:j + _COMBINE_BLOCK], out=out[j:j + _COMBINE_BLOCK])
    return out


@dataclass(frozen=True)
class ConvergeResult:
    """What :meth:`hybridedit.HybridEditor.converge` did.

    Attributes
    ----------
    vertices : (n, 3) float64, the shape: a read-only view of the editor's array (later calls
        update it; ``.copy()`` it to keep the pose)
    converged : the bound on the cage's distance to the fixed point reached the tolerance
    stopped : "converged", "iterations" (the cap ran: not converged) or "cancelled" (nothing changed)
    iterations : cage ARAP iterations run
    rejected : extrapolated points the energy safeguard refused
    distance : the bound at the end, a fraction of the bounding-box diagonal (inf: none yet)
    seconds : wall time (reported only: it never decides anything)
    """

    vertices: np.ndarray
    converged: bool
    stopped: str
    iterations: int
    rejected: int
    distance: float
    seconds: float


class _History:
    """The last ``window`` differences of iterates x, of f = G(x) - x and of G(x), with their Gram
    matrices, in preallocated ring slots (nothing (n, 3)-sized is made per iteration but the new
    iterate)."""

    def __init__(self, window: int, size: int) -> None:
        m = self.window = window
        # rows: dF (0 .. m-1), dX (m .. 2m-1), L dX (2m .. 3m-1), one slot each
        self._S = np.zeros((3 * m, size))
        self.dF, self.dX, self.LdX = self._S[:m], self._S[m:2 * m], self._S[2 * m:]
        self.dG = np.zeros((m, size))
        self.FF = np.zeros((m, m))  # dF dF^T, the least-squares' normal matrix
        self.B = np.zeros((m, m))  # dX L dX^T
        self.K = np.zeros((m, m))  # -dX L dF^T (I - J in the span, L's metric)
        self._rhs = np.zeros(m)  # dF f of the last point
        self._V = np.zeros((3, size))  # the new df, L dx and f
        self._combined = np.zeros(size)
        self.count = 0  # differences held (slots 0 .. count - 1)
        self.head = 0  # the slot the next difference goes to
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # x, f, G(x) of the last point

    def clear(self) -> None:
        self.count = 0
        self.head = 0
        self._S[:] = 0.0  # (the products run over every slot: empty ones must add nothing)
        self._last = None

    def push(self, x: np.ndarray, f: np.ndarray, g: np.ndarray, metric: Callable[[np.ndarray], np.ndarray]) -> None:
        """A new point (its x, f and G(x), (n, 3) each): its differences from the last one join the
        history (the oldest leaves when it is full)."""
        if self._last is not None:
            px, pf, pg = self._last
            m, s = self.window, self.head
            np.subtract(f.ravel(), pf.ravel(), out=self.dF[s])
            np.subtract(x.ravel(), px.ravel(), out=self.dX[s])
            np.subtract(g.ravel(), pg.ravel(), out=self.dG[s])
            self.LdX[s] = metric(self.dX[s].reshape(-1, 3)).ravel()
            self.count = min(self.count + 1, m)
            V = self._V
            V[0], V[1], V[2] = self.dF[s], self.LdX[s], f.ravel()
            P = _dots(self._S, V)
            self.FF[s, :] = self.FF[:, s] = P[:m, 0]
            self.B[s, :] = self.B[:, s] = P[m:2 * m, 1]
            self.K[s, :] = -P[:m, 1]
            self.K[:, s] = -P[2 * m:, 0]
            self._rhs[:] = P[:m, 2]
            self.head = (s + 1) % m
        self._last = (x, f, g)

    def extrapolate(self, g: np.ndarray) -> np.ndarray | None:
        """Anderson's next point ``g - dG gamma``, gamma fitting the last point's f (pushed last, with
        G(x) = ``g``) by dF, (n, 3); None when the history is empty or its normal equations cannot be
        solved."""
        k = self.count
        if k == 0:
            return None
        A = self.FF[:k, :k]
        lam = _REGULARIZATION * float(np.trace(A)) / k
        try:
            gamma = np.linalg.solve(A + lam * np.eye(k), self._rhs[:k])
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(gamma)):
            return None
        out = g.ravel() - _combine(gamma, self.dG[:k], self._combined)
        return out.reshape(-1, 3)

    def kappa(self) -> float | None:
        """1 / (smallest Ritz value of I - J) on the span of a full window, in L's metric; None when
        the window is not full or its Ritz values are not all in (0, 1.5)."""
        k = self.count
        if k < self.window:
            return None
        B = self.B[:k, :k]
        K = 0.5 * (self.K[:k, :k] + self.K[:k, :k].T)
        tr = float(np.trace(B))
        if not (tr > 0 and math.isfinite(tr)):
            return None
        try:
            theta = scipy.linalg.eigh(K, B + 1e-12 * tr / k * np.eye(k), eigvals_only=True)
        except (np.linalg.LinAlgError, ValueError):
            return None
        if not (theta[0] > 0 and theta[-1] < _RITZ_MAX):
            return None
        return 1.0 / float(theta[0])


def _should_stop(cancel) -> bool:
    if cancel is None:
        return False
    is_set = getattr(cancel, "is_set", None)
    return bool(is_set() if is_set is not None else cancel())


def converge(gmap: LocalGlobal, *, tolerance: float, max_iterations: int = MAX_ITERATIONS, window: int = WINDOW,
             cancel=None, progress: Callable[[float], None] | None = None):
    """Iterate ``gmap`` from its start to its fixed point, Anderson-accelerated and safeguarded.

    Parameters
    ----------
    gmap : a :class:`LocalGlobal` (the map of (f, 3) free positions).
    tolerance : float
        Stop when the bound on the distance to the fixed point (see the module's notes) is at
        most this (the positions' units), > 0.
    max_iterations : int
        Cap on the local/global iterations (>= 1); a run stopped there is not converged.
    window : int
        Iterates the extrapolation remembers (>= 1).
    cancel : callable() -> bool or threading.Event, optional
        Checked between iterations; true (set) stops the run ("cancelled").
    progress : callable(fraction), optional
        Told after each iteration how far the run is, in [0, 1], by a rule (never the clock):
        the reduction of ``max |f|`` so far over the reduction the rule needs, on a log scale,
        never decreasing.

    Returns
    -------
    positions : (f, 3) float64, G(x) of the last point x (what the plain iteration's
        :meth:`~hybridedit.deform.arap.ARAPSolver.solve` would leave after an iteration from x)
    stats : :class:`ConvergeStats`

    Notes
    -----
    The map's rotations are those of the last point x at the end (its global step used them).

    Examples
    --------
    >>> gmap = local_global_map(arap, targets, slots=slots)  # doctest: +SKIP
    >>> x, stats = converge(gmap, tolerance=1e-6 * diagonal)  # doctest: +SKIP
    >>> arap.adopt(x, gmap.rotations()); stats.converged  # doctest: +SKIP
    True
    """
    if not (tolerance > 0) or not math.isfinite(tolerance):
        raise ValueError(f"tolerance must be a finite number > 0, got {tolerance!r}")
    if int(max_iterations) < 1 or int(window) < 1:
        raise ValueError(f"max_iterations and window must be >= 1, got {max_iterations!r}, {window!r}")
    t0 = time.perf_counter()
    x = gmap.start()
    energy = gmap.rotate(x)
    g = gmap.step()
    f = g - x
    iterations, rejected = 1, 0
    history = _History(int(window), x.size)
    history.push(x, f, g, gmap.metric)
    kappa = 0.0  # the largest estimate so far (0: none yet)
    kappas = [0.0] * (int(window) + 1)  # kappa after each of the last ``window`` + 1 iterations (a ring)
    first = None  # max |f| at the start (progress)
    done = 0.0
    stopped = "iterations"
    while True:
        residual = float(np.abs(f).max(initial=0.0))
        distance = SAFETY * kappa * residual if kappa > 0 else (0.0 if residual == 0.0 else math.inf)
        steady = kappa <= _STEADY * kappas[(iterations + 1) % len(kappas)]  # (vs a window ago: risen little)
        if residual <= _FLOOR * tolerance:
            distance = min(distance, residual / _FLOOR)
            stopped = "converged"
            break
        if history.count == history.window and steady and distance <= tolerance:
            stopped = "converged"
            break
        if iterations >= int(max_iterations):
            break
        if _should_stop(cancel):
            stopped = "cancelled"
            break
        if progress is not None:
            first = residual if first is None else first
            need = math.log(max(first * SAFETY * max(kappa, 1.0) / tolerance, 1.0 + 1e-12))
            done = max(done, min(math.log(first / residual) / need, 1.0) if residual < first else 0.0)
            progress(done)
        candidate = history.extrapolate(g)
        if candidate is not None:
            e = gmap.rotate(candidate)
            if not e <= energy + _ROUNDING * abs(energy):  # (a NaN too): the plain step, the history from there
                rejected += 1
                candidate = None
                history.clear()
        if candidate is None:
            candidate = g
            e = gmap.rotate(candidate)
        x, energy = candidate, e
        g = gmap.step()
        iterations += 1
        f = g - x
        history.push(x, f, g, gmap.metric)
        estimate = history.kappa()
        if estimate is not None:
            kappa = max(kappa, estimate)
        kappas[iterations % len(kappas)] = kappa
    if progress is not None and stopped == "converged":
        progress(1.0)
    return g, ConvergeStats(iterations=iterations, rejected=rejected, converged=stopped == "converged",
                            stopped=stopped, distance=distance, kappa=kappa, seconds=time.perf_counter() - t0)

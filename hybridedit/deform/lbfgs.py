"""ARAP's local/global iterations run to convergence by L-BFGS in the Laplacian's metric.

The plain iteration ``x <- G(x)`` (:class:`~hybridedit.deform.local_global.LocalGlobalMap`)
is a descent method on the ARAP energy E: ``f = G(x) - x = -L^-1 grad E / c`` (L the free
Laplacian, c a constant), a gradient step preconditioned by L. It converges linearly, and
slowly on a big cage (at the 692K armadillo's 34.6K cage the error shrinks by 0.995 an
iteration). L-BFGS (Nocedal & Wright, Algorithm 7.4) with ``L^-1`` as its initial inverse
Hessian, as Liu et al. 2017 ("Quasi-Newton Methods for Real-Time Simulation of Hyperelastic
Materials") use it, turns the last ``window`` steps into a quasi-Newton direction; a
backtracking line search on E keeps every step a descent, so the run also leaves the saddles
where the plain iteration crawls. (Anderson acceleration with an energy safeguard was used
before: near a saddle its extrapolation heads for the saddle, is refused, and the run falls
back to plain steps: 5,203 iterations at the 692K armadillo's big move, 323 here.)

Every vector L-BFGS needs is a combination of the history's steps ``dX`` and residual changes
``dF`` (the gradient changes are ``-L dF``), so the two loops run on small Gram matrices and
each iteration costs one local step, one global step (the solve) and one product with L (of
the step and f side by side), like a plain iteration, plus one more local step for each
halving of a refused step, and two passes over the history's rows
(:mod:`hybridedit.core.row_sums`).

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
most 10% over the last window (a slow direction entering the steps late raises it). It
returns ``G(x_k)``, which is closer still. A residual below 1e-9 of the tolerance stops it
whatever the estimate (a start at the fixed point, whose steps are rounding noise: the
bound then assumes kappa <= 1e9). ``benchmarks/converge.py`` prints the true distances.

A run is deterministic: a rule, never the clock; the same start gives the same iterates
bit for bit (every long sum runs in blocks on the calling thread, in one order).
``max_iterations`` caps it: a run stopped there says so (``converged`` False).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np
import scipy.linalg

from ..core.row_sums import combine, gram

# the cap a converge stops at (then not converged), and its default tolerance (a fraction of the diagonal)
from ..defaults import CONVERGE_MAX_ITERATIONS as MAX_ITERATIONS
from ..defaults import CONVERGE_TOLERANCE as TOLERANCE

__all__ = ["ConvergeResult", "ConvergeStats", "LocalGlobal", "converge", "SAFETY", "WINDOW", "MAX_ITERATIONS",
           "TOLERANCE"]

#: the factor on the estimated 1 / (1 - rho) of the stopping rule
SAFETY = 2.0
#: steps the quasi-Newton direction remembers
WINDOW = 10
#: halvings of a step that raises the energy before the plain step is taken instead
_HALVINGS = 3
#: Ritz values of I - J above this come from a region where the linear model does not hold
_RITZ_MAX = 1.5
#: the rule stops only once its estimate rose by at most this factor over the last window of iterations
_STEADY = 1.1
#: energies closer than this fraction are equal to the line search (the sum's rounding): near the fixed
#: point the energy stops telling iterates apart, and the step is then taken
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
    rejected : steps the line search refused for raising the energy (each cost one more local step)
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
    rejected : steps the line search refused for raising the energy
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
    """The last ``window`` steps dX and changes of f = G(x) - x (dF), with their Gram matrices in
    L's metric, in preallocated ring slots (nothing (n, 3)-sized is made per iteration but the new
    iterate and its direction)."""

    def __init__(self, window: int, size: int) -> None:
        m = self.window = window
        # rows: dX (0 .. m-1), dF (m .. 2m-1) and the last point's f (2m): what every direction
        # is a combination of
        self._S = np.zeros((2 * m + 1, size))
        self.dX, self.dF, self._f = self._S[:m], self._S[m:2 * m], self._S[2 * m]
        self.B = np.zeros((m, m))  # dX L dX^T
        self.K = np.zeros((m, m))  # -dX L dF^T: I - J in the span (L's metric); its diagonal is s.y
        self.FLF = np.zeros((m, m))  # dF L dF^T
        self.c = np.zeros(m)  # dX L f of the last point
        self.h = np.zeros(m)  # dF L f of the last point
        self.fLf = 0.0
        self._V = np.zeros((3, size))  # the new L dx, L df and L f (the last point's, kept for the next df)
        self._P = np.zeros((2 * m + 1, 3))  # the rows' products with them
        self._pair = np.zeros((size // 3, 6))  # dx and f side by side: L applied to both in one pass
        self._combined = np.zeros(size)
        self.count = 0  # steps held (slots 0 .. count - 1)
        self.head = 0  # the slot the next step goes to
        self._last_x: np.ndarray | None = None  # x of the last point (its f is the last row)

    def clear(self) -> None:
        """Forget the steps (the last point stays: the next push starts a new history from it)."""
        self.count = 0
        self.head = 0
        self._S[:2 * self.window] = 0.0  # (the products run over every slot: empty ones must add nothing)

    def push(self, x: np.ndarray, f: np.ndarray, metric: Callable[[np.ndarray], np.ndarray]) -> None:
        """A new point (its x and f, (n, 3) each): its step from the last one joins the history (the
        oldest leaves when it is full)."""
        V, m, s = self._V, self.window, self.head
        stepped = self._last_x is not None
        if stepped:
            np.subtract(x.ravel(), self._last_x.ravel(), out=self.dX[s])
            np.subtract(f.ravel(), self._f, out=self.dF[s])
            self._pair[:, :3] = self.dX[s].reshape(-1, 3)
            self._pair[:, 3:] = f
            Lpair = metric(self._pair)
            Ldx, Ldf, Lf = (v.reshape(-1, 3) for v in V)
            Ldx[:] = Lpair[:, :3]
            np.subtract(Lpair[:, 3:], Lf, out=Ldf)  # L df = L f - L f of the last point
            Lf[:] = Lpair[:, 3:]
        else:
            V[2] = metric(f).ravel()
        self._f[:] = f.ravel()
        P = gram(self._S, V, self._P)
        if stepped:
            self.B[s, :] = self.B[:, s] = P[:m, 0]
            self.K[:, s] = -P[:m, 1]  # -dX_j L dF_s
            self.K[s, :] = -P[m:2 * m, 0]  # -dX_s L dF_j (= -dF_j L dX_s)
            self.FLF[s, :] = self.FLF[:, s] = P[m:2 * m, 1]
            self.count = min(self.count + 1, m)
            self.head = (s + 1) % m
        self.c[:] = P[:m, 2]
        self.h[:] = P[m:2 * m, 2]
        self.fLf = float(P[2 * m, 2])
        self._last_x = x

    def _order(self) -> list[int]:
        """The slots held, newest first, whose step has positive curvature (s.y > 0: usable)."""
        m = self.window
        slots = [(self.head - 1 - i) % m for i in range(self.count)]
        return [j for j in slots if self.K[j, j] > 1e-300]

    def direction(self) -> tuple[np.ndarray | None, float]:
        """The L-BFGS direction at the last point, (n, 3) (a buffer the next call overwrites), and
        its product with L f (> 0: a descent direction for E); (None, 0.0) when the history has no
        usable step."""
        order = self._order()
        if not order:
            return None, 0.0
        K, FLF, c, h = self.K, self.FLF, self.c, self.h
        m = self.window
        # q = -L f + sum_j a_j L dF_j (the gradient, up to its constant, after the first loop)
        a = np.zeros(m)
        for i in order:  # newest to oldest
            sq = -c[i] - sum(a[j] * K[i, j] for j in order)  # (a is 0 where not yet set)
            a[i] = sq / K[i, i]
        newest = order[0]
        gamma = K[newest, newest] / FLF[newest, newest] if FLF[newest, newest] > 0 else 1.0
        # r = gamma (-f + sum_j a_j dF_j) + sum_j beta_j dX_j
        beta = np.zeros(m)
        for i in reversed(order):  # oldest to newest
            yr = -gamma * (-h[i] + sum(a[j] * FLF[i, j] for j in order)) + sum(beta[j] * K[j, i] for j in order)
            beta[i] = a[i] - yr / K[i, i]
        # d = -r = gamma f - sum beta dX - gamma sum a dF (f is the last row)
        d = combine(np.concatenate([-beta, -gamma * a, [gamma]]), self._S, self._combined)
        slope = gamma * self.fLf - float(beta @ c) - gamma * float(a @ h)
        return d.reshape(-1, 3), slope

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
    """Iterate ``gmap`` from its start to its fixed point by L-BFGS with a line search on the energy.

    Parameters
    ----------
    gmap : a :class:`LocalGlobal` (the map of (f, 3) free positions).
    tolerance : float
        Stop when the bound on the distance to the fixed point (see the module's notes) is at
        most this (the positions' units), > 0.
    max_iterations : int
        Cap on the local/global iterations (>= 1); a run stopped there is not converged.
    window : int
        Steps the quasi-Newton direction remembers (>= 1).
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
    history.push(x, f, gmap.metric)
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
        d, slope = history.direction()
        candidate = None
        if d is not None and slope > 0:  # (slope <= 0: rounding far from a minimum)
            step = 1.0
            for _ in range(_HALVINGS + 1):  # the step if it lowers the energy, else half of it ...
                trial = x + step * d
                e = gmap.rotate(trial)
                if e <= energy + _ROUNDING * abs(energy):  # (not for a NaN)
                    candidate = trial
                    break
                rejected += 1
                step *= 0.5
        if candidate is None:  # ... else (or with no direction) the plain step: it lowers the energy
            if d is not None:
                history.clear()  # (the history from there)
            candidate = g
            e = gmap.rotate(candidate)
        x, energy = candidate, e
        g = gmap.step()
        iterations += 1
        f = g - x
        history.push(x, f, gmap.metric)
        estimate = history.kappa()
        if estimate is not None:
            kappa = max(kappa, estimate)
        kappas[iterations % len(kappas)] = kappa
    if progress is not None and stopped == "converged":
        progress(1.0)
    return g, ConvergeStats(iterations=iterations, rejected=rejected, converged=stopped == "converged",
                            stopped=stopped, distance=distance, kappa=kappa, seconds=time.perf_counter() - t0)

"""Polish on release for the browser editor: the window's polish (:func:`~..viewer.model.polishing.polish`,
the same job and stopping rule, so that an edit file replays it), in a thread of its own, given to the
session on the server's event loop while it is still current."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from ..core.heap import trim_heap
from ..defaults import POLISH_MAX_ITERATIONS, POLISH_TOLERANCE
from ..viewer.model.polishing import PolishOutcome, PolishRequest, ShapeARAPHolder, polish

__all__ = ["PolishOnRelease"]


class PolishOnRelease:
    """Starts a polish after a drag, drops it when anything changes the pose first.

    Parameters
    ----------
    session : the session polished (:class:`~hybridedit.viewer.model.session.Session`).
    on_done : told a sentence for the status line when a polish has been given to the session (or
        failed); called on the event loop.

    Polishes run one at a time on one thread (they share the shape's factorized set-up); a newer one
    stops the one running at its next iteration.
    """

    def __init__(self, session, on_done: Callable[[str], None]) -> None:
        self.session = session
        self.on_done = on_done
        self.enabled = True
        self._holder: ShapeARAPHolder | None = None
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hybridedit-polish")
        self._token = 0
        self._stop = threading.Event()
        self.running = False

    def start(self) -> bool:
        """Polish the pose on display in the background; False when there is nothing to polish."""
        s = self.session
        if not self.enabled:
            return False
        job = s.polish_job(max_iterations=POLISH_MAX_ITERATIONS, tolerance=POLISH_TOLERANCE)
        if job is None:
            return False
        self.cancel()
        if self._holder is None or self._holder.mesh is not s.mesh:
            self._holder = ShapeARAPHolder(s.mesh)  # built by the shape's first polish
        token, stop = self._token, threading.Event()
        self._stop = stop
        request = PolishRequest(self._holder, job, s.edges, token)
        future = asyncio.get_running_loop().run_in_executor(self._pool, _run, request, stop)
        future.add_done_callback(lambda f: self._finished(f, token))
        self.running = True
        return True

    def cancel(self) -> None:
        """Drop the polish under way (it stops at its next iteration; its result is not used)."""
        self._token += 1
        self._stop.set()
        self.running = False

    def _finished(self, future, token: int) -> None:
        if token != self._token or future.cancelled():
            return  # stale: the pose changed since it started
        self.running = False
        try:
            out: PolishOutcome | None = future.result()
        except Exception as e:  # noqa: BLE001 -- said in the status line; the pose stays as it was
            self.on_done(f"The polish failed ({type(e).__name__}: {e}); the pose is kept unpolished")
            return
        if out is None:
            return
        try:
            self.session.adopt_polish(out.request.job, out.result)
        except ValueError:
            return  # the pose changed since (the session refuses a polish of another pose)
        self.on_done(f"Polished: edge error {out.error_before:.2f}% -> {out.error_after:.2f}% "
                     f"({out.result.iterations} iterations, {out.seconds:.1f} s)")

    def close(self) -> None:
        self.cancel()
        self._pool.shutdown(wait=False, cancel_futures=True)


def _run(request: PolishRequest, stop: threading.Event) -> PolishOutcome | None:
    try:
        return polish(request, stop.is_set)
    finally:
        trim_heap()  # (the polish's working arrays, handed back: as the window's worker does)

"""Opening a shape for the browser editor: the window's build (:class:`~..viewer.model.building.Build`)
in a thread of its own, its progress, the shape read and the end told on the server's event loop, and
a Cancel that stops it at its next step.

The page shows the shape as soon as it is read, and the build's stage and percentage over it until
the engine is ready (an 11M-vertex scan builds for a minute or two; the page is never blank).
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

from ..viewer.model.building import Build, BuildRequest, BuildResult, Cancelled
from ..viewer.model.crash_reports import failure_message, is_crash, write_crash_report
from ..viewer.model.look import Look

__all__ = ["OpeningJob"]


class OpeningJob:
    """One build of the browser editor's shape.

    Parameters
    ----------
    request : what to build (:class:`~..viewer.model.building.BuildRequest`).
    look : the file's look, when the caller read the file (``request.mesh``) already.
    progress : told ``(stage, fraction)`` as the build goes.
    shape_read : told ``(mesh, look, up)`` once the shape is read (``up``: its up axis first).
    finished : told ``(result, message)`` at the end: the :class:`~..viewer.model.building.BuildResult`
        and ``""``, or None and why not ("cancelled", or the one line that says what went wrong).

    Every callback runs on the event loop that :meth:`start` ran on.
    """

    def __init__(self, request: BuildRequest, *, look: Look | None = None,
                 progress: Callable[[str, float], None], shape_read: Callable[[object, object, tuple], None],
                 finished: Callable[[BuildResult | None, str], None]) -> None:
        self.request = request
        self.look = look
        self._progress, self._shape_read, self._finished = progress, shape_read, finished
        self._build: Build | None = None
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="hybridedit-build")
        self.running = False

    def start(self) -> None:
        """Start the build (called on the event loop, which then hears of it)."""
        loop = asyncio.get_running_loop()

        def on_loop(fn):
            return lambda *args: loop.call_soon_threadsafe(fn, *args)

        self._build = Build(self.request, progress=on_loop(self._progress), shape_read=on_loop(self._shape_read))
        self.running = True
        future = loop.run_in_executor(self._pool, self._build.run, self.look)
        future.add_done_callback(self._done)

    def cancel(self) -> None:
        """Stop the build at its next step (``finished`` is told "cancelled")."""
        if self._build is not None:
            self._build.cancel()

    def _done(self, future) -> None:
        self.running = False
        try:
            result = future.result()
        except Cancelled:
            self._finished(None, "cancelled")
        except MemoryError:
            self._finished(None, "not enough memory to build the cage and binding for this shape")
        except Exception as e:  # noqa: BLE001 -- one line for the page, a crash report for a bug
            if is_crash(e):
                report = write_crash_report(e, context="web build")
                self._finished(None, failure_message("The build failed", e, report))
            else:
                self._finished(None, str(e).strip() or type(e).__name__)
        else:
            self._finished(result, "")

    def close(self) -> None:
        """Cancel a build still running and let its thread go."""
        self.cancel()
        self._pool.shutdown(wait=False, cancel_futures=True)

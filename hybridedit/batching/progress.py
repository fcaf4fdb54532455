"""The batch's progress on the terminal: one line with a bar, done / failed / remaining, the rate and
the time left, redrawn in place on a terminal and printed every few seconds into a log.

Examples
--------
>>> import io
>>> out = io.StringIO()
>>> bar = BatchProgress(4, skipped=1, stream=out, clock=iter([0, 60, 120, 120]).__next__, tty=False)
>>> bar.update("done"); bar.update("failed"); bar.close()
>>> print(out.getvalue().splitlines()[-1])
batch: [##############################..........] 3/4: 2 done (1 before), 1 failed, 1 left; 1.0 per minute, 1 min left
"""

from __future__ import annotations

import sys
import time
from typing import Callable, TextIO

from ..core.progress import format_seconds


__all__ = ["BatchProgress", "format_seconds"]

#: a log (not a terminal) gets a line at most this often
LOG_EVERY_SECONDS = 10.0
#: a terminal's line is redrawn at most this often
REDRAW_SECONDS = 0.2
BAR_WIDTH = 40


class BatchProgress:
    """Counts outputs as they finish and shows where the batch is.

    Parameters
    ----------
    total : int
        Outputs in the batch (those done before included).
    skipped : int
        Outputs already done before (counted as done, not in the rate).
    stream : text stream, optional
        Where to write (default ``sys.stderr``).
    quiet : bool
        Show nothing.
    clock : callable, optional
        Seconds, monotonic (default ``time.monotonic``).
    tty : bool, optional
        Redraw one line in place (default: whether ``stream`` is a terminal).
    """

    def __init__(self, total: int, *, skipped: int = 0, stream: TextIO | None = None, quiet: bool = False,
                 clock: Callable[[], float] = time.monotonic, tty: bool | None = None) -> None:
        self.total, self.skipped = int(total), int(skipped)
        self.done, self.failed = self.skipped, 0
        self.stream = sys.stderr if stream is None else stream
        self.quiet = quiet
        self._clock = clock
        self._t0 = clock()
        self._shown = -1e300
        self._open = False
        self._counts: tuple[int, int] | None = None  # (done, failed) when last shown
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)()) if tty is None else tty

    @property
    def remaining(self) -> int:
        return self.total - self.done - self.failed

    def line(self, now: float | None = None) -> str:
        """The progress line (no newline)."""
        now = self._clock() if now is None else now
        finished = self.done + self.failed
        fill = int(BAR_WIDTH * finished / max(self.total, 1))
        made = finished - self.skipped
        elapsed = max(now - self._t0, 1e-9)
        text = (f"batch: [{'#' * fill}{'.' * (BAR_WIDTH - fill)}] {finished}/{self.total}: {self.done} done"
                f"{f' ({self.skipped} before)' if self.skipped else ''}, {self.failed} failed, {self.remaining} left")
        if made > 0:
            rate = made / elapsed
            text += f"; {rate * 60:.1f} per minute"
            if self.remaining:
                text += f", {format_seconds(self.remaining / rate)} left"
        return text

    def _show(self, force: bool = False) -> None:
        if self.quiet:
            return
        now = self._clock()
        if not force and now - self._shown < (REDRAW_SECONDS if self.tty else LOG_EVERY_SECONDS):
            return
        text = self.line(now)
        self._shown, self._counts = now, (self.done, self.failed)
        if self.tty:
            self.stream.write("\r\x1b[K" + text)
            self._open = True
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def update(self, status: str) -> None:
        """Count one output finished with ``status`` ("done" or "failed")."""
        if status == "done":
            self.done += 1
        else:
            self.failed += 1
        self._show(force=self.remaining == 0)

    def say(self, text: str) -> None:
        """Print a line of its own (a failure, a note) above the progress line."""
        if self.quiet:
            return
        self.end_line()
        self.stream.write(text + "\n")
        self.stream.flush()
        self._show(force=True)

    def end_line(self) -> None:
        """End the progress line on a terminal (what is printed next starts on a line of its own)."""
        if self._open:
            self.stream.write("\n")
            self.stream.flush()
            self._open = False

    def close(self) -> None:
        """Show the final line (unless it is shown) and end it."""
        if self._counts != (self.done, self.failed):
            self._show(force=True)
        self.end_line()

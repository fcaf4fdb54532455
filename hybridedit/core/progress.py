"""Progress of the slow steps (read, cage, bind, polish, write) with an estimate of the time left.

The engine reports progress as ``progress(step, fraction)`` calls (see
:data:`hybridedit.binding.rig.Progress`). :class:`StepTimer` turns those calls into
:class:`StepReport` values (elapsed time, estimated time left, whether the step is
worth showing) that a front end renders: :class:`TextProgress` on a terminal or a
log (the CLI), a progress bar in the window. Nothing here imports Qt.

Examples
--------
>>> timer = StepTimer()
>>> r = timer.update("binding", 0.5)
>>> r.step, r.fraction, r.done
('binding', 0.5, False)
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Callable, TextIO

__all__ = ["StepReport", "StepTimer", "TextProgress", "format_seconds"]

#: a step is shown once it has run this long, or is expected to run longer
SHOW_AFTER_SECONDS = 1.0
#: no estimate before a step has run this long ...
MIN_ELAPSED = 0.5
#: ... and advanced by this fraction (an estimate from less is noise)
MIN_ADVANCE = 0.02


def format_seconds(seconds: float) -> str:
    """'3 s', '45 s', '2 min 5 s', '1 h 3 min' (whole seconds, at least 1 s).

    Examples
    --------
    >>> format_seconds(125), format_seconds(3725)
    ('2 min 5 s', '1 h 2 min')
    """
    s = max(1, int(round(seconds)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        m, s = divmod(s, 60)
        return f"{m} min {s} s" if s else f"{m} min"
    h, rest = divmod(s, 3600)
    return f"{h} h {rest // 60} min"


@dataclass(frozen=True)
class StepReport:
    """Where one step is.

    Attributes
    ----------
    step : str
        What the step does, in plain words ("binding").
    fraction : float
        Done of the step, in [0, 1].
    elapsed : float
        Seconds since the step's first report.
    remaining : float or None
        Estimated seconds left, from the step's average rate so far; None while
        too little has happened to tell (see :data:`MIN_ELAPSED`, :data:`MIN_ADVANCE`).
    done : bool
        The step has reported fraction 1.
    """

    step: str
    fraction: float
    elapsed: float
    remaining: float | None
    done: bool

    def worth_showing(self, after: float = SHOW_AFTER_SECONDS) -> bool:
        """True once the step has run ``after`` seconds or is expected to end later than that."""
        if self.elapsed >= after:
            return True
        return self.remaining is not None and self.elapsed + self.remaining >= after

    def eta_text(self) -> str:
        """'about 12 s left', or '' when there is no estimate or the step is done."""
        if self.done or self.remaining is None:
            return ""
        return f"about {format_seconds(self.remaining)} left"

    def text(self) -> str:
        """'binding 42%, about 3 s left', 'binding 42%', or 'binding done (2.31 s)'."""
        if self.done:
            return f"{self.step} done ({self.elapsed:.2f} s)"
        eta = self.eta_text()
        return f"{self.step} {int(100 * self.fraction)}%" + (f", {eta}" if eta else "")


class StepTimer:
    """Turns ``update(step, fraction)`` calls into :class:`StepReport` values.

    A new step name starts a new step (its clock starts at its first report); the
    estimate of the time left is the step's average rate since its last report
    without progress (a step's set-up before its first chunk, such as the
    binding's plan of the points, reports 0 and does not count in the rate),
    which is steady for the engine's steps (chunks of equal work).

    Parameters
    ----------
    clock : callable returning seconds, optional
        ``time.perf_counter`` by default (tests pass a fake clock).
    """

    def __init__(self, clock: Callable[[], float] = time.perf_counter) -> None:
        self._clock = clock
        self._step: str | None = None
        self._t0 = 0.0
        self._t_rate = 0.0
        self._f0 = 0.0

    def update(self, step: str, fraction: float) -> StepReport:
        """Record that ``step`` is ``fraction`` done (clamped to [0, 1]; NaN counts as 0).

        Returns
        -------
        StepReport
        """
        now = self._clock()
        f = float(fraction)
        f = min(max(f, 0.0), 1.0) if f == f else 0.0
        if step != self._step:
            self._step, self._t0, self._f0 = step, now, f
            self._t_rate = now
        elif f <= self._f0:  # no progress yet: the rate is measured from here
            self._t_rate, self._f0 = now, f
        elapsed = now - self._t0
        done = f >= 1.0
        remaining = None
        advanced = f - self._f0
        rate_elapsed = now - self._t_rate
        if not done and rate_elapsed >= MIN_ELAPSED and advanced >= MIN_ADVANCE:
            remaining = rate_elapsed * (1.0 - f) / advanced
        report = StepReport(step, f, elapsed, remaining, done)
        if done:
            self._step = None  # the same name again is a new step
        return report


class TextProgress:
    """The CLI's rendering of progress on a text stream (stderr by default).

    Called as ``say(message)`` it prints ``hybridedit: message``. Called as
    ``say(step, fraction)``: on a terminal one line per step, updated in place
    (at most every 0.1 s) with the percentage and the estimated time left;
    otherwise (a log) one line when the step starts and one with its duration
    when it ends.

    Parameters
    ----------
    quiet : bool
        Print nothing.
    stream : text stream, optional
    clock : callable, optional
    prefix : str
    """

    def __init__(self, quiet: bool = False, stream: TextIO | None = None,
                 clock: Callable[[], float] = time.perf_counter, prefix: str = "hybridedit: ") -> None:
        self.quiet = quiet
        self.out = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.out, "isatty", lambda: False)())
        self.prefix = prefix
        self._clock = clock
        self._timer = StepTimer(clock)
        self._step: str | None = None
        self._finished: str | None = None  # the step that just ended (a repeated end is not a new step)
        self._shown = -1.0
        self._width = 0
        self._open = False  # a step's line is on the terminal, not ended by a newline yet

    def end_line(self) -> None:
        """End a step's line left open on the terminal (a step that stopped before its end, e.g.
        on an error), so that whatever is printed next starts on a line of its own."""
        if self._open:
            print(file=self.out, flush=True)
            self._open = False

    def __call__(self, message: str, fraction: float | None = None) -> None:
        if self.quiet:
            return
        if fraction is None:
            self.end_line()
            print(f"{self.prefix}{message}", file=self.out, flush=True)
            return
        if message == self._finished and fraction >= 1.0:
            return  # the step's end reported again (by a caller and by its callee): said already
        self._finished = None
        r = self._timer.update(message, fraction)
        first = message != self._step
        if first:
            self._step = message
            self._shown = -1.0
            if not self.tty:
                print(f"{self.prefix}{message} ...", file=self.out, flush=True)
        now = self._clock()
        if self.tty and (r.done or first or now - self._shown >= 0.1):
            line = f"{self.prefix}{message} {int(100 * r.fraction):3d}%"
            eta = r.eta_text()
            if eta:
                line += f" ({eta})"
            if r.done:  # wipe what a longer line before left, then the final line
                print("\r" + " " * self._width, end="", file=self.out)
                print(f"\r{line}", file=self.out, flush=True)
                self._open = False
            else:
                print(f"\r{line}", end="", file=self.out, flush=True)
                self._open = True
            self._width = len(line)
            self._shown = now
        elif r.done and not self.tty:
            print(f"{self.prefix}{r.text()}", file=self.out, flush=True)
        if r.done:
            self._step = None
            self._finished = message

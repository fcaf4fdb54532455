"""How far a file is read or written: format modules report, the front passes it on.

:func:`hybridedit.fileio.formats.read_document` and :func:`~hybridedit.fileio.formats.write_document`
install a callback with :func:`reporting`; a format module calls :func:`report`
with the fraction of its work done (between passes, or per chunk of rows), inside
:func:`span` where one pass covers only part of the whole. With no callback
installed, reporting costs a lookup. A callback may raise (the window's cancel):
the exception goes through the format module to the caller.

Examples
--------
>>> seen = []
>>> with reporting(seen.append):
...     with span(0.5, 1.0):
...         report(0.5)
>>> seen
[0.75]
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["report", "reporting", "span"]

_sink: ContextVar[Callable[[float], None] | None] = ContextVar("hybridedit_file_progress", default=None)
_range: ContextVar[tuple[float, float]] = ContextVar("hybridedit_file_progress_range", default=(0.0, 1.0))


@contextmanager
def reporting(callback: Callable[[float], None] | None) -> Iterator[None]:
    """Send the fractions reported inside to ``callback(fraction)`` (None: nowhere)."""
    token, whole = _sink.set(callback), _range.set((0.0, 1.0))
    try:
        yield
    finally:
        _range.reset(whole)
        _sink.reset(token)


@contextmanager
def span(lo: float, hi: float) -> Iterator[None]:
    """Fractions reported inside cover [lo, hi] of the enclosing range."""
    a, b = _range.get()
    token = _range.set((a + (b - a) * lo, a + (b - a) * hi))
    try:
        yield
    finally:
        _range.reset(token)


def report(fraction: float) -> None:
    """The current pass is ``fraction`` (0..1) done."""
    sink = _sink.get()
    if sink is not None:
        a, b = _range.get()
        sink(a + (b - a) * min(max(float(fraction), 0.0), 1.0))

"""Handing freed memory back to the system (:func:`trim_heap`).

glibc's malloc keeps what a program frees for its next allocations: after an undo history drops old
snapshots (copies of the shape, freed in the hundreds of MB) the resident set stays where it was, and
over a long session grows as those holes fragment (the window on the creature: 1,145 MB at cycle 100,
1,293 MB at cycle 500, while what Python held stayed flat). ``malloc_trim`` returns the free pages
of every arena. Elsewhere (macOS, Windows, musl) there is no such call and nothing is done.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import sys

__all__ = ["trim_heap"]

_trim = None
if sys.platform.startswith("linux"):
    try:
        _trim = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
        _trim.argtypes, _trim.restype = [ctypes.c_size_t], ctypes.c_int
    except (OSError, AttributeError):  # not glibc
        _trim = None


def trim_heap() -> bool:
    """Give the free pages of the C heap back to the system (glibc's ``malloc_trim(0)``); True when
    some were, False when none were or the C library has no such call."""
    return bool(_trim(0)) if _trim is not None else False

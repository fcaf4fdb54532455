"""Ending a process that has run the window or VTK, without the interpreter's teardown.

When Python finalizes, Qt (PySide6) and VTK objects still alive are destroyed in
no particular order, and a refcount error in one of those C extensions can abort
the process after all the work is done ("Fatal Python error: none_dealloc",
exit 134, seen once after a clean benchmark run; one cause found since: PySide6
6.12.0 before Python 3.12 drops a reference to None on every call that returns
nothing, which pyproject.toml leaves out). A process whose work is done, its
files written atomically and closed, loses nothing by skipping that teardown:
:func:`leave` flushes the output streams and logging and ends the process with
its exit status.
"""

from __future__ import annotations

import logging
import os
import sys

__all__ = ["leave", "uses_window"]


def uses_window() -> bool:
    """True once Qt or VTK has been loaded in this process."""
    return any(m in sys.modules for m in ("PySide6", "vtkmodules"))


def leave(status: int) -> None:
    """Flush standard output, standard error and logging, then end the process with ``status``."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    logging.shutdown()
    os._exit(int(status))

"""One loop body, compiled twice: the serial and the parallel twin of a kernel.

A kernel whose work is worth two threads only from some size comes in twins, chosen by
:func:`hybridedit.core.parallel.pick`. :func:`twins` makes both from one Python function whose
loop is a ``numba.prange``: compiled with ``parallel=False`` numba types and lowers ``prange`` as
a plain ``range`` (so the serial twin is the loop a ``range`` would give, bit for bit), and with
``parallel=True`` the loop is spread over the threads.

Both twins are cached on disk. numba names a cached kernel by its function's qualified name and
first line, not by its compile options, so two dispatchers of one function would read each
other's compiled code; the parallel twin is therefore compiled from a copy of the function
renamed ``<name>__parallel`` (same code, globals and file: the cache still notices edits to the
file).

A kernel module writes the loop once and chooses at the call::

    @twins(error_model="numpy")
    def _double(x, out):
        for i in prange(x.shape[0]):
            out[i] = 2.0 * x[i]

    pick("propagate", *_double, x.shape[0])(x, out)
"""

from __future__ import annotations

import sys
import types
from typing import Callable, NamedTuple

from numba import njit

#: added to the parallel copy's name (its cache entry's name)
PARALLEL_SUFFIX = "__parallel"


class Twins(NamedTuple):
    """The two compiled versions of one kernel; ``pick(kind, *twins, n)`` chooses one."""

    serial: Callable
    parallel: Callable


def twins(**options) -> Callable[[Callable], Twins]:
    """Decorator: the function compiled as ``njit(cache=True, **options)`` and, from a renamed
    copy, as ``njit(cache=True, parallel=True, **options)``."""

    def make(fn: Callable) -> Twins:
        return Twins(serial=njit(cache=True, **options)(fn),
                     parallel=njit(cache=True, parallel=True, **options)(renamed(fn, PARALLEL_SUFFIX)))

    return make


def renamed(fn: types.FunctionType, suffix: str) -> types.FunctionType:
    """A copy of ``fn`` (same code, globals, defaults and closure) whose name and qualified name
    end in ``suffix``.

    Examples
    --------
    >>> def f(x):
    ...     return x + 1
    >>> g = renamed(f, PARALLEL_SUFFIX)
    >>> g.__qualname__, g(1)
    ('f__parallel', 2)
    """
    name = fn.__name__ + suffix
    qualname = fn.__qualname__ + suffix
    names = {"co_name": name}
    if sys.version_info >= (3, 11):
        names["co_qualname"] = qualname
    copy = types.FunctionType(fn.__code__.replace(**names), fn.__globals__, name, fn.__defaults__,
                              fn.__closure__)
    copy.__qualname__ = qualname
    copy.__kwdefaults__ = fn.__kwdefaults__
    copy.__doc__ = fn.__doc__
    copy.__module__ = fn.__module__
    return copy

"""The memory an object graph holds: the distinct array buffers reachable from it, each counted once.

Snapshots of an editing session share arrays (a selection step keeps the pose of the step before it;
a view shares its base's buffer), so their size is not the sum of their arrays' ``nbytes``: here a
buffer is named by the array that owns it (the end of the ``.base`` chain), and every buffer reached
is counted once. An undo history adds and removes snapshots by these names
(:class:`~hybridedit.viewer.model.history.History`).
"""

from __future__ import annotations

import dataclasses
import types

import numpy as np

__all__ = ["held_buffers", "owner"]

_ATOMS = (str, bytes, bytearray, int, float, complex, bool, type(None), type, types.ModuleType,
          types.BuiltinFunctionType, np.dtype, np.generic)


def owner(a: np.ndarray) -> np.ndarray:
    """The array that owns ``a``'s buffer: ``a`` itself, or the last array of its ``.base`` chain."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def held_buffers(*objs, skip: frozenset[int] | set[int] = frozenset(), out: dict[int, int] | None = None
                 ) -> dict[int, int]:
    """The distinct buffers reachable from ``objs``: {id of the buffer's owner: bytes}.

    Followed: tuples, lists, sets, dicts (their values), dataclass fields, instance ``__dict__`` and
    ``__slots__``, a function's closure, a bound method's object, and scipy's sparse matrices (their
    arrays are attributes). An array counts the bytes of the array that owns its buffer (:func:`owner`).
    Another object with an integer ``nbytes``
    (e.g. :class:`~hybridedit.core.linsolve.SPDSolver`'s estimate of its factor) counts that, and is
    not followed further. Anything else (a C extension's object) counts nothing.

    Parameters
    ----------
    objs : the roots.
    skip : ids of buffer owners (and objects) not counted nor followed: what the roots share with
        something that outlives them (an engine's own arrays, under its snapshots).
    out : a dict to add to (its keys are not counted again), returned.

    Notes
    -----
    The ids name live objects: they hold as long as the roots are alive.
    """
    found: dict[int, int] = {} if out is None else out
    seen: set[int] = set()
    stack = list(objs)
    while stack:
        o = stack.pop()
        if isinstance(o, _ATOMS):
            continue
        k = id(o)
        if k in seen or k in skip:
            continue
        seen.add(k)
        if isinstance(o, np.ndarray):
            own = owner(o)
            if id(own) not in skip:
                found.setdefault(id(own), int(own.nbytes))
            continue
        if isinstance(o, dict):
            stack.extend(o.values())
            continue
        if isinstance(o, (tuple, list, set, frozenset)):
            stack.extend(o)
            continue
        if isinstance(o, types.MethodType):
            stack.append(o.__self__)
            continue
        if isinstance(o, types.FunctionType):
            for cell in o.__closure__ or ():
                try:
                    stack.append(cell.cell_contents)
                except ValueError:  # an empty cell
                    pass
            continue
        nbytes = getattr(o, "nbytes", None)
        if isinstance(nbytes, (int, np.integer)) and not isinstance(nbytes, bool):
            found.setdefault(k, int(nbytes))
            continue
        if dataclasses.is_dataclass(o):
            stack.extend(getattr(o, f.name, None) for f in dataclasses.fields(o))
        d = getattr(o, "__dict__", None)
        if isinstance(d, dict):
            stack.extend(d.values())
        for klass in type(o).__mro__:
            for name in getattr(klass, "__slots__", ()):
                if isinstance(name, str) and name not in ("__dict__", "__weakref__"):
                    stack.append(getattr(o, name, None))
    return found

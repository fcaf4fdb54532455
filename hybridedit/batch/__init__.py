"""Posing at dataset scale on a Dask cluster (``hybridedit batch``, ``he.batch``).

One module a job: :mod:`~hybridedit.batch.settings` (the arguments, checked),
:mod:`~hybridedit.batch.plan` (inputs found, one job per output), :mod:`~hybridedit.batch.poses`
(plausible random poses: extremities, regions, joints, seeded draws),
:mod:`~hybridedit.batch.tasks` (what the workers run), :mod:`~hybridedit.batch.graph` (the task graph
and its results), :mod:`~hybridedit.batch.manifest` (``manifest.parquet``),
:mod:`~hybridedit.batch.progress` (the terminal line), :mod:`~hybridedit.batch.cluster` (the Dask
client) and :mod:`~hybridedit.batch.api` (:func:`~hybridedit.batch.api.batch`).

``hybridedit.batch`` is this package and, called, :func:`hybridedit.batch.api.batch`: the package is a
submodule of ``hybridedit``, which the import system binds as ``hybridedit.batch`` once anything
imports it, so the name is the same object in every import order (``he.batch(inputs, out, poses=N)``).
Dask and pyarrow (``pip install 'hybridedit[batch]'``) are imported only when a batch runs.
"""

from __future__ import annotations

import sys
import types

__all__ = ["batch"]


def batch(*args, **kwargs):
    """:func:`hybridedit.batch.api.batch` (see there)."""
    from .api import batch as run_batch

    return run_batch(*args, **kwargs)


class _CallablePackage(types.ModuleType):
    """This package, callable as :func:`batch`."""

    def __call__(self, *args, **kwargs):
        return batch(*args, **kwargs)


sys.modules[__name__].__class__ = _CallablePackage

"""Posing at dataset scale on a Dask cluster (``hybridedit batch``, ``he.batch``).

One module a job: :mod:`~hybridedit.batching.settings` (the arguments, checked),
:mod:`~hybridedit.batching.plan` (inputs found, one job per output), :mod:`~hybridedit.batching.poses`
(plausible random poses: regions, rotations and seeded draws on the limb skeleton of
:mod:`hybridedit.deform.skeleton`),
:mod:`~hybridedit.batching.tasks` (what the workers run), :mod:`~hybridedit.batching.graph` (the task
graph and its results), :mod:`~hybridedit.batching.manifest` (``manifest.parquet``),
:mod:`~hybridedit.batching.progress` (the terminal line), :mod:`~hybridedit.batching.cluster` (the
Dask client) and :mod:`~hybridedit.batching.api` (:func:`~hybridedit.batching.api.batch`, exported as
``hybridedit.batch``).

The package is ``batching``, not ``batch``: a package attribute named like a submodule would change
with imports (the import system binds ``hybridedit.batch`` to the submodule once anything imports
it), so ``he.batch`` is the function whatever was imported before. Dask and pyarrow (``pip install
'hybridedit[batch]'``) are imported only when a batch runs.
"""

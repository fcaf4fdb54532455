"""The Dask cluster a batch runs on: a client given by the caller, a running scheduler's address, or a
``LocalCluster`` of worker processes started (and stopped) for the batch.

A local cluster has ``workers`` processes of one thread each (the batch's parallelism is its
processes: each pose is one task), each with the engine's compiled kernels on ``cores // workers``
threads; Dask's nanny already keeps BLAS and OpenMP to one thread a worker. Its dashboard listens on a
free port, and has pages to show where the scheduler has bokeh (``pip install bokeh``).
"""

from __future__ import annotations

import importlib.util
import os
from contextlib import contextmanager
from typing import Iterator

__all__ = ["ClusterError", "open_client", "dashboard_link", "needs_dask"]


class ClusterError(RuntimeError):
    """The cluster cannot be had (Dask missing, the scheduler unreachable); the message says why."""


def needs_dask() -> None:
    """Raise :class:`ClusterError` saying how to install Dask and pyarrow when either is missing."""
    missing = [name for name, module in (("dask[distributed]", "distributed"), ("pyarrow", "pyarrow"))
               if importlib.util.find_spec(module) is None]
    if missing:
        raise ClusterError(f"hybridedit batch needs {' and '.join(missing)}: pip install 'hybridedit[batch]'")


def _has_bokeh() -> bool:
    return importlib.util.find_spec("bokeh") is not None


def dashboard_link(client) -> str | None:
    """The Dask dashboard's address, when the scheduler serves one (its pages need bokeh there)."""
    try:
        services = client.scheduler_info().get("services", {})
        if "dashboard" not in services or not client.run_on_scheduler(_has_bokeh):
            return None
    except Exception:  # noqa: BLE001 -- no dashboard to tell of
        return None
    return client.dashboard_link


@contextmanager
def open_client(*, client=None, scheduler: str | None = None, workers: int | None = None,
                timeout: float = 20.0) -> Iterator[object]:
    """A ``distributed.Client`` for the batch, closed after it unless it was given.

    Parameters
    ----------
    client : distributed.Client, optional
        Used as it is (and left open).
    scheduler : str, optional
        The address of a running scheduler (``tcp://HOST:PORT``), started with ``dask scheduler``.
    workers : int, optional
        Worker processes of the local cluster (default: the core count).
    timeout : float
        Seconds to wait for the scheduler.

    Yields
    ------
    distributed.Client
    """
    if client is not None:
        yield client
        return
    needs_dask()
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            own = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError) as e:
            raise ClusterError(f"cannot reach the Dask scheduler at {scheduler}: {' '.join(str(e).split())}") from None
        with own:
            yield own
        return
    cores = os.cpu_count() or 1
    n = cores if workers is None else int(workers)
    if n < 1:
        raise ClusterError(f"workers must be >= 1, got {n}")
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                           env={"NUMBA_NUM_THREADS": str(max(1, cores // n))})
    try:
        with Client(cluster) as own:
            yield own
    finally:
        cluster.close()

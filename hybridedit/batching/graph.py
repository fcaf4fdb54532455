"""The batch's task graph on a Dask client, and its results as they arrive.

:func:`outputs_done` asks the workers for the hashes a re-run checks (inputs, the edit files given,
the outputs a manifest row says are done) and returns the outputs that need not be made again.
:func:`submit` then gives Dask one ``bind`` task per input still to pose (read, cage and binding
through the cache, skeleton) and one ``pose`` task per output depending on it, so that each mesh is
bound once and posed N times from that; in the edits mode, one ``replay`` task per output. Pose tasks
run before further binds (a higher priority), so a worker finishes a mesh's poses before it binds
another, and a bound mesh is let go once its poses are done. :func:`results` yields a manifest row per
task as each finishes; a task whose retries are spent (an exception, or workers lost under it) is a
failed row saying so.
"""

from __future__ import annotations

import uuid
from typing import Iterator

from .manifest import Manifest, file_sha256, new_row, verified
from .plan import Job
from .settings import BatchSettings
from .tasks import bind_input, pose_output, replay_output

__all__ = ["outputs_done", "submit", "results"]

#: Dask priorities: a mesh's poses before the next mesh's bind
BIND_PRIORITY, POSE_PRIORITY = 0, 10


def outputs_done(client, jobs: list[Job], settings: BatchSettings, manifest: Manifest) -> set[str]:
    """The outputs of ``jobs`` made before with these settings from the same input (and edit file),
    whose files still have the hashes their rows record.

    Parameters
    ----------
    client : distributed.Client
    jobs : list of Job
    settings : BatchSettings
    manifest : Manifest
        The output folder's rows.

    Returns
    -------
    set of str
        Their ``output`` paths.
    """
    candidates = [j for j in jobs if j.output in manifest.rows and manifest.rows[j.output].get("status") == "done"]
    if not candidates:
        return set()
    paths = sorted({j.input for j in candidates} | {j.source_edit for j in candidates if j.source_edit})
    hashes = dict(zip(paths, client.gather(client.map(file_sha256, paths, pure=False))))
    key = settings.key()
    claimed = []
    for j in candidates:
        row = manifest.claimed_done(j.output, settings=key, input_sha256=hashes[j.input])
        if row is not None and (j.source_edit is None or hashes[j.source_edit] == row.get("edit_sha256")):
            claimed.append(row)
    folder = str(manifest.folder)
    ok = client.gather(client.map(verified, claimed, folder=folder, pure=False))
    return {row["output"] for row, good in zip(claimed, ok) if good}


def submit(client, jobs: list[Job], settings: BatchSettings, outdir: str, *, retries: int = 2) -> dict:
    """Give Dask the tasks that make ``jobs``.

    Parameters
    ----------
    client : distributed.Client
    jobs : list of Job
        The outputs to make (none already done).
    settings : BatchSettings
    outdir : str
        The output folder (as the workers see it).
    retries : int
        Times Dask runs a task again after an exception (a lost worker's tasks are rerun elsewhere
        regardless).

    Returns
    -------
    dict
        {future: Job}, one future per job.
    """
    run = uuid.uuid4().hex[:8]  # keys of their own on a scheduler other batches share
    futures = {}
    if settings.mode == "edits":
        for i, job in enumerate(jobs):
            futures[_job_task(client, job, settings, outdir, f"{run}-{i}", retries)] = job
        return futures
    by_input: dict[str, list[Job]] = {}
    for job in jobs:
        by_input.setdefault(job.input, []).append(job)
    for m, (path, its) in enumerate(by_input.items()):
        bound = _bind_task(client, path, settings, f"{run}-{m}", retries)
        for job in its:
            futures[_job_task(client, job, settings, outdir, f"{run}-{m}-{job.pose}", retries, bound)] = job
        del bound  # Dask lets the bound mesh go once its poses are done
    return futures


def _bind_task(client, path: str, settings: BatchSettings, key: str, retries: int):
    """The future of ``path``'s binding (its key ``hybridedit-bind-KEY``)."""
    return client.submit(bind_input, path, settings.cage_size, key=f"hybridedit-bind-{key}", retries=retries,
                         priority=BIND_PRIORITY)


def _job_task(client, job: Job, settings: BatchSettings, outdir: str, key: str, retries: int, bound=None):
    """The future that makes ``job``: its edit replayed (the edits mode), or its pose from the
    binding future ``bound`` (keys ``hybridedit-replay-KEY`` / ``hybridedit-pose-KEY``)."""
    if settings.mode == "edits":
        return client.submit(replay_output, job, settings, outdir, key=f"hybridedit-replay-{key}", retries=retries,
                             priority=POSE_PRIORITY)
    return client.submit(pose_output, bound, job, settings, outdir, key=f"hybridedit-pose-{key}", retries=retries,
                         priority=POSE_PRIORITY)


def _failed(job: Job, settings: BatchSettings, error: BaseException | None) -> dict:
    """The row of a task Dask gave up on."""
    from distributed import KilledWorker

    if isinstance(error, KilledWorker):
        why = "the workers running it died too often (Dask gave up: KilledWorker)"
    elif error is None:
        why = "cancelled"
    else:
        why = f"{type(error).__name__}: {' '.join(str(error).split()) or 'no message'} (after Dask's retries)"
    return new_row(input=job.input, output=job.output, edit=job.edit, pose=job.pose,
                   seed=settings.seed if settings.mode == "poses" else None, settings=settings.key(),
                   status="failed", message=f"internal error: {why}")


def resubmit(client, job: Job, settings: BatchSettings, outdir: str, *, retries: int = 2):
    """A new future that makes ``job`` alone (its binding made again for a pose): for a task Dask
    reported cancelled without anyone cancelling it (it can, when the worker holding a task's
    dependency is killed as the task is handed on), or whose row was lost with its worker."""
    key = uuid.uuid4().hex[:8] + "-again"
    bound = None if settings.mode == "edits" else _bind_task(client, job.input, settings, key, retries)
    return _job_task(client, job, settings, outdir, key, retries, bound)


#: times a job whose task came back cancelled (or lost) is submitted again before it is reported failed
CANCELLED_AGAIN = 2


def results(futures: dict, settings: BatchSettings, *, again=None) -> Iterator[tuple[Job, dict]]:
    """(job, manifest row) for each task as it finishes, in the order they finish.

    ``again`` (job -> future), when given, makes a job whose task came back cancelled or lost again,
    up to :data:`CANCELLED_AGAIN` times (:func:`resubmit`), instead of reporting it failed: nobody
    cancels a batch's tasks but Dask itself, after losing a worker, and a finished task's row is lost
    when the worker holding it dies before it is gathered (its output file is written by then; made
    again, it is written again, atomically, the same)."""
    from distributed import as_completed

    tries: dict[str, int] = {}
    pending = as_completed(list(futures))
    for f in pending:
        job = futures.pop(f)
        row = None
        if f.status == "finished":
            try:
                row = f.result()
            except Exception:  # noqa: BLE001 -- lost (or cancelled) since it finished: its worker died
                row = None
        if row is None and f.status != "error" and again is not None \
                and tries.get(job.output, 0) < CANCELLED_AGAIN:
            tries[job.output] = tries.get(job.output, 0) + 1
            f.release()
            nf = again(job)
            futures[nf] = job
            pending.add(nf)
            continue
        if row is None:  # the task's own error, or Dask gave up on it (cancelled, lost: no error)
            try:
                error = f.exception() if f.status == "error" else None
            except Exception as e:  # noqa: BLE001 -- (cancelled meanwhile)
                error = e
            row = _failed(job, settings, error)
        f.release()
        yield job, row

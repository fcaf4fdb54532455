"""The batch's task graph on a Dask client, and its results as they arrive.

:func:`plan_work` asks the workers for the hashes a re-run checks (inputs, the edit files given,
the outputs, packs or staged poses a manifest row says are made) and returns what is left to do.
:func:`submit` then gives Dask one ``bind`` task per input still to pose (read, cage and binding
through the cache, skeleton) and one ``pose`` task per output depending on it, so that each mesh is
bound once and posed N times from that; in the edits mode, one ``replay`` task per output. With a
pack, one ``pack`` task per input depends on its binding and its pose tasks and writes the pack
(:mod:`hybridedit.batching.packing`). Packs run before further poses, and poses before further
binds (priorities), so a worker finishes a mesh before it binds another, and a bound mesh is let go
once its poses and pack are done. :func:`results` yields a manifest row per pose task as each
finishes, and a pack's rows when it is written; a task whose retries are spent (an exception, or
workers lost under it) is a failed row saying so.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass, field
from typing import Iterator

from .manifest import Manifest, file_sha256, new_row, row_files
from .packing import PACKED, pack_input
from .plan import Job, PackJob, pack_jobs
from .settings import BatchSettings
from .tasks import bind_input, pose_output, replay_output

__all__ = ["Work", "PackTask", "plan_work", "submit", "results", "resubmit", "repack"]

#: Dask priorities: an input's pack before more poses, a mesh's poses before the next mesh's bind
BIND_PRIORITY, POSE_PRIORITY, PACK_PRIORITY = 0, 10, 20


@dataclass(frozen=True)
class PackTask:
    """A pack to write: its job, and the rows of its poses made before this run (carried, not posed
    again: staged, or in the pack already), by output."""

    pack: PackJob
    carried: dict = field(default_factory=dict)


@dataclass
class Work:
    """What a batch has left to do.

    Attributes
    ----------
    jobs : list of Job
        The outputs to pose (or replay).
    packs : list of PackTask
        The packs to write (with a pack).
    done : set of str
        The outputs made before and kept: not made again (their rows stand).
    """

    jobs: list
    packs: list
    done: set


def plan_work(client, jobs: list[Job], settings: BatchSettings, manifest: Manifest) -> Work:
    """What is left of ``jobs``: an output made before with these settings from the same input (and
    edit file), whose files still have the hashes its row records, is not made again.

    With a pack, a pose made before (staged, or in a pack whose hash its row records) is not posed
    again, and an input's pack is written unless it holds every pose of the input already.

    Parameters
    ----------
    client : distributed.Client
    jobs : list of Job
    settings : BatchSettings
    manifest : Manifest
        The output folder's rows.

    Returns
    -------
    Work
    """
    packed = settings.pack is not None
    candidates = [j for j in jobs if j.output in manifest.rows
                  and manifest.rows[j.output].get("status") in (PACKED if packed else ("done",))]
    good: dict[str, dict] = {}
    if candidates:
        paths = sorted({j.input for j in candidates} | {j.source_edit for j in candidates if j.source_edit})
        hashes = dict(zip(paths, client.gather(client.map(file_sha256, paths, pure=False))))
        key = settings.key()
        claimed = []
        for j in candidates:
            row = manifest.claimed_done(j.output, settings=key, input_sha256=hashes[j.input], posed=packed)
            if row is not None and (j.source_edit is None or hashes[j.source_edit] == row.get("edit_sha256")):
                claimed.append(row)
        files = sorted({name for row in claimed for name, _ in row_files(row)})  # a pack is hashed once
        folder = manifest.folder
        found = dict(zip(files, client.gather(client.map(file_sha256, [str(folder / f) for f in files],
                                                          pure=False))))
        good = {row["output"]: row for row in claimed
                if all(sha is not None and found[name] == sha for name, sha in row_files(row))}
    if not packed:
        return Work([j for j in jobs if j.output not in good], [], set(good))
    work = Work([], [], set())
    for pack in pack_jobs(jobs):
        carried = {j.output: good[j.output] for j in pack.jobs if j.output in good}
        work.done |= {o for o, row in carried.items() if row["status"] == "done"}
        whole = {row.get("pack_sha256") for row in carried.values()}
        if len(carried) == len(pack.jobs) and all(r["status"] == "done" for r in carried.values()) and len(whole) == 1:
            continue  # the pack holds every pose already
        work.jobs.extend(j for j in pack.jobs if j.output not in carried)
        work.packs.append(PackTask(pack, carried))
    return work


def submit(client, work: Work | list[Job], settings: BatchSettings, outdir: str, *, retries: int = 2) -> dict:
    """Give Dask the tasks that make ``work``.

    Parameters
    ----------
    client : distributed.Client
    work : Work, or list of Job
        What to make (nothing already done); a list: those outputs, no pack.
    settings : BatchSettings
    outdir : str
        The output folder (as the workers see it).
    retries : int
        Times Dask runs a task again after an exception (a lost worker's tasks are rerun elsewhere
        regardless).

    Returns
    -------
    dict
        {future: Job} one future per job, and {future: PackTask} one per pack.
    """
    if not isinstance(work, Work):
        work = Work(list(work), [], set())
    run = uuid.uuid4().hex[:8]  # keys of their own on a scheduler other batches share
    futures: dict = {}
    if settings.mode == "edits":
        for i, job in enumerate(work.jobs):
            futures[_job_task(client, job, settings, outdir, f"{run}-{i}", retries)] = job
        return futures
    by_input: dict[str, list[Job]] = {}
    for job in work.jobs:
        by_input.setdefault(job.input, []).append(job)
    packs = {task.pack.input: task for task in work.packs}
    for m, path in enumerate(dict.fromkeys([*by_input, *packs])):
        its = by_input.get(path, [])
        bound = _bind_task(client, path, settings, f"{run}-{m}", retries) if its else None
        posing = {}
        for job in its:
            f = _job_task(client, job, settings, outdir, f"{run}-{m}-{job.pose}", retries, bound)
            futures[f] = job
            posing[job.output] = f
        if path in packs:
            task = packs[path]
            items = [posing[j.output] if j.output in posing else task.carried[j.output] for j in task.pack.jobs]
            futures[_pack_task(client, task, items, settings, outdir, f"{run}-{m}", retries, bound)] = task
        del bound  # Dask lets the bound mesh go once its poses (and its pack) are done
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


def _pack_task(client, task: PackTask, items: list, settings: BatchSettings, outdir: str, key: str, retries: int,
               bound=None):
    """The future that writes ``task``'s pack from ``items``, each pose's row or the future of its
    pose task (key ``hybridedit-pack-KEY``)."""
    return client.submit(pack_input, bound, task.pack, items, settings, outdir, key=f"hybridedit-pack-{key}",
                         retries=retries, priority=PACK_PRIORITY)


def _failed(job: Job, settings: BatchSettings, error: BaseException | None) -> dict:
    """The row of a task Dask gave up on."""
    return new_row(input=job.input, output=job.output, edit=job.edit, pose=job.pose,
                   seed=settings.seed if settings.mode == "poses" else None, settings=settings.key(),
                   status="failed", message=f"internal error: {_why(error)}")


def _why(error: BaseException | None) -> str:
    """Why Dask gave a task up, in words."""
    from distributed import KilledWorker

    if isinstance(error, KilledWorker):
        return "the workers running it died too often (Dask gave up: KilledWorker)"
    if error is None:
        return "cancelled"
    return f"{type(error).__name__}: {' '.join(str(error).split()) or 'no message'} (after Dask's retries)"


def resubmit(client, job: Job, settings: BatchSettings, outdir: str, *, retries: int = 2):
    """A new future that makes ``job`` alone (its binding made again for a pose): for a task Dask
    reported cancelled without anyone cancelling it (it can, when the worker holding a task's
    dependency is killed as the task is handed on), or whose row was lost with its worker."""
    key = uuid.uuid4().hex[:8] + "-again"
    bound = None if settings.mode == "edits" else _bind_task(client, job.input, settings, key, retries)
    return _job_task(client, job, settings, outdir, key, retries, bound)


def repack(client, task: PackTask, rows: list[dict], settings: BatchSettings, outdir: str, *, retries: int = 2):
    """A new future that writes ``task``'s pack from its poses' rows as they came back: for a pack
    whose pose tasks (its dependencies) failed or were made again, or that Dask gave up itself."""
    return _pack_task(client, task, rows, settings, outdir, uuid.uuid4().hex[:8] + "-again", retries)


#: times a job whose task came back cancelled (or lost) is submitted again before it is reported failed
CANCELLED_AGAIN = 2


def _row_of(f) -> object | None:
    """A finished future's result, or None when it did not finish (or was lost since)."""
    if f.status != "finished":
        return None
    try:
        return f.result()
    except Exception:  # noqa: BLE001 -- lost (or cancelled) since it finished: its worker died
        return None


def _error_of(f) -> BaseException | None:
    """The exception of a future that erred (None: cancelled or lost)."""
    try:
        return f.exception() if f.status == "error" else None
    except Exception as e:  # noqa: BLE001 -- (cancelled meanwhile)
        return e


def results(futures: dict, settings: BatchSettings, *, again=None, repack=None) -> Iterator[tuple[object, object]]:
    """(job, manifest row) for each pose (or replay) task as it finishes, in the order they finish,
    and (pack job, its rows) for each pack.

    ``again`` (job -> future), when given, makes a job whose task came back cancelled or lost again,
    up to :data:`CANCELLED_AGAIN` times (:func:`resubmit`), instead of reporting it failed: nobody
    cancels a batch's tasks but Dask itself, after losing a worker, and a finished task's row is lost
    when the worker holding it dies before it is gathered (its output file is written by then; made
    again, it is written again, atomically, the same). ``repack`` (pack task, rows -> future) makes
    a pack that did not finish again (:func:`repack`) once each of its poses has its row, from those
    rows, up to :data:`CANCELLED_AGAIN` times; after that (or without ``repack``) its poses are
    failed rows saying why."""
    from distributed import as_completed

    tries: dict[str, int] = {}
    seen: dict[str, dict] = {}  # each pose's latest row
    packed: set[str] = set()    # outputs a pack wrote: a late row of the same pose is stale
    waiting: dict[str, PackTask] = {}  # packs to make again once their poses have rows
    pending = as_completed(list(futures))
    for f in pending:
        what = futures.pop(f)
        if isinstance(what, PackTask):
            made = _row_of(f)
            name = what.pack.pack
            if made is None and repack is not None and tries.get(name, 0) < CANCELLED_AGAIN:
                tries[name] = tries.get(name, 0) + 1
                waiting[name] = what
            elif made is None:
                why = _why(_error_of(f))
                made = [new_row(**{**{k: v for k, v in row.items() if k != "finished"}, "status": "failed",
                                   "message": f"internal error: its pack {name}: {why}"})
                        for row in _pose_rows(what, seen) if row is not None and row.get("status") == "posed"]
            f.release()
            if made is not None:
                packed |= {row["output"] for row in made}
                yield what.pack, made
        else:
            job = what
            row = _row_of(f)
            if row is None and f.status != "error" and again is not None \
                    and tries.get(job.output, 0) < CANCELLED_AGAIN:
                tries[job.output] = tries.get(job.output, 0) + 1
                f.release()
                nf = again(job)
                futures[nf] = job
                pending.add(nf)
                continue
            if row is None:  # the task's own error, or Dask gave up on it (cancelled, lost: no error)
                row = _failed(job, settings, _error_of(f))
            f.release()
            if job.output in packed:
                continue  # made again after its pack was written (its first row was lost): stale
            seen[job.output] = row
            yield job, row
        for name, task in list(waiting.items()):
            rows = _pose_rows(task, seen)
            if all(row is not None for row in rows):
                del waiting[name]
                nf = repack(task, rows)
                futures[nf] = task
                pending.add(nf)


def _pose_rows(task: PackTask, seen: dict) -> list:
    """The rows of a pack's poses in pose order: this run's, else those carried (None: not back yet)."""
    return [seen.get(j.output) or task.carried.get(j.output) for j in task.pack.jobs]

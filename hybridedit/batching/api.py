"""``he.batch``: pose a dataset on a Dask cluster and get its manifest as a table."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence, TextIO

from ..defaults import CAGE_SIZE
from .plan import find_inputs, plan_jobs
from .settings import BatchSettings, PoseSettings

__all__ = ["batch", "run", "BatchResult"]


@dataclass
class BatchResult:
    """What a batch made.

    Attributes
    ----------
    table : pyarrow.Table
        The manifest's rows of this batch's outputs, in input and pose order.
    made, failed, skipped : int
        Outputs made now, failed now, and already done before (not made again).
    manifest : Path
        ``OUTDIR/manifest.parquet``.
    dashboard : str or None
        The Dask dashboard's address, when there was one.
    """

    table: object
    made: int
    failed: int
    skipped: int
    manifest: Path
    dashboard: str | None = None


def run(inputs: Sequence[str | os.PathLike[str]] | str | os.PathLike[str], out: str | os.PathLike[str], *,
        settings: BatchSettings, client=None, scheduler: str | None = None, workers: int | None = None,
        retries: int = 2, progress: bool = True, stream: TextIO | None = None) -> BatchResult:
    """Run a batch (see :func:`batch`) with checked settings; the counts with the table.

    Raises
    ------
    hybridedit.batching.plan.InputError
        An input names nothing, or the output folder is a file.
    hybridedit.batching.cluster.ClusterError
        Dask is missing or the scheduler cannot be reached.
    """
    from .cluster import dashboard_link, needs_dask, open_client
    from .graph import plan_work, repack, resubmit, results, submit
    from .manifest import Manifest
    from .plan import InputError, PackJob
    from .progress import BatchProgress

    needs_dask()
    outdir = Path(out)
    if outdir.exists() and not outdir.is_dir():
        raise InputError(f"{outdir}: the output folder is a file")
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    if settings.mode == "edits" and not Path(settings.edits).is_dir():
        raise InputError(f"{settings.edits}: the --edits folder does not exist")
    found = find_inputs(inputs, exclude=outdir)
    jobs = plan_jobs(found, poses=settings.poses, edits=settings.edits, output_format=settings.output_format,
                     pack=settings.pack_extension)
    sources = {j.input for j in jobs}
    clash = next((j.pack or j.output for j in jobs if str((outdir / (j.pack or j.output)).resolve()) in sources), None)
    if clash is not None:
        raise InputError(f"{outdir / clash}: an output would replace its input; choose another output folder")
    outdir.mkdir(parents=True, exist_ok=True)
    manifest = Manifest(outdir)
    err = sys.stderr if stream is None else stream
    final: dict[str, str] = {}  # each output's status as its last row says
    try:
        with open_client(client=client, scheduler=scheduler, workers=workers) as c:
            link = dashboard_link(c)
            work = plan_work(c, jobs, settings, manifest)
            bar = BatchProgress(len(jobs), skipped=len(jobs) - len(work.jobs), stream=err, quiet=not progress)
            if link:
                bar.say(f"hybridedit: batch: Dask dashboard at {link}")
            outpath = str(outdir.resolve())
            futures = submit(c, work, settings, outpath, retries=retries)
            for what, got in results(futures, settings,
                                     again=lambda job: resubmit(c, job, settings, outpath, retries=retries),
                                     repack=lambda task, rows: repack(c, task, rows, settings, outpath,
                                                                      retries=retries)):
                if isinstance(what, PackJob):  # a pack written (its poses' rows), or not (why, once)
                    for row in got:
                        manifest.add(row)
                        final[row["output"]] = row["status"]
                    if got and got[0]["status"] == "failed":
                        bar.say(f"hybridedit: failed: {what.pack}: {got[0]['message']}")
                    continue
                manifest.add(got)
                final[what.output] = got["status"]
                bar.update("failed" if got["status"] == "failed" else "done")  # (posed: made, to be packed)
                if got["status"] == "failed":
                    bar.say(f"hybridedit: failed: {what.output}: {got['message']}")
            bar.close()
    finally:
        manifest.close()
    made = sum(status == "done" and out not in work.done for out, status in final.items())
    failed = sum(status != "done" for status in final.values())
    return BatchResult(manifest.table([j.output for j in jobs]), made, failed, len(work.done), manifest.path, link)


def batch(inputs: Sequence[str | os.PathLike[str]] | str | os.PathLike[str], out: str | os.PathLike[str], *,
          poses: int | None = None, edits: str | os.PathLike[str] | None = None, seed: int = 0, client=None,
          scheduler: str | None = None, workers: int | None = None, cage_size: int | float = CAGE_SIZE,
          output_format: str | None = None, pack: str | None = None, max_degrees: float = 45.0,
          max_stretch: float = 50.0, min_move: float = 2.0, tries: int = 8, handles: int = 2, retries: int = 2,
          progress: bool = True):
    """Pose every mesh of a dataset on a Dask cluster: N random plausible poses each, or the edit file
    given for each; every output with its edit file, and a manifest row per output.

    Parameters
    ----------
    inputs : path, or sequence of paths
        Mesh files, folders (searched below) or glob patterns; every format ``hybridedit deform``
        reads.
    out : path
        The output folder: the outputs, their edit files and ``manifest.parquet``.
    poses : int, optional
        Random poses per mesh (give this or ``edits``).
    edits : path, optional
        A folder with an edit file per mesh, ``<stem>.json`` or ``<stem>.edit.json``.
    seed : int
        Pose k of a mesh is drawn from (seed, the file's content hash, k) alone: the same seed makes
        the same files whatever the workers.
    client : distributed.Client, optional
        Run on this client's cluster (left open).
    scheduler : str, optional
        Or on a running scheduler, ``tcp://HOST:PORT``.
    workers : int, optional
        Or on a local cluster of this many worker processes (default: the core count).
    cage_size : int or float
        The cage of the poses (vertex count or fraction).
    output_format : str, optional
        The outputs' extension (".ply"); default each input's own.
    pack : {"glb", "usd"}, optional
        With ``poses``: one file per input holding all its poses, ``<stem>-poses.glb`` (glTF morph
        targets) or ``<stem>-poses.usdc`` (USD blend shapes; needs usd-core), instead of one mesh
        per pose (see :func:`hybridedit.save_poses`).
    max_degrees : float
        Largest rotation of a limb about its joint (or of a bend or twist of the main axis).
    max_stretch : float
        Largest edge stretch, in percent, of a pose kept; a pose over it is drawn again.
    min_move : float
        Least largest displacement of a pose kept, in percent of the bounding-box diagonal; a pose
        under it is drawn again (after ``tries`` draws, the one that moved most, its row saying so).
    tries : int
        Draws of one pose before it is a failed row.
    handles : int
        Most limbs one pose moves.
    retries : int
        Times Dask reruns a task that raised.
    progress : bool
        Show the progress line on standard error.

    Returns
    -------
    pyarrow.Table
        The manifest's rows of these outputs (see :mod:`hybridedit.batching.manifest` for the columns),
        in input and pose order; ``table.to_pandas()`` makes a DataFrame where pandas is installed.

    Raises
    ------
    ValueError
        A setting out of range, an input that names nothing (:class:`~hybridedit.batching.plan.InputError`).
    hybridedit.batching.cluster.ClusterError
        Dask or pyarrow missing, the scheduler unreachable.

    Examples
    --------
    >>> import hybridedit as he
    >>> import pyarrow.compute as pc  # doctest: +SKIP
    >>> table = he.batch(["scans/"], "posed/", poses=10, seed=1)  # doctest: +SKIP
    >>> table.filter(pc.field("status") == "failed").column("message")  # doctest: +SKIP
    >>> he.batch(["scans/"], "packed/", poses=20, pack="glb").column("pack")  # doctest: +SKIP
    """
    settings = BatchSettings(poses=poses, edits=None if edits is None else str(edits), seed=seed,
                             cage_size=cage_size, output_format=output_format, pack=pack,
                             pose=PoseSettings(max_degrees=max_degrees, max_stretch=max_stretch, tries=tries,
                                               handles=handles, min_move=min_move))
    return run(inputs, out, settings=settings, client=client, scheduler=scheduler, workers=workers,
               retries=retries, progress=progress).table

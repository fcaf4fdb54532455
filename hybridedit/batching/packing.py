"""The pack task: an input's poses written into one file, glTF morph targets or USD blend shapes.

A batch with ``--pack glb`` (or ``usd``) gives Dask one :func:`pack_input` task per input, depending
on that input's pose tasks (and on its binding, so that Dask runs it where the rest document
already is). The pose tasks have each written the pose's edit file and staged its differences from
the rest (:func:`hybridedit.batching.tasks.stage`); the pack task writes ``<stem>-poses.glb``
(``.usdc``) with :func:`hybridedit.save_poses` from the rest document, every attribute of the input
kept, with a target ``pose-000``, ``pose-001``, ... per pose that succeeded (a failed one is left
out; its row says why), then removes the staged files it packed. It returns the rows it changed:
each packed pose "done", naming the pack and its SHA-256.

A pose already in a pack with the hash its row records (a re-run) is not staged any more: when the
pack stays as it is (no new pose succeeded), nothing is written; when it must be written again (more
poses asked for, a pose that failed now made), such a pose is replayed from its edit file, as
``hybridedit deform`` replays it.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..core.command_line import one_line
from .manifest import file_sha256, new_row
from .plan import PackJob
from .settings import BatchSettings

__all__ = ["pack_input", "PACKED"]

#: the statuses of a pose a pack holds (or will): made and staged, or in a pack already
PACKED = ("posed", "done")


def _deltas(path: Path, n: int) -> np.ndarray:
    """A staged pose, (n, 3) float64 (ValueError when it is not one of ``n`` vertices)."""
    d = np.load(path, allow_pickle=False)
    if d.shape != (n, 3) or not np.isfinite(d).all():
        raise ValueError(f"{path.name}: a staged pose of shape {d.shape}, not ({n}, 3) finite")
    return d.astype(np.float64)


def _replayed(input_path: str, edit_path: Path, settings: BatchSettings, state: dict) -> np.ndarray:
    """A pose packed before, replayed from its edit file on the input's editor (made once, in
    ``state``), as ``hybridedit deform`` replays it."""
    from ..deform.editor import HybridEditor
    from ..fileio.editfile import load_edit
    from .tasks import _replay, bind_input

    if "editor" not in state:
        bound = state.get("bound") or bind_input(input_path, settings.cage_size)
        if bound.failure is not None:
            raise ValueError(bound.failure)
        state["editor"] = HybridEditor(bound.rig)
    return _replay(state["editor"], load_edit(edit_path), name=edit_path.name)


def pack_input(bound, pack: PackJob, rows: list[dict], settings: BatchSettings, outdir: str) -> list[dict]:
    """Write one input's pack from its poses' rows; the rows it changed.

    Parameters
    ----------
    bound : hybridedit.batching.tasks.Bound or None
        The input read and bound by this batch (None: it is read here, and bound only to replay a
        pose packed before).
    pack : PackJob
        The pack and its poses.
    rows : list of dict
        Each pose's manifest row, in ``pack.jobs`` order: "posed" (staged), "done" (in the pack
        already) or "failed".
    settings : BatchSettings
    outdir : str
        The output folder.

    Returns
    -------
    list of dict
        The rows of the poses packed now ("done", with ``pack`` and ``pack_sha256``), or, when the
        pack could not be written, the staged poses "failed" saying why (the file on disk, if any,
        is left as it was, and the poses it holds with it); empty when nothing changed
        (no pose succeeded, or the pack on disk holds these poses already).
    """
    from ..fileio.formats import MeshFileError
    from ..fileio.meshfiles import read_document
    from ..fileio.poses import save_poses
    from .tasks import _READ_ERRORS

    out = Path(outdir)
    chosen = [(job, row) for job, row in zip(pack.jobs, rows) if row.get("status") in PACKED]
    if not chosen:
        return []
    old = {row.get("pack_sha256") for _, row in chosen if row["status"] == "done"}
    if all(row["status"] == "done" for _, row in chosen) and len(old) == 1 \
            and file_sha256(out / pack.pack) == next(iter(old)):
        return []  # the pack holds exactly these poses already
    t0 = time.perf_counter()
    try:
        state = {"bound": bound if bound is not None and bound.failure is None else None}
        doc = state["bound"].document if state["bound"] is not None else read_document(pack.input)
        rest = doc.mesh.vertices
        poses = []
        for job, row in chosen:
            if row["status"] == "posed":
                poses.append(rest + _deltas(out / job.staged, len(rest)))
            else:
                poses.append(_replayed(pack.input, out / job.edit, settings, state))
        notes = save_poses(out / pack.pack, doc, poses, names=[job.target for job, _ in chosen])
    except (MeshFileError, *_READ_ERRORS) as e:  # an unwritable folder, usd-core missing, a staged file lost
        why = f"{Path(pack.pack).name}: the pack could not be written: {one_line(e)}"
        return [_changed(row, status="failed", message=why, pack_seconds=time.perf_counter() - t0)
                for _, row in chosen if row["status"] == "posed"]  # (a pose in the old pack stays there)
    sha = file_sha256(out / pack.pack)
    seconds = time.perf_counter() - t0
    for job, row in chosen:  # packed: the staged files are no longer needed
        if row["status"] == "posed":
            (out / job.staged).unlink(missing_ok=True)
    _prune(out / pack.jobs[0].staged, out)
    made = []
    for _, row in chosen:
        kept = [m for m in str(row.get("message") or "").split("; ") if m and m not in notes]
        made.append(_changed(row, status="done", pack=pack.pack, pack_sha256=sha, pack_seconds=seconds,
                             output_sha256=None, message="; ".join([*kept, *notes])))
    return made


def _changed(row: dict, **fields) -> dict:
    """``row`` with ``fields`` changed, finished now."""
    return new_row(**{**{k: v for k, v in row.items() if k != "finished"}, **fields})


def _prune(staged: Path, outdir: Path) -> None:
    """Remove the staging folders above ``staged`` that are empty now, up to the output folder."""
    folder = staged.parent
    while folder != outdir and outdir in folder.parents:
        try:
            folder.rmdir()
        except OSError:  # not empty (other packs' poses wait there), or gone
            return
        folder = folder.parent

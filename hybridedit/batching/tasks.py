"""The work a batch's tasks do on a Dask worker: hash a file, bind a mesh, pose it, replay an edit
(the pack task, which gathers an input's poses into one file, is :mod:`hybridedit.batching.packing`).

Each function here runs in a worker process (Dask imports this module there by name): it imports
the engine (``hybridedit.*``, never Qt or VTK), makes its outputs with the project's atomic writes,
and returns a manifest row (a dict of :data:`hybridedit.batching.manifest.COLUMNS`). A mesh the method
cannot serve (unreadable, no cage, no pose within the stretch allowed) is a ``failed`` row with a
one-line reason, never an exception; an exception that escapes (a bug, a lost resource) is Dask's to
retry, and the client records it as failed once the retries are spent.

An output is replayable: its edit file is written first, and the pose written is the replay of that
very file (read back as ``hybridedit deform`` reads it) on the editor ``deform`` builds. A pose bound
for a pack is not written as a mesh: its differences from the rest wait, as float32, in a staged file
(:func:`hybridedit.batching.plan.staged_path`) for the pack task.

A pose is drawn from the shape's limbs (:mod:`hybridedit.batching.poses`) when it has any, else
along its main axis (:mod:`hybridedit.batching.axis_poses`), and drawn again while it stretches an
edge over ``max_stretch`` or moves the shape less than ``min_move``; a shape with limbs whose first
half of the draws found no such pose draws the rest along its axis.
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.command_line import one_line
from ..core.face_geometry import centre_of_mass
from ..defaults import CAGE_SIZE, SETTLE_FRAMES
from ..deform.skeleton import Skeleton, find_skeleton
from .axis_poses import MainAxis, draw_axis_pose, main_axis, vertex_areas
from .manifest import file_sha256, new_row
from .plan import Job
from .poses import draw_pose, limb_extremities, limbs_only, pose_rng
from .settings import BatchSettings

__all__ = ["Bound", "bind_input", "pose_output", "replay_output", "edge_errors", "moved_percent", "stage"]

#: the engine's errors that mean "this input cannot be served" (a failed row, no retry)
_READ_ERRORS: tuple[type[BaseException], ...] = (OSError, ValueError, MemoryError, RecursionError)


def _worker_name() -> str:
    """The Dask worker running this task (its address), or "client" outside one."""
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return "client"


def edge_errors(rest: np.ndarray, posed: np.ndarray, edges: np.ndarray) -> tuple[float, float]:
    """(relative RMS edge-length error, largest |stretch|), both in percent.

    Parameters
    ----------
    rest, posed : (n, 3) float64
    edges : (e, 2) int64
    """
    from ..core.mesh import rrms_edge_error

    l0 = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=1)
    l1 = np.linalg.norm(posed[edges[:, 1]] - posed[edges[:, 0]], axis=1)
    ok = l0 > 0
    stretch = float(np.abs((l1[ok] - l0[ok]) / l0[ok]).max() * 100.0) if ok.any() else 0.0
    return float(rrms_edge_error(rest, posed, edges)), stretch


def moved_percent(rest: np.ndarray, posed: np.ndarray) -> float:
    """How far a pose moved the shape: its largest vertex displacement, in percent of the rest's
    bounding-box diagonal (0 for a shape of no size).

    Parameters
    ----------
    rest, posed : (n, 3) float64
    """
    size = float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))) if len(rest) else 0.0
    return float(np.linalg.norm(posed - rest, axis=1).max() / size * 100.0) if size > 0 else 0.0


@dataclass
class Bound:
    """One input read and bound: what its pose tasks share (c cage vertices, n shape vertices).

    Attributes
    ----------
    path : str
    sha256 : str or None
        The content hash of the bytes read (None: unreadable).
    failure : str or None
        Why the input cannot be posed (then the rest is None).
    document : hybridedit.Document
    rig : hybridedit.Rig
    skeleton : Skeleton
    limbs : (k,) bool
        Which of the skeleton's extremities are limbs (:func:`hybridedit.batching.poses.limb_extremities`).
    axis : MainAxis
        The shape's main axis (the poses of a shape without limbs).
    dominant : (n,) int64
        Each shape vertex's dominant cage vertex.
    edges : (e, 2) int64
        The shape's edges.
    read_seconds, bind_seconds : float
    cache_hit : bool
    """

    path: str
    sha256: str | None
    failure: str | None = None
    document: object = None
    rig: object = None
    skeleton: Skeleton | None = None
    limbs: np.ndarray | None = None
    axis: MainAxis | None = None
    dominant: np.ndarray | None = None
    edges: np.ndarray | None = None
    read_seconds: float = 0.0
    bind_seconds: float = 0.0
    cache_hit: bool = False


def bind_input(path: str, cage_size: int | float = CAGE_SIZE) -> Bound:
    """Read a mesh, bind it to its cage (through the on-disk cache), find its skeleton, its limbs and
    its main axis.

    Parameters
    ----------
    path : str
        The mesh file (every format ``hybridedit deform`` reads).
    cage_size : int or float
        Cage vertex count or fraction.

    Returns
    -------
    Bound
        With ``failure`` set (one line) when the file cannot be read or bound.
    """
    from ..binding.rig import build_rig
    from ..fileio.meshfiles import read_document

    name = Path(path).name
    sha = file_sha256(path)
    if sha is None:
        return Bound(path, None, failure=f"{name}: cannot be read")
    t0 = time.perf_counter()
    try:
        doc = read_document(path)
    except _READ_ERRORS as e:
        return Bound(path, sha, failure=one_line(e), read_seconds=time.perf_counter() - t0)
    t1 = time.perf_counter()
    try:
        rig = build_rig(doc.mesh, cage_size=cage_size, cache=True)
    except _READ_ERRORS as e:
        return Bound(path, sha, failure=f"{name}: no cage or binding: {one_line(e)}", read_seconds=t1 - t0,
                     bind_seconds=time.perf_counter() - t1)
    edges = np.concatenate([rig.cage.edges(), np.asarray(rig.links, dtype=np.int64).reshape(-1, 2)])
    mesh = doc.mesh
    skeleton = find_skeleton(rig.cage.vertices, edges, centre_of_mass(mesh.vertices, mesh.faces))
    dominant = np.asarray(rig.M.argmax(axis=1)).ravel().astype(np.int64)
    shape_edges = mesh.edges()
    limbs = limb_extremities(skeleton, dominant=dominant, vertices=mesh.vertices, edges=shape_edges)
    axis = main_axis(mesh.vertices, vertex_areas(mesh.vertices, mesh.faces))
    return Bound(path, sha, None, doc, rig, skeleton, limbs, axis, dominant, shape_edges, t1 - t0,
                 time.perf_counter() - t1, bool(rig.cache_hit))


def _row(job: Job, settings: BatchSettings, **fields) -> dict:
    """A manifest row of ``job`` (the columns not given are empty)."""
    return new_row(input=job.input, output=job.output, edit=job.edit, pose=job.pose,
                   seed=settings.seed if settings.mode == "poses" else None, settings=settings.key(),
                   worker=_worker_name(), **fields)


def _as_file_holds(edit):
    """The edit as its file reads back (``hybridedit deform`` replays what ``load_edit`` gives)."""
    from ..fileio.editfile import parse_edit

    return parse_edit(json.loads(json.dumps(edit.to_json())), "<pose>")


def _replay(editor, edit, *, name: str, editor_for_cage=None) -> np.ndarray:
    """``hybridedit deform``'s replay: from the rest pose, each step on the cage it records."""
    editor.reset()
    V = editor.apply_edit(edit, frames=SETTLE_FRAMES, path=name, editor_for_cage=editor_for_cage)
    if not np.all(np.isfinite(V)):
        raise ValueError("the deformation produced non-finite positions; the edit is too extreme")
    return np.array(V)


def _write(outdir: Path, job: Job, document, V: np.ndarray) -> tuple[str, list[str]]:
    """The posed document written to the job's output (atomically); (its SHA-256, the writer's notes)."""
    from ..fileio.meshfiles import write_document

    dst = outdir / job.output
    dst.parent.mkdir(parents=True, exist_ok=True)
    notes = write_document(dst, document.with_vertices(V))
    return file_sha256(dst) or "", list(notes)


@dataclass
class _Drawn:
    """The pose kept for an output: its edit, shape, errors and the draws it took (edit None: no pose
    within the stretch allowed, ``why`` says so; else ``why`` says why it moves less than asked,
    or is empty)."""

    edit: object
    V: np.ndarray | None
    rrms: float | None
    stretch: float | None
    moved: float | None
    draws: int
    why: str = ""


def _draw(bound: Bound, job: Job, settings: BatchSettings, editor, cage: dict, fingerprint: dict) -> _Drawn:
    """Draw pose ``job.pose`` until one is within the stretch allowed and moves at least ``min_move``;
    failing that, the one within the stretch that moved most."""
    p = settings.pose
    rng = pose_rng(settings.seed, bound.sha256, job.pose)
    mesh = bound.rig.mesh
    limbs = limbs_only(bound.skeleton, bound.limbs)
    along_axis_from = 1 if len(limbs.extremities) == 0 else (p.tries + 1) // 2 + 1
    best: _Drawn | None = None
    tried: list[tuple[float, float]] = []  # (moved, stretch) of each pose solved
    reason = "no limb could be drawn on the shape"
    for draw in range(1, p.tries + 1):
        if draw >= along_axis_from:
            edit, why = draw_axis_pose(bound.axis, rng, max_degrees=p.max_degrees, iterations=p.iterations,
                                       cage=cage, fingerprint=fingerprint)
            if edit is None:
                reason = why
                continue
        else:
            edit = draw_pose(limbs, rng, dominant=bound.dominant, vertices=mesh.vertices, edges=bound.edges,
                             handles=p.handles, max_degrees=p.max_degrees, iterations=p.iterations, cage=cage,
                             fingerprint=fingerprint)
            if edit is None:
                continue
        edit = _as_file_holds(edit)
        try:
            V = _replay(editor, edit, name=job.edit)
        except ValueError as e:  # a selection the editor refuses, a pose that blew up
            reason = one_line(e)
            continue
        rrms, stretch = edge_errors(mesh.vertices, V, bound.edges)
        moved = moved_percent(mesh.vertices, V)
        tried.append((moved, stretch))
        if stretch > p.max_stretch:
            continue
        if best is None or moved > best.moved:
            best = _Drawn(edit, V, rrms, stretch, moved, draw)
        if moved >= p.min_move:
            return best
    if best is not None:
        more = sum(m > best.moved for m, _ in tried)
        best.draws = p.tries
        best.why = (f"moved {best.moved:.2f}% of the diagonal, under --min-move {p.min_move:g}%: "
                    + (f"the {more} draw{'s' if more != 1 else ''} that moved more stretched over --max-stretch "
                       f"{p.max_stretch:g}%" if more else f"no draw of {p.tries} moved more"))
        return best
    if tried:
        reason = (f"no pose within --max-stretch {p.max_stretch:g}% in {p.tries} draws "
                  f"(the least stretched: {min(s for _, s in tried):.1f}%)")
    return _Drawn(None, None, None, None, None, p.tries, reason)


def stage(path: Path, deltas: np.ndarray) -> str:
    """Write a pose's differences from the rest, (n, 3), as float32 to ``path`` (atomically); its
    SHA-256.

    Float32 differences, not positions: a vertex the pose leaves is an exact 0 (the pack stores
    only what moved), and the rounding is relative to the motion, not to where the shape sits.
    """
    from ..fileio.atomic import atomic_write

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "wb") as f:
        np.save(f, np.ascontiguousarray(deltas, dtype="<f4"), allow_pickle=False)
    return file_sha256(path) or ""


def pose_output(bound: Bound, job: Job, settings: BatchSettings, outdir: str) -> dict:
    """Make one random pose of a bound input: draw, replay, judge, write the edit then the output.

    Parameters
    ----------
    bound : Bound
        The input, read and bound (:func:`bind_input`).
    job : Job
        The output to make (its pose index, output and edit paths).
    settings : BatchSettings
    outdir : str
        The batch's output folder.

    Returns
    -------
    dict
        The manifest row.
    """
    from ..deform.editor import HybridEditor
    from ..fileio.editfile import mesh_fingerprint, save_edit

    common = dict(input_sha256=bound.sha256, read_seconds=bound.read_seconds, bind_seconds=bound.bind_seconds,
                  cache_hit=bound.cache_hit)
    if bound.failure is not None:
        return _row(job, settings, status="failed", message=bound.failure, **common)
    t0 = time.perf_counter()
    rig = bound.rig
    editor = HybridEditor(rig)
    cage = {"size": rig.cage_size, "vertices": int(rig.cage.n_vertices)}
    got = _draw(bound, job, settings, editor, cage, mesh_fingerprint(rig.mesh))
    t1 = time.perf_counter()
    if got.edit is None:
        return _row(job, settings, status="failed", message=f"{Path(job.input).name}: {got.why}", draws=got.draws,
                    pose_seconds=t1 - t0, **common)
    out = Path(outdir)
    (out / job.edit).parent.mkdir(parents=True, exist_ok=True)
    save_edit(out / job.edit, got.edit)
    if job.pack is not None:  # the pack task writes it with the input's other poses
        sha, notes, status = stage(out / job.staged, got.V - bound.document.mesh.vertices), [], "posed"
    else:
        (sha, notes), status = _write(out, job, bound.document, got.V), "done"
    return _row(job, settings, status=status, message="; ".join([got.why, *notes] if got.why else notes),
                output_sha256=sha, edit_sha256=file_sha256(out / job.edit), draws=got.draws, edge_error=got.rrms,
                max_stretch=got.stretch, moved=got.moved, pose_seconds=t1 - t0,
                write_seconds=time.perf_counter() - t1, **common)


def replay_output(job: Job, settings: BatchSettings, outdir: str) -> dict:
    """Replay a given edit file on its mesh as ``hybridedit deform`` does, and write the output with a
    copy of the edit beside it.

    Parameters
    ----------
    job : Job
        Its ``source_edit`` is the edit file to replay (None: none was found for the mesh).
    settings : BatchSettings
    outdir : str

    Returns
    -------
    dict
        The manifest row.
    """
    from ..binding.rig import build_rig
    from ..deform.editor import HybridEditor
    from ..fileio.editfile import load_edit
    from ..fileio.meshfiles import read_document

    name = Path(job.input).name
    sha = file_sha256(job.input)
    if sha is None:
        return _row(job, settings, status="failed", message=f"{name}: cannot be read")
    if job.source_edit is None:
        return _row(job, settings, status="failed", input_sha256=sha,
                    message=f"{name}: no edit file for it in the --edits folder")
    t0 = time.perf_counter()
    try:
        edit = load_edit(job.source_edit)
        doc = read_document(job.input)
    except _READ_ERRORS as e:
        return _row(job, settings, status="failed", input_sha256=sha, message=one_line(e),
                    read_seconds=time.perf_counter() - t0)
    t1 = time.perf_counter()
    mesh = doc.mesh
    recorded = [s.cage for s in edit.steps if s.cage is not None]
    size = recorded[-1]["size"] if recorded else CAGE_SIZE

    def editor_on(cage_size):
        return HybridEditor(build_rig(mesh, cage_size=cage_size, cache=True))

    try:
        editor = editor_on(size)
        t2 = time.perf_counter()
        V = _replay(editor, edit, name=job.source_edit, editor_for_cage=lambda c: editor_on(c["size"]))
    except _READ_ERRORS as e:
        return _row(job, settings, status="failed", input_sha256=sha, message=one_line(e), read_seconds=t1 - t0,
                    bind_seconds=time.perf_counter() - t1)
    t3 = time.perf_counter()
    out = Path(outdir)
    (out / job.edit).parent.mkdir(parents=True, exist_ok=True)
    from ..fileio.atomic import atomic_write

    with atomic_write(out / job.edit, "wb") as f, open(job.source_edit, "rb") as src:
        shutil.copyfileobj(src, f)
    out_sha, notes = _write(out, job, doc, V)
    rrms, stretch = edge_errors(mesh.vertices, V, mesh.edges())
    return _row(job, settings, status="done", message="; ".join(notes), input_sha256=sha, output_sha256=out_sha,
                edit_sha256=file_sha256(out / job.edit), edge_error=rrms, max_stretch=stretch,
                moved=moved_percent(mesh.vertices, V),
                read_seconds=t1 - t0, bind_seconds=t2 - t1, pose_seconds=t3 - t2,
                write_seconds=time.perf_counter() - t3, cache_hit=bool(editor.cache_hit))

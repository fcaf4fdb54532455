"""Autosaved unsaved poses, and their recovery after an unclean exit (Qt-free).

While the pose on display is not saved, the window keeps a *recovery file* in the user cache folder
(:func:`recovery_folder`): the session's edit (every step since the rest pose, as an edit file holds
it), the selection on the cage, the kept poses (:mod:`.pose_library`, as an edit file's ``poses``),
and what the shape is (its file, its fingerprint, the cage). A clean
save or quit removes it. A recovery file whose process is gone is *orphaned*: the process died (a
crash, a kill, a power cut), and :func:`orphans` finds it on the next start so that the pose can be
replayed exactly (:func:`recover`), as ``hybridedit deform`` replays a saved edit.

One file per window process and shape, named ``<topology hash>-<pid>.json``: two windows on one
shape do not write over each other, and a file of a live process is never offered.
"""

from __future__ import annotations

import json
import os
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...core.cache_dir import default_cache_dir
from ...deform.packed_step import unpack_step_json
from ...deform.selection import SelectionError
from ...fileio.atomic import atomic_write
from ...fileio.editfile import (Edit, EditFileError, check_mesh, mesh_fingerprint, parse_edit, parse_pose_list,
                                pose_list_json, steps_document)
from .pose_library import replay_poses

if TYPE_CHECKING:
    from .session import Session

__all__ = ["FORMAT", "Recovery", "RecoveryError", "RecoveryFile", "recovery_folder", "orphans", "recover",
           "process_alive"]

FORMAT = "hybridedit-recovery"
#: 2: the edit's index lists packed (:meth:`~hybridedit.deform.packed_step.PackedStep.to_json`); 1: as lists
VERSION = 2
READS = (1, 2)
#: a recovery file larger than this is refused as damaged (an edit of 10,000 steps is a few MB)
MAX_BYTES = 256 * 2**20


class RecoveryError(ValueError):
    """A recovery file that cannot be read or does not fit the shape (the message names the file)."""


def recovery_folder(folder: str | os.PathLike | None = None) -> Path:
    """Where recovery files live: ``folder``, else ``recovery/`` in the user cache folder
    (:func:`~hybridedit.core.cache_dir.default_cache_dir`)."""
    return Path(folder) if folder is not None else default_cache_dir() / "recovery"


def process_alive(pid: int, host: str | None = None) -> bool:
    """Whether process ``pid`` of this machine runs (a file written on another ``host``: unknown, so not).

    >>> process_alive(os.getpid())
    True
    """
    if host is not None and host != socket.gethostname():
        return False
    if pid == os.getpid():
        return True
    if pid <= 0:
        return False
    if sys.platform == "win32":  # (os.kill(pid, 0) would send CTRL_C_EVENT there)
        import ctypes

        k32 = ctypes.windll.kernel32
        h = k32.OpenProcess(0x1000, False, pid)  # PROCESS_QUERY_LIMITED_INFORMATION
        if not h:
            return False
        code = ctypes.c_ulong()
        k32.GetExitCodeProcess(h, ctypes.byref(code))
        k32.CloseHandle(h)
        return code.value == 259  # STILL_ACTIVE
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


@dataclass(frozen=True)
class Recovery:
    """An unsaved pose found in a recovery file.

    Attributes
    ----------
    file : the recovery file.
    mesh_path : the mesh file the pose was made on (absolute), or None (a shape made in memory).
    mesh_name : its name, for messages.
    fingerprint : the shape's :func:`~hybridedit.fileio.editfile.mesh_fingerprint`.
    cage_size, cage_vertices : the cage the pose was made on (as the toolbar gives it, and its vertices).
    saved_at : when it was written (seconds since the epoch).
    pid, host : the process that wrote it.
    edit : the steps since the rest pose (:class:`~hybridedit.fileio.editfile.Edit`), or None.
    selection : the selection on the cage: ``roi`` (indices), ``handle_group`` (int8 per cage vertex,
        as ``[[index, role], ...]``), ``n_groups``, ``active``, ``symmetry``.
    poses : the kept poses, ``((name, edit), ...)`` (none in a file written before there were any).
    """

    file: Path
    mesh_path: Path | None
    mesh_name: str
    fingerprint: dict
    cage_size: int | float
    cage_vertices: int
    saved_at: float
    pid: int
    host: str
    edit: Edit | None
    selection: dict
    poses: tuple = ()

    @property
    def steps(self) -> int:
        """How many steps the pose took (the edit's selections and polishes)."""
        return 0 if self.edit is None else len(self.edit.steps)

    def summary(self) -> str:
        """'creature.ply (7 steps, 12:41)': the shape, its steps (and kept poses) and when it was saved,
        in words."""
        t = time.localtime(self.saved_at)
        when = time.strftime("%H:%M", t) if time.localtime()[:3] == t[:3] else time.strftime("%Y-%m-%d %H:%M", t)
        n, k = self.steps, len(self.poses)
        kept = f", {k} kept pose{'s' if k != 1 else ''}" if k else ""
        return f"{self.mesh_name} ({n} step{'s' if n != 1 else ''}{kept}, {when})"

    @property
    def orphaned(self) -> bool:
        """The process that wrote it is gone: it did not exit cleanly."""
        return not process_alive(self.pid, self.host)

    def fits(self, mesh) -> bool:
        """The recovery was made on ``mesh`` (its fingerprint)."""
        try:
            check_mesh(Edit(handles=[], mesh=self.fingerprint), mesh, str(self.file))
        except EditFileError:
            return False
        return True

    def discard(self) -> None:
        """Remove the recovery file (missing already: nothing to do)."""
        self.file.unlink(missing_ok=True)


def _selection_json(session: Session) -> dict:
    sel = session.selection
    groups = np.flatnonzero(sel.handle_group)
    return {"roi": np.flatnonzero(sel.roi).tolist(),
            "handle_group": np.column_stack([groups, sel.handle_group[groups]]).tolist(),
            "n_groups": int(sel.n_groups), "active": int(sel.active), "symmetry": sel.symmetry}


def _edit_json(session: Session, fingerprint: dict) -> dict | None:
    """The steps that made the session's pose (the engine's edit) as an edit file's JSON, each index list
    packed (:meth:`~hybridedit.deform.packed_step.PackedStep.to_json`), or None before any selection.

    Written from the engine's packed record as it is: the edit file's own form (each list unpacked, then
    a Python int per index) held about a megabyte a step on the creature while it was written, every
    write, so that a long session's resident memory grew with its steps."""
    try:
        steps = session.editor.packed_steps()
    except SelectionError:
        return None
    return steps_document([p.to_json() for p in steps], fingerprint)


def _edit_of_json(d, version: int):
    """The edit JSON of a recovery file of ``version`` in the edit file's own form (version 2's packed
    lists unpacked; ValueError for one that does not unpack)."""
    if version >= 2 and isinstance(d, dict) and isinstance(d.get("steps"), list):
        d = dict(d, steps=[unpack_step_json(s) for s in d["steps"]])
    return d


class RecoveryFile:
    """The recovery file of one window process: written while the pose is unsaved, removed when it is
    saved or the window quits.

    Parameters
    ----------
    folder : where it is written (default: :func:`recovery_folder`).

    Examples
    --------
    >>> import tempfile, trimesh, hybridedit as he
    >>> from hybridedit.viewer.model.session import Session
    >>> ball = trimesh.creation.icosphere(3)
    >>> ed = he.HybridEditor(he.Mesh(ball.vertices, ball.faces), 100)
    >>> keeper = RecoveryFile(folder=tempfile.mkdtemp())
    >>> path = keeper.write(Session(ed, cage_size=100))
    >>> read_recovery(path).steps  # a rest pose: no steps yet
    0
    >>> keeper.remove(); path.exists()
    False
    """

    def __init__(self, *, folder: str | os.PathLike | None = None) -> None:
        self.folder = recovery_folder(folder)
        self.path: Path | None = None  # the file written last, until removed
        self._fingerprint: tuple[object, dict] | None = None  # (mesh, its fingerprint): hashed once a shape

    def fingerprint(self, mesh) -> dict:
        """``mesh``'s :func:`~hybridedit.fileio.editfile.mesh_fingerprint` (hashed once per shape)."""
        if self._fingerprint is None or self._fingerprint[0] is not mesh:
            self._fingerprint = (mesh, mesh_fingerprint(mesh))
        return self._fingerprint[1]

    def write(self, session: Session) -> Path:
        """Write the session's pose and selection atomically (over the last one written); returns the path.

        Raises
        ------
        OSError
            The folder cannot be written (the caller says so; the session is untouched).
        """
        fp = self.fingerprint(session.mesh)
        path = self.folder / f"{fp['topology']}-{os.getpid()}.json"
        data = {
            "format": FORMAT, "version": VERSION, "pid": os.getpid(), "host": socket.gethostname(),
            "saved_at": time.time(),
            "mesh_path": None if session.path is None else str(Path(session.path).absolute()),
            "mesh_name": session.path.name if session.path is not None else (session.mesh.name or "shape"),
            "mesh": fp,
            "cage_size": session.cage_size if isinstance(session.cage_size, float) else int(session.cage_size),
            "cage_vertices": int(session.editor.cage.n_vertices),
            "edit": _edit_json(session, fp),
            "selection": _selection_json(session),
            "poses": pose_list_json(session.poses.entries()),
        }
        text = json.dumps(data, separators=(",", ":"))  # (C encoder: json.dump's streaming one is 4x slower)
        self.folder.mkdir(parents=True, exist_ok=True)
        with atomic_write(path, "w") as fh:
            fh.write(text)
        if self.path is not None and self.path != path:
            self.path.unlink(missing_ok=True)  # (another shape opened since: its file goes)
        self.path = path
        return path

    def remove(self) -> None:
        """Remove the file written (nothing unsaved any more)."""
        if self.path is not None:
            self.path.unlink(missing_ok=True)
            self.path = None


def read_recovery(path: str | os.PathLike) -> Recovery:
    """Read a recovery file; raises :class:`RecoveryError` naming it on any problem."""
    p = Path(path)
    try:
        if p.stat().st_size > MAX_BYTES:
            raise RecoveryError(f"{p}: {p.stat().st_size / 2**20:.0f} MB, too large for a recovery file")
        data = json.loads(p.read_text(encoding="utf-8"))
    except OSError as e:
        raise RecoveryError(f"{p}: cannot read it ({e.strerror or e})") from None
    except (UnicodeDecodeError, ValueError, RecursionError) as e:
        raise RecoveryError(f"{p}: damaged, not a recovery file ({e.__class__.__name__})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise RecoveryError(f"{p}: not a hybridedit recovery file")
    if data.get("version") not in READS:
        raise RecoveryError(f"{p}: recovery file version {data.get('version')!r} is not one this hybridedit reads")
    try:
        edit = None if data["edit"] is None else parse_edit(_edit_of_json(data["edit"], data["version"]), str(p))
        poses = tuple(parse_pose_list(data.get("poses", []), str(p), data["mesh"]))
        sel = data["selection"]
        fp = data["mesh"]
        rec = Recovery(
            file=p, mesh_path=None if data["mesh_path"] is None else Path(data["mesh_path"]),
            mesh_name=str(data["mesh_name"]), fingerprint=fp, cage_size=data["cage_size"],
            cage_vertices=int(data["cage_vertices"]), saved_at=float(data["saved_at"]), pid=int(data["pid"]),
            host=str(data["host"]), edit=edit,
            selection={"roi": np.asarray(sel["roi"], dtype=np.int64).reshape(-1),
                       "handle_group": np.asarray(sel["handle_group"], dtype=np.int64).reshape(-1, 2),
                       "n_groups": int(sel["n_groups"]), "active": int(sel["active"]),
                       "symmetry": sel["symmetry"]},
            poses=poses)
    except EditFileError as e:
        raise RecoveryError(f"{p}: damaged edit ({str(e).removeprefix(str(p) + ': ')})") from None
    except (KeyError, TypeError, ValueError) as e:
        raise RecoveryError(f"{p}: damaged, a field is missing or malformed ({e.__class__.__name__}: {e})") from None
    if not isinstance(fp, dict) or not isinstance(rec.cage_size, (int, float)) or isinstance(rec.cage_size, bool):
        raise RecoveryError(f"{p}: damaged, the shape or cage it names is malformed")
    return rec


def orphans(*, folder: str | os.PathLike | None = None, topology: str | None = None
            ) -> tuple[list[Recovery], list[tuple[Path, str]]]:
    """The recovery files whose process is gone, newest first, and a line for each damaged one.

    Parameters
    ----------
    folder : where to look (default: :func:`recovery_folder`).
    topology : only those of the shape with this fingerprint topology hash.

    Returns
    -------
    found : the orphaned recoveries, newest first.
    problems : (file, one line saying why) for each file that could not be read (it is left where it is).
    """
    where = recovery_folder(folder)
    found, problems = [], []
    pattern = f"{topology}-*.json" if topology else "*-*.json"
    for p in sorted(where.glob(pattern)) if where.is_dir() else []:
        try:
            rec = read_recovery(p)
        except RecoveryError as e:
            problems.append((p, str(e)))
            continue
        if rec.orphaned:
            found.append(rec)
    found.sort(key=lambda r: r.saved_at, reverse=True)
    return found, problems


def recover(session: Session, rec: Recovery) -> None:
    """Replay a recovery on ``session`` (the same shape and cage): its pose exactly, as
    :meth:`~.session.Session.load_edit` replays an edit, then its selection; one undo step. Its kept
    poses are replayed for their positions and go to the session's library
    (:meth:`~.pose_library.PoseLibrary.take`: added after the poses kept there unsaved).

    Raises
    ------
    RecoveryError
        It was made on another shape or cage (the session is left as it was).
    """
    if not rec.fits(session.mesh):
        raise RecoveryError(f"{rec.file}: made on another shape than {rec.mesh_name} as it is now")
    if rec.cage_vertices != session.editor.cage.n_vertices:
        raise RecoveryError(f"{rec.file}: made on a cage of {rec.cage_vertices:,} vertices, this one has "
                            f"{session.editor.cage.n_vertices:,}")
    c = session.editor.cage.n_vertices
    sel = rec.selection
    hg = sel["handle_group"]
    if (sel["roi"].size and (sel["roi"].min() < 0 or sel["roi"].max() >= c)) or \
            (hg.size and (hg[:, 0].min() < 0 or hg[:, 0].max() >= c)):
        raise RecoveryError(f"{rec.file}: damaged, its selection is not on this cage")
    try:
        kept = replay_poses(session, rec.poses, path=str(rec.file))
        if rec.edit is not None:
            session.load_edit(rec.edit, path=str(rec.file))
    except (EditFileError, SelectionError, ValueError) as e:
        raise RecoveryError(str(e)) from None
    if kept:
        session.poses.take(kept, saved=False)
    roi = np.zeros(c, dtype=bool)
    roi[sel["roi"]] = True
    handle_group = np.zeros(c, dtype=np.int8)
    handle_group[hg[:, 0]] = hg[:, 1]
    try:
        session.selection.recovered(roi, handle_group, n_groups=sel["n_groups"], active=sel["active"],
                                    symmetry=sel["symmetry"])
    except (SelectionError, ValueError) as e:
        raise RecoveryError(f"{rec.file}: its selection does not fit ({e}); the pose is recovered") from None

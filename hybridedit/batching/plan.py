"""What a batch will make: its inputs found (files, folders, globs) and one :class:`Job` per output.

Outputs are named from their input, so that a re-run with the same arguments makes the same names:
``OUTDIR/<sub>/<stem>-pose007.<ext>`` with its edit ``<stem>-pose007.edit.json`` (the poses mode), or
``OUTDIR/<sub>/<stem>.<ext>`` with ``<stem>.edit.json`` (the edits mode), where ``<sub>`` is the
input's folder below a folder given as an input (nothing for a file or a glob). Two inputs that would
get the same name (``a/x.obj`` and ``b/x.obj`` given as files) each get a short hash of their path
added to the stem.

With a pack (``--pack glb``), the poses of an input go into one file, ``OUTDIR/<sub>/<stem>-poses.glb``
(or ``.usdc``), as its morph targets ``pose-000``, ``pose-001``, ...: a pose's output is named
``<stem>-poses.glb#pose-007`` (the pack, then the target), its edit file is as above, and until its
pack is written its positions wait in ``OUTDIR/.hybridedit-staging/`` (:func:`staged_path`).

Examples
--------
>>> jobs = plan_jobs([(Path("/data/cat.obj"), Path("."))], poses=2, edits=None, output_format=".ply")
>>> [(j.output, j.edit, j.pose) for j in jobs]
[('cat-pose000.ply', 'cat-pose000.edit.json', 0), ('cat-pose001.ply', 'cat-pose001.edit.json', 1)]
"""

from __future__ import annotations

import glob
import hashlib
import os
from collections import Counter
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Sequence

__all__ = ["Job", "PackJob", "InputError", "find_inputs", "plan_jobs", "pack_jobs", "staged_path",
           "MESH_EXTENSIONS", "STAGING"]

#: the extensions a folder or glob is searched for (``hybridedit deform``'s formats)
MESH_EXTENSIONS = (".obj", ".ply", ".stl", ".off", ".glb")
#: the folder (in the output folder) where packed poses wait for their pack
STAGING = ".hybridedit-staging"


class InputError(ValueError):
    """An input argument that names nothing usable; the message says which and why."""


@dataclass(frozen=True)
class Job:
    """One output of a batch.

    Attributes
    ----------
    input : str
        The mesh file, absolute.
    output : str
        The output mesh, relative to the output folder (POSIX separators).
    edit : str
        Its edit file, relative to the output folder.
    pose : int or None
        The pose index (the poses mode), or None.
    source_edit : str or None
        The edit file given for the mesh (the edits mode; None: none was found).
    pack : str or None
        The file of poses this pose goes into, relative to the output folder (``--pack``); then
        ``output`` is ``PACK#TARGET``, the pack and the pose's name in it.
    """

    input: str
    output: str
    edit: str
    pose: int | None = None
    source_edit: str | None = None
    pack: str | None = None

    @property
    def target(self) -> str | None:
        """The pose's name in its pack ("pose-007"), or None."""
        return None if self.pack is None else self.output.rpartition("#")[2]

    @property
    def staged(self) -> str | None:
        """Where the pose waits for its pack (:func:`staged_path`), or None."""
        return None if self.pack is None else staged_path(self.output)


@dataclass(frozen=True)
class PackJob:
    """One pack: an input's poses in one file.

    Attributes
    ----------
    input : str
        The mesh file, absolute.
    pack : str
        The pack, relative to the output folder.
    jobs : tuple of Job
        Its poses, in pose order.
    """

    input: str
    pack: str
    jobs: tuple


def staged_path(output: str) -> str:
    """Where a packed pose's positions wait for its pack, relative to the output folder:
    ``.hybridedit-staging/<pack>/<target>.npy`` (float32 differences from the rest, (n, 3)).

    >>> staged_path("sub/cat-poses.glb#pose-007")
    '.hybridedit-staging/sub/cat-poses.glb/pose-007.npy'
    """
    pack, _, target = output.rpartition("#")
    return str(PurePosixPath(STAGING) / pack / f"{target}.npy")


def _is_mesh(path: Path) -> bool:
    return path.suffix.lower() in MESH_EXTENSIONS


def _inside(path: Path, folder: Path | None) -> bool:
    return folder is not None and (path == folder or folder in path.parents)


def _folder_meshes(folder: Path, exclude: Path | None) -> list[tuple[Path, Path]]:
    found = []
    for root, dirs, files in os.walk(folder):
        here = Path(root)
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and not _inside((here / d).resolve(), exclude))
        for name in sorted(files):
            p = here / name
            if not name.startswith(".") and _is_mesh(p) and p.is_file():
                found.append((p.resolve(), here.relative_to(folder)))
    return found


def find_inputs(arguments: Sequence[str | os.PathLike[str]], *, exclude: str | os.PathLike[str] | None = None
                ) -> list[tuple[Path, Path]]:
    """The mesh files the arguments name, each with the sub-folder its outputs go to.

    Parameters
    ----------
    arguments : sequence of str or path-like
        Files (taken whatever their extension: one that cannot be read is a failed row), folders
        (searched below for every extension ``deform`` reads, hidden entries skipped) or glob
        patterns (``scans/**/*.ply``; the mesh files they match).
    exclude : str or path-like, optional
        A folder never searched (the output folder).

    Returns
    -------
    list of (Path, Path)
        (the file, absolute; its folder relative to the folder argument it was found in, or ".")
        in argument order, each file once.

    Raises
    ------
    InputError
        An argument names nothing, or no mesh file is found at all.
    """
    skip = Path(exclude).resolve() if exclude is not None else None
    found: list[tuple[Path, Path]] = []
    for arg in arguments:
        p = Path(arg)
        if p.is_file():
            found.append((p.resolve(), Path(".")))
        elif p.is_dir():
            meshes = _folder_meshes(p, skip)
            if not meshes:
                raise InputError(f"{arg}: no mesh files ({' '.join(MESH_EXTENSIONS)}) in this folder")
            found.extend(meshes)
        elif glob.has_magic(str(arg)):
            matched = [Path(m).resolve() for m in sorted(glob.glob(str(arg), recursive=True))]
            matched = [m for m in matched if m.is_file() and _is_mesh(m) and not _inside(m, skip)]
            if not matched:
                raise InputError(f"{arg}: matches no mesh file")
            found.extend((m, Path(".")) for m in matched)
        else:
            raise InputError(f"{arg}: no such file or folder")
    seen: set[Path] = set()
    unique = [(f, sub) for f, sub in found if not (f in seen or seen.add(f))]
    if not unique:
        raise InputError("no input given")
    return unique


def _stems(inputs: list[tuple[Path, Path]]) -> list[PurePosixPath]:
    """Each input's output name without extension, made unique with a hash of its path where needed."""
    base = [PurePosixPath(sub.as_posix()) / f.stem for f, sub in inputs]
    counts = Counter(base)
    return [b if counts[b] == 1 else b.with_name(f"{b.name}-{hashlib.sha256(str(f).encode()).hexdigest()[:8]}")
            for b, (f, _) in zip(base, inputs)]


def _edit_for(edits: Path, sub: Path, stem: str) -> str | None:
    """The edit file given for a mesh: ``EDITS/<sub>/<stem>.json`` or ``.edit.json``, else the same at
    the top of ``EDITS``."""
    for folder in (edits / sub, edits):
        for name in (f"{stem}.json", f"{stem}.edit.json"):
            if (folder / name).is_file():
                return str((folder / name).resolve())
    return None


def plan_jobs(inputs: list[tuple[Path, Path]], *, poses: int | None, edits: str | os.PathLike[str] | None,
              output_format: str | None, pack: str | None = None) -> list[Job]:
    """One job per output: ``poses`` per input, or one per input replaying its edit file.

    Parameters
    ----------
    inputs : list of (Path, Path)
        From :func:`find_inputs`.
    poses : int or None
        Poses per input (the poses mode).
    edits : str or path-like or None
        The folder of edit files (the edits mode).
    output_format : str or None
        The outputs' extension (".ply"); None: each input's own.
    pack : str or None
        The packs' extension (".glb", ".usdc"): the poses of an input go into one file.

    Returns
    -------
    list of Job
        Input by input, pose by pose.
    """
    jobs: list[Job] = []
    width = max(3, len(str(max((poses or 1) - 1, 0))))
    for (f, sub), stem in zip(inputs, _stems(inputs)):
        ext = output_format or f.suffix.lower()
        if poses is not None:
            for k in range(poses):
                name = f"{stem}-pose{k:0{width}d}"
                if pack is not None:
                    bundle = f"{stem}-poses{pack}"
                    jobs.append(Job(str(f), f"{bundle}#pose-{k:0{width}d}", f"{name}.edit.json", k, pack=bundle))
                else:
                    jobs.append(Job(str(f), f"{name}{ext}", f"{name}.edit.json", k))
        else:
            jobs.append(Job(str(f), f"{stem}{ext}", f"{stem}.edit.json", None,
                            _edit_for(Path(edits), sub, f.stem)))
    return jobs


def pack_jobs(jobs: list[Job]) -> list[PackJob]:
    """The packs of ``jobs`` (those with a ``pack``), one per pack file, in the jobs' order."""
    packs: dict[str, list[Job]] = {}
    for j in jobs:
        if j.pack is not None:
            packs.setdefault(j.pack, []).append(j)
    return [PackJob(its[0].input, name, tuple(its)) for name, its in packs.items()]

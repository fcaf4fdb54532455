"""Checking every output path before any work starts.

A command that writes files calls :func:`check_outputs` first, so that a path
it would refuse (unknown extension, missing or read-only folder, the input
itself, two outputs on one file) fails at once, whatever the size of the mesh.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["OutputPathError", "check_outputs", "same_file"]


class OutputPathError(ValueError):
    """An output path is refused; the message names the path and the reason."""


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """``a`` and ``b`` name one file: equal after resolving ``..`` and symlinks, or hard links
    to one inode."""
    pa, pb = Path(a), Path(b)
    try:
        if pa.resolve() == pb.resolve():
            return True
        return pa.exists() and pb.exists() and os.path.samefile(pa, pb)
    except OSError:
        return False


def _check_one(label: str, path: Path, extensions: tuple[str, ...]) -> None:
    ext = path.suffix.lower()
    if ext not in extensions:
        known = ", ".join(extensions)
        what = f"unknown extension '{ext}'" if ext else "no extension"
        raise OutputPathError(f"{path}: {label} has {what} (use {known})")
    if path.is_dir():
        raise OutputPathError(f"{path}: {label} is a folder")
    folder = path.resolve().parent
    if not folder.exists():
        raise OutputPathError(f"{path}: {label} folder {folder} does not exist")
    if not folder.is_dir():
        raise OutputPathError(f"{path}: {label} folder {folder} is not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputPathError(f"{path}: {label} folder {folder} is not writable")


def check_outputs(outputs: dict[str, tuple[str | os.PathLike[str] | None, tuple[str, ...]]],
                  *, inputs: dict[str, str | os.PathLike[str] | None],
                  may_overwrite: tuple[str, ...] = ()) -> None:
    """Refuse output paths that cannot or must not be written, before any work.

    Parameters
    ----------
    outputs : dict of label to (path or None, allowed extensions)
        Each output the command will write, e.g. ``{"-o": ("out.obj", (".obj", ...)),
        "--stats": ("s.json", (".json",))}``; None is skipped.
    inputs : dict of label to path or None
        Files the command reads; no output may be one of them.
    may_overwrite : tuple of str
        Output labels allowed to replace the input mesh (``--force``).

    Raises
    ------
    OutputPathError
        For the first refused path: unknown extension, a folder, a missing,
        non-folder or read-only parent folder, an input file, or the same file
        as another output (after ``..``, symlinks and hard links).
    """
    given = {label: (Path(p), exts) for label, (p, exts) in outputs.items() if p is not None}
    for label, (path, exts) in given.items():
        _check_one(label, path, exts)
    for label, (path, _) in given.items():
        for in_label, src in inputs.items():
            if src is None or not same_file(path, src):
                continue
            if in_label == "input" and label in may_overwrite:
                continue
            hint = " (use --force)" if in_label == "input" and label == "-o" else ""
            raise OutputPathError(f"{path}: refusing to overwrite the {in_label} file with "
                                  f"{label}{hint}")
    labels = list(given)
    for i, a in enumerate(labels):
        for b in labels[i + 1:]:
            if same_file(given[a][0], given[b][0]):
                raise OutputPathError(f"{given[b][0]}: {a} and {b} are the same file")

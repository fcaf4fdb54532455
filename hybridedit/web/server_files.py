"""Where the browser editor may write on the server: a file name typed in the page resolves in the
mesh's folder, and a path that leaves it (``..``, an absolute path, a link out of it) is refused, as
is one the project cannot write (an unknown extension, a missing folder) or the opened mesh itself.
A browser may be another user's (``--host``): it never chooses where on the machine to write."""

from __future__ import annotations

from pathlib import Path

from ..fileio.meshfiles import SUPPORTED_EXTENSIONS
from ..fileio.outpaths import OutputPathError, check_outputs

__all__ = ["OutputPathError", "posed_name", "save_target"]


def posed_name(mesh_path: Path) -> str:
    """The name Save offers: ``<stem>-posed<extension>``, beside the mesh.

    Examples
    --------
    >>> posed_name(Path("/scans/creature.ply"))
    'creature-posed.ply'
    """
    return f"{mesh_path.stem}-posed{mesh_path.suffix}"


def save_target(mesh_path: Path, typed: str) -> Path:
    """The file that Save writes for the name ``typed`` in the page.

    Parameters
    ----------
    mesh_path : the mesh opened (its folder is where files go).
    typed : a file name, or a path inside the mesh's folder.

    Returns
    -------
    Path : resolved, inside the mesh's folder.

    Raises
    ------
    OutputPathError
        An empty name, a path outside the mesh's folder, the mesh itself, or a path
        :func:`~hybridedit.fileio.outpaths.check_outputs` refuses (extension, folder), in one line.

    Examples
    --------
    >>> save_target(Path("/tmp/creature.ply"), "../etc/x.ply")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    OutputPathError: ../etc/x.ply: not in the mesh's folder /tmp
    """
    name = (typed or "").strip()
    if not name:
        raise OutputPathError("give a file name to save to")
    folder = mesh_path.resolve().parent
    target = (folder / name).resolve()
    if not target.is_relative_to(folder):
        raise OutputPathError(f"{name}: not in the mesh's folder {folder}")
    check_outputs({"Save": (target, SUPPORTED_EXTENSIONS)}, inputs={"input": mesh_path})
    return target

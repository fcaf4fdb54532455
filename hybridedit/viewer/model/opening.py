"""Opening a shape for editing without a window: its engine, session, look and up axis.

What ``hybridedit open --screenshot``, ``hybridedit web`` and ``he.widget`` do before they draw
anything, as the window's build does it (the file read with everything it holds, the binding
cache used, the up axis remembered for the shape or else guessed).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ...core.mesh import Mesh
from ...defaults import CAGE_SIZE
from .session import Session

__all__ = ["Opened", "open_session"]


@dataclass(frozen=True)
class Opened:
    """A shape opened for editing.

    Attributes
    ----------
    session : the editing model (:class:`~.session.Session`; ``session.look`` is the file's look).
    up_axis : the shape's up axis ("+Y", "-Z", ...: the camera's up).
    notes : what the look could not show (a texture not found, ...), one sentence each.
    """

    session: Session
    up_axis: str
    notes: tuple[str, ...]


def open_session(source: str | os.PathLike | Mesh, *, cage_size: int | float = CAGE_SIZE) -> Opened:
    """Read a mesh file (or take a :class:`~hybridedit.Mesh`) and build its engine and session.

    Parameters
    ----------
    source : a mesh file (every format :func:`hybridedit.read_document` reads), or a Mesh
        (then the session has no file: Save Edit needs a path).
    cage_size : the cage's vertex count (int) or fraction of the shape's (float).

    Returns
    -------
    Opened

    Raises
    ------
    MeshError, MeshFileError, ValueError, OSError
        The file cannot be read, or the shape cannot be bound.

    Examples
    --------
    >>> from hybridedit.viewer.model.opening import open_session
    >>> opened = open_session("data/creature.ply")  # doctest: +SKIP
    >>> opened.session.n_cage  # doctest: +SKIP
    5028
    """
    from ...deform.editor import HybridEditor
    from ...fileio.meshfiles import read_document
    from ...fileio.up_axes import up_axis_of
    from .look import shown_look

    if isinstance(source, Mesh):
        editor = HybridEditor(source, cage_size, cache=True)
        return Opened(Session(editor, cage_size=cage_size), up_axis_of(source)[0], ())
    path = Path(source)
    document = read_document(path)
    editor = HybridEditor(document.mesh, cage_size, cache=True)
    session = Session(editor, path=path, cage_size=cage_size)
    session.look = shown_look(document)
    notes = tuple(session.look.notes) if session.look is not None else ()
    return Opened(session, up_axis_of(document.mesh, path=path)[0], notes)

"""A mesh file checked before anything is asked about it: one that cannot be opened is refused at once,
in one line, and the shape and pose on display stay (no Save / Discard / Cancel question first).

A small file is read whole (any error of its contents shows here, in the reader's words); a large one,
whose reading is the build's first stage, only has its name, its type and its first byte checked here.
"""

from __future__ import annotations

import os
from pathlib import Path

from ...fileio.formats import unsupported
from ...fileio.meshfiles import SUPPORTED_EXTENSIONS, MeshFileError, read_document

READ_FIRST_BYTES = 4 * 2**20
"""Files up to this size are read whole before the question (a 4 MB OBJ, about 60K vertices, reads in a
fraction of a second); larger ones are read by the build, which says why when it cannot."""


def why_unopenable(path: str | os.PathLike) -> str | None:
    """Why the mesh file ``path`` cannot be opened, in one line starting with its name; None when it can
    be (as far as is checked: see the module).

    Examples
    --------
    >>> why_unopenable("notes.txt")
    "notes.txt: unsupported file extension '.txt' (use one of .obj, .off, .ply, .stl, .glb)"
    """
    p = Path(path)
    name = p.name or str(p)
    ext = p.suffix.lower()
    if ext not in SUPPORTED_EXTENSIONS:
        return str(unsupported(name, ext, "open"))
    try:
        size = p.stat().st_size
        if p.is_dir():
            return f"{name}: is a folder, not a file"
        with open(p, "rb") as f:
            f.read(1)
    except FileNotFoundError:
        return f"{name}: file not found ({p.absolute()})"
    except PermissionError:
        return f"{name}: permission denied"
    except OSError as e:
        return f"{name}: cannot read file ({e.strerror or e})"
    if size == 0:
        return f"{name}: file is empty"
    if size <= READ_FIRST_BYTES:
        try:
            read_document(p)
        except MeshFileError as e:
            return str(e)
    return None

"""An editor and its mesh file: open a file for editing, keeping everything it holds (texture
coordinates, polygons, materials, colours), and save the pose into it (the :class:`EditorFiles`
part of :class:`~hybridedit.HybridEditor`; ``he.open`` is :meth:`~EditorFiles.from_file`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..binding.rig import Progress, build_rig
from ..defaults import CAGE_SIZE, TRUNCATION

if TYPE_CHECKING:
    from .editor import HybridEditor

__all__ = ["EditorFiles"]


class EditorFiles:
    """:class:`~hybridedit.HybridEditor`'s files, mixed into it: :meth:`save` writes its shape
    ``_out`` into the :attr:`document` it was opened from."""

    #: the file this editor was opened from (:meth:`from_file`), which :meth:`save` writes
    #: back with the current positions; None for an editor built from a bare Mesh
    document = None

    @classmethod
    def from_file(cls, path, cage_size: int | float = CAGE_SIZE, *, cache: bool | str | Path = False,
                  truncation: float = TRUNCATION, progress: Progress | None = None, **options) -> "HybridEditor":
        """Open a mesh file for editing, keeping everything it holds for :meth:`save`.

        Reads ``path`` with :func:`hybridedit.read_document` (texture coordinates,
        polygons, materials, colours, ... stay in :attr:`document`), builds the cage
        and binding as :func:`hybridedit.build_rig` (``cage_size``, ``cache``,
        ``truncation``) and takes the editor's own ``options`` (``weights``,
        ``iterations``, ``propagation``). ``progress(stage, fraction)`` hears both.
        """
        from ..fileio.meshfiles import read_document

        doc = read_document(path, progress=progress)
        rig = build_rig(doc.mesh, cage_size=cage_size, cache=cache, truncation=truncation, progress=progress)
        editor = cls(rig, **options)
        editor.document = doc
        return editor

    def save(self, path, *, progress: Progress | None = None) -> list[str]:
        """Write the current pose to ``path`` atomically (format by extension); returns notes.

        An editor opened with :meth:`from_file` writes everything the file had (texture
        coordinates, polygons, materials and their images, colours, recomputed normals)
        with the new positions, through :func:`hybridedit.write_document`. One built
        from a bare Mesh has only positions and triangles to write; the first note says so.
        """
        from ..fileio.document import Document
        from ..fileio.meshfiles import write_document

        if self.document is None:
            doc = Document.from_mesh(self.deformed)
            note = ["no source document (the editor was built from a Mesh): wrote positions and triangles only; "
                    "open the file with HybridEditor.from_file to keep the rest"]
        else:
            doc = self.document.with_vertices(self._out)
            note = []
        return note + write_document(path, doc, progress=progress)

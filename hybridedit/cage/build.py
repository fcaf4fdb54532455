"""The cage of a shape: :func:`build_cage`.

Each connected part of the shape gets its own closed cage piece (:mod:`hybridedit.cage.parts`:
simplified by quadric error metrics to its share of the vertex budget, a tiny part its own
cage, an open surface wrapped in a thin closed shell), and :func:`hybridedit.cage.links.cage_links`
ties a piece that sits inside or against a bigger one to it for ARAP. The binding of each part to
its piece is the next floor's (:func:`hybridedit.binding.assemble.cage_and_binding`).
"""

from __future__ import annotations

from ..core.mesh import Mesh
from ..defaults import CAGE_SIZE
from .parts import cage_parts

__all__ = ["build_cage"]


def build_cage(mesh: Mesh, size: int | float = CAGE_SIZE, notes: list[str] | None = None) -> Mesh:
    """The cage of ``mesh``: one closed piece per connected part (see
    :func:`hybridedit.cage.parts.cage_parts`).

    Parameters
    ----------
    mesh : Mesh
        The shape (not modified).
    size : int or float
        Target vertex count (int) or fraction of the shape's vertices (float).
    notes : list of str, optional
        Plain-word sentences about every repair and adjustment are appended here.

    Returns
    -------
    Mesh
        A closed, consistently oriented, outward surface (possibly of several pieces).
    """
    return cage_parts(mesh, size, notes=notes).cage

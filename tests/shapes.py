"""Shapes and paths the tests share (import them with ``from shapes import ...``).

Kept out of conftest.py: tests/viewer has a conftest.py of its own, and which one
``import conftest`` finds depends on the order pytest loads them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from hybridedit.core.mesh import Mesh

REPO = Path(__file__).resolve().parent.parent
SHARED_MESHES = REPO.parent / "shared" / "meshes"


def icosphere(subdivisions: int = 3, radius: float = 1.0) -> Mesh:
    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    return Mesh(np.asarray(s.vertices), np.asarray(s.faces), name="sphere")


def bumpy_blob(subdivisions: int = 4) -> Mesh:
    """A closed, non-convex, elongated shape with bumps: a stand-in for a scan."""
    s = icosphere(subdivisions)
    v = s.vertices.copy()
    x, y, z = v.T
    r = 1.0 + 0.08 * np.sin(7 * x) * np.cos(5 * y) + 0.05 * np.sin(11 * z)
    v = v * r[:, None]
    v[:, 0] *= 2.0  # elongate along x: two "limbs" to bend
    v[:, 1] += 0.3 * np.cos(1.5 * v[:, 0])  # and bend it, so it is not convex
    return Mesh(v, s.faces, name="blob")


def capsule_blob(subdivisions: int = 4):
    """A closed, bumpy capsule about 4 long along X, 2.5K vertices at subdivision 4."""
    import trimesh

    from hybridedit.core.mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    v = np.asarray(s.vertices).copy()
    x, y, z = v.T
    r = 1.0 + 0.06 * np.sin(6 * x) * np.cos(4 * y) + 0.04 * np.sin(9 * z)
    v *= r[:, None]
    v[:, 0] *= 2.0
    v[:, 1] += 0.15 * np.cos(1.2 * v[:, 0])
    return Mesh(v, np.asarray(s.faces), name="blob")


def arm_edit(ed, blob: Mesh) -> dict:
    """On ``ed`` editing ``blob`` (:func:`bumpy_blob`), select the +x end as the handle and the
    arm from about x = 0.3 as the region, and return the drag's keyword arguments: the end swung
    up about where the arm starts."""
    x = blob.vertices[:, 0]
    hand, arm = np.flatnonzero(x > 1.6), np.flatnonzero(x > 0.3)
    ed.set_selection(hand, roi=arm)
    return {"rotate": {"axis": (0, 0, 1), "degrees": 35, "center": blob.vertices[arm].mean(axis=0)},
            "translate": (0.0, 0.2, 0.0)}

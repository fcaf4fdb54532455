"""Shared fixtures: small generated meshes, and the scanned armadillo when present."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from hybridedit.mesh import Mesh

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


@pytest.fixture(scope="session", autouse=True)
def _private_cache_dir(tmp_path_factory):
    """Tests never read or write the user's binding cache."""
    mp = pytest.MonkeyPatch()
    mp.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path_factory.mktemp("binding-cache")))
    yield
    mp.undo()


@pytest.fixture
def sphere() -> Mesh:
    return icosphere(3)


@pytest.fixture(scope="session")
def blob() -> Mesh:
    return bumpy_blob(4)


@pytest.fixture(scope="session")
def armadillo_path() -> Path:
    p = SHARED_MESHES / "armadillo43k.obj"
    if not p.exists():
        pytest.skip(f"{p} not present")
    return p

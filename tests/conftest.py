"""Shared fixtures: small generated meshes, and the scanned armadillo when present."""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridedit.core.mesh import Mesh

from shapes import REPO, SHARED_MESHES, bumpy_blob, icosphere  # noqa: F401  (fixtures below use them)


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

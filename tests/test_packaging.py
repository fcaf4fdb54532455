"""The package as pip builds it: what the wheel holds and says, and how an installed copy behaves
(default mesh, kernel cache). Building the wheel needs the package index (setuptools >= 77 in
pip's build environment); without it those tests are skipped."""

from __future__ import annotations

import email
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from shapes import REPO

tomllib = pytest.importorskip("tomllib")  # Python 3.11+ (3.10 would need tomli)

PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())


def test_every_subpackage_is_listed_for_the_wheel():
    """pyproject.toml lists the packages (the default mesh's folder is mapped in): a new
    subpackage missing from the list would be missing from the wheel."""
    listed = set(PYPROJECT["tool"]["setuptools"]["packages"])
    found = {".".join(p.parent.relative_to(REPO).parts) for p in (REPO / "hybridedit").rglob("__init__.py")}
    assert found <= listed, f"add to [tool.setuptools] packages: {sorted(found - listed)}"
    assert PYPROJECT["tool"]["setuptools"]["package-dir"] == {"hybridedit.data": "data"}


def test_dependencies_install_from_wheels_everywhere():
    """cholespy (CHOLMOD in wheels) is required; scikit-sparse (source only) is an extra, never
    required: a plain pip install compiles nothing. sksparse-minimal, which cannot share a process
    with cholespy, is not a dependency at all."""
    deps = PYPROJECT["project"]["dependencies"]
    names = [d.split(">")[0].split("=")[0].split("<")[0].strip().lower() for d in deps]
    assert "cholespy" in names
    assert "scikit-sparse" not in names and "sksparse-minimal" not in names
    extras = PYPROJECT["project"]["optional-dependencies"]
    assert any(d.startswith("scikit-sparse") for d in extras["cholmod"])
    assert not any("sksparse-minimal" in d for ds in extras.values() for d in ds)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(REPO)],
                         capture_output=True, text=True, timeout=600)
    if run.returncode != 0:
        if "No matching distribution" in run.stderr or "Could not find a version" in run.stderr:
            pytest.skip("the package index is not reachable for the build environment")
        raise AssertionError(run.stderr[-3000:])
    (whl,) = out.glob("hybridedit-*.whl")
    return whl


@pytest.mark.slow
def test_the_wheel_ships_the_default_mesh_and_every_module(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        assert z.read("hybridedit/data/creature.ply") == (REPO / "data" / "creature.ply").read_bytes()
        help_text = "hybridedit/viewer/window/how_to_edit.md"  # Help ▸ How to Edit reads it at run time
        assert z.read(help_text) == (REPO / help_text).read_bytes()
    for py in (REPO / "hybridedit").rglob("*.py"):
        assert py.relative_to(REPO).as_posix() in names
    assert not any(n.startswith(("tests/", "benchmarks/", "data/")) for n in names)


@pytest.mark.slow
def test_the_wheel_metadata(wheel):
    with zipfile.ZipFile(wheel) as z:
        info = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
        meta = email.message_from_bytes(z.read(info))
        entry = z.read(info.replace("METADATA", "entry_points.txt")).decode()
    assert meta["Name"] == "hybridedit"
    import hybridedit

    assert meta["Version"] == hybridedit.__version__
    assert meta["License-Expression"] == "MIT"
    assert meta["Requires-Python"] == ">=3.10"
    assert "Programming Language :: Python :: 3.10" in meta.get_all("Classifier")
    assert meta.get_all("Project-URL") is None  # none exist: none are made up
    requires = meta.get_all("Requires-Dist")
    assert any(r.startswith("cholespy") for r in requires)
    assert all("extra ==" in r for r in requires if r.startswith("scikit-sparse"))
    assert "hybridedit = hybridedit.cli:console_main" in entry


def _run_installed(target: Path, code: str, cwd: Path, **env) -> subprocess.CompletedProcess:
    """``code`` in a fresh interpreter that imports hybridedit from ``target`` (the wheel's files),
    its dependencies from this environment."""
    path = os.pathsep.join([str(target)] + [p for p in sys.path if "site-packages" in p])
    full = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "HYBRIDEDIT_CACHE_DIR")}
    full.update(PYTHONPATH=path, **env)
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, env=full,
                          capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    target = tmp_path_factory.mktemp("site")
    run = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target),
                          str(wheel)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return target


@pytest.mark.slow
def test_an_installed_wheel_opens_its_default_mesh(installed, tmp_path):
    """From an installed wheel (no checkout around it), ``hybridedit`` with no argument has its
    mesh: the copy inside the package, which reads as the creature."""
    code = ("import hybridedit, hybridedit.cli as c, hybridedit.fileio.meshfiles as io; "
            "m = io.read_mesh(c.DEFAULT_MESH); print(hybridedit.__file__); print(c.DEFAULT_MESH); print(m.n_vertices)")
    run = _run_installed(installed, code, tmp_path)
    assert run.returncode == 0, run.stderr
    where, mesh, n = run.stdout.split()
    assert Path(where).is_relative_to(installed)
    assert Path(mesh) == installed / "hybridedit" / "data" / "creature.ply"
    assert int(n) == 100_576


@pytest.mark.slow
def test_a_read_only_installation_keeps_its_kernels_in_the_user_cache(installed, tmp_path):
    """Where the package folder cannot be written (an installation owned by root), numba's cache
    goes to the user cache folder, and a kernel compiled there is found there again.
    (chmod does not stop root, so the run answers os.access as a read-only folder would.)"""
    cache = tmp_path / "user-cache"
    code = (
        "import os, sys\n"
        f"pkg = {str(installed / 'hybridedit')!r}\n"
        "real = os.access\n"
        "os.access = lambda p, m, **k: False if (m & os.W_OK and str(p).startswith(pkg)) else real(p, m, **k)\n"
        "import hybridedit, numpy as np\n"
        "print(os.environ['NUMBA_CACHE_DIR'])\n"
        "from hybridedit.core.rotations import closest_rotation\n"
        "out = np.zeros((3, 3)); closest_rotation(np.eye(3) * 2.0, out); assert np.allclose(out, np.eye(3))\n"
    )
    env = {"HYBRIDEDIT_CACHE_DIR": str(cache)}
    before = set((installed / "hybridedit").rglob("*.nb[ic]"))  # (other tests' runs of this installation)
    run = _run_installed(installed, code, tmp_path, **env)
    assert run.returncode == 0, run.stderr
    assert Path(run.stdout.strip()).parent.parent == cache / "kernels"  # (kernels/<installation>/<sources>)
    index = list((cache / "kernels").rglob("*closest_rotation*.nbi"))
    assert index, "the kernel was not cached in the user cache folder"
    assert set((installed / "hybridedit").rglob("*.nb[ic]")) == before  # nothing written next to the code
    # a second run loads it instead of compiling
    stamps = {p: p.stat().st_mtime_ns for p in (cache / "kernels").rglob("*.nbc")}
    run = _run_installed(installed, code, tmp_path, **env)
    assert run.returncode == 0, run.stderr
    assert {p: p.stat().st_mtime_ns for p in (cache / "kernels").rglob("*.nbc")} == stamps


@pytest.mark.slow
def test_a_writable_installation_keeps_its_kernels_beside_the_code(installed, tmp_path):
    code = "import os, hybridedit; print(os.environ['NUMBA_CACHE_DIR'])"
    run = _run_installed(installed, code, tmp_path, HYBRIDEDIT_CACHE_DIR=str(tmp_path / "c"))
    assert run.returncode == 0, run.stderr
    assert Path(run.stdout.strip()).parent == installed / "hybridedit" / "__pycache__" / "kernels"

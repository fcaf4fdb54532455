"""Shared pieces of the benchmark scripts: meshes, the canonical edit, timing."""

from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))  # (support.edits: the canonical edit the tests use too)

from hybridedit import Mesh, build_cage, read_mesh, rigid_transform  # noqa: E402
from support.edits import canonical_edit  # noqa: E402,F401  (re-exported: the benchmarks import it from here)

MESHES = Path(os.environ.get("HYBRIDEDIT_MESHES", REPO.parent / "shared" / "meshes"))


def armadillo() -> Mesh:
    """The 43,243-vertex scanned armadillo from ../shared/meshes."""
    p = MESHES / "armadillo43k.obj"
    if not p.exists():
        sys.exit(f"benchmark needs {p} (set HYBRIDEDIT_MESHES to its folder)")
    m = read_mesh(p)
    m.name = "armadillo 43K"
    return m


def armadillo_21k(full: Mesh) -> Mesh:
    """The paper's second model: the armadillo QEM-simplified to 21,622 vertices."""
    m = build_cage(full, 21622)
    m.name = f"armadillo {m.n_vertices / 1000:.1f}K"
    return m


def quarter_edit(mesh: Mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A big-region edit: a quarter of the shape moves (issue 47's held-out kind of edit).

    Handle: the highest 10% of the vertices (Y up); region of interest: the highest
    quarter (the handle and the band between it and the fixed three quarters);
    the handle turns 30 degrees about +Z through the centroid of the region's lowest
    vertices, as bending the upper body forward at the waist. By vertex counts, so it
    moves the same share of every resolution of a shape.

    Returns
    -------
    handle, roi : int64 shape vertex indices; T : (4, 4) float64 handle transform
    """
    y = mesh.vertices[:, 1]
    order = np.argsort(-y, kind="stable")
    n = len(y)
    handle = np.sort(order[: max(1, n // 10)])
    roi = np.sort(order[: max(2, n // 4)])
    waist = mesh.vertices[order[n // 4 - max(1, n // 100): n // 4]].mean(axis=0)
    return handle, roi, rigid_transform(axis=(0, 0, 1), degrees=30.0, center=waist)


def mark(value: float, target: float | None) -> str:
    """'met' or 'NOT met' for a figure that must be at most ``target`` (nothing for no target)."""
    if target is None:
        return ""
    return f"{'met' if value <= target else 'NOT met'} (<= {target:g})"


def machine() -> str:
    """One line naming the machine the numbers were measured on."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


class Timer:
    """with Timer() as t: ...; t.seconds"""

    def __enter__(self) -> "Timer":
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        self.seconds = time.perf_counter() - self.t0

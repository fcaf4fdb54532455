"""A quadruped's front leg picked from the front in the window, with the rectangle and with the brush,
as ``benchmarks/select_tear.py`` does it (real Qt events under Xvfb): the cat's (its front legs lie side
by side, one tube in the mesh) and Loop-subdivided spot's. An 80 px drag of the foot stays within 10%
edge error, and nothing farther from the leg than its radius moves by more than 0.1% of the diagonal:
the selection took the leg, not the hind leg behind it or the other front leg beside it."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest

from shapes import REPO, SHARED_MESHES

pytestmark = pytest.mark.slow

SHAPES = {"cat": SHARED_MESHES / "cat" / "cat.obj", "spot": SHARED_MESHES / "spot" / "spot_triangulated.obj"}


@pytest.fixture(scope="module")
def bench():
    """benchmarks/select_tear.py as a module: its limbs, its plans of where the gestures go, its driver."""
    spec = importlib.util.spec_from_file_location("select_tear", REPO / "benchmarks" / "select_tear.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["select_tear"] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("shape", ["cat", "spot"])
def test_a_front_leg_picked_from_the_front_bends_without_tearing(qtbot, bench, shape, tmp_path):
    if not SHAPES[shape].is_file():
        pytest.skip(f"{SHAPES[shape]} is not there")
    spec = bench.SHAPES[shape]
    drv = bench.Driver()
    try:
        drv.open(spec.prepare(tmp_path), spec.cage)
        s = drv.w.session
        limb = bench.limb_of(s.mesh.vertices, s.edges, spec.limbs[0])
        plan = bench.plan_for(drv, limb, "front", bench.first_camera(drv), 80.0)
        assert plan.visible
        rows = {tool: bench.run_tool(drv, limb, plan, tool) for tool in ("rectangle", "brush", "hand-made")}
    finally:
        drv.close()
    for tool in ("rectangle", "brush"):
        row = rows[tool]
        assert row["dragged"] and row["roi"] > 0 and row["handle"] > 0, (tool, row)
        assert row["rrms"] <= bench.MAX_EDGE_ERROR, (tool, row)
        assert row["outside"] <= bench.MAX_OUTSIDE, (tool, row)
        assert row["touch"] == 0, (tool, row)  # (no tear warning was due)
    assert np.isfinite(rows["hand-made"]["rrms"])

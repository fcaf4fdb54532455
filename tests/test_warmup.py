"""After `python -m hybridedit.warmup` (what scripts/setup.sh runs) nothing compiles at run time."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from hybridedit import warmup

AFTER_WARMUP = textwrap.dedent("""
    import sys
    import numpy as np
    import trimesh
    import hybridedit as he
    from hybridedit import warmup
    from hybridedit.deform.polish import ShapeARAP, polish
    from hybridedit.core.region_metrics import ShapeMetrics
    from hybridedit.core.up_axis import guess_up_axis

    s = trimesh.creation.icosphere(subdivisions=6)  # 41K vertices: past the parallel thresholds
    mesh = he.Mesh(np.asarray(s.vertices) * [2.0, 1.0, 1.0], np.asarray(s.faces), name="check")
    with warmup.record_compiles() as compiled:
        ed = he.HybridEditor(mesh, 300)
        x = mesh.vertices[:, 0]
        ed.set_selection(np.flatnonzero(x > 1.7), roi=np.flatnonzero(x > -1.9))
        for k in range(3):
            V = ed.drag(translate=(0, 0.1 * k, 0))
        free = x > -1.5
        free[x > 1.7] = False
        polish(ShapeARAP(mesh), V, free, max_iterations=2)
        sm = ShapeMetrics(mesh.vertices, mesh.faces)
        sm.set_moving(np.flatnonzero(free))
        sm.write_normals(V, np.zeros((len(V), 3), np.float32), everything=True)
        sm.update_error(V, everything=True)
        guess_up_axis(mesh)
    print(len(compiled), "PySide6" in sys.modules or "vtkmodules" in sys.modules)
""")


@pytest.mark.slow
def test_nothing_compiles_after_the_warmup(tmp_path):
    env_cache = {"HYBRIDEDIT_CACHE_DIR": str(tmp_path)}
    import os

    env = {**os.environ, **env_cache}
    r = subprocess.run([sys.executable, "-m", "hybridedit.warmup", "-q"], capture_output=True, text=True,
                       timeout=1200, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "kernel versions compiled" in r.stderr
    r = subprocess.run([sys.executable, "-c", AFTER_WARMUP], capture_output=True, text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["0", "False"]  # nothing compiled, and no Qt or VTK imported


def test_every_entry_kernel_is_found():
    names = warmup.entry_kernels()
    assert "hybridedit.deform.propagate._csr_times_xyz.parallel" in names
    assert "hybridedit.core.normals._gather.serial" in names
    assert "hybridedit.core.normals.accumulate_corners" in names
    assert "hybridedit.deform.propagate._row" not in names  # inlined into the entry kernels
    assert "hybridedit.core.region_metrics" in warmup.kernel_modules()
    assert not any(m.startswith("hybridedit.viewer.") for m in warmup.kernel_modules())  # engine only

"""benchmarks/window_fps.py on a small mesh: it runs the real window and prints its result line."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow  # (a new process: Python, VTK and a cage build of its own)
def test_window_fps_smoke(blob_file):
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "window_fps.py"), "--smoke", str(blob_file)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.strip().splitlines()
    m = re.fullmatch(r"window_fps: blob\.obj 2562 displayed_fps=([0-9.]+) bare_fps=([0-9.]+) overhead=([0-9.]+)",
                     lines[-1])
    assert m, lines[-1]
    shown, bare, overhead = map(float, m.groups())
    assert shown > 0 and bare > 0
    assert abs(overhead - bare / shown) < 0.011
    stages = {ln.split()[0] for ln in lines[:-1] if ln and ln.split()[0] in
              ("engine", "normals", "vtk", "render", "compose", "other")}
    assert stages == {"engine", "normals", "vtk", "render", "compose", "other"}

"""benchmarks/soak.py at its smoke size: the real window through 30 cycles of select, drag, polish, undo
and redo on a small shape, and the engine through 1,000 drags; it completes and prints its table and
verdicts (their PASS or FAIL is the full run's to judge: a few cycles a window are too few)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow  # (a new process: Python, VTK and a cage build of its own; about 30 s)
def test_soak_smoke():
    r = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "soak.py"), "--smoke"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    out = r.stdout
    assert "FAILED" not in out
    rows = re.findall(r"^ +([0-9,]+) +(\d+) +([0-9.]+) +([0-9.]+) +([0-9.]+) +([0-9.]+) +(\d+) +(\d+) +([0-9,]+)",
                      out, re.M)
    assert [int(row[0]) for row in rows] == [3, 15, 30]  # the window's checkpoints
    assert all(float(row[2]) > 0 and float(row[3]) > 0 for row in rows)  # frames and polishes were timed
    assert int(rows[-1][8].replace(",", "")) > 0  # the 4 MB history filled: the oldest were dropped
    assert "says the history is full 1 time " in out  # and the window said so once
    for part, measures in (("window", ("memory", "frame time", "polish time")), ("engine", ("memory", "frame time"))):
        for m in measures:
            assert re.search(rf"^soak {part}: {m} at \w+ [0-9,]+ .*: [-+][0-9.]+% \(at most \+10%\): (PASS|FAIL)$",
                             out, re.M), (part, m, out[-2000:])

import subprocess
import sys
from pathlib import Path

import numpy as np

from hybridedit import qem_worker
from hybridedit.topology import edge_face_counts

from shapes import bumpy_blob

WORKER = Path(qem_worker.__file__)


def _open_half():
    s = bumpy_blob(4)
    keep = s.vertices[s.faces].mean(axis=1)[:, 0] < 0.0
    return s.vertices, s.faces[keep]


def _border(f, n):
    edges, counts = edge_face_counts(f, n)
    return np.unique(edges[counts == 1])


def _run(payload: bytes) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(WORKER)], input=payload, capture_output=True)


def test_the_script_gives_what_simplify_half_gives():
    v, f = _open_half()
    head = np.array([len(v), len(f), 600], dtype=np.int64).tobytes()
    run = _run(head + v.astype(np.float64).tobytes() + f.astype(np.int32).tobytes())
    assert run.returncode == 0, run.stderr
    nv, nf = np.frombuffer(run.stdout[:16], dtype=np.int64)
    assert len(run.stdout) == 16 + 24 * nv + 12 * nf
    got_v = np.frombuffer(run.stdout, dtype=np.float64, count=3 * nv, offset=16).reshape(-1, 3)
    got_f = np.frombuffer(run.stdout, dtype=np.int32, count=3 * nf, offset=16 + 24 * nv).reshape(-1, 3)
    want_v, want_f = qem_worker.simplify_half(v, f, 600)
    assert np.array_equal(got_v, want_v) and np.array_equal(got_f, want_f)


def test_nothing_sent_ends_it_quietly():
    run = _run(b"")
    assert run.returncode == 0 and run.stdout == b""


def test_a_short_surface_is_refused():
    v, f = _open_half()
    head = np.array([len(v), len(f), 600], dtype=np.int64).tobytes()
    run = _run(head + v.astype(np.float64).tobytes()[:100])
    assert run.returncode == 2 and b"ended early" in run.stderr


def test_the_border_is_kept_exactly():
    v, f = _open_half()
    border = v[_border(f, len(v))]
    out_v, out_f = qem_worker.simplify_half(v, f, 600)
    assert len(out_f) < len(f)
    kept = out_v[_border(out_f, len(out_v))]
    # the same border vertices, at exactly the same places
    assert len(kept) == len(border)
    assert np.array_equal(np.unique(kept, axis=0), np.unique(border, axis=0))


def test_bad_usage_exits_2():
    run = subprocess.run([sys.executable, str(WORKER), "extra"], capture_output=True)
    assert run.returncode == 2 and b"usage" in run.stderr



def test_modules_beside_the_script_do_not_shadow_others(tmp_path):
    # run as a script, Python puts the script's folder (the package's, with its io.py) first on
    # the path; the worker takes it off: a numpy.py beside it must not be the numpy it imports
    (tmp_path / "qem_worker.py").write_text(WORKER.read_text())
    (tmp_path / "numpy.py").write_text("raise ImportError('the numpy beside the script was imported')\n")
    run = subprocess.run([sys.executable, str(tmp_path / "qem_worker.py"), "extra"], capture_output=True, text=True)
    assert run.returncode == 2 and "usage" in run.stderr, run.stderr

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hybridedit.cage import qem, qem_worker
from hybridedit.cage.build import build_cage
from hybridedit.core.topology import edge_face_counts

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


# --------------------------------------------------------------------------- which interpreter runs the helper


def _host_program(tmp_path, name="blender"):
    """An executable that is not Python (as an embedding host's sys.executable is): it leaves a
    mark when started, so a test can tell that it never was."""
    mark = tmp_path / f"{name}-was-started"
    prog = tmp_path / name
    prog.write_text(f"#!/bin/sh\ntouch '{mark}'\nexit 0\n")
    prog.chmod(0o755)
    return prog, mark


@pytest.mark.parametrize("name", ["python", "python3", "python3.11", "python3.13t", "pythonw.exe", "python.exe",
                                  "pypy3"])
def test_interpreter_names_are_recognised(tmp_path, name):
    exe = tmp_path / name
    exe.write_text("#!/bin/sh\n")
    exe.chmod(0o755)
    assert qem._is_python(str(exe))


@pytest.mark.parametrize("name", ["blender", "jupyter-lab", "ipykernel_launcher", "houdini", "maya.bin"])
def test_host_programs_are_not_taken_for_python(tmp_path, name):
    prog, _ = _host_program(tmp_path, name)
    assert not qem._is_python(str(prog))
    assert not qem._is_python(str(tmp_path / "absent" / "python3"))  # and a missing file neither


def _not_python_anywhere(monkeypatch, prog):
    from multiprocessing import spawn

    monkeypatch.setattr(qem, "WORKER", None)
    monkeypatch.setattr(sys, "executable", str(prog))
    monkeypatch.setattr(spawn, "get_executable", lambda: str(prog))


def test_the_helper_is_refused_when_sys_executable_is_not_python(tmp_path, monkeypatch):
    """Inside an embedding host: no helper process is started (the host program is never run),
    and the halves are simplified here into the very cage the helper would have given."""
    big = bumpy_blob(5)
    monkeypatch.setattr(qem, "SPLIT_MIN_FACES", 0)
    with_helper = qem.presimplify(big.vertices, big.faces, 1000)
    cage_with_helper = build_cage(big, 0.05)
    prog, mark = _host_program(tmp_path)
    _not_python_anywhere(monkeypatch, prog)
    assert qem.helper_python() is None
    w = qem.HalfWorker()
    assert not w.started and not w.simplify(*_open_half(), 100)
    w.close()
    in_process = qem.presimplify(big.vertices, big.faces, 1000)
    cage_in_process = build_cage(big, 0.05)
    assert not mark.exists()
    assert np.array_equal(in_process[0], with_helper[0]) and np.array_equal(in_process[1], with_helper[1])
    assert np.array_equal(cage_in_process.vertices, cage_with_helper.vertices)
    assert np.array_equal(cage_in_process.faces, cage_with_helper.faces)


def test_a_host_that_names_its_python_to_multiprocessing_gets_the_helper(tmp_path, monkeypatch):
    """sys.executable is the host program, but multiprocessing.set_executable() named the bundled
    Python (as embedding hosts do): the helper runs with that one."""
    from multiprocessing import spawn

    prog, mark = _host_program(tmp_path)
    real = sys.executable
    monkeypatch.setattr(qem, "WORKER", None)
    monkeypatch.setattr(sys, "executable", str(prog))
    monkeypatch.setattr(spawn, "get_executable", lambda: real)
    assert qem.helper_python() == real
    v, f = _open_half()
    w = qem.HalfWorker()
    try:
        assert w.started and w.simplify(v, f, 600)
        got = w.result()
    finally:
        w.close()
    want = qem_worker.simplify_half(v, f, 600)
    assert got is not None and np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert not mark.exists()


def test_the_helper_sees_the_import_path_this_process_was_given(tmp_path, monkeypatch):
    """A folder a host put on sys.path at run time (not in the interpreter's own path) reaches the
    helper, so that it imports what this process imports."""
    extra = tmp_path / "host-site-packages"
    extra.mkdir()
    (extra / "only_here_probe.py").write_text("VALUE = 42\n")
    monkeypatch.syspath_prepend(str(extra))
    run = subprocess.run([sys.executable, "-c", "import only_here_probe; print(only_here_probe.VALUE)"],
                         env=qem._helper_env(), capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.strip() == "42", run.stderr


@pytest.mark.parametrize("sizes", [(10, 10), (100_000, 200_000), (0, 0)])
def test_a_reserve_header_before_the_surface_changes_nothing(sizes):
    """Sizes announced first (smaller or larger than the surface, or none) only grow the
    simplifier's buffers: the surface that follows is simplified exactly as without them."""
    v, f = _open_half()
    reserve = np.array([*sizes, qem_worker.RESERVE], dtype=np.int64).tobytes()
    head = np.array([len(v), len(f), 600], dtype=np.int64).tobytes()
    run = _run(reserve + head + v.astype(np.float64).tobytes() + f.astype(np.int32).tobytes())
    assert run.returncode == 0, run.stderr
    nv, nf = np.frombuffer(run.stdout[:16], dtype=np.int64)
    got_v = np.frombuffer(run.stdout, dtype=np.float64, count=3 * nv, offset=16).reshape(-1, 3)
    got_f = np.frombuffer(run.stdout, dtype=np.int32, count=3 * nf, offset=16 + 24 * nv).reshape(-1, 3)
    want_v, want_f = qem_worker.simplify_half(v, f, 600)
    assert np.array_equal(got_v, want_v) and np.array_equal(got_f, want_f)


def test_a_reserve_header_alone_ends_it_quietly():
    run = _run(np.array([1000, 2000, qem_worker.RESERVE], dtype=np.int64).tobytes())
    assert run.returncode == 0 and run.stdout == b""


def test_the_worker_takes_its_share_and_the_cut_does_not_depend_on_it(monkeypatch):
    """The worker's half has WORKER_SHARE of the faces, whether it grew its buffers ahead or not;
    a worker that reads the sizes, then dies, leaves both halves of the same cut to this process,
    which makes the same surface (the simplification is deterministic)."""
    big = bumpy_blob(5)
    sizes = []
    real = qem.simplify_half

    def counting(v, f, target):
        sizes.append(len(f))
        return real(v, f, target)

    monkeypatch.setattr(qem, "simplify_half", counting)
    results = []
    for command in (None, [sys.executable, "-c", "import sys; sys.stdin.buffer.read(24); sys.exit(3)"]):
        monkeypatch.setattr(qem, "WORKER", command)
        sizes.clear()
        w = qem.HalfWorker(expect=(big.n_vertices, big.n_faces))
        try:
            results.append(qem.presimplify(big.vertices, big.faces, 1000, min_faces=0, worker=w))
        finally:
            w.close()
        mine = sizes[0]
        assert abs((big.n_faces - mine) / big.n_faces - qem.WORKER_SHARE) <= 0.01
        assert len(sizes) == (1 if command is None else 2)
    plain = qem.presimplify(big.vertices, big.faces, 1000, min_faces=0)  # a worker started here
    for v, f in results:
        assert np.array_equal(v, plain[0]) and np.array_equal(f, plain[1])

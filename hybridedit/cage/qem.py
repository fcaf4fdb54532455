"""Quadric simplification of a big surface on two cores.

fast-simplification runs on one core and holds Python's lock. On a surface of
millions of faces it is most of the cage build (7-12 s at 2.7M vertices), and a
good part of that is its first touch of the 2 GB it allocates. :func:`presimplify`
cuts such a surface in two halves across its longest axis, simplifies one half in
a process of its own (:mod:`hybridedit.cage.qem_worker`, which a caller can start early
with :func:`start_worker`, so that it is ready when the half is) while this process
simplifies the other, both with the cut's border kept exactly, and joins the
halves along the cut. The caller then simplifies the joined surface, a little
above its target, to the target as usual, and that last pass simplifies across
the cut as well.

The helper process is started only with an interpreter that is known to be a
Python (:func:`helper_python`): inside an embedded interpreter (Blender, some
notebook hosts) ``sys.executable`` can be the host's own program, which must
never be started with a script. Without one, both halves are simplified in this
process, one after the other: the same cage, on one core.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from numba import njit, prange

from .qem_worker import RESERVE, simplify_half
from ..core.index_sets import unique_in_range
from ..core.topology import group_rows
from ..core.bounds import points_box
from ..core.parallel import pick
from ..core.twins import twins

__all__ = ["SPLIT_MIN_FACES", "MARGIN", "HalfWorker", "helper_python", "presimplify", "start_worker", "splits",
           "will_split"]

#: surfaces of at least this many faces are simplified in two halves at once
#: (the 173K armadillo's 346K faces: 0.6 s on one core)
SPLIT_MIN_FACES = 300_000
#: the halves together keep this many times the final face target (the last pass
#: then has room to simplify across the cut)
MARGIN = 1.25
#: the share of the faces the worker's half has (the rest are simplified in this process). A worker
#: started early grows its buffers while this process repairs the shape (see :func:`start_worker`)
#: and then simplifies a face faster: in equal halves it finished first and sat idle, at 0.55 both
#: halves end about together (at 0.6 the worker's is the longer). The cut does not depend on whether
#: the worker runs, so that the cage is the same with or without it.
WORKER_SHARE = 0.55
#: the command that runs a half in another process (the worker's path is appended); None: the
#: interpreter :func:`helper_python` finds, or no helper when it finds none
WORKER: list[str] | None = None

#: names of CPython and PyPy interpreters: python, python3, python3.12, python3.13t, pythonw.exe, pypy3
_PYTHON_NAME = re.compile(r"(python|pypy)(\d+(\.\d+)*)?[dmtw]*(\.exe)?", re.IGNORECASE)


def _is_python(path: str) -> bool:
    """Whether ``path`` is an executable file named as a Python interpreter (itself or, for a
    link such as a virtual environment's ``python``, what it points to)."""
    if not path or not os.path.isfile(path) or not os.access(path, os.X_OK):
        return False
    names = {os.path.basename(path), os.path.basename(os.path.realpath(path))}
    return any(_PYTHON_NAME.fullmatch(n) for n in names)


def helper_python() -> str | None:
    """The interpreter to start the helper with, or None when there is none to trust.

    ``sys.executable`` when it is a Python interpreter; else the one multiprocessing's spawn
    would start (``multiprocessing.set_executable``, which hosts embedding Python set to their
    bundled interpreter) when that is one. A host program (``blender``, a notebook server's
    binary) is never started. The helper gets this process's import path (:func:`_helper_env`),
    so that it finds the same numpy and fast-simplification, paths a host added included.
    """
    candidates = [sys.executable]
    try:
        from multiprocessing import spawn

        candidates.append(spawn.get_executable())
    except Exception:  # noqa: BLE001 -- no multiprocessing (some embedded builds): sys.executable alone
        pass
    for exe in candidates:
        if isinstance(exe, bytes):
            exe = os.fsdecode(exe)
        if exe and _is_python(str(exe)):
            return str(exe)
    return None


def _helper_env() -> dict[str, str]:
    """The environment of the helper: this one, with this process's import path first."""
    here = os.path.dirname(os.path.realpath(__file__))
    paths = [p for p in sys.path if p and os.path.isdir(p) and os.path.realpath(p) != here]
    env = dict(os.environ)
    old = env.get("PYTHONPATH")
    env["PYTHONPATH"] = os.pathsep.join(paths + ([old] if old else []))
    return env


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def splits(n_faces: int, *, min_faces: int | None = None) -> bool:
    """Whether a surface of ``n_faces`` faces is big enough to simplify in halves on this machine."""
    limit = SPLIT_MIN_FACES if min_faces is None else int(min_faces)
    return n_faces >= max(limit, 8) and _cores() >= 2


class HalfWorker:
    """A :mod:`hybridedit.cage.qem_worker` process, started before its half is known.

    It imports numpy and fast-simplification while the caller prepares the
    surface; :meth:`simplify` sends it a half and :meth:`result` collects it.
    :meth:`close` ends it (a worker that got nothing exits quietly).

    ``expect``, (vertices, faces) about the size of the half to come, lets it grow
    fast-simplification's buffers meanwhile (:func:`hybridedit.cage.qem_worker.reserve`).
    """

    def __init__(self, *, expect: tuple[int, int] | None = None) -> None:
        self.used = False
        self._proc = None
        if WORKER is not None:
            command = list(WORKER)
        else:
            exe = helper_python()
            command = [exe] if exe else []
        #: whether a helper process was started (False: its half is simplified in this process)
        self.started = False
        if not command or not all(command):  # no interpreter to start (an embedded Python)
            return
        worker = Path(__file__).with_name("qem_worker.py")
        try:
            self._proc = subprocess.Popen([*command, str(worker)], stdin=subprocess.PIPE,
                                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                          env=_helper_env())
            self.started = True
        except OSError:
            self._proc = None
            return
        if expect is not None:
            nv, nf = (max(int(x), 0) for x in expect)
            try:
                self._proc.stdin.write(np.array([nv, nf, RESERVE], dtype=np.int64).tobytes())
                self._proc.stdin.flush()
            except OSError:  # it died: its half is simplified here
                self.close()

    def simplify(self, vertices: np.ndarray, faces: np.ndarray, target: int) -> bool:
        """Send a surface ((k, 3) float64, (t, 3) int32) to simplify to ``target`` faces;
        False when the worker is not there to take it."""
        self.used = True
        if self._proc is None:
            return False
        try:
            pipe = self._proc.stdin
            pipe.write(np.array([len(vertices), len(faces), int(target)], dtype=np.int64).tobytes())
            # (the arrays' own memory, not a copy: 265 MB for half the 11M armadillo)
            pipe.write(memoryview(np.ascontiguousarray(vertices, dtype=np.float64)).cast("B"))
            pipe.write(memoryview(np.ascontiguousarray(faces, dtype=np.int32)).cast("B"))
            pipe.close()
            return True
        except OSError:  # it died (a broken pipe)
            self.close()
            return False

    def result(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The simplified surface, or None when the worker failed."""
        if self._proc is None:
            return None
        out = self._proc.stdout.read()
        self._proc.wait()
        ok = self._proc.returncode == 0 and len(out) >= 16
        self._proc = None
        if not ok:
            return None
        nv, nf = (int(x) for x in np.frombuffer(out[:16], dtype=np.int64))
        if nv < 0 or nf < 0 or len(out) != 16 + 24 * nv + 12 * nf:
            return None
        v = np.frombuffer(out, dtype=np.float64, count=3 * nv, offset=16).reshape(nv, 3).copy()
        f = np.frombuffer(out, dtype=np.int32, count=3 * nf, offset=16 + 24 * nv).reshape(nf, 3).copy()
        if nf and (f.min() < 0 or f.max() >= nv):
            return None
        return v, f

    def close(self) -> None:
        """End the worker (at once if it is still working)."""
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.poll() is None:
            proc.kill()
        for pipe in (proc.stdin, proc.stdout):
            try:
                pipe.close()
            except OSError:
                pass
        proc.wait()


def start_worker(n_faces: int, target_faces: int, n_vertices: int) -> HalfWorker | None:
    """A worker started now for a surface of ``n_faces`` faces and ``n_vertices`` vertices
    that :func:`presimplify` will split when it simplifies it to ``target_faces``
    (:func:`will_split`), else None. Give it to :func:`presimplify`; :meth:`HalfWorker.close` it
    afterwards.

    The worker grows its buffers to its share of the surface (:data:`WORKER_SHARE`, a little
    more: the cut's vertices are in both halves) while the caller is busy.
    """
    if not will_split(n_faces, target_faces):
        return None
    room = 1.02
    return HalfWorker(expect=(int(room * WORKER_SHARE * n_vertices) + 64, int(room * WORKER_SHARE * n_faces) + 64))


def will_split(n_faces: int, target_faces: int, *, min_faces: int | None = None) -> bool:
    """Whether :func:`presimplify` splits a surface of ``n_faces`` faces simplified to
    ``target_faces``: one it :func:`splits`, whose target is well below its size (the halves
    keep :data:`MARGIN` times it, at most half the surface).

    Examples
    --------
    >>> will_split(1_383_712, 69_184), will_split(415_112, 276_742)  # the 690K armadillo; 2.77M's clusters
    (True, False)
    """
    return splits(n_faces, min_faces=min_faces) and MARGIN * target_faces <= 0.5 * n_faces


def presimplify(vertices: np.ndarray, faces: np.ndarray, target_faces: int, *,
                min_faces: int | None = None, worker: HalfWorker | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A surface close to ``MARGIN * target_faces`` faces made on two cores, or the input itself.

    A surface below ``min_faces`` faces (:data:`SPLIT_MIN_FACES` by default),
    one whose target is not well below its size, or a machine of one core gets
    the input back unchanged. Otherwise the faces are cut in two at a quantile of
    their centroids along the longest axis of the bounding box (the worker's half
    has :data:`WORKER_SHARE` of them); each half is
    simplified with its border kept (one in a worker process, one here, at the
    same time), and the halves are joined by merging the cut's vertices, which
    neither pass moved. If the worker fails, its half is simplified here.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    target_faces : int
        The face count the caller will simplify to.
    min_faces : int, optional
        Split only from this many faces.
    worker : HalfWorker, optional
        A worker started earlier (:func:`start_worker`), used if it has not been
        yet; else one is started here. The caller closes it.

    Returns
    -------
    vertices : (k, 3) float64
    faces : (t, 3) int32, on ``vertices`` (some of which may be unused)

    Examples
    --------
    >>> v, f = presimplify(mesh.vertices, mesh.faces, 50_000)  # doctest: +SKIP
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    f = np.ascontiguousarray(faces).reshape(-1, 3)
    m = len(f)
    if not will_split(m, target_faces, min_faces=min_faces):
        return v, f.astype(np.int32, copy=False)
    lo, hi = points_box(v)
    axis = int(np.argmax(hi - lo))
    key = _face_keys(v, f, axis)
    cut = min(max(int(round((1.0 - WORKER_SHARE) * m)), 0), m - 1)
    pivot = np.partition(key, cut)[cut]
    halves = _halves(v, f, key, pivot)
    if not len(halves[1][1]):  # every centroid on the quantile: no cut to make
        return v, f.astype(np.int32, copy=False)
    targets = [max(4, int(round(MARGIN * target_faces * len(h[1]) / m))) for h in halves]
    own = worker is None or worker.used
    if own:
        worker = HalfWorker()
    try:
        sent = worker.simplify(halves[1][0], halves[1][1], targets[1])
        done0 = simplify_half(halves[0][0], halves[0][1], targets[0])
        done1 = worker.result() if sent else None
    finally:
        if own:
            worker.close()
    if done1 is None:
        done1 = simplify_half(halves[1][0], halves[1][1], targets[1])
    return _join(done0, done1)


@njit(cache=True, inline="always")
def _face_key(v, f, axis, key, i):
    key[i] = v[f[i, 0], axis] + v[f[i, 1], axis] + v[f[i, 2], axis]


@twins()
def _face_keys_twins(v, f, axis, key):  # pragma: no cover - compiled
    for i in prange(f.shape[0]):
        _face_key(v, f, axis, key, i)


def _face_keys(v: np.ndarray, f: np.ndarray, axis: int) -> np.ndarray:
    """(m,) three times each face's centroid coordinate along ``axis``."""
    key = np.empty(f.shape[0])
    pick("faces", *_face_keys_twins, f.shape[0])(v, f, axis, key)
    return key


@njit(cache=True)
def _halves(v, f, key, pivot):  # pragma: no cover - compiled
    """The faces whose key is at most ``pivot``, and the others, each half as (vertices it uses in
    their order, float64; its faces on them, int32). Two passes over the faces and two over the
    vertices (numpy's masks, cumulative sums and gathers took 3-5 s for the 11M armadillo)."""
    n = v.shape[0]
    m = f.shape[0]
    remap0 = np.full(n, -1, dtype=np.int32)
    remap1 = np.full(n, -1, dtype=np.int32)
    m0 = 0
    for i in range(m):
        if key[i] <= pivot:
            m0 += 1
            remap0[f[i, 0]] = remap0[f[i, 1]] = remap0[f[i, 2]] = 0
        else:
            remap1[f[i, 0]] = remap1[f[i, 1]] = remap1[f[i, 2]] = 0
    n0 = 0
    n1 = 0
    for k in range(n):
        if remap0[k] == 0:
            remap0[k] = n0
            n0 += 1
        if remap1[k] == 0:
            remap1[k] = n1
            n1 += 1
    v0 = np.empty((n0, 3))
    v1 = np.empty((n1, 3))
    for k in range(n):
        if remap0[k] >= 0:
            v0[remap0[k]] = v[k]
        if remap1[k] >= 0:
            v1[remap1[k]] = v[k]
    f0 = np.empty((m0, 3), dtype=np.int32)
    f1 = np.empty((m - m0, 3), dtype=np.int32)
    t0 = 0
    t1 = 0
    for i in range(m):
        if key[i] <= pivot:
            f0[t0, 0] = remap0[f[i, 0]]
            f0[t0, 1] = remap0[f[i, 1]]
            f0[t0, 2] = remap0[f[i, 2]]
            t0 += 1
        else:
            f1[t1, 0] = remap1[f[i, 0]]
            f1[t1, 1] = remap1[f[i, 1]]
            f1[t1, 2] = remap1[f[i, 2]]
            t1 += 1
    return (v0, f0), (v1, f1)


def _join(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The two simplified halves as one surface: a vertex of b's border that sits
    exactly on one of a's border vertices becomes that vertex."""
    (va, fa), (vb, fb) = a, b
    border_a, border_b = _border(fa, len(va)), _border(fb, len(vb))
    remap = np.arange(len(va), len(va) + len(vb), dtype=np.int64)
    if border_a.size and border_b.size:
        keys = np.vstack([va[border_a], vb[border_b]]) + 0.0  # -0.0 as 0.0
        first, group = group_rows(keys.view(np.int64))
        # a group's first row is an a vertex when any of its rows is one (a's rows come first)
        head = first[group[len(border_a):]]
        on_a = head < len(border_a)
        remap[border_b[on_a]] = border_a[head[on_a]]
    v = np.vstack([va, vb])
    f = np.vstack([fa.astype(np.int64), remap[fb]])
    return v, f.astype(np.int32)


def _border(f: np.ndarray, n: int) -> np.ndarray:
    """The vertices on an edge that only one face uses (sorted)."""
    from ..core.topology import edge_face_counts

    edges, counts = edge_face_counts(f, n)
    return unique_in_range(edges[counts == 1], n)

"""One quadric simplification in a process of its own (run as a script by :mod:`hybridedit.cage.qem`).

Usage: ``python qem_worker.py``, then on standard input the vertex count, the
face count and the target face count (three int64), the vertices (float64) and
the faces (int32) as raw bytes. It simplifies the surface to the target, keeping
its open border (the cut with the other half) untouched, and writes the vertex
count, the face count (two int64), the vertices (float64) and the faces (int32)
to standard output. Standard input closed before anything arrives (the caller
did not need it after all) ends it quietly.

A header whose target is :data:`RESERVE` comes before the surface's, with no
arrays: the sizes the surface will have about. The worker then grows
fast-simplification's buffers to them (:func:`reserve`) while the caller is
still preparing the surface.

It imports only numpy and fast-simplification, not the hybridedit package, so
that it is ready in a fraction of a second; the caller starts it early and sends
the half when it has one.
"""

from __future__ import annotations

import os
import sys

if __name__ == "__main__":
    # run as a script, Python puts this file's folder first on the path, where its
    # sibling modules (build.py, qem.py) would shadow any others of the same name
    _here = os.path.dirname(os.path.realpath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.realpath(p or ".") != _here]

import numpy as np  # noqa: E402

#: fast-simplification's aggressiveness for every cage simplification (its default: 7)
AGGRESSIVENESS = 7.0
#: the target of a header that only announces the sizes of the surface to come (see :func:`reserve`)
RESERVE = -1


def reserve(n_vertices: int, n_faces: int) -> None:
    """Grow fast-simplification's buffers to ``n_vertices`` vertices and ``n_faces`` faces.

    It keeps its vertices and faces in C++ vectors that grow one push at a time and keep their
    memory between calls. Its loading of half the 11M armadillo took 4.1 s, most of it the
    kernel's first touch of the 1.8 GB the vectors grow to, and 0.3 s into vectors grown already.
    Loading a surface of these sizes (all its faces on one point, which leaves nothing to
    simplify) touches that memory now.
    """
    import fast_simplification

    n_vertices, n_faces = max(int(n_vertices), 1), max(int(n_faces), 1)
    fast_simplification.simplify(np.zeros((n_vertices, 3)), np.zeros((n_faces, 3), dtype=np.int32),
                                 target_count=n_faces)


def simplify_half(vertices: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Simplify to ``target`` faces with the border kept: ((k, 3) float64, (t, 3) int32)."""
    import fast_simplification

    v, f = fast_simplification.simplify(np.ascontiguousarray(vertices, dtype=np.float64),
                                        np.ascontiguousarray(faces, dtype=np.int32),
                                        target_count=int(min(target, len(faces))), agg=AGGRESSIVENESS,
                                        preserve_border=True)
    return np.ascontiguousarray(v, dtype=np.float64), np.ascontiguousarray(f, dtype=np.int32)


def _read(stream, nbytes: int) -> bytearray | None:
    """Exactly ``nbytes`` from ``stream`` (a writable buffer), or None at an early end."""
    buf = bytearray(nbytes)
    view, got = memoryview(buf), 0
    while got < nbytes:
        k = stream.readinto(view[got:])
        if not k:
            return None
        got += k
    return buf


def main(argv: list[str]) -> int:
    if argv:
        print("usage: qem_worker.py  (the surface on standard input, see the module's docstring)",
              file=sys.stderr)
        return 2
    import fast_simplification  # noqa: F401  -- loaded while the caller is still busy

    stdin = sys.stdin.buffer
    target = RESERVE
    while target == RESERVE:
        head = _read(stdin, 24)
        if head is None:
            return 0  # not needed after all
        nv, nf, target = (int(x) for x in np.frombuffer(head, dtype=np.int64))
        if target == RESERVE and nv >= 0 and nf >= 0:
            reserve(nv, nf)
    if nv < 0 or nf < 0 or target < 0:
        print("qem_worker: bad header", file=sys.stderr)
        return 2
    vb, fb = _read(stdin, 24 * nv), _read(stdin, 12 * nf)
    if vb is None or fb is None:
        print("qem_worker: the surface ended early", file=sys.stderr)
        return 2
    v, f = simplify_half(np.frombuffer(vb, dtype=np.float64).reshape(nv, 3),
                         np.frombuffer(fb, dtype=np.int32).reshape(nf, 3), target)
    out = sys.stdout.buffer
    out.write(np.array([len(v), len(f)], dtype=np.int64).tobytes())
    out.write(v.tobytes())
    out.write(f.tobytes())
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

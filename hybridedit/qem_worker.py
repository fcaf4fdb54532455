"""One quadric simplification in a process of its own (run as a script by :mod:`hybridedit.qem`).

Usage: ``python qem_worker.py VERTICES.npy FACES.npy TARGET``. It simplifies the
surface to ``TARGET`` faces, keeping its open border (the seam with the other
half) untouched, and writes the vertex count, the face count (two int64), the
vertices (float64) and the faces (int32) to standard output as raw bytes.

It imports only numpy and fast-simplification, not the hybridedit package, so
that it starts in a fraction of a second.
"""

from __future__ import annotations

import os
import sys

if __name__ == "__main__":
    # run as a script, Python puts this file's folder (the package's) first on the
    # path, where io.py and the other modules would shadow those of the same name
    _here = os.path.dirname(os.path.realpath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.realpath(p or ".") != _here]

import numpy as np  # noqa: E402


def simplify_half(vertices: np.ndarray, faces: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """Simplify to ``target`` faces with the border kept: ((k, 3) float64, (t, 3) int32)."""
    import fast_simplification

    v, f = fast_simplification.simplify(np.ascontiguousarray(vertices, dtype=np.float64),
                                        np.ascontiguousarray(faces, dtype=np.int32),
                                        target_count=int(min(target, len(faces))), agg=7.0, preserve_border=True)
    return np.ascontiguousarray(v, dtype=np.float64), np.ascontiguousarray(f, dtype=np.int32)


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        print("usage: qem_worker.py VERTICES.npy FACES.npy TARGET", file=sys.stderr)
        return 2
    v, f = simplify_half(np.load(argv[0]), np.load(argv[1]), int(argv[2]))
    out = sys.stdout.buffer
    out.write(np.array([len(v), len(f)], dtype=np.int64).tobytes())
    out.write(v.tobytes())
    out.write(f.tobytes())
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""When a kernel runs on every core: one table of sizes, one way to choose.

Many compiled kernels come in twins, a serial loop and a ``prange`` one. Starting numba's thread
pool costs more than small work, and on a busy 2-core machine a parallel pass can wait milliseconds
for its second thread, so each kind of work switches to its parallel twin from a size measured for
it (:data:`THRESHOLDS`, items of the loop: rows, vertices, faces). Every caller chooses through
:func:`pick`; :func:`all_parallel` sets every size to zero for a while (``python -m
hybridedit.warmup`` compiles the parallel twins that way).

Examples
--------
>>> pick("propagate", "serial", "parallel", 10)
'serial'
>>> with all_parallel():
...     pick("propagate", "serial", "parallel", 10)
'parallel'
"""

from __future__ import annotations

import contextlib
from typing import Iterator, TypeVar

K = TypeVar("K")

THRESHOLDS: dict[str, int] = {
    # a cage vertex's rotation (a 3x3 polar decomposition) is work enough that two threads win from
    # about a thousand: the local step of a 2,163-vertex cage 0.61 -> 0.33 ms, of 8,650 2.6 -> 1.3 ms
    "rotations": 1_000,
    # the region step's right-hand side (rotation blend, then the ARAP right-hand side): the canonical
    # edit's region at 173K (5.9K vertices) 0.26 ms on one thread, 0.21 on two; at 690K (12K) 0.37 -> 0.20
    "region_step": 8_000,
    # constrained rows placed exactly: they lie scattered through the shape and two threads wait on
    # memory side by side (the 52K handle rows at 690K 0.22-0.9 ms -> 0.1-0.46 ms)
    "place": 20_000,
    # rows of x' = M y' (plus the rotated residual): a few multiply-adds each
    "propagate": 20_000,
    # faces tested for degeneracy while a mesh is checked
    "faces": 50_000,
    # the window's per-frame kernels (points, normals, edge error, stretch) run on its frame thread,
    # beside the software rasterizer: a parallel region there waits for its slowest thread (the 173K
    # armadillo's region normals: 31 ms in parallel, about 2 ms serial)
    "window": 50_000,
    # vertex normals of a whole shape (the window's full update, a file's normals)
    "normals": 50_000,
}


def pick(kind: str, serial: K, parallel: K, n: int) -> K:
    """The parallel twin when ``n`` items reach ``THRESHOLDS[kind]``, else the serial one."""
    return parallel if n >= THRESHOLDS[kind] else serial


@contextlib.contextmanager
def all_parallel() -> Iterator[None]:
    """Every kind runs its parallel twin inside the ``with`` block (sizes restored after)."""
    saved = dict(THRESHOLDS)
    try:
        THRESHOLDS.update(dict.fromkeys(THRESHOLDS, 0))
        yield
    finally:
        THRESHOLDS.update(saved)

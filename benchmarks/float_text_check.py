"""The compiled shortest float text (text_format.float_rows) against Python's repr, at scale.

Too slow for a unit test (tests/fileio/test_text_format.py checks ~200K values): every special
value family (extremes, subnormals, powers of 2 and 10 and their neighbours, the first and last
mantissas of every exponent, integers about 2**53, the layout's 1e-4 / 1e16 boundaries), every
coordinate of the shared meshes, then ``--count`` random doubles of each of five kinds (random bit
patterns over every exponent, mesh-like magnitudes, float32 values widened, dyadic rationals,
decimals rounded to 0..16 places). Prints the mismatches (none expected) and their total.

    python benchmarks/float_text_check.py [--count 10000000] [--seed 1] [--smoke]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hybridedit.fileio.formats.text_format import float_rows  # noqa: E402

SHARED = ROOT.parent / "shared" / "meshes"


def check(values: np.ndarray, label: str) -> int:
    """Mismatches of float_rows against repr over ``values`` (any shape, float64); prints a line."""
    v = np.ascontiguousarray(values, dtype=np.float64).reshape(-1, 1)
    got = float_rows(b"", v).tobytes().split(b"\n")[:-1]
    want = [repr(x).encode() for x in v.ravel().tolist()]
    bad = [(w, g) for w, g in zip(want, got) if w != g] if got != want else []
    print(f"{label:>16}: {len(want):>10,} values, {len(bad)} different {bad[:5]}", flush=True)
    return len(bad) + abs(len(got) - len(want))


def families() -> dict[str, np.ndarray]:
    exps = np.arange(0, 2047, dtype=np.uint64) << np.uint64(52)
    low = np.arange(0, 64, dtype=np.uint64)
    high = np.uint64((1 << 52) - 1) - low
    edges = (exps[:, None] | np.concatenate([low, high])[None, :]).ravel().view(np.float64)
    powers = np.array([10.0 ** k for k in range(-325, 309)] + [2.0 ** k for k in range(-1074, 1024)])
    around = np.concatenate([np.nextafter(powers, 0), np.nextafter(powers, np.inf), powers])
    ints = np.array([float(2 ** 53 + d) for d in range(-4096, 4096)] + [float(k * 10 ** j) for k in range(1, 1000)
                                                                       for j in range(0, 23)])
    layout = np.array([k * 10.0 ** e for k in np.arange(1, 10000) for e in (-5, -4, -3, 15, 16, 17)])
    return {"exponent edges": edges, "powers": around, "integers": ints, "layout": layout}


def shared_coordinates() -> list[tuple[str, np.ndarray]]:
    from hybridedit.fileio.meshfiles import read_mesh

    out = []
    for path in sorted(SHARED.rglob("*")):
        if path.suffix.lower() in (".obj", ".ply", ".off", ".stl", ".glb"):
            out.append((path.name, read_mesh(path).vertices))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--count", type=int, default=10_000_000, help="random values of each kind")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--smoke", action="store_true", help="CI smoke run: 20,000 random values of each kind")
    args = ap.parse_args()
    if args.smoke:
        args.count = 20_000
    t0 = time.perf_counter()
    bad = 0
    for label, values in families().items():
        bad += check(np.concatenate([values, -values]), label)
    for name, values in shared_coordinates():
        bad += check(values, name[:16])
    rng = np.random.default_rng(args.seed)
    done = 0
    while done < args.count:
        m = min(2_000_000, args.count - done)
        bits = rng.integers(0, 2 ** 64, size=m, dtype=np.uint64).view(np.float64)
        bad += check(np.where(np.isfinite(bits), bits, 1.0), "bits")
        bad += check(rng.normal(size=m) * 10.0 ** rng.integers(-3, 4, size=m), "mesh-like")
        bad += check(rng.normal(size=m).astype(np.float32).astype(np.float64) * np.float32(3), "float32 widened")
        bad += check(rng.integers(-2 ** 60, 2 ** 60, size=m) / 2.0 ** rng.integers(0, 70, size=m), "dyadic")
        bad += check(np.round(rng.normal(size=m) * 10.0 ** rng.integers(0, 17, size=m))
                     / 10.0 ** rng.integers(0, 17, size=m), "rounded")
        done += m
    print(f"different in all: {bad} ({time.perf_counter() - t0:.0f} s)")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()

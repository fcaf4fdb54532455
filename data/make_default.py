"""Generate the editor's default mesh, ``data/creature.ply``.

The creature is an implicit surface: a smooth union of ellipsoids, spheres
and (tapered) capsules -- body, hips, neck, head with snout, eyes, brows,
horns and ears, two arms held out along +-X ending in hands with four fingers
and a thumb, two legs with three-toed feet, a curled tail and a row of spines
down the back; pupils, nostrils and a mouth are carved in -- plus a scale
pattern (a cellular displacement, about 0.4% of the height deep) added to the
distance field.  It is meshed with VTK's flying-edges contouring on a regular
grid and cleaned up (largest component, merged duplicate points, outward
orientation, no degenerate faces).

Everything is analytic: no downloads and no randomness, so the output is the
same on every run.

Conventions: Y up, the creature faces +Z, it is centred near the origin and is
about 2 units tall.  The hand at +X is the set of vertices with x > 0.85.

Usage (from the repository root)::

    python data/make_default.py                      # writes data/creature.ply
    python data/make_default.py --out /tmp/c.ply --resolution 300
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.join(HERE, "creature.ply")
# Grid cells along the longest side of the bounding box; chosen so the mesh
# lands near 100K vertices.
DEFAULT_RESOLUTION = 294

BIG = np.float32(1.0)  # field value where no part is near (well outside)


# ---------------------------------------------------------------------------
# the shape
# ---------------------------------------------------------------------------


def creature_parts() -> list[tuple]:
    """The parts, in blending order: (kind, params, blend radius k, scale
    weight, carve).

    kinds: "ellipsoid" (center, radii), "sphere" (center, r),
    "capsule" (a, b, ra, rb) -- a capsule whose radius goes linearly from ra
    at a to rb at b.  Each part is smooth-unioned with the parts before it
    over a distance k (0: plain union).  The scale weight sets how strongly
    the scale pattern shows on the part:
    thin parts (fingers, toes, horn tips, spines) get less or none so they
    stay clean and no bump bridges the gap between two of them.  A carved
    part is smoothly subtracted instead (mouth, nostrils, pupils).
    """
    P: list[tuple] = []

    def add(kind, prm, k, w=1.0, carve=False):
        P.append((kind, prm, k, w, carve))

    def both(p):
        return [(-p[0], p[1], p[2]), (p[0], p[1], p[2])]

    # torso, chest and hips
    add("ellipsoid", ((0.0, 0.02, 0.0), (0.30, 0.40, 0.25)), 0.0)
    add("ellipsoid", ((0.0, 0.10, 0.06), (0.27, 0.25, 0.20)), 0.08)  # chest
    add("ellipsoid", ((0.0, -0.30, -0.02), (0.27, 0.20, 0.23)), 0.10)  # hips
    add("ellipsoid", ((0.0, -0.10, 0.16), (0.20, 0.26, 0.10)), 0.08, 0.3)  # smooth belly plate
    # neck, head, snout
    add("capsule", ((0.0, 0.34, 0.0), (0.0, 0.56, 0.04), 0.12, 0.10), 0.08)
    add("sphere", ((0.0, 0.70, 0.04), 0.22), 0.08, 0.7)
    add("ellipsoid", ((0.0, 0.63, 0.22), (0.14, 0.11, 0.14)), 0.06, 0.4)  # snout
    add("ellipsoid", ((0.0, 0.61, 0.34), (0.05, 0.035, 0.03)), 0.03, 0.3)  # nose tip
    add("ellipsoid", ((0.0, 0.54, 0.13), (0.12, 0.08, 0.13)), 0.06, 0.4)  # jaw, fills the crease under the chin
    for c in both((0.105, 0.765, 0.225)):  # eyes: smooth bulging spheres
        add("sphere", (c, 0.055), 0.02, 0.0)
    for c in both((0.105, 0.83, 0.19)):  # brow ridges
        add("ellipsoid", (c, (0.07, 0.022, 0.05)), 0.03)
    # Carved details.  Each carving tool is centred just outside the surface
    # (found by marching along a ray through the parts so far), so it cuts an
    # open dimple or groove and never a closed tunnel or an inner void.
    for side in (-1.0, 1.0):  # pupils: shallow dimples in the eyes
        c = _surface_point(P, (side * 0.105, 0.765, 0.225), (side * 0.25, 0.05, 1.0), 0.006)
        add("sphere", (c, 0.016), 0.008, carve=True)
    for side in (-1.0, 1.0):  # nostrils
        c = _surface_point(P, (0.0, 0.61, 0.34), (side * 0.35, 0.15, 1.0), 0.004)
        add("sphere", (c, 0.011), 0.006, carve=True)
    # mouth: a smiling groove around the front of the snout
    mouth = []
    for phi in np.radians(np.linspace(-75.0, 75.0, 9)):
        y = 0.575 + 0.02 * (phi / np.radians(75.0)) ** 2
        mouth.append(_surface_point(P, (0.0, y, 0.22), (np.sin(phi), 0.0, np.cos(phi)), 0.005))
    for a, b in zip(mouth[:-1], mouth[1:]):
        add("capsule", (a, b, 0.014, 0.014), 0.01, carve=True)
    # horns: tapered chains sweeping up and back
    horn = [(0.10, 0.84, 0.02), (0.15, 0.95, -0.02), (0.17, 1.03, -0.10), (0.16, 1.07, -0.19)]
    hrad = [0.050, 0.036, 0.022, 0.010]
    hw = [0.6, 0.2, 0.0]
    for side in (-1.0, 1.0):
        pts = [(side * x, y, z) for x, y, z in horn]
        for i in range(3):
            add("capsule", (pts[i], pts[i + 1], hrad[i], hrad[i + 1]), 0.03 if i == 0 else 0.0, hw[i])
    # ears: lobes on the sides of the head
    for side in (-1.0, 1.0):
        add("capsule", ((side * 0.18, 0.74, -0.04), (side * 0.31, 0.80, -0.08), 0.045, 0.022), 0.04, 0.3)
    # arms held out along +-X (slight droop), elbow slightly back
    for side in (-1.0, 1.0):
        def m(p, side=side):
            return (side * p[0], p[1], p[2])

        shoulder, elbow, wrist = (0.26, 0.24, 0.0), (0.58, 0.22, -0.03), (0.86, 0.20, 0.0)
        add("sphere", (m(shoulder), 0.10), 0.07)
        add("capsule", (m(shoulder), m(elbow), 0.085, 0.065), 0.04)
        add("capsule", (m(elbow), m(wrist), 0.065, 0.050), 0.03)
        # hand: flattened palm, four spread fingers and a thumb toward +Z
        add("ellipsoid", (m((0.95, 0.20, 0.0)), (0.085, 0.04, 0.075)), 0.03, 0.5)
        # fingers fan out from the palm centre over +-45 degrees in the XZ plane
        for ang, length in ((45.0, 0.16), (15.0, 0.19), (-15.0, 0.185), (-45.0, 0.155)):
            t = np.radians(ang)
            u = np.array([np.cos(t), -0.06, np.sin(t)])
            a = (0.95 + 0.05 * u[0], 0.20 + 0.05 * u[1], 0.05 * u[2])
            b = (0.95 + length * u[0], 0.20 + length * u[1], length * u[2])
            add("capsule", (m(a), m(b), 0.020, 0.015), 0.012, 0.0)
        add("capsule", (m((0.92, 0.19, 0.06)), m((0.93, 0.175, 0.16)), 0.023, 0.018), 0.015, 0.0)  # thumb
    # legs: thigh, shin, foot with three toes
    for side in (-1.0, 1.0):
        def m(p, side=side):
            return (side * p[0], p[1], p[2])

        hip, knee, ankle = (0.15, -0.36, 0.0), (0.19, -0.66, 0.06), (0.19, -0.90, -0.01)
        add("capsule", (m(hip), m(knee), 0.13, 0.085), 0.08)
        add("capsule", (m(knee), m(ankle), 0.085, 0.065), 0.03)
        add("ellipsoid", (m((0.19, -0.95, 0.06)), (0.09, 0.05, 0.15)), 0.05, 0.6)
        for dx in (-0.045, 0.0, 0.045):
            add("capsule", (m((0.19 + dx, -0.96, 0.14)), m((0.19 + 1.8 * dx, -0.975, 0.25)), 0.028, 0.02), 0.015, 0.0)
    # tail: a tapered chain curling back and up
    tail = [(0.0, -0.36, -0.16), (0.0, -0.48, -0.40), (0.0, -0.52, -0.65), (0.0, -0.45, -0.88),
            (0.0, -0.30, -1.02), (0.0, -0.13, -1.06), (0.0, 0.00, -0.99)]
    trad = [0.12, 0.10, 0.08, 0.065, 0.05, 0.038, 0.028]
    tw = [1.0, 1.0, 1.0, 0.9, 0.7, 0.4]
    for i in range(len(tail) - 1):
        add("capsule", (tail[i], tail[i + 1], trad[i], trad[i + 1]), 0.08 if i == 0 else 0.02, tw[i])
    # a row of spines down the back (-Z side)
    spine = [(0.0, 0.50, -0.12), (0.0, 0.36, -0.20), (0.0, 0.20, -0.25), (0.0, 0.04, -0.26),
             (0.0, -0.12, -0.25), (0.0, -0.28, -0.24)]
    for i, (x, y, z) in enumerate(spine):
        length = 0.07 + 0.02 * np.sin(np.pi * i / (len(spine) - 1))
        add("capsule", ((x, y, z + 0.02), (x, y + 0.03, z - length), 0.035, 0.008), 0.025, 0.0)
    return P


def _union_at(parts: list[tuple], pts: np.ndarray) -> np.ndarray:
    """The field of the (uncarved) parts so far at points (n, 3)."""
    x, y, z = (np.ascontiguousarray(pts[:, i], dtype=np.float32) for i in range(3))
    field = np.full(len(pts), BIG, dtype=np.float32)
    weight = np.ones(len(pts), dtype=np.float32)
    for kind, prm, k, w, carve in parts:
        if not carve:
            _add_part(field, weight, _part_sdf(kind, prm, x, y, z), k, w, False)
    return field


def _surface_point(parts: list[tuple], inside, direction, offset: float) -> tuple:
    """Where the ray from `inside` along `direction` first leaves the parts so
    far, moved `offset` further out."""
    o = np.asarray(inside, dtype=np.float64)
    u = np.asarray(direction, dtype=np.float64)
    u /= np.linalg.norm(u)
    t = np.linspace(0.0, 0.5, 5001)
    f = _union_at(parts, o + t[:, None] * u)
    if f[0] >= 0 or not np.any(f > 0):
        raise RuntimeError(f"ray from {inside} does not cross the surface")
    i = int(np.argmax(f > 0))
    t0 = t[i - 1] + (t[i] - t[i - 1]) * f[i - 1] / (f[i - 1] - f[i])
    return tuple(float(v) for v in o + (t0 + offset) * u)


def _part_bbox(kind: str, prm) -> tuple[np.ndarray, np.ndarray]:
    if kind == "ellipsoid":
        c, r = np.array(prm[0]), np.array(prm[1])
        return c - r, c + r
    if kind == "sphere":
        c, r = np.array(prm[0]), prm[1]
        return c - r, c + r
    a, b, ra, rb = np.array(prm[0]), np.array(prm[1]), prm[2], prm[3]
    r = max(ra, rb)
    return np.minimum(a, b) - r, np.maximum(a, b) + r


def _part_sdf(kind: str, prm, x, y, z):
    """Signed distance (approximate for ellipsoids / tapers) on broadcast axes."""
    f32 = np.float32
    if kind == "sphere":
        c, r = prm
        return np.sqrt((x - f32(c[0])) ** 2 + (y - f32(c[1])) ** 2 + (z - f32(c[2])) ** 2) - f32(r)
    if kind == "ellipsoid":
        c, r = prm
        px, py, pz = x - f32(c[0]), y - f32(c[1]), z - f32(c[2])
        rx, ry, rz = (f32(v) for v in r)
        k0 = np.sqrt((px / rx) ** 2 + (py / ry) ** 2 + (pz / rz) ** 2)
        k1 = np.sqrt((px / rx**2) ** 2 + (py / ry**2) ** 2 + (pz / rz**2) ** 2)
        return k0 * (k0 - f32(1.0)) / np.maximum(k1, f32(1e-12))
    a, b, ra, rb = prm
    a = np.asarray(a, dtype=np.float32)
    ba = np.asarray(b, dtype=np.float32) - a
    px, py, pz = x - a[0], y - a[1], z - a[2]
    t = np.clip((px * ba[0] + py * ba[1] + pz * ba[2]) / f32(ba @ ba), f32(0.0), f32(1.0))
    d = np.sqrt((px - t * ba[0]) ** 2 + (py - t * ba[1]) ** 2 + (pz - t * ba[2]) ** 2)
    return d - (f32(ra) + t * f32(rb - ra))


def _smin_plain(field: np.ndarray, d: np.ndarray, k: float) -> None:
    """field = smooth-min(field, d), in place; blend radius k (plain min if k == 0)."""
    if k <= 0:
        np.minimum(field, d, out=field)
        return
    k = np.float32(k)
    h = np.maximum(k - np.abs(field - d), np.float32(0.0)) / k
    np.minimum(field, d, out=field)
    field -= h * h * (k * np.float32(0.25))


def _add_part(field: np.ndarray, weight: np.ndarray, d: np.ndarray, k: float, w: float, carve: bool) -> None:
    """Blend one part (distance d) into field, in place.

    Union: field = smooth-min(field, d), and the scale weight moves toward w
    where the part is the nearer surface.  Carve: field = smooth-max(field, -d).
    """
    if carve:
        np.negative(field, out=field)
        _smin_plain(field, d, k)
        np.negative(field, out=field)
        return
    s = np.clip(np.float32(0.5) + (field - d) * np.float32(0.5 / WEIGHT_BLEND), np.float32(0.0), np.float32(1.0))
    weight += (np.float32(w) - weight) * s
    _smin_plain(field, d, k)


WEIGHT_BLEND = 0.04  # distance over which the bump strength fades between parts
SCALE_SIZE = 0.06  # spacing of the scale centres (~3% of the height)
SCALE_DEPTH = 0.008  # height of a scale above its grooves (0.4% of the height)
SCALE_GROOVE = 0.5 * SCALE_SIZE  # width of the rounded edge of a scale


def _hash01(i, j, k, salt: int):
    """Deterministic pseudo-random numbers in [0, 1) from integer cell coordinates."""
    with np.errstate(over="ignore"):
        h = (i.astype(np.uint32) * np.uint32(0x8DA6B343)) ^ (j.astype(np.uint32) * np.uint32(0xD8163841))
        h ^= k.astype(np.uint32) * np.uint32(0xCB1AB31F)
        h ^= np.uint32(salt * 0x9E3779B9 & 0xFFFFFFFF)
        h ^= h >> np.uint32(16)
        h *= np.uint32(0x7FEB352D)
        h ^= h >> np.uint32(15)
        h *= np.uint32(0x846CA68B)
        h ^= h >> np.uint32(16)
    return (h >> np.uint32(8)).astype(np.float32) * np.float32(1.0 / (1 << 24))


def _scales(x, y, z):
    """Scale pattern: a 3D cellular (Worley) field with one jittered feature
    point per cell; the surface is raised inside each cell and grooved along
    the cell borders, where the distances to the nearest two feature points
    (F1, F2) are equal.  Returns the displacement (negative = outward)."""
    inv = np.float32(1.0 / SCALE_SIZE)
    px, py, pz = x * inv, y * inv, z * inv
    cx, cy, cz = np.floor(px), np.floor(py), np.floor(pz)
    f1 = np.full(px.shape, np.inf, dtype=np.float32)
    f2 = np.full(px.shape, np.inf, dtype=np.float32)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            for dk in (-1, 0, 1):
                i, j, k = (cx + di).astype(np.int32), (cy + dj).astype(np.int32), (cz + dk).astype(np.int32)
                fx = i + np.float32(0.1) + np.float32(0.8) * _hash01(i, j, k, 1)
                fy = j + np.float32(0.1) + np.float32(0.8) * _hash01(i, j, k, 2)
                fz = k + np.float32(0.1) + np.float32(0.8) * _hash01(i, j, k, 3)
                d = np.sqrt((px - fx) ** 2 + (py - fy) ** 2 + (pz - fz) ** 2)
                f2 = np.minimum(f2, np.maximum(f1, d))
                f1 = np.minimum(f1, d)
    t = np.clip((f2 - f1) * np.float32(SCALE_SIZE / SCALE_GROOVE), np.float32(0.0), np.float32(1.0))
    shape = t * t * (np.float32(3.0) - np.float32(2.0) * t)  # 0 in a groove, 1 on a scale
    return np.float32(SCALE_DEPTH) * (np.float32(0.5) - shape)


def sample_field(resolution: int) -> tuple[np.ndarray, np.ndarray, float]:
    """The creature's signed distance field on a grid.

    Returns (field, origin, spacing), field of shape (nx, ny, nz), negative inside.
    """
    parts = creature_parts()
    lo = np.min([_part_bbox(kind, p)[0] for kind, p, *_ in parts], axis=0)
    hi = np.max([_part_bbox(kind, p)[1] for kind, p, *_ in parts], axis=0)
    pad = 0.05
    lo, hi = lo - pad, hi + pad
    h = float((hi - lo).max() / resolution)
    n = np.ceil((hi - lo) / h).astype(int) + 1
    axes = [(lo[i] + h * np.arange(n[i])).astype(np.float32) for i in range(3)]
    field = np.full(tuple(n), BIG, dtype=np.float32)
    weight = np.ones(tuple(n), dtype=np.float32)  # scale strength per grid point
    # A part farther than `margin` from a grid point cannot change the zero
    # set there (smooth-min equals min once the two values differ by > k), so
    # each part is evaluated only on its bounding box grown by a margin.
    band = 3.0 * h + 2.0 * SCALE_DEPTH
    for kind, prm, k, w, carve in parts:
        blo, bhi = _part_bbox(kind, prm)
        m = k + band + 0.02
        i0 = np.maximum(np.floor((blo - m - lo) / h).astype(int), 0)
        i1 = np.minimum(np.ceil((bhi + m - lo) / h).astype(int) + 1, n)
        sl = tuple(slice(i0[i], i1[i]) for i in range(3))
        x = axes[0][sl[0], None, None]
        y = axes[1][None, sl[1], None]
        z = axes[2][None, None, sl[2]]
        d = _part_sdf(kind, prm, x, y, z)
        _add_part(field[sl], weight[sl], d, k, w, carve)  # views: updated in place
    # add the scales only in the band around the surface (elsewhere they
    # cannot flip the sign); done in slabs to bound memory
    for i in range(0, n[0], 32):
        sub = field[i : i + 32]
        near = np.abs(sub) < band
        if not near.any():
            continue
        ii, jj, kk = np.nonzero(near)
        sub[near] += weight[i : i + 32][near] * _scales(axes[0][i + ii], axes[1][jj], axes[2][kk])
    # keep grid values off the iso-value so no mesh vertex lands on a grid
    # node (which would create zero-length edges / zero-area triangles)
    eps = np.float32(0.02 * h)
    tiny = np.abs(field) < eps
    field[tiny] = np.where(field[tiny] < 0, -eps, eps)
    return field, lo, h


# ---------------------------------------------------------------------------
# meshing and cleanup
# ---------------------------------------------------------------------------


def contour(field: np.ndarray, origin: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    import pyvista as pv

    grid = pv.ImageData(dimensions=field.shape, spacing=(h, h, h), origin=tuple(float(v) for v in origin))
    grid.point_data["sdf"] = field.ravel(order="F")  # VTK: x varies fastest
    surf = grid.contour([0.0], scalars="sdf", method="flying_edges", compute_scalars=False)
    surf = surf.triangulate()
    v = np.asarray(surf.points, dtype=np.float64)
    f = surf.regular_faces.astype(np.int64)
    return v, f


def clean(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge duplicate points, drop degenerate faces, keep the largest
    component, orient outward and compact the vertex list."""
    import scipy.sparse as sp
    from scipy.sparse.csgraph import connected_components

    # merge exactly coincident points (as they will be stored: float32)
    v32 = v.astype(np.float32)
    _, first, inverse = np.unique(v32, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    # keep the first occurrence's order for locality
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    f = rank[inverse[f]]
    v = v32[np.sort(first)].astype(np.float64)
    # degenerate faces: repeated index or zero area
    rep = (f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0])
    area2 = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    f = f[~rep & (area2 > 0)]
    # duplicate faces (same vertex set)
    _, keep = np.unique(np.sort(f, axis=1), axis=0, return_index=True)
    f = f[np.sort(keep)]
    # largest connected component (by face count)
    nv = len(v)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]]])
    adj = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(nv, nv))
    ncomp, label = connected_components(adj, directed=False)
    if ncomp > 1:
        counts = np.bincount(label[f[:, 0]], minlength=ncomp)
        f = f[label[f[:, 0]] == np.argmax(counts)]
    # compact
    used = np.zeros(nv, dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    v, f = v[used], remap[f]
    # outward orientation: positive signed volume
    vol = np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6.0
    if vol < 0:
        f = f[:, ::-1].copy()
    return v, f


# ---------------------------------------------------------------------------
# output
# ---------------------------------------------------------------------------


def write_ply(path: str, v: np.ndarray, f: np.ndarray, comment: str = "") -> None:
    """Binary little-endian PLY: float32 x, y, z and uchar-count int32 faces.
    Written to a temporary file next to ``path`` and moved into place."""
    header = ["ply", "format binary_little_endian 1.0"]
    if comment:
        header.append(f"comment {comment}")
    header += [
        f"element vertex {len(v)}",
        "property float x",
        "property float y",
        "property float z",
        f"element face {len(f)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    head = ("\n".join(header) + "\n").encode("ascii")
    verts = np.ascontiguousarray(v, dtype="<f4")
    faces = np.empty(len(f), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    faces["n"] = 3
    faces["idx"] = f
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".creature-", suffix=".ply.tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(head)
            fh.write(verts.tobytes())
            fh.write(faces.tobytes())
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def check(path: str) -> bool:
    """Read the file back and print its vital statistics; True if all is well."""
    import trimesh

    m = trimesh.load(path, process=False)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    n_edges = len(np.unique(edges, axis=0))
    euler = len(v) - n_edges + len(f)
    ncomp = len(m.split(only_watertight=False))
    lo, hi = v.min(axis=0), v.max(axis=0)
    e = v[edges[:, 1]] - v[edges[:, 0]]
    elen = np.linalg.norm(e, axis=1)
    area = m.area_faces
    print(f"vertices            {len(v)}")
    print(f"faces               {len(f)}")
    print(f"file size           {os.path.getsize(path) / 1e6:.2f} MB")
    print(f"watertight          {m.is_watertight}")
    print(f"winding consistent  {m.is_winding_consistent}")
    print(f"volume              {m.volume:.4f}")
    print(f"components          {ncomp}")
    print(f"euler characteristic {euler} (genus {(2 - euler) / 2:g})")
    print(f"bbox min            {np.array2string(lo, precision=3)}")
    print(f"bbox max            {np.array2string(hi, precision=3)}")
    print(f"edge length         min {elen.min():.2e}  mean {elen.mean():.2e}  max {elen.max():.2e}")
    print(f"min face area       {area.min():.2e}")
    ok = m.is_watertight and m.is_winding_consistent and m.volume > 0 and ncomp == 1 and area.min() > 0
    print(f"checks              {'OK' if ok else 'FAILED'}")
    return ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=DEFAULT_OUT, help="output PLY path (default: data/creature.ply)")
    ap.add_argument(
        "--resolution",
        type=int,
        default=DEFAULT_RESOLUTION,
        help=(
            f"grid cells along the longest bounding-box side (default {DEFAULT_RESOLUTION}, ~100K vertices); "
            "below ~200 the fingers are under-resolved and the surface may gain handles"
        ),
    )
    args = ap.parse_args(argv)
    if args.resolution < 16:
        ap.error("--resolution must be at least 16")

    t0 = time.perf_counter()
    field, origin, h = sample_field(args.resolution)
    t1 = time.perf_counter()
    v, f = contour(field, origin, h)
    del field
    t2 = time.perf_counter()
    v, f = clean(v, f)
    write_ply(args.out, v, f, comment=f"hybridedit default creature, make_default.py --resolution {args.resolution}")
    t3 = time.perf_counter()
    print(f"wrote {args.out}")
    print(f"grid spacing        {h:.5f}")
    print(f"time                {t3 - t0:.1f} s (field {t1 - t0:.1f}, contour {t2 - t1:.1f}, clean+write {t3 - t2:.1f})")
    return 0 if check(args.out) else 1


if __name__ == "__main__":
    sys.exit(main())

"""Fast mean value coordinates: exact near each point, a quadrature farther away.

The same coordinates as :mod:`hybridedit.binding.mvc_exact` (within about 1e-5 of a
row's magnitude at the default ratio), every face still visited for every
point but the far ones by a cheap vectorized quadrature. The hierarchical
kernel (:mod:`hybridedit.binding.mvc_tree`) uses it for rows it cannot decide, and
binding uses it for rows kept whole.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.core import cgutils
from numba.extending import intrinsic

from .mvc_cage import CageData, morton_order, prepare_cage
from .mvc_faces import compile_exact_face_lanes, exact_face, near_block, tolerances
from .truncation import truncate_row_sparse

__all__ = ["FastCageData", "FastPlan", "prepare_fast_cage", "plan_fast", "fast_scratch",
           "compute_fast_sorted", "compute_fast_truncated", "check_far_ratio", "LANES",
           "FAR_RATIO"]

exact_face_lanes = compile_exact_face_lanes()


# ---------------------------------------------------------------------------
# Fast method: exact near field, quadrature far field
# ---------------------------------------------------------------------------
# With phi_i the hat function of cage vertex i, the weight that face f gives
# vertex i (the kernel's w_i / d_i above) is the surface integral
#     W_i^f(x) = integral over f of phi_i(p) * n_f . (p - x) / |p - x|^4 dA,
# n_f the unit normal of the face's vertex order; n_f . (p - x) = off_f - n_f . x
# is constant over the face. For a face far from x compared with its size the
# integrand is smooth and a quadrature is accurate: the fast method replaces
# g(p) = 1 / |p - x|^4 by its quadratic interpolant through the face's three
# vertices and three edge midpoints, which integrates exactly against phi_i:
#     W_i^f ~= A_f (off_f - n_f . x) / 60 * (3 g_i - 4 g_jk + 8 T - S),
# S the sum of g over the face's vertices, T over its edge midpoints and g_jk
# the value at the midpoint of the edge opposite i. The values of g are
# computed once per point per cage vertex and per edge; no angle is needed.
# Its relative error per face is of order (r_f / distance)^3.
#
# Points are sorted along a Morton curve and processed in batches of LANES
# consecutive points ("lanes"); the far-field loops are vectorized over the
# lanes. Faces are grouped in blocks of FAST_BLOCK consecutive faces (Morton
# order). A face f is "near" a batch when some point of the batch is closer
# than ``far_ratio * r_f`` to its centroid, r_f the largest distance from the
# centroid to the face's vertices (tested per block first, then per face).
# Near faces are evaluated exactly (vectorized over the lanes, with the
# exact kernel's scalar path and special cases for points within NEAR_EPS of
# a near face's plane, i.e. on or next to the cage), all others by the
# quadrature. The decisions depend on the batch, hence (within the
# quadrature's error) on the other points of the call, never on how a call
# is chunked.
#
# The far field is evaluated in single precision, relative to the batch's
# centre and with coordinates scaled to the cage's diagonal: it needs a
# relative accuracy of about 1e-7, far below the quadrature's own error, and
# single precision halves the data its loops move and doubles their width.
# Near weights, sums and rows are double precision.
#
# The quadrature breaks the exact linear precision of the coordinates a
# little (sum_i W_i (p_i - x) = r != 0, |r| about 1e-6 of the row's scale).
# With ``correct`` it is restored per point by adding mu_i * b . (p_i - x) to
# the weights, mu_i = |far-field weight of i|, where the 3-vector b solves
# sum_i mu_i (p_i - x)(p_i - x)^T b = -r; rows then reproduce linear
# functions to rounding, as the exact ones do. Binding applies it when the
# rows are kept whole (truncation 0); truncated rows skip it (it costs about
# 20% and changes rows by ~1e-5 of their magnitude, far below what the
# truncation drops).

#: Points per batch of the fast kernel (the length of its vectorized loops).
LANES = 32
#: Faces per block (the unit of the first near/far test).
FAST_BLOCK = 32
#: Default ratio of distance to face size beyond which a face is integrated
#: by quadrature (see the section comment).
FAR_RATIO = 3.0
#: A linear precision correction that would change a row by more than this
#: fraction of its magnitude is not applied (an ill-conditioned far field).
MAX_CORRECTION = 1e-2


@dataclass(frozen=True)
class FastCageData:
    """Cage arrays of the fast method (built by :func:`prepare_fast_cage`).

    Coordinates are ``(p - origin) / unit``, ``origin`` the centre of the
    cage's bounding box and ``unit`` its diagonal (mean value coordinates
    are invariant under such a map). Cage vertices are renumbered internally
    by first use in the face order, so that the data of a tile of faces is
    close in memory; ``perm[k]`` is the caller's index of internal vertex
    ``k``.

    Attributes
    ----------
    exact : CageData
        The exact kernel's data in these coordinates (faces in kernel order).
    origin : (3,) float64
    unit : float
    perm, inv_perm : (c,) int64
    verts_t : (3, c) float64
        Vertices in internal order.
    mids_t : (3, e) float64
        Edge midpoints (edges as in ``exact.edges``).
    qcoef : (4, f) float64
        ``A_f (off_f - n_f . x) / 60 = q0 + q1 x + q2 y + q3 z``.
    far_idx : (f, 6) uint32
        Internal vertex ids, then the edge ids of the edges 01, 12, 20.
    face_geo : (4, f) float64
        Centroid and radius (largest centroid-vertex distance) of each face.
    tile_verts, tile_edges, tile_blocks : (t + 1,) int64
        Vertices, edges and blocks first used by each tile of ``exact.face_tiles``.
    block_faces : (nb + 1,) int64
    block_geo : (5, nb) float64
        Centre, spread (largest centre-to-face-centroid distance) and size
        (largest face radius) of each block.
    """

    exact: CageData
    origin: np.ndarray
    unit: float
    perm: np.ndarray
    inv_perm: np.ndarray
    verts_t: np.ndarray
    mids_t: np.ndarray
    qcoef: np.ndarray
    far_idx: np.ndarray
    face_geo: np.ndarray
    tile_verts: np.ndarray
    tile_edges: np.ndarray
    tile_blocks: np.ndarray
    block_faces: np.ndarray
    block_geo: np.ndarray

    @property
    def n_vertices(self) -> int:
        return self.exact.n_vertices

    @property
    def scale(self) -> float:
        return self.exact.scale


def prepare_fast_cage(cage_vertices: np.ndarray, cage_faces: np.ndarray) -> FastCageData:
    """Validate a cage and precompute the fast kernel's arrays (see :class:`FastCageData`)."""
    v = np.asarray(cage_vertices)
    origin = np.zeros(3)
    unit = 1.0
    if (v.ndim == 2 and v.shape[1] == 3 and v.shape[0] > 0 and np.issubdtype(v.dtype, np.number)
            and np.all(np.isfinite(v))):
        v = np.asarray(v, dtype=np.float64)
        origin = 0.5 * (v.min(axis=0) + v.max(axis=0))
        diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
        unit = diag if diag > 0 else 1.0
        v = (v - origin) / unit
    ex = prepare_cage(v, cage_faces)  # validates
    f = ex.faces
    nf = len(f)
    c = ex.n_vertices
    # Internal vertex order: by first use in the kernel's face order.
    used, first = np.unique(f.ravel(), return_index=True)
    by_use = np.argsort(first, kind="stable")
    perm = np.concatenate([used[by_use], np.setdiff1d(np.arange(c), used)]).astype(np.int64)
    inv_perm = np.empty(c, dtype=np.int64)
    inv_perm[perm] = np.arange(c)
    first_face = np.sort(first) // 3
    tile_verts = np.searchsorted(first_face, ex.face_tiles, side="left").astype(np.int64)
    verts_t = np.ascontiguousarray(ex.vertices[perm].T)
    far_idx = np.concatenate([inv_perm[f], ex.face_idx[:, 3:].astype(np.int64)], axis=1)
    far_idx = np.ascontiguousarray(far_idx.astype(np.uint32))
    mids = 0.5 * (ex.vertices[ex.edges[:, 0]] + ex.vertices[ex.edges[:, 1]])
    mids_t = np.ascontiguousarray(mids.T)
    planes = ex.planes
    qcoef = np.empty((4, nf))
    qcoef[0] = planes[4] * planes[3] / 120.0  # planes[4] is twice the area
    qcoef[1:4] = -planes[4] * planes[0:3] / 120.0
    tri = ex.vertices[f]
    cen = tri.mean(axis=1)
    rad = np.linalg.norm(tri - cen[:, None, :], axis=2).max(axis=1)
    face_geo = np.ascontiguousarray(np.concatenate([cen.T, rad[None]]))
    # Blocks of FAST_BLOCK faces (a divisor of FACE_TILE: tiles hold whole blocks).
    block_faces = np.unique(np.append(np.arange(0, nf, FAST_BLOCK), nf)).astype(np.int64)
    nb = len(block_faces) - 1
    tile_blocks = np.searchsorted(block_faces, ex.face_tiles, side="left").astype(np.int64)
    bid = np.arange(nf) // FAST_BLOCK
    cnt = np.bincount(bid, minlength=nb).astype(np.float64)
    bc = np.stack([np.bincount(bid, weights=cen[:, k], minlength=nb) for k in range(3)]) / cnt
    spread = np.zeros(nb)
    np.maximum.at(spread, bid, np.linalg.norm(cen - bc.T[bid], axis=1))
    size = np.zeros(nb)
    np.maximum.at(size, bid, rad)
    block_geo = np.ascontiguousarray(np.concatenate([bc, spread[None], size[None]]))
    return FastCageData(
        exact=ex, origin=origin, unit=unit, perm=perm, inv_perm=inv_perm, verts_t=verts_t,
        mids_t=mids_t,
        qcoef=np.ascontiguousarray(qcoef), far_idx=far_idx, face_geo=face_geo,
        tile_verts=tile_verts, tile_edges=ex.edge_tiles, tile_blocks=tile_blocks,
        block_faces=block_faces, block_geo=block_geo,
    )


_F0 = np.float32(0.0)
#: Cap of 1 / |p - x|^4 in the far field (lengths in units of the cage's
#: diagonal; float32 overflows beyond 3.4e38). A face is far only from points
#: at least (far_ratio - 1) r_f from its vertices, so the cap is reached only
#: by faces smaller than about 1e-8 of the cage; it keeps inf * 0 out of the
#: sums.
_G_MAX = np.float32(1e30)


# The loops over a batch's lanes are written as explicit SIMD code (LLVM IR
# through numba's ``intrinsic``): numba cannot tell LLVM that the rows a loop
# reads and writes do not overlap, and the run-time overlap checks LLVM then
# inserts before every such loop cost more than the loop itself. Every
# operation is the plain IEEE one, in the order written (no fused
# multiply-add, no reassociation), as in the rest of this module.

#: float32 values per vector of the lane loops (LANES must be a multiple).
_VW = 16
assert LANES % _VW == 0


def _vec_helpers(builder):
    """The float32 vector type of the lane loops, a splat and a constant maker."""
    vt = ir.VectorType(ir.FloatType(), _VW)

    def splat(x):
        zero = ir.Constant(ir.IntType(32), 0)
        v = builder.insert_element(ir.Constant(vt, ir.Undefined), x, zero)
        mask = ir.Constant(ir.VectorType(ir.IntType(32), _VW), [0] * _VW)
        return builder.shuffle_vector(v, v, mask)

    def const(x):
        return ir.Constant(vt, [float(x)] * _VW)

    return vt, splat, const


def _row_data(context, builder, ty, value):
    ary = context.make_array(ty)(context, builder, value)
    return ary.data, cgutils.unpack_tuple(builder, ary.shape, 1)[0]


_F32_ROW = types.Array(types.float32, 1, "C")


@intrinsic
def far_rows(typingctx, Y0, Y1, Y2, G0, G1, G2, M01, M12, M20, A0, A1, A2, q0, q1, q2, q3):
    """A_k[l] += q(l) * (3 G_k[l] - 4 M_opp(k)[l] + 8 (M01 + M12 + M20)[l] - (G0 + G1 + G2)[l]).

    All rows float32 of the same length (a multiple of _VW), ``q(l) = q0 +
    q1 Y0[l] + q2 Y1[l] + q3 Y2[l]`` (float32 scalars): the quadrature weights
    of one face for every lane (see the section comment).
    """
    sig = types.void(*([_F32_ROW] * 12), types.float32, types.float32, types.float32,
                     types.float32)

    def codegen(context, builder, sig, args):
        vt, splat, const = _vec_helpers(builder)
        ptrs = []
        for k in range(12):
            data, n = _row_data(context, builder, sig.args[k], args[k])
            ptrs.append(data)
        q = [splat(a) for a in args[12:16]]
        c3, c4, c8 = const(3.0), const(4.0), const(8.0)
        fa, fm, fs = builder.fadd, builder.fmul, builder.fsub
        nvec = builder.udiv(n, ir.Constant(n.type, _VW))
        with cgutils.for_range(builder, nvec) as loop:
            off = builder.mul(loop.index, ir.Constant(n.type, _VW))
            vptr = [builder.bitcast(builder.gep(p, [off]), vt.as_pointer()) for p in ptrs]
            y0, y1, y2, g0, g1, g2, m01, m12, m20, a0, a1, a2 = [
                builder.load(p, align=4) for p in vptr]
            qq = fa(fa(fa(q[0], fm(q[1], y0)), fm(q[2], y1)), fm(q[3], y2))
            base = fs(fm(c8, fa(fa(m01, m12), m20)), fa(fa(g0, g1), g2))
            a0 = fa(a0, fm(qq, fa(fs(fm(c3, g0), fm(c4, m12)), base)))
            a1 = fa(a1, fm(qq, fa(fs(fm(c3, g1), fm(c4, m20)), base)))
            a2 = fa(a2, fm(qq, fa(fs(fm(c3, g2), fm(c4, m01)), base)))
            for p, v in zip(vptr[9:], (a0, a1, a2)):
                builder.store(v, p, align=4)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def g_row(typingctx, Y0, Y1, Y2, G, px, py, pz):
    """G[l] = min(1 / r2^2, _G_MAX), r2 = |(px, py, pz) - (Y0, Y1, Y2)[l]|^2 (float32 rows)."""
    sig = types.void(*([_F32_ROW] * 4), types.float32, types.float32, types.float32)

    def codegen(context, builder, sig, args):
        vt, splat, const = _vec_helpers(builder)
        ptrs = []
        for k in range(4):
            data, n = _row_data(context, builder, sig.args[k], args[k])
            ptrs.append(data)
        p = [splat(a) for a in args[4:7]]
        one, gmax = const(1.0), const(float(_G_MAX))
        fa, fm, fs = builder.fadd, builder.fmul, builder.fsub
        nvec = builder.udiv(n, ir.Constant(n.type, _VW))
        with cgutils.for_range(builder, nvec) as loop:
            off = builder.mul(loop.index, ir.Constant(n.type, _VW))
            vptr = [builder.bitcast(builder.gep(q, [off]), vt.as_pointer()) for q in ptrs]
            y0, y1, y2 = [builder.load(q, align=4) for q in vptr[:3]]
            dx = fs(p[0], y0)
            dy = fs(p[1], y1)
            dz = fs(p[2], y2)
            r2 = fa(fa(fm(dx, dx), fm(dy, dy)), fm(dz, dz))
            g = builder.fdiv(one, fm(r2, r2))
            # min(g, gmax) as numpy's min: g if g < gmax (nan stays nan).
            lt = builder.fcmp_ordered(">", g, gmax)
            builder.store(builder.select(lt, gmax, g), vptr[3], align=4)
        return context.get_dummy_value()

    return sig, codegen


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _g_pass(Y, cx, cy, cz, pts_t, g, v0, v1):
    """g[v, l] = 1 / |pts_t[:, v] - c - Y[:, l]|^4 (capped) for v in [v0, v1), every lane l.

    ``Y`` (3, lanes) float32 holds the lanes' points relative to ``c``.
    """
    Y0 = Y[0]
    Y1 = Y[1]
    Y2 = Y[2]
    for v in range(v0, v1):
        g_row(Y0, Y1, Y2, g[v], np.float32(pts_t[0, v] - cx), np.float32(pts_t[1, v] - cy),
               np.float32(pts_t[2, v] - cz))


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _far_face(Y, cx, cy, cz, qcoef, far_idx, gv, ge, accf, f):
    """Quadrature weights of face f for every lane, added to ``accf`` (float32)."""
    q1 = qcoef[1, f]
    q2 = qcoef[2, f]
    q3 = qcoef[3, f]
    q0 = np.float32(qcoef[0, f] + q1 * cx + q2 * cy + q3 * cz)
    i0 = far_idx[f, 0]
    i1 = far_idx[f, 1]
    i2 = far_idx[f, 2]
    far_rows(Y[0], Y[1], Y[2], gv[i0], gv[i1], gv[i2], ge[far_idx[f, 3]], ge[far_idx[f, 4]],
              ge[far_idx[f, 5]], accf[i0], accf[i1], accf[i2], q0, np.float32(q1),
              np.float32(q2), np.float32(q3))


@njit(cache=True, fastmath={"reassoc", "nsz"}, error_model="numpy")
def _finish_row(w, nacc, near_list, n_slots, verts_t, x0, x1, x2, correct, row):
    """``row`` = normalized far weights ``w`` plus near weights ``nacc[k]`` at ``near_list[k]``.

    With ``correct``, applies the linear precision correction of the section
    comment with mu_j = |w_j| (the far weights). ``row`` may be ``w``.
    Compiled with reassociation allowed, so that the sums vectorize: the
    result is deterministic but may differ in the last bits from the order
    written.
    """
    c = w.shape[0]
    vx = verts_t[0]
    vy = verts_t[1]
    vz = verts_t[2]
    s = 0.0
    sabs = 0.0
    for k in range(n_slots):
        s += nacc[k]
        sabs += abs(nacc[k])
    if not correct:
        for j in range(c):
            s += w[j]
        inv = 1.0 / s
        for j in range(c):
            row[j] = w[j] * inv
        for k in range(n_slots):
            row[near_list[k]] += nacc[k] * inv
        return
    rx = 0.0
    ry = 0.0
    rz = 0.0
    for k in range(n_slots):
        j = near_list[k]
        rx += nacc[k] * (vx[j] - x0)
        ry += nacc[k] * (vy[j] - x1)
        rz += nacc[k] * (vz[j] - x2)
    m0 = 0.0
    mx = 0.0
    my = 0.0
    mz = 0.0
    mxx = 0.0
    mxy = 0.0
    mxz = 0.0
    myy = 0.0
    myz = 0.0
    mzz = 0.0
    for j in range(c):
        wj = w[j]
        mu = abs(wj)
        ax = vx[j] - x0
        ay = vy[j] - x1
        az = vz[j] - x2
        s += wj
        sabs += mu
        rx += wj * ax
        ry += wj * ay
        rz += wj * az
        m0 += mu
        max_ = mu * ax
        may = mu * ay
        maz = mu * az
        mx += max_
        my += may
        mz += maz
        mxx += max_ * ax
        mxy += max_ * ay
        mxz += max_ * az
        myy += may * ay
        myz += may * az
        mzz += maz * az
    # Solve M b = -r (M symmetric positive semi-definite) by the adjugate.
    c00 = myy * mzz - myz * myz
    c01 = mxz * myz - mxy * mzz
    c02 = mxy * myz - mxz * myy
    c11 = mxx * mzz - mxz * mxz
    c12 = mxy * mxz - mxx * myz
    c22 = mxx * myy - mxy * mxy
    det = mxx * c00 + mxy * c01 + mxz * c02
    tr = mxx + myy + mzz
    bx = 0.0
    by = 0.0
    bz = 0.0
    if tr > 0.0 and det > 1e-12 * tr * tr * tr:
        inv = -1.0 / det
        bx = (c00 * rx + c01 * ry + c02 * rz) * inv
        by = (c01 * rx + c11 * ry + c12 * rz) * inv
        bz = (c02 * rx + c12 * ry + c22 * rz) * inv
        # sum_j |mu_j b . a_j| <= sqrt(sum_j mu_j) sqrt(b^T M b), b^T M b = -b . r
        btmb = -(bx * rx + by * ry + bz * rz)
        if not (m0 * btmb <= (MAX_CORRECTION * sabs) ** 2):
            bx = 0.0
            by = 0.0
            bz = 0.0
    inv = 1.0 / (s + bx * mx + by * my + bz * mz)
    for j in range(c):
        wj = w[j]
        row[j] = (wj + abs(wj) * (bx * (vx[j] - x0) + by * (vy[j] - x1) + bz * (vz[j] - x2))) * inv
    for k in range(n_slots):
        row[near_list[k]] += nacc[k] * inv


@njit(cache=True, fastmath=False, error_model="numpy")
def _fast_batch(X, x_center, x_radius, dest, cg, eps_v, eps_plane, eps_near, far_ratio, correct,
                sc, wk):
    """Rows of one batch of points (internal column order) into the scratch ``tf``.

    ``cg`` is :func:`_cage_arrays`, ``sc`` :func:`fast_scratch` (worker
    ``wk``'s part is used). On return ``tf[l]`` holds the row of every lane
    with ``dest[l] >= 0``. ``accf``, ``near_v`` and ``nacc`` must be zero on
    entry and are left zero; ``near_v[j]`` is 1 + the slot of vertex j in
    ``nacc`` once a near face uses it (``near_list`` lists them by slot).
    """
    (verts_t, mids_t, qcoef, far_idx, planes, face_geo, tile_verts, tile_edges, tile_blocks,
     block_faces, block_geo) = cg
    Y = sc[0][wk]
    gv = sc[1][wk]
    ge = sc[2][wk]
    accf = sc[3][wk]
    fq = sc[4][wk]
    far = sc[5][wk]
    nearf = sc[6][wk]
    snapped = sc[7][wk]
    near_v = sc[8][wk]
    near_list = sc[9][wk]
    nacc = sc[10][wk]
    tf = sc[11][wk]
    wl = sc[12][wk]
    scalar = sc[13][wk]
    c = verts_t.shape[1]
    nb = block_geo.shape[1]
    nl = X.shape[1]
    cx = x_center[0]
    cy = x_center[1]
    cz = x_center[2]
    for l in range(nl):
        Y[0, l] = np.float32(X[0, l] - cx)
        Y[1, l] = np.float32(X[1, l] - cy)
        Y[2, l] = np.float32(X[2, l] - cz)
    for k in range(nb):
        dx = block_geo[0, k] - cx
        dy = block_geo[1, k] - cy
        dz = block_geo[2, k] - cz
        thr = block_geo[3, k] + far_ratio * block_geo[4, k] + x_radius
        far[k] = dx * dx + dy * dy + dz * dz > thr * thr
    for l in range(nl):
        snapped[l] = dest[l] < 0  # inactive lanes skip the exact work
    n_slots = 0
    for t in range(tile_verts.shape[0] - 1):
        _g_pass(Y, cx, cy, cz, verts_t, gv, tile_verts[t], tile_verts[t + 1])
        _g_pass(Y, cx, cy, cz, mids_t, ge, tile_edges[t], tile_edges[t + 1])
        for k in range(tile_blocks[t], tile_blocks[t + 1]):
            f0 = block_faces[k]
            f1 = block_faces[k + 1]
            block_far = far[k]
            n_near = 0
            for f in range(f0, f1):
                is_near = False
                if not block_far:
                    dx = face_geo[0, f] - cx
                    dy = face_geo[1, f] - cy
                    dz = face_geo[2, f] - cz
                    thr = far_ratio * face_geo[3, f] + x_radius
                    # (not > rather than <=: with an infinite ratio a face
                    # of zero size gives nan, and is near)
                    is_near = not (dx * dx + dy * dy + dz * dz > thr * thr)
                nearf[f - f0] = is_near
                if is_near:
                    n_near += 1
                    for m in range(3):
                        v = far_idx[f, m]
                        if near_v[v] == 0:
                            near_list[n_slots] = v
                            n_slots += 1
                            near_v[v] = n_slots
                else:
                    _far_face(Y, cx, cy, cz, qcoef, far_idx, gv, ge, accf, f)
            if n_near == 0:
                continue
            # Lanes within eps_near of the plane of a near face take the
            # scalar path with the exact kernel's special cases; the others
            # get the near faces' weights from the vectorized loop below.
            for l in range(nl):
                scalar[l] = snapped[l]
                if snapped[l]:
                    continue
                x0 = X[0, l]
                x1 = X[1, l]
                x2 = X[2, l]
                for f in range(f0, f1):
                    if nearf[f - f0] and planes[4, f] > 0.0:
                        dist = (planes[0, f] * x0 + planes[1, f] * x1 + planes[2, f] * x2
                                - planes[3, f])
                        if abs(dist) <= eps_near:
                            scalar[l] = True
                            break
                if not scalar[l]:
                    continue
                # On the cage: the row is final (written to tf[l], which the
                # transposition below then leaves alone).
                if near_block(x0, x1, x2, verts_t, far_idx, planes, fq, eps_v, eps_plane,
                               eps_near, f0, f1, tf[l]):
                    snapped[l] = True
                    continue
                acc = nacc[l]
                for f in range(f0, f1):
                    if nearf[f - f0]:
                        exact_face(x0, x1, x2, verts_t, near_v[far_idx[f, 0]] - 1,
                                    near_v[far_idx[f, 1]] - 1, near_v[far_idx[f, 2]] - 1,
                                    far_idx[f, 0], far_idx[f, 1], far_idx[f, 2], fq[f], acc)
            for f in range(f0, f1):
                if not nearf[f - f0]:
                    continue
                i0 = far_idx[f, 0]
                i1 = far_idx[f, 1]
                i2 = far_idx[f, 2]
                exact_face_lanes(X, verts_t, planes, i0, i1, i2, f, wl)
                s0 = near_v[i0] - 1
                s1 = near_v[i1] - 1
                s2 = near_v[i2] - 1
                for l in range(nl):
                    if not scalar[l]:
                        nacc[l, s0] += wl[0, l]
                        nacc[l, s1] += wl[1, l]
                        nacc[l, s2] += wl[2, l]
    # Transpose the far weights to one row per lane, in blocks of accf that
    # stay in cache, and clear accf for the next batch.
    for j0 in range(0, c, 64):
        j1 = min(c, j0 + 64)
        for l in range(nl):
            if not snapped[l]:
                tfl = tf[l]
                for j in range(j0, j1):
                    tfl[j] = np.float64(accf[j, l])
        accf[j0:j1, :] = _F0
    for l in range(nl):
        if not snapped[l]:
            _finish_row(tf[l], nacc[l], near_list, n_slots, verts_t, X[0, l], X[1, l], X[2, l],
                        correct, tf[l])
        nacc[l, :n_slots] = 0.0
    for k in range(n_slots):
        near_v[near_list[k]] = 0



@njit(cache=True, fastmath=False, error_model="numpy", parallel=True)
def _fast_kernel(bx, bsph, dest, cg, eps_v, eps_plane, eps_near, far_ratio, correct, sc, dense,
                 out, truncation, min_kept_sum, col_of_slot, counts, cols, vals):
    """Rows of every batch; lane ``l`` of batch ``b`` goes to row ``r = dest[b, l]`` if >= 0.

    With ``dense``, the row (internal column order) is copied to ``out[r]``;
    otherwise it is truncated into ``counts[r]``, ``cols[r]``, ``vals[r]``
    (see :func:`hybridedit.binding.truncation.truncate_row_sparse`; columns are ``col_of_slot[j]``).
    """
    nbatch = bx.shape[0]
    n_workers = sc[0].shape[0]
    c = col_of_slot.shape[0]
    for wk in prange(n_workers):
        tf = sc[11][wk]
        surv = np.empty(c, dtype=np.int64)
        work = np.empty(c)
        idx = np.empty(c, dtype=np.int64)
        for b in range((wk * nbatch) // n_workers, ((wk + 1) * nbatch) // n_workers):
            _fast_batch(bx[b], bsph[b, 0:3], bsph[b, 3], dest[b], cg, eps_v, eps_plane,
                        eps_near, far_ratio, correct, sc, wk)
            for l in range(bx.shape[2]):
                r = dest[b, l]
                if r < 0:
                    continue
                if dense:
                    out[r, :] = tf[l]
                else:
                    counts[r] = truncate_row_sparse(tf[l], truncation, min_kept_sum, col_of_slot,
                                                    surv, work, idx, cols[r], vals[r])


def _cage_arrays(cage: FastCageData) -> tuple:
    """The cage arrays the fast kernels take, as one tuple."""
    return (cage.verts_t, cage.mids_t, cage.qcoef, cage.far_idx, cage.exact.planes, cage.face_geo,
            cage.tile_verts, cage.tile_edges, cage.tile_blocks, cage.block_faces, cage.block_geo)


def fast_scratch(cage: FastCageData, n_workers: int | None = None) -> tuple:
    """Work arrays of the fast kernels for ``n_workers`` parallel workers.

    Reusable across calls (the kernels leave the arrays that must start at
    zero zeroed); about ``40 * LANES * (vertices + edges)`` bytes per worker.
    """
    if n_workers is None:
        n_workers = 2 * numba.get_num_threads()
    w = max(1, int(n_workers))
    c = cage.n_vertices
    ne = cage.mids_t.shape[1]
    nf = cage.far_idx.shape[0]
    nb = cage.block_geo.shape[1]
    return (
        np.empty((w, 3, LANES), dtype=np.float32),  # 0 Y: lanes relative to the batch centre
        np.empty((w, c, LANES), dtype=np.float32),  # 1 gv: 1/|p - x|^4 at vertices
        np.empty((w, ne, LANES), dtype=np.float32),  # 2 ge: ... at edge midpoints
        np.zeros((w, c, LANES), dtype=np.float32),  # 3 accf: far weights
        np.empty((w, nf)),  # 4 fq: 1 / (2 Delta_f) of the exact kernel
        np.empty((w, nb), dtype=np.bool_),  # 5 far: block decisions
        np.empty((w, FAST_BLOCK), dtype=np.bool_),  # 6 nearf: face decisions in a block
        np.empty((w, LANES), dtype=np.bool_),  # 7 snapped (or inactive) lanes
        np.zeros((w, c), dtype=np.uint32),  # 8 near_v: slot + 1 of near vertices
        np.empty((w, c), dtype=np.int64),  # 9 near_list: near vertices by slot
        np.zeros((w, LANES, c)),  # 10 nacc: near weights by slot
        np.empty((w, LANES, c)),  # 11 tf: the rows
        np.empty((w, 3, LANES)),  # 12 wl: a near face's weights per lane
        np.empty((w, LANES), dtype=np.bool_),  # 13 scalar: lanes on the scalar path
    )


def fast_destinations(plan: "FastPlan", start: int, stop: int) -> tuple[int, int, np.ndarray]:
    """Batches ``k0:k1`` covering sorted positions [start, stop) and where their lanes go.

    ``dest[b, l]`` is the output row (``position - start``) of lane ``l`` of
    batch ``k0 + b``, or -1 outside [start, stop).
    """
    stop = min(stop, plan.n_points)
    k0 = start // LANES
    k1 = -(-stop // LANES)
    pos = np.arange(k0 * LANES, k1 * LANES, dtype=np.int64)
    dest = np.where((pos >= start) & (pos < stop), pos - start, -1).reshape(k1 - k0, LANES)
    return k0, k1, dest


def fast_tolerances(cage: FastCageData) -> tuple[float, float, float]:
    """The exact kernel's on-cage tolerances in the fast method's coordinates."""
    return tolerances(cage.scale)


@dataclass(frozen=True)
class FastPlan:
    """Points of one fast computation, sorted and cut into batches (:func:`plan_fast`).

    ``order[k]`` is the caller's index of the point at sorted position ``k``;
    batch ``b`` holds sorted positions ``b * LANES`` to ``b * LANES + LANES - 1``
    (the last batch is padded with copies of the last point).
    """

    order: np.ndarray
    bx: np.ndarray  # (nbatch, 3, LANES), in the cage's coordinates (FastCageData)
    bsph: np.ndarray  # (nbatch, 4): centre and radius of each batch

    @property
    def n_points(self) -> int:
        return int(self.order.shape[0])


def plan_fast(points: np.ndarray, cage: FastCageData) -> FastPlan:
    """Sort ``points`` (finite, (n, 3)) along a Morton curve and cut them into batches."""
    n = points.shape[0]
    if n == 0:
        return FastPlan(np.zeros(0, dtype=np.int64), np.zeros((0, 3, LANES)), np.zeros((0, 4)))
    order = morton_order(points).astype(np.int64)
    nbatch = -(-n // LANES)
    pos = np.minimum(np.arange(nbatch * LANES), n - 1)
    pb = ((points[order[pos]] - cage.origin) / cage.unit).reshape(nbatch, LANES, 3)
    center = 0.5 * (pb.min(axis=1) + pb.max(axis=1))
    radius = np.linalg.norm(pb - center[:, None, :], axis=2).max(axis=1)
    bx = np.ascontiguousarray(pb.transpose(0, 2, 1))
    bsph = np.ascontiguousarray(np.concatenate([center, radius[:, None]], axis=1))
    return FastPlan(order=order, bx=bx, bsph=bsph)


def compute_fast_sorted(plan: FastPlan, cage: FastCageData, start: int, stop: int,
                        out: np.ndarray, far_ratio: float = FAR_RATIO,
                        correct: bool = True, scratch: tuple | None = None) -> None:
    """Fast coordinates of sorted positions [start, stop) into ``out[0:stop - start]``.

    Columns are in the cage's internal vertex order (``cage.perm``). The row
    of a point does not depend on ``start`` and ``stop``. ``scratch`` is
    :func:`fast_scratch` (made here if not given). Internal helper shared
    with :mod:`hybridedit.binding.bind`.
    """
    if min(stop, plan.n_points) <= start:
        return
    _run_fast_kernel(plan, cage, start, stop, far_ratio, correct, scratch, out=out)


def _run_fast_kernel(plan, cage, start, stop, far_ratio, correct, scratch, out=None,
                     truncation=0.0, min_kept_sum=0.0, counts=None, cols=None, vals=None):
    """Run ``_fast_kernel`` on sorted positions [start, stop): dense rows into
    ``out`` if given, else truncated rows into ``counts`` / ``cols`` / ``vals``."""
    k0, k1, dest = fast_destinations(plan, start, stop)
    if scratch is None:
        scratch = fast_scratch(cage, min(k1 - k0, 2 * numba.get_num_threads()))
    eps_v, eps_plane, eps_near = fast_tolerances(cage)
    dense = out is not None
    if dense:
        counts = np.empty(0, dtype=np.int64)
        cols = np.empty((0, 1), dtype=np.int32)
        vals = np.empty((0, 1))
    else:
        out = np.empty((0, 1))
    _fast_kernel(plan.bx[k0:k1], plan.bsph[k0:k1], dest, _cage_arrays(cage), eps_v, eps_plane,
                 eps_near, float(far_ratio), bool(correct), scratch, dense, out, float(truncation),
                 float(min_kept_sum), cage.perm, counts, cols, vals)


def compute_fast_truncated(plan: "FastPlan", cage: "FastCageData", start: int, stop: int,
                           truncation: float, min_kept_sum: float, counts: np.ndarray,
                           cols: np.ndarray, vals: np.ndarray, far_ratio: float = FAR_RATIO,
                           scratch: tuple | None = None) -> None:
    """Fast coordinates of sorted positions [start, stop), truncated as they are made.

    Row ``r = position - start`` gets ``counts[r]`` entries in ``cols[r]``
    (caller's column indices, sorted) and ``vals[r]``, or ``counts[r] = -1``
    (not finite) or -2 (more entries kept than ``cols.shape[1]``). The rows
    are the uncorrected ones (see the section comment). Internal helper of
    :mod:`hybridedit.binding.bind`.
    """
    if min(stop, plan.n_points) <= start:
        return
    _run_fast_kernel(plan, cage, start, stop, far_ratio, False, scratch, truncation=truncation,
                     min_kept_sum=min_kept_sum, counts=counts, cols=cols, vals=vals)


def check_far_ratio(far_ratio: float) -> float:
    """``far_ratio`` as a float >= 1 (``inf`` allowed: everything exact), or ValueError."""
    try:
        r = float(far_ratio)
    except (TypeError, ValueError):
        raise ValueError(f"far_ratio must be a number >= 1, got {far_ratio!r}") from None
    if not r >= 1.0:
        raise ValueError(f"far_ratio must be a number >= 1, got {far_ratio!r}")
    return r

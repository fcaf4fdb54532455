"""Fast mean value coordinates: exact near each point, a quadrature farther away.

The same coordinates as :mod:`hybridedit.binding.mvc_exact` (within about 1e-5 of a
row's magnitude at the default ratio), every face still visited for every
point but the far ones by a cheap vectorized quadrature. The hierarchical
kernel (:mod:`hybridedit.binding.mvc_tree`) uses it for rows it cannot decide, and
binding uses it for rows kept whole.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange

from .lane_ir import VW, far_rows, g_row
from .mvc_faces import compile_exact_face_lanes, exact_face, near_block, tolerances
from .mvc_layout import FAST_BLOCK, LANES, FastCageData, FastPlan, fast_destinations
from .truncation import truncate_row_sparse

__all__ = ["fast_scratch", "compute_fast_sorted", "compute_fast_truncated", "check_far_ratio", "fast_tolerances",
           "on_cage_truncated", "FAR_RATIO", "MAX_CORRECTION"]

exact_face_lanes = compile_exact_face_lanes()

assert LANES % VW == 0  # (the lane loops run whole vectors)

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

#: Default ratio of distance to face size beyond which a face is integrated
#: by quadrature (see the section comment).
FAR_RATIO = 3.0
#: A linear precision correction that would change a row by more than this
#: fraction of its magnitude is not applied (an ill-conditioned far field).
MAX_CORRECTION = 1e-2


_F0 = np.float32(0.0)


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
    written (its steps are inlined, so they are compiled with it).
    """
    s = 0.0
    sabs = 0.0
    for k in range(n_slots):
        s += nacc[k]
        sabs += abs(nacc[k])
    if not correct:
        _finish_plain(w, nacc, near_list, n_slots, s, row)
        return
    rx, ry, rz = _near_residual(nacc, near_list, n_slots, verts_t, x0, x1, x2)
    s, sabs, rx, ry, rz, m0, mx, my, mz, mxx, mxy, mxz, myy, myz, mzz = _far_moments(
        w, verts_t, x0, x1, x2, s, sabs, rx, ry, rz)
    bx, by, bz = _correction(rx, ry, rz, m0, sabs, mxx, mxy, mxz, myy, myz, mzz)
    inv = 1.0 / (s + bx * mx + by * my + bz * mz)
    vx = verts_t[0]
    vy = verts_t[1]
    vz = verts_t[2]
    for j in range(w.shape[0]):
        wj = w[j]
        row[j] = (wj + abs(wj) * (bx * (vx[j] - x0) + by * (vy[j] - x1) + bz * (vz[j] - x2))) * inv
    for k in range(n_slots):
        row[near_list[k]] += nacc[k] * inv


@njit(cache=True, fastmath={"reassoc", "nsz"}, error_model="numpy", inline="always")
def _finish_plain(w, nacc, near_list, n_slots, s, row):
    """``row`` = (``w`` plus ``nacc[k]`` at ``near_list[k]``) / their sum, ``s`` the near weights' sum."""
    c = w.shape[0]
    for j in range(c):
        s += w[j]
    inv = 1.0 / s
    for j in range(c):
        row[j] = w[j] * inv
    for k in range(n_slots):
        row[near_list[k]] += nacc[k] * inv


@njit(cache=True, fastmath={"reassoc", "nsz"}, error_model="numpy", inline="always")
def _near_residual(nacc, near_list, n_slots, verts_t, x0, x1, x2):
    """sum_k nacc[k] (p_j - x), j = near_list[k]: the near weights' part of the residual r."""
    vx = verts_t[0]
    vy = verts_t[1]
    vz = verts_t[2]
    rx = 0.0
    ry = 0.0
    rz = 0.0
    for k in range(n_slots):
        j = near_list[k]
        rx += nacc[k] * (vx[j] - x0)
        ry += nacc[k] * (vy[j] - x1)
        rz += nacc[k] * (vz[j] - x2)
    return rx, ry, rz


@njit(cache=True, fastmath={"reassoc", "nsz"}, error_model="numpy", inline="always")
def _far_moments(w, verts_t, x0, x1, x2, s, sabs, rx, ry, rz):
    """The far weights added to the sums ``s``, ``sabs`` and the residual ``r``, and the moments
    of mu_j = |w_j| about x: m0 = sum mu_j, m = sum mu_j a_j, M = sum mu_j a_j a_j^T (a_j = p_j - x).

    Returns ``(s, sabs, rx, ry, rz, m0, mx, my, mz, mxx, mxy, mxz, myy, myz, mzz)``.
    """
    vx = verts_t[0]
    vy = verts_t[1]
    vz = verts_t[2]
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
    for j in range(w.shape[0]):
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
    return s, sabs, rx, ry, rz, m0, mx, my, mz, mxx, mxy, mxz, myy, myz, mzz


@njit(cache=True, fastmath={"reassoc", "nsz"}, error_model="numpy", inline="always")
def _correction(rx, ry, rz, m0, sabs, mxx, mxy, mxz, myy, myz, mzz):
    """b solving M b = -r (M symmetric positive semi-definite, by the adjugate), or 0 when M is
    singular or b would change the row by more than :data:`MAX_CORRECTION` of its magnitude."""
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
    return bx, by, bz


@njit(cache=True, fastmath=False, error_model="numpy")
def _fast_batch(X, x_center, x_radius, dest, cg, eps_v, eps_plane, eps_near, far_ratio, correct,
                sc, wk):
    """Rows of one batch of points (internal column order) into the scratch ``tf``.

    ``cg`` is :func:`_cage_arrays`, ``sc`` :func:`fast_scratch` (worker
    ``wk``'s part is used). On return ``tf[l]`` holds the row of every lane
    with ``dest[l] >= 0``. ``accf``, ``near_v`` and ``nacc`` must be zero on
    entry and are left zero; ``near_v[j]`` is 1 + the slot of vertex j in
    ``nacc`` once a near face uses it (``near_list`` lists them by slot).
    The steps are inlined (one compiled loop nest, as written).
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
    nl = X.shape[1]
    cx = x_center[0]
    cy = x_center[1]
    cz = x_center[2]
    _start_batch(X, cx, cy, cz, x_radius, far_ratio, block_geo, dest, Y, far, snapped)
    n_slots = 0
    for t in range(tile_verts.shape[0] - 1):
        _g_pass(Y, cx, cy, cz, verts_t, gv, tile_verts[t], tile_verts[t + 1])
        _g_pass(Y, cx, cy, cz, mids_t, ge, tile_edges[t], tile_edges[t + 1])
        for k in range(tile_blocks[t], tile_blocks[t + 1]):
            f0 = block_faces[k]
            f1 = block_faces[k + 1]
            n_near, n_slots = _block_faces(Y, cx, cy, cz, x_radius, far_ratio, far[k], face_geo, qcoef,
                                           far_idx, gv, ge, accf, nearf, near_v, near_list, n_slots, f0,
                                           f1)
            if n_near == 0:
                continue
            _scalar_lanes(X, verts_t, far_idx, planes, fq, eps_v, eps_plane, eps_near, nearf, near_v,
                          snapped, scalar, tf, nacc, f0, f1)
            _near_lanes(X, verts_t, far_idx, planes, nearf, near_v, scalar, wl, nacc, f0, f1)
    _far_to_rows(accf, snapped, tf, nl)
    for l in range(nl):
        if not snapped[l]:
            _finish_row(tf[l], nacc[l], near_list, n_slots, verts_t, X[0, l], X[1, l], X[2, l],
                        correct, tf[l])
        nacc[l, :n_slots] = 0.0
    for k in range(n_slots):
        near_v[near_list[k]] = 0


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _start_batch(X, cx, cy, cz, x_radius, far_ratio, block_geo, dest, Y, far, snapped):
    """The lanes relative to the batch centre c into ``Y`` (float32), the blocks of faces far
    from the whole batch into ``far``, and the inactive lanes (``dest < 0``) into ``snapped``."""
    nl = X.shape[1]
    for l in range(nl):
        Y[0, l] = np.float32(X[0, l] - cx)
        Y[1, l] = np.float32(X[1, l] - cy)
        Y[2, l] = np.float32(X[2, l] - cz)
    for k in range(block_geo.shape[1]):
        dx = block_geo[0, k] - cx
        dy = block_geo[1, k] - cy
        dz = block_geo[2, k] - cz
        thr = block_geo[3, k] + far_ratio * block_geo[4, k] + x_radius
        far[k] = dx * dx + dy * dy + dz * dz > thr * thr
    for l in range(nl):
        snapped[l] = dest[l] < 0  # inactive lanes skip the exact work


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _block_faces(Y, cx, cy, cz, x_radius, far_ratio, block_far, face_geo, qcoef, far_idx, gv, ge, accf,
                 nearf, near_v, near_list, n_slots, f0, f1):
    """Sort faces [f0, f1) into near (``nearf``, their vertices given slots in ``near_v`` /
    ``near_list``) and far (their quadrature added to ``accf`` now).

    Returns ``(n_near, n_slots)``: the near faces of the block and the slots now in use.
    """
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
    return n_near, n_slots


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _scalar_lanes(X, verts_t, far_idx, planes, fq, eps_v, eps_plane, eps_near, nearf, near_v, snapped,
                  scalar, tf, nacc, f0, f1):
    """The lanes within ``eps_near`` of the plane of a near face of [f0, f1) (``scalar``): the
    exact kernel's scalar path with its special cases. A lane on the cage gets its final row in
    ``tf[l]`` (and is ``snapped``); the others add the near faces' weights to ``nacc[l]``."""
    for l in range(X.shape[1]):
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
        # transposition of the far weights then leaves alone).
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


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _near_lanes(X, verts_t, far_idx, planes, nearf, near_v, scalar, wl, nacc, f0, f1):
    """The exact weights of the near faces of [f0, f1) for every lane not on the scalar path,
    vectorized over the lanes, added to ``nacc`` by slot."""
    nl = X.shape[1]
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


@njit(cache=True, fastmath=False, error_model="numpy", inline="always")
def _far_to_rows(accf, snapped, tf, nl):
    """Transpose the far weights ``accf`` (c, lanes) to one row per lane not snapped, in blocks
    that stay in cache, and clear ``accf`` for the next batch."""
    c = accf.shape[0]
    for j0 in range(0, c, 64):
        j1 = min(c, j0 + 64)
        for l in range(nl):
            if not snapped[l]:
                tfl = tf[l]
                for j in range(j0, j1):
                    tfl[j] = np.float64(accf[j, l])
        accf[j0:j1, :] = _F0


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


def fast_tolerances(cage: FastCageData) -> tuple[float, float, float]:
    """The exact kernel's on-cage tolerances in the fast method's coordinates."""
    return tolerances(cage.scale)


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


@njit(cache=True, fastmath=False, error_model="numpy")
def _on_cage_kernel(x, ptr, faces, verts_t, far_idx, planes, eps_v, eps_plane, eps_near, truncation, min_kept_sum,
                    col_of_slot, counts, cols, vals):  # pragma: no cover - compiled
    """Row i: point ``x[i]``'s row on the first of its candidate faces ``faces[ptr[i]:ptr[i + 1]]``
    (ascending) that it lies on, truncated; ``counts[i]`` is left as it was when it lies on none."""
    c = verts_t.shape[1]
    row = np.zeros(c)
    fq = np.empty(planes.shape[1])
    surv = np.empty(c, dtype=np.int64)
    work = np.empty(c)
    idx = np.empty(c, dtype=np.int64)
    for i in range(x.shape[0]):
        for q in range(ptr[i], ptr[i + 1]):
            f = faces[q]
            if near_block(x[i, 0], x[i, 1], x[i, 2], verts_t, far_idx, planes, fq, eps_v, eps_plane, eps_near, f,
                          f + 1, row):
                counts[i] = truncate_row_sparse(row, truncation, min_kept_sum, col_of_slot, surv, work, idx,
                                                cols[i], vals[i])
                break


def on_cage_truncated(points: np.ndarray, cage: FastCageData, truncation: float, min_kept_sum: float,
                      counts: np.ndarray, cols: np.ndarray, vals: np.ndarray) -> None:
    """The truncated rows of the (k, 3) ``points`` that lie on the cage's surface, as the flat
    kernel makes them, without its pass over every face.

    A point on a face (within the on-cage tolerances) has that face's row: the unit row of a
    vertex it sits on, else its barycentric coordinates (:func:`hybridedit.binding.mvc_faces.near_block`
    on the first face in the kernel's order that it lies on, as the flat kernel finds it). Only the
    faces whose bounding sphere holds the point are tried. Row i goes to ``counts[i]``,
    ``cols[i]``, ``vals[i]`` as in :func:`compute_fast_truncated`; ``counts[i]`` is left as it was
    (the caller sets it negative) for a point on no face. When the faces to try would be more than
    the flat kernel's pass visits (a cage with a face as large as the cage, a shell or a box:
    every face is near every point), nothing is done.
    """
    from scipy.spatial import cKDTree

    k = points.shape[0]
    if k == 0:
        return
    eps_v, eps_plane, eps_near = fast_tolerances(cage)
    x = np.ascontiguousarray((points - cage.origin) / cage.unit)  # (as plan_fast places them)
    geo = cage.face_geo
    tree = cKDTree(np.ascontiguousarray(geo[:3].T))
    reach = float(geo[3].max()) + eps_near
    nf = geo.shape[1]
    if int(tree.query_ball_point(x, reach, return_length=True).sum()) > nf * -(-k // LANES):
        return
    near = tree.query_ball_point(x, reach)
    lists = []
    for i in range(k):
        f = np.asarray(near[i], dtype=np.int64)
        d = np.linalg.norm(geo[:3, f].T - x[i], axis=1)
        lists.append(np.sort(f[d <= geo[3, f] + eps_near]))
    ptr = np.zeros(k + 1, dtype=np.int64)
    np.cumsum([len(f) for f in lists], out=ptr[1:])
    faces = np.concatenate(lists) if ptr[-1] else np.zeros(0, dtype=np.int64)
    _on_cage_kernel(x, ptr, faces, cage.verts_t, cage.far_idx, cage.exact.planes, eps_v, eps_plane, eps_near,
                    float(truncation), float(min_kept_sum), cage.perm, counts, cols, vals)


def check_far_ratio(far_ratio: float) -> float:
    """``far_ratio`` as a float >= 1 (``inf`` allowed: everything exact), or ValueError."""
    try:
        r = float(far_ratio)
    except (TypeError, ValueError):
        raise ValueError(f"far_ratio must be a number >= 1, got {far_ratio!r}") from None
    if not r >= 1.0:
        raise ValueError(f"far_ratio must be a number >= 1, got {far_ratio!r}")
    return r

"""Hierarchical truncated mean value coordinates: far cage regions in aggregate.

A truncated binding keeps a dozen coordinates per point; the thousands of
far cage vertices are all dropped. This kernel never computes them one by
one. With ``phi_j`` the hat function of cage vertex ``j``, the (un-normalized)
weight of vertex ``j`` at ``x`` is the integral over its star

    W_j(x) = integral of phi_j(p) n(p) . K(p - x) dA,   K(v) = v / |v|^4

(the form the quadrature of :mod:`hybridedit.binding.mvc_flat` integrates). A
bounding-volume hierarchy over the cage vertices (each with its star) is
walked per batch of ``LANES`` points. A node of centre ``C`` and radius ``r``
(a sphere holding the stars of its vertices) is *aggregated* when it is well
separated from the batch: ``r <= theta * (|C - c| - R)``, ``(c, R)`` the
batch's bounding sphere. Its vertices then count through three numbers per
point:

* the total ``sum_j W_j`` (for the normalization). It is
  ``integral of Phi(p) n . K(d + y) dA`` with ``Phi`` the sum of the node's
  hat functions, ``d = C - x`` and ``y = p - C``; its Taylor expansion in
  ``y`` to second order needs only the node's moments ``M0 = int Phi n``,
  ``M1 = int Phi n y^T`` and ``M2 = int Phi n y y^T`` (exact integrals over
  the triangles, summed up the tree with the parallel axis rule), with a
  relative error of order ``(r / |d|)^3``;
* the magnitude ``sum_j |W_j|`` (for the truncation budget). When the
  node is seen from one side (the cone of its vertices' normals, half-angle
  ``alpha``, and the cone of directions from the batch, half-angle
  ``asin((r + R) / |C - c|)``, never meet at 90 degrees) every ``W_j`` has
  the sign of the total and the magnitude is its absolute value. Otherwise
  it is estimated from the first-order weights ``a_j . (p_j - x) / |d|^4``
  (``a_j`` the vector area of vertex j's hat function) by Cauchy-Schwarz,
  ``sqrt(N sum_j (a_j . (p_j - x))^2)``, a quadratic form in ``x`` per node
  (about 15% above the truth for a node seen edge-on; a larger magnitude only
  makes the truncation keep more);
* a bound on each vertex, ``|W_j| <= A_j / 3 / (|d| - r)^3`` (``A_j`` the
  area of its star).

A node well separated from the batch's own size as well (``R <= LOCAL_RATIO * (|C - c| - r)``)
is not evaluated at every point: its total and magnitude are evaluated at ten points of the batch's
sphere (its centre, the six ends of its axes, three points between them), summed over all such
nodes, and the sums are interpolated by one quadratic at the batch's points (the remainder is of
order ``20 (R / |C - c|)^3`` of those nodes' share); its vertex bound is taken at the batch's sphere,
``A_j / 3 / (|C - c| - R - r)^3``. These numbers only decide which entries a row keeps and whether
the rule is shown to hold: a row's values come from its open vertices, rescaled to sum to 1.

The other leaves are *opened*: their vertices get their full weights from
all the faces of their stars, exactly for faces near the batch and by the
quadrature for the others, as in :mod:`hybridedit.binding.mvc_flat`. Each point's
row then holds the open vertices and, in aggregate, the mass ``F`` of the
others (which still counts in the normalization and the budget). The
truncation rule (:func:`hybridedit.binding.truncation.keep_row`) runs with ``F``
already dropped; if every kept entry is larger than the aggregated vertices'
bound, the result is the rule on the whole row up to the error of ``F``. A
row for which this cannot be shown (the aggregated mass exceeds the budget,
a kept entry is not above the bound, the safeguard would fire, the point is
on the cage's surface, or too many vertices were opened) is
reported as undecided; :func:`hybridedit.binding.bind.bind` then gives a point at a cage
vertex its unit row and a point on a cage face that face's row, tries the others again in
batches of near points only with a smaller ``theta``
(:func:`hybridedit.binding.mvc_layout.plan_groups`) and finally with the flat kernel (a pass
over every cage face: the rows sent there are what made the binding grow faster than the
shape, so a point next to a near face's plane is handled here, by the flat kernel's own rules
for that face, :func:`hybridedit.binding.mvc_faces.near_face_case`).

Cost: the open region of a batch and the aggregated nodes around it grow
like ``log c`` (a few hundred leaves and nodes), not like ``c``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .lane_ir import far_rows, g_row
from .mvc_faces import NEAR_DROPPED, NEAR_ON_CAGE, compile_exact_face_lanes, near_face_case, tolerances
from .mvc_layout import LANES, fast_destinations
from .tree_cage import TreeCage
from .truncation import TOO_WIDE, UNDECIDED, keep_row, store_kept

__all__ = ["compute_tree_truncated", "tree_scratch", "THETA", "TREE_FAR_RATIO", "MAX_OPEN"]

#: Largest ratio of a node's radius to its distance from a batch for which the node is aggregated.
#: 0.4 makes rows as close to the flat kernel's as 0.3 (the same reconstruction error) and binds
#: faster (the 690K armadillo in 4.5 s instead of 5.3); 0.5 is no faster. (A small cage gains
#: nothing: its first pass takes as long and leaves more rows to the second.)
THETA = 0.4
#: Ratio of distance to face size beyond which a face of the open leaves is integrated by the
#: quadrature (:mod:`hybridedit.binding.mvc_flat`, whose whole rows use 3). The exact faces near a
#: batch are most of this kernel's work: at 2 the 173K armadillo binds in 2.2 s instead of 2.8 on
#: one thread, and the quadrature's error on the armadillo's cage grows from 4e-6 to 4e-5 of a row's
#: magnitude at most, far below the 3% the truncation drops.
TREE_FAR_RATIO = 2.0
#: Most cage vertices a batch may open (more: its rows are undecided).
MAX_OPEN = 4096
#: Largest ratio of a batch's radius to an aggregated node's distance for which the node counts
#: through the batch's ten-point quadratic (see the module docstring) instead of at each point. A
#: node's ten evaluations then cost as much as three of the lanes' 32 (the sums are evaluated in
#: the same vector loop). The fit's remainder for a 1 / d^3 decay is at most about 20 (R / d)^3 of
#: those nodes' share, of the order of the nodes' own expansion at :data:`THETA`. At 0.2 the 11M
#: armadillo binds about 10% faster than with every node at every point, as accurately: a few rows
#: keep other entries (as a change of THETA from 0.4 to 0.3 moves), and the rows the looser
#: batch-wide bound leaves undecided go to the second pass.
LOCAL_RATIO = 0.2
_D = math.sqrt(0.5)
#: the ten points where the quadratic is fitted, on the unit sphere (two more, copies of the centre,
#: fill the vector loop's last step)
_STENCIL = np.array([[0.0, 1.0, -1.0, 0.0, 0.0, 0.0, 0.0, _D, _D, 0.0, 0.0, 0.0],
                     [0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0, _D, 0.0, _D, 0.0, 0.0],
                     [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, _D, _D, 0.0, 0.0]])

exact_face_lanes = compile_exact_face_lanes()


@njit(cache=True, error_model="numpy", inline="always")
def _node_total(mom, k, ux, uy, uz):
    """Second-order expansion of ``sum_j W_j`` of node k at ``x``, ``u = C - x``."""
    r2 = ux * ux + uy * uy + uz * uz
    i2 = 1.0 / r2
    i4 = i2 * i2
    i6 = i4 * i2
    i8 = i4 * i4
    t0 = (mom[k, 0] * ux + mom[k, 1] * uy + mom[k, 2] * uz) * i4
    m = mom[k]
    tr = m[3] + m[7] + m[11]
    uMu = (ux * (m[3] * ux + m[4] * uy + m[5] * uz) + uy * (m[6] * ux + m[7] * uy + m[8] * uz)
           + uz * (m[9] * ux + m[10] * uy + m[11] * uz))
    t1 = tr * i4 - 4.0 * uMu * i6
    wu = m[12] * ux + m[13] * uy + m[14] * uz
    cub = 0.0
    u = (ux, uy, uz)
    for a in range(3):
        o = 15 + 6 * a
        q = (m[o] * ux * ux + 2.0 * m[o + 1] * ux * uy + 2.0 * m[o + 2] * ux * uz
             + m[o + 3] * uy * uy + 2.0 * m[o + 4] * uy * uz + m[o + 5] * uz * uz)
        cub += u[a] * q
    t2 = -2.0 * wu * i6 + 12.0 * cub * i8
    return t0 + t1 + t2


@njit(cache=True, error_model="numpy", inline="always")
def _node_mass(aux, k, ux, uy, uz):
    """Estimate of ``sum_j |W_j|`` over node k at ``x`` (``u = C - x``) when signs mix.

    To first order ``W_j = a_j . (p_j - x) / |p_j - x|^4``; with ``|p_j - x|``
    taken as ``|u|``, Cauchy-Schwarz gives ``sum_j |a_j . (u + y_j)| <=
    sqrt(N sum_j (a_j . (u + y_j))^2)``, a quadratic form in ``u``. It
    overestimates by about 15% for values spread evenly between zero and
    their largest, as on a node seen edge-on.
    """
    m = aux[k]
    q = (m[1] * ux * ux + 2.0 * m[2] * ux * uy + 2.0 * m[3] * ux * uz + m[4] * uy * uy
         + 2.0 * m[5] * uy * uz + m[6] * uz * uz)
    q += 2.0 * (m[7] * ux + m[8] * uy + m[9] * uz) + m[10]
    r2 = ux * ux + uy * uy + uz * uz
    return math.sqrt(max(0.0, m[0] * q)) / (r2 * r2)


@njit(cache=True, error_model="numpy", fastmath={"nsz", "arcp", "contract"})
def _node_lanes(mom, aux, geo, k, X, coherent, fsig, fmag, bmax):
    """Add node k's aggregated total, magnitude and vertex bound for every lane."""
    cx = geo[k, 0]
    cy = geo[k, 1]
    cz = geo[k, 2]
    r = geo[k, 3]
    a3 = geo[k, 8] / 3.0
    X0 = X[0]
    X1 = X[1]
    X2 = X[2]
    for l in range(X0.shape[0]):
        ux = cx - X0[l]
        uy = cy - X1[l]
        uz = cz - X2[l]
        F = _node_total(mom, k, ux, uy, uz)
        fsig[l] += F
        aF = abs(F)
        mass = aF if coherent else max(aF, _node_mass(aux, k, ux, uy, uz))
        fmag[l] += mass
        dm = math.sqrt(ux * ux + uy * uy + uz * uz) - r
        bmax[l] = max(bmax[l], a3 / (dm * dm * dm))


@njit(cache=True, error_model="numpy", inline="always")
def _quadratic(S, h):
    """The coefficients of the quadratic through the values ``S`` at :data:`_STENCIL` scaled by
    ``h``: constant, gradient (3), the halved diagonal of the Hessian (3), its xy, xz, yz terms."""
    f0 = S[0]
    gx = (S[1] - S[2]) * (0.5 / h)
    gy = (S[3] - S[4]) * (0.5 / h)
    gz = (S[5] - S[6]) * (0.5 / h)
    ih2 = 1.0 / (h * h)
    hxx = (S[1] + S[2] - 2.0 * f0) * ih2
    hyy = (S[3] + S[4] - 2.0 * f0) * ih2
    hzz = (S[5] + S[6] - 2.0 * f0) * ih2
    a = h * _D
    ia2 = 1.0 / (a * a)
    hxy = (S[7] - f0 - a * (gx + gy)) * ia2 - 0.5 * (hxx + hyy)
    hxz = (S[8] - f0 - a * (gx + gz)) * ia2 - 0.5 * (hxx + hzz)
    hyz = (S[9] - f0 - a * (gy + gz)) * ia2 - 0.5 * (hyy + hzz)
    return f0, gx, gy, gz, 0.5 * hxx, 0.5 * hyy, 0.5 * hzz, hxy, hxz, hyz


@njit(cache=True, error_model="numpy", inline="always")
def _add_quadratic(S, h, X, cx, cy, cz, acc):
    """Add the quadratic through ``S`` (:func:`_quadratic`) at every lane of ``X`` to ``acc``."""
    c0, c1, c2, c3, c4, c5, c6, c7, c8, c9 = _quadratic(S, h)
    for l in range(X.shape[1]):
        yx = X[0, l] - cx
        yy = X[1, l] - cy
        yz = X[2, l] - cz
        acc[l] += (c0 + c1 * yx + c2 * yy + c3 * yz + c4 * yx * yx + c5 * yy * yy + c6 * yz * yz
                   + c7 * yx * yy + c8 * yx * yz + c9 * yy * yz)


def tree_scratch(tree: TreeCage, n_workers: int) -> tuple:
    """Work arrays of :func:`compute_tree_truncated` for ``n_workers`` workers."""
    w = max(1, int(n_workers))
    fast = tree.fast
    c = fast.n_vertices
    nf = fast.far_idx.shape[0]
    ne = fast.mids_t.shape[1]
    cap = min(c, MAX_OPEN)
    return (
        np.empty((w, tree.n_nodes), dtype=np.int64),  # 0 stack
        np.zeros((w, c), dtype=np.int64),  # 1 slot + 1 of open vertices
        np.empty((w, cap), dtype=np.int64),  # 2 open vertices by slot
        np.zeros((w, nf), dtype=np.bool_),  # 3 face marks
        np.empty((w, nf), dtype=np.int64),  # 4 open faces
        np.zeros((w, cap + 1, LANES), dtype=np.float32),  # 5 far weights by slot (+ a sink)
        np.zeros((w, LANES, cap)),  # 6 near weights by slot
        np.empty((w, 3, LANES), dtype=np.float32),  # 7 Y: lanes relative to the batch centre
        np.empty((w, 3, LANES)),  # 8 an exact face's weights per lane
        np.empty((w, 4, LANES)),  # 9 aggregated signed total, magnitude, bound; flags
        np.zeros((w, c), dtype=np.int64),  # 10 g row + 1 of each vertex
        np.zeros((w, ne), dtype=np.int64),  # 11 g row + 1 of each edge midpoint
        np.empty((w, 12 * cap + 6, LANES), dtype=np.float32),  # 12 g rows (6 spare)
        np.empty((w, 12 * cap), dtype=np.int64),  # 13 owner of each g row (edge e: -1 - e)
        np.empty((w, 6), dtype=np.int64),  # 14 a face's g rows
        np.empty((w, 6, _STENCIL.shape[1])),  # 15 sums of total, magnitude (+ bound sink); points
    )


@njit(cache=True, error_model="numpy")
def _tree_batch(X, xc, xr, dest, cg, tg, eps_near, eps_plane, far_ratio, theta, truncation, min_kept_sum,
                col_of, counts, cols, vals, sc, wk, row, surv, work, idx, colmap, drop):
    """Truncated rows of one batch into ``counts[r]``, ``cols[r]``, ``vals[r]``, r = dest[l].

    The steps are inlined; the loop over the open faces stays in this body (one kernel: as
    inlined steps of its own it ran 35% slower, bind "fast" on the 43K armadillo, one thread).
    """
    verts_t, mids_t, qcoef, far_idx, planes, face_geo = cg
    star_ptr, star_faces, order, lo, hi, left, right, geo, mom, aux = tg
    stack = sc[0][wk]
    slot_of = sc[1][wk]
    open_v = sc[2][wk]
    fmark = sc[3][wk]
    flist = sc[4][wk]
    accf = sc[5][wk]
    nacc = sc[6][wk]
    yg = sc[7][wk]
    wl = sc[8][wk]
    agg = sc[9][wk]
    vslot = sc[10][wk]
    eslot = sc[11][wk]
    gbuf = sc[12][wk]
    gown = sc[13][wk]
    gi = sc[14][wk]
    st = sc[15][wk]
    cap_g = gbuf.shape[0] - 6
    cx = xc[0]
    cy = xc[1]
    cz = xc[2]
    undecided = agg[3]
    _start_lanes(X, cx, cy, cz, dest, yg, agg)
    n_open, overflow = _walk(mom, aux, geo, order, lo, hi, left, right, X, cx, cy, cz, xr, theta, stack,
                             open_v, slot_of, agg, st)
    if overflow:
        for s in range(n_open):
            slot_of[open_v[s]] = 0
        for l in range(X.shape[1]):
            r = dest[l]
            if r >= 0:
                counts[r] = UNDECIDED
        return
    n_faces = _star_faces(open_v, n_open, star_ptr, star_faces, fmark, flist)
    Y0 = yg[0]
    Y1 = yg[1]
    Y2 = yg[2]
    sink = accf[open_v.shape[0]]
    nl = X.shape[1]
    n_g = 0
    for m in range(n_faces):
        f = flist[m]
        fmark[f] = False
        i0 = far_idx[f, 0]
        i1 = far_idx[f, 1]
        i2 = far_idx[f, 2]
        s0 = slot_of[i0] - 1
        s1 = slot_of[i1] - 1
        s2 = slot_of[i2] - 1
        dx = face_geo[0, f] - cx
        dy = face_geo[1, f] - cy
        dz = face_geo[2, f] - cz
        thr = far_ratio * face_geo[3, f] + xr
        if dx * dx + dy * dy + dz * dz > thr * thr:
            # Far: the quadrature of mvc_flat, g at the vertices and edge
            # midpoints (each computed once per batch while the cache has room).
            for k in range(3):
                v = far_idx[f, k]
                gs = vslot[v] - 1
                if gs < 0:
                    if n_g < cap_g:
                        gs = n_g
                        n_g += 1
                        vslot[v] = n_g
                        gown[gs] = v
                        g_row(Y0, Y1, Y2, gbuf[gs], np.float32(verts_t[0, v] - cx),
                              np.float32(verts_t[1, v] - cy), np.float32(verts_t[2, v] - cz))
                    else:
                        gs = cap_g + k
                        g_row(Y0, Y1, Y2, gbuf[gs], np.float32(verts_t[0, v] - cx),
                              np.float32(verts_t[1, v] - cy), np.float32(verts_t[2, v] - cz))
                gi[k] = gs
                e = far_idx[f, 3 + k]
                gs = eslot[e] - 1
                if gs < 0:
                    if n_g < cap_g:
                        gs = n_g
                        n_g += 1
                        eslot[e] = n_g
                        gown[gs] = -1 - e
                        g_row(Y0, Y1, Y2, gbuf[gs], np.float32(mids_t[0, e] - cx),
                              np.float32(mids_t[1, e] - cy), np.float32(mids_t[2, e] - cz))
                    else:
                        gs = cap_g + 3 + k
                        g_row(Y0, Y1, Y2, gbuf[gs], np.float32(mids_t[0, e] - cx),
                              np.float32(mids_t[1, e] - cy), np.float32(mids_t[2, e] - cz))
                gi[3 + k] = gs
            q1 = qcoef[1, f]
            q2 = qcoef[2, f]
            q3 = qcoef[3, f]
            q0 = np.float32(qcoef[0, f] + q1 * cx + q2 * cy + q3 * cz)
            far_rows(Y0, Y1, Y2, gbuf[gi[0]], gbuf[gi[1]], gbuf[gi[2]], gbuf[gi[3]], gbuf[gi[4]],
                     gbuf[gi[5]], accf[s0] if s0 >= 0 else sink, accf[s1] if s1 >= 0 else sink,
                     accf[s2] if s2 >= 0 else sink, q0, np.float32(q1), np.float32(q2),
                     np.float32(q3))
        else:
            # Near: exact. A point next to the face's plane takes the flat kernel's rules for it
            # (the face dropped, or evaluated as any other); a point on the cage goes to the flat
            # kernel, which writes its row.
            n_drop = 0
            if planes[4, f] > 0.0:
                for l in range(nl):
                    dist = (planes[0, f] * X[0, l] + planes[1, f] * X[1, l]
                            + planes[2, f] * X[2, l] - planes[3, f])
                    if abs(dist) <= eps_near:
                        case = near_face_case(X[0, l], X[1, l], X[2, l], verts_t, i0, i1, i2, planes[0, f],
                                              planes[1, f], planes[2, f], planes[4, f], dist, eps_plane)
                        if case == NEAR_ON_CAGE:
                            undecided[l] = 1.0
                        elif case == NEAR_DROPPED:
                            drop[l] = True
                            n_drop += 1
            exact_face_lanes(X, verts_t, planes, i0, i1, i2, f, wl)
            for l in range(nl):
                if undecided[l] == 0.0 and not drop[l]:
                    if s0 >= 0:
                        nacc[l, s0] += wl[0, l]
                    if s1 >= 0:
                        nacc[l, s1] += wl[1, l]
                    if s2 >= 0:
                        nacc[l, s2] += wl[2, l]
            if n_drop:
                drop[:] = False
    for m in range(n_g):
        o = gown[m]
        if o >= 0:
            vslot[o] = 0
        else:
            eslot[-1 - o] = 0
    for s in range(n_open):
        colmap[s] = col_of[open_v[s]]
    _store_rows(dest, agg, nacc, accf, n_open, truncation, min_kept_sum, counts, cols, vals, row, surv,
                work, idx, colmap)
    # Leave the scratch clean.
    for s in range(n_open):
        slot_of[open_v[s]] = 0
        for l in range(X.shape[1]):
            nacc[l, s] = 0.0
        accf[s, :] = np.float32(0.0)


@njit(cache=True, error_model="numpy", inline="always")
def _start_lanes(X, cx, cy, cz, dest, yg, agg):
    """The lanes relative to the batch centre c into ``yg`` (float32); the aggregates ``agg``
    (signed total, magnitude, bound, undecided flag) zeroed, inactive lanes undecided."""
    for l in range(X.shape[1]):
        yg[0, l] = np.float32(X[0, l] - cx)
        yg[1, l] = np.float32(X[1, l] - cy)
        yg[2, l] = np.float32(X[2, l] - cz)
        agg[0, l] = 0.0
        agg[1, l] = 0.0
        agg[2, l] = 0.0
        agg[3, l] = 1.0 if dest[l] < 0 else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _walk(mom, aux, geo, order, lo, hi, left, right, X, cx, cy, cz, xr, theta, stack, open_v, slot_of, agg, st):
    """Walk the hierarchy from the root: aggregate the nodes well separated from the batch (into
    ``agg``; the nodes far from it for its size through its ten-point quadratic, in ``st``), open
    the other leaves (their vertices into ``open_v``, 1 + slot into ``slot_of``).

    Returns ``(n_open, overflow)``: overflow when more than ``len(open_v)`` vertices would open.
    """
    fsig = agg[0]
    fmag = agg[1]
    bmax = agg[2]
    cap = open_v.shape[0]
    half_pi = 0.5 * math.pi
    n_open = 0
    overflow = False
    ssig = st[0]
    smag = st[1]
    unused = st[2]  # the ten points' own vertex bounds (the batch-wide bound is used)
    pts = st[3:6]
    for q in range(pts.shape[1]):
        ssig[q] = 0.0
        smag[q] = 0.0
        pts[0, q] = cx + xr * _STENCIL[0, q]
        pts[1, q] = cy + xr * _STENCIL[1, q]
        pts[2, q] = cz + xr * _STENCIL[2, q]
    n_local = 0
    blocal = 0.0
    stack[0] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        k = stack[sp]
        dx = geo[k, 0] - cx
        dy = geo[k, 1] - cy
        dz = geo[k, 2] - cz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        r = geo[k, 3]
        if r <= theta * (d - xr):
            beta = math.asin(min(1.0, (r + xr) / d))
            cs = (geo[k, 4] * dx + geo[k, 5] * dy + geo[k, 6] * dz) / d
            gamma = math.acos(min(1.0, max(-1.0, cs)))
            alpha = geo[k, 7]
            coherent = gamma + alpha + beta < half_pi or gamma - alpha - beta > half_pi
            if xr > 0.0 and xr <= LOCAL_RATIO * (d - r):
                n_local += 1
                _node_lanes(mom, aux, geo, k, pts, coherent, ssig, smag, unused)
                dm = d - xr - r
                blocal = max(blocal, geo[k, 8] / 3.0 / (dm * dm * dm))
            else:
                _node_lanes(mom, aux, geo, k, X, coherent, fsig, fmag, bmax)
        elif left[k] < 0:
            if n_open + hi[k] - lo[k] > cap:
                overflow = True
                break
            for t in range(lo[k], hi[k]):
                j = order[t]
                open_v[n_open] = j
                n_open += 1
                slot_of[j] = n_open
        else:
            stack[sp] = right[k]
            stack[sp + 1] = left[k]
            sp += 2
    if n_local and not overflow:
        _add_quadratic(ssig, xr, X, cx, cy, cz, fsig)
        _add_quadratic(smag, xr, X, cx, cy, cz, fmag)
        for l in range(X.shape[1]):
            bmax[l] = max(bmax[l], blocal)
    return n_open, overflow


@njit(cache=True, error_model="numpy", inline="always")
def _star_faces(open_v, n_open, star_ptr, star_faces, fmark, flist):
    """The faces of the open vertices' stars, each once, into ``flist`` (marked in ``fmark``);
    returns their count."""
    n_faces = 0
    for s in range(n_open):
        j = open_v[s]
        for q in range(star_ptr[j], star_ptr[j + 1]):
            f = star_faces[q]
            if not fmark[f]:
                fmark[f] = True
                flist[n_faces] = f
                n_faces += 1
    return n_faces


@njit(cache=True, error_model="numpy", inline="always")
def _store_rows(dest, agg, nacc, accf, n_open, truncation, min_kept_sum, counts, cols, vals, row, surv,
                work, idx, colmap):
    """Each decided lane's row (open vertices' weights, the aggregated mass counted as dropped)
    normalized and truncated into ``counts``, ``cols``, ``vals``; UNDECIDED where the rule on the
    partial row cannot be shown to be the rule on the whole row."""
    fsig = agg[0]
    fmag = agg[1]
    bmax = agg[2]
    undecided = agg[3]
    rw = row[:n_open]
    for l in range(dest.shape[0]):
        rr = dest[l]
        if rr < 0:
            continue
        if undecided[l] != 0.0:
            counts[rr] = UNDECIDED
            continue
        tot = fsig[l]
        for s in range(n_open):
            w = nacc[l, s] + np.float64(accf[s, l])
            rw[s] = w
            tot += w
        if not (abs(tot) > 0.0 and abs(tot) < np.inf):
            counts[rr] = UNDECIDED
            continue
        inv = 1.0 / tot
        for s in range(n_open):
            rw[s] *= inv
        ainv = abs(inv)
        bound = bmax[l] * ainv
        n_keep, scale = keep_row(rw, truncation, min_kept_sum, fmag[l] * ainv, surv, work, idx)
        if n_keep <= 0:
            counts[rr] = UNDECIDED
            continue
        ok = True
        for k in range(n_keep):
            if not (abs(work[k]) > bound):
                ok = False
                break
        if not ok:
            counts[rr] = UNDECIDED
            continue
        counts[rr] = store_kept(n_keep, scale, idx, work, colmap, cols[rr], vals[rr])


@njit(cache=True, error_model="numpy", parallel=True)
def _tree_kernel(bx, bsph, dest, cg, tg, eps_near, eps_plane, far_ratio, theta, truncation, min_kept_sum,
                 col_of, counts, cols, vals, sc):
    nbatch = bx.shape[0]
    n_workers = sc[0].shape[0]
    cap = sc[2].shape[1]
    for wk in prange(n_workers):
        row = np.empty(cap)
        surv = np.empty(cap, dtype=np.int64)
        work = np.empty(cap)
        idx = np.empty(cap, dtype=np.int64)
        colmap = np.empty(cap, dtype=np.int64)
        drop = np.zeros(bx.shape[2], dtype=np.bool_)  # lanes for which the current near face is dropped
        for b in range((wk * nbatch) // n_workers, ((wk + 1) * nbatch) // n_workers):
            _tree_batch(bx[b], bsph[b, 0:3], bsph[b, 3], dest[b], cg, tg, eps_near, eps_plane, far_ratio,
                        theta, truncation, min_kept_sum, col_of, counts, cols, vals, sc, wk,
                        row, surv, work, idx, colmap, drop)


def compute_tree_truncated(plan, tree: TreeCage, start: int, stop: int, truncation: float,
                           min_kept_sum: float, counts: np.ndarray, cols: np.ndarray,
                           vals: np.ndarray, far_ratio: float, scratch: tuple,
                           theta: float = THETA) -> None:
    """Truncated rows of sorted positions [start, stop) of a :class:`~hybridedit.binding.mvc_layout.FastPlan`.

    Row ``r = position - start`` gets ``counts[r]`` entries in ``cols[r]``
    (caller's column indices, sorted) and ``vals[r]``, or ``counts[r]`` =
    UNDECIDED (see the module docstring) or TOO_WIDE (more entries than
    ``cols.shape[1]``): such rows must be computed otherwise.
    """
    if min(stop, plan.n_points) <= start:
        return
    fast = tree.fast
    k0, k1, dest = fast_destinations(plan, start, stop)
    _, eps_plane, eps_near = tolerances(fast.scale)
    cg = (fast.verts_t, fast.mids_t, fast.qcoef, fast.far_idx, fast.exact.planes, fast.face_geo)
    tg = (tree.star_ptr, tree.star_faces, tree.order, tree.lo, tree.hi, tree.left, tree.right,
          tree.geo, tree.mom, tree.aux)
    _tree_kernel(plan.bx[k0:k1], plan.bsph[k0:k1], dest, cg, tg, eps_near, eps_plane, float(far_ratio),
                 float(theta), float(truncation), float(min_kept_sum), fast.perm, counts, cols,
                 vals, scratch)


assert TOO_WIDE < 0 and UNDECIDED < 0

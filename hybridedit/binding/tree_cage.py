"""The hierarchy over a cage's vertices that the tree kernel (:mod:`hybridedit.binding.mvc_tree`) walks.

:func:`prepare_tree_cage` splits the vertices of a prepared fast cage at the median of their
longest axis down to leaves of :data:`LEAF_SIZE` vertices and gives every node what the kernel
needs to count its vertices in aggregate (see the module docstring of
:mod:`hybridedit.binding.mvc_tree`): a sphere holding the stars of its vertices, the cone of
their normals, the moments of their hat functions about the sphere's centre and the second
moments of their first-order weights (:class:`TreeCage`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .mvc_layout import FastCageData

__all__ = ["LEAF_SIZE", "N_MOM", "TreeCage", "prepare_tree_cage"]

#: Vertices per leaf of the hierarchy.
LEAF_SIZE = 2
#: Node moments: M0 (3), M1 (9, row-major: a then b), w = 2 v1 + v2 (3)
#: with v1_c = sum_a M2[a, a, c], v2_a = sum_b M2[a, b, b], and the
#: symmetric M2[a] (6 each: xx xy xz yy yz zz).
N_MOM = 33


@dataclass(frozen=True)
class TreeCage:
    """The hierarchy over a fast cage's vertices (built by :func:`prepare_tree_cage`).

    Vertex ids are the fast cage's internal ones (``fast.perm``).

    Attributes
    ----------
    fast : FastCageData
    star_ptr, star_faces : (c + 1,), (3 f,) int64
        Faces (kernel order) around each vertex.
    order : (c,) int64
        Vertices in tree order: node ``k`` holds ``order[lo[k]:hi[k]]``.
    lo, hi, left, right : (nn,) int64
        Node ranges and children (``left = -1`` for a leaf). Node 0 is the root.
    geo : (nn, 9) float64
        Centre, radius, unit mean normal, normal cone half-angle and the
        largest star area of the node's vertices.
    mom : (nn, N_MOM) float64
        Moments about the centre (see ``N_MOM``).
    aux : (nn, 11) float64
        Vertex count, then with ``a_j`` the vector area of vertex j's hat
        function and ``y_j`` its position from the centre: ``sum a a^T``
        (xx xy xz yy yz zz), ``sum (a . y) a`` and ``sum (a . y)^2``.
    """

    fast: FastCageData
    star_ptr: np.ndarray
    star_faces: np.ndarray
    order: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    left: np.ndarray
    right: np.ndarray
    geo: np.ndarray
    mom: np.ndarray
    aux: np.ndarray

    @property
    def n_nodes(self) -> int:
        return int(self.lo.shape[0])


@njit(cache=True, error_model="numpy")
def _build_nodes(pos, leaf_size):
    """Median split on the longest axis; returns (order, lo, hi, left, right)."""
    c = pos.shape[0]
    order = np.arange(c)
    cap = 4 * (c // max(1, leaf_size) + 2) + 1  # leaves hold more than leaf_size / 2
    lo = np.empty(cap, dtype=np.int64)
    hi = np.empty(cap, dtype=np.int64)
    left = np.full(cap, -1, dtype=np.int64)
    right = np.full(cap, -1, dtype=np.int64)
    lo[0] = 0
    hi[0] = c
    nn = 1
    stack = np.empty(cap, dtype=np.int64)
    stack[0] = 0
    sp = 1
    while sp > 0:
        sp -= 1
        k = stack[sp]
        a = lo[k]
        b = hi[k]
        if b - a <= leaf_size:
            continue
        mn = np.full(3, np.inf)
        mx = np.full(3, -np.inf)
        for t in range(a, b):
            for d in range(3):
                v = pos[order[t], d]
                mn[d] = min(mn[d], v)
                mx[d] = max(mx[d], v)
        ax = 0
        for d in range(1, 3):
            if mx[d] - mn[d] > mx[ax] - mn[ax]:
                ax = d
        sub = order[a:b].copy()
        srt = np.argsort(pos[sub, ax], kind="mergesort")
        for t in range(b - a):
            order[a + t] = sub[srt[t]]
        m = (a + b) // 2
        left[k] = nn
        right[k] = nn + 1
        lo[nn] = a
        hi[nn] = m
        lo[nn + 1] = m
        hi[nn + 1] = b
        stack[sp] = nn
        stack[sp + 1] = nn + 1
        sp += 2
        nn += 2
    return order, lo[:nn], hi[:nn], left[:nn], right[:nn]


@njit(cache=True, error_model="numpy", inline="always")
def _shift_add(dst, src, sx, sy, sz):
    """dst += moments ``src`` (a 39-vector: M0, M1 (9), M2 (27)) moved by s = C_old - C_new."""
    s = (sx, sy, sz)
    for a in range(3):
        dst[a] += src[a]
    for a in range(3):
        for b in range(3):
            dst[3 + 3 * a + b] += src[3 + 3 * a + b] + src[a] * s[b]
    for a in range(3):
        for b in range(3):
            for cc in range(3):
                dst[12 + 9 * a + 3 * b + cc] += (src[12 + 9 * a + 3 * b + cc]
                                                 + src[3 + 3 * a + b] * s[cc]
                                                 + src[3 + 3 * a + cc] * s[b]
                                                 + src[a] * s[b] * s[cc])


@njit(cache=True, error_model="numpy", inline="always")
def _unit(x, y, z):
    """(x, y, z) scaled to length 1, and its length (a zero vector stays zero)."""
    n = math.sqrt(x * x + y * y + z * z)
    if n > 0.0:
        return x / n, y / n, z / n, n
    return x, y, z, n



@njit(cache=True, error_model="numpy")
def _node_data(verts, vmom, star_ptr, star_faces, faces, star_area, order, lo, hi, left, right):
    """Bottom-up geometry and moments of every node (children after parents in the arrays).

    Returns ``(geo, mom, aux)`` as in :class:`TreeCage`.
    """
    nn = lo.shape[0]
    geo = np.zeros((nn, 9))
    full = np.zeros((nn, 39))
    for k in range(nn - 1, -1, -1):
        if left[k] < 0:
            _leaf_node(verts, vmom, star_ptr, star_faces, faces, star_area, order, lo[k], hi[k], geo[k],
                       full[k])
        else:
            _inner_node(geo, full, k, left[k], right[k])
    return geo, _compact_moments(full), _weight_moments(verts, vmom, order, lo, hi, geo)


@njit(cache=True, error_model="numpy", inline="always")
def _leaf_node(verts, vmom, star_ptr, star_faces, faces, star_area, order, lo, hi, g, full):
    """Geometry ``g`` (9,) and moments ``full`` (39,) of the leaf holding ``order[lo:hi]``."""
    # Sphere around the vertices of the stars.
    mn = np.full(3, np.inf)
    mx = np.full(3, -np.inf)
    for t in range(lo, hi):
        j = order[t]
        for q in range(star_ptr[j], star_ptr[j + 1]):
            f = star_faces[q]
            for m in range(3):
                for d in range(3):
                    v = verts[faces[f, m], d]
                    mn[d] = min(mn[d], v)
                    mx[d] = max(mx[d], v)
    cx = 0.5 * (mn[0] + mx[0])
    cy = 0.5 * (mn[1] + mx[1])
    cz = 0.5 * (mn[2] + mx[2])
    r = 0.0
    amax = 0.0
    for t in range(lo, hi):
        j = order[t]
        amax = max(amax, star_area[j])
        for q in range(star_ptr[j], star_ptr[j + 1]):
            f = star_faces[q]
            for m in range(3):
                i = faces[f, m]
                dd = math.sqrt((verts[i, 0] - cx) ** 2 + (verts[i, 1] - cy) ** 2
                               + (verts[i, 2] - cz) ** 2)
                r = max(r, dd)
        _shift_add(full, vmom[j], verts[j, 0] - cx, verts[j, 1] - cy, verts[j, 2] - cz)
    # Cone of the vertices' normals (their hat functions' vector areas).
    nx = 0.0
    ny = 0.0
    nz = 0.0
    for t in range(lo, hi):
        j = order[t]
        nx += vmom[j, 0]
        ny += vmom[j, 1]
        nz += vmom[j, 2]
    nx, ny, nz, nl = _unit(nx, ny, nz)
    alpha = math.pi
    if nl > 0.0:
        alpha = 0.0
        for t in range(lo, hi):
            j = order[t]
            vl = math.sqrt(vmom[j, 0] ** 2 + vmom[j, 1] ** 2 + vmom[j, 2] ** 2)
            if vl > 0.0:
                cs = (nx * vmom[j, 0] + ny * vmom[j, 1] + nz * vmom[j, 2]) / vl
                alpha = max(alpha, math.acos(min(1.0, max(-1.0, cs))))
    _set_geo(g, cx, cy, cz, r, nx, ny, nz, alpha, amax)


@njit(cache=True, error_model="numpy", inline="always")
def _inner_node(geo, full, k, a, b):
    """Geometry ``geo[k]`` and moments ``full[k]`` of node k from those of its children a and b."""
    mn = np.empty(3)
    mx = np.empty(3)
    for d in range(3):
        mn[d] = min(geo[a, d] - geo[a, 3], geo[b, d] - geo[b, 3])
        mx[d] = max(geo[a, d] + geo[a, 3], geo[b, d] + geo[b, 3])
    cx = 0.5 * (mn[0] + mx[0])
    cy = 0.5 * (mn[1] + mx[1])
    cz = 0.5 * (mn[2] + mx[2])
    r = 0.0
    for ch in (a, b):
        dd = math.sqrt((geo[ch, 0] - cx) ** 2 + (geo[ch, 1] - cy) ** 2
                       + (geo[ch, 2] - cz) ** 2)
        r = max(r, dd + geo[ch, 3])
        _shift_add(full[k], full[ch], geo[ch, 0] - cx, geo[ch, 1] - cy, geo[ch, 2] - cz)
    amax = max(geo[a, 8], geo[b, 8])
    nx, ny, nz, nl = _unit(full[k, 0], full[k, 1], full[k, 2])
    alpha = math.pi
    if nl > 0.0:
        alpha = 0.0
        for ch in (a, b):
            cs = nx * geo[ch, 4] + ny * geo[ch, 5] + nz * geo[ch, 6]
            alpha = max(alpha, math.acos(min(1.0, max(-1.0, cs))) + geo[ch, 7])
        alpha = min(alpha, math.pi)
    _set_geo(geo[k], cx, cy, cz, r, nx, ny, nz, alpha, amax)


@njit(cache=True, error_model="numpy", inline="always")
def _set_geo(g, cx, cy, cz, r, nx, ny, nz, alpha, amax):
    """One node's row of ``TreeCage.geo``."""
    g[0] = cx
    g[1] = cy
    g[2] = cz
    g[3] = r
    g[4] = nx
    g[5] = ny
    g[6] = nz
    g[7] = alpha
    g[8] = amax


@njit(cache=True, error_model="numpy", inline="always")
def _compact_moments(full):
    """(nn, N_MOM) moments from the full (nn, 39) ones: M0, M1, w, symmetric M2 (see ``N_MOM``)."""
    nn = full.shape[0]
    mom = np.empty((nn, N_MOM))
    for k in range(nn):
        src = full[k]
        for m in range(12):
            mom[k, m] = src[m]
        for cc in range(3):
            v1 = 0.0
            for a in range(3):
                v1 += src[12 + 9 * a + 3 * a + cc]
            v2 = 0.0
            for b in range(3):
                v2 += src[12 + 9 * cc + 3 * b + b]
            mom[k, 12 + cc] = 2.0 * v1 + v2
        for a in range(3):
            base = 12 + 9 * a
            o = 15 + 6 * a
            mom[k, o] = src[base + 0]
            mom[k, o + 1] = src[base + 1]
            mom[k, o + 2] = src[base + 2]
            mom[k, o + 3] = src[base + 4]
            mom[k, o + 4] = src[base + 5]
            mom[k, o + 5] = src[base + 8]
    return mom


@njit(cache=True, error_model="numpy", inline="always")
def _weight_moments(verts, vmom, order, lo, hi, geo):
    """(nn, 11) second moments of the vertices' first-order weights per node (``TreeCage.aux``,
    read by ``_node_mass`` in :mod:`hybridedit.binding.mvc_tree`)."""
    nn = lo.shape[0]
    aux = np.zeros((nn, 11))
    for k in range(nn):
        cx = geo[k, 0]
        cy = geo[k, 1]
        cz = geo[k, 2]
        for t in range(lo[k], hi[k]):
            j = order[t]
            ax = vmom[j, 0]
            ay = vmom[j, 1]
            az = vmom[j, 2]
            ay_ = ax * (verts[j, 0] - cx) + ay * (verts[j, 1] - cy) + az * (verts[j, 2] - cz)
            aux[k, 0] += 1.0
            aux[k, 1] += ax * ax
            aux[k, 2] += ax * ay
            aux[k, 3] += ax * az
            aux[k, 4] += ay * ay
            aux[k, 5] += ay * az
            aux[k, 6] += az * az
            aux[k, 7] += ay_ * ax
            aux[k, 8] += ay_ * ay
            aux[k, 9] += ay_ * az
            aux[k, 10] += ay_ * ay_
    return aux


@njit(cache=True, error_model="numpy")
def _vertex_moments(verts, faces, fnorm, farea):
    """(c, 39) moments of each vertex's hat function about the vertex, summed over its corners:
    per corner, with e1, e2 the edges from it, A the face's area and n its unit normal,
    ``int phi n = A/3 n`` (3), ``int phi n y^T = A/12 n (e1 + e2)^T`` (9, row-major) and
    ``int phi n y y^T = n (A/30 (e1 e1^T + e2 e2^T) + A/60 (e1 e2^T + e2 e1^T))`` (27). Summed
    corner by corner in face order, a sum per corner position (as numpy's bincount of each
    corner position's terms, added in turn)."""
    c = verts.shape[0]
    out = np.zeros((c, 39))
    acc = np.empty((c, 39))
    part = np.empty(39)
    e1 = np.empty(3)
    e2 = np.empty(3)
    for m in range(3):
        acc[:] = 0.0
        for f in range(faces.shape[0]):
            v = faces[f, m]
            a = faces[f, (m + 1) % 3]
            b = faces[f, (m + 2) % 3]
            for i in range(3):
                e1[i] = verts[a, i] - verts[v, i]
                e2[i] = verts[b, i] - verts[v, i]
            A = farea[f]
            for i in range(3):
                part[i] = A / 3.0 * fnorm[f, i]
            y1 = A / 12.0 * (e1[0] + e2[0]), A / 12.0 * (e1[1] + e2[1]), A / 12.0 * (e1[2] + e2[2])
            for i in range(3):
                for j in range(3):
                    part[3 + 3 * i + j] = fnorm[f, i] * y1[j]
            for j in range(3):
                for k in range(3):
                    S = (e1[j] * e1[k] + e2[j] * e2[k]) / 30.0
                    S += (e1[j] * e2[k] + e2[j] * e1[k]) / 60.0
                    S *= A
                    for i in range(3):
                        part[12 + 9 * i + 3 * j + k] = fnorm[f, i] * S
            for q in range(39):
                acc[v, q] += part[q]
        for j in range(c):
            for q in range(39):
                out[j, q] += acc[j, q]
    return out


def prepare_tree_cage(fast: FastCageData) -> TreeCage:
    """The hierarchy over the vertices of a prepared fast cage (see :class:`TreeCage`)."""
    verts = np.ascontiguousarray(fast.verts_t.T)
    faces = np.ascontiguousarray(fast.far_idx[:, :3].astype(np.int64))
    c = verts.shape[0]
    nf = faces.shape[0]
    planes = fast.exact.planes
    fnorm = np.ascontiguousarray(planes[0:3].T)
    farea = 0.5 * planes[4]
    # Faces around each vertex.
    corner_v = faces.ravel()
    corner_f = np.repeat(np.arange(nf, dtype=np.int64), 3)
    srt = np.argsort(corner_v, kind="stable")
    star_faces = np.ascontiguousarray(corner_f[srt])
    star_ptr = np.zeros(c + 1, dtype=np.int64)
    np.cumsum(np.bincount(corner_v, minlength=c), out=star_ptr[1:])
    star_area = np.bincount(corner_v, weights=np.repeat(farea, 3), minlength=c)
    vmom = _vertex_moments(verts, faces, fnorm, farea)
    order, lo, hi, left, right = _build_nodes(verts, LEAF_SIZE)
    geo, mom, aux = _node_data(verts, vmom, star_ptr, star_faces, faces, star_area,
                          order, lo, hi, left, right)
    return TreeCage(fast=fast, star_ptr=star_ptr, star_faces=star_faces, order=order, lo=lo,
                    hi=hi, left=left, right=right, geo=geo, mom=mom, aux=aux)

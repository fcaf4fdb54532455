"""Hand-written LLVM IR for the float32 lane loops of the far field (:func:`far_rows`, :func:`g_row`).

The fast kernels (:mod:`hybridedit.binding.mvc_flat`, :mod:`hybridedit.binding.mvc_tree`) loop
over the lanes of a batch of points; those loops are written here as explicit SIMD code,
loaded into numba as intrinsics. Numba cannot tell LLVM that the rows a loop reads and
writes do not overlap, and the run-time overlap checks LLVM then inserts before every such
loop cost more than the loop itself. Every operation is the plain IEEE one, in the order
written (no fused multiply-add, no reassociation).

The kernels that compile these in are cached in a folder that follows every kernel source,
this one included (:mod:`hybridedit.kernel_cache`): an edit here recompiles them.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["VW", "far_rows", "g_row"]

#: Cap of 1 / |p - x|^4 in the far field (lengths in units of the cage's
#: diagonal; float32 overflows beyond 3.4e38). A face is far only from points
#: at least (far_ratio - 1) r_f from its vertices, so the cap is reached only
#: by faces smaller than about 1e-8 of the cage; it keeps inf * 0 out of the
#: sums.
_G_MAX = np.float32(1e30)

#: float32 values per vector of the lane loops (LANES must be a multiple).
VW = 16


def _vec_helpers(builder):
    """The float32 vector type of the lane loops, a splat and a constant maker."""
    vt = ir.VectorType(ir.FloatType(), VW)

    def splat(x):
        zero = ir.Constant(ir.IntType(32), 0)
        v = builder.insert_element(ir.Constant(vt, ir.Undefined), x, zero)
        mask = ir.Constant(ir.VectorType(ir.IntType(32), VW), [0] * VW)
        return builder.shuffle_vector(v, v, mask)

    def const(x):
        return ir.Constant(vt, [float(x)] * VW)

    return vt, splat, const


def _row_data(context, builder, ty, value):
    ary = context.make_array(ty)(context, builder, value)
    return ary.data, cgutils.unpack_tuple(builder, ary.shape, 1)[0]


_F32_ROW = types.Array(types.float32, 1, "C")


@intrinsic
def far_rows(typingctx, Y0, Y1, Y2, G0, G1, G2, M01, M12, M20, A0, A1, A2, q0, q1, q2, q3):
    """A_k[l] += q(l) * (3 G_k[l] - 4 M_opp(k)[l] + 8 (M01 + M12 + M20)[l] - (G0 + G1 + G2)[l]).

    All rows float32 of the same length (a multiple of VW), ``q(l) = q0 +
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
        nvec = builder.udiv(n, ir.Constant(n.type, VW))
        with cgutils.for_range(builder, nvec) as loop:
            off = builder.mul(loop.index, ir.Constant(n.type, VW))
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
        nvec = builder.udiv(n, ir.Constant(n.type, VW))
        with cgutils.for_range(builder, nvec) as loop:
            off = builder.mul(loop.index, ir.Constant(n.type, VW))
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

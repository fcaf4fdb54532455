"""Compiled text of a plain file's rows, written straight into a byte buffer: the same bytes
Python's formatting gives, many times faster.

* :func:`face_lines`: OBJ face lines (``f 1/2/3 ...``), as ``%d``-formatting.
* :func:`counted_lines`: OFF face lines (``3 0 1 2``), as ``%d``-formatting.
* :func:`float_rows`: rows of float64 in their shortest exact form, as ``repr(float)`` (Ryu:
  Ulf Adams, "Ryu: fast float-to-string conversion", PLDI 2018; the shortest decimal that reads
  back to the value, the closest of them to it, ties to even: the digits of Python's
  ``repr``, laid out by its rules). The digit generation follows the steps, constants and table
  definitions of the paper's reference implementation (github.com/ulfjack/ryu, ``d2s.c``,
  Apache-2.0 or Boost-1.0), written here for numba; the tables are computed at import.

Pure compute (numba); the format modules call it per chunk of rows and report progress between.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["counted_lines", "face_lines", "float_rows"]


_POW10 = np.array([10 ** i for i in range(20)], dtype=np.uint64)
_PAIRS = np.frombuffer(b"".join(b"%02d" % i for i in range(100)), dtype=np.uint8).copy()  # "00".."99"


@njit(cache=True, inline="always")
def _int_width(x):
    """Number of decimal digits of ``x`` (an integer >= 0: int64 or uint64)."""
    u = np.uint64(x)
    n = 1
    while n < 20 and u >= _POW10[n]:
        n += 1
    return n


@njit(cache=True, inline="always")
def _put_digits(out, end, x):
    """Write the decimal digits of ``x`` (uint64) into ``out`` (uint8) so that they end before
    ``end``, two at a time."""
    hundred = np.uint64(100)
    while x >= hundred:
        q = x // hundred
        r = np.int64(x - q * hundred)
        out[end - 2] = _PAIRS[2 * r]
        out[end - 1] = _PAIRS[2 * r + 1]
        end -= 2
        x = q
    if x >= np.uint64(10):
        r = np.int64(x)
        out[end - 2] = _PAIRS[2 * r]
        out[end - 1] = _PAIRS[2 * r + 1]
    else:
        out[end - 1] = 48 + np.int64(x)


@njit(cache=True, inline="always")
def _put_int(out, at, x):
    """Write ``x`` (int64 >= 0) in decimal at ``out[at:]`` (uint8); returns the index after it."""
    end = at + _int_width(x)
    _put_digits(out, end, np.uint64(x))
    return end


@njit(cache=True)
def _face_lines(counts, table, style):
    n_faces = counts.shape[0]
    m = table.shape[1]
    size = 0
    for c in range(table.shape[0]):  # "a", "a/b", "a//c", "a/b/c" and one space or line end
        size += _int_width(table[c, 0]) + 1
        if m >= 2:
            if style == 1:
                size += 2 + _int_width(table[c, 1])
            elif table[c, 1] != 0:
                size += 1 + _int_width(table[c, 1])
            elif m == 3:
                size += 1
            if m == 3:
                size += 1 + _int_width(table[c, 2])
    size += 2 * n_faces  # "f " of each line
    out = np.empty(size, dtype=np.uint8)
    at = 0
    c = 0
    for f in range(n_faces):
        out[at] = 102  # f
        out[at + 1] = 32
        at += 2
        for j in range(counts[f]):
            at = _put_int(out, at, table[c, 0])
            if m >= 2:
                if style == 1:  # a//n
                    out[at] = 47
                    out[at + 1] = 47
                    at = _put_int(out, at + 2, table[c, 1])
                elif table[c, 1] != 0:
                    out[at] = 47
                    at = _put_int(out, at + 1, table[c, 1])
                elif m == 3:  # a corner without texture coordinates: a//n
                    out[at] = 47
                    at += 1
                if m == 3:
                    out[at] = 47
                    at = _put_int(out, at + 1, table[c, 2])
            out[at] = 10 if j == counts[f] - 1 else 32
            at += 1
            c += 1
    return out


def face_lines(counts: np.ndarray, table: np.ndarray, normals_only: bool = False) -> np.ndarray:
    """The OBJ face lines of polygons, as ``"f " + " ".join(corners) + "\\n"`` each.

    Parameters
    ----------
    counts : (p,) int64 array
        Corners of each polygon (>= 1).
    table : (sum(counts), m) int64 array, m in 1..3, every value >= 0
        Each corner's numbers (1-based): the vertex; then either its texture coordinate (0: none)
        and, when m is 3, its normal; or, with ``normals_only`` (m is 2), its normal.
    normals_only : bool
        Corners are written ``v//n`` (no texture coordinates).

    Returns
    -------
    (bytes,) uint8 array
        The lines' text. A corner is ``v``, ``v/t``, ``v/t/n`` or ``v//n``; a texture
        coordinate of 0 is left out (``v``, ``v//n``): the text of ``"%d/%d/%d"``-formatting
        with ``/0/`` made ``//`` and a trailing ``/0`` dropped.
    """
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    table = np.ascontiguousarray(table, dtype=np.int64)
    if table.ndim != 2 or not 1 <= table.shape[1] <= 3 or (normals_only and table.shape[1] != 2):
        raise ValueError("face_lines: table must be (corners, 1..3), (corners, 2) with normals_only")
    if int(counts.sum()) != len(table):
        raise ValueError("face_lines: counts do not add up to the table's rows")
    return _face_lines(counts, table, 1 if normals_only else 0)


@njit(cache=True)
def _counted_lines(counts, flat):
    size = 0
    for f in range(counts.shape[0]):
        size += _int_width(counts[f]) + 1
    for c in range(flat.shape[0]):
        size += _int_width(flat[c]) + 1
    out = np.empty(size, dtype=np.uint8)
    at = 0
    c = 0
    for f in range(counts.shape[0]):
        at = _put_int(out, at, counts[f])
        for j in range(counts[f]):
            out[at] = 32
            at = _put_int(out, at + 1, flat[c])
            c += 1
        out[at] = 10
        at += 1
    return out


def counted_lines(counts: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Polygons as OFF writes them: a line of each one's corner count and then its corners.

    Parameters
    ----------
    counts : (p,) int64 array, every value >= 0
    flat : (sum(counts),) int64 array, every value >= 0
        The polygons' vertex indices, one polygon after another.

    Returns
    -------
    (bytes,) uint8 array
        The text of ``" ".join(map(str, [c, *corners])) + "\\n"`` for each polygon.
    """
    counts = np.ascontiguousarray(counts, dtype=np.int64)
    flat = np.ascontiguousarray(flat, dtype=np.int64).ravel()
    if int(counts.sum()) != len(flat):
        raise ValueError("counted_lines: counts do not add up to the corners")
    return _counted_lines(counts, flat)


# --------------------------------------------------------------------------- shortest float64 text (Ryu)
#
# The digit generation below is a numba rendering of Ryu's reference implementation (d2s.c),
# Copyright 2018 Ulf Adams, used under the Boost Software License 1.0 (it is offered under
# Apache-2.0 or BSL-1.0), whose notice follows:
#
# Boost Software License - Version 1.0 - August 17th, 2003
#
# Permission is hereby granted, free of charge, to any person or organization obtaining a copy of
# the software and accompanying documentation covered by this license (the "Software") to use,
# reproduce, display, distribute, execute, and transmit the Software, and to prepare derivative
# works of the Software, and to permit third-parties to whom the Software is furnished to do so,
# all subject to the following:
#
# The copyright notices in the Software and this entire statement, including the above license
# grant, this restriction and the following disclaimer, must be included in all copies of the
# Software, in whole or in part, and all derivative works of the Software, unless such copies or
# derivative works are solely in the form of machine-executable object code generated by a source
# language processor.
#
# THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR IMPLIED, INCLUDING BUT
# NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY, FITNESS FOR A PARTICULAR PURPOSE, TITLE AND
# NON-INFRINGEMENT. IN NO EVENT SHALL THE COPYRIGHT HOLDERS OR ANYONE DISTRIBUTING THE SOFTWARE BE
# LIABLE FOR ANY DAMAGES OR OTHER LIABILITY, WHETHER IN CONTRACT, TORT OR OTHERWISE, ARISING FROM,
# OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE SOFTWARE.

_POW5_INV_BITCOUNT = 125
_POW5_BITCOUNT = 125
_MASK64 = (1 << 64) - 1


def _ryu_tables() -> tuple[np.ndarray, np.ndarray]:
    """Ryu's 125-bit tables as (low, high) uint64 halves: ``inverse[q]`` about 2**(bits(5**q) - 1 + 125)
    / 5**q (rounded up), (342, 2); ``power[i]`` the top 125 bits of 5**i, (326, 2)."""
    inverse = np.empty((342, 2), dtype=np.uint64)
    for q in range(342):
        p = 5 ** q
        v = (1 << (p.bit_length() - 1 + _POW5_INV_BITCOUNT)) // p + 1
        inverse[q] = (v & _MASK64, v >> 64)
    power = np.empty((326, 2), dtype=np.uint64)
    for i in range(326):
        p = 5 ** i
        shift = p.bit_length() - _POW5_BITCOUNT
        v = p >> shift if shift >= 0 else p << -shift
        power[i] = (v & _MASK64, v >> 64)
    return inverse, power


_POW5_INV_SPLIT, _POW5_SPLIT = _ryu_tables()

_U32 = np.uint64(0xFFFFFFFF)
_S32 = np.uint64(32)


@njit(cache=True, inline="always")
def _umul128(a, b):
    """(low, high) uint64 halves of the 128-bit product of uint64 ``a`` and ``b``."""
    a_lo = a & _U32
    a_hi = a >> _S32
    b_lo = b & _U32
    b_hi = b >> _S32
    b00 = a_lo * b_lo
    b01 = a_lo * b_hi
    b10 = a_hi * b_lo
    b11 = a_hi * b_hi
    mid1 = b10 + (b00 >> _S32)
    mid2 = b01 + (mid1 & _U32)
    high = b11 + (mid1 >> _S32) + (mid2 >> _S32)
    low = ((mid2 & _U32) << _S32) | (b00 & _U32)
    return low, high


@njit(cache=True, inline="always")
def _mul_shift(m, mul_lo, mul_hi, j):
    """(m * mul) >> j for uint64 ``m``, 128-bit ``mul`` and 64 < j < 128 (uint64)."""
    lo0, hi0 = _umul128(m, mul_lo)
    lo2, hi2 = _umul128(m, mul_hi)
    low = lo2 + hi0
    high = hi2 + np.uint64(1 if low < lo2 else 0)
    shift = np.uint64(j - 64)
    return (high << (np.uint64(64) - shift)) | (low >> shift)


@njit(cache=True, inline="always")
def _scaled_bounds(mv, mm_shift, mul_lo, mul_hi, j):
    """The value (4 m), its upper bound (4 m + 2) and lower bound (4 m - 1 - mm_shift), each times
    the 128-bit ``mul`` and shifted right by ``j`` (:func:`_mul_shift`): (vr, vp, vm) uint64."""
    return (_mul_shift(mv, mul_lo, mul_hi, j), _mul_shift(mv + np.uint64(2), mul_lo, mul_hi, j),
            _mul_shift(mv - np.uint64(1) - mm_shift, mul_lo, mul_hi, j))


@njit(cache=True, inline="always")
def _pow5_factor(v):
    count = 0
    while v % np.uint64(5) == np.uint64(0):
        v //= np.uint64(5)
        count += 1
    return count


@njit(cache=True, inline="always")
def _pow5bits(e):
    return ((e * 1217359) >> 19) + 1


@njit(cache=True)
def _shortest_digits(bits):
    """The shortest decimal ``digits * 10**exponent`` reading back to the finite, non-zero float64
    of IEEE ``bits`` (uint64, sign ignored), closest to it, ties to even: (digits uint64, exponent)."""
    mantissa = bits & np.uint64((1 << 52) - 1)
    biased = np.int64((bits >> np.uint64(52)) & np.uint64(0x7FF))
    if biased == 0:
        e2 = 1 - 1023 - 52 - 2
        m2 = mantissa
    else:
        e2 = biased - 1023 - 52 - 2
        m2 = mantissa | np.uint64(1 << 52)
    even = (m2 & np.uint64(1)) == np.uint64(0)
    mv = np.uint64(4) * m2
    mm_shift = np.uint64(1 if (mantissa != np.uint64(0) or biased <= 1) else 0)
    vm_trailing_zeros = False
    vr_trailing_zeros = False
    if e2 >= 0:
        q = ((e2 * 78913) >> 18) - (1 if e2 > 3 else 0)
        e10 = q
        k = _POW5_INV_BITCOUNT + _pow5bits(q) - 1
        i = -e2 + q + k
        vr, vp, vm = _scaled_bounds(mv, mm_shift, _POW5_INV_SPLIT[q, 0], _POW5_INV_SPLIT[q, 1], i)
        if q <= 21:
            if mv % np.uint64(5) == np.uint64(0):
                vr_trailing_zeros = _pow5_factor(mv) >= q
            elif even:
                vm_trailing_zeros = _pow5_factor(mv - np.uint64(1) - mm_shift) >= q
            elif _pow5_factor(mv + np.uint64(2)) >= q:
                vp -= np.uint64(1)
    else:
        q = ((-e2 * 732923) >> 20) - (1 if -e2 > 1 else 0)
        e10 = q + e2
        i = -e2 - q
        k = _pow5bits(i) - _POW5_BITCOUNT
        j = q - k
        vr, vp, vm = _scaled_bounds(mv, mm_shift, _POW5_SPLIT[i, 0], _POW5_SPLIT[i, 1], j)
        if q <= 1:
            vr_trailing_zeros = True
            if even:
                vm_trailing_zeros = mm_shift == np.uint64(1)
            else:
                vp -= np.uint64(1)
        elif q < 63:
            vr_trailing_zeros = (mv & ((np.uint64(1) << np.uint64(q)) - np.uint64(1))) == np.uint64(0)
    removed = 0
    last = np.uint64(0)
    ten = np.uint64(10)
    if vm_trailing_zeros or vr_trailing_zeros:  # the general case (rare)
        while vp // ten > vm // ten:
            vm_trailing_zeros = vm_trailing_zeros and vm % ten == np.uint64(0)
            vr_trailing_zeros = vr_trailing_zeros and last == np.uint64(0)
            last = vr % ten
            vr //= ten
            vp //= ten
            vm //= ten
            removed += 1
        if vm_trailing_zeros:
            while vm % ten == np.uint64(0):
                vr_trailing_zeros = vr_trailing_zeros and last == np.uint64(0)
                last = vr % ten
                vr //= ten
                vp //= ten
                vm //= ten
                removed += 1
        if vr_trailing_zeros and last == np.uint64(5) and vr % np.uint64(2) == np.uint64(0):
            last = np.uint64(4)  # exactly half-way: to even
        up = (vr == vm and (not even or not vm_trailing_zeros)) or last >= np.uint64(5)
    else:
        up = False
        hundred = np.uint64(100)
        if vp // hundred > vm // hundred:
            up = vr % hundred >= np.uint64(50)
            vr //= hundred
            vp //= hundred
            vm //= hundred
            removed += 2
        while vp // ten > vm // ten:
            up = vr % ten >= np.uint64(5)
            vr //= ten
            vp //= ten
            vm //= ten
            removed += 1
        up = up or vr == vm
    return vr + np.uint64(1 if up else 0), e10 + removed


@njit(cache=True, inline="always")
def _put_float(out, at, x, bits):
    """Write ``repr(x)`` (float64 ``x``, its IEEE ``bits`` uint64) at ``out[at:]`` (uint8, room for
    24 bytes); returns the index after it."""
    if x != x:
        out[at] = 110  # nan
        out[at + 1] = 97
        out[at + 2] = 110
        return at + 3
    if bits >> np.uint64(63):
        out[at] = 45  # -
        at += 1
    if x == 0.0:
        out[at] = 48
        out[at + 1] = 46
        out[at + 2] = 48
        return at + 3
    if x == np.inf or x == -np.inf:
        out[at] = 105
        out[at + 1] = 110
        out[at + 2] = 102
        return at + 3
    digits, exponent = _shortest_digits(bits)
    n = _int_width(digits)
    point = exponent + n  # the value is 0.d1d2...dn * 10**point
    if point < -3 or point > 16:  # d1.d2...dne[+-]XX
        if n == 1:
            out[at] = 48 + np.int64(digits)
            at += 1
        else:  # the digits one place on, then the first one back before the point
            _put_digits(out, at + 1 + n, digits)
            out[at] = out[at + 1]
            out[at + 1] = 46
            at += n + 1
        out[at] = 101  # e
        e = point - 1
        out[at + 1] = 45 if e < 0 else 43
        e = -e if e < 0 else e
        at += 2
        if e < 10:
            out[at] = 48
            at += 1
        return _put_int(out, at, e)
    if point <= 0:  # 0.000ddd
        out[at] = 48
        out[at + 1] = 46
        at += 2
        for i in range(-point):
            out[at + i] = 48
        at += -point
        _put_digits(out, at + n, digits)
        return at + n
    if point >= n:  # ddd000.0
        end = at + n
        _put_digits(out, end, digits)
        for i in range(point - n):
            out[end + i] = 48
        end += point - n
        out[end] = 46
        out[end + 1] = 48
        return end + 2
    _put_digits(out, at + 1 + n, digits)  # dd.ddd: the digits one place on, the first ones back
    for i in range(point):
        out[at + i] = out[at + 1 + i]
    out[at + point] = 46
    return at + n + 1

#: the most bytes of one float's text: sign, 17 digits, point, e-308
_FLOAT_ROOM = 24


@njit(cache=True)
def _float_rows(values, bits, head):
    k, c = values.shape
    out = np.empty(k * (len(head) + (_FLOAT_ROOM + 1) * c + 1), dtype=np.uint8)
    at = 0
    for r in range(k):
        for h in range(len(head)):
            out[at + h] = head[h]
        at += len(head)
        for j in range(c):
            if j > 0 or len(head) > 0:
                out[at] = 32
                at += 1
            at = _put_float(out, at, values[r, j], bits[r, j])
        out[at] = 10
        at += 1
    return out[:at]


def float_rows(head: bytes, values: np.ndarray) -> np.ndarray:
    """Each row of ``values`` as a line: ``head``, then each value's ``repr`` after a space (no space
    before the first when ``head`` is empty), then ``\\n``.

    Parameters
    ----------
    head : bytes
        The start of every line (``b"v"``, or ``b""``).
    values : (k, c) float64 array

    Returns
    -------
    (bytes,) uint8 array
        The text of ``(head.decode() + " %r" * c + "\\n") % tuple(row)`` for every row, one after
        another (``"%r %r %r\\n"`` when ``head`` is empty).
    """
    values = np.ascontiguousarray(values, dtype=np.float64)
    if values.ndim != 2:
        raise ValueError("float_rows: values must be (rows, columns)")
    return _float_rows(values, values.view(np.uint64), np.frombuffer(head, dtype=np.uint8))

"""Compiled (numba) fast paths of the BVH reader: the frame-block parse and the
Euler-angle -> quaternion conversion.

:func:`parse_table` reads the whitespace table of frame values straight from the
file's bytes in one pass. It handles the plain case -- ASCII decimal numbers
``[+-]digits[.digits][(e|E)[+-]digits]`` separated by spaces/tabs, lines ended by
LF, CRLF or a lone CR, blank lines anywhere, exactly ``n_rows`` lines of exactly
``n_cols`` values -- and reports anything else (a ragged line, a stray byte,
``nan``, too many or too few lines) by a non-zero status; the reader then falls
back to :func:`numpy.loadtxt` and its line-naming error reports, so every bad
input still raises the same ``MotionFormatError``.

Exactness: a token with decimal mantissa ``m`` (its digits without the point) and
decimal exponent ``e`` (after moving the point) is converted as ``m * 10**e`` or
``m / 10**-e`` in one IEEE operation when ``m <= 2**53`` and ``|e| <= 22``: both
operands are then exact doubles, so the single correctly rounded multiply or
divide is the correctly rounded value of the decimal -- the same double as
``float(token)`` (Clinger's fast path: W. D. Clinger, "How to read floating point
numbers accurately", PLDI 1990). Every BVH number with at most 15 significant
digits and a magnitude between 1e-22 and 1e22 is in that range (all but a few
tokens of the real clips); the others (``-1.23456e-023``, 17-digit ``repr``
output) are returned as byte spans and converted by ``float()``. The tests compare
with ``float(token)`` bit for bit.

:func:`euler_to_quat_nb` performs the same floating-point operations, in the same
order, as the numpy version :func:`mocomp.io.bvh._euler_columns_to_quat` (sparse
Hamilton products of the elementary rotations; :func:`euler_program` lists them),
so it gives the same bits (tested), in one pass over the frames.

Numba is a project dependency; the kernels are compiled once per machine and
cached on disk (``cache=True``); the module is imported on the first read, so
``import mocomp.io`` does not pay numba's import. ``AVAILABLE`` (from
:mod:`mocomp.core._compiled`, the project's one switch) is False when numba cannot be
imported or ``MOCOMP_NO_NUMBA`` is set, and the reader then uses the numpy code only.
The Euler conversion is a sparse product program (zero components skipped, to keep the
numpy version's bits), not general quaternion algebra, so it does not use core's ``qmul``.
"""
from __future__ import annotations

import math

import numpy as np

from ..core._compiled import AVAILABLE, njit

__all__ = ["AVAILABLE", "parse_table", "OK", "euler_program", "euler_to_quat_nb"]

#: status of a complete, exact parse
OK = 0
#: exact powers of ten 1e0 .. 1e22 (every one is a double without rounding)
_P10 = np.array([10.0 ** k for k in range(23)])
_TWO53 = 2 ** 53

if AVAILABLE:
    @njit
    def parse_table(buf, start, out, slow):
        """Fill ``out`` (``(n_rows, n_cols)`` float64) with the numbers in ``buf[start:]``
        (``uint8``). Returns ``(status, n_slow)``: status :data:`OK` (0) when the block
        is exactly that table of decimal numbers, else non-zero (1: a byte or token
        this parser does not handle, 2: a line with the wrong number of values, 3: too
        few or too many lines, 4: more than ``len(slow)`` slow tokens), and ``out`` is
        then partly filled garbage. A well-formed number outside the exact fast range
        is left to the caller: its ``(row, column, start, end)`` byte span goes into
        ``slow[:n_slow]`` (for ``float(buf[start:end])``)."""
        n_rows, n_cols = out.shape
        n = buf.size
        i = start
        row = 0
        col = 0
        n_slow = 0
        while i < n:
            c = buf[i]
            if c == 32 or c == 9:  # space, tab
                i += 1
                continue
            if c == 10 or c == 13:  # LF, CR (CRLF: the LF then ends an empty line)
                if col != 0:
                    if col != n_cols:
                        return 2, n_slow
                    row += 1
                    col = 0
                i += 1
                continue
            if row >= n_rows:
                return 3, n_slow
            if col >= n_cols:
                return 2, n_slow
            tok0 = i
            neg = False
            if c == 45:  # '-'
                neg = True
                i += 1
            elif c == 43:  # '+'
                i += 1
            m = 0
            nd = 0
            frac = 0
            big = False
            while i < n:
                d = np.int64(buf[i]) - 48  # int64 as under numba: uint8 - 48 wraps with the JIT off
                if d < 0 or d > 9:
                    break
                if m > _TWO53:
                    big = True
                else:
                    m = m * 10 + d
                nd += 1
                i += 1
            if i < n and buf[i] == 46:  # '.'
                i += 1
                while i < n:
                    d = np.int64(buf[i]) - 48  # int64 as under numba: uint8 - 48 wraps with the JIT off
                    if d < 0 or d > 9:
                        break
                    if m > _TWO53:
                        big = True
                    else:
                        m = m * 10 + d
                    nd += 1
                    frac += 1
                    i += 1
            if nd == 0:
                return 1, n_slow
            e = 0
            if i < n and (buf[i] == 101 or buf[i] == 69):  # 'e', 'E'
                i += 1
                eneg = False
                if i < n and (buf[i] == 45 or buf[i] == 43):
                    eneg = buf[i] == 45
                    i += 1
                ne = 0
                while i < n:
                    d = np.int64(buf[i]) - 48  # int64 as under numba: uint8 - 48 wraps with the JIT off
                    if d < 0 or d > 9:
                        break
                    if e < 100000:
                        e = e * 10 + d
                    ne += 1
                    i += 1
                if ne == 0:
                    return 1, n_slow
                if eneg:
                    e = -e
            if i < n:
                c = buf[i]
                if not (c == 32 or c == 9 or c == 10 or c == 13):
                    return 1, n_slow
            e -= frac
            if m == 0 and not big:
                v = 0.0
            elif big or m > _TWO53 or e > 22 or e < -22:  # not exact in one operation: float() decides
                if n_slow >= slow.shape[0]:
                    return 4, n_slow
                slow[n_slow, 0] = row
                slow[n_slow, 1] = col
                slow[n_slow, 2] = tok0
                slow[n_slow, 3] = i
                n_slow += 1
                v = 0.0
            elif e >= 0:
                v = float(m) * _P10[e]
            else:
                v = float(m) / _P10[-e]
            out[row, col] = -v if neg else v
            col += 1
        if col != 0:
            if col != n_cols:
                return 2, n_slow
            row += 1
        if row != n_rows:
            return 3, n_slow
        return OK, n_slow
else:  # pragma: no cover
    parse_table = None


# ---------------------------------------------------------------- Euler angles -> quaternions
# (output component, a component, b component, sign) of the Hamilton product a*b in (x, y, z, w)
# order; the same table (and term order) as mocomp.io.bvh._HAMILTON
_HAMILTON = (
    (0, 3, 0, 1), (0, 0, 3, 1), (0, 1, 2, 1), (0, 2, 1, -1),
    (1, 3, 1, 1), (1, 0, 2, -1), (1, 1, 3, 1), (1, 2, 0, 1),
    (2, 3, 2, 1), (2, 0, 1, 1), (2, 1, 0, -1), (2, 2, 3, 1),
    (3, 3, 3, 1), (3, 0, 0, -1), (3, 1, 1, -1), (3, 2, 2, -1),
)
#: step codes of an Euler program: first term of an output (+t / -t), later terms (+= t / -= t)
_SET, _SET_NEG, _ADD, _SUB = 0, 1, 2, 3


def euler_program(seq: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The operations of :func:`mocomp.io.bvh._euler_columns_to_quat` for the intrinsic
    sequence ``seq`` (1-3 axes) as data for :func:`euler_to_quat_nb`: ``axes (3,)``
    (-1 past the end), ``steps (3, 16, 4)`` rows ``(output, a component, b component,
    code)`` of each elementary product (stage 0 unused: the first elementary
    rotation is the start), ``n_steps (3,)``, and ``present (4,)``, which output
    components are non-zero. Zero components are skipped exactly as the numpy
    version skips them (``None``), so the kernel performs the same floating-point
    operations in the same order and gives the same bits."""
    axes = np.full(3, -1, dtype=np.int64)
    steps = np.zeros((3, 16, 4), dtype=np.int64)
    n_steps = np.zeros(3, dtype=np.int64)
    present = None
    for s, ch in enumerate(seq):
        ax = "XYZ".index(ch)
        axes[s] = ax
        b = {ax, 3}
        if present is None:
            present = b
            continue
        done: set[int] = set()
        k = 0
        for o, i, kb, sg in _HAMILTON:
            if i not in present or kb not in b:
                continue
            code = (_SET if sg > 0 else _SET_NEG) if o not in done else (_ADD if sg > 0 else _SUB)
            done.add(o)
            steps[s, k] = (o, i, kb, code)
            k += 1
        n_steps[s] = k
        present = done
    mask = np.array([c in present for c in range(4)])
    return axes, steps, n_steps, mask


if AVAILABLE:
    @njit
    def euler_to_quat_nb(data, cols, axes, steps, n_steps, present, out):
        """``out[t, j]`` = the quaternion of the intrinsic Euler rotation whose angles
        (degrees) are ``data[t, cols[j, s]]`` about axes ``axes[j, s]``, for every frame
        ``t`` and joint ``j`` with ``axes[j, 0] >= 0`` (the others are left alone).
        Per joint the program of :func:`euler_program`: half angles ``a * (pi / 360)``,
        elementary quaternions ``(sin, cos)`` (a zero angle gives ``(+-0, 1)`` without
        calling them: the same bits, and a fifth of the CMU channels never move),
        products term by term."""
        T = data.shape[0]
        J = cols.shape[0]
        k = math.pi / 360.0
        q = np.empty(4)
        b = np.zeros(4)
        nq = np.empty(4)
        for j in range(J):  # joint outside: its program stays in cache and the branches predictable
            a0 = axes[j, 0]
            if a0 < 0:
                continue
            for t in range(T):
                h = data[t, cols[j, 0]] * k
                if h == 0.0:  # still joints: sin(+-0) = +-0 and cos(0) = 1 exactly, without the calls
                    q[a0] = h
                    q[3] = 1.0
                else:
                    q[a0] = math.sin(h)
                    q[3] = math.cos(h)
                for s in range(1, 3):
                    ax = axes[j, s]
                    if ax < 0:
                        break
                    h = data[t, cols[j, s]] * k
                    if h == 0.0:
                        b[ax] = h
                        b[3] = 1.0
                    else:
                        b[ax] = math.sin(h)
                        b[3] = math.cos(h)
                    for r in range(n_steps[j, s]):
                        o = steps[j, s, r, 0]
                        v = q[steps[j, s, r, 1]] * b[steps[j, s, r, 2]]
                        code = steps[j, s, r, 3]
                        if code == 0:
                            nq[o] = v
                        elif code == 1:
                            nq[o] = -v
                        elif code == 2:
                            nq[o] = nq[o] + v
                        else:
                            nq[o] = nq[o] - v
                    for c in range(4):
                        q[c] = nq[c]
                for c in range(4):
                    out[t, j, c] = q[c] if present[j, c] else 0.0
        return out
else:  # pragma: no cover
    euler_to_quat_nb = None

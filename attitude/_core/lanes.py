"""Lanes: LANES independent float64 values carried together, for structure-of-arrays kernels.

A batch kernel (:mod:`attitude._core.taylor_batch`) integrates LANES members at once: every
quantity is a tuple of LANES floats, one per member, and arrays keep the lane as their last,
contiguous axis (``cf[k, column, lane]``). Each helper below applies ONE floating-point
operation lane by lane (multiply–adds as explicit fused operations, :mod:`attitude._core.fma`),
so a lane computes exactly the operations, in exactly the order, of the scalar kernel it
mirrors. LLVM's SLP vectoriser (on for the kernels that use these helpers:
:func:`orbit._shared_jit.slp_vectorized`) turns each helper into one SIMD instruction
(LANES = 4 doubles: one AVX2 register) and keeps the tuples of a loop's accumulators in
registers. Lanes never mix: no helper reduces across lanes.
"""

from __future__ import annotations

from orbit._shared_jit import jit

from .fma import fma as _fma

#: Members per batch (one 256-bit SIMD register of float64).
LANES = 4

ZERO = (0.0, 0.0, 0.0, 0.0)


@jit(inline="always")
def load(a, k, c):
    """``a[k, c, :]`` as a lane tuple."""
    return (a[k, c, 0], a[k, c, 1], a[k, c, 2], a[k, c, 3])


@jit(inline="always")
def store(a, k, c, v):
    """``a[k, c, :] = v``."""
    a[k, c, 0] = v[0]
    a[k, c, 1] = v[1]
    a[k, c, 2] = v[2]
    a[k, c, 3] = v[3]


@jit(inline="always")
def load_row(a, c):
    """``a[c, :]`` (a 2-D array of per-lane constants) as a lane tuple."""
    return (a[c, 0], a[c, 1], a[c, 2], a[c, 3])


@jit(inline="always")
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3])


@jit(inline="always")
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2], a[3] - b[3])


@jit(inline="always")
def mul(a, b):
    return (a[0] * b[0], a[1] * b[1], a[2] * b[2], a[3] * b[3])


@jit(inline="always")
def div(a, b):
    return (a[0] / b[0], a[1] / b[1], a[2] / b[2], a[3] / b[3])


@jit(inline="always")
def smul(s, a):
    """The scalar ``s`` times every lane (a product commutes exactly: also ``a * s``)."""
    return (s * a[0], s * a[1], s * a[2], s * a[3])


@jit(inline="always")
def fma(a, b, c):
    """a·b + c rounded once, lane by lane (:func:`attitude._core.fma.fma`)."""
    return (_fma(a[0], b[0], c[0]), _fma(a[1], b[1], c[1]), _fma(a[2], b[2], c[2]),
            _fma(a[3], b[3], c[3]))  # fmt: skip


@jit(inline="always")
def neg(a):
    return (-a[0], -a[1], -a[2], -a[3])

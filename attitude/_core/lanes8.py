"""Lanes of 8 doubles (one AVX-512 register): :mod:`attitude._core.lanes` at twice the width.

The same helpers, the same one floating-point operation per lane, on tuples of LANES = 8
floats; :func:`attitude._core.taylor_batch.batch` binds the batch integrator to this module on a
CPU with AVX-512 (:func:`attitude._core.lanes.simd_lanes`). A lane computes what it computes in
a batch of 4, or alone: the width changes no result.
"""

from __future__ import annotations

from orbit._shared_jit import jit

from .fma import fma as _fma

#: Members per batch (one 512-bit SIMD register of float64).
LANES = 8

ZERO = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@jit(inline="always")
def load(a, k, c):
    """``a[k, c, :]`` as a lane tuple."""
    return (
        a[k, c, 0],
        a[k, c, 1],
        a[k, c, 2],
        a[k, c, 3],
        a[k, c, 4],
        a[k, c, 5],
        a[k, c, 6],
        a[k, c, 7],
    )


@jit(inline="always")
def store(a, k, c, v):
    """``a[k, c, :] = v``."""
    a[k, c, 0] = v[0]
    a[k, c, 1] = v[1]
    a[k, c, 2] = v[2]
    a[k, c, 3] = v[3]
    a[k, c, 4] = v[4]
    a[k, c, 5] = v[5]
    a[k, c, 6] = v[6]
    a[k, c, 7] = v[7]


@jit(inline="always")
def load_row(a, c):
    """``a[c, :]`` (a 2-D array of per-lane constants) as a lane tuple."""
    return (a[c, 0], a[c, 1], a[c, 2], a[c, 3], a[c, 4], a[c, 5], a[c, 6], a[c, 7])


@jit(inline="always")
def add(a, b):
    return (
        a[0] + b[0],
        a[1] + b[1],
        a[2] + b[2],
        a[3] + b[3],
        a[4] + b[4],
        a[5] + b[5],
        a[6] + b[6],
        a[7] + b[7],
    )


@jit(inline="always")
def sub(a, b):
    return (
        a[0] - b[0],
        a[1] - b[1],
        a[2] - b[2],
        a[3] - b[3],
        a[4] - b[4],
        a[5] - b[5],
        a[6] - b[6],
        a[7] - b[7],
    )


@jit(inline="always")
def mul(a, b):
    return (
        a[0] * b[0],
        a[1] * b[1],
        a[2] * b[2],
        a[3] * b[3],
        a[4] * b[4],
        a[5] * b[5],
        a[6] * b[6],
        a[7] * b[7],
    )


@jit(inline="always")
def div(a, b):
    return (
        a[0] / b[0],
        a[1] / b[1],
        a[2] / b[2],
        a[3] / b[3],
        a[4] / b[4],
        a[5] / b[5],
        a[6] / b[6],
        a[7] / b[7],
    )


@jit(inline="always")
def smul(s, a):
    """The scalar ``s`` times every lane (a product commutes exactly: also ``a * s``)."""
    return (s * a[0], s * a[1], s * a[2], s * a[3], s * a[4], s * a[5], s * a[6], s * a[7])


@jit(inline="always")
def fma(a, b, c):
    """a·b + c rounded once, lane by lane (:func:`attitude._core.fma.fma`)."""
    return (
        _fma(a[0], b[0], c[0]),
        _fma(a[1], b[1], c[1]),
        _fma(a[2], b[2], c[2]),
        _fma(a[3], b[3], c[3]),
        _fma(a[4], b[4], c[4]),
        _fma(a[5], b[5], c[5]),
        _fma(a[6], b[6], c[6]),
        _fma(a[7], b[7], c[7]),
    )


@jit(inline="always")
def neg(a):
    return (-a[0], -a[1], -a[2], -a[3], -a[4], -a[5], -a[6], -a[7])

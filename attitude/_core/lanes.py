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

:mod:`attitude._core.lanes8` is the same at 8 doubles (one AVX-512 register);
:func:`simd_lanes` says which width this CPU takes (chosen at run time, never at import).
"""

from __future__ import annotations

import os

from orbit._shared_jit import jit

from .fma import fma as _fma

#: Members per batch (one 256-bit SIMD register of float64).
LANES = 4

ZERO = (0.0, 0.0, 0.0, 0.0)

#: Lane widths with a module of helpers (this one and :mod:`attitude._core.lanes8`).
WIDTHS = (4, 8)

_HOST: list[int] = []


def simd_lanes() -> int:
    """Doubles per SIMD register of this CPU, as the batch integrator's lane count: 8 with
    AVX-512 (``avx512f``), else 4 (AVX2, or the width LLVM splits for older CPUs).

    ``ATTITUDE_SIMD_LANES=4`` or ``8`` overrides it (read at every call: tests compare the
    widths). A width changes speed only, never a result.
    """
    env = os.environ.get("ATTITUDE_SIMD_LANES", "").strip()
    if env:
        if int(env) not in WIDTHS:
            raise ValueError(f"ATTITUDE_SIMD_LANES={env!r}: must be one of {WIDTHS}")
        return int(env)
    if not _HOST:
        try:
            import llvmlite.binding as llb

            avx512 = bool(llb.get_host_cpu_features().get("avx512f"))
        except Exception:  # pragma: no cover - no feature list (another architecture)
            avx512 = False
        _HOST.append(8 if avx512 else 4)
    return _HOST[0]


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

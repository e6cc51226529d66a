"""Scalar quaternion kernels for compiled code.

Quaternions are anything indexable of length 4, scalar first ``(w, x, y, z)`` (a 1-D float
array or a 4-tuple); vectors are length 3. Results are returned as tuples, which numba keeps
in registers, so the integrators call these without allocating.

Hamilton product (Schwab eq. 2; Arribas et al. Sect. 2):
    a∘b = (a0 b0 − a·b, a0 b + b0 a + a × b)
"""

from __future__ import annotations

import math

from orbit._shared_jit import jit

from .fma import fma as F


@jit
def mul(a, b):
    """Hamilton product a∘b -> 4-tuple."""
    return (
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    )


@jit
def conj_mul(a, b):
    """ã∘b (conjugate of a times b) -> 4-tuple."""
    return (
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3],
        a[0] * b[1] - a[1] * b[0] - a[2] * b[3] + a[3] * b[2],
        a[0] * b[2] + a[1] * b[3] - a[2] * b[0] - a[3] * b[1],
        a[0] * b[3] - a[1] * b[2] + a[2] * b[1] - a[3] * b[0],
    )


@jit
def mul_vec(a, v):
    """a∘(0, v) for a 3-vector v -> 4-tuple."""
    return (
        -a[1] * v[0] - a[2] * v[1] - a[3] * v[2],
        a[0] * v[0] + a[2] * v[2] - a[3] * v[1],
        a[0] * v[1] - a[1] * v[2] + a[3] * v[0],
        a[0] * v[2] + a[1] * v[1] - a[2] * v[0],
    )


@jit
def conj(a):
    """Conjugate ã = (a0, −a) -> 4-tuple."""
    return (a[0], -a[1], -a[2], -a[3])


@jit
def dot(a, b):
    """Euclidean dot product of two 4-vectors (Arribas et al.: p·q = Re(p q̃))."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


@jit
def norm(a):
    """Euclidean norm of a 4-vector."""
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2] + a[3] * a[3])


@jit
def rotate(q, v):
    """vec(q∘(0, v)∘q̃): body components -> space components (Schwab eq. 6) -> 3-tuple.

    Uses x + 2w (u × x) + 2 u × (u × x) with u = vec(q), valid for unit q.
    """
    w, x, y, z = q[0], q[1], q[2], q[3]
    tx = 2.0 * (y * v[2] - z * v[1])
    ty = 2.0 * (z * v[0] - x * v[2])
    tz = 2.0 * (x * v[1] - y * v[0])
    return (
        v[0] + w * tx + (y * tz - z * ty),
        v[1] + w * ty + (z * tx - x * tz),
        v[2] + w * tz + (x * ty - y * tx),
    )


@jit
def rotate_inverse(q, v):
    """vec(q̃∘(0, v)∘q): space components -> body components -> 3-tuple."""
    return rotate((q[0], -q[1], -q[2], -q[3]), v)


@jit
def cross(a, b):
    """a × b for 3-vectors -> 3-tuple."""
    return (
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    )


@jit(inline="always")
def shorter(q):
    """The quaternion of the shorter rotation (scalar part >= 0)."""
    if q[0] < 0.0:
        return (-q[0], -q[1], -q[2], -q[3])
    return q


@jit(inline="always")
def mrp(q):
    """Modified Rodrigues parameters of the shorter rotation of ``q`` (|σ| <= 1)."""
    s = shorter(q)
    d = 1.0 + s[0]
    return (s[1] / d, s[2] / d, s[3] / d)


# sin x / x and cos x by their series in x² (Horner's rule on the coefficients: multiply–adds
# on a short chain, no division, sine or square root)
_S1 = -1.0 / 6.0
_S2 = 1.0 / 120.0
_S3 = -1.0 / 5040.0
_S4 = 1.0 / 362880.0
_C1 = -1.0 / 2.0
_C2 = 1.0 / 24.0
_C3 = -1.0 / 720.0
_C4 = 1.0 / 40320.0
_C5 = -1.0 / 3628800.0

#: x² below which :func:`sinc_cos_series` is exact to round-off (x < 0.05: the first terms
#: left out, x¹⁰/11! and x¹²/12!, are below 3e-21 relative)
SERIES_X2 = 0.0025


@jit(inline="always")
def sinc_cos_series(x2):
    """(sin x / x, cos x) from x² < :data:`SERIES_X2` by their series (the half angle of a
    small rotation: its quaternion is (cos x, sin x / x · θ/2) with x = |θ|/2)."""
    sinc = F(x2, F(x2, F(x2, F(x2, _S4, _S3), _S2), _S1), 1.0)
    cos = F(x2, F(x2, F(x2, F(x2, F(x2, _C5, _C4), _C3), _C2), _C1), 1.0)
    return sinc, cos


@jit(inline="always")
def half_angle(ww, dt):
    """(sin a / w, cos a) of the half angle a = wΔt/2 of the rotation by ω over Δt, from
    w² = |ω|² (``ww``): the quaternion of that rotation is (cos a, sin a / w · ω). Below
    a² = :data:`SERIES_X2` by :func:`sinc_cos_series` (no square root, sine or division: the
    usual tick of a filter, arcseconds of sensor noise), else by sin and cos."""
    a2 = 0.25 * ww * dt * dt
    if a2 < SERIES_X2:
        sinc, ca = sinc_cos_series(a2)
        return 0.5 * dt * sinc, ca
    w = math.sqrt(ww)
    a = 0.5 * w * dt
    return math.sin(a) / w, math.cos(a)

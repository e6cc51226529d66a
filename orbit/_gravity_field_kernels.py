"""Compiled spherical-harmonic gravity: Pines' non-singular formulation, fully normalised.

The geopotential V = (μ/r) Σₙ (a/r)ⁿ Σₘ Āₙₘ(u) [C̄ₙₘ rₘ + S̄ₙₘ iₘ] (the geodesists' sign:
acceleration = ∇V) in Pines' variables (Pines 1973, AIAA J. 11, 1508): the direction cosines
s, t, u = x/r, y/r, z/r, rₘ + i iₘ = (s + i t)ᵐ, and the derived Legendre functions
Aₙₘ(u) = dᵐPₙ/duᵐ, so that Pₙₘ(sin φ) = cosᵐφ Aₙₘ(u): no 1/cos φ anywhere, the poles included.
With the fully normalised Āₙₘ = Nₙₘ Aₙₘ, Nₙₘ = sqrt((2 − δₘ₀)(2n + 1)(n − m)!/(n + m)!), the
recursions and the gradient are those of Lundberg & Schutz (1988, J. Guid. Control Dyn. 11, 31)
as Basilisk's gravity effector writes them: stable to high degree (no factorials are formed).

The normalisation factors are a table computed once per degree (:func:`factors`, plain Python);
the kernels take it, the coefficients and scratch arrays, and never allocate.

Also the point-mass pull of a third body (the Sun, the Moon) on an Earth orbit,
:func:`third_body`.
"""

from __future__ import annotations

import math

import numpy as np

from ._shared_jit import jit

__all__ = [
    "F_DIAG", "F_N1", "F_N2", "F_NQ1", "F_NQ2", "F_OFF",
    "factors", "field", "field_loop", "third_body", "third_body_loop",
]  # fmt: skip

# Rows of the factor table (F_*, (n_max + 2) × (n_max + 2) each).
F_DIAG = 0  # Ā_nn / Ā_(n-1)(n-1)  (in column 0 of row n)
F_OFF = 1  # Ā_n(n-1) / (u Ā_nn)   (column 0)
F_N1 = 2  # Ā_nm = u N1 Ā_(n-1)m − N2 Ā_(n-2)m
F_N2 = 3
F_NQ1 = 4  # ∂/∂u terms of the gradient: Ā_n(m+1) and Ā_(n+1)(m+1) weights
F_NQ2 = 5


def _k(m: int) -> float:
    return 1.0 if m == 0 else 2.0


def factors(n_max: int) -> np.ndarray:
    """The normalisation factors of the recursions to degree ``n_max`` (the table reaches
    ``n_max + 1``: the gradient reads Ā of one degree more), shape (6, n_max + 2, n_max + 2)."""
    size = n_max + 2
    f = np.zeros((6, size, size))
    for n in range(1, size):
        f[F_DIAG, n, 0] = math.sqrt((2 * n + 1) * _k(n) / (2 * n * _k(n - 1)))
        f[F_OFF, n, 0] = math.sqrt(2 * n * _k(n - 1) / _k(n))
    for n in range(2, size):
        for m in range(n - 1):
            f[F_N1, n, m] = math.sqrt((2 * n + 1) * (2 * n - 1) / ((n - m) * (n + m)))
            f[F_N2, n, m] = math.sqrt(
                (n + m - 1) * (2 * n + 1) * (n - m - 1) / ((n + m) * (n - m) * (2 * n - 3))
            )
    for n in range(size - 1):
        for m in range(n + 1):
            f[F_NQ1, n, m] = math.sqrt((n - m) * _k(m) * (n + m + 1) / _k(m + 1))
            f[F_NQ2, n, m] = math.sqrt(
                (n + m + 2) * (n + m + 1) * (2 * n + 1) * _k(m) / ((2 * n + 3) * _k(m + 1))
            )
    return f


@jit
def field(x, y, z, C, S, n_max, m_max, mu, a, f, A, re, im):
    """V (J/kg, positive: μ/r for a point mass) and ∇V (m/s²) at (x, y, z) (m, body-fixed) to
    degree ``n_max`` and order ``m_max``; ``A`` (n_max + 2)², ``re``/``im`` (n_max + 2):
    scratch. Returns (V, gx, gy, gz)."""
    r = math.sqrt(x * x + y * y + z * z)
    s = x / r
    t = y / r
    u = z / r
    top = n_max + 1
    # Ā_nm(u): the diagonal, the first off-diagonal, then down each column
    A[0, 0] = 1.0
    for n in range(1, top + 1):
        A[n, n] = f[F_DIAG, n, 0] * A[n - 1, n - 1]
        A[n, n - 1] = f[F_OFF, n, 0] * u * A[n, n]
    for m in range(top - 1):
        for n in range(m + 2, top + 1):
            A[n, m] = u * f[F_N1, n, m] * A[n - 1, m] - f[F_N2, n, m] * A[n - 2, m]
    # (s + i t)^m
    re[0] = 1.0
    im[0] = 0.0
    for m in range(1, m_max + 1):
        re[m] = s * re[m - 1] - t * im[m - 1]
        im[m] = s * im[m - 1] + t * re[m - 1]
    rho = a / r
    scale = mu / r  # (μ/r)(a/r)^n
    V = 0.0
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    a4 = 0.0
    for n in range(n_max + 1):
        v = 0.0
        b1 = 0.0
        b2 = 0.0
        b3 = 0.0
        b4 = 0.0
        for m in range(min(n, m_max) + 1):
            c = C[n, m]
            sn = S[n, m]
            D = c * re[m] + sn * im[m]
            v += A[n, m] * D
            if m > 0:
                E = c * re[m - 1] + sn * im[m - 1]
                F = sn * re[m - 1] - c * im[m - 1]
                b1 += m * A[n, m] * E
                b2 += m * A[n, m] * F
            if m < n:
                b3 += f[F_NQ1, n, m] * A[n, m + 1] * D
            b4 += f[F_NQ2, n, m] * A[n + 1, m + 1] * D
        V += scale * v
        g = scale / r  # (μ/r²)(a/r)^n
        a1 += g * b1
        a2 += g * b2
        a3 += g * b3
        a4 -= g * b4
        scale *= rho
    return V, a1 + s * a4, a2 + t * a4, a3 + u * a4


@jit
def field_loop(pos, C, S, n_max, m_max, mu, a, f, V, g):
    """:func:`field` at each row of ``pos`` (k, 3) into ``V`` (k,) and ``g`` (k, 3)."""
    size = n_max + 2
    A = np.zeros((size, size))
    re = np.zeros(size)
    im = np.zeros(size)
    for k in range(pos.shape[0]):
        V[k], g[k, 0], g[k, 1], g[k, 2] = field(
            pos[k, 0], pos[k, 1], pos[k, 2], C, S, n_max, m_max, mu, a, f, A, re, im
        )


@jit
def third_body(mu, sx, sy, sz, rx, ry, rz):
    """The acceleration (m/s²) at r relative to the Earth's centre by a point mass ``mu`` at s
    (both m, the same axes): μ [(s − r)/|s − r|³ − s/|s|³], the direct pull less the Earth's,
    in Battin's form (Battin 1999, Sect. 8.4: f(q), q = r·(r − 2s)/|s|²), which does not lose
    the digits the difference of two nearly equal terms loses far from the body."""
    dx = rx - sx
    dy = ry - sy
    dz = rz - sz
    d2 = dx * dx + dy * dy + dz * dz
    s2 = sx * sx + sy * sy + sz * sz
    q = (rx * (rx - 2.0 * sx) + ry * (ry - 2.0 * sy) + rz * (rz - 2.0 * sz)) / s2
    fq = q * (3.0 + 3.0 * q + q * q) / (1.0 + (1.0 + q) * math.sqrt(1.0 + q))
    k = -mu / (d2 * math.sqrt(d2))
    return k * (rx + fq * sx), k * (ry + fq * sy), k * (rz + fq * sz)


@jit
def third_body_loop(mu, s, r, out):
    """:func:`third_body` for each row of ``s`` and ``r`` (k, 3) into ``out`` (k, 3)."""
    for k in range(r.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = third_body(
            mu, s[k, 0], s[k, 1], s[k, 2], r[k, 0], r[k, 1], r[k, 2]
        )

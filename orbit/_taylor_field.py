"""Taylor coefficients of the spherical-harmonic acceleration (Pines), order by order.

The series counterpart of :func:`orbit._gravity_field_kernels.field`: the same recursion (Pines
1973; fully normalised as Lundberg & Schutz 1988 write it), each quantity a truncated power
series in the time τ since the start of a Taylor step, its coefficient of order k computed from
those of orders ≤ k by series arithmetic (Cauchy products, division, powers; Jorba & Zou 2005,
Sect. 2).

Reorganised for series (the values are the same sums, summed in another order):

* with ρ = a/|r|, the scaled functions Bₙₘ = ρⁿ Āₙₘ(u) obey the recursion of Āₙₘ with ρ and ρu
  in it: Bₙₙ = fₙ ρ Bₙ₋₁,ₙ₋₁, Bₙ,ₙ₋₁ = f'ₙ u Bₙₙ, Bₙₘ = N1 (ρu) Bₙ₋₁,ₘ − N2 ρ² Bₙ₋₂,ₘ, where
  ρu = a z/|r|² and ρ² = a²/|r|²: two Cauchy products per (n, m), not one per term of the sums;
* the gradient's sums over n at fixed m are linear in the Bₙₘ (constant C̄ₙₘ, S̄ₙₘ weights): per
  m, X1ₘ = Σₙ m C̄ₙₘ Bₙₘ, Y1ₘ = Σₙ m S̄ₙₘ Bₙₘ, X3ₘ, Y3ₘ (weights N_q1 of Bₙ,ₘ₊₁), X4ₘ, Y4ₘ (N_q2
  of Bₙ₊₁,ₘ₊₁) cost one multiply–add per (n, m) and order, and the products with
  (s + i t)ᵐ = reₘ + i imₘ are taken once per m:
  P1 = Σ X1ₘ reₘ₋₁ + Y1ₘ imₘ₋₁, P2 = Σ Y1ₘ reₘ₋₁ − X1ₘ imₘ₋₁, P3 = Σ X3ₘ reₘ + Y3ₘ imₘ,
  P4 = Σ X4ₘ reₘ + Y4ₘ imₘ;
* ∇V = (μ/|r|²) (P1, P2, P3) − (μ/a) (x, y, z) |r|⁻² P4 (the kernel's a₁ + s a₄ ...: there the
  sums carry (μ/|r|²) ρⁿ; ρⁿ Āₙ₊₁,ₘ₊₁ = Bₙ₊₁,ₘ₊₁/ρ gives the μ/(a|r|) of the last term).

Storage: the scalar series are rows of the integrator's table ``S`` (:data:`FIELD_ROWS`, from
the row ``f0``: S[row, k] is the coefficient of order k); the series indexed by m are planes of
the array ``F`` (shape (:func:`field_planes`, PMAX + 1, n_max + 2): F[plane, k, m]), m
innermost, so that the loops over m (every m of a degree n at once in the recursion, the sums
over n, the products with reₘ, imₘ) are independent multiply–adds the compiler vectorises, each
m's sum still taken in the order of j: Bₙ is plane n, then reₘ, imₘ, X1 .. Y4 and the
accumulators (:data:`PLANES`, after the n_max + 2 planes of B). Bₙ,ₙ₊₁ is never written and
stays 0 (N_q1 of m = n is 0 too).

For a 20 × 20 field: ~460 Cauchy products per order for the B recursion, 12 per m for the rest.
"""

from __future__ import annotations

import math

import numpy as np

from ._force_kernels import FORCES
from ._gravity_field_kernels import F_DIAG, F_N1, F_N2, F_NQ1, F_NQ2, F_OFF
from ._layout import layout
from ._shared_jit import jit

__all__ = [
    "FIELD_ROWS", "PLANES", "cauchy", "field_order", "field_planes", "new_field_state",
    "power_order",
]  # fmt: skip

#: Rows of the field's scalar series in ``S`` (from ``f0``).
FIELD_ROWS = layout(
    "Taylor field series rows",
    w=1,  # |r|⁻²
    ri=1,  # |r|⁻¹
    s=1,  # x/|r| (ITRS)
    t=1,  # y/|r|
    u=1,  # z/|r|
    zw=1,  # z |r|⁻²
    p4=1,  # P4
    q4=1,  # |r|⁻² P4
    p1=1,
    p2=1,
    p3=1,
)
#: Planes of ``F`` after Bₙ (n = 0 .. n_max + 1).
PLANES = layout(
    "Taylor field series planes (after B)",
    re=1, im=1, x1=1, y1=1, x3=1, y3=1, x4=1, y4=1,
    acc=1,  # scratch: rows 0, 1 the recursion's sums; 2..5 those of P1..P4 per m
)  # fmt: skip


def field_planes(n_max: int) -> int:
    """Planes of ``F`` for a field of degree ``n_max`` (its width is n_max + 2)."""
    return n_max + 2 + PLANES.SIZE


def new_field_state(n_max: int, pmax: int) -> np.ndarray:
    """A zeroed ``F`` for a field of degree ``n_max`` (a point mass: an unused 1-plane array)."""
    if n_max == 0:
        return np.zeros((1, 1, 1))
    return np.zeros((field_planes(n_max), pmax + 1, n_max + 2))


@jit(inline="always")
def cauchy(S, a, b, k):
    """(S[a] ⋆ S[b])[k] = Σ_{j ≤ k} S[a, j] S[b, k − j]: the Cauchy product's order k."""
    acc = 0.0
    for j in range(k + 1):
        acc += S[a, j] * S[b, k - j]
    return acc


@jit(inline="always")
def power_order(S, src, dst, k, alpha):
    """Order k ≥ 1 of u = s^α (rows ``dst``, ``src``; orders < k of u known):
    u[k] = Σ_{j<k} (α (k − j) − j) s[k − j] u[j] / (k s[0]) (Jorba & Zou 2005, Sect. 2)."""
    acc = 0.0
    for j in range(k):
        acc += (alpha * (k - j) - j) * S[src, k - j] * S[dst, j]
    return acc / (k * S[src, 0])


@jit
def _scalars(S, k, f0, xi, yi, zi, r2):
    """Order k of |r|⁻² (a division), |r|⁻¹ (a power), s, t, u and z |r|⁻²."""
    W = f0 + FIELD_ROWS.W
    RI = f0 + FIELD_ROWS.RI
    if k == 0:
        S[W, 0] = 1.0 / S[r2, 0]
        S[RI, 0] = 1.0 / math.sqrt(S[r2, 0])
    else:
        acc = 0.0
        for j in range(1, k + 1):
            acc += S[r2, j] * S[W, k - j]
        S[W, k] = -acc * S[W, 0]
        S[RI, k] = power_order(S, r2, RI, k, -0.5)
    S[f0 + FIELD_ROWS.S, k] = cauchy(S, xi, RI, k)
    S[f0 + FIELD_ROWS.T, k] = cauchy(S, yi, RI, k)
    S[f0 + FIELD_ROWS.U, k] = cauchy(S, zi, RI, k)
    S[f0 + FIELD_ROWS.ZW, k] = cauchy(S, zi, W, k)


@jit
def _legendre(d, S, F, k, f0, nmax, mw):
    """Order k of Bₙₘ (planes 0 .. n_max + 1), m ≤ ``mw`` (the order + 1)."""
    a = d[FORCES.RADIUS]
    fo = int(d[FORCES.F])
    size = nmax + 2
    sq = size * size
    W = f0 + FIELD_ROWS.W
    ZW = f0 + FIELD_ROWS.ZW
    RI = f0 + FIELD_ROWS.RI
    UR = f0 + FIELD_ROWS.U
    acc = F[nmax + 2 + PLANES.ACC]
    c1 = acc[0]
    c2 = acc[1]
    f1 = d[fo + F_N1 * sq : fo + (F_N1 + 1) * sq]
    f2 = d[fo + F_N2 * sq : fo + (F_N2 + 1) * sq]
    F[0, k, 0] = 1.0 if k == 0 else 0.0
    for n in range(1, nmax + 2):
        if n - 1 <= mw:  # Bₙₙ and Bₙ,ₙ₋₁ (which needs Bₙₙ)
            s = 0.0
            for j in range(k + 1):
                s += S[RI, j] * F[n - 1, k - j, n - 1]
            F[n, k, n] = d[fo + F_DIAG * sq + n * size] * a * s
            s = 0.0
            for j in range(k + 1):
                s += S[UR, j] * F[n, k - j, n]
            F[n, k, n - 1] = d[fo + F_OFF * sq + n * size] * s
        ml = min(n - 1, mw + 1)  # Bₙₘ for m ≤ n − 2 and m ≤ mw
        if ml <= 0:
            continue
        for m in range(ml):
            c1[m] = 0.0
            c2[m] = 0.0
        for j in range(k + 1):
            zw = S[ZW, j]
            w = S[W, j]
            b1 = F[n - 1, k - j]
            b2 = F[n - 2, k - j]
            for m in range(ml):
                c1[m] += zw * b1[m]
                c2[m] += w * b2[m]
        out = F[n, k]
        row = n * size
        for m in range(ml):
            out[m] = f1[row + m] * a * c1[m] - f2[row + m] * (a * a) * c2[m]


@jit
def _powers(S, F, k, f0, pl, m1):
    """Order k of (s + i t)ᵐ = reₘ + i imₘ, m < ``m1``."""
    re = F[pl + PLANES.RE]
    im = F[pl + PLANES.IM]
    SR = f0 + FIELD_ROWS.S
    TR = f0 + FIELD_ROWS.T
    re[k, 0] = 1.0 if k == 0 else 0.0
    im[k, 0] = 0.0
    for m in range(1, m1):
        c1 = 0.0
        c2 = 0.0
        for j in range(k + 1):
            s = S[SR, j]
            t = S[TR, j]
            c1 += s * re[k - j, m - 1] - t * im[k - j, m - 1]
            c2 += s * im[k - j, m - 1] + t * re[k - j, m - 1]
        re[k, m] = c1
        im[k, m] = c2


@jit(inline="always")
def _combination_planes(F, pl):
    """The planes of X1ₘ, Y1ₘ, X3ₘ, Y3ₘ, X4ₘ, Y4ₘ (rows: orders)."""
    return (F[pl + PLANES.X1], F[pl + PLANES.Y1], F[pl + PLANES.X3], F[pl + PLANES.Y3],
            F[pl + PLANES.X4], F[pl + PLANES.Y4])  # fmt: skip


@jit
def _combinations(d, F, k, nmax, mmax, pl):
    """Order k of X1ₘ .. Y4ₘ, the linear combinations of the Bₙₘ over n (module docstring)."""
    x1, y1, x3, y3, x4, y4 = _combination_planes(F, pl)
    m1 = mmax + 1
    co = int(d[FORCES.C])
    so = int(d[FORCES.S])
    fo = int(d[FORCES.F])
    size = nmax + 2
    sq = size * size
    n1 = nmax + 1
    q1 = fo + F_NQ1 * sq
    q2 = fo + F_NQ2 * sq
    for m in range(m1):  # m outer: six sums over n in registers, side by side
        a1 = b1 = a3 = b3 = a4 = b4 = 0.0
        for n in range(m, nmax + 1):
            c = d[co + n * n1 + m]
            s = d[so + n * n1 + m]
            b = F[n, k, m]
            a1 += c * b
            b1 += s * b
            e = d[q1 + n * size + m] * F[n, k, m + 1]  # 0 at m = n
            a3 += c * e
            b3 += s * e
            e = d[q2 + n * size + m] * F[n + 1, k, m + 1]
            a4 += c * e
            b4 += s * e
        x1[k, m] = m * a1
        y1[k, m] = m * b1
        x3[k, m] = a3
        y3[k, m] = b3
        x4[k, m] = a4
        y4[k, m] = b4


@jit
def _products(F, k, pl, m1):
    """Order k of P1 .. P4: per-m sums of the products of X1ₘ .. Y4ₘ with reₘ, imₘ, then
    their sums over m."""
    re = F[pl + PLANES.RE]
    im = F[pl + PLANES.IM]
    x1, y1, x3, y3, x4, y4 = _combination_planes(F, pl)
    acc = F[pl + PLANES.ACC]
    for i in range(2, 6):
        for m in range(m1):
            acc[i, m] = 0.0
    a1 = acc[2]
    a2 = acc[3]
    a3 = acc[4]
    a4 = acc[5]
    for j in range(k + 1):
        rk = re[k - j]
        ik = im[k - j]
        X1 = x1[j]
        Y1 = y1[j]
        X3 = x3[j]
        Y3 = y3[j]
        X4 = x4[j]
        Y4 = y4[j]
        for m in range(m1):
            a3[m] += X3[m] * rk[m] + Y3[m] * ik[m]
            a4[m] += X4[m] * rk[m] + Y4[m] * ik[m]
        for m in range(1, m1):
            a1[m] += X1[m] * rk[m - 1] + Y1[m] * ik[m - 1]
            a2[m] += Y1[m] * rk[m - 1] - X1[m] * ik[m - 1]
    p1 = p2 = p3 = p4 = 0.0
    for m in range(m1):
        p1 += a1[m]
        p2 += a2[m]
        p3 += a3[m]
        p4 += a4[m]
    return p1, p2, p3, p4


@jit
def field_order(d, S, F, k, f0, xi, yi, zi, r2):
    """Order k of ∇V (m/s², Earth-fixed axes) from the orders ≤ k of the Earth-fixed position
    (rows ``xi``, ``yi``, ``zi`` of ``S``, m) and of |r|² (row ``r2``); the field's rows of
    ``S`` (from ``f0``) and the planes of ``F`` hold the orders < k of its series and receive
    order k. Returns (gx, gy, gz)."""
    nmax = int(d[FORCES.N_MAX])
    mmax = int(d[FORCES.M_MAX])
    mu = d[FORCES.MU]
    a = d[FORCES.RADIUS]
    m1 = mmax + 1
    pl = nmax + 2
    _scalars(S, k, f0, xi, yi, zi, r2)
    _legendre(d, S, F, k, f0, nmax, m1)
    _powers(S, F, k, f0, pl, m1)
    _combinations(d, F, k, nmax, mmax, pl)
    p1, p2, p3, p4 = _products(F, k, pl, m1)
    S[f0 + FIELD_ROWS.P1, k] = p1
    S[f0 + FIELD_ROWS.P2, k] = p2
    S[f0 + FIELD_ROWS.P3, k] = p3
    S[f0 + FIELD_ROWS.P4, k] = p4
    W = f0 + FIELD_ROWS.W
    Q4 = f0 + FIELD_ROWS.Q4
    S[Q4, k] = cauchy(S, W, f0 + FIELD_ROWS.P4, k)
    g = mu / a
    gx = mu * cauchy(S, W, f0 + FIELD_ROWS.P1, k) - g * cauchy(S, xi, Q4, k)
    gy = mu * cauchy(S, W, f0 + FIELD_ROWS.P2, k) - g * cauchy(S, yi, Q4, k)
    gz = mu * cauchy(S, W, f0 + FIELD_ROWS.P3, k) - g * cauchy(S, zi, Q4, k)
    return gx, gy, gz

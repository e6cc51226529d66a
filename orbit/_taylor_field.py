"""Taylor coefficients of the spherical-harmonic acceleration (Pines), order by order.

The series counterpart of :func:`orbit._gravity_field_kernels.field`: the same recursion (Pines
1973; fully normalised as Lundberg & Schutz 1988 write it), each quantity a truncated power
series in the time τ since the start of a Taylor step, its coefficient of order k computed from
those of orders ≤ k by series arithmetic (Cauchy products, division, powers; Jorba & Zou 2005,
Sect. 2). Every series is a row of the caller's table ``S`` (shape (rows, PMAX + 1); its rows
are laid out by :mod:`orbit._taylor`, the field's from ``f0`` on).

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

For a 20 × 20 field: ~460 Cauchy products per order for the B recursion, 12 per m for the rest.
"""

from __future__ import annotations

import math

from ._force_kernels import FORCES
from ._gravity_field_kernels import F_DIAG, F_N1, F_N2, F_NQ1, F_NQ2, F_OFF
from ._layout import layout
from ._shared_jit import jit

__all__ = ["FIELD_ROWS", "cauchy", "field_order", "field_rows", "power_order"]

#: Rows of the field's own series (from ``f0``), besides the per-m and per-(n, m) blocks.
FIELD_ROWS = layout(
    "Taylor field series rows",
    w=1,  # |r|⁻²
    ri=1,  # |r|⁻¹
    s=1,  # x/|r| (ITRS)
    t=1,  # y/|r|
    u=1,  # z/|r|
    zw=1,  # z |r|⁻²
    p1=1,
    p2=1,
    p3=1,
    p4=1,
    q4=1,  # |r|⁻² P4
)


def field_rows(n_max: int, m_max: int) -> int:
    """Number of rows the field's series take (0 for a point mass)."""
    if n_max == 0:
        return 0
    return FIELD_ROWS.SIZE + 8 * (m_max + 1) + (n_max + 2) ** 2


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
def field_order(d, S, k, f0, xi, yi, zi, r2):
    """Order k of ∇V (m/s², Earth-fixed axes) from the orders ≤ k of the Earth-fixed position
    (rows ``xi``, ``yi``, ``zi``, m) and of |r|² (row ``r2``); the field's rows from ``f0``
    hold the orders < k of its own series and receive order k. Returns (gx, gy, gz)."""
    nmax = int(d[FORCES.N_MAX])
    mmax = int(d[FORCES.M_MAX])
    mu = d[FORCES.MU]
    a = d[FORCES.RADIUS]
    co = int(d[FORCES.C])
    so = int(d[FORCES.S])
    fo = int(d[FORCES.F])
    size = nmax + 2
    n1 = nmax + 1
    sq = size * size
    m1 = mmax + 1
    top = nmax + 1
    W = f0 + FIELD_ROWS.W
    RI = f0 + FIELD_ROWS.RI
    SR = f0 + FIELD_ROWS.S
    TR = f0 + FIELD_ROWS.T
    UR = f0 + FIELD_ROWS.U
    ZW = f0 + FIELD_ROWS.ZW
    re0 = f0 + FIELD_ROWS.SIZE  # reₘ rows, then imₘ, X1, Y1, X3, Y3, X4, Y4 (m1 rows each)
    im0 = re0 + m1
    x10 = re0 + 2 * m1
    b0 = re0 + 8 * m1  # Bₙₘ at b0 + n size + m
    # |r|⁻² (a division) and |r|⁻¹ (a power)
    if k == 0:
        S[W, 0] = 1.0 / S[r2, 0]
        S[RI, 0] = 1.0 / math.sqrt(S[r2, 0])
    else:
        acc = 0.0
        for j in range(1, k + 1):
            acc += S[r2, j] * S[W, k - j]
        S[W, k] = -acc * S[W, 0]
        S[RI, k] = power_order(S, r2, RI, k, -0.5)
    S[SR, k] = cauchy(S, xi, RI, k)
    S[TR, k] = cauchy(S, yi, RI, k)
    S[UR, k] = cauchy(S, zi, RI, k)
    S[ZW, k] = cauchy(S, zi, W, k)
    # Bₙₘ = ρⁿ Āₙₘ(u), m ≤ mmax + 1 (the gradient reads one order more)
    S[b0, k] = 1.0 if k == 0 else 0.0
    for n in range(1, top + 1):
        row = b0 + n * size
        if n - 1 <= m1:  # (Bₙ,ₙ₋₁ needs Bₙₙ)
            S[row + n, k] = d[fo + F_DIAG * sq + n * size] * a * cauchy(S, RI, row - size + n - 1, k)
        if n - 1 <= m1:
            S[row + n - 1, k] = d[fo + F_OFF * sq + n * size] * cauchy(S, UR, row + n, k)
        for m in range(min(n - 1, m1 + 1)):
            q1 = row - size + m
            q2 = row - 2 * size + m
            c1 = 0.0
            c2 = 0.0
            for j in range(k + 1):
                c1 += S[ZW, j] * S[q1, k - j]
                c2 += S[W, j] * S[q2, k - j]
            fnm = fo + n * size + m
            S[row + m, k] = d[fnm + F_N1 * sq] * a * c1 - d[fnm + F_N2 * sq] * (a * a) * c2
    # (s + i t)ᵐ
    S[re0, k] = 1.0 if k == 0 else 0.0
    S[im0, k] = 0.0
    for m in range(1, m1):
        c1 = 0.0
        c2 = 0.0
        for j in range(k + 1):
            s = S[SR, j]
            t = S[TR, j]
            c1 += s * S[re0 + m - 1, k - j] - t * S[im0 + m - 1, k - j]
            c2 += s * S[im0 + m - 1, k - j] + t * S[re0 + m - 1, k - j]
        S[re0 + m, k] = c1
        S[im0 + m, k] = c2
    # the linear combinations over n, then their products with reₘ, imₘ
    p1 = p2 = p3 = p4 = 0.0
    for m in range(m1):
        x1 = y1 = x3 = y3 = x4 = y4 = 0.0
        for n in range(m, nmax + 1):
            c = d[co + n * n1 + m]
            sn = d[so + n * n1 + m]
            fnm = fo + n * size + m
            b = S[b0 + n * size + m, k]
            x1 += m * c * b
            y1 += m * sn * b
            if m < n:
                b = d[fnm + F_NQ1 * sq] * S[b0 + n * size + m + 1, k]
                x3 += c * b
                y3 += sn * b
            b = d[fnm + F_NQ2 * sq] * S[b0 + (n + 1) * size + m + 1, k]
            x4 += c * b
            y4 += sn * b
        S[x10 + m, k] = x1
        S[x10 + m1 + m, k] = y1
        S[x10 + 2 * m1 + m, k] = x3
        S[x10 + 3 * m1 + m, k] = y3
        S[x10 + 4 * m1 + m, k] = x4
        S[x10 + 5 * m1 + m, k] = y4
        X1 = x10 + m
        Y1 = x10 + m1 + m
        X3 = x10 + 2 * m1 + m
        Y3 = x10 + 3 * m1 + m
        X4 = x10 + 4 * m1 + m
        Y4 = x10 + 5 * m1 + m
        for j in range(k + 1):
            re = S[re0 + m, k - j]
            im = S[im0 + m, k - j]
            p3 += S[X3, j] * re + S[Y3, j] * im
            p4 += S[X4, j] * re + S[Y4, j] * im
            if m > 0:
                re = S[re0 + m - 1, k - j]
                im = S[im0 + m - 1, k - j]
                x = S[X1, j]
                y = S[Y1, j]
                p1 += x * re + y * im
                p2 += y * re - x * im
    S[f0 + FIELD_ROWS.P1, k] = p1
    S[f0 + FIELD_ROWS.P2, k] = p2
    S[f0 + FIELD_ROWS.P3, k] = p3
    S[f0 + FIELD_ROWS.P4, k] = p4
    Q4 = f0 + FIELD_ROWS.Q4
    S[Q4, k] = cauchy(S, W, f0 + FIELD_ROWS.P4, k)
    g = mu / a
    gx = mu * cauchy(S, W, f0 + FIELD_ROWS.P1, k) - g * cauchy(S, xi, Q4, k)
    gy = mu * cauchy(S, W, f0 + FIELD_ROWS.P2, k) - g * cauchy(S, yi, Q4, k)
    gz = mu * cauchy(S, W, f0 + FIELD_ROWS.P3, k) - g * cauchy(S, zi, Q4, k)
    return gx, gy, gz

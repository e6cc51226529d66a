"""Compiled special functions for the exact torque-free motion: Jacobi sn, cn, dn, the complete
integral K, Carlson's symmetric integrals RF, RC, RD, RJ and Legendre's Π.

numba cannot call :mod:`scipy.special`, so these are written out here as plain-float kernels
(valid Python with the JIT disabled). Conventions follow DLMF ch. 19 and 22 (parameter
``m = k²``); every function that is ill-conditioned near ``m = 1`` also takes the
*complementary* parameter ``m1 = 1 − m``, which callers compute from differences of the data
(never as ``1 − m``), so the separatrix of the rigid body costs no accuracy.

Algorithms
----------
* ``K(m)``: arithmetic–geometric mean, ``K = π / (2 AGM(1, √m1))`` (DLMF 19.8.5).
* sn, cn, dn: the argument is reduced by the period ``2K`` to ``r ∈ [−K, K]``, then to
  ``[0, K/2]`` with the quarter-period formulas ``sn(K − w) = cn w / dn w``,
  ``cn(K − w) = k' sn w / dn w``, ``dn(K − w) = k' / dn w`` (DLMF 22.4.3 table), which keep full
  *relative* accuracy near the zero of cn. On ``[0, K/2]``: for ``m ≤ 1/2`` four descending
  Landen (Gauss) steps (DLMF 22.7.1–3, A&S 16.12) to a parameter below 1e-20 and the first-order
  trigonometric approximation (A&S 16.13); for ``m > 1/2`` four ascending Landen steps
  (DLMF 22.7.4–6, A&S 16.14), driven by ``m1`` so that the complementary parameters are exact,
  to ``m1 < 1e-20`` and the first-order hyperbolic approximation (A&S 16.15). No step subtracts
  nearly equal numbers on ``[0, K/2]``.
* RF, RD, RJ: Carlson's duplication algorithm with the fifth-order series (Carlson 1995,
  Numer. Algorithms 10, 13–26; DLMF 19.36.1–2); RJ's sum uses ``RC(α_m, β_m)`` (Carlson 1995
  eq. 2.36). RC: closed form (DLMF 19.2.17–19).
* Π(n; φ|m) = sin φ RF(c², Δ², 1) + (n/3) sin³φ RJ(c², Δ², 1, 1 − n sin²φ) (DLMF 19.25.14),
  for ``|φ| ≤ π/2``, evaluated from ``(sin φ, cos φ, Δ)`` = ``(sn, cn, dn)`` directly.
"""

from __future__ import annotations

import math

from orbit._shared_jit import jit

__all__ = [
    "ellipf_sc",
    "ellipj",
    "ellipj_reduced",
    "ellipk",
    "ellipkm1",
    "ellippi_complete",
    "ellippi_sc",
    "elliprc",
    "elliprd",
    "elliprf",
    "elliprf_rj",
    "elliprj",
]

_PI = math.pi
_INF = math.inf
_NAN = math.nan
_MAXIT = 200
# Carlson (1995): stop when 4^-m Q < |A_m| with Q = c * max|A0 - x|; c = (3 r)^(-1/6) for RF,
# (r/4)^(-1/6) for RD and RJ, r the relative truncation error (here r = 2^-53).
_R = 2.0**-53
_CF = (3.0 * _R) ** (-1.0 / 6.0)
_CJ = (0.25 * _R) ** (-1.0 / 6.0)


# --------------------------------------------------------------------------------------------
# complete integral of the first kind
# --------------------------------------------------------------------------------------------


@jit
def ellipkm1(p):
    """Complete elliptic integral of the first kind K(m) at m = 1 − p (p ≥ 0, like scipy's).

    AGM: K = π / (2 AGM(1, √p)) (DLMF 19.8.5). Returns inf at p = 0.
    """
    if p == 0.0:
        return _INF
    a = 1.0
    b = math.sqrt(p)
    for _ in range(_MAXIT):
        if abs(a - b) <= 1.5e-8 * a:
            break
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    # AGM = (a + b)/2 - O((a - b)^2 / a): below 1e-17 relative after the test above
    return _PI / (a + b)


@jit
def ellipk(m):
    """K(m) for m ≤ 1 (use :func:`ellipkm1` near m = 1)."""
    return ellipkm1(1.0 - m)


# --------------------------------------------------------------------------------------------
# Carlson's symmetric integrals
# --------------------------------------------------------------------------------------------


@jit
def elliprc(x, y):
    """Carlson's degenerate integral RC(x, y), x ≥ 0, y ≠ 0 (Cauchy principal value if y < 0).

    Closed forms (DLMF 19.2.17–19).
    """
    if y < 0.0:
        # DLMF 19.2.20: principal value
        return math.sqrt(x / (x - y)) * elliprc(x - y, -y)
    if x == y:
        return 1.0 / math.sqrt(x)
    e = (y - x) / x if x > 0.0 else 1.0
    if abs(e) < 1e-3:
        # RC = x^-1/2 Σ (-e)^k / (2k + 1) (atan(√e)/√e, atanh(√-e)/√-e); truncation < e^6/13
        ser = 1.0 - e * (1.0 / 3.0 - e * (0.2 - e * (1.0 / 7.0 - e * (1.0 / 9.0 - e / 11.0))))
        return ser / math.sqrt(x)
    if x < y:
        d = y - x
        sd = math.sqrt(d)
        return math.atan2(sd, math.sqrt(x)) / sd
    d = x - y
    sd = math.sqrt(d)
    if d < 0.5 * x:
        return math.atanh(sd / math.sqrt(x)) / sd
    if y == 0.0:
        return _INF
    return math.log((math.sqrt(x) + sd) / math.sqrt(y)) / sd


@jit
def elliprf(x, y, z):
    """Carlson's RF(x, y, z) for x, y, z ≥ 0, at most one of them zero.

    Duplication with the fifth-order series (Carlson 1995, DLMF 19.36.1).
    """
    A0 = (x + y + z) / 3.0
    if A0 == 0.0:
        return _INF
    Q = _CF * max(abs(A0 - x), abs(A0 - y), abs(A0 - z))
    xm, ym, zm, Am = x, y, z, A0
    f = 1.0
    for _ in range(_MAXIT):
        if f * Q < abs(Am):
            break
        sx, sy, sz = math.sqrt(xm), math.sqrt(ym), math.sqrt(zm)
        lam = sx * sy + sx * sz + sy * sz
        xm = 0.25 * (xm + lam)
        ym = 0.25 * (ym + lam)
        zm = 0.25 * (zm + lam)
        Am = 0.25 * (Am + lam)
        f *= 0.25
    else:
        return _INF
    X = (A0 - x) * f / Am
    Y = (A0 - y) * f / Am
    Z = -(X + Y)
    E2 = X * Y - Z * Z
    E3 = X * Y * Z
    return (1.0 - E2 / 10.0 + E3 / 14.0 + E2 * E2 / 24.0 - 3.0 * E2 * E3 / 44.0) / math.sqrt(Am)


@jit
def elliprd(x, y, z):
    """Carlson's RD(x, y, z) = RJ(x, y, z, z), x, y ≥ 0 (not both zero), z > 0.

    Duplication with the fifth-order series (Carlson 1995).
    """
    A0 = (x + y + 3.0 * z) / 5.0
    Q = _CJ * max(abs(A0 - x), abs(A0 - y), abs(A0 - z))
    xm, ym, zm, Am = x, y, z, A0
    f = 1.0
    s = 0.0
    for _ in range(_MAXIT):
        if f * Q < abs(Am):
            break
        sx, sy, sz = math.sqrt(xm), math.sqrt(ym), math.sqrt(zm)
        lam = sx * sy + sx * sz + sy * sz
        s += f / (sz * (zm + lam))
        xm = 0.25 * (xm + lam)
        ym = 0.25 * (ym + lam)
        zm = 0.25 * (zm + lam)
        Am = 0.25 * (Am + lam)
        f *= 0.25
    else:
        return _INF
    X = (A0 - x) * f / Am
    Y = (A0 - y) * f / Am
    Z = -(X + Y) / 3.0
    XY = X * Y
    Z2 = Z * Z
    E2 = XY - 6.0 * Z2
    E3 = (3.0 * XY - 8.0 * Z2) * Z
    E4 = 3.0 * (XY - Z2) * Z2
    E5 = XY * Z2 * Z
    ser = (
        1.0
        - 3.0 * E2 / 14.0
        + E3 / 6.0
        + 9.0 * E2 * E2 / 88.0
        - 3.0 * E4 / 22.0
        - 9.0 * E2 * E3 / 52.0
        + 3.0 * E5 / 26.0
    )
    return f * ser / (Am * math.sqrt(Am)) + 3.0 * s


@jit
def elliprf_rj(x, y, z, p):
    """(RF(x, y, z), RJ(x, y, z, p)) in one duplication loop (they share x, y, z).

    x, y, z ≥ 0 with at most one zero, p > 0. Carlson (1995), with RJ's sum written as
    Σ 4^-m RC(α_m, β_m) (his eq. 2.36), whose arguments carry no cancellation.
    """
    Af0 = (x + y + z) / 3.0
    Aj0 = (x + y + z + 2.0 * p) / 5.0
    Qf = _CF * max(abs(Af0 - x), abs(Af0 - y), abs(Af0 - z))
    Qj = _CJ * max(abs(Aj0 - x), abs(Aj0 - y), abs(Aj0 - z), abs(Aj0 - p))
    xm, ym, zm, pm, Af, Aj = x, y, z, p, Af0, Aj0
    f = 1.0
    s = 0.0
    for _ in range(_MAXIT):
        if f * Qf < abs(Af) and f * Qj < abs(Aj):
            break
        sx, sy, sz = math.sqrt(xm), math.sqrt(ym), math.sqrt(zm)
        lam = sx * sy + sx * sz + sy * sz
        # Carlson (1995) eq. 2.36: both arguments of RC are sums of positive terms
        alpha = pm * (sx + sy + sz) + sx * sy * sz
        alpha *= alpha
        beta = pm + lam
        beta *= beta * pm
        s += f * elliprc(alpha, beta)
        xm = 0.25 * (xm + lam)
        ym = 0.25 * (ym + lam)
        zm = 0.25 * (zm + lam)
        pm = 0.25 * (pm + lam)
        Af = 0.25 * (Af + lam)
        Aj = 0.25 * (Aj + lam)
        f *= 0.25
    else:
        return _INF, _INF
    # RF
    X = (Af0 - x) * f / Af
    Y = (Af0 - y) * f / Af
    Z = -(X + Y)
    E2 = X * Y - Z * Z
    E3 = X * Y * Z
    rf = (1.0 - E2 / 10.0 + E3 / 14.0 + E2 * E2 / 24.0 - 3.0 * E2 * E3 / 44.0) / math.sqrt(Af)
    # RJ
    X = (Aj0 - x) * f / Aj
    Y = (Aj0 - y) * f / Aj
    Z = (Aj0 - z) * f / Aj
    P = -0.5 * (X + Y + Z)
    XYZ = X * Y * Z
    P2 = P * P
    E2 = X * Y + X * Z + Y * Z - 3.0 * P2
    E3 = XYZ + 2.0 * E2 * P + 4.0 * P2 * P
    E4 = (2.0 * XYZ + E2 * P + 3.0 * P2 * P) * P
    E5 = XYZ * P2
    ser = (
        1.0
        - 3.0 * E2 / 14.0
        + E3 / 6.0
        + 9.0 * E2 * E2 / 88.0
        - 3.0 * E4 / 22.0
        - 9.0 * E2 * E3 / 52.0
        + 3.0 * E5 / 26.0
    )
    rj = f * ser / (Aj * math.sqrt(Aj)) + 3.0 * s
    return rf, rj


@jit
def elliprj(x, y, z, p):
    """Carlson's RJ(x, y, z, p) for x, y, z ≥ 0 (at most one zero) and p > 0."""
    return elliprf_rj(x, y, z, p)[1]


# --------------------------------------------------------------------------------------------
# Legendre's integral of the third kind
# --------------------------------------------------------------------------------------------


@jit
def ellippi_sc(n, s, c, d):
    """Π(n; φ|m) for |φ| ≤ π/2 from s = sin φ, c = cos φ ≥ 0, d = √(1 − m sin²φ) (DLMF 19.25.14).

    Requires 1 − n s² > 0 and not c = d = 0.
    """
    s2 = s * s
    if n == 0.0:
        return s * elliprf(c * c, d * d, 1.0)
    rf, rj = elliprf_rj(c * c, d * d, 1.0, 1.0 - n * s2)
    return s * rf + (n / 3.0) * s * s2 * rj


@jit
def ellippi_complete(n, m1, K):
    """Complete Π(n|m) = K + (n/3) RJ(0, m1, 1, 1 − n) for n < 1, m1 = 1 − m > 0 (DLMF 19.25.2)."""
    if n == 0.0:
        return K
    return K + (n / 3.0) * elliprj(0.0, m1, 1.0, 1.0 - n)


# --------------------------------------------------------------------------------------------
# Jacobi elliptic functions
# --------------------------------------------------------------------------------------------


@jit
def _sncndn_half(v, m, m1):
    """sn, cn, dn for 0 ≤ v ≤ K(m)/2, 0 ≤ m ≤ 1, m1 = 1 − m; a few ulp relative."""
    if m <= 0.5:
        # Descending Landen (Gauss) transformation, A&S 16.12 / DLMF 22.7.1-3:
        # k_{i+1} = (1 - k'_i)/(1 + k'_i) = m_i/(1 + k'_i)^2, k'_{i+1} = 2 sqrt(k'_i)/(1 + k'_i).
        kp = math.sqrt(m1)
        k1 = m / ((1.0 + kp) * (1.0 + kp))
        kp = 2.0 * math.sqrt(kp) / (1.0 + kp)
        k2 = k1 * k1 / ((1.0 + kp) * (1.0 + kp))
        kp = 2.0 * math.sqrt(kp) / (1.0 + kp)
        k3 = k2 * k2 / ((1.0 + kp) * (1.0 + kp))
        kp = 2.0 * math.sqrt(kp) / (1.0 + kp)
        k4 = k3 * k3 / ((1.0 + kp) * (1.0 + kp))
        mu = k4 * k4  # < 3e-21 for m <= 1/2
        w = v / (1.0 + k1) / (1.0 + k2) / (1.0 + k3) / (1.0 + k4)
        sw = math.sin(w)
        cw = math.cos(w)
        corr = 0.25 * mu * (w - sw * cw)  # A&S 16.13.1-3
        s = sw - corr * cw
        c = cw + corr * sw
        d = 1.0 - 0.5 * mu * sw * sw
        for k in (k4, k3, k2, k1):
            ks2 = k * s * s
            den = 1.0 + ks2
            s, c, d = (1.0 + k) * s / den, c * d / den, (1.0 - ks2) / den
        return s, c, d
    # Ascending Landen transformation, A&S 16.14 / DLMF 22.7.4-6, driven by the complement:
    # e_{i+1} = mu1^(1/2) = (1 - k_i)/(1 + k_i) = m1_i/(1 + k_i)^2, k_{i+1} = 2 sqrt(k_i)/(1 + k_i).
    k = math.sqrt(m)
    e1 = m1 / ((1.0 + k) * (1.0 + k))
    k = 2.0 * math.sqrt(k) / (1.0 + k)
    e2 = e1 * e1 / ((1.0 + k) * (1.0 + k))
    k = 2.0 * math.sqrt(k) / (1.0 + k)
    e3 = e2 * e2 / ((1.0 + k) * (1.0 + k))
    k = 2.0 * math.sqrt(k) / (1.0 + k)
    e4 = e3 * e3 / ((1.0 + k) * (1.0 + k))
    mu1 = e4 * e4  # < 3e-21 for m >= 1/2
    w = v / (1.0 + e1) / (1.0 + e2) / (1.0 + e3) / (1.0 + e4)
    ew = math.exp(-w)
    t = math.tanh(w)
    sech = 2.0 * ew / (1.0 + ew * ew)
    corr = 0.0
    if mu1 > 0.0:
        sc = t / (sech * sech)  # sinh w cosh w
        corr = 0.25 * mu1 * sc
    wcorr = 0.25 * mu1 * w
    # A&S 16.15.1-3
    s = t + (corr - wcorr) * sech * sech
    c = sech - (corr - wcorr) * t * sech
    d = sech + (corr + wcorr) * t * sech
    for e in (e4, e3, e2, e1):
        d2 = d * d
        s, c, d = (1.0 + e) * s * c / d, (d2 - e) / ((1.0 - e) * d), (d2 + e) / ((1.0 + e) * d)
    return s, c, d


@jit
def ellipj_reduced(u, m, m1, K):
    """Jacobi functions at the reduced argument: returns (sn r, cn r, dn r, j) with
    u = 2 j K + r, r ∈ [−K, K] (so sn u = (−1)^j sn r, cn u = (−1)^j cn r, dn u = dn r).

    m ∈ [0, 1), m1 = 1 − m > 0 computed without cancellation, K = K(m).
    """
    x = u / (2.0 * K) + 0.5
    j = float(math.floor(x)) if abs(x) < 4.0e15 else x  # (beyond 2^52 x is integral)
    r = u - (2.0 * K) * j
    v = abs(r)
    if v <= 0.5 * K:
        s, c, d = _sncndn_half(v, m, m1)
    else:
        w = K - v
        if w < 0.0:
            w = 0.0
        s1, c1, d1 = _sncndn_half(w, m, m1)
        kp = math.sqrt(m1)
        # quarter-period shift (DLMF 22.4.3): sn(K-w) = cd w, cn(K-w) = k' sd w, dn(K-w) = k' nd w
        s = c1 / d1
        c = kp * s1 / d1
        d = kp / d1
    if r < 0.0:
        s = -s
    return s, c, d, j


@jit
def ellipf_sc(s, c, d):
    """F(φ|m) for |φ| ≤ π/2 from s = sin φ, c = cos φ ≥ 0, d = √(1 − m sin²φ) (DLMF 19.25.5).

    This inverts :func:`ellipj_reduced` on [−K, K]: u = F(am u | m).
    """
    return s * elliprf(c * c, d * d, 1.0)


@jit
def ellipj(u, m):
    """(sn, cn, dn)(u|m) for real u and 0 ≤ m ≤ 1 (m1 = 1 − m formed here; for m near 1 use
    :func:`ellipj_reduced` with an accurate complementary parameter)."""
    m1 = 1.0 - m
    if m1 <= 0.0:
        t = math.tanh(u)
        a = abs(u)
        ea = math.exp(-a)
        sech = 2.0 * ea / (1.0 + ea * ea)
        return t, sech, sech
    K = ellipkm1(m1)
    s, c, d, j = ellipj_reduced(u, m, m1, K)
    if j % 2.0 != 0.0:
        s = -s
        c = -c
    return s, c, d

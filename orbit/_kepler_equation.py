"""Compiled scalar kernels of Kepler's equation (plain floats in, floats out): its solvers,
elliptic and hyperbolic, with their cancellation-free series and error-free transformations, the
conversions between the anomalies, and the loops of the vectorised public functions of
:mod:`orbit.kepler`. Decorated with :func:`orbit._shared_jit.jit` (compiled lazily); no argument
checking (:mod:`orbit.kepler` validates at the boundary). The orbit on its element array is
:mod:`orbit._kernels`.

Kepler's equation, elliptic (M = E − e sin E)
---------------------------------------------
M is reduced to [−π, π] with a three-part 2π (Cody & Waite) and an exact product, so the
reduced value (a double-double) is exact to ~1e-32 k; the result for the original M is
``E = M + (E_r − M_r)`` (because E − M = e sin E is 2π-periodic), continuous in M. On [0, π]
(odd symmetry) the solver starts from Markley's (1995, Celest. Mech. Dyn. Astr. 63, 101)
cubic starter (his α of eq. 20, d, q, r of eqs. 5, 9, 10; relative error below 2.9e-4
everywhere; its cube root by a bit-trick inverse cube root and three division-free Newton steps,
not libm's cbrt, which cost a third of the solve) and applies one sixth-order correction (series
reversion of the degree-5 Taylor polynomial, one division), with the residual E − e sin E − M
evaluated without cancellation:

* |E| < 1: E − e sin E = (1 − e) E + e (E − sin E), with E − sin E and 1 − cos E from their
  Taylor series (no cancellation as e → 1 and M → 0, the hard corner), truncated where the
  dropped terms move E by a fraction of an ulp (``_x_minus_sin_kepler``, ``_one_minus_cos_kepler``);
* |E| >= 1: (E − M) − e sin E with an error-free sum and product (double-double), so the only
  rounding left is the one of ``sin``.

Hyperbolic (M = e sinh H − H)
-----------------------------
Starter: the smaller of two upper bounds of H (the root of the cubic (e − 1) H + e H³/6 = M,
and one monotone fixed-point step H <- asinh((M + H)/e) from asinh(M/(e − 1))); then Halley
steps until a step is below 1e-9 H (at most three on a 300 × 300 test grid over M in
[1e-12, 1e12], e − 1 in [1e-12, 1e4]), and a Newton polish
with the same careful residual (series for sinh H − H when |H| < 2.5). For M/e > 1e10 the
root is the fixed point of H = log(2(M + H)/e) to double precision (e^-2H < 1e-20), iterated
without overflow.
"""

from __future__ import annotations

import math

import numpy as np

from ._shared_jit import from_source, jit

# 2π = TWO_PI_1 + TWO_PI_2 + TWO_PI_3 to ~160 bits (computed with mpmath).
TWO_PI_1 = 6.283185307179586
TWO_PI_2 = 2.4492935982947064e-16
TWO_PI_3 = -5.989539619436679e-33
PI = math.pi
_SPLITTER = 134217729.0  # 2**27 + 1 (Dekker split)
# Reciprocals of the Taylor-series denominators (multiplying is much cheaper than dividing).
_R3 = 1.0 / 3.0
_R6 = 1.0 / 6.0
_R24 = 1.0 / 24.0
_R120 = 1.0 / 120.0
_R12 = 1.0 / 12.0
_R20 = 1.0 / 20.0
_R30 = 1.0 / 30.0
_R42 = 1.0 / 42.0
_R56 = 1.0 / 56.0
_R72 = 1.0 / 72.0
_R90 = 1.0 / 90.0
_R110 = 1.0 / 110.0
_R132 = 1.0 / 132.0
_R156 = 1.0 / 156.0
_R182 = 1.0 / 182.0
_R210 = 1.0 / 210.0
_R240 = 1.0 / 240.0
_R272 = 1.0 / 272.0
_R306 = 1.0 / 306.0
_R342 = 1.0 / 342.0
_R380 = 1.0 / 380.0
_R420 = 1.0 / 420.0
_R462 = 1.0 / 462.0
_R506 = 1.0 / 506.0
_R552 = 1.0 / 552.0
_R600 = 1.0 / 600.0
_R650 = 1.0 / 650.0
_R702 = 1.0 / 702.0
_MK_A = 3.0 * PI * PI / (PI * PI - 6.0)  # Markley's α (his eq. 20) = _MK_A + _MK_B (π − M)/(1 + e)
_MK_B = 1.6 * PI / (PI * PI - 6.0)
_INV_CBRT_MAGIC = np.int64(0x553EF0FF289DD794)  # Moroz et al. (2021), inverse cube root
_HYP_SERIES = 2.5  # |H| below which sinh H − H and cosh H − 1 come from their series
_HYP_LOG_REGIME = 1.0e10  # M/e above which H = log(2(M + H)/e) to double precision


# Error-free transformations (Knuth two-sum, Dekker two-product; no FMA needed).
@jit
def _two_sum(a, b):
    s = a + b
    bb = s - a
    err = (a - (s - bb)) + (b - bb)
    return s, err


@jit
def _two_prod(a, b):
    p = a * b
    c = _SPLITTER * a
    ah = c - (c - a)
    al = a - ah
    c = _SPLITTER * b
    bh = c - (c - b)
    bl = b - bh
    err = ((ah * bh - p) + ah * bl + al * bh) + al * bl
    return p, err


@jit
def reduce_angle(x):
    """x = r + r_lo + 2πk with r + r_lo in [−π, π] (double-double) -> (r, r_lo, k).

    k is returned as a float (an integer value). Exact reduction (error ~1e-32 k) for |k| < 2**26.
    """
    if -PI <= x <= PI:
        return x, 0.0, 0.0
    k = math.floor(x / TWO_PI_1 + 0.5)
    ph, pl = _two_prod(k, TWO_PI_1)
    s = x - ph  # exact: x and k·2π agree to within a factor 2 (Sterbenz)
    corr = pl + (k * TWO_PI_2 + k * TWO_PI_3)
    r = s - corr
    r_lo = (s - r) - corr
    return r, r_lo, k


# ---------------------------------------------------------------------------------------------
# Cancellation-free pieces of Kepler's equation.
@jit
def _x_minus_sin(x):
    """x − sin x for |x| <= 1 by its Taylor series (relative error ~1 ulp)."""
    y = x * x
    s = 1.0 - y * _R420
    s = 1.0 - y * _R342 * s
    s = 1.0 - y * _R272 * s
    s = 1.0 - y * _R210 * s
    s = 1.0 - y * _R156 * s
    s = 1.0 - y * _R110 * s
    s = 1.0 - y * _R72 * s
    s = 1.0 - y * _R42 * s
    s = 1.0 - y * _R20 * s
    return x * y * _R6 * s


@jit
def _one_minus_cos(x):
    """1 − cos x for |x| <= 1 by its Taylor series."""
    y = x * x
    c = 1.0 - y * _R380
    c = 1.0 - y * _R306 * c
    c = 1.0 - y * _R240 * c
    c = 1.0 - y * _R182 * c
    c = 1.0 - y * _R132 * c
    c = 1.0 - y * _R90 * c
    c = 1.0 - y * _R56 * c
    c = 1.0 - y * _R30 * c
    c = 1.0 - y * _R12 * c
    return 0.5 * y * c


@jit
def _x_minus_sin_kepler(x):
    """x − sin x for |x| <= 1, truncated for the Kepler residual (relative error < 5e-17).

    The dropped terms x^19/19! − ... change E − e sin E − M by at most e E³/6 · 6E^16/19!,
    below 1.7e-17 E after division by f1 >= E²/2 (e -> 1): a fraction of an ulp.
    """
    y = x * x
    s = 1.0 - y * _R272
    s = 1.0 - y * _R210 * s
    s = 1.0 - y * _R156 * s
    s = 1.0 - y * _R110 * s
    s = 1.0 - y * _R72 * s
    s = 1.0 - y * _R42 * s
    s = 1.0 - y * _R20 * s
    return x * y * _R6 * s


@jit
def _one_minus_cos_kepler(x):
    """1 − cos x for |x| <= 1, truncated for the Kepler derivative (relative error < 3e-16).

    It enters only f1 = 1 − e cos E, the divisor of a correction of relative size < 2.9e-4,
    so its error moves E by less than 1e-19 E.
    """
    y = x * x
    c = 1.0 - y * _R240
    c = 1.0 - y * _R182 * c
    c = 1.0 - y * _R132 * c
    c = 1.0 - y * _R90 * c
    c = 1.0 - y * _R56 * c
    c = 1.0 - y * _R30 * c
    c = 1.0 - y * _R12 * c
    return 0.5 * y * c


@jit
def _sinh_minus_x(x):
    """sinh x − x for |x| <= 2.5 by its Taylor series (all terms of one sign, 13 terms)."""
    y = x * x
    s = 1.0 + y * _R702
    s = 1.0 + y * _R600 * s
    s = 1.0 + y * _R506 * s
    s = 1.0 + y * _R420 * s
    s = 1.0 + y * _R342 * s
    s = 1.0 + y * _R272 * s
    s = 1.0 + y * _R210 * s
    s = 1.0 + y * _R156 * s
    s = 1.0 + y * _R110 * s
    s = 1.0 + y * _R72 * s
    s = 1.0 + y * _R42 * s
    s = 1.0 + y * _R20 * s
    return x * y * _R6 * s


@jit
def _cosh_minus_one(x):
    """cosh x − 1 for |x| <= 2.5 by its Taylor series (13 terms)."""
    y = x * x
    c = 1.0 + y * _R650
    c = 1.0 + y * _R552 * c
    c = 1.0 + y * _R462 * c
    c = 1.0 + y * _R380 * c
    c = 1.0 + y * _R306 * c
    c = 1.0 + y * _R240 * c
    c = 1.0 + y * _R182 * c
    c = 1.0 + y * _R132 * c
    c = 1.0 + y * _R90 * c
    c = 1.0 + y * _R56 * c
    c = 1.0 + y * _R30 * c
    c = 1.0 + y * _R12 * c
    return 0.5 * y * c


@jit
def _pow_two_thirds(x):
    """x^(2/3) for a normal x in [1e-300, 1e300], relative error below 1e-9, without libm.

    x^(2/3) = x · x^(−1/3); y = x^(−1/3) from the exponent-halving bit trick with Moroz et
    al.'s constant (relative error 3.4e-2) and three Newton steps y <- (4y − x y⁴)/3 (errors
    2.4e-3, 1.1e-5, 2.6e-10), with no division. Markley's starter only needs 2.9e-4, and the
    libm cube root cost more than the rest of the starter.
    """
    i = np.int64(_INV_CBRT_MAGIC - np.float64(x).view(np.int64) // 3)
    y = i.view(np.float64)
    x3 = x * _R3
    for _ in range(3):
        y2 = y * y
        y = 4.0 * _R3 * y - (x3 * y2) * y2  # (x y²) y² ~ x^(−1/3): no overflow
    return x * y


@jit
def _kepler_residual(E, M, M_lo, e, ome):
    """(E − e sin E − (M + M_lo), 1 − e cos E, sin E, cos E) for 0 <= E <= π, ome = 1 − e."""
    if E < 1.0:
        S = _x_minus_sin_kepler(E)
        C = _one_minus_cos_kepler(E)
        p1, q1 = _two_prod(ome, E)
        p2, q2 = _two_prod(e, S)
        s, q3 = _two_sum(p1, p2)
        d, q4 = _two_sum(s, -M)
        f0 = d + (((q1 + q2) + q3 + q4) - M_lo)
        return f0, ome + e * C, E - S, 1.0 - C
    sn = math.sin(E)
    cs = math.cos(E)
    d, q1 = _two_sum(E, -M)
    p, q2 = _two_prod(e, sn)
    f0 = (d - p) + ((q1 - q2) - M_lo)
    return f0, 1.0 - e * cs, sn, cs


@jit
def _kepler_E_core(M, M_lo, e):
    """Solve E − e sin E = M + M_lo for 0 <= M <= π, 0 <= e < 1."""
    if M == 0.0 and M_lo == 0.0:
        return 0.0
    if e == 0.0:
        return M + M_lo
    ome = 1.0 - e
    # Markley's starter: α (his eq. 20), d (eq. 5), q (eq. 9), r (eq. 10), E1 = cubic root.
    alpha = _MK_A + _MK_B * (PI - M) / (1.0 + e)  # (3π² + 1.6π(π − M)/(1 + e))/(π² − 6)
    d = 3.0 * ome + alpha * e
    q = 2.0 * alpha * d * ome - M * M
    r = 3.0 * alpha * d * (d - ome) * M + M * M * M
    w = _pow_two_thirds(abs(r) + math.sqrt(q * q * q + r * r))
    D = w * w + w * q + q * q
    E = (2.0 * r * w + M * D) / (d * D)  # (2rw/D + M)/d with one division
    if E > PI:
        E = PI
    # One sixth-order correction: the root δ of the degree-5 Taylor polynomial of
    # E − e sin E − M about E, by series reversion in x = −f0/f1 (one division instead of the
    # four of Markley's nested fifth-order corrector). With g = f0 + f1 δ + f2 δ²/2 + ...:
    #   δ = x − a x² + (2a² − b) x³ + (5ab − 5a³ − c) x⁴ + (14a⁴ − 21a²b + 6ac + 3b² − d) x⁵,
    #   a = f2/(2 f1), b = f3/(6 f1), c = f4/(24 f1), d = f5/(120 f1),
    #   f2 = e sin E, f3 = e cos E, f4 = −f2, f5 = −f3. The residual is evaluated without
    # cancellation, so the result is at rounding level: the starter's relative error is below
    # 2.9e-4 on the whole domain, which leaves a truncation error below 1e-18 E.
    f0, f1, sn, cs = _kepler_residual(E, M, M_lo, e, ome)
    inv = 1.0 / f1
    x = -f0 * inv
    f2 = e * sn * inv
    f3 = e * cs * inv
    a = 0.5 * f2
    b = f3 * _R6
    c = -f2 * _R24
    d = -f3 * _R120
    a2 = a * a
    c3 = 2.0 * a2 - b
    c4 = 5.0 * a * b - 5.0 * a2 * a - c
    c5 = 14.0 * a2 * a2 - 21.0 * a2 * b + 6.0 * a * c + 3.0 * b * b - d
    return E + x * (1.0 + x * (-a + x * (c3 + x * (c4 + x * c5))))


@jit
def _kepler_E_reduced(M, e):
    """-> (E_r, M_r, k): E_r solves Kepler's equation for M_r = M − 2πk in [−π, π]."""
    Mr, Mlo, k = reduce_angle(M)
    if Mr < 0.0 or (Mr == 0.0 and Mlo < 0.0):
        Er = -_kepler_E_core(-Mr, -Mlo, e)
    else:
        Er = _kepler_E_core(Mr, Mlo, e)
    return Er, Mr + Mlo, k


@jit
def kepler_E(M, e):
    """Eccentric anomaly E [rad] with E − e sin E = M, for 0 <= e < 1 and any real M [rad].

    Continuous in M: E(M + 2π) = E(M) + 2π up to rounding of the sum.
    """
    Er, Mr, k = _kepler_E_reduced(M, e)
    return _continuous_E(M, Er, Mr, k)


@jit
def _continuous_E(M, Er, Mr, k):
    """E from the reduced solution ``(Er, Mr, k)`` of :func:`_kepler_E_reduced`."""
    if k == 0.0:
        return Er
    # E − M = e sin E is 2π-periodic: E = M + (E_r − M_r), one rounding only.
    return M + (Er - Mr)


# ---------------------------------------------------------------------------------------------
@jit
def _hyp_residual(H, M, e, em1):
    """(e sinh H − H − M, e cosh H − 1, e sinh H, e cosh H) for H >= 0, em1 = e − 1."""
    if H < _HYP_SERIES:
        S = _sinh_minus_x(H)
        C = _cosh_minus_one(H)
        p1, q1 = _two_prod(em1, H)
        p2, q2 = _two_prod(e, S)
        s, q3 = _two_sum(p1, p2)
        d, q4 = _two_sum(s, -M)
        f0 = d + ((q1 + q2) + q3 + q4)
        return f0, em1 + e * C, e * (H + S), e * (1.0 + C)
    sh = math.sinh(H)
    ch = math.cosh(H)
    p, q1 = _two_prod(e, sh)
    d, q2 = _two_sum(H, M)
    f0 = (p - d) + (q1 - q2)
    return f0, e * ch - 1.0, e * sh, e * ch


@jit
def _kepler_H_core(M, e):
    """Solve e sinh H − H = M for M >= 0, e > 1 -> (H, number of Halley steps)."""
    if M == 0.0:
        return 0.0, 0
    if M / e > _HYP_LOG_REGIME:
        # e sinh H = M + H with e^-H negligible: H = log(2/e) + log(M + H), a contraction with
        # factor 1/(M + H) < 1e-10, so three steps converge from log(2M/e).
        l2e = math.log(2.0 / e)
        H = l2e + math.log(M)
        for _ in range(3):
            H = l2e + math.log(M + H)
        return H, 0
    em1 = e - 1.0
    # Upper bound 1: the root of the cubic (e − 1) H + e H³/6 = M (sinh H − H >= H³/6),
    # in the cancellation-free form H = 6M/e / (A² + AB + B²), A³ − B³ = 6M/e, AB = 2(e−1)/e.
    pp = 2.0 * em1 / e
    qq = 3.0 * M / e
    A = (qq + math.sqrt(qq * qq + pp * pp * pp)) ** (1.0 / 3.0)
    B = pp / A
    H = 2.0 * qq / (A * A + A * B + B * B)
    # Upper bound 2: asinh(M/(e − 1)) (sinh H >= H), sharpened by one monotone fixed-point step.
    Hb = math.asinh(M / em1)
    Hb = math.asinh((M + min(H, Hb)) / e)
    if Hb < H:
        H = Hb
    # Halley steps, stopped once a step is below 1e-9 H (at most 3 on the whole domain; the
    # bound 12 is a guard that is never reached, see tests/test_kepler.py).
    nit = 0
    while nit < 12:
        f0, f1, f2, _ = _hyp_residual(H, M, e, em1)
        dH = f0 / (f1 - 0.5 * f0 * f2 / f1)
        H = H - dH
        nit += 1
        if abs(dH) <= 1e-9 * H:
            break
    # After a step below 1e-9 H the Halley error is below 1e-27 H; polish the rounding.
    f0, f1, _, _ = _hyp_residual(H, M, e, em1)
    return H - f0 / f1, nit


@jit
def kepler_H(M, e):
    """Hyperbolic anomaly H with e sinh H − H = M, for e > 1 and any real M."""
    if M < 0.0:
        return -_kepler_H_core(-M, e)[0]
    return _kepler_H_core(M, e)[0]


@jit
def kepler_H_iterations_loop(M, e, out):
    """Number of Halley steps kepler_H takes (for the tests)."""
    for i in range(M.size):
        out[i] = _kepler_H_core(abs(M[i]), e[i])[1]


# ---------------------------------------------------------------------------------------------
# Anomaly conversions (scalar kernels; the public vectorised versions live in orbit.kepler).
@jit
def true_from_eccentric_scalar(E, e):
    """True anomaly f from E (elliptic), continuous in E: f = E at E = kπ."""
    Er, Er_lo, k = reduce_angle(E)
    Er = Er + Er_lo
    h = 0.5 * Er  # in [−π/2, π/2]: cos(E/2) >= 0, so the half-angle atan2 has no branch cut
    fr = 2.0 * math.atan2(math.sqrt(1.0 + e) * math.sin(h), math.sqrt(1.0 - e) * math.cos(h))
    if k == 0.0:
        return fr
    return E + (fr - Er)


@jit
def eccentric_from_true_scalar(f, e):
    """Eccentric anomaly E from f (elliptic), continuous in f."""
    fr, fr_lo, k = reduce_angle(f)
    fr = fr + fr_lo
    h = 0.5 * fr
    Er = 2.0 * math.atan2(math.sqrt(1.0 - e) * math.sin(h), math.sqrt(1.0 + e) * math.cos(h))
    if k == 0.0:
        return Er
    return f + (Er - fr)


@jit
def mean_from_eccentric_scalar(E, e):
    """M = E − e sin E, cancellation-free for small |E| and e -> 1."""
    Er, Er_lo, k = reduce_angle(E)
    if k == 0.0 and abs(E) < 1.0:
        a = abs(E)
        p1, q1 = _two_prod(1.0 - e, a)
        p2, q2 = _two_prod(e, _x_minus_sin(a))
        v, q3 = _two_sum(p1, p2)
        v = v + ((q1 + q2) + q3)
        return v if E >= 0.0 else -v
    return E - e * math.sin(Er + Er_lo)


@jit
def true_from_hyperbolic_scalar(H, e):
    """True anomaly f from H: tan(f/2) = sqrt((e + 1)/(e − 1)) tanh(H/2)."""
    h = 0.5 * H
    return 2.0 * math.atan2(math.sqrt(e + 1.0) * math.sinh(h), math.sqrt(e - 1.0) * math.cosh(h))


@jit
def hyperbolic_from_true_scalar(f, e):
    """Hyperbolic anomaly H from f, |f| < acos(−1/e) (not checked here)."""
    h = 0.5 * f
    x = math.sqrt(e - 1.0) * math.sin(h)
    y = math.sqrt(e + 1.0) * math.cos(h)
    return 2.0 * math.atanh(x / y)  # tanh(H/2) = sqrt((e − 1)/(e + 1)) tan(f/2)


@jit
def mean_from_hyperbolic_scalar(H, e):
    """M = e sinh H − H, cancellation-free for small |H| and e -> 1."""
    a = abs(H)
    if a < _HYP_SERIES:
        v = (e - 1.0) * a + e * _sinh_minus_x(a)
    else:
        v = e * math.sinh(a) - a
    return v if H >= 0.0 else -v


# Loops for the vectorised public API (compiled whole, one call per array): the value of
# element i from x = X[i] and e = E[i], one loop generated per line.
_LOOPS = {
    "kepler_E_loop": "kepler_E(x, e)",
    "kepler_H_loop": "kepler_H(x, e)",
    "true_from_eccentric_loop": "true_from_eccentric_scalar(x, e)",
    "eccentric_from_true_loop": "eccentric_from_true_scalar(x, e)",
    "mean_from_eccentric_loop": "mean_from_eccentric_scalar(x, e)",
    "true_from_hyperbolic_loop": "true_from_hyperbolic_scalar(x, e)",
    "hyperbolic_from_true_loop": "hyperbolic_from_true_scalar(x, e)",
    "mean_from_hyperbolic_loop": "mean_from_hyperbolic_scalar(x, e)",
    "true_from_mean_loop": "true_from_eccentric_scalar(kepler_E(x, e), e)",
    "true_from_mean_hyperbolic_loop": "true_from_hyperbolic_scalar(kepler_H(x, e), e)",
    "mean_from_true_loop": "mean_from_eccentric_scalar(eccentric_from_true_scalar(x, e), e)",
    "mean_from_true_hyperbolic_loop": (
        "mean_from_hyperbolic_scalar(hyperbolic_from_true_scalar(x, e), e)"
    ),
}
globals().update(
    from_source(
        "".join(
            f"def {name}(X, E, out):\n    for i in range(X.size):\n"
            f"        x = X[i]\n        e = E[i]\n        out[i] = {value}\n\n"
            for name, value in _LOOPS.items()
        ),
        globals(),
        __name__,
        __file__,
    )
)

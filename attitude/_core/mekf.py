"""The multiplicative extended Kalman filter (MEKF) of attitude and gyro bias, compiled.

Lefferts, Markley & Shuster, "Kalman filtering for spacecraft attitude estimation", J. Guidance
5, 1982; Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*,
2014, Sect. 6.2. The estimate is a unit quaternion q̂ (body → space, the package's convention)
and a gyro bias β̂; the filter's state is the 6-vector error δx = (δθ, δβ) with
q = q̂∘δq(δθ), δq(δθ) ≈ (1, δθ/2), and β = β̂ + δβ, its covariance P (6 × 6).

Propagation over a tick Δt with the rate ω̂ = ω̃ − β̂ held: q̂ ← q̂∘exp(ω̂ Δt/2) (exact for the
held rate), P ← Φ P Φᵀ + Q with (Markley & Crassidis eqs. 6.83–6.85, W = [ω̂×], w = |ω̂|)

    Φ₁₁ = 1 − W sin(wΔt)/w + W² (1 − cos(wΔt))/w²
    Φ₁₂ = W (1 − cos(wΔt))/w² − 1 Δt − W² (wΔt − sin(wΔt))/w³,   Φ₂₁ = 0, Φ₂₂ = 1
    Q₁₁ = (σ_v² Δt + σ_u² Δt³/3) 1,  Q₁₂ = −σ_u² Δt²/2 1,  Q₂₂ = σ_u² Δt 1.

q̂ is propagated every tick (the control law reads it); P only when it is read (an update)
and at least every :data:`SPAN_TICKS` ticks, in one step over the ticks since with the mean
of their held rates, ω̄ = Σ ω̂ᵢ Δtᵢ / Σ Δtᵢ. At rest that one step is the product of the
per-tick steps, Q included (Farrenkopf's Q is the closed-form integral of the noise over the
interval). At a constant rate Φ is still their product (Φ(Δt₁ + Δt₂) = Φ(Δt₂) Φ(Δt₁)) and Q
differs by its rotation within the span, which the closed form neglects as it does within a
tick (O(|ω| nΔt) of Q's share of P). A rate varying within the span also changes Φ₁₂, by the
order the rates came in: |δω| (nΔt)²/2 of it, first order in the variation δω; on the sensor
day of the benchmark (ω ~ 1e-5 rad/s, gyro noise 5e-5 rad/s a tick, n = 5) that reaches P
through the bias covariance at ~1e-9 of √(P_ii P_jj) (tests/test_sensors.py). The record
reads P advanced to its tick in a scratch copy (:func:`mekf_covariance_at`): whether a tick is
recorded changes nothing in the filter.

Updates (Joseph form P = (1 − KH) P (1 − KH)ᵀ + K R Kᵀ, then the reset q̂ ← q̂∘δq(δθ),
β̂ ← β̂ + δβ, δx ← 0):

* star tracker q̃: the residual 2 vec(q̂⁻¹∘q̃) (scalar part >= 0), H = [1 0], R its noise
  rotated from the sensor frame to body axes;
* a body-frame measurement b̃ of a known space vector r (magnetometer: the IGRF field of the
  same tables, an idealisation the docs state; Sun sensor: the Sun's direction): the residual
  b̃ − A(q̂) r, H = [[b̂×] 0], R = σ² 1.

Layout of the filter state ``es`` (offsets E_*), all in one float64 array with its scratch
matrices, so it compiles without allocations.
"""

from __future__ import annotations

import math

from orbit._layout import Field, Gap, layout
from orbit._shared_jit import inline_copy, jit

from .fma import fma as F
from .quat import SERIES_X2, conj_mul, half_angle, mul, rotate_inverse, shorter

E = layout(
    "filter state",
    q=Field(4, "", "q̂"),
    b=Field(3, "rad/s", "β̂"),
    p=Field(36, "rad, rad/s", "P (row-major)", (6, 6)),
    init=Field(1, "", "1 once initialised"),
    wsum=Field(3, "rad", "Σ ω̂ Δt over the ticks P has not been propagated over yet"),
    span=Field(1, "s", "Σ Δt over those ticks"),
    nspan=Field(1, "", "their number"),
    _a=Gap(1),
    phi=Field(36, "", "scratch Φ"),
    tmp=Field(36, "", "scratch"),
    k=Field(18, "", "gain (6 × 3)"),
    s=Field(18, "", "innovation covariance and its inverse (9 + 9)"),
    size=160,
)

# parameters (a record of the flight software's program)
EP = layout(
    "filter parameters",
    sv=Field(1, "rad/s^0.5", "σ_v of the gyro model"),
    su=Field(1, "rad/s^1.5", "σ_u"),
    p0=Field(6, "rad2, rad2/s2", "initial covariance diagonal"),
    init=Field(1, "", "0: from the first valid star tracker measurement; 1: the given q0, b0"),
    q0=4,
    b0=Field(3, "rad/s"),
    st_r=Field(9, "rad2", "star tracker noise covariance in body axes", (3, 3)),
    mag=Field(1, "T", "magnetometer σ (0: not used)"),
    sun=Field(1, "", "Sun sensor σ (unit vector; 0: not used)"),
)


#: The most ticks P's propagation is deferred over (:func:`mekf_covariance`).
SPAN_TICKS = 10

# (x − sin x)/x³ by its series in x² (Horner's rule; truncation (wΔt)¹⁰/13! < 3e-21 relative
# below the series' threshold)
_T0 = 1.0 / 6.0
_T1 = -1.0 / 120.0
_T2 = 1.0 / 5040.0
_T3 = -1.0 / 362880.0
_T4 = 1.0 / 39916800.0


@jit(inline="always")
def _p(es, i, j):
    return es[E.P + 6 * i + j]


@jit
def mekf_init(es, ep, q0, b0):
    """Start the filter at (q0, b0) with the covariance diag(EP.P0)."""
    for i in range(4):
        es[E.Q + i] = q0[i]
    for i in range(3):
        es[E.B + i] = b0[i]
    for i in range(36):
        es[E.P + i] = 0.0
    for i in range(6):
        es[E.P + 7 * i] = ep[EP.P0 + i]
    for i in range(3):
        es[E.WSUM + i] = 0.0
    es[E.SPAN] = 0.0
    es[E.NSPAN] = 0.0
    es[E.INIT] = 1.0


@jit
def mekf_propagate(es, ep, omega_meas, dt):
    """Propagate q̂ over ``dt`` with ω̂ = ω̃ − β̂ held (ω̃ the gyro rate of the last tick); P's
    propagation over the tick is added to the pending span (:func:`mekf_covariance`, run here
    once the span holds :data:`SPAN_TICKS` ticks)."""
    w0 = omega_meas[0] - es[E.B]
    w1 = omega_meas[1] - es[E.B + 1]
    w2 = omega_meas[2] - es[E.B + 2]
    # q̂ ← q̂∘exp(ω̂ Δt/2)
    k, ca = half_angle(w0 * w0 + w1 * w1 + w2 * w2, dt)
    dq = (ca, k * w0, k * w1, k * w2)
    q = mul((es[E.Q], es[E.Q + 1], es[E.Q + 2], es[E.Q + 3]), dq)
    nq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    # 1/√n: q̂ and dq are unit to round-off, so n = 1 + e with |e| ~ 1e-16 and 1 − e/2 is
    # 1/√n to round-off (the next term, 3e²/8, is below 4e-17 while |e| < 1e-8)
    e = nq - 1.0
    inv_n = 1.0 - 0.5 * e if abs(e) < 1e-8 else 1.0 / math.sqrt(nq)
    for i in range(4):
        es[E.Q + i] = q[i] * inv_n
    es[E.WSUM] += w0 * dt
    es[E.WSUM + 1] += w1 * dt
    es[E.WSUM + 2] += w2 * dt
    es[E.SPAN] += dt
    es[E.NSPAN] += 1.0
    if es[E.NSPAN] >= SPAN_TICKS:
        mekf_covariance(es, ep)


@jit
def _advance(es, ep, src, dst):
    """P at ``src`` propagated over the pending span into ``dst`` (which may be ``src``): one
    step with the span's mean rate ω̄ held (see the module docstring)."""
    dt = es[E.SPAN]
    if dt == 0.0:
        if dst != src:
            for i in range(36):
                es[dst + i] = es[src + i]
        return
    inv = 1.0 / dt
    w0 = es[E.WSUM] * inv
    w1 = es[E.WSUM + 1] * inv
    w2 = es[E.WSUM + 2] * inv
    ww = w0 * w0 + w1 * w1 + w2 * w2  # w²
    # the coefficients c1 = sin(wΔt)/w = 2 sin a cos a / w, c2 = (1 − cos(wΔt))/w² =
    # 2 (sin a / w)² from the half angle (no cancellation), c3 = (wΔt − sin(wΔt))/w³ by its
    # series in (wΔt)² on the usual span (truncation (wΔt)¹⁰/13! < 3e-21 relative)
    k, ca = half_angle(ww, dt)
    c1 = 2.0 * k * ca
    c2 = 2.0 * k * k
    x2 = ww * dt * dt  # (wΔt)²
    if x2 < 4.0 * SERIES_X2:
        c3 = dt * dt * dt * F(x2, F(x2, F(x2, F(x2, _T4, _T3), _T2), _T1), _T0)
    else:
        w = math.sqrt(ww)
        c3 = (w * dt - c1 * w) / (ww * w)  # c1 w = sin(wΔt)
    # Φ₁₁ = 1 − W c1 + W² c2 (f), Φ₁₂ = W c2 − 1 Δt − W² c3 (g), W = [ω×], W² = ω ωᵀ − w² 1
    d1 = 1.0 - ww * c2
    d2 = -dt + ww * c3
    f00 = d1 + w0 * w0 * c2
    g00 = d2 - w0 * w0 * c3
    f01 = w0 * w1 * c2 + w2 * c1
    g01 = -w0 * w1 * c3 - w2 * c2
    f02 = w0 * w2 * c2 - w1 * c1
    g02 = -w0 * w2 * c3 + w1 * c2
    f10 = w1 * w0 * c2 - w2 * c1
    g10 = -w1 * w0 * c3 + w2 * c2
    f11 = d1 + w1 * w1 * c2
    g11 = d2 - w1 * w1 * c3
    f12 = w1 * w2 * c2 + w0 * c1
    g12 = -w1 * w2 * c3 - w0 * c2
    f20 = w2 * w0 * c2 + w1 * c1
    g20 = -w2 * w0 * c3 - w1 * c2
    f21 = w2 * w1 * c2 - w0 * c1
    g21 = -w2 * w1 * c3 + w0 * c2
    f22 = d1 + w2 * w2 * c2
    g22 = d2 - w2 * w2 * c3
    # P ← Φ P Φᵀ + Q with Φ = [[Φ₁₁, Φ₁₂], [0, 1]] by blocks: [T₁ T₂] = [Φ₁₁ Φ₁₂] P (t),
    # P_aa ← T₁ Φ₁₁ᵀ + T₂ Φ₁₂ᵀ, P_ab ← T₂, P_bb unchanged. Written out on scalars (P read
    # once into locals): the products then run as independent chains, not through memory.
    p00 = es[src + 0]
    p01 = es[src + 1]
    p02 = es[src + 2]
    p03 = es[src + 3]
    p04 = es[src + 4]
    p05 = es[src + 5]
    p11 = es[src + 7]
    p12 = es[src + 8]
    p13 = es[src + 9]
    p14 = es[src + 10]
    p15 = es[src + 11]
    p22 = es[src + 14]
    p23 = es[src + 15]
    p24 = es[src + 16]
    p25 = es[src + 17]
    p33 = es[src + 21]
    p34 = es[src + 22]
    p35 = es[src + 23]
    p44 = es[src + 28]
    p45 = es[src + 29]
    p55 = es[src + 35]
    t00 = F(g02, p05, F(g01, p04, F(g00, p03, F(f02, p02, F(f01, p01, f00 * p00)))))
    t01 = F(g02, p15, F(g01, p14, F(g00, p13, F(f02, p12, F(f01, p11, f00 * p01)))))
    t02 = F(g02, p25, F(g01, p24, F(g00, p23, F(f02, p22, F(f01, p12, f00 * p02)))))
    t03 = F(g02, p35, F(g01, p34, F(g00, p33, F(f02, p23, F(f01, p13, f00 * p03)))))
    t04 = F(g02, p45, F(g01, p44, F(g00, p34, F(f02, p24, F(f01, p14, f00 * p04)))))
    t05 = F(g02, p55, F(g01, p45, F(g00, p35, F(f02, p25, F(f01, p15, f00 * p05)))))
    t10 = F(g12, p05, F(g11, p04, F(g10, p03, F(f12, p02, F(f11, p01, f10 * p00)))))
    t11 = F(g12, p15, F(g11, p14, F(g10, p13, F(f12, p12, F(f11, p11, f10 * p01)))))
    t12 = F(g12, p25, F(g11, p24, F(g10, p23, F(f12, p22, F(f11, p12, f10 * p02)))))
    t13 = F(g12, p35, F(g11, p34, F(g10, p33, F(f12, p23, F(f11, p13, f10 * p03)))))
    t14 = F(g12, p45, F(g11, p44, F(g10, p34, F(f12, p24, F(f11, p14, f10 * p04)))))
    t15 = F(g12, p55, F(g11, p45, F(g10, p35, F(f12, p25, F(f11, p15, f10 * p05)))))
    t20 = F(g22, p05, F(g21, p04, F(g20, p03, F(f22, p02, F(f21, p01, f20 * p00)))))
    t21 = F(g22, p15, F(g21, p14, F(g20, p13, F(f22, p12, F(f21, p11, f20 * p01)))))
    t22 = F(g22, p25, F(g21, p24, F(g20, p23, F(f22, p22, F(f21, p12, f20 * p02)))))
    t23 = F(g22, p35, F(g21, p34, F(g20, p33, F(f22, p23, F(f21, p13, f20 * p03)))))
    t24 = F(g22, p45, F(g21, p44, F(g20, p34, F(f22, p24, F(f21, p14, f20 * p04)))))
    t25 = F(g22, p55, F(g21, p45, F(g20, p35, F(f22, p25, F(f21, p15, f20 * p05)))))
    v = F(t05, g02, F(t04, g01, F(t03, g00, F(t02, f02, F(t01, f01, t00 * f00)))))
    es[dst + 0] = v
    v = F(t05, g12, F(t04, g11, F(t03, g10, F(t02, f12, F(t01, f11, t00 * f10)))))
    es[dst + 1] = v
    es[dst + 6] = v
    v = F(t05, g22, F(t04, g21, F(t03, g20, F(t02, f22, F(t01, f21, t00 * f20)))))
    es[dst + 2] = v
    es[dst + 12] = v
    v = F(t15, g12, F(t14, g11, F(t13, g10, F(t12, f12, F(t11, f11, t10 * f10)))))
    es[dst + 7] = v
    v = F(t15, g22, F(t14, g21, F(t13, g20, F(t12, f22, F(t11, f21, t10 * f20)))))
    es[dst + 8] = v
    es[dst + 13] = v
    v = F(t25, g22, F(t24, g21, F(t23, g20, F(t22, f22, F(t21, f21, t20 * f20)))))
    es[dst + 14] = v
    es[dst + 3] = t03
    es[dst + 18] = t03
    es[dst + 4] = t04
    es[dst + 24] = t04
    es[dst + 5] = t05
    es[dst + 30] = t05
    es[dst + 9] = t13
    es[dst + 19] = t13
    es[dst + 10] = t14
    es[dst + 25] = t14
    es[dst + 11] = t15
    es[dst + 31] = t15
    es[dst + 15] = t23
    es[dst + 20] = t23
    es[dst + 16] = t24
    es[dst + 26] = t24
    es[dst + 17] = t25
    es[dst + 32] = t25
    if dst != src:  # P_bb (unchanged by Φ)
        for i in range(3, 6):
            for j in range(3, 6):
                es[dst + 6 * i + j] = es[src + 6 * i + j]
    sv2 = ep[EP.SV] * ep[EP.SV]
    su2 = ep[EP.SU] * ep[EP.SU]
    for i in range(3):
        es[dst + 7 * i] += sv2 * dt + su2 * dt * dt * dt / 3.0
        es[dst + 6 * i + i + 3] += -su2 * dt * dt / 2.0
        es[dst + 6 * (i + 3) + i] += -su2 * dt * dt / 2.0
        es[dst + 7 * (i + 3)] += su2 * dt


@jit
def mekf_covariance(es, ep):
    """Bring the filter's P to the time of q̂ (over the pending span; nothing if none)."""
    if es[E.SPAN] != 0.0:
        _advance(es, ep, E.P, E.P)
        for i in range(3):
            es[E.WSUM + i] = 0.0
        es[E.SPAN] = 0.0
        es[E.NSPAN] = 0.0


@jit
def mekf_covariance_at(es, ep, dst):
    """P at the time of q̂ into ``es[dst : dst + 36]``, the filter's own P and span unchanged
    (what the record reads: recording a tick or not changes nothing in the filter)."""
    _advance(es, ep, E.P, dst)


@jit(inline="always")
def _inv3_sym(s00, s01, s02, s11, s12, s22):
    """The rows of S⁻¹ for a symmetric 3 × 3 S given by its upper triangle (cofactors over the
    determinant; S⁻¹ is symmetric too)."""
    a00 = s11 * s22 - s12 * s12
    a01 = s02 * s12 - s01 * s22
    a02 = s01 * s12 - s02 * s11
    inv = 1.0 / (s00 * a00 + s01 * a01 + s02 * a02)
    i0 = (a00 * inv, a01 * inv, a02 * inv)
    i1 = (a01 * inv, (s00 * s22 - s02 * s02) * inv, (s01 * s02 - s00 * s12) * inv)
    i2 = (a02 * inv, i1[2], (s00 * s11 - s01 * s01) * inv)
    return i0, i1, i2


@jit
def _update(es, H, y0, y1, y2, R):
    """The Kalman update with a 3 × 6 measurement matrix H (rows of 6 in a tuple of 18) and
    the residual y, noise R (tuple of 9); then the reset."""
    # PHᵀ (6 × 3) into E.TMP
    tmp = E.TMP
    for i in range(6):
        for j in range(3):
            s = 0.0
            for k in range(6):
                s += es[E.P + 6 * i + k] * H[6 * j + k]
            es[tmp + 3 * i + j] = s
    # S = H P Hᵀ + R
    S = E.S
    for i in range(3):
        for j in range(3):
            s = R[3 * i + j]
            for k in range(6):
                s += H[6 * i + k] * es[tmp + 3 * k + j]
            es[S + 3 * i + j] = s
    # S⁻¹ (S is symmetric: from its upper triangle)
    inv = _inv3_sym(es[S], es[S + 1], es[S + 2], es[S + 4], es[S + 5], es[S + 8])
    for i in range(3):
        for j in range(3):
            es[S + 9 + 3 * i + j] = inv[i][j]
    # K = P Hᵀ S⁻¹
    for i in range(6):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += es[tmp + 3 * i + k] * es[S + 9 + 3 * k + j]
            es[E.K + 3 * i + j] = s
    # δx = K y
    x0 = es[E.K] * y0 + es[E.K + 1] * y1 + es[E.K + 2] * y2
    x1 = es[E.K + 3] * y0 + es[E.K + 4] * y1 + es[E.K + 5] * y2
    x2 = es[E.K + 6] * y0 + es[E.K + 7] * y1 + es[E.K + 8] * y2
    x3 = es[E.K + 9] * y0 + es[E.K + 10] * y1 + es[E.K + 11] * y2
    x4 = es[E.K + 12] * y0 + es[E.K + 13] * y1 + es[E.K + 14] * y2
    x5 = es[E.K + 15] * y0 + es[E.K + 16] * y1 + es[E.K + 17] * y2
    dx = (x0, x1, x2, x3, x4, x5)
    # Joseph: A = 1 − K H (into E.PHI), P ← A P Aᵀ + K R Kᵀ
    ph = E.PHI
    for i in range(6):
        for j in range(6):
            s = 1.0 if i == j else 0.0
            for k in range(3):
                s -= es[E.K + 3 * i + k] * H[6 * k + j]
            es[ph + 6 * i + j] = s
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += es[ph + 6 * i + k] * es[E.P + 6 * k + j]
            es[tmp + 6 * i + j] = s
    for i in range(6):
        for j in range(i, 6):
            s = 0.0
            for k in range(6):
                s += es[tmp + 6 * i + k] * es[ph + 6 * j + k]
            # + K R Kᵀ
            for a in range(3):
                ka = es[E.K + 3 * i + a]
                for b in range(3):
                    s += ka * R[3 * a + b] * es[E.K + 3 * j + b]
            es[E.P + 6 * i + j] = s
            es[E.P + 6 * j + i] = s
    _reset(es, dx[0], dx[1], dx[2], dx[3], dx[4], dx[5])


@jit(inline="always")
def _reset(es, d0, d1, d2, d3, d4, d5):
    """The reset after an update: q̂ ← q̂∘δq(δθ), β̂ ← β̂ + δβ."""
    q = mul((es[E.Q], es[E.Q + 1], es[E.Q + 2], es[E.Q + 3]), (1.0, 0.5 * d0, 0.5 * d1, 0.5 * d2))
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        es[E.Q + i] = q[i] / n
    es[E.B] += d3
    es[E.B + 1] += d4
    es[E.B + 2] += d5


@jit(inline="always")
def _dot3(a, b):
    return F(a[2], b[2], F(a[1], b[1], a[0] * b[0]))


@jit
def _update_attitude(es, ep, y0, y1, y2):
    """The update of :func:`_update` for H = [1 0] (a measurement of the attitude error, R the
    star tracker's EP.ST_R), by blocks on scalars: with the columns c_j = P[:3, j], S = P_aa +
    R (symmetric: its upper triangle), the gain's rows k_i = c_iᵀ S⁻¹ (S⁻¹ by cofactors), and
    P ← P − K P[:3, :] = P_ij − k_i·c_j (equal to the Joseph form for this optimal gain) on the
    upper triangle, mirrored so P stays exactly symmetric."""
    P = E.P
    R = EP.ST_R
    cs = (
        (es[P], es[P + 6], es[P + 12]),
        (es[P + 1], es[P + 7], es[P + 13]),
        (es[P + 2], es[P + 8], es[P + 14]),
        (es[P + 3], es[P + 9], es[P + 15]),
        (es[P + 4], es[P + 10], es[P + 16]),
        (es[P + 5], es[P + 11], es[P + 17]),
    )
    i0, i1, i2 = _inv3_sym(
        es[P] + ep[R],
        es[P + 1] + ep[R + 1],
        es[P + 2] + ep[R + 2],
        es[P + 7] + ep[R + 4],
        es[P + 8] + ep[R + 5],
        es[P + 14] + ep[R + 8],
    )
    ks = (
        (_dot3(cs[0], i0), _dot3(cs[0], i1), _dot3(cs[0], i2)),
        (_dot3(cs[1], i0), _dot3(cs[1], i1), _dot3(cs[1], i2)),
        (_dot3(cs[2], i0), _dot3(cs[2], i1), _dot3(cs[2], i2)),
        (_dot3(cs[3], i0), _dot3(cs[3], i1), _dot3(cs[3], i2)),
        (_dot3(cs[4], i0), _dot3(cs[4], i1), _dot3(cs[4], i2)),
        (_dot3(cs[5], i0), _dot3(cs[5], i1), _dot3(cs[5], i2)),
    )
    y = (y0, y1, y2)
    for i in range(6):
        ki = ks[i]
        for j in range(i, 6):
            v = es[P + 6 * i + j] - _dot3(ki, cs[j])
            es[P + 6 * i + j] = v
            es[P + 6 * j + i] = v
    _reset(es, _dot3(ks[0], y), _dot3(ks[1], y), _dot3(ks[2], y), _dot3(ks[3], y),
           _dot3(ks[4], y), _dot3(ks[5], y))  # fmt: skip


@jit
def mekf_update_quaternion(es, ep, qm):
    """Update with a star tracker quaternion ``qm`` (its noise covariance EP.ST_R)."""
    mekf_covariance(es, ep)
    q = (es[E.Q], es[E.Q + 1], es[E.Q + 2], es[E.Q + 3])
    r = conj_mul(q, (qm[0], qm[1], qm[2], qm[3]))
    s = 1.0 if r[0] >= 0.0 else -1.0
    _update_attitude(es, ep, 2.0 * s * r[1], 2.0 * s * r[2], 2.0 * s * r[3])


@jit
def mekf_update_vector(es, ep, bm0, bm1, bm2, r0, r1, r2, sigma):
    """Update with a body-axes measurement b̃ of the space vector r (noise σ, isotropic)."""
    mekf_covariance(es, ep)
    q = (es[E.Q], es[E.Q + 1], es[E.Q + 2], es[E.Q + 3])
    b = rotate_inverse(q, (r0, r1, r2))  # b̂ = A(q̂) r
    # H = [[b̂×] 0]
    H = (
        0.0, -b[2], b[1], 0.0, 0.0, 0.0,
        b[2], 0.0, -b[0], 0.0, 0.0, 0.0,
        -b[1], b[0], 0.0, 0.0, 0.0, 0.0,
    )  # fmt: skip
    s2 = sigma * sigma
    R = (s2, 0.0, 0.0, 0.0, s2, 0.0, 0.0, 0.0, s2)
    _update(es, H, bm0 - b[0], bm1 - b[1], bm2 - b[2], R)


@jit
def estimation_error(es, po, q_true, beta_true):
    """(δθ (3), δβ (3), NEES) of the estimate against the truth: q_true = q̂∘δq(δθ) (the
    shorter rotation), δβ = β − β̂, NEES = δxᵀ P⁻¹ δx (Cholesky of the P at ``es[po:]``: the
    filter's, or :func:`mekf_covariance_at`'s copy)."""
    q = (es[E.Q], es[E.Q + 1], es[E.Q + 2], es[E.Q + 3])
    r = shorter(conj_mul(q, q_true))
    v = math.sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3])
    ang = 2.0 * math.atan2(v, r[0])
    k = ang / v if v > 0.0 else 2.0
    b0 = beta_true[0] - es[E.B]
    b1 = beta_true[1] - es[E.B + 1]
    b2 = beta_true[2] - es[E.B + 2]
    e = (k * r[1], k * r[2], k * r[3], b0, b1, b2)
    # NEES by a Cholesky factorisation of P (into E.TMP)
    L = E.TMP
    for i in range(36):
        es[L + i] = 0.0
    ok = True
    for i in range(6):
        for j in range(i + 1):
            s = es[po + 6 * i + j]
            for m in range(j):
                s -= es[L + 6 * i + m] * es[L + 6 * j + m]
            if i == j:
                if s <= 0.0:
                    ok = False
                    s = 1e-300
                es[L + 7 * i] = math.sqrt(s)
            else:
                es[L + 6 * i + j] = s / es[L + 7 * j]
    # solve L z = e
    z0 = e[0] / es[L]
    z1 = (e[1] - es[L + 6] * z0) / es[L + 7]
    z2 = (e[2] - es[L + 12] * z0 - es[L + 13] * z1) / es[L + 14]
    z3 = (e[3] - es[L + 18] * z0 - es[L + 19] * z1 - es[L + 20] * z2) / es[L + 21]
    z4 = (e[4] - es[L + 24] * z0 - es[L + 25] * z1 - es[L + 26] * z2 - es[L + 27] * z3) / es[L + 28]
    z5 = (
        e[5] - es[L + 30] * z0 - es[L + 31] * z1 - es[L + 32] * z2 - es[L + 33] * z3
        - es[L + 34] * z4
    ) / es[L + 35]  # fmt: skip
    nees = z0 * z0 + z1 * z1 + z2 * z2 + z3 * z3 + z4 * z4 + z5 * z5
    if not ok:
        nees = math.nan
    return e, nees


# the copy the tick's sensing inlines (fsw.sense_and_estimate)
mekf_propagate_inline = inline_copy(mekf_propagate, globals())

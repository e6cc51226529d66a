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

from orbit._shared_jit import jit

from .quat import mul, rotate_inverse

E_Q = 0  # q̂ (4)
E_B = 4  # β̂ (3)
E_P = 7  # P (36, row-major)
E_INIT = 43  # 1 once initialised
E_W = 44  # ω̂ of the last tick (3)
E_T = 47  # time of the last tick
E_NEES = 48  # the last normalised estimation error squared (attitude and bias, 6 dof)
E_PHI = 50  # scratch Φ (36)
E_TMP = 86  # scratch (36)
E_K = 122  # gain (6 × 3 = 18)
E_S = 140  # innovation covariance and its inverse (9 + 9)
E_SIZE = 160

# parameters (a record of the flight software's program)
EP_SV = 0  # σ_v of the gyro model (rad/√s)
EP_SU = 1  # σ_u (rad/s^1.5)
EP_P0 = 2  # initial covariance diagonal (6)
EP_INIT = 8  # 0: from the first valid star tracker measurement; 1: the given q0, b0
EP_Q0 = 9  # (4)
EP_B0 = 13  # (3)
EP_ST_R = 16  # star tracker noise covariance in body axes (9)
EP_MAG = 25  # magnetometer σ (T; 0: not used)
EP_SUN = 26  # Sun sensor σ (unit vector; 0: not used)
EP_SIZE = 27


@jit(inline="always")
def _p(es, i, j):
    return es[E_P + 6 * i + j]


@jit
def mekf_init(es, ep, q0, b0):
    """Start the filter at (q0, b0) with the covariance diag(EP_P0)."""
    for i in range(4):
        es[E_Q + i] = q0[i]
    for i in range(3):
        es[E_B + i] = b0[i]
    for i in range(36):
        es[E_P + i] = 0.0
    for i in range(6):
        es[E_P + 7 * i] = ep[EP_P0 + i]
    es[E_INIT] = 1.0


@jit
def mekf_propagate(es, ep, omega_meas, dt):
    """Propagate q̂ and P over ``dt`` with ω̂ = ω̃ − β̂ held (ω̃ the gyro rate of the last
    tick)."""
    w0 = omega_meas[0] - es[E_B]
    w1 = omega_meas[1] - es[E_B + 1]
    w2 = omega_meas[2] - es[E_B + 2]
    w = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    # q̂ ← q̂∘exp(ω̂ Δt/2)
    a = 0.5 * w * dt
    if w > 0.0:
        k = math.sin(a) / w
        dq = (math.cos(a), k * w0, k * w1, k * w2)
    else:
        dq = (1.0, 0.0, 0.0, 0.0)
    q = mul((es[E_Q], es[E_Q + 1], es[E_Q + 2], es[E_Q + 3]), dq)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        es[E_Q + i] = q[i] / n
    # Φ
    x = w * dt
    if w > 1e-8:
        c1 = math.sin(x) / w
        c2 = (1.0 - math.cos(x)) / (w * w)
        c3 = (x - math.sin(x)) / (w * w * w)
    else:  # series
        c1 = dt - w * w * dt * dt * dt / 6.0
        c2 = dt * dt / 2.0 - w * w * dt**4 / 24.0
        c3 = dt**3 / 6.0 - w * w * dt**5 / 120.0
    # W = [ω×], W² = ω ωᵀ − w² 1
    W = (0.0, -w2, w1, w2, 0.0, -w0, -w1, w0, 0.0)
    ph = E_PHI
    for i in range(6):
        for j in range(6):
            es[ph + 6 * i + j] = 1.0 if i == j else 0.0
    for i in range(3):
        for j in range(3):
            ww = (w0, w1, w2)[i] * (w0, w1, w2)[j] - (w * w if i == j else 0.0)
            es[ph + 6 * i + j] = (1.0 if i == j else 0.0) - W[3 * i + j] * c1 + ww * c2
            es[ph + 6 * i + 3 + j] = W[3 * i + j] * c2 - (dt if i == j else 0.0) - ww * c3
    # P ← Φ P Φᵀ + Q
    tmp = E_TMP
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += es[ph + 6 * i + k] * es[E_P + 6 * k + j]
            es[tmp + 6 * i + j] = s
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += es[tmp + 6 * i + k] * es[ph + 6 * j + k]
            es[E_P + 6 * i + j] = s
    sv2 = ep[EP_SV] * ep[EP_SV]
    su2 = ep[EP_SU] * ep[EP_SU]
    for i in range(3):
        es[E_P + 7 * i] += sv2 * dt + su2 * dt * dt * dt / 3.0
        es[E_P + 6 * i + i + 3] += -su2 * dt * dt / 2.0
        es[E_P + 6 * (i + 3) + i] += -su2 * dt * dt / 2.0
        es[E_P + 7 * (i + 3)] += su2 * dt
    # symmetrise
    for i in range(6):
        for j in range(i + 1, 6):
            v = 0.5 * (es[E_P + 6 * i + j] + es[E_P + 6 * j + i])
            es[E_P + 6 * i + j] = v
            es[E_P + 6 * j + i] = v
    es[E_W] = w0
    es[E_W + 1] = w1
    es[E_W + 2] = w2


@jit
def _inv3(es, src, dst):
    a = es[src : src + 9]
    det = (
        a[0] * (a[4] * a[8] - a[5] * a[7])
        - a[1] * (a[3] * a[8] - a[5] * a[6])
        + a[2] * (a[3] * a[7] - a[4] * a[6])
    )
    es[dst] = (a[4] * a[8] - a[5] * a[7]) / det
    es[dst + 1] = (a[2] * a[7] - a[1] * a[8]) / det
    es[dst + 2] = (a[1] * a[5] - a[2] * a[4]) / det
    es[dst + 3] = (a[5] * a[6] - a[3] * a[8]) / det
    es[dst + 4] = (a[0] * a[8] - a[2] * a[6]) / det
    es[dst + 5] = (a[2] * a[3] - a[0] * a[5]) / det
    es[dst + 6] = (a[3] * a[7] - a[4] * a[6]) / det
    es[dst + 7] = (a[1] * a[6] - a[0] * a[7]) / det
    es[dst + 8] = (a[0] * a[4] - a[1] * a[3]) / det


@jit
def _update(es, H, y0, y1, y2, R):
    """The Kalman update with a 3 × 6 measurement matrix H (rows of 6 in a tuple of 18) and
    the residual y, noise R (tuple of 9); then the reset."""
    # PHᵀ (6 × 3) into E_TMP
    tmp = E_TMP
    for i in range(6):
        for j in range(3):
            s = 0.0
            for k in range(6):
                s += es[E_P + 6 * i + k] * H[6 * j + k]
            es[tmp + 3 * i + j] = s
    # S = H P Hᵀ + R
    S = E_S
    for i in range(3):
        for j in range(3):
            s = R[3 * i + j]
            for k in range(6):
                s += H[6 * i + k] * es[tmp + 3 * k + j]
            es[S + 3 * i + j] = s
    _inv3(es, S, S + 9)
    # K = P Hᵀ S⁻¹
    for i in range(6):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += es[tmp + 3 * i + k] * es[S + 9 + 3 * k + j]
            es[E_K + 3 * i + j] = s
    # δx = K y
    x0 = es[E_K] * y0 + es[E_K + 1] * y1 + es[E_K + 2] * y2
    x1 = es[E_K + 3] * y0 + es[E_K + 4] * y1 + es[E_K + 5] * y2
    x2 = es[E_K + 6] * y0 + es[E_K + 7] * y1 + es[E_K + 8] * y2
    x3 = es[E_K + 9] * y0 + es[E_K + 10] * y1 + es[E_K + 11] * y2
    x4 = es[E_K + 12] * y0 + es[E_K + 13] * y1 + es[E_K + 14] * y2
    x5 = es[E_K + 15] * y0 + es[E_K + 16] * y1 + es[E_K + 17] * y2
    dx = (x0, x1, x2, x3, x4, x5)
    # Joseph: A = 1 − K H (into E_PHI), P ← A P Aᵀ + K R Kᵀ
    ph = E_PHI
    for i in range(6):
        for j in range(6):
            s = 1.0 if i == j else 0.0
            for k in range(3):
                s -= es[E_K + 3 * i + k] * H[6 * k + j]
            es[ph + 6 * i + j] = s
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += es[ph + 6 * i + k] * es[E_P + 6 * k + j]
            es[tmp + 6 * i + j] = s
    for i in range(6):
        for j in range(i, 6):
            s = 0.0
            for k in range(6):
                s += es[tmp + 6 * i + k] * es[ph + 6 * j + k]
            # + K R Kᵀ
            for a in range(3):
                ka = es[E_K + 3 * i + a]
                for b in range(3):
                    s += ka * R[3 * a + b] * es[E_K + 3 * j + b]
            es[E_P + 6 * i + j] = s
            es[E_P + 6 * j + i] = s
    # reset: q̂ ← q̂∘δq(δθ), β̂ ← β̂ + δβ
    dq = (1.0, 0.5 * dx[0], 0.5 * dx[1], 0.5 * dx[2])
    q = mul((es[E_Q], es[E_Q + 1], es[E_Q + 2], es[E_Q + 3]), dq)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        es[E_Q + i] = q[i] / n
    for i in range(3):
        es[E_B + i] += dx[3 + i]


@jit
def mekf_update_quaternion(es, ep, qm):
    """Update with a star tracker quaternion ``qm`` (its noise covariance EP_ST_R)."""
    q = (es[E_Q], es[E_Q + 1], es[E_Q + 2], es[E_Q + 3])
    r = mul((q[0], -q[1], -q[2], -q[3]), (qm[0], qm[1], qm[2], qm[3]))
    s = 1.0 if r[0] >= 0.0 else -1.0
    H = (
        1.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
    )  # fmt: skip
    o = EP_ST_R
    R = (ep[o], ep[o + 1], ep[o + 2], ep[o + 3], ep[o + 4], ep[o + 5], ep[o + 6], ep[o + 7],
         ep[o + 8])  # fmt: skip
    _update(es, H, 2.0 * s * r[1], 2.0 * s * r[2], 2.0 * s * r[3], R)


@jit
def mekf_update_vector(es, bm0, bm1, bm2, r0, r1, r2, sigma):
    """Update with a body-axes measurement b̃ of the space vector r (noise σ, isotropic)."""
    q = (es[E_Q], es[E_Q + 1], es[E_Q + 2], es[E_Q + 3])
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
def estimation_error(es, q_true, beta_true):
    """(δθ (3), δβ (3), NEES) of the estimate against the truth: q_true = q̂∘δq(δθ) (the
    shorter rotation), δβ = β − β̂, NEES = δxᵀ P⁻¹ δx (Cholesky of P)."""
    q = (es[E_Q], es[E_Q + 1], es[E_Q + 2], es[E_Q + 3])
    r = mul((q[0], -q[1], -q[2], -q[3]), q_true)
    if r[0] < 0.0:
        r = (-r[0], -r[1], -r[2], -r[3])
    v = math.sqrt(r[1] * r[1] + r[2] * r[2] + r[3] * r[3])
    ang = 2.0 * math.atan2(v, r[0])
    k = ang / v if v > 0.0 else 2.0
    b0 = beta_true[0] - es[E_B]
    b1 = beta_true[1] - es[E_B + 1]
    b2 = beta_true[2] - es[E_B + 2]
    e = (k * r[1], k * r[2], k * r[3], b0, b1, b2)
    # NEES by a Cholesky factorisation of P (into E_TMP)
    L = E_TMP
    for i in range(36):
        es[L + i] = 0.0
    ok = True
    for i in range(6):
        for j in range(i + 1):
            s = es[E_P + 6 * i + j]
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

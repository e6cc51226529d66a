"""The exact Kepler flow of a state vector: universal variables, Stumpff functions, f and g.

:func:`kepler_drift` carries a position and velocity (r, v) about a point mass μ through a time
dt, elliptic, parabolic or hyperbolic alike, without elements: the "drift" of a Wisdom–Holman
splitting (Wisdom & Holman, Astron. J. 102, 1528 (1991)), which the symplectic orbit–attitude
method of :mod:`attitude._core.splitting` composes with kicks. Any consistent units (km, km/s,
km³/s² or m, m/s, m³/s²). Plain floats in, tuples out; nothing allocates.

Universal variables (Danby, *Fundamentals of Celestial Mechanics*, 2nd ed. 1988, Sect. 6.9;
Battin 1999, Sect. 4.5). With r0 = |r|, η = r·v, β = 2μ/r0 − |v|² (= μ/a) and the Stumpff
functions c_n(z) = Σ_k (−z)^k/(n + 2k)!, the G-functions G_n(s) = s^n c_n(β s²) give

    Kepler's equation     F(s) = r0 G1 + η G2 + μ G3 − dt = 0,       F'(s) = r(s) > 0,
    Lagrange's f and g    f = 1 − μ G2/r0,  g = r0 G1 + η G2,
                          ḟ = −μ G1/(r0 r),  ġ = 1 − μ G2/r,   r = r0 G0 + η G1 + μ G2,

and r' = f r + g v, v' = ḟ r + ġ v. The new state is formed as r + ((f − 1) r + g v) and
v + (ḟ r + (ġ − 1) v) from f − 1 and ġ − 1 directly, without cancellation for a short drift.

* **Stumpff functions** (:func:`stumpff`): z is quartered until |z| ≤ 0.1, c4 and c5 summed to
  1/15! there (truncation < 1e-20), then the double-angle relations c4(4z) = (1 + c1) c3/8,
  c5(4z) = (c5 + c4 + c3 c2)/16 and c_n = 1/n! − z c_{n+2} climb back (Danby 1988, Sect. 6.9;
  as in REBOUND's WHFast, Rein & Tamayo, MNRAS 452, 376 (2015)). One formula for all z; against
  their series at 40 digits within 1.4e-16 for |z| ≤ 1, 1.8e-14 of the functions' amplitude for
  z ≤ 60 (a drift of up to half a period), 1.1e-15 for −400 ≤ z < 0 (tests/test_kepler_drift.py).
* **The root** s: Halley's iteration from s ≈ dt/r0 − η dt²/(2 r0³), safeguarded by a bracket
  (a step leaving it bisects). Since ds/dt = 1/r, |s| lies between |dt|/r_max and |dt|/r_min
  with r_min the periapsis p/(1 + e) and r_max the apoapsis p/(1 − e) of an ellipse, or
  r0 + v_p |dt| of a hyperbola (v_p = h/r_min its fastest speed); both widened by 1e-9. An
  ellipse's dt is first reduced modulo the period 2πμ/β^{3/2} (so |βs²| ≤ 4π²). The iteration
  stops when its step is below 4e-16 |s|.
* **Consistency.** f, g, ḟ, ġ are all evaluated at the same s, with g = r0 G1 + η G2 (not
  dt − μ G3): whatever the last rounding of s, they are the exact flow over the time
  F(s) + dt, so f ġ − g ḟ = 1 and the energy and angular momentum of the new state are those
  of the old to round-off.

A radial state (r × v = 0) has no bracket; the iteration then runs unguarded and may fail.
A failure (no convergence in 100 iterations, a non-finite value) returns NaNs.

Measured against a 50-digit solution of Kepler's equation (tests/test_kepler_drift.py): within
1.5e-15 (relative, position and velocity) for e from 0 to 0.74 and hyperbolas up to e = 3 over
±half a period and more, 9e-16 for e = 1 ± 1e-9, 7e-15 at e = 0.99 from a state near periapsis
(β = μ/a there is a 200-fold cancellation of 2μ/r and v²; for the same reason a drift over
whole periods of such an orbit is off by β's error times the number of periods: 2e-11 after one).
"""

from __future__ import annotations

import math

from ._shared_jit import jit

__all__ = ["kepler_drift", "kepler_drift_state", "stumpff"]

#: 1/n! for n = 0..15 (the Stumpff series).
_INV_FACT = tuple(1.0 / math.factorial(n) for n in range(16))
#: Relative widening of the bracket of s (the periapsis and apoapsis are computed in floats).
_WIDEN = 1e-9
#: Largest number of iterations of Kepler's equation.
MAX_ITER = 100


@jit
def stumpff(z):
    """Stumpff functions (c0, c1, c2, c3) of z (any sign; c_n(z) = Σ_k (−z)^k/(n + 2k)!).

    Parameters
    ----------
    z : float
        Argument (β s² in the universal variables); z > 0 elliptic, z < 0 hyperbolic.

    Returns
    -------
    tuple of 4 floats
        c0 = cos √z, c1 = sin √z/√z, c2 = (1 − cos √z)/z, c3 = (√z − sin √z)/z^{3/2} (and their
        cosh/sinh forms for z < 0, their limits 1, 1, 1/2, 1/6 at z = 0).
    """
    n = 0
    while abs(z) > 0.1:  # quarter z (halve √z) until the series converge fast
        z *= 0.25
        n += 1
    # c5 and c4 to the 1/15! and 1/14! terms (Horner in z)
    c5 = _INV_FACT[15]
    c4 = _INV_FACT[14]
    for k in range(13, 4, -2):
        c5 = _INV_FACT[k] - z * c5
        c4 = _INV_FACT[k - 1] - z * c4
    c3 = _INV_FACT[3] - z * c5
    c2 = _INV_FACT[2] - z * c4
    c1 = 1.0 - z * c3
    for _ in range(n):  # double-angle relations: c_n(4z) from c_n(z)
        z *= 4.0
        c5 = (c5 + c4 + c3 * c2) * 0.0625
        c4 = (1.0 + c1) * c3 * 0.125
        c3 = _INV_FACT[3] - z * c5
        c2 = 0.5 - z * c4
        c1 = 1.0 - z * c3
    return 1.0 - z * c2, c1, c2, c3


@jit
def _g_functions(beta, s):
    """G_n = s^n c_n(β s²), n = 0..3."""
    c0, c1, c2, c3 = stumpff(beta * s * s)
    s2 = s * s
    return c0, s * c1, s2 * c2, s2 * s * c3


@jit
def _bracket(r0, v2, mu, beta, h2, ecc, dt):
    """(lo, hi): the universal anomaly s of the drift dt lies between them (see the module
    docstring); (-inf, inf) for a radial state."""
    p = h2 / mu
    if not p > 0.0:
        return -math.inf, math.inf
    r_min = p / (1.0 + ecc)
    if beta > 0.0 and ecc < 1.0:
        r_max = p / (1.0 - ecc)
    else:
        r_max = r0 + math.sqrt(h2) / r_min * abs(dt)
    a = abs(dt) / r_max * (1.0 - _WIDEN)
    b = abs(dt) / r_min * (1.0 + _WIDEN)
    if dt > 0.0:
        return a, b
    return -b, -a


@jit
def kepler_drift(rx, ry, rz, vx, vy, vz, mu, dt):
    """The state (r, v) about a point mass ``mu`` after a time ``dt`` (the exact Kepler flow).

    Parameters
    ----------
    rx, ry, rz : float
        Position (any length unit L; r ≠ 0).
    vx, vy, vz : float
        Velocity [L/T].
    mu : float
        Gravitational parameter [L³/T²], > 0.
    dt : float
        Time [T], either sign.

    Returns
    -------
    tuple of 6 floats
        The position and velocity after dt; NaNs if Kepler's equation did not converge.
    """
    if dt == 0.0:
        return rx, ry, rz, vx, vy, vz
    r0 = math.sqrt(rx * rx + ry * ry + rz * rz)
    eta = rx * vx + ry * vy + rz * vz
    v2 = vx * vx + vy * vy + vz * vz
    beta = 2.0 * mu / r0 - v2
    zeta = mu - beta * r0
    # the eccentricity from its vector ((v² − μ/r) r − η v)/μ: no cancellation near e = 0
    cr = v2 - mu / r0
    ex = (cr * rx - eta * vx) / mu
    ey = (cr * ry - eta * vy) / mu
    ez = (cr * rz - eta * vz) / mu
    ecc = math.sqrt(ex * ex + ey * ey + ez * ez)
    hx = ry * vz - rz * vy
    hy = rz * vx - rx * vz
    hz = rx * vy - ry * vx
    h2 = hx * hx + hy * hy + hz * hz
    t = dt
    if beta > 0.0:  # an ellipse: whole periods are the identity
        period = 2.0 * math.pi * mu / (beta * math.sqrt(beta))
        t = dt - round(dt / period) * period
    lo, hi = _bracket(r0, v2, mu, beta, h2, ecc, t)
    s = t / r0 - 0.5 * eta * t * t / (r0 * r0 * r0)
    if not lo < s < hi:
        s = 0.5 * (lo + hi) if math.isfinite(hi - lo) else t / r0
    ok = False
    for _ in range(MAX_ITER):
        g0, g1, g2, g3 = _g_functions(beta, s)
        f = r0 * g1 + eta * g2 + mu * g3 - t
        fp = r0 * g0 + eta * g1 + mu * g2  # r(s) > 0: F increases with s
        if f == 0.0:
            ok = True
            break
        if f < 0.0:
            lo = s
        else:
            hi = s
        fpp = eta * g0 + zeta * g1
        ds = -f / (fp - 0.5 * f * fpp / fp)  # Halley
        s_new = s + ds
        if not lo < s_new < hi:  # left the bracket: bisect
            s_new = 0.5 * (lo + hi)
        step = abs(s_new - s)
        s = s_new
        if step <= 4e-16 * abs(s) or not math.isfinite(step):
            ok = math.isfinite(step)
            break
    nan = math.nan
    if not ok:
        return nan, nan, nan, nan, nan, nan
    g0, g1, g2, g3 = _g_functions(beta, s)
    r = r0 * g0 + eta * g1 + mu * g2
    f_m1 = -mu * g2 / r0
    g = r0 * g1 + eta * g2
    fdot = -mu * g1 / (r0 * r)
    gdot_m1 = -mu * g2 / r
    return (
        rx + (f_m1 * rx + g * vx),
        ry + (f_m1 * ry + g * vy),
        rz + (f_m1 * rz + g * vz),
        vx + (fdot * rx + gdot_m1 * vx),
        vy + (fdot * ry + gdot_m1 * vy),
        vz + (fdot * rz + gdot_m1 * vz),
    )


@jit
def kepler_drift_state(x, mu, dt):
    """:func:`kepler_drift` in place on ``x`` = (r, v), a float64 array of 6 (or a view)."""
    y = kepler_drift(x[0], x[1], x[2], x[3], x[4], x[5], mu, dt)
    for i in range(6):
        x[i] = y[i]

"""Compiled adaptive Taylor-series integration of the canonical equations (eq. 7).

The canonical equations of Arribas, Elipe & Palacios (2006), eq. 7, are polynomial (cubic) in
(q, Q): a Taylor method computes the Taylor coefficients of the solution through the current
state to order p by automatic-differentiation recurrences (Cauchy products of power series),
sums them with Horner's rule, and reads dense output off the same polynomial.

Recurrences
-----------
Eq. 7 is q̇ = ½ q∘(0, ω), Q̇ = ½ Q∘(0, ω) + 2 q∘(0, τ_B), with ω = I⁻¹ g and
g = ½ vec(q̃∘Q). Along its solution three relations hold exactly (docs/integrators.md, "taylor"):

* n = |q|² and c = q·Q are constant (the generalised force is tangent),
* g obeys Euler's equations ġ = g × ω + n τ_B (the body momentum of eq. 17),
* Q = q∘(c, 2g) / n (because q̃∘Q = (c, 2g) and q∘q̃ = n).

So the Taylor coefficients of (q, Q) are obtained from the series of q and g alone:

    q[k+1] = ½ Σ_m ω_m ⋆ (q∘e_m) [k] / (k+1)      (⋆: Cauchy product, e_m principal axes)
    g[k+1] = ((g × ω) ⋆ [k] + n τ[k]) / (k+1)
    Q[k]   = (c q[k] + 2 Σ_m g_m ⋆ (q∘e_m) [k]) / n      (k ≥ 1; Q[0] is the state itself)

where the twelve products g_m ⋆ (q∘e_m)_l serve both q̇ and Q: 15 multiply–adds per term of a
torque-free Cauchy product, against 36 for the term-by-term expansion of eq. 7. In exact
arithmetic these are the Taylor coefficients of eq. 7's solution (tests/test_taylor.py checks
them against an independent mpmath expansion of eq. 7 itself).

The torque enters through auxiliary series that are themselves solutions of polynomial ODEs:

* heavy top: s = q̃∘s₃∘q (the vertical in body axes), ṡ = s × ω, τ = −W c × s;
* gravity gradient: the body-axes position and velocity of the orbit r = q̃∘r_S∘q,
  v = q̃∘v_S∘q with ṙ = v + r × ω, v̇ = −μ r/|r|³ + v × ω, and τ = 3μ |r|⁻⁵ r × I r
  (Arribas et al. eq. 20 differentiated). |r|⁻³ and |r|⁻⁵ come from the power recurrence
  u = s^α: u[k] = Σ_{j<k} (α(k−j) − j) s[k−j] u[j] / (k s[0]) and a series division.
  The orbit is restarted exactly at every step from the Kepler solution (orbit._state_kernels
  .orbit_state on the orbit's kernel_data), so the attitude sees the same analytic orbit as
  every other method, with no orbital drift.

Coupled orbit–attitude mode (issue 41)
--------------------------------------
For a body of mass m the orbit (r, p = m v) and the attitude (q, Q) together have the
Hamiltonian H = |p|²/(2m) − μ m/|r| + V2(q, r) + ½ gᵀ I⁻¹ g, with MacCullagh's term
V2 = −μ/(2|r|³) (tr I − 3 r̂ᵀ I r̂) (r in body axes; its torque is the gravity gradient above,
τ = −r × ∇V2). The orbit then feels the back-reaction F = −∇_r V2, in body axes

    F = −(3μ tr I/2) |r|⁻⁵ r − 3μ |r|⁻⁵ I r + (15μ/2) (rᵀ I r) |r|⁻⁷ r,

(−∇ of −(μ tr I/2) |r|⁻³ gives the first term, of (3μ/2) (rᵀ I r) |r|⁻⁵ the other two; r × F =
−3μ |r|⁻⁵ r × I r = −τ, so r × p + R(q) g is conserved). In the coupled mode
(``KIND_GRAVITY_GRADIENT_COUPLED``, block :data:`COUPLED`) the body-axes r and v are part of the
state (row Y holds the 14 values of :data:`XSTATE`: q, Q, r_B, v_B), carried from step to step
instead of restarted from Kepler, and v̇ = −μ r/|r|³ + v × ω + F/m. Carrying them in body axes
keeps the recurrences above unchanged (the series start from the state, with no rotation at the
start of a step).
F/m is polynomial in r, |r|⁻⁵ and |r|⁻⁷ = |r|⁻⁵/|r|² (a series division), with the Cauchy
products rᵀ I r and (rᵀ I r) ⋆ |r|⁻⁷ in the extra columns of :data:`XCOL`
(:func:`force_series`); 1/m = 0 turns the back-reaction off (a Kepler orbit integrated in
body axes). The stepping of this mode is in :mod:`attitude._core.taylor_coupled`.

Order and step (Jorba & Zou 2005, Experimental Math. 14, 99–117, Sect. 3.2)
----------------------------------------------------------------------------
Order p = ⌈−½ ln ε + 1⌉ with ε = rtol. Per block b ∈ {q, Q}, with the scale
S_b = max(‖x_b[0]‖∞, atol/rtol) (relative control, or absolute below atol/rtol),
ρ = min_b min_{j ∈ {p−1, p}} (S_b / ‖x_b[j]‖∞)^{1/j} estimates the radius of convergence and the
step is h = ρ/e² · exp(−0.7/(p − 1)), their eqs. 3.7–3.9 (the choice heyoka makes as well).
There is no rejected step.

Layout of the persistent arrays
-------------------------------
``work`` : float64, shape (WORK_ROWS, COL.SIZE)
    rows 0..PMAX: Taylor coefficients of the last step (row k = order k; columns below);
    row Y: the current state (8 values, columns 0..7).
``tstate`` : float64, shape (5,)
    ``[t, h_last, t_old, p, exp(−2 − 0.7/(p − 1))]``: current time, last step, its start, the
    order and the step factor of Jorba & Zou.
``counters`` : int64, shape (5,)
    ``[n_steps, n_series_terms, 0, started, has_step]``.

The coefficient table of the last step stays in ``work`` after every call: :func:`dense_eval`
evaluates that polynomial at any time of the step (for event location).
"""

from __future__ import annotations

import math

import numpy as np

from orbit import _state_kernels as _SK
from orbit._layout import Field, Gap, layout
from orbit._rk import NONFINITE, STEP_TOO_SMALL, SUCCESS, TOO_MANY_STEPS
from orbit._shared_jit import jit
from orbit._taylor import jorba_zou_factor, jorba_zou_order

from .fma import fma as F
from .potentials import (
    HEAVY_TOP,
    KIND_GRAVITY_GRADIENT,
    KIND_GRAVITY_GRADIENT_COUPLED,
    KIND_HEAVY_TOP,
    MODEL,
)
from .quat import rotate_inverse

PMAX = 40  # highest order (rtol = 1e-34; double precision needs p ≤ 20)

# Columns of the coefficient table.
COL = layout(
    "Taylor coefficient columns",
    q=4,
    p=Field(4, "", "Q"),
    g=Field(3, "", "g = ½ vec(q̃∘Q)"),
    w=Field(3, "", "ω = I⁻¹ g"),
    a=Field(3, "", "heavy top: s; gravity gradient: r in body axes"),
    v=Field(3, "", "gravity gradient: v in body axes"),
    r2=Field(1, "", "|r|²"),
    u3=Field(1, "", "|r|⁻³"),
    u5=Field(1, "", "|r|⁻⁵"),
    x=Field(3, "", "r × I r"),
)
# The coupled mode's columns: COL's, then the series of the back-reaction force (the other
# kinds never touch them, and their tables stay COL.SIZE wide).
XCOL = layout(
    "coupled Taylor coefficient columns",
    col=Gap(COL.SIZE),
    u7=Field(1, "", "|r|⁻⁷"),
    rir=Field(1, "", "rᵀ I r"),
    e7=Field(1, "", "(rᵀ I r) |r|⁻⁷"),
)
# The coupled mode's model block (at MODEL.KIND): μ where the gravity gradient reads the orbit's
# μ (MODEL.DATA + orbit._state_kernels.MU), so the torque and orbit series are shared.
COUPLED = layout(
    "coupled gravity gradient block",
    kind=1,
    type=Field(1, "", "unused (the orbit type's place)"),
    mu=Field(1, "m3 s-2", "gravitational parameter μ"),
    inv_mass=Field(1, "1/kg", "1/m (0: no back-reaction on the orbit)"),
)
assert MODEL.KIND + COUPLED.MU == MODEL.DATA + _SK.MU
# The coupled mode's state (row Y; the coefficient columns of q, Q are 0..7, of r, v COL.A, COL.V).
XSTATE = layout(
    "coupled Taylor state",
    q=4,
    p=Field(4, "kg m2/s", "Q"),
    r=Field(3, "m", "position of the centre of mass, body axes"),
    v=Field(3, "m/s", "its velocity (inertial), body axes"),
)
Y = PMAX + 1
#: 1/(k + 1) for the orders of the table: a load instead of a division in the recurrences
#: (the same numbers; a division sat on their chain of dependent operations).
RECIPROCALS = np.array([1.0 / (k + 1.0) for k in range(PMAX + 1)])
WORK_ROWS = PMAX + 2

_EPS = 2.220446049250313e-16


def new_state():
    """Fresh persistent arrays ``(work, tstate, counters)``."""
    return np.zeros((WORK_ROWS, COL.SIZE)), np.zeros(5), np.zeros(5, dtype=np.int64)


@jit
def order_from_tolerance(rtol):
    """Jorba & Zou's order (eq. 3.8, :func:`orbit._taylor.jorba_zou_order`) up to PMAX."""
    return jorba_zou_order(rtol, PMAX)


@jit
def set_order(tstate, p):
    """Store the order p and Jorba & Zou's step factor exp(−2 − 0.7/(p − 1)) in ``tstate``."""
    tstate[3] = p
    tstate[4] = jorba_zou_factor(p)


@jit
def _initial_row(work, t, params):
    """Row 0 of the coefficient table from the state in row Y -> (n, c)."""
    y = work[Y]
    cf = work
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    Q0, Q1, Q2, Q3 = y[4], y[5], y[6], y[7]
    for i in range(8):
        cf[0, i] = y[i]
    # q̃∘Q = (c, 2g)
    c = q0 * Q0 + q1 * Q1 + q2 * Q2 + q3 * Q3
    cf[0, COL.G] = 0.5 * (q0 * Q1 - q1 * Q0 - q2 * Q3 + q3 * Q2)
    cf[0, COL.G + 1] = 0.5 * (q0 * Q2 + q1 * Q3 - q2 * Q0 - q3 * Q1)
    cf[0, COL.G + 2] = 0.5 * (q0 * Q3 - q1 * Q2 + q2 * Q1 - q3 * Q0)
    n = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    kind = int(params[MODEL.KIND])
    q = (q0, q1, q2, q3)
    if kind == KIND_HEAVY_TOP:
        s = rotate_inverse(q, (0.0, 0.0, 1.0))
        cf[0, COL.A] = s[0]
        cf[0, COL.A + 1] = s[1]
        cf[0, COL.A + 2] = s[2]
    elif kind == KIND_GRAVITY_GRADIENT:
        # Exact Kepler restart: the orbit's state at t, in body axes (the trig of the constant
        # angles precomputed in the orbit's kernel data: bit for bit orbit._kernels.state).
        x, yy, z, vx, vy, vz = _SK.orbit_state(params[MODEL.DATA :], t)
        r = rotate_inverse(q, (x, yy, z))
        v = rotate_inverse(q, (vx, vy, vz))
        for i in range(3):
            cf[0, COL.A + i] = r[i]
            cf[0, COL.V + i] = v[i]
    elif kind == KIND_GRAVITY_GRADIENT_COUPLED:
        # Coupled mode: the orbit is carried in the state (body axes, values 8..13), not restarted.
        for i in range(3):
            cf[0, COL.A + i] = y[XSTATE.R + i]
            cf[0, COL.V + i] = y[XSTATE.V + i]
    return n, c


@jit
def taylor_coefficients(cf, p, params, n, c):
    """Fill rows 1..p of the coefficient table ``cf`` from row 0 (see the module docstring).

    Multiply–adds are explicit :func:`~attitude._core.fma.fma` operations (F), nothing is
    contracted or reassociated by the compiler: the SIMD batch version
    (:func:`attitude._core.taylor_batch.taylor_coefficients_lanes`) repeats these operations
    lane by lane and reproduces this table bit for bit.
    """
    kind = int(params[MODEL.KIND])
    coupled = kind == KIND_GRAVITY_GRADIENT_COUPLED
    if coupled:  # the gravity gradient's series, and the back-reaction force (force_series)
        kind = KIND_GRAVITY_GRADIENT
    iI0 = 1.0 / params[0]
    iI1 = 1.0 / params[1]
    iI2 = 1.0 / params[2]
    # Euler: g × ω = ((iI2 − iI1) g1 g2, (iI0 − iI2) g2 g0, (iI1 − iI0) g0 g1)
    e0 = iI2 - iI1
    e1 = iI0 - iI2
    e2 = iI1 - iI0
    inv_n = 1.0 / n
    W = 0.0
    cx = cy = cz = 0.0
    mu = 0.0
    D0 = D1 = D2 = 0.0
    if kind == KIND_HEAVY_TOP:
        W = params[MODEL.KIND + HEAVY_TOP.WEIGHT]
        cx = params[MODEL.KIND + HEAVY_TOP.CM]
        cy = params[MODEL.KIND + HEAVY_TOP.CM + 1]
        cz = params[MODEL.KIND + HEAVY_TOP.CM + 2]
    elif kind == KIND_GRAVITY_GRADIENT:
        mu = params[MODEL.DATA + _SK.MU]
        # r × I r = ((I2 − I1) r1 r2, (I0 − I2) r2 r0, (I1 − I0) r0 r1)
        D0 = params[2] - params[1]
        D1 = params[0] - params[2]
        D2 = params[1] - params[0]
    for k in range(p + 1):
        cf[k, COL.W] = iI0 * cf[k, COL.G]
        cf[k, COL.W + 1] = iI1 * cf[k, COL.G + 1]
        cf[k, COL.W + 2] = iI2 * cf[k, COL.G + 2]
        # A[l][m] = Σ_j (q[j]∘e_m)_l g_m[k−j]:
        # q∘e_0 = (−q1, q0, q3, −q2), q∘e_1 = (−q2, −q3, q0, q1), q∘e_2 = (−q3, q2, −q1, q0).
        a00 = a10 = a20 = a30 = 0.0
        a01 = a11 = a21 = a31 = 0.0
        a02 = a12 = a22 = a32 = 0.0
        # Euler's equations: the Cauchy products g1 ⋆ g2, g2 ⋆ g0, g0 ⋆ g1 (same loop).
        p12 = p20 = p01 = 0.0
        for j in range(k + 1):
            q0 = cf[j, 0]
            q1 = cf[j, 1]
            q2 = cf[j, 2]
            q3 = cf[j, 3]
            g0 = cf[k - j, COL.G]
            g1 = cf[k - j, COL.G + 1]
            g2 = cf[k - j, COL.G + 2]
            p12 = F(cf[j, COL.G + 1], g2, p12)
            p20 = F(cf[j, COL.G + 2], g0, p20)
            p01 = F(cf[j, COL.G], g1, p01)
            a00 = F(-q1, g0, a00)
            a10 = F(q0, g0, a10)
            a20 = F(q3, g0, a20)
            a30 = F(-q2, g0, a30)
            a01 = F(-q2, g1, a01)
            a11 = F(-q3, g1, a11)
            a21 = F(q0, g1, a21)
            a31 = F(q1, g1, a31)
            a02 = F(-q3, g2, a02)
            a12 = F(q2, g2, a12)
            a22 = F(-q1, g2, a22)
            a32 = F(q0, g2, a32)
        if k > 0:
            # Q = q∘(c, 2g)/n
            cf[k, 4] = F(c, cf[k, 0], 2.0 * (a00 + a01 + a02)) * inv_n
            cf[k, 5] = F(c, cf[k, 1], 2.0 * (a10 + a11 + a12)) * inv_n
            cf[k, 6] = F(c, cf[k, 2], 2.0 * (a20 + a21 + a22)) * inv_n
            cf[k, 7] = F(c, cf[k, 3], 2.0 * (a30 + a31 + a32)) * inv_n
        if k == p:
            break
        h = 0.5 / (k + 1.0)
        # q̇ = ½ q∘(0, ω)
        cf[k + 1, 0] = h * F(iI2, a02, F(iI1, a01, iI0 * a00))
        cf[k + 1, 1] = h * F(iI2, a12, F(iI1, a11, iI0 * a10))
        cf[k + 1, 2] = h * F(iI2, a22, F(iI1, a21, iI0 * a20))
        cf[k + 1, 3] = h * F(iI2, a32, F(iI1, a31, iI0 * a30))
        # Torque series τ[k] (and the auxiliary series to order k + 1).
        t0, t1, t2 = torque_series(cf, k, kind, W, cx, cy, cz, mu, D0, D1, D2)
        if coupled:
            force_series(cf, k, params, mu)
        inv = RECIPROCALS[k]
        # Euler's equations: ġ = g × ω + n τ
        cf[k + 1, COL.G] = F(e0, p12, n * t0) * inv
        cf[k + 1, COL.G + 1] = F(e1, p20, n * t1) * inv
        cf[k + 1, COL.G + 2] = F(e2, p01, n * t2) * inv


@jit(inline="always")
def torque_series(cf, k, kind, W, cx, cy, cz, mu, D0, D1, D2):
    """The built-in torque's series τ[k] (heavy top, gravity gradient; 0 otherwise), and its
    auxiliary series to order k + 1, from the rows 0..k of ``cf`` (ω in the COL.W columns).

    Shared by the rigid body (:func:`taylor_coefficients`) and the gyrostat
    (:mod:`attitude._core.taylor_gyrostat`): the same operations in the same order.
    """
    t0 = t1 = t2 = 0.0
    inv = RECIPROCALS[k]
    if kind == KIND_HEAVY_TOP:
        s0 = cf[k, COL.A]
        s1 = cf[k, COL.A + 1]
        s2 = cf[k, COL.A + 2]
        # τ = c × F_B, F_B = −W s
        t0 = -W * F(cy, s2, -cz * s1)
        t1 = -W * F(cz, s0, -cx * s2)
        t2 = -W * F(cx, s1, -cy * s0)
        b0 = b1 = b2 = 0.0
        for j in range(k + 1):
            s0 = cf[j, COL.A]
            s1 = cf[j, COL.A + 1]
            s2 = cf[j, COL.A + 2]
            w0 = cf[k - j, COL.W]
            w1 = cf[k - j, COL.W + 1]
            w2 = cf[k - j, COL.W + 2]
            b0 = F(s1, w2, F(-s2, w1, b0))
            b1 = F(s2, w0, F(-s0, w2, b1))
            b2 = F(s0, w1, F(-s1, w0, b2))
        cf[k + 1, COL.A] = b0 * inv
        cf[k + 1, COL.A + 1] = b1 * inv
        cf[k + 1, COL.A + 2] = b2 * inv
    elif kind == KIND_GRAVITY_GRADIENT:
        # |r|², r × I r at order k
        s = 0.0
        x0 = x1 = x2 = 0.0
        for j in range(k + 1):
            r0 = cf[j, COL.A]
            r1 = cf[j, COL.A + 1]
            r2 = cf[j, COL.A + 2]
            u0 = cf[k - j, COL.A]
            u1 = cf[k - j, COL.A + 1]
            u2 = cf[k - j, COL.A + 2]
            s = F(r2, u2, F(r1, u1, F(r0, u0, s)))
            x0 = F(r1, u2, x0)
            x1 = F(r2, u0, x1)
            x2 = F(r0, u1, x2)
        cf[k, COL.R2] = s
        cf[k, COL.X] = D0 * x0
        cf[k, COL.X + 1] = D1 * x1
        cf[k, COL.X + 2] = D2 * x2
        s00 = cf[0, COL.R2]
        if k == 0:
            cf[0, COL.U3] = 1.0 / (s00 * math.sqrt(s00))
            cf[0, COL.U5] = cf[0, COL.U3] / s00
        else:
            # u = s^(−3/2): power recurrence; |r|⁻⁵ = u / s: division.
            acc = 0.0
            for j in range(k):
                acc = F((-1.5 * (k - j) - j) * cf[k - j, COL.R2], cf[j, COL.U3], acc)
            cf[k, COL.U3] = acc / (k * s00)
            acc = cf[k, COL.U3]
            for j in range(1, k + 1):
                acc = F(-cf[j, COL.R2], cf[k - j, COL.U5], acc)
            cf[k, COL.U5] = acc / s00
        # τ[k] = 3μ (|r|⁻⁵ ⋆ r × I r)[k];  ṙ = v + r × ω;  v̇ = −μ |r|⁻³ r + v × ω
        b0 = b1 = b2 = 0.0
        d0 = d1 = d2 = 0.0
        f0 = f1 = f2 = 0.0
        for j in range(k + 1):
            u5 = cf[j, COL.U5]
            u3 = cf[j, COL.U3]
            w0 = cf[k - j, COL.W]
            w1 = cf[k - j, COL.W + 1]
            w2 = cf[k - j, COL.W + 2]
            r0 = cf[j, COL.A]
            r1 = cf[j, COL.A + 1]
            r2 = cf[j, COL.A + 2]
            v0 = cf[j, COL.V]
            v1 = cf[j, COL.V + 1]
            v2 = cf[j, COL.V + 2]
            t0 = F(u5, cf[k - j, COL.X], t0)
            t1 = F(u5, cf[k - j, COL.X + 1], t1)
            t2 = F(u5, cf[k - j, COL.X + 2], t2)
            b0 = F(r1, w2, F(-r2, w1, b0))
            b1 = F(r2, w0, F(-r0, w2, b1))
            b2 = F(r0, w1, F(-r1, w0, b2))
            d0 = F(v1, w2, F(-v2, w1, d0))
            d1 = F(v2, w0, F(-v0, w2, d1))
            d2 = F(v0, w1, F(-v1, w0, d2))
            f0 = F(u3, cf[k - j, COL.A], f0)
            f1 = F(u3, cf[k - j, COL.A + 1], f1)
            f2 = F(u3, cf[k - j, COL.A + 2], f2)
        t0 *= 3.0 * mu
        t1 *= 3.0 * mu
        t2 *= 3.0 * mu
        cf[k + 1, COL.A] = (cf[k, COL.V] + b0) * inv
        cf[k + 1, COL.A + 1] = (cf[k, COL.V + 1] + b1) * inv
        cf[k + 1, COL.A + 2] = (cf[k, COL.V + 2] + b2) * inv
        cf[k + 1, COL.V] = F(-mu, f0, d0) * inv
        cf[k + 1, COL.V + 1] = F(-mu, f1, d1) * inv
        cf[k + 1, COL.V + 2] = F(-mu, f2, d2) * inv
    return t0, t1, t2


@jit
def force_series(cf, k, params, mu):
    """Coupled mode: add the back-reaction F_B/m at order k to v[k + 1] (after
    :func:`torque_series`, which filled r, |r|², |r|⁻⁵ to order k and v[k + 1] without it).

    F/m = (3μ/m) (−(tr I/2 + I_i) |r|⁻⁵ r_i + (5/2) (rᵀ I r) |r|⁻⁷ r_i) (module docstring),
    with rᵀ I r, |r|⁻⁷ = |r|⁻⁵/|r|² and (rᵀ I r) |r|⁻⁷ at order k in the :data:`XCOL` columns.
    """
    I0 = params[0]
    I1 = params[1]
    I2 = params[2]
    # rᵀ I r at order k
    e = 0.0
    for j in range(k + 1):
        e = F(I0 * cf[j, COL.A], cf[k - j, COL.A], e)
        e = F(I1 * cf[j, COL.A + 1], cf[k - j, COL.A + 1], e)
        e = F(I2 * cf[j, COL.A + 2], cf[k - j, COL.A + 2], e)
    cf[k, XCOL.RIR] = e
    # |r|⁻⁷ = |r|⁻⁵ / |r|²: division (as |r|⁻⁵ from |r|⁻³)
    acc = cf[k, COL.U5]
    for j in range(1, k + 1):
        acc = F(-cf[j, COL.R2], cf[k - j, XCOL.U7], acc)
    cf[k, XCOL.U7] = acc / cf[0, COL.R2]
    acc = 0.0
    for j in range(k + 1):
        acc = F(cf[j, XCOL.RIR], cf[k - j, XCOL.U7], acc)
    cf[k, XCOL.E7] = acc
    # |r|⁻⁵ ⋆ r and (rᵀ I r) |r|⁻⁷ ⋆ r
    a0 = a1 = a2 = 0.0
    b0 = b1 = b2 = 0.0
    for j in range(k + 1):
        u5 = cf[j, COL.U5]
        e7 = cf[j, XCOL.E7]
        r0 = cf[k - j, COL.A]
        r1 = cf[k - j, COL.A + 1]
        r2 = cf[k - j, COL.A + 2]
        a0 = F(u5, r0, a0)
        a1 = F(u5, r1, a1)
        a2 = F(u5, r2, a2)
        b0 = F(e7, r0, b0)
        b1 = F(e7, r1, b1)
        b2 = F(e7, r2, b2)
    th = 0.5 * (I0 + I1 + I2)
    s = 3.0 * mu * params[MODEL.KIND + COUPLED.INV_MASS] * RECIPROCALS[k]
    cf[k + 1, COL.V] += s * F(2.5, b0, -(th + I0) * a0)
    cf[k + 1, COL.V + 1] += s * F(2.5, b1, -(th + I1) * a1)
    cf[k + 1, COL.V + 2] += s * F(2.5, b2, -(th + I2) * a2)


@jit
def _block_norm(cf, k, c0):
    m = 0.0
    for i in range(c0, c0 + 4):
        a = abs(cf[k, i])
        if a > m:
            m = a
    return m


@jit
def _radius(cf, p, rtol, atol):
    """Jorba & Zou's ρ (eq. 3.7) over the q and Q blocks; inf when the series terminates."""
    floor = atol / rtol
    sq = max(_block_norm(cf, 0, 0), floor)
    sp = max(_block_norm(cf, 0, 4), floor)
    rho = order_radius(sq, sp, _block_norm(cf, p - 1, 0), _block_norm(cf, p - 1, 4), p - 1)
    return min(rho, order_radius(sq, sp, _block_norm(cf, p, 0), _block_norm(cf, p, 4), p))


@jit(inline="always")
def order_radius(sq, sp, nq, nQ, j):
    """(‖q‖/‖q_j‖)^(1/j) and (‖Q‖/‖Q_j‖)^(1/j), the smaller (inf if both coefficients vanish):
    the term of order j in ρ (the min over the blocks before the root: x -> x^(1/j) is
    increasing). Shared by the single run and the lanes of the batch."""
    ratio = math.inf
    if nq > 0.0:
        ratio = sq / nq
    if nQ > 0.0:
        ratio = min(ratio, sp / nQ)
    if ratio < math.inf:
        return ratio ** (1.0 / j)
    return math.inf


@jit
def dense_eval(work, p, tau, out):
    """Evaluate the 8 state polynomials of the last step at ``tau`` = t − t_old (Horner; the
    eight recurrences side by side, so they overlap in the pipeline)."""
    a0, a1, a2, a3 = work[p, 0], work[p, 1], work[p, 2], work[p, 3]
    a4, a5, a6, a7 = work[p, 4], work[p, 5], work[p, 6], work[p, 7]
    for k in range(p - 1, -1, -1):
        a0 = F(a0, tau, work[k, 0])
        a1 = F(a1, tau, work[k, 1])
        a2 = F(a2, tau, work[k, 2])
        a3 = F(a3, tau, work[k, 3])
        a4 = F(a4, tau, work[k, 4])
        a5 = F(a5, tau, work[k, 5])
        a6 = F(a6, tau, work[k, 6])
        a7 = F(a7, tau, work[k, 7])
    out[0], out[1], out[2], out[3] = a0, a1, a2, a3
    out[4], out[5], out[6], out[7] = a4, a5, a6, a7


@jit
def taylor_step(params, work, tstate, counters, rtol, atol, t_end, max_step):
    """One Taylor step from the state in ``work[Y]`` at ``tstate[0]``; returns a status.

    The coefficient table of the step stays in ``work`` (rows 0..p) for :func:`dense_eval`.
    """
    p = int(tstate[3])
    n, c = _initial_row(work, tstate[0], params)
    taylor_coefficients(work, p, params, n, c)
    counters[1] += p
    return step_from_coefficients(work, tstate, counters, rtol, atol, t_end, max_step)


@jit(inline="always")
def step_end(t, h_abs, t_end, max_step):
    """(status, end time) of a step of size ``h_abs`` from ``t`` toward ``t_end``: capped by
    ``max_step`` and by ``t_end``; NONFINITE for a NaN size, STEP_TOO_SMALL below round-off.
    Shared by the single run and the lanes of the batch integrator (the same operations)."""
    direction = 1.0 if t_end >= t else -1.0
    if not h_abs <= max_step:  # also catches a NaN radius
        if math.isnan(h_abs):
            return NONFINITE, t
        h_abs = max_step
    min_step = 10.0 * _EPS * max(abs(t), 1e-300)
    t_new = t + direction * h_abs
    if direction * (t_new - t_end) >= 0.0:
        t_new = t_end
    elif h_abs < min_step:
        return STEP_TOO_SMALL, t
    return SUCCESS, t_new


@jit
def step_from_coefficients(work, tstate, counters, rtol, atol, t_end, max_step):
    """The rest of :func:`taylor_step` once the coefficient table of the step is in ``work``:
    Jorba & Zou's step from it, the state at the end of the step, the step's bookkeeping.

    Also called lane by lane by the batch integrator (:mod:`attitude._core.taylor_batch`)
    with ``work`` a view of one lane, so a member of a batch steps exactly as it does alone.
    """
    p = int(tstate[3])
    t = tstate[0]
    rho = _radius(work, p, rtol, atol)
    h_abs = rho * tstate[4]  # exp(−2 − 0.7/(p − 1)), set with the order
    status, t_new = step_end(t, h_abs, t_end, max_step)
    if status != SUCCESS:
        return status
    h = t_new - t
    y = work[Y]
    dense_eval(work, p, h, y)
    for i in range(8):
        if not math.isfinite(y[i]):
            # Keep the state at the start of the step (work row 0) as the current state.
            for ii in range(8):
                y[ii] = work[0, ii]
            return NONFINITE
    tstate[2] = t
    tstate[1] = h
    tstate[0] = t_new
    counters[0] += 1
    counters[4] = 1
    return SUCCESS


@jit
def taylor_canonical_builtin(
    params, y0, t0, t_out, y_out, work, tstate, counters, rtol, atol, t_end, max_step, max_steps
):
    """Integrate from the stored state through the output times ``t_out``: the cached entry
    point, with the arguments of ``entry_points.dop853_canonical``.

    On the first call (``counters[3] == 0``) the state is initialised from ``(t0, y0)``; later
    calls continue from ``work``/``tstate`` bit for bit. Returns ``(status, n_done)``.
    """
    m = t_out.shape[0]
    y = work[Y]
    if counters[3] == 0:
        for i in range(8):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        set_order(tstate, order_from_tolerance(rtol))
        counters[3] = 1
        counters[4] = 0
    direction = 1.0 if t_end >= tstate[0] else -1.0
    k = 0
    while True:
        k = emit_samples(work, tstate, counters, t_out, y_out, k, direction)
        if k >= m:
            return SUCCESS, k
        if counters[0] >= max_steps:
            return TOO_MANY_STEPS, k
        status = taylor_step(params, work, tstate, counters, rtol, atol, t_end, max_step)
        if status != SUCCESS:
            return status, k


@jit
def emit_samples(work, tstate, counters, t_out, y_out, k, direction):
    """Write the output samples ``k, k + 1, ...`` that need no further step: the current
    state at its own time, the step polynomial inside the last step. Returns the next ``k``."""
    m = t_out.shape[0]
    p = int(tstate[3])
    y = work[Y]
    while k < m:
        to = t_out[k]
        t = tstate[0]
        if to == t:
            for i in range(8):
                y_out[k, i] = y[i]
        elif counters[4] == 1 and direction * (to - tstate[2]) >= 0.0 and direction * (t - to) > 0:
            dense_eval(work, p, to - tstate[2], y_out[k])
        else:
            break
        k += 1
    return k

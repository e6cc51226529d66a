"""Compiled adaptive Taylor-series integration of an Earth orbit (``method="taylor"``).

The equations are those the DOP853 path integrates (:mod:`orbit._force_kernels`): ṙ = v,
v̇ = a(t, r) in the GCRS, a the Earth's point mass or spherical harmonics (evaluated in the
ITRS, x_ITRS = R(t) x_GCRS) plus the third bodies. A Taylor method computes the Taylor
coefficients of the solution through the current state to an order p by series arithmetic
(automatic differentiation: Cauchy products, division, powers; Jorba & Zou 2005, Experimental
Math. 14, 99–117, Sect. 2) and sums them: r[k + 1] = v[k]/(k + 1), v[k + 1] = a[k]/(k + 1),
with a[k] from the orders ≤ k of r.

Series of the force model
-------------------------
* point mass: |r|² (three Cauchy products), |r|⁻³ = (|r|²)^(−3/2) by the power recurrence,
  a = −μ |r|⁻³ ⋆ r;
* the field: :mod:`orbit._taylor_field` (Pines' recursion in series) on the Earth-fixed
  position;
* the Earth's rotation R = R3(θ) M is a function of time alone, expanded once per step:
  ``earth_rotation="uniform"``: θ = θ0 + ω t, M = I, cos θ and sin θ by their recurrence (exact
  series of a rotation at a constant rate); ``"iers"``: θ's residual and M are the degree-7
  Lagrange polynomials the force kernel interpolates (600 s nodes), re-expanded about the step's
  start (exact Taylor coefficients of that polynomial), cos θ and sin θ by the recurrence
  c' = −s θ', s' = c θ';
* a third body at s(t): s is the degree-7 Hermite polynomial of its table (4 nodes), re-expanded
  about the step's start; μ[(s − r)/|s − r|³ − s/|s|³] in series, its order 0 in Battin's form
  (:func:`orbit._gravity_field_kernels.third_body`, the DOP853 path's value: the two terms cancel
  there, not in the higher orders, where the satellite's motion dominates both).

The interpolating polynomial of a table is the one of the window around the step's start (the
kernel picks the window around each time): a step never leaves that window, where both
interpolants agree to the table's accuracy (2e-12 rad for the Earth's orientation).

Order and step (Jorba & Zou 2005, Sect. 3.2)
---------------------------------------------
p = ⌈−½ ln ε + 1⌉ with ε = ``rtol``; ρ = min over j ∈ {p − 1, p} and the blocks r, v of
(S_b / ‖x_b[j]‖∞)^{1/j}, S_b = max(‖x_b[0]‖∞, atol/rtol); h = ρ exp(−2 − 0.7/(p − 1)); no
rejected steps. Steps never stop at output times (dense output: the step's polynomials).

Layout of the persistent arrays
-------------------------------
``S`` : float64, shape (:func:`n_rows`, PMAX + 1)
    one series a row (:data:`ROWS`, then :data:`BODY` per third body, then the field's rows of
    :mod:`orbit._taylor_field`); rows 0..5 hold the last step's polynomials of x, y, z, vx, vy,
    vz (m, m/s; coefficient k of τ^k, τ = t − t_old), row ``ROWS.NOW`` the current state.
``tstate`` : float64, shape (5,)
    ``[t, h_last, t_old, p, exp(−2 − 0.7/(p − 1))]``.
``counters`` : int64, shape (5,)
    ``[n_steps, n_orders, 0, started, has_step]``.
"""

from __future__ import annotations

import math

import numpy as np

from . import _force_kernels as _fk
from . import _gravity_field_kernels as _kg
from . import _state_kernels as _sk
from . import _taylor_field as _tf
from ._force_kernels import _LAGRANGE_DEN, FORCES, IMPACT
from ._layout import layout
from ._rk import NONFINITE, STEP_TOO_SMALL, SUCCESS, TOO_MANY_STEPS
from ._shared_jit import jit
from ._taylor_field import cauchy, field_order, power_order

__all__ = [
    "PMAX", "ROWS", "dense_eval", "jorba_zou_factor", "jorba_zou_order", "n_rows", "new_state",
    "order_from_tolerance", "run",
]  # fmt: skip

#: Highest order (rtol ≥ 1e-15 gives p ≤ 19).
PMAX = 24
#: Degree of the tables' interpolating polynomials (Lagrange on 8 nodes, Hermite on 4).
_TABLE_DEGREE = 7

ROWS = layout(
    "orbit Taylor series rows",
    x=1, y=1, z=1, vx=1, vy=1, vz=1,  # the state (GCRS, m, m/s)
    now=1,  # the current state (columns 0..5)
    r2=1,  # |r|²
    u3=1,  # |r|⁻³ (point mass)
    th=1, co=1, si=1,  # θ, cos θ, sin θ
    m=9,  # M (row-major; "iers" only)
    mx=1, my=1, mz=1,  # M r
    xi=1, yi=1, zi=1,  # R r (ITRS)
    gx=1, gy=1, gz=1,  # the field's acceleration (ITRS)
    hx=1, hy=1, hz=1,  # R3(θ)ᵀ g
)  # fmt: skip
BODY = layout(
    "third-body series rows",
    sx=1, sy=1, sz=1,  # the body's position (m)
    s2=1, us=1,  # |s|², |s|⁻³
    tx=1, ty=1, tz=1,  # |s|⁻³ s
    dx=1, dy=1, dz=1,  # r − s
    d2=1, ud=1,  # |r − s|², its −3/2 power
)  # fmt: skip


def n_rows(n_max: int, m_max: int, n_bodies: int) -> int:
    """Rows of ``S`` for a field of degree ``n_max``, order ``m_max`` and ``n_bodies``."""
    return ROWS.SIZE + BODY.SIZE * n_bodies + (_tf.FIELD_ROWS.SIZE if n_max > 0 else 0)


def new_state(n_max: int, m_max: int, n_bodies: int):
    """Fresh persistent arrays ``(S, F, tstate, counters)`` (``F``: the field's planes,
    :mod:`orbit._taylor_field`)."""
    return (
        np.zeros((n_rows(n_max, m_max, n_bodies), PMAX + 1)),
        _tf.new_field_state(n_max, PMAX),
        np.zeros(5),
        np.zeros(5, dtype=np.int64),
    )


@jit
def jorba_zou_order(rtol, pmax):
    """Jorba & Zou's order p = ⌈−½ ln ε + 1⌉ (eq. 3.8), clipped to [2, pmax] (the attitude's
    Taylor method shares it, with its own pmax)."""
    p = int(math.ceil(-0.5 * math.log(rtol) + 1.0))  # noqa: RUF046 (numba: float ceil)
    return min(max(p, 2), pmax)


@jit
def jorba_zou_factor(p):
    """Jorba & Zou's step factor exp(−2 − 0.7/(p − 1)) of order p (their safety factor
    exp(−0.7/(p − 1)))."""
    return math.exp(-2.0 - 0.7 / (p - 1.0))


@jit
def order_from_tolerance(rtol):
    """:func:`jorba_zou_order` up to this module's PMAX."""
    return jorba_zou_order(rtol, PMAX)


@jit(inline="always")
def _shift_poly(c, x0):
    """Multiply the polynomial ``c`` (coefficients of δ⁰..δ⁷, in place) by (δ + x0)."""
    for i in range(_TABLE_DEGREE, 0, -1):
        c[i] = c[i] * x0 + c[i - 1]
    c[0] *= x0


@jit
def _sincos(S, p):
    """cos θ and sin θ to order p from θ's series (c' = −s θ', s' = c θ'; θ has ≤ 8 terms)."""
    S[ROWS.CO, 0] = math.cos(S[ROWS.TH, 0])
    S[ROWS.SI, 0] = math.sin(S[ROWS.TH, 0])
    for k in range(1, p + 1):
        c = 0.0
        s = 0.0
        for j in range(1, min(k, _TABLE_DEGREE) + 1):
            w = j * S[ROWS.TH, j]
            c -= w * S[ROWS.SI, k - j]
            s += w * S[ROWS.CO, k - j]
        S[ROWS.CO, k] = c / k
        S[ROWS.SI, k] = s / k


@jit
def _rotation_series(d, S, t, p, direction):
    """R(t + τ)'s series (θ, cos θ, sin θ, M) to order p; returns how far (s, in ``direction``)
    the interpolating polynomial of the window at t reaches (inf: uniform rotation)."""
    n = int(d[FORCES.EO_N])
    for i in range(p + 1):
        S[ROWS.TH, i] = 0.0
    S[ROWS.TH, 0] = d[FORCES.THETA0] + d[FORCES.OMEGA] * t
    S[ROWS.TH, 1] = d[FORCES.OMEGA]
    reach = math.inf
    if n > 0:
        for e in range(9):
            for i in range(p + 1):
                S[ROWS.M + e, i] = 0.0
        h = d[FORCES.EO_H]
        j0, x = _fk.eop_window(d, t)
        mo = int(d[FORCES.EO_M]) + 9 * j0
        do = int(d[FORCES.EO_DTH]) + j0
        c = np.empty(_TABLE_DEGREE + 1)
        top = min(p, _TABLE_DEGREE)
        for j in range(8):
            # the Lagrange basis polynomial of node j in δ = x(t + τ) − x(t), then τ = h δ
            c[:] = 0.0
            c[0] = _LAGRANGE_DEN[j]
            for kk in range(8):
                if kk != j:
                    _shift_poly(c, x - kk)
            scale = 1.0
            for i in range(top + 1):
                w = c[i] * scale
                scale /= h
                S[ROWS.TH, i] += w * d[do + j]
                for e in range(9):
                    S[ROWS.M + e, i] += w * d[mo + 9 * j + e]
        t_lo = d[FORCES.EO_T0] + j0 * h
        reach = t_lo + 7.0 * h - t if direction > 0.0 else t - t_lo
    _sincos(S, p)
    return reach


@jit
def _body_series(d, S, t, p, direction, row, to):
    """A third body's position series (table at ``d[to:]``, km -> m) and |s|⁻³ s to order p
    in the rows from ``row``; returns how far the window's polynomial reaches (s)."""
    n = int(d[to + _sk.E_N])
    tt = to + _sk.E_TIMES
    roff = tt + n
    i = _sk.table_interval(d, tt, n, d[to + _sk.E_H], t)
    j0 = min(max(i - 1, 0), n - 4)
    for c in range(3):
        for k in range(p + 1):
            S[row + BODY.SX + c, k] = 0.0
    L = np.empty(_TABLE_DEGREE + 1)
    top = min(p, _TABLE_DEGREE)
    for j in range(4):
        tj = d[tt + j0 + j]
        # L_j(t + τ) = Π (τ + t − t_k)/(t_j − t_k); a_j = (1 − 2 c_j (t + τ − t_j)) L_j²,
        # b_j = (t + τ − t_j) L_j² (orbit._state_kernels.hermite_weights4)
        L[:] = 0.0
        L[0] = 1.0
        cj = 0.0
        for kk in range(4):
            if kk != j:
                tk = d[tt + j0 + kk]
                L[0] /= tj - tk
                cj += 1.0 / (tj - tk)
        for kk in range(4):
            if kk != j:
                _shift_poly(L, t - d[tt + j0 + kk])
        q = np.zeros(_TABLE_DEGREE + 1)  # L_j², degree 6
        for a in range(4):
            for b in range(4):
                q[a + b] += L[a] * L[b]
        x0 = t - tj
        for i in range(top + 1):
            qm = q[i - 1] if i > 0 else 0.0
            wa = (1.0 - 2.0 * cj * x0) * q[i] - 2.0 * cj * qm
            wb = x0 * q[i] + qm
            r = roff + 6 * (j0 + j)
            for c in range(3):
                S[row + BODY.SX + c, i] += 1e3 * (wa * d[r + c] + wb * d[r + 3 + c])
    S2 = row + BODY.S2
    US = row + BODY.US
    for k in range(p + 1):
        S[S2, k] = (cauchy(S, row + BODY.SX, row + BODY.SX, k)
                    + cauchy(S, row + BODY.SY, row + BODY.SY, k)
                    + cauchy(S, row + BODY.SZ, row + BODY.SZ, k))  # fmt: skip
        if k == 0:
            S[US, 0] = 1.0 / (S[S2, 0] * math.sqrt(S[S2, 0]))
        else:
            S[US, k] = power_order(S, S2, US, k, -1.5)
        for c in range(3):
            S[row + BODY.TX + c, k] = cauchy(S, US, row + BODY.SX + c, k)
    t_lo = d[tt + j0]
    t_hi = d[tt + j0 + 3]
    return t_hi - t if direction > 0.0 else t - t_lo


@jit
def _short(S, a, b, k):
    """Order k of S[a] ⋆ S[b] with S[a] a polynomial of degree ≤ 7 (a table's)."""
    acc = 0.0
    for j in range(min(k, _TABLE_DEGREE) + 1):
        acc += S[a, j] * S[b, k - j]
    return acc


@jit
def _acceleration_order(d, S, F, k, f0, nb):
    """Order k of the acceleration (GCRS, m/s²) from the orders ≤ k of r."""
    nmax = int(d[FORCES.N_MAX])
    mu = d[FORCES.MU]
    X = ROWS.X
    Y = ROWS.Y
    Z = ROWS.Z
    R2 = ROWS.R2
    S[R2, k] = cauchy(S, X, X, k) + cauchy(S, Y, Y, k) + cauchy(S, Z, Z, k)
    if nmax == 0:
        if k == 0:
            S[ROWS.U3, 0] = 1.0 / (S[R2, 0] * math.sqrt(S[R2, 0]))
        else:
            S[ROWS.U3, k] = power_order(S, R2, ROWS.U3, k, -1.5)
        ax = -mu * cauchy(S, ROWS.U3, X, k)
        ay = -mu * cauchy(S, ROWS.U3, Y, k)
        az = -mu * cauchy(S, ROWS.U3, Z, k)
    else:
        iers = int(d[FORCES.EO_N]) > 0
        if iers:  # M r
            for i in range(3):
                S[ROWS.MX + i, k] = (_short(S, ROWS.M + 3 * i, X, k)
                                     + _short(S, ROWS.M + 3 * i + 1, Y, k)
                                     + _short(S, ROWS.M + 3 * i + 2, Z, k))  # fmt: skip
            X = ROWS.MX
            Y = ROWS.MY
            Z = ROWS.MZ
        # R3(θ) = [[c, s, 0], [−s, c, 0], [0, 0, 1]]
        S[ROWS.XI, k] = cauchy(S, ROWS.CO, X, k) + cauchy(S, ROWS.SI, Y, k)
        S[ROWS.YI, k] = cauchy(S, ROWS.CO, Y, k) - cauchy(S, ROWS.SI, X, k)
        S[ROWS.ZI, k] = S[Z, k]
        gx, gy, gz = field_order(d, S, F, k, f0, ROWS.XI, ROWS.YI, ROWS.ZI, R2)
        S[ROWS.GX, k] = gx
        S[ROWS.GY, k] = gy
        S[ROWS.HZ, k] = gz
        S[ROWS.HX, k] = cauchy(S, ROWS.CO, ROWS.GX, k) - cauchy(S, ROWS.SI, ROWS.GY, k)
        S[ROWS.HY, k] = cauchy(S, ROWS.SI, ROWS.GX, k) + cauchy(S, ROWS.CO, ROWS.GY, k)
        if iers:  # Mᵀ R3(θ)ᵀ g
            ax = ay = az = 0.0
            for i in range(3):
                ax += _short(S, ROWS.M + 3 * i, ROWS.HX + i, k)
                ay += _short(S, ROWS.M + 3 * i + 1, ROWS.HX + i, k)
                az += _short(S, ROWS.M + 3 * i + 2, ROWS.HX + i, k)
        else:
            ax = S[ROWS.HX, k]
            ay = S[ROWS.HY, k]
            az = S[ROWS.HZ, k]
    bo = int(d[FORCES.BODIES])
    for b in range(nb):
        mub = d[bo + 2 * b]
        row = ROWS.SIZE + BODY.SIZE * b
        for c in range(3):
            S[row + BODY.DX + c, k] = S[ROWS.X + c, k] - S[row + BODY.SX + c, k]
        D2 = row + BODY.D2
        UD = row + BODY.UD
        S[D2, k] = (cauchy(S, row + BODY.DX, row + BODY.DX, k)
                    + cauchy(S, row + BODY.DY, row + BODY.DY, k)
                    + cauchy(S, row + BODY.DZ, row + BODY.DZ, k))  # fmt: skip
        if k == 0:
            S[UD, 0] = 1.0 / (S[D2, 0] * math.sqrt(S[D2, 0]))
            px, py, pz = _kg.third_body(mub, S[row + BODY.SX, 0], S[row + BODY.SY, 0],
                                        S[row + BODY.SZ, 0], S[ROWS.X, 0], S[ROWS.Y, 0],
                                        S[ROWS.Z, 0])  # fmt: skip
        else:
            S[UD, k] = power_order(S, D2, UD, k, -1.5)
            px = -mub * (cauchy(S, UD, row + BODY.DX, k) + S[row + BODY.TX, k])
            py = -mub * (cauchy(S, UD, row + BODY.DY, k) + S[row + BODY.TY, k])
            pz = -mub * (cauchy(S, UD, row + BODY.DZ, k) + S[row + BODY.TZ, k])
        ax += px
        ay += py
        az += pz
    return ax, ay, az


@jit
def coefficients(d, S, F, t, p, direction):
    """The Taylor coefficients (orders 0..p, rows 0..5 of ``S``) of the solution through the
    state in row ``ROWS.NOW`` at time t; returns how far (s, in ``direction``) the tables'
    polynomials of this step reach."""
    nb = int(d[FORCES.N_BODIES])
    f0 = ROWS.SIZE + BODY.SIZE * nb
    reach = math.inf
    if int(d[FORCES.N_MAX]) > 0:
        reach = _rotation_series(d, S, t, p, direction)
    bo = int(d[FORCES.BODIES])
    for b in range(nb):
        reach = min(reach, _body_series(d, S, t, p, direction, ROWS.SIZE + BODY.SIZE * b,
                                        int(d[bo + 2 * b + 1])))  # fmt: skip
    for i in range(6):
        S[i, 0] = S[ROWS.NOW, i]
    for k in range(p):
        ax, ay, az = _acceleration_order(d, S, F, k, f0, nb)
        inv = 1.0 / (k + 1.0)
        S[ROWS.X, k + 1] = S[ROWS.VX, k] * inv
        S[ROWS.Y, k + 1] = S[ROWS.VY, k] * inv
        S[ROWS.Z, k + 1] = S[ROWS.VZ, k] * inv
        S[ROWS.VX, k + 1] = ax * inv
        S[ROWS.VY, k + 1] = ay * inv
        S[ROWS.VZ, k + 1] = az * inv
    return reach


@jit
def _radius(S, p, rtol, atol):
    """Jorba & Zou's ρ (eq. 3.7) over the blocks r and v (inf when the series end)."""
    floor = atol / rtol
    rho = math.inf
    for b in range(2):
        s = floor
        for i in range(3 * b, 3 * b + 3):
            s = max(s, abs(S[i, 0]))
        for j in (p - 1, p):
            nj = 0.0
            for i in range(3 * b, 3 * b + 3):
                nj = max(nj, abs(S[i, j]))
            if nj > 0.0:
                rho = min(rho, (s / nj) ** (1.0 / j))
    return rho


@jit
def dense_eval(S, p, tau, out):
    """The state (6,) at ``tau`` = t − t_old on the last step's polynomials (Horner)."""
    for i in range(6):
        a = S[i, p]
        for k in range(p - 1, -1, -1):
            a = a * tau + S[i, k]
        out[i] = a


@jit
def taylor_step(d, S, F, tstate, counters, rtol, atol, t_stop, max_step):
    """One Taylor step from (``tstate[0]``, ``S[ROWS.NOW]``) toward ``t_stop``; returns a status
    (SUCCESS, NONFINITE or STEP_TOO_SMALL). The step's polynomials stay in rows 0..5."""
    p = int(tstate[3])
    t = tstate[0]
    direction = 1.0 if t_stop >= t else -1.0
    reach = coefficients(d, S, F, t, p, direction)
    counters[1] += p
    h_abs = _radius(S, p, rtol, atol) * tstate[4]
    if not h_abs <= min(max_step, reach):  # also a NaN radius
        if math.isnan(h_abs):
            return NONFINITE
        h_abs = min(max_step, reach)
    t_new = t + direction * h_abs
    if direction * (t_new - t_stop) >= 0.0:
        t_new = t_stop
    elif h_abs < 10.0 * 2.220446049250313e-16 * max(abs(t), 1e-300):
        return STEP_TOO_SMALL
    y = S[ROWS.NOW]
    dense_eval(S, p, t_new - t, y)
    for i in range(6):
        if not math.isfinite(y[i]):
            for ii in range(6):
                y[ii] = S[ii, 0]
            return NONFINITE
    tstate[2] = t
    tstate[1] = t_new - t
    tstate[0] = t_new
    counters[0] += 1
    counters[4] = 1
    return SUCCESS


@jit
def crossing(d, S, tstate, out):
    """The first time of the last step where the orbit is inside the Earth (it is at the step's
    end, not at its start): bisection on the step's polynomials to the last bit, the state
    there in ``out``. Returns the time."""
    p = int(tstate[3])
    t_old = tstate[2]
    lo = t_old
    hi = tstate[0]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid == lo or mid == hi:
            break
        dense_eval(S, p, mid - t_old, out)
        if _fk.inside(d, mid, out):
            hi = mid
        else:
            lo = mid
    dense_eval(S, p, hi - t_old, out)
    return hi


@jit
def run(d, y0, t0, t_out, y_out, S, F, tstate, counters, rtol, atol, t_stop, max_step, max_steps,
        impact):  # fmt: skip
    """Integrate the orbit through the output times ``t_out``: the arguments and returns of
    :func:`orbit._force_kernels.run` (``S`` and ``F`` in place of DOP853's ``work``), from
    ``(t0, y0)`` on the first call (``counters[3] == 0``), else continuing bit for bit from the
    stored state.
    Steps never cross ``t_stop`` (±inf: they do not depend on the outputs asked for).

    Returns ``(status, n_done, t_impact)``.
    """
    m = t_out.shape[0]
    y = S[ROWS.NOW]
    if counters[3] == 0:
        for i in range(6):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        p = order_from_tolerance(rtol)
        tstate[3] = p
        tstate[4] = jorba_zou_factor(p)
        counters[3] = 1
        counters[4] = 0
    p = int(tstate[3])
    direction = 1.0 if t_stop >= tstate[0] else -1.0
    k = 0
    while True:
        while k < m:
            to = t_out[k]
            t = tstate[0]
            if to == t:
                for i in range(6):
                    y_out[k, i] = y[i]
            elif (counters[4] == 1 and direction * (to - tstate[2]) >= 0.0
                  and direction * (t - to) > 0.0):  # fmt: skip
                dense_eval(S, p, to - tstate[2], y_out[k])
            else:
                break
            k += 1
        if k == m:
            return SUCCESS, k, math.nan
        if counters[0] >= max_steps:
            return TOO_MANY_STEPS, k, math.nan
        status = taylor_step(d, S, F, tstate, counters, rtol, atol, t_stop, max_step)
        if status != SUCCESS:
            return status, k, math.nan
        if _fk.inside(d, tstate[0], y):
            ti = crossing(d, S, tstate, impact)
            while k < m and direction * (ti - t_out[k]) > 0.0:
                dense_eval(S, p, t_out[k] - tstate[2], y_out[k])
                k += 1
            return IMPACT, k, ti

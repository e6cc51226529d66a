"""The spacecraft with actuators in canonical variables: a gyrostat in (q, Q, h).

Reaction wheels make the rigid body a gyrostat (Hughes, *Spacecraft Attitude Dynamics*, 1986,
Sect. 3.6 and 7.3; Krishnaprasad, "Lie-Poisson structures, dual-spin spacecraft and
asymptotic stability", Nonlinear Analysis 9, 1985). With n wheels of spin axes a_k (unit, body
axes) and axial inertias J_k, I the spacecraft's inertia with the wheels locked (principal
axes, ``params[0:3]``), Ĩ = I − Σ J_k a_k a_kᵀ, h_k = J_k (a_k·ω + Ω_k) the axial momentum of
wheel k (Ω_k its speed relative to the body; h_k is conjugate to the cyclic wheel angle) and
ℓ = Σ h_k a_k, the Hamiltonian is

    H = ½ (g − ℓ)ᵀ Ĩ⁻¹ (g − ℓ) + Σ h_k² / (2 J_k) + U(q, t),    g = ½ vec(q̃∘Q)

with g the total angular momentum of body and wheels in body axes (Arribas et al. eq. 17).
Since H depends on (q, Q) through g only and ∂H/∂g = Ĩ⁻¹ (g − ℓ) = ω, eq. 7 keeps its form
with the gyrostat's ω, and the wheels add one equation each:

    q̇ = ½ q∘(0, ω),   Q̇ = ½ Q∘(0, ω) + 2 q∘(0, τ_B),   ḣ_k = u_k + f_k(Ω_k)

(u_k the motor torque, f_k the bearing friction torque: internal torques, which never enter
Q̇). External torques τ_B are the model's plus the magnetorquers' and thrusters'
(:func:`attitude._core.actuators.actuator_torque`). State ``y`` = (q (4), Q (4), h (n)).

The kernels take ``P = (params, sc)``: the model's parameter vector and the spacecraft block
(:mod:`attitude._core.actuators`).
"""

from __future__ import annotations

import math

from orbit._shared_jit import jit, jit_generic

from .actuators import (
    MTQ,
    SC,
    THR,
    WHEEL,
    actuator_torque,
    body_rate,
    magnetorquer_base,
    state_rate,
    thruster_base,
    thrusters_update,
    wheel_friction,
    wheel_momentum_sum,
    wheel_speed,
)
from .coupled import coupled_begin, coupled_end
from .environment import field_body
from .quat import conj_mul, cross, mul_vec

# Columns of the spacecraft diagnostics (per sample), after the 13 of
# attitude._core.dynamics.diagnostics_with: ω (3), g (3), G (3), energy, |q| − 1, q·Q, U.
NDIAG = 13


@jit_generic
def spacecraft_rhs_with(torque, has_torque, t, y, P, dydt):
    """Eq. 7 of the gyrostat with the model's torque plus the actuators'; writes ``dydt``.
    ``has_torque(params)``: False where the model exerts none (its call is skipped)."""
    params = P[0]
    sc = P[1]
    co = int(sc[SC.COUPLED])
    ag = (0.0, 0.0, 0.0)
    if co >= 0:  # the orbit is in the state: the models read it (attitude._core.coupled)
        ag = coupled_begin(sc, co, params, t, y)
    q = (y[0], y[1], y[2], y[3])
    Q = (y[4], y[5], y[6], y[7])
    w = conj_mul(q, Q)
    l0, l1, l2 = wheel_momentum_sum(sc, y)
    om = body_rate(sc, 0.5 * w[1], 0.5 * w[2], 0.5 * w[3], l0, l1, l2)
    # the model's torque at q as an array, as eq. 7's right-hand side gives it (a tuple compiled
    # every kernel of the model a second time: ~20 s of a fresh cache for a sum of models)
    if has_torque(params):  # (a torque-free hub skips the generic switch's call)
        tau = torque(y[0:4], om, t, params)
    else:
        tau = (0.0, 0.0, 0.0)
    ta = actuator_torque(sc, q, t)
    tau = (tau[0] + ta[0], tau[1] + ta[1], tau[2] + ta[2])
    a = mul_vec(q, om)
    b = mul_vec(Q, om)
    for i in range(4):
        dydt[i] = 0.5 * a[i]
        dydt[4 + i] = 0.5 * b[i]
    if tau[0] != 0.0 or tau[1] != 0.0 or tau[2] != 0.0:  # (wheels alone: no external torque)
        c = mul_vec(q, tau)
        for i in range(4):
            dydt[4 + i] += 2.0 * c[i]
    for k in range(int(sc[SC.NW])):
        bk = SC.WHEELS + k * WHEEL.SIZE
        u = sc[bk + WHEEL.U]
        if sc[bk + WHEEL.FRICTION] != 0.0:  # (frictionless wheels: no speed, no call)
            u += wheel_friction(sc, bk, wheel_speed(sc, bk, y[8 + k], om))
        dydt[8 + k] = u
    if co >= 0:
        coupled_end(sc, co, params, q, t, y, ag, dydt)


@jit(inline="always")
def spacecraft_diagnostics_row(y, k, U, params, sc, out):
    """Row ``k`` of the diagnostics of the gyrostat states ``y`` given the potential energy
    ``U``: the columns of :func:`attitude._core.dynamics.diagnostics_row` with the gyrostat's
    ω and energy T = ½ (g − ℓ)·ω + Σ h_k²/(2 J_k) + U."""
    yk = y[k]
    g, om = state_rate(sc, yk)
    q = (yk[0], yk[1], yk[2], yk[3])
    Q = (yk[4], yk[5], yk[6], yk[7])
    G1 = 0.5 * (-Q[0] * q[1] + Q[1] * q[0] - Q[2] * q[3] + Q[3] * q[2])
    G2 = 0.5 * (-Q[0] * q[2] + Q[1] * q[3] + Q[2] * q[0] - Q[3] * q[1])
    G3 = 0.5 * (-Q[0] * q[3] - Q[1] * q[2] + Q[2] * q[1] + Q[3] * q[0])
    l0, l1, l2 = wheel_momentum_sum(sc, yk)
    T = 0.5 * ((g[0] - l0) * om[0] + (g[1] - l1) * om[1] + (g[2] - l2) * om[2])
    for j in range(int(sc[SC.NW])):
        h = yk[8 + j]
        T += 0.5 * h * h / sc[SC.WHEELS + j * WHEEL.SIZE + WHEEL.J]
    nq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    out[k, 0] = om[0]
    out[k, 1] = om[1]
    out[k, 2] = om[2]
    out[k, 3] = g[0]
    out[k, 4] = g[1]
    out[k, 5] = g[2]
    out[k, 6] = G1
    out[k, 7] = G2
    out[k, 8] = G3
    out[k, 9] = T + U
    out[k, 10] = (nq - 1.0) / (1.0 + math.sqrt(nq))
    out[k, 11] = q[0] * Q[0] + q[1] * Q[1] + q[2] * Q[2] + q[3] * Q[3]
    out[k, 12] = U


@jit
def actuator_diagnostics(t, y, rec, sc, torque_out, wheel_out):
    """Per sample: the actuators' torques on the body and each wheel's speed and friction.

    ``y`` (m, 8 + n_w) states, ``rec`` (m, n_rec) the commands in force
    (:func:`attitude._core.holds.record` layout), ``sc`` a scratch copy of the spacecraft block
    (its held slots are overwritten). ``torque_out`` (m, 3, 3): row 0 the torque of the wheels'
    motors and bearings on the body, −Σ a_k (u_k + f_k) (internal: it leaves G unchanged),
    row 1 the magnetorquers' m × B_B, row 2 the thrusters' torque. ``wheel_out`` (m, n_w, 2):
    Ω_k and the friction torque f_k(Ω_k).
    """
    nw = int(sc[SC.NW])
    nm = int(sc[SC.NM])
    nt = int(sc[SC.NT])
    o = int(sc[SC.MTQ])
    for i in range(y.shape[0]):
        yi = y[i]
        q = (yi[0], yi[1], yi[2], yi[3])
        _, om = state_rate(sc, yi)
        c = 0
        r0 = r1 = r2 = 0.0
        for k in range(nw):
            b = SC.WHEELS + k * WHEEL.SIZE
            sc[b + WHEEL.STRIBECK] = rec[i, c + 3]
            u = rec[i, c + 1]
            Om = wheel_speed(sc, b, yi[8 + k], om)
            f = wheel_friction(sc, b, Om)
            wheel_out[i, k, 0] = Om
            wheel_out[i, k, 1] = f
            r0 -= sc[b] * (u + f)
            r1 -= sc[b + 1] * (u + f)
            r2 -= sc[b + 2] * (u + f)
            c += 4
        torque_out[i, 0, 0] = r0
        torque_out[i, 0, 1] = r1
        torque_out[i, 0, 2] = r2
        m0 = m1 = m2 = 0.0
        for j in range(nm):
            b = magnetorquer_base(sc, j)
            m = rec[i, c + 1]
            m0 += m * sc[b + MTQ.AXIS]
            m1 += m * sc[b + MTQ.AXIS + 1]
            m2 += m * sc[b + MTQ.AXIS + 2]
            c += 2
        if o >= 0:
            bb = field_body(q, t[i], sc, o)
            tm = cross((m0, m1, m2), bb)
            torque_out[i, 1, 0] = tm[0]
            torque_out[i, 1, 1] = tm[1]
            torque_out[i, 1, 2] = tm[2]
        else:
            torque_out[i, 1, 0] = 0.0
            torque_out[i, 1, 1] = 0.0
            torque_out[i, 1, 2] = 0.0
        for j in range(nt):
            b = thruster_base(sc, j)
            sc[b + THR.FIRING] = rec[i, c + 1]
            c += 2
        thrusters_update(sc)
        torque_out[i, 2, 0] = sc[SC.TAU]
        torque_out[i, 2, 1] = sc[SC.TAU + 1]
        torque_out[i, 2, 2] = sc[SC.TAU + 2]
        torque_out[i, 3, 0] = rec[i, c]
        torque_out[i, 3, 1] = rec[i, c + 1]
        torque_out[i, 3, 2] = rec[i, c + 2]

"""Right-hand side of the canonical equations of motion, and their diagnostics.

Canonical quaternion variables, Arribas, Elipe & Palacios (2006) eq. 7, with the scalar part of
q̃∘Q dropped (their I0 is irrelevant on the constraint manifold):

    g = ½ vec(q̃∘Q)                 body angular momentum (eq. 17)
    ω = I⁻¹ g                       body angular velocity
    q̇ = ¼ q∘(I⁻¹⊗q̃∘Q) = ½ q∘(0, ω)
    Q̇ = −¼ Q∘(I⁻¹⊗Q̃∘q) + 2 q∘(0, τ_B) = ½ Q∘(0, ω) + 2 q∘(0, τ_B)

where the potential enters through the generalised force 2 q∘(0, τ_B) of Schwab eq. 25
(minus the tangential gradient of U), which keeps |q| and q·Q exactly invariant.

State vector ``y`` (length 8): ``[q0, q1, q2, q3, Q0, Q1, Q2, Q3]``.

Both kernels take the model as an argument; the cached entry points that bind them to a model
are in :mod:`attitude._core.entry_points`.
"""

from __future__ import annotations

import math

from orbit._shared_jit import jit, jit_generic

from .quat import conj_mul, mul_vec


@jit_generic
def canonical_rhs_with(torque, t, y, params, dydt):
    """Eq. 7 with the body torque ``torque(q, ω, t, params)``; writes into ``dydt``."""
    q = y[0:4]
    Q = y[4:8]
    w = conj_mul(q, Q)
    om = (0.5 * w[1] / params[0], 0.5 * w[2] / params[1], 0.5 * w[3] / params[2])
    a = mul_vec(q, om)
    b = mul_vec(Q, om)
    tau = torque(q, om, t, params)
    c = mul_vec(q, tau)
    for i in range(4):
        dydt[i] = 0.5 * a[i]
        dydt[4 + i] = 0.5 * b[i] + 2.0 * c[i]


@jit_generic
def diagnostics_with(potential, t, y, params, out):
    """Per-sample diagnostics of canonical states ``y`` (m, 8) into ``out`` (m, 13).

    Columns: ω (3), g (3), G (3), energy, |q| − 1, q·Q, U.
    """
    m = y.shape[0]
    for k in range(m):
        diagnostics_row(y, k, potential(y[k, 0:4], t[k], params), params, out)


@jit(inline="always")
def diagnostics_row(y, k, U, params, out):
    """Row ``k`` of :func:`diagnostics_with` given the potential energy ``U`` of that sample."""
    q = (y[k, 0], y[k, 1], y[k, 2], y[k, 3])  # tuples, not array views (no reference counting)
    Q = (y[k, 4], y[k, 5], y[k, 6], y[k, 7])
    d = diagnostic_values(q, Q, U, params)
    for i in range(13):
        out[k, i] = d[i]


@jit(inline="always")
def diagnostic_values(q, Q, U, params):
    """The 13 diagnostics of the state (q, Q) with potential energy U, as a tuple: ω (3),
    g (3), G (3), energy, |q| − 1, q·Q, U."""
    w = conj_mul(q, Q)
    g = (0.5 * w[1], 0.5 * w[2], 0.5 * w[3])
    om = (g[0] / params[0], g[1] / params[1], g[2] / params[2])
    # G = ½ vec(Q∘q̃)
    G1 = 0.5 * (-Q[0] * q[1] + Q[1] * q[0] - Q[2] * q[3] + Q[3] * q[2])
    G2 = 0.5 * (-Q[0] * q[2] + Q[1] * q[3] + Q[2] * q[0] - Q[3] * q[1])
    G3 = 0.5 * (-Q[0] * q[3] - Q[1] * q[2] + Q[2] * q[1] + Q[3] * q[0])
    T = 0.5 * (g[0] * om[0] + g[1] * om[1] + g[2] * om[2])
    nq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    # |q| − 1 = (|q|² − 1)/(|q| + 1) without cancellation in the square root.
    return (
        om[0], om[1], om[2], g[0], g[1], g[2], G1, G2, G3,
        T + U, (nq - 1.0) / (1.0 + math.sqrt(nq)), w[0], U,
    )  # fmt: skip


@jit_generic
def term_torques_with(term_torque, n_terms, t, y, params, out):
    """Body torque of each term of the model at canonical states ``y`` (m, 8).

    ``out`` (m, n_terms + 1, 3): term j in ``out[:, j]``, their sum in ``out[:, n_terms]`` (the
    torque that drives the motion, summed in the order of the model's own kernel).
    """
    m = y.shape[0]
    for k in range(m):
        q = y[k, 0:4]
        Q = y[k, 4:8]
        w = conj_mul(q, Q)
        om = (0.5 * w[1] / params[0], 0.5 * w[2] / params[1], 0.5 * w[3] / params[2])
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for j in range(n_terms):
            tau = term_torque(j, q, om, t[k], params)
            out[k, j, 0] = tau[0]
            out[k, j, 1] = tau[1]
            out[k, j, 2] = tau[2]
            if j == 0:
                s0, s1, s2 = tau[0], tau[1], tau[2]
            else:
                s0 += tau[0]
                s1 += tau[1]
                s2 += tau[2]
        out[k, n_terms, 0] = s0
        out[k, n_terms, 1] = s1
        out[k, n_terms, 2] = s2


@jit_generic
def term_torques_at_rates_with(term_torque, n_terms, t, y, rates, params, out):
    """:func:`term_torques_with` at given body angular velocities ``rates`` (m, 3) (a
    gyrostat's ω is not I⁻¹ g)."""
    m = y.shape[0]
    for k in range(m):
        q = y[k, 0:4]
        om = (rates[k, 0], rates[k, 1], rates[k, 2])
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for j in range(n_terms):
            tau = term_torque(j, q, om, t[k], params)
            out[k, j, 0] = tau[0]
            out[k, j, 1] = tau[1]
            out[k, j, 2] = tau[2]
            if j == 0:
                s0, s1, s2 = tau[0], tau[1], tau[2]
            else:
                s0 += tau[0]
                s1 += tau[1]
                s2 += tau[2]
        out[k, n_terms, 0] = s0
        out[k, n_terms, 1] = s1
        out[k, n_terms, 2] = s2

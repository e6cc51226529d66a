"""Right-hand sides of the non-canonical formulations.

Each right-hand side is written once with the body torque as a function argument
``torque(q, ω, t, params)`` (``jit_generic``: inlined, never cached on its own); the cached
entry points that bind it to a model, with the DOP853 loop around it, are in
:mod:`attitude._core.entry_points`.

Parameter vector
----------------
``params`` is the canonical parameter vector of :mod:`attitude._core.potentials` (inertia,
kind, potential numbers) followed by ``N_EXTRA`` slots owned by this module, addressed from the
end so the potential's own layout is untouched::

    params[-6]   smallest sin ϑ met below the stop threshold (Euler angles; written)
    params[-5]   stop threshold on sin ϑ (Euler angles; read)
    params[-4:]  scratch: the unit attitude quaternion handed to ``torque``

The scratch slots let the right-hand sides hand an *array* quaternion to user torques without
allocating in the hot loop.

Formulations
------------
``euler_angles``  state (φ, ϑ, ψ, Φ, Θ, Ψ): Hamilton's equations of Arribas et al. eq. 10.
``schwab``        state (q, q̇): Schwab eq. 23 solved in closed form for (q̈, λ).
``euler_equations``  state (q, ω): Schwab eqs. 16 and 19.
"""

from __future__ import annotations

import math

from orbit._layout import Field, layout
from orbit._shared_jit import jit, jit_generic

from .quat import conj_mul, mul, mul_vec

#: The slots at the end of ``params`` owned by this module.
EXTRA = layout(
    "formulation slots",
    min_sin=Field(1, "", "smallest sin ϑ met below the stop threshold (Euler angles; written)"),
    tol=Field(1, "", "stop threshold on sin ϑ (Euler angles; read)"),
    scratch=Field(4, "", "the unit attitude quaternion handed to ``torque``"),
)
N_EXTRA = EXTRA.SIZE
# Their offsets from the end of ``params`` (negative).
X_MIN_SIN = EXTRA.MIN_SIN - EXTRA.SIZE
X_TOL = EXTRA.TOL - EXTRA.SIZE
X_SCRATCH = EXTRA.SCRATCH - EXTRA.SIZE


@jit
def _unit_scratch(q, params, normalize):
    """Copy q (divided by |q| when ``normalize``) into the scratch slots; return the view."""
    n = params.shape[0]
    s = 1.0
    if normalize:
        s = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for i in range(4):
        params[n + X_SCRATCH + i] = q[i] * s
    return params[n + X_SCRATCH :]


# --------------------------------------------------------------------------------------------
# 3-1-3 Euler angles and their conjugate momenta (Arribas et al. Sect. 4)
# --------------------------------------------------------------------------------------------


@jit
def euler_angles_hamilton(y, inertia1, inertia2, inertia3):
    """Kinetic part of Hamilton's equations of eq. 10 at the state ``y`` = (φ, ϑ, ψ, Φ, Θ, Ψ).

    Returns ``(φ̇, ϑ̇, ψ̇, −∂T/∂ϑ, −∂T/∂ψ, ω1, ω2, ω3)`` (T does not depend on φ). With
    A = (Φ − Ψ cos ϑ)/sin ϑ, eq. 8 gives g = (A sin ψ + Θ cos ψ, A cos ψ − Θ sin ψ, Ψ) and
    ∂T/∂g = ω = g/I, so (chain rule, u = ω1 sin ψ + ω2 cos ψ):

        ∂H/∂Φ = u / sin ϑ,    ∂H/∂Θ = ω1 cos ψ − ω2 sin ψ,    ∂H/∂Ψ = ω3 − u cos ϑ / sin ϑ,
        ∂T/∂ϑ = u (Ψ − Φ cos ϑ) / sin² ϑ,    ∂T/∂ψ = ω1 g2 − ω2 g1.
    """
    s = math.sin(y[1])
    c = math.cos(y[1])
    sp = math.sin(y[2])
    cp = math.cos(y[2])
    Phi = y[3]
    Th = y[4]
    Psi = y[5]
    A = (Phi - Psi * c) / s
    g1 = A * sp + Th * cp
    g2 = A * cp - Th * sp
    w1 = g1 / inertia1
    w2 = g2 / inertia2
    w3 = Psi / inertia3
    u = w1 * sp + w2 * cp
    return (
        u / s,
        w1 * cp - w2 * sp,
        w3 - u * c / s,
        -u * (Psi - Phi * c) / (s * s),
        w2 * g1 - w1 * g2,
        w1,
        w2,
        w3,
    )


@jit
def euler_angles_forces(y, tau):
    """Generalised forces −∂V/∂(φ, ϑ, ψ) from the body torque ``tau``.

    A virtual rotation δφ s3 + δϑ ℓ + δψ b3 does work τ·(...), so −∂V/∂φ = τ·s3,
    −∂V/∂ϑ = τ·ℓ, −∂V/∂ψ = τ·b3, with the axes in body components
    s3 = (sin ϑ sin ψ, sin ϑ cos ψ, cos ϑ), ℓ = (cos ψ, −sin ψ, 0), b3 = (0, 0, 1).
    """
    s = math.sin(y[1])
    c = math.cos(y[1])
    sp = math.sin(y[2])
    cp = math.cos(y[2])
    return (
        s * (tau[0] * sp + tau[1] * cp) + tau[2] * c,
        tau[0] * cp - tau[1] * sp,
        tau[2],
    )


@jit
def euler_angles_quaternion(y):
    """Attitude quaternion of the 3-1-3 angles (eq. 12)."""
    ch = math.cos(0.5 * y[1])
    sh = math.sin(0.5 * y[1])
    sp = 0.5 * (y[0] + y[2])
    dp = 0.5 * (y[0] - y[2])
    return (ch * math.cos(sp), sh * math.cos(dp), sh * math.sin(dp), ch * math.sin(sp))


@jit_generic
def euler_angles_rhs_with(torque, t, y, params, dydt):
    """Hamilton's equations of eq. 10 with the potential entering through ``torque``.

    Where sin ϑ is below the stop threshold ``params[-5]`` (or ϑ has left (0, π)), the
    derivative is NaN: the integrator rejects the step and shrinks it, and reports a non-finite
    state when it cannot get past; the smallest such sin ϑ is recorded in ``params[-6]``, which
    tells the driver that the failure is the singularity.
    """
    n = params.shape[0]
    s = math.sin(y[1])
    if not s >= params[n + X_TOL]:  # also catches NaN
        if not s >= params[n + X_MIN_SIN]:
            params[n + X_MIN_SIN] = s
        for i in range(6):
            dydt[i] = math.nan
        return
    k = euler_angles_hamilton(y, params[0], params[1], params[2])
    q = _unit_scratch(euler_angles_quaternion(y), params, False)
    f = euler_angles_forces(y, torque(q, (k[5], k[6], k[7]), t, params))
    dydt[0] = k[0]
    dydt[1] = k[1]
    dydt[2] = k[2]
    dydt[3] = f[0]
    dydt[4] = k[3] + f[1]
    dydt[5] = k[4] + f[2]


# --------------------------------------------------------------------------------------------
# Schwab: second-order equations in the Euler parameters with the norm multiplier λ
# --------------------------------------------------------------------------------------------


@jit
def schwab_accelerations(q, qd, tau, inertia1, inertia2, inertia3):
    """Solve Schwab eq. 23 for (q̈, λ) in closed form.

    Eq. 23, with Q = L(q) the matrix of q∘(·), D = diag(0, J'), f = 2 q∘(0, M') (eq. 25):

        4 L D Lᵀ q̈ + 2 q λ = f + 8 L̇ D L̇ᵀ q =: b,        2 qᵀ q̈ = −2 |q̇|²

    (the last row is the second derivative of the constraint eq. 20; the OCR drops its right
    side). For any q ≠ 0, LᵀL = LLᵀ = |q|² 1 and Lᵀq = (|q|², 0), so with a = Lᵀq̈ = q̃∘q̈,
    premultiplying by Lᵀ splits the system:

        scalar:  2 λ |q|² = (q̃∘b)_0           (λ = ω'ᵀJ'ω' on the manifold, eq. 24)
        vector:  4 |q|² J' vec(a) = vec(q̃∘b)
        constraint:  a_0 = −|q̇|²

    and q̈ = q∘a / |q|². This is the exact solution of the 5×5 system, also off the
    constraint manifold (what the integrator sees as the constraint drifts).

    Returns
    -------
    qdd : 4-tuple
    lam : float
    """
    nq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    # L̇ᵀ q = q̇̃∘q; D keeps the vector part scaled by J'.
    w = conj_mul(qd, q)
    dw = (inertia1 * w[1], inertia2 * w[2], inertia3 * w[3])
    c = mul_vec(qd, dw)
    f = mul_vec(q, tau)
    b = (
        2.0 * f[0] + 8.0 * c[0],
        2.0 * f[1] + 8.0 * c[1],
        2.0 * f[2] + 8.0 * c[2],
        2.0 * f[3] + 8.0 * c[3],
    )
    lb = conj_mul(q, b)
    lam = lb[0] / (2.0 * nq)
    a = (
        -(qd[0] * qd[0] + qd[1] * qd[1] + qd[2] * qd[2] + qd[3] * qd[3]),
        lb[1] / (4.0 * nq * inertia1),
        lb[2] / (4.0 * nq * inertia2),
        lb[3] / (4.0 * nq * inertia3),
    )
    r = mul(q, a)
    return (r[0] / nq, r[1] / nq, r[2] / nq, r[3] / nq), lam


@jit_generic
def schwab_rhs_with(torque, t, y, params, dydt):
    """First-order form of eq. 23 in (q, q̇); the torque is evaluated at the attitude q/|q|."""
    q = y[0:4]
    qd = y[4:8]
    qu = _unit_scratch(q, params, True)
    # body angular velocity ω = 2 vec(q̃∘q̇)/|q|² (Schwab eq. 16)
    v = conj_mul(q, qd)
    nq = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]
    tau = torque(qu, (2.0 * v[1] / nq, 2.0 * v[2] / nq, 2.0 * v[3] / nq), t, params)
    qdd = schwab_accelerations(q, qd, tau, params[0], params[1], params[2])[0]
    for i in range(4):
        dydt[i] = qd[i]
        dydt[4 + i] = qdd[i]


# --------------------------------------------------------------------------------------------
# Euler's equations with the quaternion kinematics
# --------------------------------------------------------------------------------------------


@jit_generic
def euler_equations_rhs_with(torque, t, y, params, dydt):
    """q̇ = ½ q∘(0, ω) (Schwab eq. 16), I ω̇ = τ − ω × Iω (Schwab eq. 19).

    The torque is evaluated at the attitude q/|q|; q itself is integrated as is, so |q| − 1
    shows the integration error.
    """
    q = y[0:4]
    I1 = params[0]
    I2 = params[1]
    I3 = params[2]
    w1 = y[4]
    w2 = y[5]
    w3 = y[6]
    qu = _unit_scratch(q, params, True)
    tau = torque(qu, (w1, w2, w3), t, params)
    dq = mul_vec(q, (w1, w2, w3))
    for i in range(4):
        dydt[i] = 0.5 * dq[i]
    dydt[4] = (tau[0] - (w2 * I3 * w3 - w3 * I2 * w2)) / I1
    dydt[5] = (tau[1] - (w3 * I1 * w1 - w1 * I3 * w3)) / I2
    dydt[6] = (tau[2] - (w1 * I2 * w2 - w2 * I1 * w1)) / I3

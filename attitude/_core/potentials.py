"""Compiled torque and potential kernels of the built-in potentials.

Every built-in potential is data: a parameter vector ``params`` whose first entries are the
principal moments of inertia and a kind code, followed by the potential's own numbers:

    params[0:3]  I1, I2, I3          principal moments of inertia
    params[3]    kind                KIND_* below
    params[4:]   potential parameters

so one cached, compiled function (:func:`builtin_torque`) serves them all, and the
integrators that call it are cached on disk too. Torques are body-frame components; they enter
Hamilton's equations through the generalised force 2 q∘(0, τ_B) (Schwab eq. 25), which is minus
the tangential part of ∂U/∂q, so |q| = 1 and q·Q = 0 stay invariants of the flow.
"""

from __future__ import annotations

import numpy as np

from orbit._kernels import radius_and_radial_unit
from orbit._shared_jit import jit, jit_generic

from .quat import conj_mul, cross, rotate, rotate_inverse

KIND_TORQUE_FREE = 0
KIND_HEAVY_TOP = 1
KIND_GRAVITY_GRADIENT = 2

P_KIND = 3  # index of the kind code
P0 = 4  # first potential parameter

# Heavy top: params[4] = weight M g, params[5:8] = centre of mass in body axes.
# Gravity gradient: params[4:13] = orbit element array (orbit._kernels layout).


@jit
def heavy_top_torque(q, params):
    # Gravity -weight s3 acts at the centre of mass c: τ_B = c × F_B, F_B = q̃∘(−W s3)∘q.
    w = params[P0]
    c = (params[P0 + 1], params[P0 + 2], params[P0 + 3])
    fb = rotate_inverse(q, (0.0, 0.0, -w))
    return cross(c, fb)


@jit
def heavy_top_potential(q, params):
    # V = W (q∘c∘q̃)·s3: the potential energy of the weight (height of the centre of mass).
    # Arribas et al. eq. 18 prints U = x^c·F with F = −Mg s3, which is −V; see docs/potentials.md.
    w = params[P0]
    c = (params[P0 + 1], params[P0 + 2], params[P0 + 3])
    return w * rotate(q, c)[2]


@jit
def gravity_gradient_terms(q, t, params):
    """(3μ/r³, x̂_B, I x̂_B) for the gravity gradient at time t."""
    el = params[P0 : P0 + 9]
    r, ux, uy, uz = radius_and_radial_unit(el, t)
    mu = el[7]
    k = 3.0 * mu / (r * r * r)
    xb = rotate_inverse(q, (ux, uy, uz))  # x̂_B = q̃∘x̂_S∘q
    ixb = (params[0] * xb[0], params[1] * xb[1], params[2] * xb[2])
    return k, xb, ixb


@jit
def gravity_gradient_torque(q, t, params):
    # τ_B = 3μ/r³ x̂_B × (I x̂_B): minus the derivative of eq. 20 under body rotations.
    k, xb, ixb = gravity_gradient_terms(q, t, params)
    c = cross(xb, ixb)
    return (k * c[0], k * c[1], k * c[2])


@jit
def gravity_gradient_potential(q, t, params):
    # Arribas et al. eq. 20: U = 3μ/(2r³) x̂_B·I x̂_B (q-independent terms of eq. 19 dropped).
    k, xb, ixb = gravity_gradient_terms(q, t, params)
    return 0.5 * k * (xb[0] * ixb[0] + xb[1] * ixb[1] + xb[2] * ixb[2])


@jit
def builtin_torque(q, t, params):
    """Body-frame torque of the built-in potential described by ``params``."""
    kind = int(params[P_KIND])
    if kind == KIND_HEAVY_TOP:
        return heavy_top_torque(q, params)
    if kind == KIND_GRAVITY_GRADIENT:
        return gravity_gradient_torque(q, t, params)
    return (0.0, 0.0, 0.0)


@jit
def builtin_potential(q, t, params):
    """Potential energy of the built-in potential described by ``params``."""
    kind = int(params[P_KIND])
    if kind == KIND_HEAVY_TOP:
        return heavy_top_potential(q, params)
    if kind == KIND_GRAVITY_GRADIENT:
        return gravity_gradient_potential(q, t, params)
    return 0.0


# User models ----------------------------------------------------------------------------------
# The bodies of the user kernels of attitude._user_kernels (CustomTorque, CustomPotential).

#: Complex-step size: derivatives are exact to round-off for any h this small
#: (Squire & Trapp, SIAM Rev. 40, 110, 1998): Im U(q + i h e_k) / h = ∂U/∂q_k + O(h²).
COMPLEX_STEP = 1e-30


@jit_generic
def user_torque(tau_fn, q, t):
    """A user's ``tau(q, t)`` (tuple or array) as a 3-tuple of floats."""
    tau = tau_fn(q, t)
    return (float(tau[0]), float(tau[1]), float(tau[2]))


@jit_generic
def complex_step_torque(potential_fn, q, t):
    """τ_B = −½ vec(q̃∘∇U) of a user's ``U(q, t)``, ∇U by complex steps (exact to round-off).

    The generalised force 2 q∘(0, τ_B) (Schwab eq. 25) is then minus the tangential part of
    ∇U; a radial part (U not homogeneous of degree 0 in q) drops out.
    """
    h = COMPLEX_STEP
    qc = np.empty(4, dtype=np.complex128)
    grad = np.empty(4)
    for i in range(4):
        for j in range(4):
            qc[j] = q[j]
        qc[i] = q[i] + 1j * h
        grad[i] = potential_fn(qc, t).imag / h
    w = conj_mul(q, grad)
    return (-0.5 * w[1], -0.5 * w[2], -0.5 * w[3])

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

from orbit._jit import jit
from orbit._state_kernels import MU as ORBIT_MU
from orbit._state_kernels import orbit_radial

from .quat import cross, rotate, rotate_inverse

KIND_TORQUE_FREE = 0
KIND_HEAVY_TOP = 1
KIND_GRAVITY_GRADIENT = 2

P_KIND = 3  # index of the kind code
P0 = 4  # first potential parameter

# Heavy top: params[4] = weight M g, params[5:8] = centre of mass in body axes.
# Gravity gradient: params[4:] = the orbit's kernel_data() (orbit._state_kernels layout: a type
# code, μ, the valid span, then Kepler / secular-J2 elements or a Hermite table), read only
# through the dispatcher orbit_radial, so every orbit source runs in the same cached kernels.


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
    d = params[P0:]
    r, ux, uy, uz = orbit_radial(d, t)
    k = 3.0 * d[ORBIT_MU] / (r * r * r)
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

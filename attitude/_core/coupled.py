"""Orbit and attitude in one state: the translational equations beside the gyrostat's eq. 7.

A :class:`~attitude.Spacecraft` with a mass on an :class:`orbit.NumericalOrbit` carries its
orbit in the integrated state, after (q, Q, h): y = (q, Q, h, r, v, m), r and v in the GCRS
(m, m/s), m the mass (kg). With the orbit as a canonical pair (r, p = m v) beside (q, Q), the
whole system has the Hamiltonian

    H = |p|²/(2m) + m U(t, r) + V₂(q, r) + ½ (g − ℓ)ᵀ Ĩ⁻¹ (g − ℓ) + Σ h²/(2J) + ...,

U the Earth's field and the third bodies per unit mass (:mod:`orbit._force_kernels`), V₂ the
second-order term of the mutual potential of the body and the Earth (MacCullagh), whose
torque is Arribas et al.'s eq. 20 and whose force is its back-reaction on the orbit:

    V₂ = 3μ/(2|r|⁵) rᵀ I r − μ tr I/(2|r|³)         (r in body axes)
    F  = −∇V₂ = −3μ I r/|r|⁵ + (15μ/2)(rᵀ I r) r/|r|⁷ − (3μ tr I/2) r/|r|⁵

so the total energy and the total angular momentum r × p + (the body's momentum in space
axes) are conserved when nothing else acts. The thrusters' force (body axes, turned to space by
q) and their propellant flow (ṁ = −Σ F/(isp g0)) act too:

    ṙ = v,   v̇ = −∇U + (F_thrust + F₂)/m,   ṁ = −Σ ṁ_k.

The models read the orbit through their copies of the orbit's kernel data, each turned into a
*live* orbit (``orbit._state_kernels.TYPE_LIVE``) whose state this right-hand side writes before
the models are called, so every torque (gravity gradient, drag, radiation pressure, magnetic)
sees the integrated orbit.
"""

from __future__ import annotations

import math

from orbit import _force_kernels as _fk
from orbit import _state_kernels as _SK
from orbit._layout import Field, layout
from orbit._shared_jit import jit

from .actuators import SC
from .quat import rotate, rotate_inverse

__all__ = ["COUPLED", "MAX_SLOTS", "coupled_begin", "coupled_end"]

#: Most live orbit copies in a model's parameters.
MAX_SLOTS = 16

COUPLED = layout(
    "coupled orbit block",
    iy=Field(1, "", "index of r in the state (8 + n_w)"),
    forces=Field(1, "", "offset in the spacecraft block of the orbit's force model"),
    gg=Field(1, "", "1: the model's gravity gradient also pulls the orbit (F₂)"),
    mu=Field(1, "m3 s-2", "μ of the mutual potential"),
    inertia=Field(3, "kg m2", "the principal inertia of the mutual potential"),
    n_slots=Field(1, "", "live orbit copies in the model's parameters"),
    slots=Field(MAX_SLOTS, "", "their offsets in the model's parameters"),
)


@jit(inline="always")
def coupled_begin(sc, co, params, t, y):
    """Write the state's orbit into the model's live orbit copies; the gravitational
    acceleration there (m/s², GCRS)."""
    iy = int(sc[co + COUPLED.IY])
    x = y[iy]
    yy = y[iy + 1]
    z = y[iy + 2]
    fo = int(sc[co + COUPLED.FORCES])
    ax, ay, az = _fk.acceleration(sc[fo:], t, x, yy, z)
    for k in range(int(sc[co + COUPLED.N_SLOTS])):
        o = int(sc[co + COUPLED.SLOTS + k])
        for i in range(6):
            params[o + _SK.L_STATE + i] = 1e-3 * y[iy + i]
        params[o + _SK.L_ACC] = 1e-3 * ax
        params[o + _SK.L_ACC + 1] = 1e-3 * ay
        params[o + _SK.L_ACC + 2] = 1e-3 * az
    return ax, ay, az


@jit(inline="always")
def mutual_force(co, sc, qn, x, y, z):
    """F₂ (N, space axes) of the mutual potential's second-order term at r (m)."""
    rb = rotate_inverse(qn, (x, y, z))
    i0 = sc[co + COUPLED.INERTIA]
    i1 = sc[co + COUPLED.INERTIA + 1]
    i2 = sc[co + COUPLED.INERTIA + 2]
    mu = sc[co + COUPLED.MU]
    r2 = rb[0] * rb[0] + rb[1] * rb[1] + rb[2] * rb[2]
    ir2 = 1.0 / r2
    ir5 = mu * ir2 * ir2 / math.sqrt(r2)
    ir0 = i0 * rb[0]
    ir1 = i1 * rb[1]
    iri = i2 * rb[2]
    rir = rb[0] * ir0 + rb[1] * ir1 + rb[2] * iri
    c = ir5 * (7.5 * rir * ir2 - 1.5 * (i0 + i1 + i2))
    return rotate(qn, (c * rb[0] - 3.0 * ir5 * ir0, c * rb[1] - 3.0 * ir5 * ir1,
                       c * rb[2] - 3.0 * ir5 * iri))  # fmt: skip


@jit(inline="always")
def coupled_end(sc, co, q, y, ag, dydt):
    """ṙ = v, v̇ = a_g + (F_thrust + F₂)/m, ṁ = −Σ ṁ_k into ``dydt``."""
    iy = int(sc[co + COUPLED.IY])
    nq = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    qn = (q[0] / nq, q[1] / nq, q[2] / nq, q[3] / nq)
    fx = fy = fz = 0.0
    if sc[SC.FORCE] != 0.0 or sc[SC.FORCE + 1] != 0.0 or sc[SC.FORCE + 2] != 0.0:
        fx, fy, fz = rotate(qn, (sc[SC.FORCE], sc[SC.FORCE + 1], sc[SC.FORCE + 2]))
    if sc[co + COUPLED.GG] != 0.0:
        gx, gy, gz = mutual_force(co, sc, qn, y[iy], y[iy + 1], y[iy + 2])
        fx += gx
        fy += gy
        fz += gz
    im = 1.0 / y[iy + 6]
    dydt[iy] = y[iy + 3]
    dydt[iy + 1] = y[iy + 4]
    dydt[iy + 2] = y[iy + 5]
    dydt[iy + 3] = ag[0] + fx * im
    dydt[iy + 4] = ag[1] + fy * im
    dydt[iy + 5] = ag[2] + fz * im
    dydt[iy + 6] = -sc[SC.MDOT]

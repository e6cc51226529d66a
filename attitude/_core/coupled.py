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
axes) are conserved when nothing else acts. The facets' drag and radiation-pressure forces, the
thrusters' force (body axes, turned to space by q) and their propellant flow
(ṁ = −Σ F/(isp g0)) act too:

    ṙ = v,   v̇ = −∇U + (F_thrust + F_env + F₂)/m,   ṁ = −Σ ṁ_k.

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

from . import environment as _KE
from .actuators import SC
from .quat import rotate, rotate_inverse

__all__ = [
    "COUPLED", "MAX_SLOTS", "below_surface", "coupled_begin", "coupled_end", "coupled_events",
    "coupled_software",
]  # fmt: skip

#: Most live orbit copies in a model's parameters.
MAX_SLOTS = 16

#: Most environment models (drag, radiation pressure) acting on the orbit.
MAX_ENV = 8
#: Kinds of the environment models whose forces act on the orbit (COUPLED.ENV_KIND).
FORCE_DRAG = 1
FORCE_SOLAR = 2

COUPLED = layout(
    "coupled orbit block",
    iy=Field(1, "", "index of r in the state (8 + n_w)"),
    forces=Field(1, "", "offset in the spacecraft block of the orbit's force model"),
    pred=Field(
        1,
        "",
        "offset in the spacecraft block of the orbit's own table (no spacecraft "
        "forces): where the environment tables were computed",
    ),
    gg=Field(1, "", "1: the model's gravity gradient also pulls the orbit (F₂)"),
    mu=Field(1, "m3 s-2", "μ of the mutual potential"),
    inertia=Field(3, "kg m2", "the principal inertia of the mutual potential"),
    omega_earth=Field(1, "rad/s", "the atmosphere's rotation rate (about the ITRS z axis)"),
    n_slots=Field(1, "", "live orbit copies in the model's parameters"),
    slots=Field(MAX_SLOTS, "", "their offsets in the model's parameters"),
    n_fsw=Field(1, "", "live orbit copies in the flight software's data"),
    fsw=Field(MAX_SLOTS, "", "their offsets in it"),
    n_ev=Field(1, "", "live orbit copies in the event data"),
    ev=Field(MAX_SLOTS, "", "their offsets in it"),
    n_env=Field(1, "", "environment models whose forces act on the orbit"),
    env=Field(MAX_ENV, "", "their blocks' offsets in the model's parameters"),
    env_kind=Field(MAX_ENV, "", "FORCE_DRAG or FORCE_SOLAR"),
)


@jit(inline="always")
def write_live(a, o, y, iy, ax, ay, az):
    """The state's orbit (km, km/s) and its acceleration (km/s²) into the live orbit at
    ``a[o:]``."""
    for i in range(6):
        a[o + _SK.L_STATE + i] = 1e-3 * y[iy + i]
    a[o + _SK.L_ACC] = 1e-3 * ax
    a[o + _SK.L_ACC + 1] = 1e-3 * ay
    a[o + _SK.L_ACC + 2] = 1e-3 * az


@jit
def coupled_software(sc, co, fw, t, y):
    """At a tick: the state's orbit into the flight software's live orbit copies (guidance,
    sensors)."""
    iy = int(sc[co + COUPLED.IY])
    fo = int(sc[co + COUPLED.FORCES])
    ax, ay, az = _fk.acceleration(sc[fo:], t, y[iy], y[iy + 1], y[iy + 2])
    for k in range(int(sc[co + COUPLED.N_FSW])):
        write_live(fw, int(sc[co + COUPLED.FSW + k]), y, iy, ax, ay, az)


@jit
def coupled_events(sc, co, evd, t, y):
    """The state's orbit into the event data's live orbit copies (eclipse, Sun angle, the
    orbit's frames), before an event function is evaluated at ``(t, y)``."""
    iy = int(sc[co + COUPLED.IY])
    fo = int(sc[co + COUPLED.FORCES])
    ax, ay, az = _fk.acceleration(sc[fo:], t, y[iy], y[iy + 1], y[iy + 2])
    for k in range(int(sc[co + COUPLED.N_EV])):
        write_live(evd, int(sc[co + COUPLED.EV + k]), y, iy, ax, ay, az)


@jit
def below_surface(sc, t, y):
    """Whether the state's orbit is inside the Earth (WGS 84 ellipsoid): an impact."""
    co = int(sc[SC.COUPLED])
    iy = int(sc[co + COUPLED.IY])
    return _fk.surface(sc[int(sc[co + COUPLED.FORCES]) :], t, y[iy], y[iy + 1], y[iy + 2]) < 0.0


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
        write_live(params, int(sc[co + COUPLED.SLOTS + k]), y, iy, ax, ay, az)
    if int(sc[co + COUPLED.N_ENV]) > 0:
        live_environment(sc, co, params, t, y, iy)
    return ax, ay, az


@jit
def geodetic_height(x, y, z):
    """WGS 84 geodetic height (km) of an Earth-fixed position (km): Bowring's iteration."""
    a = 6378.137
    f = 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    p = math.sqrt(x * x + y * y)
    lat = math.atan2(z, p * (1.0 - e2))
    for _ in range(5):
        s = math.sin(lat)
        n = a / math.sqrt(1.0 - e2 * s * s)
        lat = math.atan2(z + e2 * n * s, p)
    s = math.sin(lat)
    c = math.cos(lat)
    n = a / math.sqrt(1.0 - e2 * s * s)
    if c > 0.5:
        return p / c - n
    return z / s - n * (1.0 - e2)


@jit
def live_environment(sc, co, params, t, y, iy):
    """The environment at the integrated state into the live words of the drag and radiation
    blocks (attitude._core.environment): the wind v − ω⊕ ẑ × r and the density (the table's,
    along the orbit's own path, carried to the state's height with the local scale height of
    the exponential bands), the satellite → Sun vector and the shadow fraction."""
    fd = sc[int(sc[co + COUPLED.FORCES]) :]
    R = _fk.earth_rotation(fd, t)
    x = 1e-3 * y[iy]
    yy = 1e-3 * y[iy + 1]
    z = 1e-3 * y[iy + 2]
    pred = sc[int(sc[co + COUPLED.PRED]) :]
    px, py, pz, pvx, pvy, pvz = _SK.orbit_state(pred, t)
    om = sc[co + COUPLED.OMEGA_EARTH]
    for e in range(int(sc[co + COUPLED.N_ENV])):
        base = int(sc[co + COUPLED.ENV + e])
        if int(sc[co + COUPLED.ENV_KIND + e]) == FORCE_DRAG:
            # v − ω⊕ ẑ × r (ẑ the ITRS pole in GCRS components: R's last row), m/s
            vx = y[iy + 3] - om * (R[7] * y[iy + 2] - R[8] * y[iy + 1])
            vy = y[iy + 4] - om * (R[8] * y[iy] - R[6] * y[iy + 2])
            vz = y[iy + 5] - om * (R[6] * y[iy + 1] - R[7] * y[iy])
            h = geodetic_height(R[0] * x + R[1] * yy + R[2] * z, R[3] * x + R[4] * yy + R[5] * z,
                                R[6] * x + R[7] * yy + R[8] * z)  # fmt: skip
            bands = base + int(params[base + _KE.DRAG.BANDS])
            nb = int(params[base + _KE.DRAG.NB])
            code = int(params[base + _KE.DRAG.DENSITY])
            if code == _KE.DENSITY_EXPONENTIAL:
                rho = _KE.exponential_density(params, bands, nb, h)
            else:
                hp = geodetic_height(R[0] * px + R[1] * py + R[2] * pz,
                                     R[3] * px + R[4] * py + R[5] * pz,
                                     R[6] * px + R[7] * py + R[8] * pz)  # fmt: skip
                s, row, w = _KE.table_locate(params, base + int(params[base + _KE.BLOCK.TAB]), t)
                if code == _KE.DENSITY_FOLDED:
                    # the table holds √ρ v along the orbit's own path: ρ = |√ρ v|² / |v|² there
                    fw = _KE.table_vec3(params, s, row, w, 0)
                    ux = 1e3 * (pvx - om * (R[7] * pz - R[8] * py))
                    uy = 1e3 * (pvy - om * (R[8] * px - R[6] * pz))
                    uz = 1e3 * (pvz - om * (R[6] * py - R[7] * px))
                    rho_p = (fw[0] * fw[0] + fw[1] * fw[1] + fw[2] * fw[2]) / (
                        ux * ux + uy * uy + uz * uz
                    )
                else:
                    rho_p = math.exp(_KE.table_component(params, s, row, w, 3))
                # carried from the path's height to the state's with the bands' scale height
                rho = rho_p * (_KE.exponential_density(params, bands, nb, h)
                               / _KE.exponential_density(params, bands, nb, hp))  # fmt: skip
            params[base + _KE.DRAG.LIVE_V] = vx
            params[base + _KE.DRAG.LIVE_V + 1] = vy
            params[base + _KE.DRAG.LIVE_V + 2] = vz
            params[base + _KE.DRAG.LIVE_RHO] = rho
        else:
            s, row, w = _KE.table_locate(params, base + int(params[base + _KE.BLOCK.TAB]), t)
            ds = _KE.table_vec3(params, s, row, w, 0)  # Sun − path (km)
            rp = _KE.table_vec3(params, s, row, w, 3)  # the path (km)
            dx = ds[0] + rp[0] - x
            dy = ds[1] + rp[1] - yy
            dz = ds[2] + rp[2] - z
            params[base + _KE.SRP.LIVE_DS] = dx
            params[base + _KE.SRP.LIVE_DS + 1] = dy
            params[base + _KE.SRP.LIVE_DS + 2] = dz
            params[base + _KE.SRP.LIVE_NU] = _KE.shadow(
                int(params[base + _KE.SRP.ECLIPSE]), x, yy, z, dx, dy, dz,
                params[base + _KE.SRP.REARTH], params[base + _KE.SRP.RSUN],
            )  # fmt: skip


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
def coupled_end(sc, co, params, q, t, y, ag, dydt):
    """ṙ = v, v̇ = a_g + (F_thrust + F_env + F₂)/m, ṁ = −Σ ṁ_k into ``dydt``."""
    iy = int(sc[co + COUPLED.IY])
    nq = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    qn = (q[0] / nq, q[1] / nq, q[2] / nq, q[3] / nq)
    bx = sc[SC.FORCE]
    by = sc[SC.FORCE + 1]
    bz = sc[SC.FORCE + 2]
    for e in range(int(sc[co + COUPLED.N_ENV])):
        base = int(sc[co + COUPLED.ENV + e])
        if int(sc[co + COUPLED.ENV_KIND + e]) == FORCE_DRAG:
            f = _KE.drag_force(qn, t, params, base)
        else:
            f = _KE.solar_force(qn, t, params, base)
        bx += f[0]
        by += f[1]
        bz += f[2]
    fx = fy = fz = 0.0
    if bx != 0.0 or by != 0.0 or bz != 0.0:
        fx, fy, fz = rotate(qn, (bx, by, bz))
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

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

The field beyond its central term and the third bodies vary on the orbit's time scale (a
degree-n term n times per orbit), the attitude's steps on the control's (a tenth of a second
at 10 Hz): evaluated at every stage they cost ten times the rest of the closed loop. The DOP853
hold driver therefore samples that perturbation every ``field_step`` seconds at the end of a
step (:func:`field_sample`) and the right-hand side takes it from the cubic through the last
four samples, extrapolated over the next interval (an Adams-type predictor), the point mass
exact. Its error is about (ω h)⁴ times the term of frequency ω: ~1e-13 m/s² for EGM2008 20×20
at h = 1 s in low orbit, below the integrator's own at rtol 1e-12 (docs/orbit.md measures it).
The first three intervals of a run evaluate everything exactly; ``field_step = 0`` always does.
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
    "coupled_software", "field_due", "field_reset", "field_sample", "field_step_end", "gravity",
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
    field_step=Field(
        1, "s", "the field's and third bodies' sampling interval (0: evaluated at every call)"
    ),
    n_hist=Field(1, "", "samples of the perturbation held (the cubic is used from 4 on)"),
    next_sample=Field(1, "s", "time of the next sample"),
    hist_t=Field(4, "s", "the last four samples' times, newest first"),
    hist_a=Field(12, "m s-2", "the perturbation there (3 per sample, GCRS), newest first"),
    coef=Field(12, "m s-2", "its Newton divided differences, per axis (4 each)"),
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


@jit(inline="always")
def gravity(sc, co, t, x, y, z):
    """The gravitational acceleration (m/s², GCRS) at r (m): the point mass exact, the field's
    other terms and the third bodies from the cubic through their last four samples once four
    are held (:func:`field_sample`), exact before."""
    d = sc[int(sc[co + COUPLED.FORCES]) :]
    if sc[co + COUPLED.N_HIST] < 4.0:
        return _fk.acceleration(d, t, x, y, z)
    ax, ay, az = _fk.point_mass(d, x, y, z)
    h = co + COUPLED.HIST_T
    s0 = t - sc[h]
    s1 = t - sc[h + 1]
    s2 = t - sc[h + 2]
    c = co + COUPLED.COEF
    ax += sc[c] + s0 * (sc[c + 1] + s1 * (sc[c + 2] + s2 * sc[c + 3]))
    ay += sc[c + 4] + s0 * (sc[c + 5] + s1 * (sc[c + 6] + s2 * sc[c + 7]))
    az += sc[c + 8] + s0 * (sc[c + 9] + s1 * (sc[c + 10] + s2 * sc[c + 11]))
    return ax, ay, az


@jit
def field_reset(sc, co, t0):
    """At a run's start: no sample held, the first due at ``t0``."""
    sc[co + COUPLED.N_HIST] = 0.0
    sc[co + COUPLED.NEXT_SAMPLE] = t0


@jit(inline="always")
def field_step_end(sc, co, seg_end):
    """Where the next step must end: the segment's end, or, while the cubic is in use, the next
    sample's time before it (a boundary within a millionth of the interval after it serves)."""
    h = sc[co + COUPLED.FIELD_STEP]
    if h == 0.0 or sc[co + COUPLED.N_HIST] < 4.0:
        return seg_end
    ts = sc[co + COUPLED.NEXT_SAMPLE]
    return seg_end if seg_end <= ts + 1e-6 * h else ts


@jit(inline="always")
def field_due(sc, co, t):
    """Whether a sample of the perturbation is due at the end of a step at ``t``."""
    h = sc[co + COUPLED.FIELD_STEP]
    return h != 0.0 and t >= sc[co + COUPLED.NEXT_SAMPLE] - 1e-6 * h


@jit
def field_sample(sc, co, t, y, h_last):
    """At the end of a step of length ``h_last`` where a sample is due (:func:`field_due`): the
    perturbation (the field without its central term, plus the third bodies) at the state into
    the history, newest first, and the Newton divided differences of the cubic through the
    last four. Only steps of at most half the interval sample: after a longer one the history
    restarts (the steps are long enough for the exact field, and the cubic would stride over
    them). Returns whether the right-hand side changed (the cubic came into use, changed or
    went out of it)."""
    hstep = sc[co + COUPLED.FIELD_STEP]
    if not field_due(sc, co, t):
        return False
    was = sc[co + COUPLED.N_HIST] == 4.0
    sc[co + COUPLED.NEXT_SAMPLE] = t + hstep
    if h_last > 0.5 * hstep:
        sc[co + COUPLED.N_HIST] = 0.0
        return was
    iy = int(sc[co + COUPLED.IY])
    d = sc[int(sc[co + COUPLED.FORCES]) :]
    x = y[iy]
    yy = y[iy + 1]
    z = y[iy + 2]
    ax, ay, az = _fk.acceleration(d, t, x, yy, z)
    px, py, pz = _fk.point_mass(d, x, yy, z)
    ht = co + COUPLED.HIST_T
    ha = co + COUPLED.HIST_A
    for j in range(3, 0, -1):
        sc[ht + j] = sc[ht + j - 1]
        for i in range(3):
            sc[ha + 3 * j + i] = sc[ha + 3 * (j - 1) + i]
    sc[ht] = t
    sc[ha] = ax - px
    sc[ha + 1] = ay - py
    sc[ha + 2] = az - pz
    n = min(sc[co + COUPLED.N_HIST] + 1.0, 4.0)
    sc[co + COUPLED.N_HIST] = n
    if n < 4.0:
        return False
    c = co + COUPLED.COEF
    for i in range(3):
        f0 = sc[ha + i]
        f1 = sc[ha + 3 + i]
        f2 = sc[ha + 6 + i]
        f3 = sc[ha + 9 + i]
        d01 = (f0 - f1) / (sc[ht] - sc[ht + 1])
        d12 = (f1 - f2) / (sc[ht + 1] - sc[ht + 2])
        d23 = (f2 - f3) / (sc[ht + 2] - sc[ht + 3])
        d012 = (d01 - d12) / (sc[ht] - sc[ht + 2])
        d123 = (d12 - d23) / (sc[ht + 1] - sc[ht + 3])
        sc[c + 4 * i] = f0
        sc[c + 4 * i + 1] = d01
        sc[c + 4 * i + 2] = d012
        sc[c + 4 * i + 3] = (d012 - d123) / (sc[ht] - sc[ht + 3])
    return True


@jit
def coupled_software(sc, co, fw, t, y):
    """At a tick: the state's orbit into the flight software's live orbit copies (guidance,
    sensors)."""
    n = int(sc[co + COUPLED.N_FSW])
    if n == 0:
        return
    iy = int(sc[co + COUPLED.IY])
    ax, ay, az = gravity(sc, co, t, y[iy], y[iy + 1], y[iy + 2])
    for k in range(n):
        write_live(fw, int(sc[co + COUPLED.FSW + k]), y, iy, ax, ay, az)


@jit
def coupled_events(sc, co, evd, t, y):
    """The state's orbit into the event data's live orbit copies (eclipse, Sun angle, the
    orbit's frames), before an event function is evaluated at ``(t, y)``."""
    n = int(sc[co + COUPLED.N_EV])
    if n == 0:
        return
    iy = int(sc[co + COUPLED.IY])
    ax, ay, az = gravity(sc, co, t, y[iy], y[iy + 1], y[iy + 2])
    for k in range(n):
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
    ax, ay, az = gravity(sc, co, t, x, yy, z)
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

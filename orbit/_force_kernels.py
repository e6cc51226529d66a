"""Compiled forces on an Earth orbit, and the DOP853 driver of a numerically propagated orbit.

One float64 array (the ``FORCES`` block below, then its tables) describes the whole model to
compiled code: the central body (a point mass, or the spherical harmonics of
:mod:`orbit._gravity_field_kernels` evaluated in the Earth-fixed frame), the Earth's
orientation, and the third bodies. :func:`acceleration` gives the gravitational acceleration in
the GCRS at a time and position (SI units throughout: m, s).

Earth orientation
-----------------
x_ITRS = R(t) x_GCRS with R = R3(θ) M (:func:`orbit.frames.gcrs_to_itrs_matrix`'s
factorisation): θ is the Earth rotation angle and M = R3(θ)ᵀ R, which changes only with
precession–nutation and the diurnal turn of polar motion. From astropy's R and ERA at nodes
every ``h`` seconds (IAU 2006/2000A, the IERS table of :mod:`orbit.timescales`), the kernel
interpolates M and the slow residual θ(t) − θ0 − ω t (degree-7 Lagrange, uniform nodes): 2e-12
rad from astropy at h = 600 s. Without nodes (``EO_N = 0``) the Earth turns uniformly,
θ = θ0 + ω t about the GCRS z axis (an idealised Earth: then a zonal field is time-independent
in the GCRS and the energy is conserved exactly).

Third bodies
------------
Hermite tables of geocentric positions (orbit.tables layout, km), each with its μ; the pull is
:func:`orbit._gravity_field_kernels.third_body` (Battin's form).
"""

from __future__ import annotations

import math

import numpy as np

from . import _gravity_field_kernels as _kg
from . import _state_kernels as _sk
from ._layout import Field, layout
from ._rk import (
    SUCCESS,
    TOO_MANY_STEPS,
    WORK,
    _dense_coefficients,
    _initial_step,
    _interpolate,
    crossing,
    dop853_step,
)
from ._shared_jit import jit

__all__ = ["FORCES", "IMPACT", "acceleration", "earth_rotation", "orbit_rhs", "point_mass", "run"]

#: Status of :func:`run` when the orbit reached the Earth's surface (the others: orbit._rk).
IMPACT = 6

FORCES = layout(
    "orbit force model",
    mu=Field(1, "m3 s-2", "central gravitational parameter (the field's GM with a field)"),
    n_max=Field(1, "", "degree of the field (0: a point mass)"),
    m_max=Field(1, "", "order of the field"),
    radius=Field(1, "m", "the field's reference radius"),
    c=Field(1, "", "offset of C̄ₙₘ, (n_max + 1)² row-major"),
    s=Field(1, "", "offset of S̄ₙₘ, (n_max + 1)²"),
    f=Field(1, "", "offset of the recursion factors, 6 (n_max + 2)²"),
    scratch=Field(1, "", "offset of scratch words, (n_max + 2)² + 2 (n_max + 2)"),
    eo_n=Field(1, "", "Earth orientation nodes (0: uniform rotation)"),
    eo_t0=Field(1, "s", "time of the first node"),
    eo_h=Field(1, "s", "node spacing"),
    theta0=Field(1, "rad", "Earth rotation angle at t = 0"),
    omega=Field(1, "rad s-1", "its rate"),
    eo_m=Field(1, "", "offset of M at the nodes, 9 words each (row-major)"),
    eo_dth=Field(1, "", "offset of θ − θ0 − ω t at the nodes"),
    n_bodies=Field(1, "", "number of third bodies"),
    bodies=Field(1, "", "offset of their records (μ [m3 s-2], offset of the Hermite table)"),
    surface_a=Field(1, "m", "the Earth's equatorial radius (impact)"),
    surface_b=Field(1, "m", "the Earth's polar radius (impact)"),
)

# 1 / Π_{k≠j} (j − k) of the degree-7 Lagrange weights on nodes 0..7.
_LAGRANGE_DEN = np.array(
    [-1 / 5040, 1 / 720, -1 / 240, 1 / 144, -1 / 144, 1 / 240, -1 / 720, 1 / 5040]
)


@jit(inline="always")
def eop_window(d, t):
    """The 8-node Lagrange window of the Earth-orientation table around t: (its first node
    j0, t in node spacings from that node)."""
    x = (t - d[FORCES.EO_T0]) / d[FORCES.EO_H]
    j0 = min(max(int(math.floor(x)) - 3, 0), int(d[FORCES.EO_N]) - 8)  # noqa: RUF046
    return j0, x - j0


@jit
def earth_rotation(d, t):
    """R(t), x_ITRS = R x_GCRS, as 9 numbers (row-major)."""
    n = int(d[FORCES.EO_N])
    th = d[FORCES.THETA0] + d[FORCES.OMEGA] * t
    m0 = m4 = m8 = 1.0
    m1 = m2 = m3 = m5 = m6 = m7 = 0.0
    if n > 0:
        j0, x = eop_window(d, t)
        mo = int(d[FORCES.EO_M]) + 9 * j0
        do = int(d[FORCES.EO_DTH]) + j0
        m0 = m1 = m2 = m3 = m4 = m5 = m6 = m7 = m8 = 0.0
        for j in range(8):
            w = _LAGRANGE_DEN[j]
            for k in range(8):
                if k != j:
                    w *= x - k
            th += w * d[do + j]
            o = mo + 9 * j
            m0 += w * d[o]
            m1 += w * d[o + 1]
            m2 += w * d[o + 2]
            m3 += w * d[o + 3]
            m4 += w * d[o + 4]
            m5 += w * d[o + 5]
            m6 += w * d[o + 6]
            m7 += w * d[o + 7]
            m8 += w * d[o + 8]
    c = math.cos(th)
    s = math.sin(th)
    # R3(θ) = [[c, s, 0], [−s, c, 0], [0, 0, 1]]
    return (
        c * m0 + s * m3, c * m1 + s * m4, c * m2 + s * m5,
        c * m3 - s * m0, c * m4 - s * m1, c * m5 - s * m2,
        m6, m7, m8,
    )  # fmt: skip


@jit(inline="always")
def point_mass(d, x, y, z):
    """−μ r/|r|³ (m/s²) at r (m): the field's central term."""
    r2 = x * x + y * y + z * z
    k = -d[FORCES.MU] / (r2 * math.sqrt(r2))
    return k * x, k * y, k * z


@jit
def acceleration(d, t, x, y, z):
    """The gravitational acceleration (m/s², GCRS) at (x, y, z) (m, GCRS) at time ``t``."""
    nmax = int(d[FORCES.N_MAX])
    if nmax == 0:
        ax, ay, az = point_mass(d, x, y, z)
    else:
        R = earth_rotation(d, t)
        xi = R[0] * x + R[1] * y + R[2] * z
        yi = R[3] * x + R[4] * y + R[5] * z
        zi = R[6] * x + R[7] * y + R[8] * z
        size = nmax + 2
        n1 = nmax + 1
        co = int(d[FORCES.C])
        so = int(d[FORCES.S])
        fo = int(d[FORCES.F])
        wo = int(d[FORCES.SCRATCH])
        C = d[co : co + n1 * n1].reshape((n1, n1))
        S = d[so : so + n1 * n1].reshape((n1, n1))
        f = d[fo : fo + 6 * size * size].reshape((6, size, size))
        A = d[wo : wo + size * size].reshape((size, size))
        re = d[wo + size * size : wo + size * size + size]
        im = d[wo + size * size + size : wo + size * size + 2 * size]
        _, gx, gy, gz = _kg.field(
            xi, yi, zi, C, S, nmax, int(d[FORCES.M_MAX]), d[FORCES.MU], d[FORCES.RADIUS], f,
            A, re, im,
        )  # fmt: skip
        ax = R[0] * gx + R[3] * gy + R[6] * gz
        ay = R[1] * gx + R[4] * gy + R[7] * gz
        az = R[2] * gx + R[5] * gy + R[8] * gz
    bo = int(d[FORCES.BODIES])
    for b in range(int(d[FORCES.N_BODIES])):
        mu = d[bo + 2 * b]
        to = int(d[bo + 2 * b + 1])
        sx, sy, sz, _, _, _ = _sk._eph_state(d[to:], t, False)
        px, py, pz = _kg.third_body(mu, 1e3 * sx, 1e3 * sy, 1e3 * sz, x, y, z)
        ax += px
        ay += py
        az += pz
    return ax, ay, az


@jit
def orbit_rhs(t, y, d, dydt):
    """ṙ = v, v̇ = a(t, r): the translational equations in the GCRS (m, m/s)."""
    dydt[0] = y[3]
    dydt[1] = y[4]
    dydt[2] = y[5]
    dydt[3], dydt[4], dydt[5] = acceleration(d, t, y[0], y[1], y[2])


@jit
def surface(d, t, x, y, z):
    """(x² + y²)/a² + z²/b² − 1 in the Earth-fixed frame: negative inside the ellipsoid."""
    R = earth_rotation(d, t)
    zi = R[6] * x + R[7] * y + R[8] * z
    r2 = x * x + y * y + z * z
    a = d[FORCES.SURFACE_A]
    b = d[FORCES.SURFACE_B]
    return (r2 - zi * zi) / (a * a) + zi * zi / (b * b) - 1.0


@jit
def inside(d, t, y):
    """Whether the state ``y`` (m) is inside the Earth (WGS 84 ellipsoid) at t."""
    return surface(d, t, y[0], y[1], y[2]) < 0.0


@jit
def run(d, y0, t0, t_out, y_out, work, tstate, counters, rtol, atol, t_stop, max_step, max_steps,
        impact):  # fmt: skip
    """Integrate the orbit through the output times ``t_out`` (monotonic, in the direction of
    ``t_stop``), from ``(t0, y0)`` on the first call (``counters[3] == 0``), else continuing
    from the state kept in ``work``/``tstate``/``counters`` (orbit._rk's layouts). Steps never
    cross ``t_stop`` (±inf: the steps do not depend on the outputs asked for).

    Returns ``(status, n_done, t_impact)``: ``status`` one of orbit._rk's codes or
    :data:`IMPACT` (the orbit reached the surface at ``t_impact``; ``impact`` (6,) holds the
    state there, the ``n_done`` output rows before it are filled).
    """
    n = 6
    m = t_out.shape[0]
    y = work[WORK.Y]
    f = work[WORK.F0]
    if counters[3] == 0:
        for i in range(n):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        tstate[3] = 0.0
        orbit_rhs(t0, y, d, f)
        counters[1] += 1
        counters[3] = 1
        counters[4] = 0
    direction = 1.0 if t_stop >= tstate[0] else -1.0
    h_abs = tstate[1]
    k = 0
    while True:
        while k < m:
            to = t_out[k]
            if to == tstate[0]:
                for i in range(n):
                    y_out[k, i] = y[i]
            elif (
                counters[0] > 0
                and direction * (to - tstate[2]) >= 0.0
                and direction * (tstate[0] - to) > 0.0
            ):
                if counters[4] == 0:
                    _dense_coefficients(orbit_rhs, d, work, tstate, counters)
                _interpolate(work, tstate, to, y_out[k])
            else:
                break
            k += 1
        if k == m:
            return SUCCESS, k, math.nan
        if h_abs == 0.0:
            t = tstate[0]
            h_abs = _initial_step(orbit_rhs, d, t, y, f, direction, rtol, atol,
                                  abs(t_stop - t), work, counters)  # fmt: skip
        if counters[0] >= max_steps:
            return TOO_MANY_STEPS, k, math.nan
        status, h_abs = dop853_step(orbit_rhs, d, work, tstate, counters, h_abs, direction,
                                    t_stop, rtol, atol, max_step)  # fmt: skip
        if status != SUCCESS:
            return status, k, math.nan
        if inside(d, tstate[0], y):
            _dense_coefficients(orbit_rhs, d, work, tstate, counters)
            ti = crossing(inside, d, work, tstate, impact)
            while k < m and direction * (ti - t_out[k]) > 0.0:
                _interpolate(work, tstate, t_out[k], y_out[k])
                k += 1
            return IMPACT, k, ti


@jit
def acceleration_loop(d, t, r, out):
    """:func:`acceleration` at times ``t`` (k,) and positions ``r`` (k, 3) into ``out``."""
    for k in range(t.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = acceleration(d, t[k], r[k, 0], r[k, 1], r[k, 2])


@jit
def rotation_loop(d, t, out):
    """:func:`earth_rotation` at times ``t`` (k,) into ``out`` (k, 3, 3)."""
    for k in range(t.shape[0]):
        R = earth_rotation(d, t[k])
        for i in range(3):
            for j in range(3):
                out[k, i, j] = R[3 * i + j]


@jit
def surface_loop(d, t, r, out):
    """:func:`surface` at times ``t`` (k,) and positions ``r`` (k, 3) [m] into ``out`` (k,)."""
    for k in range(t.shape[0]):
        out[k] = surface(d, t[k], r[k, 0], r[k, 1], r[k, 2])

"""Reference attitudes in compiled code: one dispatcher ``frame_eval(d, t)`` over every frame.

A reference frame R (``attitude.frames``) is a float64 array ``d`` whose first entry is a type
code. :func:`frame_eval` returns its attitude quaternion q_R(t) (reference components → space
components, the convention of the body attitude q, docs/conventions.md) and its angular velocity
ω_R(t) in reference axes, so events and attitude laws can read any frame inside the integrator.

Every frame but the inertial one is a **two-vector (TRIAD) frame**: a primary reference axis
t1 points exactly along a primary direction P(t) of space, and a secondary axis as close as
possible to a secondary direction S(t). With the orthonormal triads

    body/reference:  t1 = a,  t2 = a × b / |a × b|,  t3 = t1 × t2
    space:           T1 = P,  T2 = P × S / |P × S|,   T3 = T1 × T2

the rotation is R = Σ_i T_i t_iᵀ (x_space = R x_reference) and, the triad being orthonormal,
its angular velocity is ω_S = ½ Σ_i T_i × Ṫ_i (Ṫ_i = ω × T_i), ω_R = Rᵀ ω_S. The derivatives
Ṫ_i are exact: they come from the orbit's position, velocity and acceleration
(``orbit._state_kernels.orbit_state`` / ``orbit_acceleration``) and from the velocities of
tabulated targets (the Sun, a ground station; :mod:`orbit.tables`), never from finite
differences.

Directions (unit vectors in space, seen from the spacecraft):

============  ======================================  =====================================
code          direction                               derivative
============  ======================================  =====================================
ZENITH        r/|r|                                   (v − u (u·v)) / |r|
VELOCITY      v/|v|                                   (a − u (u·a)) / |v|
NORMAL        h/|h|, h = r × v                        (ḣ − u (u·ḣ)) / |h|, ḣ = r × a
SUN           (s − r)/|s − r|, s the Sun              from ṡ − v
TARGET        (x_T − r)/|x_T − r|, x_T a table        from ẋ_T − v
FIXED         a constant vector                        0
============  ======================================  =====================================

and their opposites (NADIR = −ZENITH, ...). Frames: LVLH (CCSDS/Vallado: z to nadir, y to
minus the orbit normal) is P = NADIR on z, S = ANTI_NORMAL on y; RSW (the orbital frame p(t)
of Arribas et al. Sect. 6.2) is ZENITH on x, NORMAL on z; VNC is VELOCITY on x, NORMAL on y.

Layout (the declarations INERTIAL and ALIGNED below): the frame's type and an offset
quaternion, then an inertial frame's constant q_R, or an aligned frame's direction codes,
triad axes, fixed directions and the offsets of its blocks (the orbit's ``kernel_data()``, the
Sun table, the target table) that follow.

A parallel P and S (e.g. the Sun at the zenith for a Sun-pointing frame whose secondary points
at nadir) leaves the frame undefined: the kernel then returns NaN.
"""

from __future__ import annotations

import math

from orbit._layout import Field, layout
from orbit._shared_jit import jit
from orbit._state_kernels import (
    MU,
    TYPE,
    TYPE_KEPLER,
    orbit_acceleration,
    orbit_state,
    quaternion_from_axes,
)

from .quat import mul, rotate_inverse

FRAME_INERTIAL = 0
FRAME_ALIGNED = 1

_FRAME_HEAD = dict(
    type=Field(1, "", "FRAME_INERTIAL or FRAME_ALIGNED"),
    offset=Field(4, "", "offset quaternion o: q = q_R∘o, ω = õ∘ω_R∘o"),
)
FRAME = layout("frame header", **_FRAME_HEAD)
INERTIAL = layout("inertial frame", **_FRAME_HEAD, q=Field(4, "", "the constant q_R"))
ALIGNED = layout(
    "aligned frame",
    **_FRAME_HEAD,
    pdir=Field(1, "", "direction code of P"),
    sdir=Field(1, "", "direction code of S"),
    body=Field(9, "", "t1, t2, t3 (reference axes of the triad)", (3, 3)),
    pvec=Field(3, "", "fixed direction of P (FIXED), else unused"),
    svec=Field(3, "", "fixed direction of S (FIXED), else unused"),
    orbit=Field(1, "", "offset of the orbit's kernel_data() (0: absent)"),
    sun=Field(1, "", "offset of the Sun table (0: absent)"),
    target=Field(1, "", "offset of the target table (0: absent)"),
)

DIR_ZENITH = 1
DIR_NADIR = 2
DIR_VELOCITY = 3
DIR_ANTI_VELOCITY = 4
DIR_NORMAL = 5
DIR_ANTI_NORMAL = 6
DIR_SUN = 7
DIR_ANTI_SUN = 8
DIR_TARGET = 9
DIR_ANTI_TARGET = 10
DIR_FIXED = 11

_NAN7 = (math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)


@jit
def _unit_rate(x, y, z, dx, dy, dz):
    """(u, u̇) of u = x/|x| given x and ẋ: u̇ = (ẋ − u (u·ẋ)) / |x|."""
    n = math.sqrt(x * x + y * y + z * z)
    ux, uy, uz = x / n, y / n, z / n
    p = ux * dx + uy * dy + uz * dz
    return ux, uy, uz, (dx - ux * p) / n, (dy - uy * p) / n, (dz - uz * p) / n


@jit
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@jit
def _direction(code, vec, d, t, st, acc, sun, tgt):
    """(u, u̇) of direction ``code`` (state st = r, v; acc = a; sun, tgt = states)."""
    base = code
    sign = 1.0
    if code == DIR_NADIR or code == DIR_ANTI_VELOCITY or code == DIR_ANTI_NORMAL:
        base = code - 1
        sign = -1.0
    elif code == DIR_ANTI_SUN or code == DIR_ANTI_TARGET:
        base = code - 1
        sign = -1.0
    x, y, z, vx, vy, vz = st
    if base == DIR_ZENITH:
        u = _unit_rate(x, y, z, vx, vy, vz)
    elif base == DIR_VELOCITY:
        u = _unit_rate(vx, vy, vz, acc[0], acc[1], acc[2])
    elif base == DIR_NORMAL:
        hx, hy, hz = _cross(x, y, z, vx, vy, vz)
        dhx, dhy, dhz = _cross(x, y, z, acc[0], acc[1], acc[2])
        u = _unit_rate(hx, hy, hz, dhx, dhy, dhz)
    elif base == DIR_SUN:
        u = _unit_rate(sun[0] - x, sun[1] - y, sun[2] - z, sun[3] - vx, sun[4] - vy, sun[5] - vz)
    elif base == DIR_TARGET:
        u = _unit_rate(tgt[0] - x, tgt[1] - y, tgt[2] - z, tgt[3] - vx, tgt[4] - vy, tgt[5] - vz)
    else:  # FIXED
        n = math.sqrt(d[vec] ** 2 + d[vec + 1] ** 2 + d[vec + 2] ** 2)
        u = (d[vec] / n, d[vec + 1] / n, d[vec + 2] / n, 0.0, 0.0, 0.0)
    return (sign * u[0], sign * u[1], sign * u[2], sign * u[3], sign * u[4], sign * u[5])


@jit
def _needs_acceleration(code):
    return (
        code == DIR_VELOCITY
        or code == DIR_ANTI_VELOCITY
        or code == DIR_NORMAL
        or code == DIR_ANTI_NORMAL
    )


@jit
def _acceleration(od, t, st):
    """The orbit's acceleration at t (state st): −μ r/r³ without a second Kepler solve."""
    if int(od[TYPE]) == TYPE_KEPLER:
        x, y, z = st[0], st[1], st[2]
        r2 = x * x + y * y + z * z
        g = -od[MU] / (r2 * math.sqrt(r2))
        return g * x, g * y, g * z
    return orbit_acceleration(od, t)


@jit
def _aligned(d, t, with_rate):
    zero6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    pc = int(d[ALIGNED.PDIR])
    sc = int(d[ALIGNED.SDIR])
    o = int(d[ALIGNED.ORBIT])
    st = zero6
    acc = (0.0, 0.0, 0.0)
    if o > 0:
        od = d[o:]
        st = orbit_state(od, t)
        if with_rate and (_needs_acceleration(pc) or _needs_acceleration(sc)):
            acc = _acceleration(od, t, st)
    sun = zero6
    if int(d[ALIGNED.SUN]) > 0:
        sun = orbit_state(d[int(d[ALIGNED.SUN]) :], t)
    tgt = zero6
    if int(d[ALIGNED.TARGET]) > 0:
        tgt = orbit_state(d[int(d[ALIGNED.TARGET]) :], t)
    p = _direction(pc, ALIGNED.PVEC, d, t, st, acc, sun, tgt)
    s = _direction(sc, ALIGNED.SVEC, d, t, st, acc, sun, tgt)
    # space triad and its derivative
    T1x, T1y, T1z, dT1x, dT1y, dT1z = p
    ux, uy, uz = _cross(p[0], p[1], p[2], s[0], s[1], s[2])
    a1 = _cross(p[3], p[4], p[5], s[0], s[1], s[2])
    a2 = _cross(p[0], p[1], p[2], s[3], s[4], s[5])
    if ux * ux + uy * uy + uz * uz == 0.0:
        return _NAN7
    T2x, T2y, T2z, dT2x, dT2y, dT2z = _unit_rate(
        ux, uy, uz, a1[0] + a2[0], a1[1] + a2[1], a1[2] + a2[2]
    )
    T3x, T3y, T3z = _cross(T1x, T1y, T1z, T2x, T2y, T2z)
    # R = Σ T_i t_iᵀ; its column k is R e_k = Σ_i T_i t_i[k]
    b = ALIGNED.BODY
    c0x, c0y, c0z = _column(d, b, 0, T1x, T1y, T1z, T2x, T2y, T2z, T3x, T3y, T3z)
    c1x, c1y, c1z = _column(d, b, 1, T1x, T1y, T1z, T2x, T2y, T2z, T3x, T3y, T3z)
    c2x, c2y, c2z = _column(d, b, 2, T1x, T1y, T1z, T2x, T2y, T2z, T3x, T3y, T3z)
    q = quaternion_from_axes(c0x, c0y, c0z, c1x, c1y, c1z, c2x, c2y, c2z)
    if not with_rate:
        return q[0], q[1], q[2], q[3], 0.0, 0.0, 0.0
    b1 = _cross(dT1x, dT1y, dT1z, T2x, T2y, T2z)
    b2 = _cross(T1x, T1y, T1z, dT2x, dT2y, dT2z)
    dT3x, dT3y, dT3z = b1[0] + b2[0], b1[1] + b2[1], b1[2] + b2[2]
    # ω_S = ½ Σ T_i × Ṫ_i
    c1 = _cross(T1x, T1y, T1z, dT1x, dT1y, dT1z)
    c2 = _cross(T2x, T2y, T2z, dT2x, dT2y, dT2z)
    c3 = _cross(T3x, T3y, T3z, dT3x, dT3y, dT3z)
    wx = 0.5 * (c1[0] + c2[0] + c3[0])
    wy = 0.5 * (c1[1] + c2[1] + c3[1])
    wz = 0.5 * (c1[2] + c2[2] + c3[2])
    return (
        q[0],
        q[1],
        q[2],
        q[3],
        c0x * wx + c0y * wy + c0z * wz,
        c1x * wx + c1y * wy + c1z * wz,
        c2x * wx + c2y * wy + c2z * wz,
    )


@jit
def _column(d, b, k, T1x, T1y, T1z, T2x, T2y, T2z, T3x, T3y, T3z):
    t1k = d[b + k]
    t2k = d[b + 3 + k]
    t3k = d[b + 6 + k]
    return (
        T1x * t1k + T2x * t2k + T3x * t3k,
        T1y * t1k + T2y * t2k + T3y * t3k,
        T1z * t1k + T2z * t2k + T3z * t3k,
    )


@jit
def frame_eval(d, t):
    """(q0, q1, q2, q3, ω1, ω2, ω3): q_R(t) (reference → space) and ω_R(t) in reference axes."""
    return _frame(d, t, True)


@jit
def frame_attitude(d, t):
    """(q0, q1, q2, q3): q_R(t) only (no derivatives: cheaper, what pointing events need)."""
    r = _frame(d, t, False)
    return r[0], r[1], r[2], r[3]


@jit(inline="always")
def _offset(d, q, w):
    """(q, ω) of a frame turned by its fixed offset (none: as they are)."""
    o = (d[FRAME.OFFSET], d[FRAME.OFFSET + 1], d[FRAME.OFFSET + 2], d[FRAME.OFFSET + 3])
    if o[0] != 1.0 or o[1] != 0.0 or o[2] != 0.0 or o[3] != 0.0:
        q = mul(q, o)
        w = rotate_inverse(o, w)
    return q, w


@jit(inline="always")
def inertial_frame(d):
    """(q_R, ω_R) of an inertial frame's data ``d`` (``d[FRAME.TYPE] == FRAME_INERTIAL``), as
    :func:`frame_eval` gives them: inlined where a loop asks every tick."""
    return _offset(
        d, (d[INERTIAL.Q], d[INERTIAL.Q + 1], d[INERTIAL.Q + 2], d[INERTIAL.Q + 3]), (0.0, 0.0, 0.0)
    )


@jit
def _frame(d, t, with_rate):
    if int(d[FRAME.TYPE]) == FRAME_INERTIAL:
        q, w = inertial_frame(d)
    else:
        r = _aligned(d, t, with_rate)
        q, w = _offset(d, (r[0], r[1], r[2], r[3]), (r[4], r[5], r[6]))
    return q[0], q[1], q[2], q[3], w[0], w[1], w[2]


@jit
def frame_loop(d, t, out):
    """``out[i] = frame_eval(d, t[i])`` (m, 7)."""
    for i in range(t.shape[0]):
        r = frame_eval(d, t[i])
        for j in range(7):
            out[i, j] = r[j]

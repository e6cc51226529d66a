"""One compiled dispatcher for the state of any orbit: ``orbit_state(data, t)``.

Every orbit source (:class:`orbit.KeplerOrbit`, :class:`orbit.SecularJ2Orbit`,
:class:`orbit.EphemerisOrbit`) describes itself to compiled code as ONE float64 array
``data = orbit.kernel_data()`` whose first entry is a type code. The kernels here branch on it,
so a compiled right-hand side (the gravity-gradient torque, later environment models and
local-orbital frames) reads any orbit through the same three functions:

* :func:`orbit_state` ``(data, t) -> (x, y, z, vx, vy, vz)``  [km, km/s], space frame;
* :func:`orbit_radial` ``(data, t) -> (r, ux, uy, uz)``       radius [km] and r/|r|;
* :func:`orbit_frame` ``(data, t) -> (r, p0, p1, p2, p3)``     radius and the orbital-frame
  quaternion p (Arribas et al. 2006 Sect. 6.2: p∘s1∘p̃ = r̂, p∘s3∘p̃ = (r × v)/|r × v|);
* :func:`orbit_acceleration` ``(data, t) -> (ax, ay, az)``     [km/s²], the time derivative of
  the model's velocity (what the angular velocity of a local orbital frame needs).

``t`` is seconds since the orbit's epoch. No kernel allocates or raises. A time outside an
ephemeris table gives NaNs (the public methods and ``attitude.propagate`` reject such times
before any work; the NaN only guards against misuse from compiled code).

Layout (index constants are module attributes)
----------------------------------------------
Common header::

    data[TYPE]   type code: TYPE_KEPLER = 0, TYPE_SECULAR_J2 = 1, TYPE_EPHEMERIS = 2,
                 TYPE_LIVE = 3, TYPE_REFERENCE = 4 (data[HDR]: the offset of an
                 ephemeris table further on in the same array)
    data[MU]     gravitational parameter μ [km³/s²] (the gravity gradient uses it)
    data[T_MIN]  first valid time [s] (−inf for the analytic orbits)
    data[T_MAX]  last valid time [s]  (+inf for the analytic orbits)

Kepler (length ``K_LEN`` = 25)::

    data[K_EL : K_EL + 9]   the 9-element array of orbit._kernels (a, e, i, Ω, ω, M0, t0, μ, n)
    data[K_TRIG : +6]       cos Ω, sin Ω, cos i, sin i, cos ω, sin ω
    data[K_HALF : +6]       cos(i/2), sin(i/2), cos((Ω+ω)/2), sin((Ω+ω)/2),
                            cos((Ω−ω)/2), sin((Ω−ω)/2)

The trigonometric functions of the constant angles are computed once, when the array is
built, so a gravity-gradient right-hand side pays only for the Kepler solve and cos/sin of
E/2 (before: 6 more libm calls per evaluation). The arithmetic is otherwise that of
``orbit._kernels.radius_and_radial_unit`` / ``state`` / ``radius_and_frame``, so the results are
bit-identical to them.

Secular J2 (length ``J_LEN`` = 18)::

    data[J_EL : J_EL + 9]   a, e, i, Ω0, ω0, M0, t0, μ, n̄  (n̄ = n + Ṁ_J2: the mean-anomaly rate)
    data[J_RAAN_DOT]        Ω̇ [rad/s]
    data[J_ARGP_DOT]        ω̇ [rad/s]
    data[J_RATIO]           n̄ / n  (n = √(μ/a³))
    data[J_COSI], [J_SINI]  cos i, sin i

    Ω(t) = Ω0 + Ω̇ (t − t0),  ω(t) = ω0 + ω̇ (t − t0),  M(t) = M0 + n̄ (t − t0)

Hermite ephemeris (length ``E_TIMES + 7 N``)::

    data[E_N]                  N, number of nodes (>= 2)
    data[E_H]                  uniform spacing h [s], or 0 for irregular times
    data[E_TIMES : +N]         node times [s], strictly increasing
    data[E_TIMES + N : +6N]    rows x, y, z, vx, vy, vz of each node [km, km/s]

Live orbit (length ``L_LEN`` = 13; made in place of a copy of an ephemeris table)::

    data[L_STATE : +6]         x, y, z, vx, vy, vz [km, km/s]: the state an integration
                               carries, written by its right-hand side before the models read it
    data[L_ACC : +3]           the gravitational acceleration there [km/s²]

Interpolation: the Hermite polynomial of degree 7 matching position and velocity at the 4
nodes nearest to t (2 on each side; shifted inwards at the ends of the table), its derivative
for the velocity (:func:`hermite4`). Error bound (|t − t_j| products of the Hermite remainder)::

    |Δr| <= max|r⁽⁸⁾| /8! · Π(t − t_j)² <= 7.8e-6 h⁸ max|r⁽⁸⁾|     (inner intervals)
                                         <= 2.5e-5 h⁸ max|r⁽⁸⁾|     (first and last interval)

per component. For a circular orbit |r⁽⁸⁾| = n⁸ r: 7000 km, h = 60 s gives 2e-11 km
(measured 1e-11 km; 300 s: 2.0e-5 km at the ends). Tables with 2 or 3 nodes use the
cubic/quintic Hermite
polynomial through all of them.

Reuse: :func:`table_interval` (index of the interval holding t, O(1) on uniform grids,
bisection otherwise) and :func:`hermite4` work on any table laid out as times + rows of values
and derivatives, for any number of components (``ncomp``); environment tables (magnetic field,
density, Sun direction) can be stored and interpolated the same way.
"""

from __future__ import annotations

import math
import sys
from typing import Any

from . import _kernels as _k
from ._shared_jit import jit, specialise

__all__ = [
    "E_H", "E_N", "E_TIMES", "HDR", "J_ARGP_DOT", "J_COSI", "J_EL", "J_LEN", "J_RAAN_DOT",
    "J_RATIO", "J_SINI", "K_EL", "K_HALF", "K_LEN", "K_TRIG", "MU", "TYPE", "TYPE_EPHEMERIS",
    "TYPE_KEPLER", "TYPE_LIVE", "TYPE_REFERENCE", "TYPE_SECULAR_J2", "T_MAX", "T_MIN",
    "hermite4", "hermite4_second", "orbit_acceleration", "orbit_frame", "orbit_radial",
    "orbit_sample", "orbit_state", "radial_kernel", "sample_kernel", "table_interval",
]  # fmt: skip

TYPE_KEPLER = 0
TYPE_SECULAR_J2 = 1
TYPE_EPHEMERIS = 2
#: A live orbit: the state an integration carries, written into the array by the integrator's
#: right-hand side before the models read it (attitude._core.coupled); the models' kernels
#: read it through the same dispatcher. Made in place of an ephemeris table's copy.
TYPE_LIVE = 3
#: A reference to an ephemeris table further on in the same array (``data[HDR]``: its offset
#: from this block): a live orbit turned, after the run, into the table of the run's samples.
TYPE_REFERENCE = 4

# Common header.
TYPE = 0
MU = 1
T_MIN = 2
T_MAX = 3
HDR = 4

# Kepler.
K_EL = HDR
K_TRIG = K_EL + _k.NEL  # 13
K_HALF = K_TRIG + 6  # 19
K_LEN = K_HALF + 6  # 25

# Secular J2.
J_EL = HDR
J_RAAN_DOT = J_EL + _k.NEL  # 13
J_ARGP_DOT = J_RAAN_DOT + 1
J_RATIO = J_RAAN_DOT + 2
J_COSI = J_RAAN_DOT + 3
J_SINI = J_RAAN_DOT + 4
J_LEN = J_RAAN_DOT + 5  # 18

# Hermite ephemeris.
E_N = HDR
E_H = HDR + 1
E_TIMES = HDR + 4  # two reserved slots (6, 7) for future use

# Live orbit.
L_STATE = HDR  # x, y, z [km], vx, vy, vz [km/s]
L_ACC = HDR + 6  # the gravitational acceleration there [km/s²]
L_LEN = HDR + 9

_NAN = math.nan


# ---------------------------------------------------------------------------------------------
# Generic table kernels (reusable for any tabulated, interpolated quantity).
@jit
def table_interval(d, toff, n, h, t):
    """Index i in [0, n − 2] of the interval [times[i], times[i+1]] holding t (clamped).

    ``times = d[toff : toff + n]`` strictly increasing; ``h > 0`` for a uniform grid (O(1)
    index, corrected against the stored times), else bisection.
    """
    t0 = d[toff]
    if h > 0.0:
        x = (t - t0) / h
        if not x > 0.0:  # (also a NaN t: int(NaN) is no index)
            i = 0
        elif x >= n - 2:
            i = n - 2
        else:
            i = int(x)
        # the stored times are the truth: correct a rounding of the division
        while i > 0 and t < d[toff + i]:
            i -= 1
        while i < n - 2 and t > d[toff + i + 1]:
            i += 1
        return i
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if d[toff + mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@jit
def _hermite_general(d, toff, roff, stride, j0, m, t, c, with_derivative):
    """Hermite value and derivative of component ``c`` through m (<= 4) nodes (loop form)."""
    val = 0.0
    der = 0.0
    for j in range(m):
        tj = d[toff + j0 + j]
        L = 1.0
        cj = 0.0
        Lp = 0.0
        for k in range(m):
            if k != j:
                tk = d[toff + j0 + k]
                inv = 1.0 / (tj - tk)
                L *= (t - tk) * inv
                cj += inv
        if with_derivative:
            for mm in range(m):
                if mm != j:
                    term = 1.0 / (tj - d[toff + j0 + mm])
                    for k in range(m):
                        if k != j and k != mm:
                            tk = d[toff + j0 + k]
                            term *= (t - tk) / (tj - tk)
                    Lp += term
        x = t - tj
        L2 = L * L
        a = (1.0 - 2.0 * cj * x) * L2
        b = x * L2
        row = roff + stride * (j0 + j)
        y = d[row + c]
        yp = d[row + stride // 2 + c]
        val += a * y + b * yp
        if with_derivative:
            da = -2.0 * cj * L2 + 2.0 * (1.0 - 2.0 * cj * x) * L * Lp
            db = L2 + 2.0 * x * L * Lp
            der += da * y + db * yp
    return val, der


@jit
def hermite_weights4(t, t0, t1, t2, t3):
    """Weights of the degree-7 Hermite interpolant on 4 nodes and of its derivative.

    f(t) ≈ Σ_j a_j f(t_j) + b_j f'(t_j),  f'(t) ≈ Σ_j da_j f(t_j) + db_j f'(t_j), with the
    Lagrange basis L_j, c_j = L_j'(t_j) = Σ_{k≠j} 1/(t_j − t_k):
    a_j = (1 − 2 c_j (t − t_j)) L_j², b_j = (t − t_j) L_j².
    Returns (a0..a3, b0..b3, da0..da3, db0..db3) as a 16-tuple.
    """
    x0 = t - t0
    x1 = t - t1
    x2 = t - t2
    x3 = t - t3
    i01 = 1.0 / (t0 - t1)
    i02 = 1.0 / (t0 - t2)
    i03 = 1.0 / (t0 - t3)
    i12 = 1.0 / (t1 - t2)
    i13 = 1.0 / (t1 - t3)
    i23 = 1.0 / (t2 - t3)
    w0 = i01 * i02 * i03
    w1 = -i01 * i12 * i13
    w2 = i02 * i12 * i23
    w3 = -i03 * i13 * i23
    L0 = x1 * x2 * x3 * w0
    L1 = x0 * x2 * x3 * w1
    L2 = x0 * x1 * x3 * w2
    L3 = x0 * x1 * x2 * w3
    P0 = (x2 * x3 + x1 * x3 + x1 * x2) * w0
    P1 = (x2 * x3 + x0 * x3 + x0 * x2) * w1
    P2 = (x1 * x3 + x0 * x3 + x0 * x1) * w2
    P3 = (x1 * x2 + x0 * x2 + x0 * x1) * w3
    c0 = i01 + i02 + i03
    c1 = -i01 + i12 + i13
    c2 = -i02 - i12 + i23
    c3 = -i03 - i13 - i23
    q0 = L0 * L0
    q1 = L1 * L1
    q2 = L2 * L2
    q3 = L3 * L3
    g0 = 1.0 - 2.0 * c0 * x0
    g1 = 1.0 - 2.0 * c1 * x1
    g2 = 1.0 - 2.0 * c2 * x2
    g3 = 1.0 - 2.0 * c3 * x3
    return (
        g0 * q0,
        g1 * q1,
        g2 * q2,
        g3 * q3,
        x0 * q0,
        x1 * q1,
        x2 * q2,
        x3 * q3,
        -2.0 * c0 * q0 + 2.0 * g0 * L0 * P0,
        -2.0 * c1 * q1 + 2.0 * g1 * L1 * P1,
        -2.0 * c2 * q2 + 2.0 * g2 * L2 * P2,
        -2.0 * c3 * q3 + 2.0 * g3 * L3 * P3,
        q0 + 2.0 * x0 * L0 * P0,
        q1 + 2.0 * x1 * L1 * P1,
        q2 + 2.0 * x2 * L2 * P2,
        q3 + 2.0 * x3 * L3 * P3,
    )


@jit
def hermite4(d, toff, roff, ncomp, n, h, t, c):
    """(value, derivative) of component ``c`` of a Hermite table at t (no range check).

    Table: times ``d[toff : toff + n]`` (uniform spacing ``h``, or 0); node j's row at
    ``roff + 2 ncomp j`` holds ``ncomp`` values then their ``ncomp`` time derivatives. Degree 7
    on the 4 nodes around t.
    """
    i = table_interval(d, toff, n, h, t)
    stride = 2 * ncomp
    if n < 4:
        return _hermite_general(d, toff, roff, stride, 0, n, t, c, True)
    j0 = min(max(i - 1, 0), n - 4)
    w = hermite_weights4(t, d[toff + j0], d[toff + j0 + 1], d[toff + j0 + 2], d[toff + j0 + 3])
    val = 0.0
    der = 0.0
    for j in range(4):
        row = roff + stride * (j0 + j)
        y = d[row + c]
        yp = d[row + ncomp + c]
        val += w[j] * y + w[4 + j] * yp
        der += w[8 + j] * y + w[12 + j] * yp
    return val, der


# ---------------------------------------------------------------------------------------------
# Kepler (precomputed trigonometric functions of the constant angles).
@jit
def _kepler_radial(d, t):
    el = d[K_EL : K_EL + _k.NEL]
    r, cf, sf = _k._radius_cos_sin_f(el, t)
    return _kepler_radial_from(d, r, cf, sf)


@jit
def _kepler_radial_from(d, r, cf, sf):
    """(r, r̂) from r, cos f, sin f."""
    cO = d[K_TRIG]
    sO = d[K_TRIG + 1]
    ci = d[K_TRIG + 2]
    si = d[K_TRIG + 3]
    cw = d[K_TRIG + 4]
    sw = d[K_TRIG + 5]
    cu = cw * cf - sw * sf  # u = ω + f
    su = sw * cf + cw * sf
    return r, cO * cu - sO * ci * su, sO * cu + cO * ci * su, si * su


@jit
def _kepler_state(d, t):
    el = d[K_EL : K_EL + _k.NEL]
    _, xp, yp, vxp, vyp = _k._perifocal(el, t)
    return _k.rotate_perifocal(
        xp,
        yp,
        vxp,
        vyp,
        d[K_TRIG],
        d[K_TRIG + 1],
        d[K_TRIG + 2],
        d[K_TRIG + 3],
        d[K_TRIG + 4],
        d[K_TRIG + 5],
    )


@jit
def _kepler_frame(d, t):
    el = d[K_EL : K_EL + _k.NEL]
    c, s, sign = _k._half_angle_parts(el, t)
    return _kepler_frame_from(d, c, s, sign)


@jit
def _kepler_frame_from(d, c, s, sign):
    """(r, p) from the half-angle parts of orbit._kernels._half_angle_parts."""
    n2 = c * c + s * s
    nrm = sign / math.sqrt(n2)
    ch = c * nrm  # cos(f/2)
    sh = s * nrm  # sin(f/2)
    ci = d[K_HALF]
    si = d[K_HALF + 1]
    cA = d[K_HALF + 2]
    sA = d[K_HALF + 3]
    cB = d[K_HALF + 4]
    sB = d[K_HALF + 5]
    # Arribas et al. (2006) Sect. 6.2, their eq. 12 with (φ, ϑ, ψ) = (Ω, i, ω + f)
    return (
        abs(d[K_EL + _k.A]) * n2,
        ci * (cA * ch - sA * sh),
        si * (cB * ch + sB * sh),
        si * (sB * ch - cB * sh),
        ci * (sA * ch + cA * sh),
    )


# ---------------------------------------------------------------------------------------------
# Secular J2.
@jit
def _j2_angles(d, t):
    dt = t - d[J_EL + _k.T0]
    om = d[J_EL + _k.RAAN] + d[J_RAAN_DOT] * dt
    w = d[J_EL + _k.ARGP] + d[J_ARGP_DOT] * dt
    return math.cos(om), math.sin(om), math.cos(w), math.sin(w)


@jit
def _j2_state(d, t):
    el = d[J_EL : J_EL + _k.NEL]
    _, xp, yp, vxp, vyp = _k._perifocal(el, t)  # velocity for dM/dt = n; scaled to n̄ below
    cO, sO, cw, sw = _j2_angles(d, t)
    ci = d[J_COSI]
    si = d[J_SINI]
    k = d[J_RATIO]
    x, y, z, vx, vy, vz = _k.rotate_perifocal(xp, yp, k * vxp, k * vyp, cO, sO, ci, si, cw, sw)
    # dr/dt = (in-plane motion at rate n̄) + Ω̇ ẑ × r + ω̇ ĥ × r,
    # ĥ = (sin Ω sin i, −cos Ω sin i, cos i)
    od = d[J_RAAN_DOT]
    wd = d[J_ARGP_DOT]
    hx, hy, hz = sO * si, -cO * si, ci
    vx += -od * y + wd * (hy * z - hz * y)
    vy += od * x + wd * (hz * x - hx * z)
    vz += wd * (hx * y - hy * x)
    return x, y, z, vx, vy, vz


@jit
def _j2_radial(d, t):
    el = d[J_EL : J_EL + _k.NEL]
    r, cf, sf = _k._radius_cos_sin_f(el, t)
    cO, sO, cw, sw = _j2_angles(d, t)
    ci = d[J_COSI]
    si = d[J_SINI]
    cu = cw * cf - sw * sf
    su = sw * cf + cw * sf
    return r, cO * cu - sO * ci * su, sO * cu + cO * ci * su, si * su


# ---------------------------------------------------------------------------------------------
# Hermite ephemeris.
@jit
def _eph_in_range(d, t):
    lo = d[T_MIN]
    hi = d[T_MAX]
    tol = 1e-12 * max(1.0, abs(lo), abs(hi))
    return t >= lo - tol and t <= hi + tol


@jit
def _eph_state(d, t, with_velocity):
    if not _eph_in_range(d, t):
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN
    n = int(d[E_N])
    roff = E_TIMES + n
    i = table_interval(d, E_TIMES, n, d[E_H], t)
    if n < 4:
        x, vx = _hermite_general(d, E_TIMES, roff, 6, 0, n, t, 0, with_velocity)
        y, vy = _hermite_general(d, E_TIMES, roff, 6, 0, n, t, 1, with_velocity)
        z, vz = _hermite_general(d, E_TIMES, roff, 6, 0, n, t, 2, with_velocity)
        return x, y, z, vx, vy, vz
    j0 = min(max(i - 1, 0), n - 4)
    w = hermite_weights4(
        t, d[E_TIMES + j0], d[E_TIMES + j0 + 1], d[E_TIMES + j0 + 2], d[E_TIMES + j0 + 3]
    )
    x = y = z = vx = vy = vz = 0.0
    for j in range(4):
        row = roff + 6 * (j0 + j)
        a = w[j]
        b = w[4 + j]
        x += a * d[row] + b * d[row + 3]
        y += a * d[row + 1] + b * d[row + 4]
        z += a * d[row + 2] + b * d[row + 5]
        if with_velocity:
            da = w[8 + j]
            db = w[12 + j]
            vx += da * d[row] + db * d[row + 3]
            vy += da * d[row + 1] + db * d[row + 4]
            vz += da * d[row + 2] + db * d[row + 5]
    return x, y, z, vx, vy, vz


@jit
def _eph_radial(d, t):
    x, y, z, _, _, _ = _eph_state(d, t, False)
    r = math.sqrt(x * x + y * y + z * z)
    return r, x / r, y / r, z / r


def radial_kernel(d) -> tuple[str, Any]:
    """(tag, kernel): the kernel ``orbit_radial`` runs for the orbit ``d`` (its type's), for
    compiled code specialised to one orbit (attitude._core.models binds it instead of the
    dispatcher); an elliptic Kepler orbit gets the copy without the hyperbolic solver."""
    kind = int(d[TYPE])
    if kind == TYPE_KEPLER:
        if d[K_EL + _k.ECC] < 1.0:
            return "kepler_elliptic", _ELLIPTIC._kepler_radial
        return "kepler", _kepler_radial
    if kind == TYPE_SECULAR_J2:
        return "j2", _j2_radial
    return "ephemeris", _eph_radial


# ---------------------------------------------------------------------------------------------
# From a state to the orbital frame.
@jit
def quaternion_from_axes(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Unit quaternion (scalar first) of the active rotation R with columns a, b, c.

    R = to_matrix(q) (Schwab eq. 7): x_S = R x. Shepperd's method (largest pivot).
    """
    r00, r01, r02 = ax, bx, cx
    r10, r11, r12 = ay, by, cy
    r20, r21, r22 = az, bz, cz
    tr = r00 + r11 + r22
    if tr >= r00 and tr >= r11 and tr >= r22:
        w = 0.5 * math.sqrt(1.0 + tr)
        f = 0.25 / w
        return w, (r21 - r12) * f, (r02 - r20) * f, (r10 - r01) * f
    if r00 >= r11 and r00 >= r22:
        x = 0.5 * math.sqrt(1.0 + r00 - r11 - r22)
        f = 0.25 / x
        return (r21 - r12) * f, x, (r01 + r10) * f, (r02 + r20) * f
    if r11 >= r22:
        y = 0.5 * math.sqrt(1.0 - r00 + r11 - r22)
        f = 0.25 / y
        return (r02 - r20) * f, (r01 + r10) * f, y, (r12 + r21) * f
    z = 0.5 * math.sqrt(1.0 - r00 - r11 + r22)
    f = 0.25 / z
    return (r10 - r01) * f, (r02 + r20) * f, (r12 + r21) * f, z


@jit
def frame_from_state(x, y, z, vx, vy, vz):
    """(r, p0, p1, p2, p3): p maps (radial, along-track, normal) axes to the space frame."""
    r = math.sqrt(x * x + y * y + z * z)
    ux, uy, uz = x / r, y / r, z / r
    hx = y * vz - z * vy
    hy = z * vx - x * vz
    hz = x * vy - y * vx
    h = math.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / h, hy / h, hz / h
    sx = hy * uz - hz * uy  # ŝ2 = ĥ × r̂
    sy = hz * ux - hx * uz
    sz = hx * uy - hy * ux
    p0, p1, p2, p3 = quaternion_from_axes(ux, uy, uz, sx, sy, sz, hx, hy, hz)
    return r, p0, p1, p2, p3


# ---------------------------------------------------------------------------------------------
# The dispatcher.
@jit
def orbit_state(d, t):
    """(x, y, z, vx, vy, vz) [km, km/s] of the orbit ``d`` at t [s since its epoch]."""
    kind = int(d[TYPE])
    if kind == TYPE_KEPLER:
        return _kepler_state(d, t)
    if kind == TYPE_SECULAR_J2:
        return _j2_state(d, t)
    if kind == TYPE_LIVE:
        o = L_STATE
        return d[o], d[o + 1], d[o + 2], d[o + 3], d[o + 4], d[o + 5]
    if kind == TYPE_REFERENCE:
        return _eph_state(d[int(d[HDR]) :], t, True)
    return _eph_state(d, t, True)


@jit
def orbit_radial(d, t):
    """(r, ux, uy, uz): radius [km] and radial unit vector r/|r| (space frame)."""
    kind = int(d[TYPE])
    if kind == TYPE_KEPLER:
        return _kepler_radial(d, t)
    if kind == TYPE_SECULAR_J2:
        return _j2_radial(d, t)
    if kind == TYPE_LIVE:
        x, y, z = d[L_STATE], d[L_STATE + 1], d[L_STATE + 2]
        r = math.sqrt(x * x + y * y + z * z)
        return r, x / r, y / r, z / r
    if kind == TYPE_REFERENCE:
        return _eph_radial(d[int(d[HDR]) :], t)
    return _eph_radial(d, t)


@jit
def orbit_frame(d, t):
    """(r, p0, p1, p2, p3): radius [km] and orbital-frame quaternion p (scalar first)."""
    if int(d[TYPE]) == TYPE_KEPLER:
        return _kepler_frame(d, t)
    x, y, z, vx, vy, vz = orbit_state(d, t)
    return frame_from_state(x, y, z, vx, vy, vz)


# ---------------------------------------------------------------------------------------------
# Everything an attitude run records about the orbit at a sample, in one call.
@jit
def _kepler_sample(d, t):
    el = d[K_EL : K_EL + _k.NEL]
    c, s, sign, f = _k.half_angles_and_true_anomaly(el, t)
    r, cf, sf = _k.radius_cos_sin_f(el, c, s)
    _, ux, uy, uz = _kepler_radial_from(d, r, cf, sf)
    _, p0, p1, p2, p3 = _kepler_frame_from(d, c, s, sign)
    return r, ux, uy, uz, f, p0, p1, p2, p3


@jit
def _j2_sample(d, t):
    r, ux, uy, uz = _j2_radial(d, t)
    f = _k.true_anomaly(d[J_EL : J_EL + _k.NEL], t)
    x, y, z, vx, vy, vz = _j2_state(d, t)
    _, p0, p1, p2, p3 = frame_from_state(x, y, z, vx, vy, vz)
    return r, ux, uy, uz, f, p0, p1, p2, p3


@jit
def _eph_sample(d, t):
    r, ux, uy, uz = _eph_radial(d, t)
    x, y, z, vx, vy, vz = _eph_state(d, t, True)
    _, p0, p1, p2, p3 = frame_from_state(x, y, z, vx, vy, vz)
    return r, ux, uy, uz, _NAN, p0, p1, p2, p3


@jit
def orbit_sample(d, t):
    """(r, ux, uy, uz, f, p0, p1, p2, p3): :func:`orbit_radial`, the true anomaly of the
    orbit's ``true_anomaly`` method and :func:`orbit_frame` at t, bit for bit each; a Kepler
    orbit's from one solve of Kepler's equation.

    f is NaN for a tabulated orbit: its osculating true anomaly is computed by its method in
    numpy, whose summation order (``einsum``) a kernel cannot promise to reproduce. The
    orbital-frame quaternion is the kernel's: the public ``frame_quaternion`` of a secular-J2
    or tabulated orbit also makes its signs continuous along an array (p and −p are the same
    rotation)."""
    kind = int(d[TYPE])
    if kind == TYPE_KEPLER:
        return _kepler_sample(d, t)
    if kind == TYPE_SECULAR_J2:
        return _j2_sample(d, t)
    if kind == TYPE_LIVE:
        x, y, z, vx, vy, vz = orbit_state(d, t)
        r, p0, p1, p2, p3 = frame_from_state(x, y, z, vx, vy, vz)
        return r, x / r, y / r, z / r, _NAN, p0, p1, p2, p3
    if kind == TYPE_REFERENCE:
        return _eph_sample(d[int(d[HDR]) :], t)
    return _eph_sample(d, t)


def sample_kernel(d) -> tuple[str, Any]:
    """(tag, kernel): the kernel :func:`orbit_sample` runs for the orbit ``d`` (its type's; an
    elliptic Kepler orbit's without the hyperbolic solver), as :func:`radial_kernel`."""
    kind = int(d[TYPE])
    if kind == TYPE_KEPLER:
        if d[K_EL + _k.ECC] < 1.0:
            return "kepler_elliptic", _ELLIPTIC._kepler_sample
        return "kepler", _kepler_sample
    if kind == TYPE_SECULAR_J2:
        return "j2", _j2_sample
    return "ephemeris", _eph_sample


# ---------------------------------------------------------------------------------------------
# Acceleration: d²r/dt² of each model (the rotation rate of local orbital frames needs it).
@jit
def _j2_acceleration(d, t):
    # r = R(t) r_p with the perifocal frame turning at W = Ω̇ ẑ + ω̇ ĥ (ĥ turns at Ω̇ ẑ) and the
    # in-plane Kepler motion run at n̄ = k n:  r̈ = −k² μ r/r³ + 2 W × ṙ − W × (W × r) + Ẇ × r,
    # Ẇ = ω̇ Ω̇ ẑ × ĥ  (the exact derivative of the velocity of _j2_state).
    x, y, z, vx, vy, vz = _j2_state(d, t)
    cO, sO, _, _ = _j2_angles(d, t)
    ci = d[J_COSI]
    si = d[J_SINI]
    k = d[J_RATIO]
    od = d[J_RAAN_DOT]
    wd = d[J_ARGP_DOT]
    hx, hy, hz = sO * si, -cO * si, ci
    Wx, Wy, Wz = wd * hx, wd * hy, od + wd * hz
    r2 = x * x + y * y + z * z
    g = -k * k * d[J_EL + _k.MU] / (r2 * math.sqrt(r2))
    # W × r and W × (W × r)
    cx, cy, cz = Wy * z - Wz * y, Wz * x - Wx * z, Wx * y - Wy * x
    ccx, ccy, ccz = Wy * cz - Wz * cy, Wz * cx - Wx * cz, Wx * cy - Wy * cx
    # Ẇ = ω̇ Ω̇ ẑ × ĥ = ω̇ Ω̇ (−hy, hx, 0)
    dx, dy = -wd * od * hy, wd * od * hx
    return (
        g * x + 2.0 * (Wy * vz - Wz * vy) - ccx + (dy * z),
        g * y + 2.0 * (Wz * vx - Wx * vz) - ccy + (-dx * z),
        g * z + 2.0 * (Wx * vy - Wy * vx) - ccz + (dx * y - dy * x),
    )


@jit
def hermite4_second(d, toff, roff, ncomp, n, h, t, c):
    """Second time derivative of component ``c`` of a Hermite table (layout of :func:`hermite4`).

    With x_j = t − t_j, g_j = 1 − 2 c_j x_j and the cubic Lagrange basis L_j (L_j'' = 2 w_j
    Σ_{k≠j} x_k): a_j'' = −8 c_j L_j L_j' + 2 g_j (L_j'² + L_j L_j''),
    b_j'' = 4 L_j L_j' + 2 x_j (L_j'² + L_j L_j''). Needs n >= 4.
    """
    i = table_interval(d, toff, n, h, t)
    stride = 2 * ncomp
    j0 = min(max(i - 1, 0), n - 4)
    acc = 0.0
    for j in range(4):
        tj = d[toff + j0 + j]
        w = 1.0
        cj = 0.0
        for k in range(4):
            if k != j:
                tk = d[toff + j0 + k]
                w /= tj - tk
                cj += 1.0 / (tj - tk)
        L = w
        Lp = 0.0
        s = 0.0
        for k in range(4):
            if k != j:
                xk = t - d[toff + j0 + k]
                L *= xk
                s += xk
                prod = w
                for m in range(4):
                    if m != j and m != k:
                        prod *= t - d[toff + j0 + m]
                Lp += prod
        Lpp = 2.0 * w * s
        x = t - tj
        g = 1.0 - 2.0 * cj * x
        q = Lp * Lp + L * Lpp
        row = roff + stride * (j0 + j)
        acc += (-8.0 * cj * L * Lp + 2.0 * g * q) * d[row + c]
        acc += (4.0 * L * Lp + 2.0 * x * q) * d[row + ncomp + c]
    return acc


@jit
def _eph_acceleration(d, t):
    if not _eph_in_range(d, t):
        return _NAN, _NAN, _NAN
    n = int(d[E_N])
    roff = E_TIMES + n
    if n < 4:  # the cubic/quintic polynomial of a tiny table: central difference of velocity
        dt = 1e-3 * (d[T_MAX] - d[T_MIN])
        _, _, _, ax, ay, az = _eph_state(d, min(t + dt, d[T_MAX]), True)
        _, _, _, bx, by, bz = _eph_state(d, max(t - dt, d[T_MIN]), True)
        span = min(t + dt, d[T_MAX]) - max(t - dt, d[T_MIN])
        return (ax - bx) / span, (ay - by) / span, (az - bz) / span
    h = d[E_H]
    return (
        hermite4_second(d, E_TIMES, roff, 3, n, h, t, 0),
        hermite4_second(d, E_TIMES, roff, 3, n, h, t, 1),
        hermite4_second(d, E_TIMES, roff, 3, n, h, t, 2),
    )


@jit
def orbit_acceleration(d, t):
    """(ax, ay, az) [km/s²]: the time derivative of the model's velocity at t.

    Kepler: −μ r/r³. Secular J2: the exact derivative of its velocity (in-plane Kepler motion at
    n̄ in a perifocal frame turning at Ω̇, ω̇). Hermite table: the second derivative of the
    degree-7 interpolant (consistent with the tabulated velocity, not a force model).
    """
    kind = int(d[TYPE])
    if kind == TYPE_KEPLER:
        x, y, z, _, _, _ = _kepler_state(d, t)
        r2 = x * x + y * y + z * z
        g = -d[MU] / (r2 * math.sqrt(r2))
        return g * x, g * y, g * z
    if kind == TYPE_SECULAR_J2:
        return _j2_acceleration(d, t)
    if kind == TYPE_LIVE:
        return d[L_ACC], d[L_ACC + 1], d[L_ACC + 2]
    if kind == TYPE_REFERENCE:
        return _eph_acceleration(d[int(d[HDR]) :], t)
    return _eph_acceleration(d, t)


# ---------------------------------------------------------------------------------------------
# Loops for the vectorised public API.
@jit
def state_loop(d, t, out):
    for i in range(t.size):
        s = orbit_state(d, t[i])
        for j in range(6):
            out[i, j] = s[j]


@jit
def radial_loop(d, t, out):
    for i in range(t.size):
        s = orbit_radial(d, t[i])
        for j in range(4):
            out[i, j] = s[j]


@jit
def frame_loop(d, t, out):
    for i in range(t.size):
        s = orbit_frame(d, t[i])
        for j in range(5):
            out[i, j] = s[j]


@jit
def acceleration_loop(d, t, out):
    for i in range(t.size):
        s = orbit_acceleration(d, t[i])
        for j in range(3):
            out[i, j] = s[j]


# The Kepler radial kernel of an elliptic orbit (radial_kernel): on orbit._kernels.ELLIPTIC.
_ELLIPTIC = specialise(
    sys.modules[__name__], "elliptic", names=("_kepler_radial", "_kepler_sample"), _k=_k.ELLIPTIC
)

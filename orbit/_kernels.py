"""Compiled scalar kernels of the two-body problem (plain floats in, tuples of floats out).

The orbit on its element array in compiled code: the mean and true anomaly at t, the radius,
the radial direction, the state and the orbital frame, and their copy for an ellipse.

Everything here is decorated with :func:`orbit._shared_jit.jit`: compiled lazily by numba, or plain
Python when JIT is disabled. No kernel allocates, so the attitude integrators call
:func:`radius_and_frame` / :func:`radius_and_radial_unit` inside every right-hand-side
evaluation. No argument checking happens here: the public functions in :mod:`orbit.kepler`
and :class:`orbit.KeplerOrbit` validate their input once, at the boundary.

Element-array layout
--------------------
An orbit is a float64 array ``el`` of length 9, indexed by the module constants::

    el[A]     a     semi-major axis (> 0 ellipse, < 0 hyperbola)     [km]
    el[ECC]   e     eccentricity (0 <= e < 1 or e > 1)
    el[INC]   inc   inclination                                      [rad]
    el[RAAN]  Ω     right ascension of the ascending node            [rad]
    el[ARGP]  ω     argument of periapsis                            [rad]
    el[M0]    M0    mean anomaly at t0                               [rad]
    el[T0]    t0    epoch of M0                                      [s]
    el[MU]    μ     gravitational parameter                          [km³/s²]
    el[N]     n     mean motion sqrt(μ/|a|³)                          [rad/s]

and M(t) = M0 + n (t − t0), with t in seconds since the same origin as t0.

Kepler's equation and the anomalies are solved in :mod:`orbit._kepler_equation`; its kernels
are imported here too (their module path of old: ``orbit._kernels.kepler_E``, ...).
"""

from __future__ import annotations

import math
import sys

# Kepler's equation and the anomalies, whose kernels were defined here: every one keeps its
# module path (orbit._kernels.kepler_E, ...).
from ._kepler_equation import (  # noqa: F401
    PI,
    TWO_PI_1,
    TWO_PI_2,
    TWO_PI_3,
    _continuous_E,
    _cosh_minus_one,
    _hyp_residual,
    _kepler_E_core,
    _kepler_E_reduced,
    _kepler_H_core,
    _kepler_residual,
    _one_minus_cos,
    _one_minus_cos_kepler,
    _pow_two_thirds,
    _sinh_minus_x,
    _two_prod,
    _two_sum,
    _x_minus_sin,
    _x_minus_sin_kepler,
    eccentric_from_true_loop,
    eccentric_from_true_scalar,
    hyperbolic_from_true_loop,
    hyperbolic_from_true_scalar,
    kepler_E,
    kepler_E_loop,
    kepler_H,
    kepler_H_iterations_loop,
    kepler_H_loop,
    mean_from_eccentric_loop,
    mean_from_eccentric_scalar,
    mean_from_hyperbolic_loop,
    mean_from_hyperbolic_scalar,
    mean_from_true_hyperbolic_loop,
    mean_from_true_loop,
    reduce_angle,
    true_from_eccentric_loop,
    true_from_eccentric_scalar,
    true_from_hyperbolic_loop,
    true_from_hyperbolic_scalar,
    true_from_mean_hyperbolic_loop,
    true_from_mean_loop,
)
from ._shared_jit import jit, specialise

__all__ = [
    "ARGP",
    "ECC",
    "ELLIPTIC",
    "ELLIPTIC_ONLY",
    "INC",
    "M0",
    "MU",
    "NEL",
    "RAAN",
    "T0",
    "A",
    "N",
    "eccentric_from_true_scalar",
    "hyperbolic_from_true_scalar",
    "kepler_E",
    "kepler_H",
    "mean_anomaly",
    "mean_from_eccentric_scalar",
    "mean_from_hyperbolic_scalar",
    "radius_and_frame",
    "radius_and_radial_unit",
    "state",
    "true_anomaly",
    "true_from_eccentric_scalar",
    "true_from_hyperbolic_scalar",
]


# Element-array layout (a contract with attitude._core.potentials).
A = 0
ECC = 1
INC = 2
RAAN = 3
ARGP = 4
M0 = 5
T0 = 6
MU = 7
N = 8
NEL = 9


#: False here; True in :data:`ELLIPTIC`, the copy of the kernels for elliptic orbits, whose
#: hyperbolic branches numba then prunes: the hyperbolic solver is not compiled for an ellipse.
ELLIPTIC_ONLY = False


# Orbit kernels on the element array.
@jit
def mean_anomaly(el, t):
    """M(t) = M0 + n (t − t0)."""
    return el[M0] + el[N] * (t - el[T0])


@jit
def _true_from_half_angles(M, Er, Mr, k, c, s):
    """True anomaly f from the reduced solution ``(Er, Mr, k)`` of :func:`_kepler_E_reduced`
    and its half-angle parts ``c``, ``s`` (:func:`_elliptic_half_angles`): f_r = 2 atan2(s, c)
    (c = sqrt(1 − e) cos(E_r/2) >= 0: no branch cut), continuous in M as
    :func:`true_from_eccentric_scalar` (f = E + (f_r − E_r)); the sine and cosine of E_r/2
    are the half-angle parts' (before, they were taken again of E reduced once more)."""
    fr = 2.0 * math.atan2(s, c)
    if k == 0.0:
        return fr
    return _continuous_E(M, Er, Mr, k) + (fr - Er)


@jit
def _elliptic_half_angles(e, Er, k):
    """(c, s, sign) of :func:`_half_angle_parts` from E reduced to ``Er`` = E − 2πk."""
    h = 0.5 * Er
    c = math.sqrt(1.0 - e) * math.cos(h)
    s = math.sqrt(1.0 + e) * math.sin(h)
    return c, s, 1.0 - 2.0 * (abs(k) % 2.0)


@jit
def _hyperbolic_half_angles(e, H):
    """(c, s, sign) of :func:`_half_angle_parts` from the hyperbolic anomaly H."""
    h = 0.5 * H
    return math.sqrt(e - 1.0) * math.cosh(h), math.sqrt(e + 1.0) * math.sinh(h), 1.0


@jit
def _half_angle_parts(el, t):
    """(c, s, sign): c ∝ cos(f/2), s ∝ sin(f/2), with c² + s² = r/|a|.

    Elliptic: c = sqrt(1 − e) cos(E/2), s = sqrt(1 + e) sin(E/2), E reduced to [−π, π] and
    sign = (−1)^k carrying the 2πk removed (so f/2 is continuous in t).
    Hyperbolic: c = sqrt(e − 1) cosh(H/2), s = sqrt(e + 1) sinh(H/2), sign = 1.
    """
    e = el[ECC]
    M = mean_anomaly(el, t)
    if ELLIPTIC_ONLY or e < 1.0:  # a constant True prunes the hyperbolic branch at compile time
        Er, _, k = _kepler_E_reduced(M, e)
        return _elliptic_half_angles(e, Er, k)
    return _hyperbolic_half_angles(e, kepler_H(M, e))


@jit
def half_angles_and_true_anomaly(el, t):
    """(c, s, sign, f): :func:`_half_angle_parts` and the true anomaly of
    :func:`true_anomaly_loop` at time t, from one solve of Kepler's equation (bit for bit
    both)."""
    e = el[ECC]
    M = mean_anomaly(el, t)
    if ELLIPTIC_ONLY or e < 1.0:
        Er, Mr, k = _kepler_E_reduced(M, e)
        c, s, sign = _elliptic_half_angles(e, Er, k)
        return c, s, sign, _true_from_half_angles(M, Er, Mr, k, c, s)
    H = kepler_H(M, e)
    c, s, sign = _hyperbolic_half_angles(e, H)
    return c, s, sign, true_from_hyperbolic_scalar(H, e)


@jit
def radius_cos_sin_f(el, c, s):
    """(r, cos f, sin f) from the half-angle parts c, s of :func:`_half_angle_parts`."""
    n2 = c * c + s * s
    return abs(el[A]) * n2, (c - s) * (c + s) / n2, 2.0 * c * s / n2


@jit
def _radius_cos_sin_f(el, t):
    """(r, cos f, sin f) at time t."""
    c, s, _ = _half_angle_parts(el, t)
    return radius_cos_sin_f(el, c, s)


@jit
def radius_and_radial_unit(el, t):
    """(r, x, y, z): radius [km] and radial unit vector r/|r| in the space frame at time t."""
    r, cf, sf = _radius_cos_sin_f(el, t)
    cw = math.cos(el[ARGP])
    sw = math.sin(el[ARGP])
    cu = cw * cf - sw * sf  # u = ω + f, argument of latitude
    su = sw * cf + cw * sf
    cO = math.cos(el[RAAN])
    sO = math.sin(el[RAAN])
    ci = math.cos(el[INC])
    si = math.sin(el[INC])
    # r̂ = cos u N̂ + sin u M̂, N̂ = (cos Ω, sin Ω, 0), M̂ = (−sin Ω cos i, cos Ω cos i, sin i)
    return r, cO * cu - sO * ci * su, sO * cu + cO * ci * su, si * su


@jit
def _perifocal(el, t):
    """(r, x, y, vx, vy): position [km] and velocity [km/s] in the perifocal frame (x towards
    periapsis, y along the semi-latus rectum), all from half-angle products without
    cancellation (velocity accurate at apoapsis as e -> 1, position at periapsis).

    Elliptic:   r (cos f, sin f) = a (cos E − e, sqrt(1 − e²) sin E),
                v = sqrt(μ a)/r (−sin E, sqrt(1 − e²) cos E);
    hyperbolic: r (cos f, sin f) = |a| (e − cosh H, sqrt(e² − 1) sinh H),
                v = sqrt(μ |a|)/r (−sinh H, sqrt(e² − 1) cosh H).
    """
    e = el[ECC]
    aa = abs(el[A])
    M = mean_anomaly(el, t)
    if ELLIPTIC_ONLY or e < 1.0:
        Er, _, _ = _kepler_E_reduced(M, e)
        ch = math.cos(0.5 * Er)
        sh = math.sin(0.5 * Er)
        c = math.sqrt(1.0 - e) * ch
        s = math.sqrt(1.0 + e) * sh
        r = aa * (c * c + s * s)
        kv = math.sqrt(el[MU] * aa) / r
        return (
            r,
            aa * (c - s) * (c + s),
            2.0 * aa * c * s,
            -kv * 2.0 * sh * ch,
            kv * math.sqrt((1.0 - e) * (1.0 + e)) * (ch - sh) * (ch + sh),
        )
    H = kepler_H(M, e)
    ch = math.cosh(0.5 * H)
    sh = math.sinh(0.5 * H)
    c = math.sqrt(e - 1.0) * ch
    s = math.sqrt(e + 1.0) * sh
    r = aa * (c * c + s * s)
    kv = math.sqrt(el[MU] * aa) / r
    return (
        r,
        aa * (c - s) * (c + s),
        2.0 * aa * c * s,
        -kv * 2.0 * sh * ch,
        kv * math.sqrt((e - 1.0) * (e + 1.0)) * (ch * ch + sh * sh),
    )


@jit
def rotate_perifocal(xp, yp, vxp, vyp, cO, sO, ci, si, cw, sw):
    """Perifocal (x, y, vx, vy) to space-frame position and velocity, from the trig of Ω, i, ω."""
    # N̂ = (cos Ω, sin Ω, 0) (node line), M̂ = ĥ × N̂ = (−sin Ω cos i, cos Ω cos i, sin i);
    # periapsis P̂ = cos ω N̂ + sin ω M̂, Q̂ = −sin ω N̂ + cos ω M̂.
    mx, my, mz = -sO * ci, cO * ci, si
    px, py, pz = cw * cO + sw * mx, cw * sO + sw * my, sw * mz
    qx, qy, qz = -sw * cO + cw * mx, -sw * sO + cw * my, cw * mz
    return (
        xp * px + yp * qx,
        xp * py + yp * qy,
        xp * pz + yp * qz,
        vxp * px + vyp * qx,
        vxp * py + vyp * qy,
        vxp * pz + vyp * qz,
    )


@jit
def state(el, t):
    """(x, y, z, vx, vy, vz): position [km] and velocity [km/s] in the space frame at time t."""
    _, xp, yp, vxp, vyp = _perifocal(el, t)
    return rotate_perifocal(
        xp,
        yp,
        vxp,
        vyp,
        math.cos(el[RAAN]),
        math.sin(el[RAAN]),
        math.cos(el[INC]),
        math.sin(el[INC]),
        math.cos(el[ARGP]),
        math.sin(el[ARGP]),
    )


@jit
def radius_and_frame(el, t):
    """(r, p0, p1, p2, p3): radius [km] and orbital-frame quaternion p(t), scalar first.

    Arribas, Elipe & Palacios (2006) Sect. 6.2 (the 3-1-3 form of their eq. 12 with
    (φ, ϑ, ψ) = (Ω, i, u), u = ω + f)::

        p0 = cos(i/2) cos((Ω + u)/2)    p1 = sin(i/2) cos((Ω − u)/2)
        p2 = sin(i/2) sin((Ω − u)/2)    p3 = cos(i/2) sin((Ω + u)/2)

    p∘s1∘p̃ is the radial direction and p∘s3∘p̃ the orbit normal. f/2 is carried continuously
    through successive revolutions, so p(t) is continuous in t (it changes sign every orbit).
    """
    c, s, sign = _half_angle_parts(el, t)
    n2 = c * c + s * s
    nrm = sign / math.sqrt(n2)
    ch = c * nrm  # cos(f/2)
    sh = s * nrm  # sin(f/2)
    ci = math.cos(0.5 * el[INC])
    si = math.sin(0.5 * el[INC])
    hp = 0.5 * (el[RAAN] + el[ARGP])
    hm = 0.5 * (el[RAAN] - el[ARGP])
    cA = math.cos(hp)
    sA = math.sin(hp)
    cB = math.cos(hm)
    sB = math.sin(hm)
    # (Ω + u)/2 = (Ω + ω)/2 + f/2 ; (Ω − u)/2 = (Ω − ω)/2 − f/2
    return (
        abs(el[A]) * n2,
        ci * (cA * ch - sA * sh),
        si * (cB * ch + sB * sh),
        si * (sB * ch - cB * sh),
        ci * (sA * ch + cA * sh),
    )


@jit
def eccentric_anomaly_loop(el, t, out):
    e = el[ECC]
    for i in range(t.size):
        M = mean_anomaly(el, t[i])
        out[i] = kepler_E(M, e) if ELLIPTIC_ONLY or e < 1.0 else kepler_H(M, e)


@jit
def true_anomaly(el, t):
    """True anomaly f(t) [rad], continuous in t."""
    e = el[ECC]
    M = mean_anomaly(el, t)
    if ELLIPTIC_ONLY or e < 1.0:
        Er, Mr, k = _kepler_E_reduced(M, e)
        c, s, _ = _elliptic_half_angles(e, Er, k)
        return _true_from_half_angles(M, Er, Mr, k, c, s)
    return true_from_hyperbolic_scalar(kepler_H(M, e), e)


@jit
def true_anomaly_loop(el, t, out):
    for i in range(t.size):
        out[i] = true_anomaly(el, t[i])


@jit
def state_loop(el, t, out):
    for i in range(t.size):
        s = state(el, t[i])
        for j in range(6):
            out[i, j] = s[j]


@jit
def radial_loop(el, t, out):
    for i in range(t.size):
        s = radius_and_radial_unit(el, t[i])
        for j in range(4):
            out[i, j] = s[j]


@jit
def frame_loop(el, t, out):
    for i in range(t.size):
        s = radius_and_frame(el, t[i])
        for j in range(5):
            out[i, j] = s[j]


#: The kernels of an elliptic orbit (e < 1): copies of those that branch on e, with
#: ``ELLIPTIC_ONLY`` True (a KeplerOrbit with e < 1 runs its loops on them, and the gravity
#: gradient's radial kernel, orbit._state_kernels.radial_kernel, its orbit on them).
ELLIPTIC = specialise(
    sys.modules[__name__],
    "elliptic",
    names=(
        "_half_angle_parts",
        "half_angles_and_true_anomaly",
        "true_anomaly",
        "_radius_cos_sin_f",
        "radius_and_radial_unit",
        "_perifocal",
        "state",
        "radius_and_frame",
        "eccentric_anomaly_loop",
        "true_anomaly_loop",
        "state_loop",
        "radial_loop",
        "frame_loop",
    ),
    ELLIPTIC_ONLY=True,
)

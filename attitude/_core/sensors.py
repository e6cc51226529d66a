"""Compiled sensor models: gyro, star tracker, magnetometer, coarse Sun sensor.

Each sensor is a record of the sensor program ``sn`` (its parameters) and of the sensor state
``ss`` (its random stream, :mod:`attitude._core.rng`, and its memory: the gyro's drift). At
each tick of the flight software :func:`measure_sensors` fills the measurement vector from
the true state: the models below, their noise drawn from each sensor's own stream (so a run is
reproducible bit for bit from the seeds, and adding a sensor does not change another's noise).

Gyro (Farrenkopf, "Analytic steady-state accuracy solutions for two common spacecraft attitude
estimators", J. Guidance 1, 1978; discretised exactly for the tick interval Δt as in Markley &
Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*, 2014, eqs.
6.93–6.94): the rate ω̃ = C ω + b₀ + β + η_v with the drift β̇ = η_u,

    β_{k+1} = β_k + σ_u √Δt N_u,
    ω̃_{k+1} = C ω̄_{k+1} + b₀ + ½ (β_{k+1} + β_k) + (σ_v²/Δt + σ_u² Δt/12)^{1/2} N_v

(σ_v the angle random walk, rad/√s; σ_u the rate random walk, rad/s^{3/2}; ω̄ the mean true
rate over the interval, from the rates at its ends): the averaged rate of an integrating
gyro, whose Allan variance is σ_v²/τ + σ_u² τ/3 at every τ = m Δt. C = (1 + S) M: scale
factors S (diagonal) and misalignment M; then quantisation and saturation.

Star tracker: q̃ = q∘δq, δq = exp(δθ/2) with δθ = C_bsᵀ (σ_c N₁, σ_c N₂, σ_b N₃) (cross- and
about-boresight noise in the sensor frame, z along the boresight), at its own update rate,
flagged invalid while the Sun or the Earth's limb is within its exclusion angles.

Magnetometer: B̃ = B_B + b + σ N (IGRF field in body axes). Coarse Sun sensor: heads with
normals n_i give I_i = ν max(0, n_i·ŝ) + σ N (ν the unshadowed fraction of the Sun, Montenbruck
& Gill 2000; dark in eclipse); the Sun direction is their least-squares solution over the
heads with I_i > 3σ, valid with three independent heads lit.
"""

from __future__ import annotations

import math

from orbit._layout import Field, layout
from orbit._shared_jit import inline_copy, jit
from orbit._state_kernels import orbit_state
from orbit.sun import R_EARTH, R_SUN, conical_shadow

from .quat import half_angle, mul, rotate, rotate_inverse, shorter
from .rng import RNG_SIZE, load, normal, normal_held, store

# --- program header ----------------------------------------------------------------------------
SN = layout(
    "sensor program header",
    gyro=Field(1, "", "offset of the gyro record (0: none)"),
    st=Field(1, "", "offset of the star tracker record (0: none)"),
    mag=Field(1, "", "offset of the magnetometer record (0: none)"),
    sun=Field(1, "", "offset of the Sun sensor record (0: none)"),
    orbit=Field(1, "", "offset of the orbit's kernel data (0: none)"),
    suntab=Field(1, "", "offset of the Sun's table (0: none)"),
    field=Field(1, "", "offset of a field block (MagneticDipole layout; 0: the spacecraft's)"),
    size=8,
)

GYRO = layout(
    "gyro record",
    sv=Field(1, "rad/s^0.5", "σ_v, angle random walk"),
    su=Field(1, "rad/s^1.5", "σ_u, rate random walk"),
    b0=Field(3, "rad/s", "constant bias"),
    c=Field(9, "", "sensor matrix C", (3, 3)),
    quant=Field(1, "rad/s", "quantisation step (0: none)"),
    sat=Field(1, "rad/s", "saturation (inf: none)"),
    # its state in ss: stream, β (3), the true rate at the last tick (3), a flag saying it is set
    state=Field(1, "", "offset of its state in ss"),
    sd=Field(1, "rad/s", "σ of the rate noise over a tick, (σ_v²/Δt + σ_u² Δt/12)^½"),
    sq=Field(1, "rad/s", "σ of the drift's step over a tick, σ_u √Δt"),
    identity=Field(1, "", "1: C is the identity (C ω̄ not computed)"),
)


def gyro_tick_sigmas(sv: float, su: float, dt: float) -> tuple[float, float]:
    """(σ of the rate noise, σ of the drift's step) over a tick ``dt`` (eqs. 6.93–6.94 of
    Markley & Crassidis), computed once when the sensor program is built."""
    return math.sqrt(sv * sv / dt + su * su * dt / 12.0), su * math.sqrt(dt)


ST = layout(
    "star tracker record",
    sc=Field(1, "rad", "σ cross-boresight"),
    sb=Field(1, "rad", "σ about the boresight"),
    cbs=Field(9, "", "rows of the sensor frame in body axes (x, y, z = boresight)", (3, 3)),
    every=Field(1, "", "update every k-th tick"),
    sun_excl=Field(1, "rad", "Sun exclusion half-angle (0: none)"),
    earth_excl=Field(1, "rad", "Earth-limb exclusion angle (< 0: none)"),
    state=Field(1, "", "offset of its state in ss: stream"),
)

MAG = layout(
    "magnetometer record",
    sigma=Field(1, "T", "σ"),
    bias=Field(3, "T"),
    state=Field(1, "", "offset of its stream in ss"),
)

SUNS = layout(
    "Sun sensor record",
    nheads=1,
    sigma=Field(1, "", "σ of each head's current (fraction of the full-Sun current)"),
    state=Field(1, "", "offset of its stream"),
    normals=Field(0, "", "n normals (3 each)"),
)

# --- the measurement vector (written at each tick) -----------------------------------------------
Z = layout(
    "sensor measurements",
    omega=Field(3, "rad/s", "gyro rate"),
    gyro_ok=1,
    q=Field(4, "", "star tracker quaternion"),
    st_ok=Field(1, "", "1: a new valid measurement at this tick"),
    st_flag=Field(1, "", "0 valid, 1 no update this tick, 2 Sun, 3 Earth in exclusion"),
    b=Field(3, "T", "magnetometer"),
    mag_ok=1,
    sun=Field(3, "", "Sun direction estimate"),
    sun_ok=1,
    eclipse=Field(1, "", "fraction of the Sun visible"),
)


@jit(inline="always")
def _mv3(a, o, v0, v1, v2):
    return (
        a[o] * v0 + a[o + 1] * v1 + a[o + 2] * v2,
        a[o + 3] * v0 + a[o + 4] * v1 + a[o + 5] * v2,
        a[o + 6] * v0 + a[o + 7] * v1 + a[o + 8] * v2,
    )


@jit
def gyro_measure(sn, g, ss, om, z):
    """The gyro's rate at this tick into z[Z.OMEGA:]: the mean rate over the last interval
    (trapezoidal from the true rates at its ends), its drift advanced over the tick (the
    noise deviations of the tick in the record: :func:`gyro_tick_sigmas`)."""
    so = int(sn[g + GYRO.STATE])
    b = so + RNG_SIZE
    w_prev = b + 3
    sd = sn[g + GYRO.SD]
    sq = sn[g + GYRO.SQ]
    # the interval's mean rate (an integrating gyro), from the true rate at both ends
    if ss[w_prev + 3] == 0.0:
        a0, a1, a2 = om[0], om[1], om[2]
    else:
        a0 = 0.5 * (ss[w_prev] + om[0])
        a1 = 0.5 * (ss[w_prev + 1] + om[1])
        a2 = 0.5 * (ss[w_prev + 2] + om[2])
    ss[w_prev] = om[0]
    ss[w_prev + 1] = om[1]
    ss[w_prev + 2] = om[2]
    ss[w_prev + 3] = 1.0
    c = (a0, a1, a2) if sn[g + GYRO.IDENTITY] != 0.0 else _mv3(sn, g + GYRO.C, a0, a1, a2)
    quant = sn[g + GYRO.QUANT]
    sat = sn[g + GYRO.SAT]
    r0, r1, r2, r3 = load(ss, so)  # the six deviates drawn in registers
    for i in range(3):
        b_old = ss[b + i]
        nu, r0, r1, r2, r3 = normal_held(ss, so, r0, r1, r2, r3)
        nv, r0, r1, r2, r3 = normal_held(ss, so, r0, r1, r2, r3)
        b_new = b_old + sq * nu
        ss[b + i] = b_new
        w = c[i] + sn[g + GYRO.B0 + i] + 0.5 * (b_old + b_new) + sd * nv
        if quant > 0.0:
            w = quant * math.floor(w / quant + 0.5)
        if w > sat:
            w = sat
        elif w < -sat:
            w = -sat
        z[Z.OMEGA + i] = w
    store(ss, so, r0, r1, r2, r3)
    z[Z.GYRO_OK] = 1.0


@jit
def sun_and_earth(sn, t):
    """(satellite position (3), unit Sun direction (3), ν) in space axes, from the orbit and
    the Sun's table of the program (ν = 1 and zero vectors when absent)."""
    oo = int(sn[SN.ORBIT])
    so = int(sn[SN.SUNTAB])
    r = (0.0, 0.0, 0.0)
    s = (0.0, 0.0, 0.0)
    nu = 1.0
    if oo > 0:
        st = orbit_state(sn[oo:], t)
        r = (st[0], st[1], st[2])
        if so > 0:
            su = orbit_state(sn[so:], t)
            dx = su[0] - r[0]
            dy = su[1] - r[1]
            dz = su[2] - r[2]
            n = math.sqrt(dx * dx + dy * dy + dz * dz)
            s = (dx / n, dy / n, dz / n)
            nu = conical_shadow(r[0], r[1], r[2], su[0], su[1], su[2], R_EARTH, R_SUN)[0]
    return r, s, nu


@jit
def star_tracker_measure(sn, o, ss, q, r, s, nu, z):
    """The star tracker's quaternion at an update tick (and its validity) into z (the noise
    is drawn at every update, valid or not: the stream does not depend on the geometry)."""
    so = int(sn[o + ST.STATE])
    r0, r1, r2, r3 = load(ss, so)
    x0, r0, r1, r2, r3 = normal_held(ss, so, r0, r1, r2, r3)
    x1, r0, r1, r2, r3 = normal_held(ss, so, r0, r1, r2, r3)
    x2, r0, r1, r2, r3 = normal_held(ss, so, r0, r1, r2, r3)
    store(ss, so, r0, r1, r2, r3)
    n0 = sn[o + ST.SC] * x0
    n1 = sn[o + ST.SC] * x1
    n2 = sn[o + ST.SB] * x2
    c = ST.CBS
    # δθ in body axes = C_bsᵀ (n0, n1, n2): the rows of C_bs are the sensor axes
    d0 = sn[o + c] * n0 + sn[o + c + 3] * n1 + sn[o + c + 6] * n2
    d1 = sn[o + c + 1] * n0 + sn[o + c + 4] * n1 + sn[o + c + 7] * n2
    d2 = sn[o + c + 2] * n0 + sn[o + c + 5] * n1 + sn[o + c + 8] * n2
    # δq = (cos(a/2), sin(a/2)/a δθ), a = |δθ| (the rotation by δθ over a unit time)
    k, ch = half_angle(d0 * d0 + d1 * d1 + d2 * d2, 1.0)
    dq = (ch, k * d0, k * d1, k * d2)
    qm = shorter(mul(q, dq))
    for i in range(4):
        z[Z.Q + i] = qm[i]
    flag = 0.0
    ex = sn[o + ST.SUN_EXCL]
    ee = sn[o + ST.EARTH_EXCL]
    if ex > 0.0 or ee >= 0.0:  # exclusion angles (else no geometry)
        bs = rotate(q, (sn[o + c + 6], sn[o + c + 7], sn[o + c + 8]))  # boresight in space
        if ex > 0.0 and nu > 0.0 and (s[0] != 0.0 or s[1] != 0.0 or s[2] != 0.0):
            cs = bs[0] * s[0] + bs[1] * s[1] + bs[2] * s[2]
            if cs > math.cos(ex):
                flag = 2.0
        rn = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
        if flag == 0.0 and ee >= 0.0 and rn > 0.0:
            # the angle from the boresight to the Earth's centre, minus the Earth's half-angle
            ce = -(bs[0] * r[0] + bs[1] * r[1] + bs[2] * r[2]) / rn
            ang = math.acos(min(1.0, max(-1.0, ce)))
            if ang - math.asin(min(1.0, R_EARTH / rn)) < ee:
                flag = 3.0
    z[Z.ST_FLAG] = flag
    z[Z.ST_OK] = 1.0 if flag == 0.0 else 0.0


@jit
def magnetometer_measure(sn, o, ss, bb, z):
    """The magnetometer's field (T, body axes) into z."""
    so = int(sn[o + MAG.STATE])
    sg = sn[o + MAG.SIGMA]
    for i in range(3):
        z[Z.B + i] = bb[i] + sn[o + MAG.BIAS + i] + sg * normal(ss, so)
    z[Z.MAG_OK] = 1.0 if (bb[0] == bb[0]) else 0.0


@jit
def _css_fit(sn, o, cur, n, thr, check, d0, d1, d2):
    """Least squares Σ n nᵀ x = Σ n I over the heads whose current is above ``thr`` (and, with
    ``check``, that face the direction d: n·d > 0). Returns (heads used, x, solvable)."""
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    r0 = r1 = r2 = 0.0
    used = 0
    for i in range(n):
        b = o + SUNS.NORMALS + 3 * i
        c = cur[i]
        n0, n1, n2 = sn[b], sn[b + 1], sn[b + 2]
        if not (c > thr and c > 0.0):
            continue
        if check and n0 * d0 + n1 * d1 + n2 * d2 <= 0.0:
            continue
        used += 1
        a00 += n0 * n0
        a01 += n0 * n1
        a02 += n0 * n2
        a11 += n1 * n1
        a12 += n1 * n2
        a22 += n2 * n2
        r0 += n0 * c
        r1 += n1 * c
        r2 += n2 * c
    det = (
        a00 * (a11 * a22 - a12 * a12)
        - a01 * (a01 * a22 - a12 * a02)
        + a02 * (a01 * a12 - a11 * a02)
    )
    if used < 3 or not abs(det) > 1e-9:
        return used, 0.0, 0.0, 0.0, False
    x0 = (
        r0 * (a11 * a22 - a12 * a12) - a01 * (r1 * a22 - a12 * r2) + a02 * (r1 * a12 - a11 * r2)
    ) / det
    x1 = (
        a00 * (r1 * a22 - a12 * r2) - r0 * (a01 * a22 - a12 * a02) + a02 * (a01 * r2 - r1 * a02)
    ) / det
    x2 = (
        a00 * (a11 * r2 - r1 * a12) - a01 * (a01 * r2 - r1 * a02) + r0 * (a01 * a12 - a11 * a02)
    ) / det
    return used, x0, x1, x2, True


@jit
def sun_sensor_measure(sn, o, ss, q, s, nu, z, scratch):
    """The coarse Sun sensor's heads (cosine law, dark in eclipse) and the Sun direction from
    them into z; ``scratch`` holds the currents. The direction: least squares over the heads
    above 3σ, then again without any of them that faces away from that first solution (a dark
    head whose noise reads above 3σ, 0.13 % of its draws: it would pull the solution's
    component along its normal to half; the cosine law gives it no current from a Sun behind
    it); invalid with fewer than three heads left."""
    n = int(sn[o + SUNS.NHEADS])
    so = int(sn[o + SUNS.STATE])
    sg = sn[o + SUNS.SIGMA]
    sb = rotate_inverse(q, s)
    for i in range(n):
        b = o + SUNS.NORMALS + 3 * i
        c = sn[b] * sb[0] + sn[b + 1] * sb[1] + sn[b + 2] * sb[2]
        scratch[i] = nu * max(0.0, c) + sg * normal(ss, so)
    z[Z.ECLIPSE] = nu
    thr = 3.0 * sg
    used, x0, x1, x2, ok = _css_fit(sn, o, scratch, n, thr, False, 0.0, 0.0, 0.0)
    if ok:
        used2, y0, y1, y2, ok = _css_fit(sn, o, scratch, n, thr, True, x0, x1, x2)
        if used2 < used:  # a head facing away from the first solution: solved without it
            x0, x1, x2 = y0, y1, y2
    if ok:
        m = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        if m > 0.0:
            z[Z.SUN] = x0 / m
            z[Z.SUN + 1] = x1 / m
            z[Z.SUN + 2] = x2 / m
            z[Z.SUN_OK] = 1.0
            return
    z[Z.SUN] = math.nan
    z[Z.SUN + 1] = math.nan
    z[Z.SUN + 2] = math.nan
    z[Z.SUN_OK] = 0.0


@jit
def measure_sensors(sn, ss, t, tick, q, om, bb, z, scratch, keep):
    """All the sensors of the program at tick ``tick`` (time t) from the true attitude q, rate
    ω and body field bb, into the measurement vector z (the star tracker's model only at its
    update ticks)."""
    for i in range(Z.SIZE):
        z[i] = 0.0
    g = int(sn[SN.GYRO])
    if g > 0:
        gyro_measure(sn, g, ss, om, z)
    ot = int(sn[SN.ST])
    os_ = int(sn[SN.SUN])
    st_update = ot > 0 and tick % int(sn[ot + ST.EVERY]) == 0
    # the Sun and the Earth only for a model that looks at them (a star tracker's exclusion
    # angles at its update, a Sun sensor) or for the record's eclipse fraction (``keep``: a
    # recorded tick), not at every tick
    r = s = (0.0, 0.0, 0.0)
    nu = 1.0
    excl = st_update and (sn[ot + ST.SUN_EXCL] > 0.0 or sn[ot + ST.EARTH_EXCL] >= 0.0)
    if excl or os_ > 0 or keep:
        r, s, nu = sun_and_earth(sn, t)
    if st_update:
        star_tracker_measure(sn, ot, ss, q, r, s, nu, z)
    elif ot > 0:
        z[Z.ST_OK] = 0.0
        z[Z.ST_FLAG] = 1.0
    o = int(sn[SN.MAG])
    if o > 0:
        magnetometer_measure(sn, o, ss, bb, z)
    if os_ > 0:
        sun_sensor_measure(sn, os_, ss, q, s, nu, z, scratch)
    else:
        z[Z.ECLIPSE] = nu


# the copy the tick's sensing inlines (fsw.sense_and_estimate), with the gyro's measurement
_gyro_measure_inline = inline_copy(gyro_measure, globals())
measure_sensors_inline = inline_copy(
    measure_sensors, globals(), gyro_measure="_gyro_measure_inline"
)

"""Compiled flight software: guidance, control laws, allocation and modes at a task rate.

The flight software of :class:`attitude.FlightSoftware` runs at ticks t_k = t₀ + k·period
inside the integrator's loop (:mod:`attitude._core.holds`): at each tick :func:`fsw_tick`
reads the measurements (the true state, or the sensors and estimator of
:mod:`attitude._core.sensors`), evaluates the active mode's guidance (a reference frame of
:mod:`attitude._core.frames`, or an eigen-axis slew onto one), its control law and allocation,
and returns actuator commands; :func:`fsw_boundary` holds them until the next tick (zero-order
hold; ``delay`` whole ticks later if the software has a latency).

Everything is data, as the torque models are: the program ``fw`` (float64: header, modes,
frames, allocation matrices) and the state ``fs`` (the laws' memory: integral term, previous
field, slew start, mode, delayed commands). Layouts: :mod:`attitude._core.fsw_layout`.

Control laws (body-axis torque request L_r or dipole request):

* MRP feedback — Basilisk's ``mrpFeedback`` (Schaub & Junkins, *Analytical Mechanics of Space
  Systems*, 4th ed., Sect. 8.4): L_r = −[K σ + P δω + P K_I z − (ω_r + K_I z) × (I ω + Σ h_s a)
  + I (ω × ω_r − ω̇_r)], with z = ∫K σ dt + I δω (integral term only when K_I > 0, each
  component limited);
* quaternion feedback (Wie, *Space Vehicle Dynamics and Control*, 2nd ed., Sect. 7.3):
  L_r = −K q_e − C δω + ω × (I ω + Σ h_s a) − I (ω × ω_r − ω̇_r);
* rate damping: L_r = −K_d δω;
* B-dot (Stickler & Alfriend 1976): m = −k Ḃ_B, or normalized m = −(k/|B|) ḃ (Avanzini &
  Giulietti 2012), Ḃ_B from the measured field at this tick and the last;
* momentum dumping with magnetorquers (the cross-product law, Camillo & Markley 1980):
  m = k ((h_w − h_ref) × B) / |B|², whose torque m × B = −k (h_w − h_ref)⊥B unloads the
  wheels, beside a wheel law.

Allocation: wheel motor torques u = −G⁺ L_r (G = [a_1 ... a_n], the minimum-norm
pseudo-inverse, Basilisk's ``rwMotorTorque``) plus a null-space term −k N J (Ω − Ω_ref)
(N = 1 − G⁺G) that manages the wheel speeds without a body torque; a torque request on
magnetorquers alone, m = B × L_r / |B|²; dipoles to rods through the pseudo-inverse of their
axes; without actuators the request is an ideal body torque.
"""

from __future__ import annotations

import math

from orbit._shared_jit import inline_copy, jit

from .actuators import (
    SC,
    WHEEL,
    configure_hold,
    configure_hold_rate,
    next_thruster_off,
    state_rate,
    thrusters_off_at,
    wheel_momentum_sum,
    wheel_speed,
)
from .coupled import coupled_software
from .environment import field_body
from .frames import (
    FRAME,
    FRAME_INERTIAL,
    frame_eval,
    inertial_frame,
)
from .fsw_laws import CODES, control_law
from .fsw_layout import ES, FS, FW, MB, RS, R
from .holds import (
    BOUNDARY_DONE,
    BOUNDARY_NEEDS_COMMANDS,
    HS,
    RECORDS_FULL,
)
from .mekf import (
    EP,
    E,
    estimation_error,
    mekf_covariance_at,
    mekf_init,
    mekf_propagate_inline,
    mekf_update_quaternion,
    mekf_update_vector,
)
from .quat import conj_mul, cross, mrp, mul, rotate, rotate_inverse, shorter
from .rng import RNG_SIZE
from .sensors import (
    GYRO,
    SN,
    Z,
    measure_sensors_inline,
    sun_and_earth,
)

COND_ALWAYS = 0
COND_RATE_BELOW = 1
COND_RATE_ABOVE = 2
COND_POINTING_WITHIN = 3
COND_POINTING_BEYOND = 4
COND_AFTER = 5

GUID_NONE = 0  # no reference: the inertial identity with zero rate
GUID_FRAME = 1
GUID_SLEW = 2

CTRL_NONE = 0  # no law; the others are the registry's (attitude._core.fsw_laws.LAWS)
CTRL_MRP = CODES["mrp_feedback"]
CTRL_QUATERNION = CODES["quaternion_feedback"]
CTRL_RATE_DAMPING = CODES["rate_damping"]
CTRL_BDOT = CODES["bdot"]


#: Finite-difference half-step for ω̇ of a frame (s): the frames give q_R and ω_R exactly.
DOMEGA_STEP = 0.5


def record_width(n_cmd: int, sensors: bool = False) -> int:
    """Columns of a tick record."""
    return R.SIZE + 2 * n_cmd + ((Z.SIZE + RS.SIZE) if sensors else 0)


def state_size(delay: int, n_cmd: int) -> int:
    """Length of the software state ``fs`` before the sensors' and the filter's."""
    return FS.SIZE + max(delay, 0) * n_cmd


@jit
def frame_reference(d, t):
    """(q_R, ω_R, ω̇_R) of frame data ``d`` at t, rates in reference axes; ω̇_R by a central
    difference of the exact ω_R (components in the rotating axes: the inertial derivative),
    one-sided at the ends of a tabulated orbit."""
    r = frame_eval(d, t)
    q = (r[0], r[1], r[2], r[3])
    w = (r[4], r[5], r[6])
    if int(d[FRAME.TYPE]) == FRAME_INERTIAL:  # fixed (an offset of a fixed frame is fixed)
        return q, w, (0.0, 0.0, 0.0)
    h = DOMEGA_STEP
    a = frame_eval(d, t + h)
    b = frame_eval(d, t - h)
    if a[4] != a[4]:  # past the end of a tabulated orbit: the backward difference
        a = r
        s = h
    elif b[4] != b[4]:  # before its start: the forward difference
        b = r
        s = h
    else:
        s = 2.0 * h
    dw = ((a[4] - b[4]) / s, (a[5] - b[5]) / s, (a[6] - b[6]) / s)
    return q, w, dw


@jit
def slew_profile(theta0, t, wmax, amax):
    """(θ, θ̇, θ̈) of a rest-to-rest eigen-axis slew of angle θ0 >= 0 started at t = 0 with
    rate and acceleration limits (trapezoidal rate; triangular when θ0 is small): θ goes from
    θ0 to 0."""
    if theta0 <= 0.0:
        return 0.0, 0.0, 0.0
    t1 = wmax / amax
    if amax * t1 * t1 >= theta0:  # triangular
        t1 = math.sqrt(theta0 / amax)
        tc = 0.0
        wpk = amax * t1
    else:
        wpk = wmax
        tc = (theta0 - amax * t1 * t1) / wmax
    if t <= 0.0:
        return theta0, 0.0, 0.0
    if t < t1:
        return theta0 - 0.5 * amax * t * t, -amax * t, -amax
    if t < t1 + tc:
        return theta0 - 0.5 * amax * t1 * t1 - wpk * (t - t1), -wpk, 0.0
    te = 2 * t1 + tc
    if t < te:
        r = te - t
        return 0.5 * amax * r * r, -amax * r, amax
    return 0.0, 0.0, 0.0


@jit
def guidance(fw, fs, mb, t, q_meas):
    """(q_R, ω_R, ω̇_R) of the active mode's guidance at t (rates in reference axes)."""
    kind = int(fw[mb + MB.GUID])
    if kind == GUID_NONE:
        return (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    o = int(fw[mb + MB.GUID_FRAME])
    if int(fw[o + FRAME.TYPE]) == FRAME_INERTIAL:  # no calls a tick for the fixed frame
        qB, wB = inertial_frame(fw[o:])
        dwB = (0.0, 0.0, 0.0)
    else:
        qB, wB, dwB = frame_reference(fw[o:], t)
    if kind == GUID_FRAME:
        return qB, wB, dwB
    # slew: q_R = q_B∘exp(θ e/2), e fixed in the target's axes (from the attitude at entry)
    if fs[FS.ENTERED] == 0.0:
        off = shorter(conj_mul(qB, q_meas))  # rotation from the target to the spacecraft
        sv = math.sqrt(off[1] * off[1] + off[2] * off[2] + off[3] * off[3])
        ang = 2.0 * math.atan2(sv, off[0])
        if sv > 0.0:
            fs[FS.SLEW_AXIS] = off[1] / sv
            fs[FS.SLEW_AXIS + 1] = off[2] / sv
            fs[FS.SLEW_AXIS + 2] = off[3] / sv
        else:
            fs[FS.SLEW_AXIS] = 1.0
            fs[FS.SLEW_AXIS + 1] = 0.0
            fs[FS.SLEW_AXIS + 2] = 0.0
        fs[FS.SLEW_ANGLE] = ang
        fs[FS.SLEW_T0] = t
    e = (fs[FS.SLEW_AXIS], fs[FS.SLEW_AXIS + 1], fs[FS.SLEW_AXIS + 2])
    th, thd, thdd = slew_profile(
        fs[FS.SLEW_ANGLE], t - fs[FS.SLEW_T0], fw[mb + MB.SLEW_RATE], fw[mb + MB.SLEW_ACC]
    )
    c = math.cos(0.5 * th)
    s = math.sin(0.5 * th)
    o4 = (c, s * e[0], s * e[1], s * e[2])
    qR = mul(qB, o4)
    wBr = rotate_inverse(o4, wB)
    dwBr = rotate_inverse(o4, dwB)
    we = (thd * e[0], thd * e[1], thd * e[2])
    x = cross(we, wBr)
    wR = (wBr[0] + we[0], wBr[1] + we[1], wBr[2] + we[2])
    dwR = (dwBr[0] - x[0] + thdd * e[0], dwBr[1] - x[1] + thdd * e[1], dwBr[2] - x[2] + thdd * e[2])
    return qR, wR, dwR


@jit
def condition_holds(fw, mb, t, q, om):
    """Whether the mode's entry condition holds at t for the attitude q and rate ω."""
    kind = int(fw[mb + MB.COND])
    x = fw[mb + MB.COND_X]
    if kind == COND_ALWAYS:
        return True
    if kind == COND_RATE_BELOW or kind == COND_RATE_ABOVE:
        r = math.sqrt(om[0] * om[0] + om[1] * om[1] + om[2] * om[2])
        return r < x if kind == COND_RATE_BELOW else r > x
    if kind == COND_AFTER:
        return t >= x
    o = int(fw[mb + MB.COND_FRAME])
    r = frame_eval(fw[o:], t)
    e = conj_mul((r[0], r[1], r[2], r[3]), q)  # rotation from the frame to the body
    a = (fw[mb + MB.COND_AXIS], fw[mb + MB.COND_AXIS + 1], fw[mb + MB.COND_AXIS + 2])
    if a[0] == 0.0 and a[1] == 0.0 and a[2] == 0.0:
        sv = math.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3])
        ang = 2.0 * math.atan2(sv, abs(e[0]))
    else:
        # the angle between the body axis and the same axis of the frame
        in_frame = rotate(e, a)  # the body axis in the frame's axes
        c = in_frame[0] * a[0] + in_frame[1] * a[1] + in_frame[2] * a[2]
        c = min(1.0, max(-1.0, c))
        ang = math.acos(c)
    return ang < x if kind == COND_POINTING_WITHIN else ang > x


@jit
def sense_and_estimate(t, q, om, bb, fw, fs, rec_row, rec_at):
    """The sensors' measurements and the estimate at this tick: (q, ω, B) the software uses.

    Without sensors the truth; with sensors but no estimator the last valid star tracker
    quaternion and the gyro's rate; with the MEKF its estimate (propagated over the period
    with this tick's gyro rate, the mean over that interval, then updated). Writes the tick's
    sensor and estimator record at ``rec_at`` of ``rec_row`` (if ``rec_at`` >= 0)."""
    so = int(fw[FW.SENSORS])
    if so == 0:
        return q, om, bb
    sn = fw[so:]
    ss = fs[int(fw[FW.SS]) :]
    zo = int(fw[FW.Z])
    z = fs[zo : zo + Z.SIZE]
    scratch = fs[zo + Z.SIZE :]
    tick = int(fs[FS.TICK])
    dt = fw[FW.PERIOD]
    measure_sensors_inline(sn, ss, t, tick, q, om, bb, z, scratch, rec_at >= 0)
    qu = q
    wu = om
    bu = bb
    if z[Z.GYRO_OK] != 0.0:
        wu = (z[Z.OMEGA], z[Z.OMEGA + 1], z[Z.OMEGA + 2])
    if z[Z.MAG_OK] != 0.0:
        bu = (z[Z.B], z[Z.B + 1], z[Z.B + 2])
    eo = int(fw[FW.EST])
    es = fs[int(fw[FW.ES]) :]
    if eo == 0:
        if z[Z.ST_OK] != 0.0:
            for i in range(4):
                es[ES.LAST_Q + i] = z[Z.Q + i]
            es[ES.HAS_Q] = 1.0
        if es[ES.HAS_Q] != 0.0:
            qu = (es[ES.LAST_Q], es[ES.LAST_Q + 1], es[ES.LAST_Q + 2], es[ES.LAST_Q + 3])
    else:
        ep = fw[eo:]
        if es[E.INIT] == 0.0:
            if ep[EP.INIT] != 0.0:
                mekf_init(
                    es, ep, (ep[EP.Q0], ep[EP.Q0 + 1], ep[EP.Q0 + 2], ep[EP.Q0 + 3]), ep[13:16]
                )
                _updates(es, ep, z, q, bb, sn, t)
            elif z[Z.ST_OK] != 0.0:
                # the first measurement is the estimate: no update with it
                mekf_init(es, ep, (z[Z.Q], z[Z.Q + 1], z[Z.Q + 2], z[Z.Q + 3]), ep[13:16])
        else:
            # the gyro's rate of this tick is the mean over the interval just ended
            for i in range(3):
                es[ES.OMEGA_PREV + i] = wu[i]
            mekf_propagate_inline(es, ep, es[ES.OMEGA_PREV : ES.OMEGA_PREV + 3], dt)
            if z[Z.ST_OK] != 0.0 or z[Z.MAG_OK] != 0.0 or z[Z.SUN_OK] != 0.0:
                _updates(es, ep, z, q, bb, sn, t)
        if es[E.INIT] != 0.0:
            qu = (es[E.Q], es[E.Q + 1], es[E.Q + 2], es[E.Q + 3])
            wu = (wu[0] - es[E.B], wu[1] - es[E.B + 1], wu[2] - es[E.B + 2])
    if rec_at >= 0:
        for i in range(Z.SIZE):
            rec_row[rec_at + i] = z[i]
        r = rec_at + Z.SIZE
        for i in range(RS.SIZE):
            rec_row[r + i] = math.nan
        if eo != 0 and es[E.INIT] != 0.0:
            for i in range(4):
                rec_row[r + RS.Q + i] = es[E.Q + i]
            for i in range(3):
                rec_row[r + RS.B + i] = es[E.B + i]
            mekf_covariance_at(es, ep, E.PHI)  # P at this tick, in a scratch copy
            for i in range(6):
                rec_row[r + RS.SIGMA + i] = math.sqrt(max(es[E.PHI + 7 * i], 0.0))
            g = int(sn[SN.GYRO])
            gs = int(sn[g + GYRO.STATE]) + RNG_SIZE
            bt = (
                sn[g + GYRO.B0] + ss[gs],
                sn[g + GYRO.B0 + 1] + ss[gs + 1],
                sn[g + GYRO.B0 + 2] + ss[gs + 2],
            )
            e, nees = estimation_error(es, E.PHI, q, bt)
            for i in range(6):
                rec_row[r + RS.ERR + i] = e[i]
            rec_row[r + RS.NEES] = nees
    return qu, wu, bu


@jit
def _updates(es, ep, z, q, bb, sn, t):
    """The filter's updates with the valid measurements of the tick (q, bb: the truth, for
    the reference vectors in space the filter knows: the field model, the Sun's ephemeris)."""
    if z[Z.ST_OK] != 0.0:
        mekf_update_quaternion(es, ep, z[Z.Q : Z.Q + 4])
    if ep[EP.MAG] > 0.0 and z[Z.MAG_OK] != 0.0:
        r = rotate(q, bb)  # the field model in space (the IGRF tables)
        mekf_update_vector(es, ep, z[Z.B], z[Z.B + 1], z[Z.B + 2], r[0], r[1], r[2], ep[EP.MAG])
    if ep[EP.SUN] > 0.0 and z[Z.SUN_OK] != 0.0:
        _, s, _ = sun_and_earth(sn, t)  # the Sun's direction in space (its ephemeris)
        mekf_update_vector(es, ep, z[Z.SUN], z[Z.SUN + 1], z[Z.SUN + 2], s[0], s[1], s[2],
                           ep[EP.SUN])  # fmt: skip


@jit
def _field_offset(fw, sc):
    """Offset of the field block the software reads (its own, else the magnetorquers')."""
    fo = int(fw[FW.FIELD])
    if fo == 0:
        fo = int(sc[SC.MTQ])
    return fo


@jit
def _sense(t, y, omt, sc, fw, fs, rec_row, keep):
    """The truth at t (the state ``y`` and its body rate ``omt``), then what the software
    measures or estimates of it: (q, ω, B_body); the sensors' and the estimator's record
    written into ``rec_row`` if ``keep``."""
    qt = (y[0], y[1], y[2], y[3])
    fo = _field_offset(fw, sc)
    bbt = (0.0, 0.0, 0.0)
    if fo > 0:
        bbt = field_body(qt, t, fw if int(fw[FW.FIELD]) > 0 else sc, fo)
    if fw[FW.SENSORS] == 0.0:  # the truth (not even the call's entry a tick)
        return qt, omt, bbt
    at = R.CMD + 2 * int(fw[FW.NCMD]) if keep else -1
    return sense_and_estimate(t, qt, omt, bbt, fw, fs, rec_row, at)


@jit
def _sensed(fs):
    """The (q, ω, B_body) stored by :func:`fsw_boundary` at this tick."""
    q = (fs[FS.SQ], fs[FS.SQ + 1], fs[FS.SQ + 2], fs[FS.SQ + 3])
    om = (fs[FS.SW], fs[FS.SW + 1], fs[FS.SW + 2])
    bb = (fs[FS.SB], fs[FS.SB + 1], fs[FS.SB + 2])
    return q, om, bb


@jit(inline="always")
def _mode_switch(fw, fs, t, q, om):
    """Modes: forward to the next one when its condition holds (its state reset); the mode."""
    mode = int(fs[FS.MODE])
    nmodes = int(fw[FW.NMODES])
    if mode + 1 < nmodes:
        nb = int(fw[int(fw[FW.MODES]) + mode + 1])
        if condition_holds(fw, nb, t, q, om):
            mode += 1
            fs[FS.MODE] = mode
            fs[FS.ENTERED] = 0.0
            fs[FS.INT] = 0.0
            fs[FS.INT + 1] = 0.0
            fs[FS.INT + 2] = 0.0
            fs[FS.PRIOR] = math.nan
    return mode


@jit(inline="always")
def _errors(qR, wR_R, dwR_R, q, om):
    """The attitude error q_BR = q̃_R∘q and its MRP, whether the reference is fixed, its rate
    and acceleration in body axes, and the rate error."""
    qBR = conj_mul(qR, q)
    sig = mrp(qBR)
    # a fixed reference (inertial pointing): its rates are zeros in every axes
    still = wR_R == (0.0, 0.0, 0.0) and dwR_R == (0.0, 0.0, 0.0)
    wRN = dwRN = (0.0, 0.0, 0.0)
    if not still:
        wRN = rotate_inverse(qBR, wR_R)
        dwRN = rotate_inverse(qBR, dwR_R)
    dw = (om[0] - wRN[0], om[1] - wRN[1], om[2] - wRN[2])
    return qBR, sig, still, wRN, dwRN, dw


@jit(inline="always")
def _dumping(fw, sc, y, mb, bb, m):
    """Momentum dumping with magnetorquers beside the wheels (the cross-product law) added to
    the dipole request ``m``; also |B|²."""
    kd = fw[mb + MB.DUMP]
    b2 = bb[0] * bb[0] + bb[1] * bb[1] + bb[2] * bb[2]
    if kd > 0.0 and b2 > 0.0:
        hw0, hw1, hw2 = wheel_momentum_sum(sc, y)
        r = mb + MB.DUMP_REF
        dh = (hw0 - fw[r], hw1 - fw[r + 1], hw2 - fw[r + 2])
        c = cross(dh, bb)  # m = k (Δh × B)/|B|²: the torque m × B = −k Δh⊥ unloads the wheels
        m = (m[0] + kd * c[0] / b2, m[1] + kd * c[1] / b2, m[2] + kd * c[2] / b2)
    return m, b2


@jit(inline="always")
def _allocate(fw, sc, y, om, mb, bb, b2, cmd, external, L, m, nw, nm, ncmd):
    """The requests to the raw commands ``cmd`` (your own software wrote them there): wheels
    through G⁺ and the null-space term, a torque on magnetorquers alone, dipoles to the rods,
    or an ideal torque. Returns the (torque, dipole) requests as recorded."""
    out = cmd
    ideal = (0.0, 0.0, 0.0)
    if external:
        if fw[FW.IDEAL] != 0.0:
            L = (cmd[0], cmd[1], cmd[2])
            ideal = L
            for i in range(3):
                cmd[i] = 0.0
    elif fw[FW.IDEAL] != 0.0:
        ideal = L
    elif nw > 0:
        for i in range(ncmd):
            out[i] = 0.0
        gp = int(fw[FW.GPINV])
        for k in range(nw):
            out[k] = -(
                fw[gp + 3 * k] * L[0] + fw[gp + 3 * k + 1] * L[1] + fw[gp + 3 * k + 2] * L[2]
            )
        kn = fw[mb + MB.NULL]
        if kn > 0.0:
            npj = int(fw[FW.NULLP])
            so = int(fw[mb + MB.NULL_SPEEDS])
            for k in range(nw):
                acc = 0.0
                for j in range(nw):
                    b = SC.WHEELS + j * WHEEL.SIZE
                    Om = wheel_speed(sc, b, y[8 + j], om)
                    ref = fw[so + j] if so > 0 else 0.0
                    acc += fw[npj + nw * k + j] * sc[b + WHEEL.J] * (Om - ref)
                out[k] -= kn * acc
    else:
        for i in range(ncmd):
            out[i] = 0.0
        if nm > 0 and b2 > 0.0:
            # a torque request on magnetorquers alone: m = B × L / |B|²
            c = cross(bb, L)
            m = (m[0] + c[0] / b2, m[1] + c[1] / b2, m[2] + c[2] / b2)
    if nm > 0 and not external:
        ap = int(fw[FW.NAPINV])
        for j in range(nm):
            out[nw + j] = (
                fw[ap + 3 * j] * m[0] + fw[ap + 3 * j + 1] * m[1] + fw[ap + 3 * j + 2] * m[2]
            )
    sc[SC.IDEAL] = ideal[0]
    sc[SC.IDEAL + 1] = ideal[1]
    sc[SC.IDEAL + 2] = ideal[2]
    return L, m


@jit(inline="always")
def _record(rec_row, t, mode, qR, sig, dw, L, m, qBR, out, ncmd):
    """What the tick computed, into its record row."""
    rec_row[R.T] = t
    rec_row[R.MODE] = mode
    for i in range(4):
        rec_row[R.QREF + i] = qR[i]
    for i in range(3):
        rec_row[R.SIGMA + i] = sig[i]
        rec_row[R.DOMEGA + i] = dw[i]
        rec_row[R.TORQUE + i] = L[i]
        rec_row[R.DIPOLE + i] = m[i]
    sq = shorter(qBR)
    s2 = sq[1] * sq[1] + sq[2] * sq[2] + sq[3] * sq[3]
    rec_row[R.ANGLE] = 2.0 * math.atan2(math.sqrt(s2), sq[0])
    for i in range(ncmd):
        rec_row[R.CMD + i] = out[i]


@jit(inline="always")
def _burns(fw, t, cmd, c0):
    """The burns in progress at t: their thrusters on for the period (the part of it left at
    the burn's end), beside the allocation's command (attitude.software.Burn)."""
    bo = int(fw[FW.BURNS])
    per = fw[FW.PERIOD]
    for b in range(int(fw[bo])):
        o = bo + 1 + 3 * b
        if fw[o] <= t < fw[o + 1]:
            j = c0 + int(fw[o + 2])
            cmd[j] = max(cmd[j], min(1.0, (fw[o + 1] - t) / per))


@jit(inline="always")
def _delay(fw, fs, out, ncmd):
    """Commands ``delay`` whole ticks late: this tick's out goes in, the one ``delay`` ticks ago
    out."""
    delay = int(fw[FW.DELAY])
    if delay > 0:
        k = int(fs[FS.TICK])
        slot = FS.QUEUE + (k % delay) * ncmd
        for i in range(ncmd):
            v = fs[slot + i]
            fs[slot + i] = out[i]
            out[i] = v if k >= delay else 0.0


@jit
def fsw_tick(t, y, omt, params, sc, fw, fs, cmd, rec_row, keep):
    """One tick of the flight software at t from the state y (its body rate ``omt``): the
    commands to apply into ``cmd`` (n_cmd; after the delay), the tick's record into ``rec_row``
    if ``keep`` (an unrecorded tick writes nothing there and skips what only the record needs:
    the error angle, the estimation error and its NEES)."""
    nw = int(sc[SC.NW])
    nm = int(sc[SC.NM])
    ncmd = int(fw[FW.NCMD])
    fo = _field_offset(fw, sc)
    if fs[FS.SENSED] != 0.0:  # measured when your own step asked for its commands
        q, om, bb = _sensed(fs)
        fs[FS.SENSED] = 0.0
    else:
        q, om, bb = _sense(t, y, omt, sc, fw, fs, rec_row, keep)
    mode = _mode_switch(fw, fs, t, q, om)
    mb = int(fw[int(fw[FW.MODES]) + mode])
    qR, wR_R, dwR_R = guidance(fw, fs, mb, t, q)
    fs[FS.ENTERED] = 1.0
    qBR, sig, still, wRN, dwRN, dw = _errors(qR, wR_R, dwR_R, q, om)
    external = fw[FW.EXTERNAL] != 0.0
    # control law (attitude._core.fsw_laws: one kernel per law)
    ctrl = CTRL_NONE if external else int(fw[mb + MB.CTRL])
    L, m = control_law(ctrl, fw, fs, sc, y, mb, t, om, bb, qBR, sig, dw, wRN, dwRN, still)
    fs[FS.BPREV] = bb[0]
    fs[FS.BPREV + 1] = bb[1]
    fs[FS.BPREV + 2] = bb[2]
    fs[FS.BVALID] = 1.0 if fo > 0 else 0.0
    m, b2 = _dumping(fw, sc, y, mb, bb, m)
    out = cmd
    L, m = _allocate(fw, sc, y, om, mb, bb, b2, cmd, external, L, m, nw, nm, ncmd)
    if fw[FW.BURNS] > 0.0:
        _burns(fw, t, cmd, nw + nm)
    if keep:
        _record(rec_row, t, mode, qR, sig, dw, L, m, qBR, out, ncmd)
    _delay(fw, fs, out, ncmd)


@jit
def fsw_boundary(P, y, t, t_end, ctl):
    """The flight software as the command source of :func:`attitude._core.holds.holds_run`
    (``ctl = (hs, fw, fs, cmd, rec, rc)``): at a tick, run :func:`fsw_tick` and hold its
    commands until the next tick; at a thruster's switch-off, turn it off."""
    hs, fw, fs, cmd, rec, rc = ctl
    params = P[0]
    sc = P[1]
    per = fw[FW.PERIOD]
    if hs[HS.HOLD_END] != hs[HS.HOLD_END]:  # first call: zero commands until the first tick
        fs[FS.NEXT] = fw[FW.T0]
        fs[FS.TICK] = 0.0
        fs[FS.MODE] = 0.0
        fs[FS.PRIOR] = math.nan
        if t < fw[FW.T0]:
            for i in range(cmd.shape[0]):
                cmd[i] = 0.0
            configure_hold(sc, y, cmd, t, fw[FW.T0])
            sc[SC.IDEAL] = 0.0
            sc[SC.IDEAL + 1] = 0.0
            sc[SC.IDEAL + 2] = 0.0
            hs[HS.HOLD_END] = fw[FW.T0]
    if t >= fs[FS.NEXT]:
        if sc[SC.COUPLED] >= 0.0:  # the orbit is in the state: the software reads it there
            coupled_software(sc, int(sc[SC.COUPLED]), fw, t, y)
        k = int(fs[FS.TICK])
        every = int(fw[FW.RECORD_EVERY])
        if every > 0:
            keep = k % every == 0
        else:  # the ticks in effect at the output samples
            p = int(fs[FS.RECORD_NEXT])
            keep = p < int(fw[FW.RECORD_N]) and fw[int(fw[FW.RECORD_TABLE]) + p] == k
        if keep and rc[0] >= rec.shape[0]:
            return RECORDS_FULL
        row = rec[int(rc[0]) if keep else 0]  # (an unrecorded tick writes nothing there)
        if fw[FW.EXTERNAL] != 0.0 and hs[HS.READY] == 0.0:
            # your own step: measure once (recorded in this row), then ask for the commands
            if fs[FS.SENSED] == 0.0:
                q, om, bb = _sense(t, y, state_rate(sc, y)[1], sc, fw, fs, row, keep)
                for i in range(4):
                    fs[FS.SQ + i] = q[i]
                for i in range(3):
                    fs[FS.SW + i] = om[i]
                    fs[FS.SB + i] = bb[i]
                fs[FS.SENSED] = 1.0
            return BOUNDARY_NEEDS_COMMANDS
        hs[HS.READY] = 0.0
        _g, omt = state_rate(sc, y)  # the truth's rate, for the sensors and the wheels' limits
        fsw_tick(t, y, omt, params, sc, fw, fs, cmd, row, keep)
        t_next = fw[FW.T0] + (k + 1) * per
        configure_hold_rate(sc, y, omt, cmd, t, t_next)
        # the applied commands of the tick (after the wheels' limits)
        if keep:
            ncmd = int(fw[FW.NCMD])
            nw = int(sc[SC.NW])
            for i in range(ncmd):
                row[R.CMD + ncmd + i] = cmd[i]
            for j in range(nw):
                row[R.CMD + ncmd + j] = sc[SC.WHEELS + j * WHEEL.SIZE + WHEEL.U]
            rc[0] += 1
            fs[FS.RECORD_NEXT] += 1.0  # (read only with every = 0)
        fs[FS.TICK] = k + 1
        fs[FS.NEXT] = t_next
        hs[HS.HOLD_END] = t_next
    if sc[SC.NT] > 0.0:
        thrusters_off_at(sc, t)
        hs[HS.SEG_END] = next_thruster_off(sc, t, min(hs[HS.HOLD_END], t_end))
    else:
        hs[HS.SEG_END] = min(hs[HS.HOLD_END], t_end)
    return BOUNDARY_DONE


# The tick inlined into the single-run drivers (entry_points binds them; docs/cold_start.md);
# the ensemble drivers keep the calls (numba's parallel array analysis rejects the inlined
# tick); sense_and_estimate and the boundary's cold paths (_sense, configure_hold) stay calls.
_sense_inline = inline_copy(_sense, globals())
_guidance_inline = inline_copy(guidance, globals())
_configure_hold_inline = inline_copy(configure_hold_rate, globals())
_thrusters_off_at_inline = inline_copy(thrusters_off_at, globals())
_next_thruster_off_inline = inline_copy(next_thruster_off, globals())
fsw_tick_inline = inline_copy(
    fsw_tick, globals(), _sense="_sense_inline", guidance="_guidance_inline"
)
fsw_boundary_inline = inline_copy(
    fsw_boundary,
    globals(),
    fsw_tick="fsw_tick_inline",
    configure_hold_rate="_configure_hold_inline",
    thrusters_off_at="_thrusters_off_at_inline",
    next_thruster_off="_next_thruster_off_inline",
)

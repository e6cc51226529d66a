"""Your own compiled flight software: the measurements it sees and the boundary that calls it.

A :class:`attitude.FlightSoftware` whose step is a numba function ``step(t, m) -> commands``
runs inside the compiled loop: at each tick where the software of :mod:`attitude._core.fsw`
asks for commands, :func:`step_boundary_with` fills the measurement vector ``m`` (:func:`measure`,
the layout MEAS_* below, which :class:`attitude.software.MeasurementIndex` names), calls the
step and checks its commands before they are held.
"""

from __future__ import annotations

import math

import numpy as np

from orbit._layout import Field, layout
from orbit._shared_jit import jit, jit_generic
from orbit._state_kernels import orbit_state

from .actuators import (
    SC,
    WHEEL,
    state_rate,
    wheel_speed,
)
from .environment import field_body
from .fsw import (
    FS,
    FW,
    _field_offset,
    _sensed,
    fsw_boundary,
    guidance,
)
from .holds import (
    BOUNDARY_NEEDS_COMMANDS,
    HS,
    STEP_FAILED,
)
from .quat import conj_mul, mrp, rotate_inverse

#: Layout of the measurement vector of :func:`measure`, whose public face is
#: :class:`attitude.software.MeasurementIndex` (its members are these offsets).
MEAS = layout(
    "measurements of your own step",
    t=Field(1, "s"),
    q=Field(4, "", "attitude, body to space"),
    omega=Field(3, "rad/s", "body rate"),
    q_ref=Field(4, "", "the guidance's reference attitude"),
    omega_ref=Field(3, "rad/s", "the reference rate in body axes"),
    sigma_error=Field(3, "", "attitude error σ_BR (MRP)"),
    omega_error=Field(3, "rad/s", "rate error ω − ω_r"),
    field=Field(3, "T", "geomagnetic field"),
    sun=Field(3, "", "unit vector to the Sun"),
    r=Field(3, "km", "position, space axes (GCRS)"),
    v=Field(3, "km/s", "velocity, space axes"),
    wheel_speeds=Field(0, "rad/s", "n_w wheel speeds, then n_w momenta (N m s)"),
)


@jit
def measure(t, y, params, sc, fw, fs, out):
    """The measurements your own software sees at t (NaN where unavailable): the layout MEAS_*
    above. The attitude, rate and field are those the built-in laws would use (the truth, or
    the sensors' and the estimator's, as stored by :func:`fsw_boundary` at this tick); r, v
    and the Sun's direction (in the software's body axes) from the on-board ephemerides. Runs
    the active mode's guidance (a slew starts here)."""
    nw = int(sc[SC.NW])
    _g, omt = state_rate(sc, y)
    sensed = fs[FS.SENSED] != 0.0
    if sensed:
        q, om, bbs = _sensed(fs)
    else:
        q = (y[0], y[1], y[2], y[3])
        om = omt
    mb = int(fw[int(fw[FW.MODES]) + int(fs[FS.MODE])])
    qR, wR_R, _dwR_R = guidance(fw, fs, mb, t, q)
    fs[FS.ENTERED] = 1.0
    qBR = conj_mul(qR, q)
    sig = mrp(qBR)
    wRN = rotate_inverse(qBR, wR_R)
    out[MEAS.T] = t
    for i in range(4):
        out[MEAS.Q + i] = q[i]
        out[MEAS.Q_REF + i] = qR[i]
    for i in range(3):
        out[MEAS.OMEGA + i] = om[i]
        out[MEAS.OMEGA_REF + i] = wRN[i]
        out[MEAS.SIGMA_ERROR + i] = sig[i]
        out[MEAS.OMEGA_ERROR + i] = om[i] - wRN[i]
        out[MEAS.FIELD + i] = math.nan
        out[MEAS.SUN + i] = math.nan
        out[MEAS.R + i] = math.nan
        out[MEAS.V + i] = math.nan
    fo = int(fw[FW.FIELD])
    if _field_offset(fw, sc) <= 0:
        bb = (math.nan, math.nan, math.nan)
    elif sensed:
        bb = bbs
    elif fo > 0:
        bb = field_body(q, t, fw, fo)
    else:
        bb = field_body(q, t, sc, int(sc[SC.MTQ]))
    oo = int(fw[FW.ORBIT])
    if oo > 0:
        st = orbit_state(fw[oo:], t)
        for i in range(3):
            out[MEAS.R + i] = st[i]
            out[MEAS.V + i] = st[3 + i]
        so = int(fw[FW.SUN])
        if so > 0:
            sun = orbit_state(fw[so:], t)
            dx = sun[0] - st[0]
            dy = sun[1] - st[1]
            dz = sun[2] - st[2]
            n = math.sqrt(dx * dx + dy * dy + dz * dz)
            sb = rotate_inverse(q, (dx / n, dy / n, dz / n))
            for i in range(3):
                out[MEAS.SUN + i] = sb[i]
    for i in range(3):
        out[MEAS.FIELD + i] = bb[i]
    for k in range(nw):
        b = SC.WHEELS + k * WHEEL.SIZE
        out[MEAS.WHEEL_SPEEDS + k] = wheel_speed(sc, b, y[8 + k], omt)  # the tachometers
        out[MEAS.WHEEL_SPEEDS + nw + k] = y[8 + k]


@jit
def measure_from_python(t, y, params, sc, fw, fs, out):
    """:func:`measure` for a call from Python (your Python step, attitude._holds): a call of
    the copy compiled code calls, so that :func:`measure` compiles once (called from Python as
    well, it compiled a second time with numba's CPython wrapper: ~2.5 s of a fresh cache)."""
    measure(t, y, params, sc, fw, fs, out)


#: Why a compiled step's commands were refused (``hs[HS.FAIL]``; ``hs[HS.FAIL_N]``: the length
#: it returned).
STEP_WRONG_LENGTH = 1.0
STEP_NONFINITE = 2.0


@jit_generic
def step_boundary_with(step, P, y, t, t_end, ctl):
    """:func:`fsw_boundary` with your own compiled ``step(t, m) -> commands`` (``m``: the
    measurements of :func:`measure`, a 1-D array): called at each tick where the software asks
    for commands; its commands are checked (length n_cmd, or 3 body-torque components without
    actuators; finite), else the run stops with STEP_FAILED (the reason in ``hs``)."""
    status = fsw_boundary(P, y, t, t_end, ctl)
    if status != BOUNDARY_NEEDS_COMMANDS:
        return status
    hs, fw, fs, cmd = ctl[0], ctl[1], ctl[2], ctl[3]
    sc = P[1]
    nw = int(sc[SC.NW])
    m = np.empty(MEAS.WHEEL_SPEEDS + 2 * nw)
    measure(t, y, P[0], sc, fw, fs, m)
    out = step(t, m)
    ncmd = int(fw[FW.NCMD])
    want = ncmd if ncmd > 0 else 3
    if out.shape[0] != want:
        hs[HS.FAIL] = STEP_WRONG_LENGTH
        hs[HS.FAIL_N] = out.shape[0]
        return STEP_FAILED
    for i in range(want):
        v = float(out[i])
        if not math.isfinite(v):
            hs[HS.FAIL] = STEP_NONFINITE
            hs[HS.FAIL_N] = i
            return STEP_FAILED
        cmd[i] = v
    hs[HS.READY] = 1.0
    return fsw_boundary(P, y, t, t_end, ctl)

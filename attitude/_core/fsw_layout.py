"""Layouts of the flight software's arrays (:mod:`attitude._core.fsw`): the program ``fw``
(header, mode blocks), the state ``fs``, the filter's slots and the tick records."""

from __future__ import annotations

from orbit._layout import Field, Gap, layout

from .mekf import E

# --- the program fw: header ---------------------------------------------------------------------
FW = layout(
    "flight software program header",
    period=Field(1, "s", "tick period"),
    t0=Field(1, "s", "time of the first tick"),
    delay=Field(1, "", "whole ticks between a command's computation and its application"),
    nmodes=1,
    ncmd=Field(1, "", "raw commands: n_w + n_m + n_t"),
    modes=Field(1, "", "offset of the table of mode offsets"),
    ideal=Field(1, "", "1: the request is an ideal body torque (no actuators)"),
    inertia=Field(9, "kg m2", "the software's inertia model", (3, 3)),
    field=Field(1, "", "offset of a field block (MagneticDipole layout; 0: the spacecraft's)"),
    record_every=Field(1, "", "record every k-th tick; 0: the ticks listed at RECORD_TABLE"),
    napinv=Field(1, "", "offset of the magnetorquers' pseudo-inverse (n_m × 3; 0: none)"),
    gpinv=Field(1, "", "offset of the wheels' pseudo-inverse G⁺ (n_w × 3)"),
    nullp=Field(1, "", "offset of the null-space projector N (n_w × n_w)"),
    external=Field(1, "", "1: the commands come from Python at each tick (your own step)"),
    orbit=Field(1, "", "offset of the orbit's kernel data (0: none)"),
    sun=Field(1, "", "offset of the Sun's table (0: none)"),
    sensors=Field(1, "", "offset of the sensor program (attitude._core.sensors; 0: the truth)"),
    est=Field(1, "", "offset of the MEKF's record (attitude._core.mekf EP; 0: no estimator)"),
    ss=Field(1, "", "offset in fs of the sensors' state"),
    es=Field(1, "", "offset in fs of the filter's state"),
    z=Field(1, "", "offset in fs of the measurement vector (Z.SIZE), the Sun heads' scratch"),
    record_table=Field(1, "", "offset of the recorded ticks' indices (RECORD_EVERY = 0)"),
    record_n=Field(1, "", "their number"),
    burns=Field(1, "", "offset of the burn table: n, then (start, stop, thruster) each; 0: none"),
    size=32,
)

# --- mode blocks (offsets relative to the block) --------------------------------------------------
MB = layout(
    "mode block",
    cond=Field(1, "", "COND_*"),
    cond_x=Field(1, "rad/s, rad or s", "the condition's threshold"),
    cond_frame=Field(1, "", "offset of the condition's frame (pointing)"),
    cond_axis=Field(3, "", "body axis; zero: the total rotation angle"),
    guid=Field(1, "", "GUID_*"),
    guid_frame=Field(1, "", "offset of the reference (target) frame"),
    slew_rate=Field(1, "rad/s"),
    slew_acc=Field(1, "rad/s2"),
    ctrl=Field(1, "", "CTRL_*"),
    k=1,
    p=Field(9, "", "3 × 3", (3, 3)),
    ki=1,
    ilim=1,
    # MRP feedback: Basilisk's controlLawType 0 (ω_r + K_I z) or 1 (ω); B-dot: 0 m = −k Ḃ,
    # 1 m = −(k/|B|) ḃ
    lawtype=1,
    dump=Field(1, "1/s", "momentum-dumping gain (0: off)"),
    dump_ref=Field(3, "N m s", "reference wheel momentum in body axes"),
    null=Field(1, "1/s", "null-space gain (0: off)"),
    null_speeds=Field(1, "", "offset of the reference wheel speeds (n_w; 0: zero)"),
    size=32,
)

# --- the state fs -------------------------------------------------------------------------------
FS = layout(
    "flight software state",
    mode=1,
    tick=1,
    next=Field(1, "s", "time of the next tick"),
    int=Field(3, "rad s", "MRP feedback's ∫ K σ dt"),
    prior=Field(1, "s", "time of the last control update (NaN: none yet)"),
    bprev=Field(3, "T", "field measured at the last tick"),
    bvalid=1,
    slew_t0=Field(1, "s", "start of the slew"),
    slew_axis=Field(3, "", "axis of the offset from the target (target axes)"),
    slew_angle=Field(1, "rad", "its angle"),
    entered=Field(1, "", "1 once the active mode has run a tick (0 at its entry)"),
    sensed=Field(1, "", "1: this tick's measurements were taken (your own step asked)"),
    record_next=Field(1, "", "next entry of the table of recorded ticks"),
    _a=Gap(1),
    sq=Field(4, "", "the attitude the software uses at this tick"),
    sw=Field(3, "rad/s", "its rate"),
    sb=Field(3, "T", "its field"),
    _b=Gap(2),
    queue=Field(0, "", "delayed commands: delay rows of n_cmd, a ring indexed by the tick"),
)

# --- tick records -------------------------------------------------------------------------------
R = layout(
    "tick record",
    t=Field(1, "s"),
    mode=1,
    qref=Field(4, "", "the reference attitude"),
    sigma=Field(3, "", "σ_BR (MRP)"),
    angle=Field(1, "rad", "error angle"),
    domega=Field(3, "rad/s", "ω_BR"),
    torque=Field(3, "N m", "torque request L_r"),
    dipole=Field(3, "A m2", "dipole request, body axes"),
    cmd=Field(0, "", "commands computed at this tick (n_cmd), then those applied (n_cmd)"),
)
#: With sensors, after the commands: the measurements (Z.SIZE), then the estimate.
RS = layout(
    "tick record: the estimate",
    q=Field(4, "", "q̂"),
    b=Field(3, "rad/s", "β̂"),
    sigma=Field(6, "rad, rad/s", "the 1-σ of the six error states"),
    err=Field(6, "rad, rad/s", "the estimation errors δθ, δβ"),
    nees=Field(1, "", "the normalized estimation error squared"),
)

#: Filter state slots kept in fs beside the filter's own (the gyro rate of the last tick).
ES = layout(
    "filter state",
    filter=Field(E.SIZE, "", "the MEKF's state (attitude._core.mekf)"),
    omega_prev=Field(3, "rad/s"),
    last_q=Field(4, "", "the last valid star tracker quaternion (without a filter)"),
    has_q=1,
)

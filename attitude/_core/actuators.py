"""Compiled kernels of the actuators: the spacecraft block, wheel friction, command limits.

A spacecraft with actuators (:class:`attitude.Spacecraft`) is described to compiled code by one
float64 array ``sc``, the *spacecraft block*, beside the model's ``params``
(:mod:`attitude._core.potentials`). Its numbers are constant during a run, except the slots
marked (held): those hold the commands in force, written at every hold boundary by
:func:`configure_hold` (zero-order hold: constant until the next boundary). Layout::

    sc[SC.NW], [SC.NM], [SC.NT]    numbers of wheels, magnetorquers, thrusters
    sc[SC.MINV : +9]                M = Ĩ⁻¹, Ĩ = I − Σ J_k a_k a_kᵀ (row-major, body axes)
    sc[SC.TAU : +3]                 (held) the thrusters' torque about the centre of mass (N m)
    sc[SC.MTQ]                      offset of the magnetic-field block (−1: no magnetorquers)
    sc[SC.IDEAL : +3]               (held) an ideal control torque (N m, body axes): the flight
                                   software's request on a spacecraft without actuators
    sc[SC.WHEELS]...                n_w wheel records (the WHEEL layout)
    then                           n_m magnetorquer records (MTQ)
    then                           n_t thruster records (THR)
    then                           the field block (the layout of a ``MagneticDipole`` block
                                   of :mod:`attitude._core.environment`, its dipole slots
                                   (held) the magnetorquers' total dipole Σ m_j â_j)

The wheel is Basilisk's balanced reaction wheel (``reactionWheelStateEffector``,
``BalancedWheels``): friction (:func:`wheel_friction`) and the command limits applied when a
command is configured (:func:`configure_hold`) follow its ``updateContributions`` and
``ConfigureRWRequests``, with one difference stated in docs/actuators.md: Basilisk decides
between the Stribeck and the Coulomb friction regimes at every right-hand side (a state it
mutates inside the integrator's stages); here the regime is decided at each hold boundary
and held, so the right-hand side is a function of (t, y) alone.
"""

from __future__ import annotations

import math

from orbit._layout import Field, layout
from orbit._shared_jit import jit

from .environment import (
    DIPOLE,
    field_body,
)
from .quat import conj_mul, cross

# Header of the spacecraft block.
SC = layout(
    "spacecraft block header",
    nw=Field(1, "", "number of wheels"),
    nm=Field(1, "", "number of magnetorquers"),
    nt=Field(1, "", "number of thrusters"),
    minv=Field(9, "1/(kg m2)", "M = Ĩ⁻¹, Ĩ = I − Σ J_k a_k a_kᵀ (body axes)", (3, 3)),
    tau=Field(3, "N m", "(held) the thrusters' torque about the centre of mass"),
    mtq=Field(1, "", "offset of the magnetic-field block (−1: no magnetorquers)"),
    ideal=Field(3, "N m", "(held) an ideal control torque, body axes"),
    force=Field(3, "N", "(held) the thrusters' force, body axes"),
    mdot=Field(1, "kg/s", "(held) the propellant the firing thrusters burn"),
    coupled=Field(1, "", "offset of the coupled-orbit block (−1: the orbit is given)"),
    wheels=Field(0, "", "the wheel, magnetorquer and thruster records, the field block"),
)

# Wheel record (relative to its start).
WHEEL = layout(
    "reaction wheel record",
    axis=Field(3, "", "a, unit, body axes"),
    j=Field(1, "kg m2", "axial inertia J"),
    invj=Field(1, "1/(kg m2)", "1/J"),
    u=Field(1, "N m", "(held) applied motor torque u"),
    stribeck=Field(1, "", "(held) 1: the Stribeck friction regime, 0: Coulomb + viscous"),
    fc=Field(1, "N m", "Coulomb friction torque"),
    fs=Field(1, "N m", "static friction torque"),
    beta=Field(1, "rad/s", "Stribeck speed β (<= 0: no Stribeck regime)"),
    cv=Field(1, "N m s", "viscous friction coefficient"),
    lc=Field(1, "rad/s", "limit-cycle speed ω_lc (friction linear in Ω below it; 0: none)"),
    slope_c=Field(1, "N m s", "friction slope below ω_lc, Coulomb regime, (f_c + c_v ω_lc)/ω_lc"),
    slope_s=Field(1, "N m s", "the same in the Stribeck regime"),
    umax=Field(1, "N m", "motor torque limit (inf: none)"),
    omax=Field(1, "rad/s", "speed limit (inf: none)"),
    umin=Field(1, "N m", "smallest torque applied (below it the command is 0)"),
    pmax=Field(1, "W", "motor power limit (inf: none)"),
    ucmd=Field(1, "N m", "(held) the command as given"),
    flags=Field(1, "", "(held) limit flags of the hold (FLAG_* bits)"),
    omega_before=Field(1, "rad/s", "(held) Ω at the previous hold boundary"),
    friction=Field(1, "", "1.0 if any friction term is non-zero (skip the kernel otherwise)"),
)

# Magnetorquer record.
MTQ = layout(
    "magnetorquer record",
    axis=Field(3, "", "â"),
    max=Field(1, "A m2", "largest dipole magnitude"),
    cmd=Field(1, "A m2", "(held) commanded dipole"),
    applied=Field(1, "A m2", "(held) applied dipole, the command clipped to ±max"),
)

# Thruster record.
THR = layout(
    "thruster record",
    arm=Field(3, "m", "(r − r_cm) × d̂: torque per newton"),
    dir=Field(3, "", "d̂: force direction, body axes"),
    fmax=Field(1, "N", "thrust"),
    min_on=Field(1, "s", "shortest on-time: shorter firings are dropped"),
    cmd=Field(1, "", "(held) commanded on-time fraction of the hold"),
    on=Field(1, "s", "(held) on-time from the hold's start"),
    off_at=Field(1, "s", "(held) the time the thruster turns off (t_hold + on-time)"),
    firing=Field(1, "", "(held) 1.0 while firing in the current segment"),
    mdot=Field(1, "kg/s", "propellant burnt while firing, F/(isp g0) (0: none counted)"),
)

# Limit flags of a wheel command (WHEEL.FLAGS), Basilisk's ConfigureRWRequests in this order.
FLAG_TORQUE = 1  # clipped to ±max_torque
FLAG_SPEED = 2  # at or past the speed limit: a command spinning it further was cut to 0
FLAG_POWER = 4  # clipped to max_power / |Ω|
FLAG_DEADBAND = 8  # below min_torque: 0

_SQRT2E_OVER_SQRT2 = math.sqrt(2.0 * math.e) / math.sqrt(2.0)


@jit(inline="always")
def wheel_base(sc, k):
    """Start of wheel ``k``'s record."""
    return SC.WHEELS + k * WHEEL.SIZE


@jit(inline="always")
def magnetorquer_base(sc, j):
    """Start of magnetorquer ``j``'s record."""
    return SC.WHEELS + int(sc[SC.NW]) * WHEEL.SIZE + j * MTQ.SIZE


@jit(inline="always")
def thruster_base(sc, j):
    """Start of thruster ``j``'s record."""
    return SC.WHEELS + int(sc[SC.NW]) * WHEEL.SIZE + int(sc[SC.NM]) * MTQ.SIZE + j * THR.SIZE


@jit(inline="always")
def body_rate(sc, g0, g1, g2, l0, l1, l2):
    """ω = M (g − ℓ): the body angular velocity from the total body momentum g and the wheels'
    axial momenta ℓ = Σ h_k a_k."""
    d0 = g0 - l0
    d1 = g1 - l1
    d2 = g2 - l2
    m = SC.MINV
    return (
        sc[m] * d0 + sc[m + 1] * d1 + sc[m + 2] * d2,
        sc[m + 3] * d0 + sc[m + 4] * d1 + sc[m + 5] * d2,
        sc[m + 6] * d0 + sc[m + 7] * d1 + sc[m + 8] * d2,
    )


@jit(inline="always")
def wheel_momentum_sum(sc, y):
    """ℓ = Σ h_k a_k, the wheels' axial momenta h_k = y[8 + k] along their axes (body axes)."""
    l0 = 0.0
    l1 = 0.0
    l2 = 0.0
    for k in range(int(sc[SC.NW])):
        b = SC.WHEELS + k * WHEEL.SIZE
        h = y[8 + k]
        l0 += h * sc[b]
        l1 += h * sc[b + 1]
        l2 += h * sc[b + 2]
    return l0, l1, l2


@jit(inline="always")
def state_rate(sc, y):
    """(g, ω) of the state ``y`` = (q, Q, h): g = ½ vec(q̃∘Q), ω = M (g − ℓ)."""
    w = conj_mul((y[0], y[1], y[2], y[3]), (y[4], y[5], y[6], y[7]))
    g = (0.5 * w[1], 0.5 * w[2], 0.5 * w[3])
    l0, l1, l2 = wheel_momentum_sum(sc, y)
    return g, body_rate(sc, g[0], g[1], g[2], l0, l1, l2)


@jit(inline="always")
def wheel_speed(sc, b, h, om):
    """Ω = h/J − a·ω: the wheel's speed relative to the body."""
    return h * sc[b + WHEEL.INVJ] - (sc[b] * om[0] + sc[b + 1] * om[1] + sc[b + 2] * om[2])


@jit
def wheel_friction(sc, b, Om):
    """Friction torque on the wheel (N m, along its axis): minus Basilisk's ``frictionForce``.

    Coulomb + viscous, f = sign(Ω) f_c + c_v Ω; in the Stribeck regime
    f = √(2e) (f_s − f_c) exp(−(Ω/β)²/2) Ω/(β√2) + f_c tanh(10 Ω/β) + c_v Ω
    (Basilisk ``reactionWheelStateEffector.cpp``, ``updateContributions``); below the
    limit-cycle speed ω_lc, f is linear in Ω through its value at ω_lc.
    """
    if sc[b + WHEEL.FRICTION] == 0.0:
        return 0.0
    fc = sc[b + WHEEL.FC]
    cv = sc[b + WHEEL.CV]
    lc = sc[b + WHEEL.LC]
    a = abs(Om)
    stribeck = sc[b + WHEEL.STRIBECK] != 0.0
    if a < lc:
        f = (sc[b + WHEEL.SLOPE_S] if stribeck else sc[b + WHEEL.SLOPE_C]) * Om
    elif stribeck:
        beta = sc[b + WHEEL.BETA]
        x = Om / beta
        f = (
            _SQRT2E_OVER_SQRT2 * (sc[b + WHEEL.FS] - fc) * math.exp(-0.5 * x * x) * x
            + fc * math.tanh(10.0 * x)
            + cv * Om
        )
    else:
        s = 1.0 if Om > 0.0 else (-1.0 if Om < 0.0 else 0.0)
        f = s * fc + cv * Om
    return -f


@jit(inline="always")
def actuator_torque(sc, q, t):
    """External torque of the actuators in force (body axes): the thrusters' held torque, the
    ideal control torque, and the magnetorquers' m × B_B (Wertz 1978, Sect. 17.2.3), B_B
    from the field table at t."""
    t0 = sc[SC.TAU] + sc[SC.IDEAL]
    t1 = sc[SC.TAU + 1] + sc[SC.IDEAL + 1]
    t2 = sc[SC.TAU + 2] + sc[SC.IDEAL + 2]
    o = int(sc[SC.MTQ])
    if o >= 0:
        bb = field_body(q, t, sc, o)
        k = o + DIPOLE.VEC
        c = cross((sc[k], sc[k + 1], sc[k + 2]), bb)
        t0 += c[0]
        t1 += c[1]
        t2 += c[2]
    return t0, t1, t2


@jit(inline="always")
def _stribeck_regime(st, Om, om_before, lc):
    """1 when the wheel is (still) in Basilisk's Stribeck regime at Ω, else 0 (its
    ``updateContributions`` test: entered below 0.1 ω_lc, kept while Ω moves away from zero)."""
    if abs(Om) < 0.1 * lc:
        st = 1.0
    d = Om - om_before
    s_om = 1.0 if Om > 0.0 else (-1.0 if Om < 0.0 else 0.0)
    s_d = 1.0 if d > 0.0 else (-1.0 if d < 0.0 else 0.0)
    if not (st == 1.0 and abs(s_om - s_d) < 2.0):
        st = 0.0
    return st


@jit
def configure_hold(sc, y, cmd, t_hold, t_next):
    """Apply the raw commands ``cmd`` (wheel torques, dipoles, thrust on-time fractions, in
    that order) for the hold [t_hold, t_next) from the state ``y`` at ``t_hold``.

    Wheels, as Basilisk's ``ConfigureRWRequests``: the torque clipped to ±max_torque, zero
    below min_torque, clipped to max_power/|Ω|, and cut to zero when |Ω| >= max_speed and the
    command would spin the wheel further (Ω u >= 0); the friction regime decided from Ω and
    the Ω of the previous boundary (Basilisk's ``frictionStribeck`` test). Magnetorquers: the
    dipole clipped to ±max_dipole. Thrusters: the on-time fraction clipped to [0, 1], times
    the hold's length; an on-time below the thruster's shortest is dropped. Writes the held
    slots of ``sc``.
    """
    _, om = state_rate(sc, y)
    configure_hold_rate(sc, y, om, cmd, t_hold, t_next)


@jit
def configure_hold_rate(sc, y, om, cmd, t_hold, t_next):
    """:func:`configure_hold` with the body rate ω of ``y`` already known (the flight
    software's tick has it from its sensing)."""
    nw = int(sc[SC.NW])
    for k in range(nw):
        b = SC.WHEELS + k * WHEEL.SIZE
        Om = wheel_speed(sc, b, y[8 + k], om)
        u = cmd[k]
        flags = 0
        umax = sc[b + WHEEL.UMAX]
        if u > umax:
            u = umax
            flags |= FLAG_TORQUE
        elif u < -umax:
            u = -umax
            flags |= FLAG_TORQUE
        if abs(u) < sc[b + WHEEL.UMIN] and u != 0.0:
            u = 0.0
            flags |= FLAG_DEADBAND
        pmax = sc[b + WHEEL.PMAX]
        if abs(u * Om) >= pmax:
            u = math.copysign(pmax / abs(Om), u)
            flags |= FLAG_POWER
        if abs(Om) >= sc[b + WHEEL.OMAX]:
            flags |= FLAG_SPEED
            if Om * u >= 0.0:
                u = 0.0
        # Basilisk's Stribeck-regime test (updateContributions), at the boundary (never in
        # the regime without a Stribeck velocity β: the test's work skipped then)
        beta = sc[b + WHEEL.BETA]
        st = 0.0
        if beta > 0.0:
            st = _stribeck_regime(
                sc[b + WHEEL.STRIBECK], Om, sc[b + WHEEL.OMEGA_BEFORE], sc[b + WHEEL.LC]
            )
        sc[b + WHEEL.STRIBECK] = st
        sc[b + WHEEL.U] = u
        sc[b + WHEEL.UCMD] = cmd[k]
        sc[b + WHEEL.FLAGS] = flags
        sc[b + WHEEL.OMEGA_BEFORE] = Om
    nm = int(sc[SC.NM])
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    for j in range(nm):
        b = magnetorquer_base(sc, j)
        m = cmd[nw + j]
        mx = sc[b + MTQ.MAX]
        sc[b + MTQ.CMD] = m
        m = min(max(m, -mx), mx)
        sc[b + MTQ.APPLIED] = m
        m0 += m * sc[b + MTQ.AXIS]
        m1 += m * sc[b + MTQ.AXIS + 1]
        m2 += m * sc[b + MTQ.AXIS + 2]
    o = int(sc[SC.MTQ])
    if o >= 0:
        sc[o + DIPOLE.VEC] = m0
        sc[o + DIPOLE.VEC + 1] = m1
        sc[o + DIPOLE.VEC + 2] = m2
    if sc[SC.NT] == 0.0:  # SC.TAU stays zero: nothing to do a hold (5 % of a 10 Hz sensor tick;
        return  # the thrusters' work comes last: add what every hold needs above this line)
    nt = int(sc[SC.NT])
    span = t_next - t_hold
    for j in range(nt):
        b = thruster_base(sc, j)
        f = cmd[nw + nm + j]
        sc[b + THR.CMD] = f
        f = min(max(f, 0.0), 1.0)
        on = f * span
        if on < sc[b + THR.MIN_ON]:
            on = 0.0
        sc[b + THR.ON] = on
        sc[b + THR.OFF_AT] = t_hold + on
        sc[b + THR.FIRING] = 1.0 if on > 0.0 else 0.0
    thrusters_update(sc)


@jit
def thrusters_update(sc):
    """The held thruster torque, force (body axes) and mass flow from the thrusters firing
    (THR.FIRING). The force and the mass flow act on a coupled orbit
    (:mod:`attitude._core.coupled`); on a given orbit they are only recorded."""
    a0 = a1 = a2 = 0.0
    f0 = f1 = f2 = 0.0
    md = 0.0
    for j in range(int(sc[SC.NT])):
        b = thruster_base(sc, j)
        if sc[b + THR.FIRING] != 0.0:
            fm = sc[b + THR.FMAX]
            a0 += fm * sc[b + THR.ARM]
            a1 += fm * sc[b + THR.ARM + 1]
            a2 += fm * sc[b + THR.ARM + 2]
            f0 += fm * sc[b + THR.DIR]
            f1 += fm * sc[b + THR.DIR + 1]
            f2 += fm * sc[b + THR.DIR + 2]
            md += sc[b + THR.MDOT]
    sc[SC.TAU] = a0
    sc[SC.TAU + 1] = a1
    sc[SC.TAU + 2] = a2
    sc[SC.FORCE] = f0
    sc[SC.FORCE + 1] = f1
    sc[SC.FORCE + 2] = f2
    sc[SC.MDOT] = md


@jit
def next_thruster_off(sc, t, t_next):
    """The earliest time after ``t`` and before ``t_next`` a firing thruster turns off
    (``t_next`` if none)."""
    te = t_next
    for j in range(int(sc[SC.NT])):
        b = thruster_base(sc, j)
        if sc[b + THR.FIRING] != 0.0:
            off = sc[b + THR.OFF_AT]
            if t < off < te:
                te = off
    return te


@jit
def thrusters_off_at(sc, t):
    """Turn off the thrusters whose on-time ends at or before ``t``; True if any did."""
    changed = False
    for j in range(int(sc[SC.NT])):
        b = thruster_base(sc, j)
        if sc[b + THR.FIRING] != 0.0 and sc[b + THR.OFF_AT] <= t:
            sc[b + THR.FIRING] = 0.0
            changed = True
    if changed:
        thrusters_update(sc)
    return changed

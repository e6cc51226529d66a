"""Compiled kernels of the actuators: the spacecraft block, wheel friction, command limits.

A spacecraft with actuators (:class:`attitude.Spacecraft`) is described to compiled code by one
float64 array ``sc``, the *spacecraft block*, beside the model's ``params``
(:mod:`attitude._core.potentials`). Its numbers are constant during a run, except the slots
marked (held): those hold the commands in force, written at every hold boundary by
:func:`configure_hold` (zero-order hold: constant until the next boundary). Layout::

    sc[S_NW], sc[S_NM], sc[S_NT]   numbers of wheels, magnetorquers, thrusters
    sc[S_MINV : +9]                M = Ĩ⁻¹, Ĩ = I − Σ J_k a_k a_kᵀ (row-major, body axes)
    sc[S_TAU : +3]                 (held) the thrusters' torque about the centre of mass (N m)
    sc[S_MTQ]                      offset of the magnetic-field block (−1: no magnetorquers)
    sc[S_IDEAL : +3]               (held) an ideal control torque (N m, body axes): the flight
                                   software's request on a spacecraft without actuators
    sc[S_WHEELS]...                n_w wheel records of WS numbers (W_* fields)
    then                           n_m magnetorquer records of MS numbers (M_* fields)
    then                           n_t thruster records of TS numbers (T_* fields)
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

from orbit._shared_jit import jit

from .environment import M_VEC, field_body
from .quat import conj_mul, cross

# Header of the spacecraft block.
S_NW = 0
S_NM = 1
S_NT = 2
S_MINV = 3
S_TAU = 12
S_MTQ = 15
S_IDEAL = 16
S_WHEELS = 19

# Wheel record (relative to its start).
W_AXIS = 0  # a (3), unit, body axes
W_J = 3  # axial inertia J (kg m²)
W_INVJ = 4  # 1/J
W_U = 5  # (held) applied motor torque u (N m)
W_STRIBECK = 6  # (held) 1: the Stribeck friction regime, 0: Coulomb + viscous
W_FC = 7  # Coulomb friction torque (N m)
W_FS = 8  # static friction torque (N m)
W_BETA = 9  # Stribeck speed β (rad/s; <= 0: no Stribeck regime)
W_CV = 10  # viscous friction coefficient (N m s)
W_LC = 11  # limit-cycle speed ω_lc (rad/s; friction linear in Ω below it; 0: none)
W_SLOPE_C = 12  # friction slope below ω_lc in the Coulomb regime, (f_c + c_v ω_lc)/ω_lc
W_SLOPE_S = 13  # the same in the Stribeck regime
W_UMAX = 14  # motor torque limit (N m; inf: none)
W_OMAX = 15  # speed limit (rad/s; inf: none)
W_UMIN = 16  # smallest torque applied (N m; below it the command is 0)
W_PMAX = 17  # motor power limit (W; inf: none)
W_UCMD = 18  # (held) the command as given (N m)
W_FLAGS = 19  # (held) limit flags of the hold (FLAG_* bits)
W_OMEGA_BEFORE = 20  # (held) Ω at the previous hold boundary (Basilisk's omegaBefore)
W_FRICTION = 21  # 1.0 if any friction term is non-zero (skip the kernel otherwise)
WS = 22

# Magnetorquer record.
M_AXIS = 0  # â (3)
M_MAX = 3  # largest dipole magnitude (A m²)
M_CMD = 4  # (held) commanded dipole (A m²)
M_APPLIED = 5  # (held) applied dipole, the command clipped to ±max
MS = 6

# Thruster record.
T_ARM = 0  # (r − r_cm) × d̂ (3, m): torque per newton
T_DIR = 3  # d̂ (3): force direction, body axes
T_FMAX = 6  # thrust (N)
T_MIN_ON = 7  # shortest on-time (s): shorter firings are dropped (minimum impulse bit / F)
T_CMD = 8  # (held) commanded on-time fraction of the hold
T_ON = 9  # (held) on-time from the hold's start (s)
T_OFF_AT = 10  # (held) the time the thruster turns off (t_hold + on-time)
T_FIRING = 11  # (held) 1.0 while firing in the current segment
TS = 12

# Limit flags of a wheel command (W_FLAGS), Basilisk's ConfigureRWRequests in this order.
FLAG_TORQUE = 1  # clipped to ±max_torque
FLAG_SPEED = 2  # at or past the speed limit: a command spinning it further was cut to 0
FLAG_POWER = 4  # clipped to max_power / |Ω|
FLAG_DEADBAND = 8  # below min_torque: 0

_SQRT2E_OVER_SQRT2 = math.sqrt(2.0 * math.e) / math.sqrt(2.0)


@jit(inline="always")
def wheel_base(sc, k):
    """Start of wheel ``k``'s record."""
    return S_WHEELS + k * WS


@jit(inline="always")
def magnetorquer_base(sc, j):
    """Start of magnetorquer ``j``'s record."""
    return S_WHEELS + int(sc[S_NW]) * WS + j * MS


@jit(inline="always")
def thruster_base(sc, j):
    """Start of thruster ``j``'s record."""
    return S_WHEELS + int(sc[S_NW]) * WS + int(sc[S_NM]) * MS + j * TS


@jit(inline="always")
def body_rate(sc, g0, g1, g2, l0, l1, l2):
    """ω = M (g − ℓ): the body angular velocity from the total body momentum g and the wheels'
    axial momenta ℓ = Σ h_k a_k."""
    d0 = g0 - l0
    d1 = g1 - l1
    d2 = g2 - l2
    m = S_MINV
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
    for k in range(int(sc[S_NW])):
        b = S_WHEELS + k * WS
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
    return h * sc[b + W_INVJ] - (sc[b] * om[0] + sc[b + 1] * om[1] + sc[b + 2] * om[2])


@jit
def wheel_friction(sc, b, Om):
    """Friction torque on the wheel (N m, along its axis): minus Basilisk's ``frictionForce``.

    Coulomb + viscous, f = sign(Ω) f_c + c_v Ω; in the Stribeck regime
    f = √(2e) (f_s − f_c) exp(−(Ω/β)²/2) Ω/(β√2) + f_c tanh(10 Ω/β) + c_v Ω
    (Basilisk ``reactionWheelStateEffector.cpp``, ``updateContributions``); below the
    limit-cycle speed ω_lc, f is linear in Ω through its value at ω_lc.
    """
    if sc[b + W_FRICTION] == 0.0:
        return 0.0
    fc = sc[b + W_FC]
    cv = sc[b + W_CV]
    lc = sc[b + W_LC]
    a = abs(Om)
    stribeck = sc[b + W_STRIBECK] != 0.0
    if a < lc:
        f = (sc[b + W_SLOPE_S] if stribeck else sc[b + W_SLOPE_C]) * Om
    elif stribeck:
        beta = sc[b + W_BETA]
        x = Om / beta
        f = (
            _SQRT2E_OVER_SQRT2 * (sc[b + W_FS] - fc) * math.exp(-0.5 * x * x) * x
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
    t0 = sc[S_TAU] + sc[S_IDEAL]
    t1 = sc[S_TAU + 1] + sc[S_IDEAL + 1]
    t2 = sc[S_TAU + 2] + sc[S_IDEAL + 2]
    o = int(sc[S_MTQ])
    if o >= 0:
        bb = field_body(q, t, sc, o)
        k = o + M_VEC
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
    nw = int(sc[S_NW])
    for k in range(nw):
        b = S_WHEELS + k * WS
        Om = wheel_speed(sc, b, y[8 + k], om)
        u = cmd[k]
        flags = 0
        umax = sc[b + W_UMAX]
        if u > umax:
            u = umax
            flags |= FLAG_TORQUE
        elif u < -umax:
            u = -umax
            flags |= FLAG_TORQUE
        if abs(u) < sc[b + W_UMIN] and u != 0.0:
            u = 0.0
            flags |= FLAG_DEADBAND
        pmax = sc[b + W_PMAX]
        if abs(u * Om) >= pmax:
            u = math.copysign(pmax / abs(Om), u)
            flags |= FLAG_POWER
        if abs(Om) >= sc[b + W_OMAX]:
            flags |= FLAG_SPEED
            if Om * u >= 0.0:
                u = 0.0
        # Basilisk's Stribeck-regime test (updateContributions), at the boundary (never in
        # the regime without a Stribeck velocity β: the test's work skipped then)
        beta = sc[b + W_BETA]
        st = 0.0
        if beta > 0.0:
            st = _stribeck_regime(sc[b + W_STRIBECK], Om, sc[b + W_OMEGA_BEFORE], sc[b + W_LC])
        sc[b + W_STRIBECK] = st
        sc[b + W_U] = u
        sc[b + W_UCMD] = cmd[k]
        sc[b + W_FLAGS] = flags
        sc[b + W_OMEGA_BEFORE] = Om
    nm = int(sc[S_NM])
    m0 = 0.0
    m1 = 0.0
    m2 = 0.0
    for j in range(nm):
        b = magnetorquer_base(sc, j)
        m = cmd[nw + j]
        mx = sc[b + M_MAX]
        sc[b + M_CMD] = m
        m = min(max(m, -mx), mx)
        sc[b + M_APPLIED] = m
        m0 += m * sc[b + M_AXIS]
        m1 += m * sc[b + M_AXIS + 1]
        m2 += m * sc[b + M_AXIS + 2]
    o = int(sc[S_MTQ])
    if o >= 0:
        sc[o + M_VEC] = m0
        sc[o + M_VEC + 1] = m1
        sc[o + M_VEC + 2] = m2
    if sc[S_NT] == 0.0:  # S_TAU stays zero: nothing to do a hold (5 % of a 10 Hz sensor tick;
        return  # the thrusters' work comes last: add what every hold needs above this line)
    nt = int(sc[S_NT])
    span = t_next - t_hold
    for j in range(nt):
        b = thruster_base(sc, j)
        f = cmd[nw + nm + j]
        sc[b + T_CMD] = f
        f = min(max(f, 0.0), 1.0)
        on = f * span
        if on < sc[b + T_MIN_ON]:
            on = 0.0
        sc[b + T_ON] = on
        sc[b + T_OFF_AT] = t_hold + on
        sc[b + T_FIRING] = 1.0 if on > 0.0 else 0.0
    thrusters_update(sc)


@jit
def thrusters_update(sc):
    """The held thruster torque from the thrusters firing (T_FIRING). (Their force moves no
    orbit here: the orbit is prescribed; each thruster's force is in the results.)"""
    a0 = a1 = a2 = 0.0
    for j in range(int(sc[S_NT])):
        b = thruster_base(sc, j)
        if sc[b + T_FIRING] != 0.0:
            fm = sc[b + T_FMAX]
            a0 += fm * sc[b + T_ARM]
            a1 += fm * sc[b + T_ARM + 1]
            a2 += fm * sc[b + T_ARM + 2]
    sc[S_TAU] = a0
    sc[S_TAU + 1] = a1
    sc[S_TAU + 2] = a2


@jit
def next_thruster_off(sc, t, t_next):
    """The earliest time after ``t`` and before ``t_next`` a firing thruster turns off
    (``t_next`` if none)."""
    te = t_next
    for j in range(int(sc[S_NT])):
        b = thruster_base(sc, j)
        if sc[b + T_FIRING] != 0.0:
            off = sc[b + T_OFF_AT]
            if t < off < te:
                te = off
    return te


@jit
def thrusters_off_at(sc, t):
    """Turn off the thrusters whose on-time ends at or before ``t``; True if any did."""
    changed = False
    for j in range(int(sc[S_NT])):
        b = thruster_base(sc, j)
        if sc[b + T_FIRING] != 0.0 and sc[b + T_OFF_AT] <= t:
            sc[b + T_FIRING] = 0.0
            changed = True
    if changed:
        thrusters_update(sc)
    return changed

"""Actuators (issue 24): the gyrostat in (q, Q, h) against conservation laws, closed forms, a
second formulation, and Basilisk's reaction-wheel effector (when ``bsk`` is installed)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import attitude
from attitude import canonical as C
from attitude import quaternion as qt
from attitude.actuators import (
    AxisNormalizedWarning,
    CommandSchedule,
    Magnetorquer,
    ReactionWheel,
    Thruster,
    pyramid,
)
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.spacecraft import Spacecraft

BODY = attitude.RigidBody([10.0, 12.0, 8.0], units="kg m2")
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])


def total_momenta(craft, q, omega, speeds=None):
    return C.momenta_from_angular_velocity(q, omega, craft, wheel_speeds=speeds)


# --- conservation -----------------------------------------------------------------------------


def test_pyramid_under_a_saturating_schedule_conserves_G_and_pays_the_motor_work():
    """Torque-free, four pyramid wheels, random commands beyond the torque limit and up to the
    speed limit: G constant over 1e4 s, |q| and q·Q invariant, and the energy changes by
    exactly the motor work Σ ∫ u_k Ω_k dt (composite Simpson over each hold)."""
    wheels = pyramid(0.05, max_torque=0.02, max_speed=80.0)
    craft = Spacecraft(BODY, wheels)
    rng = np.random.default_rng(7)
    hold = 2.0
    times = np.arange(0.0, 1e4, hold)
    cmd = rng.normal(0.0, 0.02, (times.size, 4)) + 0.01 * np.sign(np.sin(times / 900.0))[:, None]
    q0 = qt.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    Q0 = total_momenta(craft, q0, [0.01, -0.02, 0.015])
    t = np.arange(0.0, 1e4 + 1e-9, hold / 8)
    ds = attitude.propagate(
        craft, q0, Q0, t, rtol=1e-12, atol=1e-14, commands=CommandSchedule(times, cmd)
    )
    G = ds.G.values
    assert np.max(np.linalg.norm(G - G[0], axis=1)) / np.linalg.norm(G[0]) < 1e-10
    # |q| − 1 and q·Q drift as in a run of the rigid body alone (DOP853 is not symplectic)
    rigid = attitude.propagate(
        BODY,
        q0,
        C.momenta_from_angular_velocity(q0, [0.01, -0.02, 0.015], BODY),
        t,
        rtol=1e-12,
        atol=1e-14,
    )
    assert np.max(np.abs(ds.norm_error.values)) < 2 * np.max(np.abs(rigid.norm_error.values))
    assert np.max(np.abs(ds.qQ.values)) < 1e-13 * np.max(np.abs(ds.Q.values))
    lim = ds.wheel_limit.values
    assert (lim & 1).any() and (lim & 2).any()  # torque-limited and speed-limited holds
    u = ds.wheel_torque.values
    om = ds.wheel_speed.values
    simpson = np.array([1, 4, 2, 4, 2, 4, 2, 4, 1]) * (hold / 8) / 3  # composite, 8 panels
    work = sum(float(u[i] @ (simpson @ om[i : i + 9])) for i in range(0, t.size - 8, 8))
    dE = float(ds.energy[-1] - ds.energy[0])
    assert abs(dE - work) < 1e-7 * abs(work)
    # the torque budget: the wheels' torque is internal, the external total is zero
    assert list(ds.model_label.values) == ["torque_free", "wheels", "total"]
    assert np.all(ds.torque.sel(model=2).values == 0.0)


def test_speed_limit_cuts_commands_that_spin_the_wheel_further():
    """At a boundary with |Ω| >= max_speed, a command of the same sign as Ω is cut to 0 (flag
    speed_limit), one of the opposite sign is applied (Basilisk's ConfigureRWRequests)."""
    craft = Spacecraft(BODY, [ReactionWheel([0, 0, 1], 0.05, max_speed=10.0, speed=9.95)])
    times = np.arange(0.0, 20.0, 1.0)
    cmd = np.full((times.size, 1), 0.01)
    cmd[12:] = -0.01
    ds = attitude.propagate(
        craft, Q_ID, np.zeros(4), times, commands=CommandSchedule(times, cmd), rtol=1e-12
    )
    om = ds.wheel_speed.values[:, 0]
    lim = ds.wheel_limit.values[:, 0]
    applied = ds.wheel_torque.values[:, 0]
    for k in range(times.size):
        if abs(om[k]) >= 10.0 and om[k] * cmd[k, 0] >= 0:
            assert applied[k] == 0.0 and lim[k] & 2
        else:
            assert applied[k] == cmd[k, 0]
    assert (applied == 0.0).any() and applied[-1] == -0.01


# --- closed forms -------------------------------------------------------------------------------


def test_wheel_on_the_symmetry_axis_spun_up_by_a_constant_torque():
    """ω₃ = −u t / (I₃ − J), Ω = u t / J + u t / (I₃ − J) from rest (angular momentum 0)."""
    body = attitude.RigidBody([10.0, 10.0, 8.0], units="kg m2")
    J, u = 0.05, 0.01
    craft = Spacecraft(body, [ReactionWheel([0, 0, 1], J)])
    t = np.linspace(0.0, 100.0, 11)
    ds = attitude.propagate(
        craft,
        Q_ID,
        np.zeros(4),
        t,
        rtol=1e-12,
        atol=1e-15,
        commands=CommandSchedule([0.0], wheel_torque=[[u]]),
    )
    np.testing.assert_allclose(ds.omega.values[:, 2], -u * t / (8.0 - J), rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        ds.wheel_speed.values[:, 0], u * t / J + u * t / (8.0 - J), rtol=1e-13, atol=1e-13
    )
    # the motor's reaction on the body, −u along the wheel's axis (internal: the total is 0)
    labels = list(ds.model_label.values)
    np.testing.assert_array_equal(ds.torque.values[:, labels.index("wheels")], [[0, 0, -u]] * 11)
    assert np.all(ds.torque.values[:, labels.index("total")] == 0.0)
    # the attitude: a rotation about b3 by −u t² / (2 (I₃ − J))
    ang = -u * t**2 / (2 * (8.0 - J))
    ref = qt.from_rotation_vector(np.outer(ang, [0, 0, 1]))
    np.testing.assert_allclose(ds.q.values, ref, atol=1e-13)


def test_steady_spins_of_a_gyrostat_with_a_skew_rotor():
    """ω ∥ g is a relative equilibrium: for any λ, ω = −(Ĩ − λ 1)⁻¹ ℓ keeps constant (body
    axes) while ℓ = h a is constant (Hall 1995; Cochran, Shu & Rew 1982). A rotor on a skew
    axis makes Ĩ non-diagonal."""
    a = np.array([1.0, 2.0, 2.0]) / 3.0
    J = 0.2
    craft = Spacecraft(BODY, [ReactionWheel(a, J)])
    It = craft.locked_less_wheels()
    for lam, h in ((15.0, 0.3), (5.0, -0.4), (9.0, 0.2)):
        w = -np.linalg.solve(It - lam * np.eye(3), h * a)
        g = It @ w + h * a
        np.testing.assert_allclose(np.cross(g, w), 0.0, atol=1e-15)
        speed = h / J - a @ w  # h = J (a·ω + Ω)
        spun = craft.with_wheel_speeds([speed])
        Q0 = total_momenta(spun, Q_ID, w)
        t = np.linspace(0.0, 2000.0, 41)
        ds = attitude.propagate(spun, Q_ID, Q0, t, rtol=1e-13, atol=1e-16)
        np.testing.assert_allclose(ds.omega.values, np.broadcast_to(w, (41, 3)), atol=1e-12)
        np.testing.assert_allclose(ds.wheel_momentum.values[:, 0], h, rtol=1e-12)


@pytest.mark.parametrize("side", [0.8, 1.25])
def test_rotor_stabilised_spin_about_the_intermediate_axis(side):
    """Spin ν about the intermediate axis b3 with a rotor along it: linearised, ω̈₁ = −κ ω₁,
    κ = (H − I₂ν)(H − I₁ν)/(I₁I₂), H = I₃ν + JΩ (Hughes 1986, Ch. 6: a dual-spin body is
    directionally stable about the intermediate axis when its rotor momentum exceeds
    (I_max − I₃) ν). Below the boundary a nutation grows as cosh(√−κ t); above it oscillates
    at √κ: both against the closed form."""
    I1, I2, I3 = 12.0, 8.0, 10.0  # b3 intermediate
    body = attitude.RigidBody([I1, I2, I3], units="kg m2")
    J, nu = 0.05, 0.1
    Om_star = (I1 - I3) * nu / J  # the boundary H = I_max ν
    Om = side * Om_star
    craft = Spacecraft(body, [ReactionWheel([0, 0, 1], J, speed=Om)])
    H = I3 * nu + J * Om
    kappa = (H - I2 * nu) * (H - I1 * nu) / (I1 * I2)
    eps = 1e-7
    w0 = np.array([eps, 0.0, nu])
    Q0 = total_momenta(craft, Q_ID, w0)
    rate = math.sqrt(abs(kappa))
    t = np.linspace(0.0, 3.0 / rate, 301)
    ds = attitude.propagate(craft, Q_ID, Q0, t, rtol=1e-13, atol=1e-18)
    w1 = ds.omega.values[:, 0]
    ref = eps * (np.cosh(rate * t) if kappa < 0 else np.cos(rate * t))
    assert (kappa < 0) == (side < 1)
    np.testing.assert_allclose(w1, ref, rtol=0, atol=1e-4 * eps * np.max(np.abs(ref)) / eps)


# --- products of inertia: a second formulation in the structural frame ------------------------


def test_from_tensor_with_skew_wheels_against_euler_equations_in_the_structural_frame():
    """A tensor with products of inertia and three wheels on the structural axes: the run in
    principal axes (Spacecraft.from_tensor), turned back to the structural frame F, against
    the gyrostat's Euler equations integrated in F with the full tensor (scipy, independent):
    J ω̇ = −ω × (J ω + Σ J_k Ω_k a_k) − Σ a_k u_k, ... written with h_k."""
    Jt = np.array([[12.0, 0.6, -0.4], [0.6, 9.0, 0.3], [-0.4, 0.3, 7.0]])
    axes = np.eye(3)
    Jw = np.array([0.04, 0.05, 0.03])
    wheels = [ReactionWheel(axes[k], Jw[k], speed=50.0 * (k + 1)) for k in range(3)]
    craft, q_pf = Spacecraft.from_tensor(Jt, wheels, units="kg m2")
    times = np.arange(0.0, 200.0, 5.0)
    rng = np.random.default_rng(3)
    cmd = rng.normal(0, 0.005, (times.size, 3))
    w0_f = np.array([0.02, -0.01, 0.03])
    q_sf = qt.normalize(np.array([0.8, 0.2, -0.4, 0.3]))
    q_sp = qt.multiply(q_sf, q_pf)
    R = qt.to_matrix(q_pf)  # x_F = R x_P
    w0_p = R.T @ w0_f
    Q0 = total_momenta(craft, q_sp, w0_p)
    t = np.linspace(0.0, 200.0, 81)
    ds = attitude.propagate(
        craft, q_sp, Q0, t, rtol=1e-13, atol=1e-15, commands=CommandSchedule(times, cmd)
    )
    # reference in F: state (q_sf, ω_F, h)
    It = Jt - sum(Jw[k] * np.outer(axes[k], axes[k]) for k in range(3))
    h0 = Jw * (axes @ w0_f + np.array([50.0, 100.0, 150.0]))

    def rhs(tt, y):
        q, w, h = y[:4], y[4:7], y[7:]
        k = min(int(tt // 5.0), times.size - 1)
        u = cmd[k]
        g = It @ w + axes.T @ h
        wdot = np.linalg.solve(It, np.cross(g, w) - axes.T @ u)
        qdot = 0.5 * qt.multiply(q, np.concatenate([[0.0], w]))
        return np.concatenate([qdot, wdot, u])

    y = np.concatenate([q_sf, w0_f, h0])
    out = [y]
    for k in range(times.size):  # restart at every hold, as the commands jump there
        ta, tb = times[k], (times[k + 1] if k + 1 < times.size else 200.0)
        grid = t[(t > ta) & (t <= tb + 1e-12)]
        if tb <= ta:
            continue
        sol = solve_ivp(
            rhs, (ta, tb), y, method="DOP853", rtol=1e-13, atol=1e-15, t_eval=grid, first_step=None
        )
        for j in range(grid.size):
            out.append(sol.y[:, j])
        y = (
            sol.y[:, -1]
            if sol.t[-1] == tb
            else solve_ivp(rhs, (ta, tb), y, method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
        )
    ref = np.array(out)[: t.size]
    q_f = qt.multiply(ds.q.values, qt.conjugate(q_pf))
    np.testing.assert_allclose(
        q_f * np.sign(q_f[:, :1]), ref[:, :4] * np.sign(ref[:, :1]), atol=1e-10
    )
    np.testing.assert_allclose(ds.omega.values @ R.T, ref[:, 4:7], atol=1e-11)
    np.testing.assert_allclose(ds.wheel_momentum.values, ref[:, 7:], atol=1e-12)


# --- magnetorquers and thrusters ----------------------------------------------------------------


def test_magnetorquers_equal_a_magnetic_dipole_of_the_same_moment():
    """Three orthogonal rods commanded to a constant dipole m act as MagneticDipole(m): the
    same field tables, the same torque (a second model of the same physics)."""
    import orbit

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.7, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    m = np.array([0.05, -0.1, 0.08])
    rods = [Magnetorquer(np.eye(3)[k], 0.2) for k in range(3)]
    craft = Spacecraft(BODY, magnetorquers=rods, orbit=o)
    q0 = qt.normalize(np.array([0.7, 0.1, 0.5, -0.2]))
    Q0 = C.momenta_from_angular_velocity(q0, [0.01, 0.02, -0.01], BODY)
    t = np.linspace(0.0, 3000.0, 61)
    ds = attitude.propagate(
        craft, q0, Q0, t, rtol=1e-12, atol=1e-14, commands=CommandSchedule([0.0], dipole=[m])
    )
    ref = attitude.propagate(BODY, q0, Q0, t, attitude.MagneticDipole(o, m), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ds.q.values, ref.q.values, atol=1e-11)
    np.testing.assert_allclose(ds.dipole.values, np.broadcast_to(m, (61, 3)))
    np.testing.assert_allclose(
        ds.torque.sel(model=1).values, ref.torque.sel(model=0).values, atol=1e-15
    )
    # clipped to ±max_dipole
    ds2 = attitude.propagate(
        craft, q0, Q0, t[:3], commands=CommandSchedule([0.0], dipole=[[1, -1, 0]])
    )
    np.testing.assert_array_equal(ds2.dipole.values[0], [0.2, -0.2, 0.0])


@pytest.mark.parametrize("about", ["+b3", "-b2"])
def test_thruster_pair_pulse_against_the_closed_form(about):
    """A couple about a principal axis (b3; −b2, the torque's only non-zero component
    negative) fired for a fraction of a hold from rest: the body turns about that axis alone,
    G = τ t_on, angle ½ (τ/I) t² while firing, then linear; the force is recorded only while
    firing."""
    if about == "+b3":
        th = [Thruster([0.5, 0, 0], [0, 1, 0], 2.0), Thruster([-0.5, 0, 0], [0, -1, 0], 2.0)]
        axis, inertia = np.array([0.0, 0.0, 1.0]), 8.0
    else:  # (0.5 x) × (2 z) = −1 y, twice
        th = [Thruster([0.5, 0, 0], [0, 0, 1], 2.0), Thruster([-0.5, 0, 0], [0, 0, -1], 2.0)]
        axis, inertia = np.array([0.0, -1.0, 0.0]), 12.0
    craft = Spacecraft(BODY, thrusters=th)
    tau = 2.0 * 2.0 * 0.5  # two 2 N forces on 0.5 m arms
    t = np.linspace(0.0, 10.0, 101)
    ds = attitude.propagate(
        craft,
        Q_ID,
        np.zeros(4),
        t,
        rtol=1e-13,
        atol=1e-16,
        commands=CommandSchedule([0.0, 10.0], thrust=[[0.37, 0.37], [0, 0]]),
    )
    ton = 3.7
    G = tau * np.minimum(t, ton)
    np.testing.assert_allclose(ds.G.values, np.outer(G, axis), atol=1e-13)
    ang = np.where(
        t <= ton,
        0.5 * tau / inertia * t**2,
        0.5 * tau / inertia * ton**2 + tau * ton / inertia * (t - ton),
    )
    ref = qt.from_rotation_vector(np.outer(ang, axis))
    np.testing.assert_allclose(ds.q.values, ref, atol=1e-12)
    firing = t < ton
    np.testing.assert_array_equal(ds.thruster_force.values[:, 0], np.where(firing, 2.0, 0.0))
    # the thrusters' torque on the body while firing, the external total the same
    labels = list(ds.model_label.values)
    want = np.where(firing[:, None], tau * axis, 0.0)
    for name in ("thrusters", "total"):
        got = ds.torque.values[:, labels.index(name)]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    # a minimum impulse bit drops shorter firings
    th2 = [Thruster([0.5, 0, 0], [0, 1, 0], 2.0, min_impulse_bit=8.0)]
    ds2 = attitude.propagate(
        Spacecraft(BODY, thrusters=th2),
        Q_ID,
        np.zeros(4),
        t,
        commands=CommandSchedule([0.0], thrust=[[0.37]]),
    )
    assert np.all(ds2.G.values == 0.0)


# --- friction --------------------------------------------------------------------------------


def _basilisk_friction(om, fc, fs, beta, cv, lc, stribeck):
    """Basilisk's frictionForce (reactionWheelStateEffector.cpp), written out again."""

    def f(w):
        if stribeck:
            return (
                math.sqrt(2 * math.e)
                * (fs - fc)
                * math.exp(-((w / beta) ** 2) / 2)
                * w
                / (beta * math.sqrt(2))
                + fc * math.tanh(w * 10 / beta)
                + cv * w
            )
        return np.sign(w) * fc + cv * w

    out = f(om)
    if abs(om) < lc:
        out = (f(lc) if stribeck else fc + cv * lc) / lc * om
    return -out


@pytest.mark.parametrize("stribeck", [False, True])
def test_friction_kernel_is_basilisks_law(stribeck):
    w = ReactionWheel(
        [1, 0, 0],
        0.1,
        coulomb_friction=5e-4,
        static_friction=8e-4,
        stribeck_speed=0.5,
        viscous_friction=2e-6,
        limit_cycle_speed=0.01,
    )
    om = np.array([-300.0, -1.0, -0.3, -0.011, -0.005, 0.0, 1e-5, 0.004, 0.02, 0.7, 2.0, 500.0])
    ours = w.friction(om, stribeck=stribeck)
    ref = [_basilisk_friction(x, 5e-4, 8e-4, 0.5, 2e-6, 0.01, stribeck) for x in om]
    np.testing.assert_allclose(ours, ref, rtol=1e-14, atol=1e-20)


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_coulomb_friction_stops_a_wheel_through_the_kink_at_the_closed_form_time(method):
    """Coulomb friction decelerates a free wheel at the constant rate f_c (1/J + 1/Ĩ₃) down to
    the limit-cycle speed, then, linear below it, exponentially: both phases against the
    closed form, across the kink (taylor cuts its step at the kink: round-off; dop853's error
    control steps across it)."""
    J, fc, lc = 0.05, 1e-3, 1e-3
    body = attitude.RigidBody([10.0, 10.0, 8.0], units="kg m2")
    wheel = ReactionWheel([0, 0, 1], J, speed=2.0, coulomb_friction=fc, limit_cycle_speed=lc)
    craft = Spacecraft(body, [wheel])
    # body + wheel about b3, no external torque: ḣ = f, g3 = 0 → ω3 = −h/Ĩ3, Ω = h (1/J + 1/Ĩ3)
    k = 1 / J + 1 / (8.0 - J)
    rate = fc * k
    t_lc = (2.0 - lc) / rate
    t = np.linspace(0.0, t_lc + 5.0 / ((fc / lc) * k), 201)
    Q0 = total_momenta(craft, Q_ID, np.zeros(3))
    ds = attitude.propagate(craft, Q_ID, Q0, t, method=method, rtol=1e-13, atol=1e-16)
    ref = np.where(
        t <= t_lc, 2.0 - rate * t, lc * np.exp(-(fc / lc) * k * np.maximum(t - t_lc, 0.0))
    )
    tol = 1e-13 if method == "taylor" else 1e-9
    np.testing.assert_allclose(ds.wheel_speed.values[:, 0], ref, rtol=0, atol=tol)
    np.testing.assert_allclose(
        ds.wheel_friction.values[:, 0], -np.minimum(fc, fc / lc * ref), rtol=0, atol=tol * fc / lc
    )


def test_stribeck_regime_of_a_wheel_let_go_below_a_tenth_of_the_limit_cycle_speed():
    """Basilisk's regime test at each hold boundary: Stribeck while |Ω| < ω_lc/10 and Ω moves
    away from rest (sign Ω = sign ΔΩ, or ΔΩ = 0 at the first boundary), else Coulomb. A free
    wheel let go at Ω₀ = ω_lc/20 decays, linear below ω_lc, as Ω₀ exp(−s k t) with
    k = 1/J + 1/(I₃ − J): the Stribeck slope s = f_S(ω_lc)/ω_lc over the first hold, the
    Coulomb slope (f_c + c_v ω_lc)/ω_lc from the second boundary on (ΔΩ < 0 there); let go
    at 0.15 ω_lc, Coulomb throughout. The slopes from Basilisk's friction law written out here."""
    J, fc, fs, beta, cv, lc = 0.05, 5e-4, 8e-4, 0.5, 2e-6, 0.01
    body = attitude.RigidBody([10.0, 10.0, 8.0], units="kg m2")
    k = 1 / J + 1 / (8.0 - J)
    s_s = -_basilisk_friction(lc, fc, fs, beta, cv, lc, True) / lc
    s_c = -_basilisk_friction(lc, fc, fs, beta, cv, lc, False) / lc
    assert abs(s_s - s_c) > 0.5 * s_s
    t = np.linspace(0.0, 8.0, 81)
    hold = 2.0
    for w0, first in ((lc / 20, s_s), (0.15 * lc, s_c)):
        wheel = ReactionWheel(
            [0, 0, 1], J, speed=w0, coulomb_friction=fc, static_friction=fs,
            stribeck_speed=beta, viscous_friction=cv, limit_cycle_speed=lc,
        )  # fmt: skip
        craft = Spacecraft(body, [wheel])
        ds = attitude.propagate(
            craft, Q_ID, total_momenta(craft, Q_ID, np.zeros(3)), t, rtol=1e-13, atol=1e-18,
            commands=CommandSchedule(np.arange(4) * hold, np.zeros((4, 1))),
        )  # fmt: skip
        w1 = w0 * math.exp(-first * k * hold)
        ref = np.where(t <= hold, w0 * np.exp(-first * k * t), w1 * np.exp(-s_c * k * (t - hold)))
        np.testing.assert_allclose(ds.wheel_speed.values[:, 0], ref, rtol=1e-10, atol=0)


@pytest.mark.parametrize("potential", ["torque_free", "gravity_gradient"])
def test_taylor_equals_dop853_with_wheels_and_thrusters(potential):
    """The two integrators of a spacecraft agree to their tolerance under the same schedule
    (pyramid wheels, a thruster, viscous friction), and against a tight DOP853 reference."""
    import orbit

    pot = None
    if potential == "gravity_gradient":
        pot = attitude.GravityGradient(orbit.KeplerOrbit(7000.0, 0.1, 0.5, 0.2, 0.1, f0=0.0))
    wheels = pyramid(0.05, max_torque=0.02, max_speed=80.0, viscous_friction=1e-5)
    craft = Spacecraft(BODY, wheels, thrusters=[Thruster([0.5, 0, 0], [0, 1, 0], 0.01)])
    rng = np.random.default_rng(7)
    times = np.arange(0.0, 2000.0, 2.0)
    sched = CommandSchedule(
        times, rng.normal(0, 0.02, (times.size, 4)), thrust=rng.uniform(0, 1, (times.size, 1))
    )
    q0 = qt.normalize(np.array([0.9, 0.1, -0.3, 0.2]))
    Q0 = total_momenta(craft, q0, [0.01, -0.02, 0.015])
    t = np.linspace(0.0, 2000.0, 401)
    run = {
        m: attitude.propagate(craft, q0, Q0, t, pot, method=m, rtol=rt, atol=1e-15, commands=sched)
        for m, rt in (("taylor", 1e-12), ("dop853", 1e-14))
    }
    a, b = run["taylor"], run["dop853"]
    assert np.max(np.abs(a.q.values - b.q.values)) < 1e-9
    assert np.max(np.abs(a.wheel_speed.values - b.wheel_speed.values)) < 1e-10
    assert np.max(np.abs(a.omega.values - b.omega.values)) < 1e-10 * np.max(np.abs(b.omega.values))
    # q·Q = c to round-off (Q is rebuilt from q and g)
    assert np.max(np.abs(a.qQ.values)) < 1e-15 * np.max(np.abs(a.Q.values)) * 10
    G = a.G.values
    # G changes only by the thruster's angular impulse: compare with dop853's G
    np.testing.assert_allclose(G, b.G.values, atol=1e-11 * np.max(np.abs(G)))


def test_taylor_order_follows_the_hold():
    """At a 10 Hz hold the step is the hold, at an order far below rtol's (Jorba & Zou)."""
    craft = Spacecraft(BODY, pyramid(0.05))
    times = np.arange(0.0, 100.0, 0.1)
    sched = CommandSchedule(times, 0.01 * np.ones((times.size, 4)))
    Q0 = total_momenta(craft, Q_ID, [0.01, 0.02, 0.03])
    ds = attitude.propagate(
        craft, Q_ID, Q0, np.linspace(0, 100, 11), method="taylor", rtol=1e-12, commands=sched
    )
    assert ds.attrs["n_steps"] == times.size
    assert ds.attrs["n_series_terms"] <= 8 * times.size <= 0.6 * ds.attrs["order"] * times.size


def test_taylor_order_stops_where_the_rest_is_below_round_off():
    """The order test of the held steps (taylor_gyrostat.order_enough). Its cases: terms
    falling by 1e-3 an order stop once the next one's estimate is below ROUNDOFF S, one order
    before two terms below tolerance would; a series whose odd terms vanish (a start from rest:
    q's terms 1, 0, αd²/4, 0, α²d⁴/32) does not stop at a zero term. In a run: 10 Hz holds of
    random wheel torques from rest (the first hold is that even series) at rtol 1e-12 are the
    same run at rtol 1e-15 (orders higher) to round-off, at a lower mean order."""
    from attitude._core.taylor_gyrostat import ROUNDOFF, order_enough

    enough = order_enough.py_func
    tol, ro = 1e-13, ROUNDOFF
    t = [1e-3**k for k in range(8)]  # S = 1
    stop = next(k for k in range(2, 8) if enough(t[k], t[k - 1], t[k - 2], tol, ro))
    two = next(k for k in range(2, 8) if t[k] <= tol and t[k - 1] <= tol)
    assert t[stop] ** 2 / t[stop - 1] <= ro < t[stop - 1] ** 2 / t[stop - 2]
    assert stop == two - 1
    a = 1e-2  # αd²
    even = [1.0, 0.0, a / 4, 0.0, a * a / 32, 0.0, a**3 / 384, 0.0]
    assert not enough(even[3], even[2], even[1], tol, ro)
    assert not enough(even[4], even[3], even[2], tol, ro)  # a²/32 > tol

    # a 0.1 kg m² body under wheel torques of 0.01 N m: ~1 rad/s² from rest, so the first
    # hold's series is 1, 0, ~2e-3, 0, ~2e-7 (stopping at its zero misses 1.5e-7)
    small = attitude.RigidBody([0.1, 0.12, 0.08], units="kg m2")
    craft = Spacecraft(small, pyramid(1e-4))
    times = np.arange(0.0, 300.0, 0.1)
    rng = np.random.default_rng(11)
    sched = CommandSchedule(times, rng.normal(0.0, 0.01, (times.size, 4)))
    Q0 = total_momenta(craft, Q_ID, [0.0, 0.0, 0.0])

    def run(t_end, method, rtol):
        return attitude.propagate(craft, Q_ID, Q0, np.linspace(0.0, t_end, 11), method=method,
                                  rtol=rtol, atol=1e-30, commands=sched)  # fmt: skip

    a, b = run(1.0, "taylor", 1e-12), run(1.0, "dop853", 1e-14)
    assert np.max(np.abs(a.q.values - b.q.values)) < 1e-13
    a, b = run(300.0, "taylor", 1e-12), run(300.0, "taylor", 1e-15)
    assert np.max(np.abs(a.q.values - b.q.values)) < 1e-14
    assert np.max(np.abs(a.wheel_speed.values - b.wheel_speed.values)) < 1e-12
    order = [r.attrs["n_series_terms"] / r.attrs["n_steps"] for r in (a, b)]
    assert order[0] < order[1]


# --- bad input ----------------------------------------------------------------------------------


def test_bad_actuators_and_schedules_are_refused_before_any_work():
    with pytest.raises(AttitudeValueError, match="axis"):
        ReactionWheel([0, 0, 0], 0.1)
    with pytest.warns(AxisNormalizedWarning):
        w = ReactionWheel([0, 0, 2.0], 0.1)
    assert np.allclose(w.axis, [0, 0, 1])
    for bad in (
        {"max_torque": 0.0},
        {"max_speed": -1.0},
        {"coulomb_friction": -1e-3},
        {"max_power": 0.0},
    ):
        with pytest.raises(AttitudeValueError, match=next(iter(bad))):
            ReactionWheel([1, 0, 0], 0.1, **bad)
    with pytest.raises(AttitudeValueError, match="inertia"):
        ReactionWheel([1, 0, 0], -0.1)
    with pytest.raises(AttitudeValueError, match="positive definite"):
        Spacecraft(BODY, [ReactionWheel([0, 0, 1], 9.0)])
    with pytest.raises(AttitudeTypeError, match="wheels"):
        Spacecraft(BODY, ["wheel"])
    with pytest.raises(AttitudeValueError, match="orbit"):
        Spacecraft(BODY, magnetorquers=[Magnetorquer([1, 0, 0], 0.1)])
    with pytest.raises(AttitudeValueError, match="increasing"):
        CommandSchedule([0.0, 2.0, 1.0], wheel_torque=np.zeros((3, 1)))
    with pytest.raises(AttitudeValueError, match="thrust"):
        CommandSchedule([0.0], thrust=[[1.5]])
    craft = Spacecraft(BODY, pyramid(0.05))
    t = np.linspace(0, 10, 3)
    with pytest.raises(AttitudeValueError, match="4 wheels"):
        attitude.propagate(
            craft,
            Q_ID,
            np.zeros(4),
            t,
            commands=CommandSchedule([0.0], wheel_torque=[[0.1, 0.1, 0.1]]),
        )
    with pytest.raises(AttitudeValueError, match="no magnetorquers"):
        attitude.propagate(
            craft, Q_ID, np.zeros(4), t, commands=CommandSchedule([0.0], dipole=[[0.1]])
        )
    with pytest.raises(AttitudeValueError, match="commands"):
        attitude.propagate(BODY, Q_ID, np.zeros(4), t, commands=CommandSchedule([0.0]))
    for method in ("exact", "splitting", "nosquish", "scipy:RK45"):
        with pytest.raises(AttitudeValueError, match="method"):
            attitude.propagate(craft, Q_ID, np.zeros(4), t, method=method)


def test_command_schedule_from_csv(tmp_path):
    p = tmp_path / "cmd.csv"
    p.write_text(
        "# a schedule\ntime,wheel_torque_1,wheel_torque_2,dipole_1\n0,0.1,0.2,0.01\n5,-0.1,0,0.02\n"
    )
    s = CommandSchedule.from_csv(p)
    np.testing.assert_array_equal(s.times, [0.0, 5.0])
    np.testing.assert_array_equal(s.wheel_torque, [[0.1, 0.2], [-0.1, 0.0]])
    np.testing.assert_array_equal(s.dipole, [[0.01], [0.02]])
    p.write_text("time,wheel_torque_2\n0,1\n")
    with pytest.raises(AttitudeValueError, match="without gaps"):
        CommandSchedule.from_csv(p)


# --- Basilisk -------------------------------------------------------------------------------------


def test_open_loop_wheels_against_basilisk():
    """Basilisk's reaction-wheel effector (balanced wheels, RK4 at the command period, and at
    half and a quarter of it) under the same open-loop schedule on a fast-spinning light
    body: our run agrees with each Basilisk run to within that run's own step-halving
    change (Richardson: |B(h) − B(h/2)| · 16/15 bounds B(h)'s error)."""
    pytest.importorskip("Basilisk")
    import basilisk_reference as br

    I = np.diag([12.0, 10.0, 8.0])
    axes = qt.to_matrix(qt.normalize(np.array([0.9, 0.2, 0.3, -0.1])))
    Js = np.array([0.05, 0.04, 0.06])
    W0 = np.array([100.0, -50.0, 200.0])
    hold, K = 0.5, 120
    rng = np.random.default_rng(11)
    cmd = 0.02 * rng.normal(size=(K, 3))
    wheels = [dict(axis=axes[:, k], Js=Js[k], Omega=W0[k]) for k in range(3)]
    sigma0 = np.array([0.1, 0.2, -0.3])
    omega0 = np.array([0.3, -0.4, 0.5])
    refs = {
        dt: br.rw_open_loop(I, wheels, sigma0, omega0, hold, cmd, dt)
        for dt in (hold, hold / 2, hold / 4)
    }
    craft = Spacecraft(
        attitude.RigidBody(np.diag(I), units="kg m2"),
        [ReactionWheel(axes[:, k], Js[k], speed=W0[k]) for k in range(3)],
    )
    q0 = br.mrp_to_quaternion(sigma0)
    Q0 = total_momenta(craft, q0, omega0)
    t = refs[hold]["t"]
    ds = attitude.propagate(
        craft, q0, Q0, t, rtol=1e-13, atol=1e-15, commands=CommandSchedule(np.arange(K) * hold, cmd)
    )

    def diff(a, b):
        qa, qb = br.mrp_to_quaternion(a["sigma"]), br.mrp_to_quaternion(b["sigma"])
        return (
            qt.angle_between(qa, qb).max(),
            np.abs(a["omega"] - b["omega"]).max(),
            np.abs(a["Omega"] - b["Omega"]).max(),
        )

    ours = {
        "sigma": qt.to_mrp(ds.q.values),
        "omega": ds.omega.values,
        "Omega": ds.wheel_speed.values,
    }
    for h in (hold, hold / 2):
        step = diff(refs[h], refs[h / 2])
        err = diff(ours, refs[h])
        assert step[0] > 1e-9  # Basilisk's discretisation is visible here
        for e, s in zip(err, step, strict=True):
            assert e <= 16 / 15 * s * 1.05 + 1e-13
    # the applied torques: Basilisk records at t_k the command of the hold ending there
    np.testing.assert_allclose(refs[hold]["u"][1:], ds.wheel_torque.values[:-1], atol=0)


#: Wheel limit and friction cases against Basilisk (ReactionWheel keywords, Basilisk's
#: RWConfigPayload fields, commands, initial speeds): docs/actuators.md shows the table.
BASILISK_CASES = {
    "torque limit": (dict(max_torque=0.2), dict(u_max=0.2), "random", [10.0, -20.0, 30.0]),
    "speed limit": (dict(max_speed=40.0), dict(Omega_max=40.0), "push", [30.0, -35.0, 38.0]),
    "power limit": (dict(max_power=2.0), dict(P_max=2.0), "random", [100.0, -50.0, 20.0]),
    "dead band": (dict(min_torque=0.1), dict(u_min=0.1), "half", [10.0, -20.0, 30.0]),
    "Coulomb + viscous": (
        dict(coulomb_friction=5e-3, viscous_friction=1e-4, limit_cycle_speed=0.05),
        dict(fCoulomb=5e-3, cViscous=1e-4, omegaLimitCycle=0.05),
        "small",
        [1.0, -0.5, 0.2],
    ),
    "Stribeck from rest": (
        dict(
            coulomb_friction=5e-3, static_friction=8e-3, stribeck_speed=0.5, viscous_friction=1e-4
        ),
        dict(fCoulomb=5e-3, fStatic=8e-3, betaStatic=0.5, cViscous=1e-4),
        "constant",
        [0.0, 0.0, 0.0],
    ),
}


def basilisk_case(name, K=1000, hold=0.1, refine=(1, 16)):
    """(our run, {k: Basilisk at step hold/k}) of one case of BASILISK_CASES."""
    import basilisk_reference as br

    ours_kw, bsk_kw, kind, W0 = BASILISK_CASES[name]
    rng = np.random.default_rng(5)
    cmd = {
        "random": 0.3 * rng.normal(size=(K, 3)),
        "half": 0.15 * rng.normal(size=(K, 3)),
        "small": 0.01 * rng.normal(size=(K, 3)),
        "push": np.full((K, 3), 0.05) * np.sign(W0),
        "constant": np.full((K, 3), 0.02),
    }[kind]
    I = np.diag([12.0, 10.0, 8.0])
    axes = np.eye(3)
    sigma0, omega0 = np.array([0.1, 0.2, -0.3]), np.array([0.01, -0.02, 0.03])
    bsk = [dict(axis=axes[:, k], Js=0.05, Omega=W0[k], **bsk_kw) for k in range(3)]
    refs = {k: br.rw_open_loop(I, bsk, sigma0, omega0, hold, cmd, hold / k) for k in refine}
    craft = Spacecraft(
        attitude.RigidBody(np.diag(I), units="kg m2"),
        [ReactionWheel(axes[:, k], 0.05, speed=W0[k], **ours_kw) for k in range(3)],
    )
    q0 = br.mrp_to_quaternion(sigma0)
    ds = attitude.propagate(
        craft,
        q0,
        total_momenta(craft, q0, omega0),
        refs[1]["t"],
        rtol=1e-13,
        atol=1e-15,
        commands=CommandSchedule(np.arange(K) * hold, cmd),
    )
    return ds, refs


@pytest.mark.parametrize("name", list(BASILISK_CASES))
def test_wheel_limits_and_friction_against_basilisk(name):
    """Basilisk at the command period applies the same torques (the same limits decided at
    the same ticks); refined 16 times it converges towards our run (its RK4 error, first order
    across friction kinks). Limits are re-decided at Basilisk's dynamics rate, so for the
    speed and power limits only the run at the command period is the same model."""
    pytest.importorskip("Basilisk")
    import basilisk_reference as br

    ds, refs = basilisk_case(name)
    np.testing.assert_allclose(ds.wheel_torque.values[:-1], refs[1]["u"][1:], rtol=0, atol=1e-8)

    def err(r):
        return (
            np.abs(ds.wheel_speed.values - r["Omega"]).max(),
            qt.angle_between(ds.q.values, br.mrp_to_quaternion(r["sigma"])).max(),
        )

    e1, e16 = err(refs[1]), err(refs[16])
    if name in ("speed limit", "power limit"):
        assert e1[0] < 1e-5 and e1[1] < 1e-5
    else:
        assert e16[0] < e1[0] / 10 and e16[1] < e1[1] / 10


# --- scenarios --------------------------------------------------------------------------------

SCENARIO = """
[body]
inertia = [900.0, 800.0, 600.0]
inertia_unit = "kg m2"
[[spacecraft.wheels]]
axis = [1.0, 0.0, 0.0]
inertia = 0.0796
inertia_unit = "kg m2"
max_torque = 0.2
max_torque_unit = "N m"
max_speed = 6000
max_speed_unit = "cycle/min"
speed = 100
speed_unit = "cycle/min"
coulomb_friction = 0.5
coulomb_friction_unit = "mN m"
[[spacecraft.wheels]]
axis = [0.0, 1.0, 0.0]
inertia = 0.0796
inertia_unit = "kg m2"
[[spacecraft.thrusters]]
position = [0.0, 0.5, 0.0]
position_unit = "m"
direction = [0.0, 0.0, 1.0]
max_thrust = 1.0
max_thrust_unit = "N"
COMMANDS
[initial_state]
form = "body_rates"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.001, -0.01, 0.03]
omega_unit = "rad/s"
[time]
start = 0.0
stop = 60.0
step = 1.0
unit = "s"
"""
INLINE = """[commands]
times = [0.0, 10.0, 20.0]
times_unit = "s"
wheel_torque = [[100.0, -100.0], [0.0, 50.0], [-100.0, 0.0]]
wheel_torque_unit = "mN m"
thrust = [[0.5], [0.0], [0.25]]
"""


def test_scenario_actuators_and_commands_inline_and_from_csv(tmp_path):
    """[[spacecraft.wheels]], [[spacecraft.thrusters]] and [commands] (inline, and a CSV file
    beside the scenario) run the same as the library calls."""
    from astropy import units as u

    from attitude.scenario import load, loads

    sc = loads(SCENARIO.replace("COMMANDS", INLINE))
    ds = sc.run()
    w = [
        ReactionWheel(
            [1, 0, 0],
            0.0796,
            max_torque=0.2,
            max_speed=6000 * u.cycle / u.min,
            speed=100 * u.cycle / u.min,
            coulomb_friction=5e-4,
        ),
        ReactionWheel([0, 1, 0], 0.0796),
    ]
    craft = Spacecraft(
        attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2"),
        w,
        thrusters=[Thruster([0, 0.5, 0], [0, 0, 1], 1.0)],
    )
    sched = CommandSchedule(
        [0.0, 10.0, 20.0], [[0.1, -0.1], [0.0, 0.05], [-0.1, 0.0]], thrust=[[0.5], [0.0], [0.25]]
    )
    ref = attitude.propagate(
        craft,
        Q_ID,
        total_momenta(craft, Q_ID, [0.001, -0.01, 0.03]),
        np.arange(61.0),
        commands=sched,
    )
    np.testing.assert_array_equal(ds.q.values, ref.q.values)
    np.testing.assert_array_equal(ds.wheel_speed.values, ref.wheel_speed.values)
    (tmp_path / "cmd.csv").write_text(
        "time,wheel_torque_1,wheel_torque_2,thrust_1\n0,0.1,-0.1,0.5\n10,0,0.05,0\n20,-0.1,0,0.25\n"
    )
    (tmp_path / "s.toml").write_text(SCENARIO.replace("COMMANDS", '[commands]\nfile = "cmd.csv"'))
    ds2 = load(tmp_path / "s.toml").run()
    np.testing.assert_array_equal(ds2.q.values, ref.q.values)


@pytest.mark.parametrize(
    ("change", "key"),
    [
        (("max_torque = 0.2", "max_torqe = 0.2"), "spacecraft.wheels[0].max_torqe"),
        (("max_torque = 0.2", "max_torque = -0.2"), "max_torque"),
        (("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]"), "spacecraft.wheels[1].axis"),
        (("thrust = [[0.5], [0.0], [0.25]]", "thrust = [[1.5], [0.0], [0.25]]"), "thrust"),
        (("times = [0.0, 10.0, 20.0]", "times = [0.0, 30.0, 20.0]"), "times"),
        (("[[-100.0, 0.0]]", "[[-100.0, 0.0, 1.0]]"), "commands.wheel_torque"),
    ],
)
def test_scenario_actuator_errors_name_the_key(change, key):
    from attitude.scenario import ScenarioError, loads

    text = SCENARIO.replace("COMMANDS", INLINE)
    old, new = change
    if old == "[[-100.0, 0.0]]":
        text = text.replace("[-100.0, 0.0]]", "[-100.0, 0.0, 1.0]]")
    else:
        assert old in text
        text = text.replace(old, new, 1)
    with pytest.raises(ScenarioError, match=key.replace("[", r"\[").replace("]", r"\]")):
        loads(text)


def test_models_keep_read_only_copies_and_leave_the_callers_arrays_writable():
    """CommandSchedule, RigidBody, Thruster and Spacecraft(center_of_mass) freeze their own
    copies: a caller's float64 arrays (often the run's own times) were made read-only by them
    before, which also compiled the drivers again for read-only arguments."""
    times = np.array([0.0, 1.0, 2.0])
    torque = np.zeros((3, 1))
    inertia = np.array([3.0, 4.0, 5.0])
    pos = np.array([0.1, 0.0, 0.0])
    cm = np.array([0.0, 0.01, 0.0])
    sched = attitude.CommandSchedule(times, wheel_torque=torque)
    body = attitude.RigidBody(inertia)
    thr = Thruster(pos, [0.0, 1.0, 0.0], 1.0)
    craft = attitude.Spacecraft(body, thrusters=[thr], center_of_mass=cm)
    for a in (times, torque, inertia, pos, cm):
        assert a.flags.writeable
    for a in (sched.times, sched.wheel_torque, body.inertia, thr.position, craft.center_of_mass):
        assert not a.flags.writeable
    times[1] = 7.0  # the schedule keeps what it was given
    assert sched.times[1] == 1.0

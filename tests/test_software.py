"""Flight software in the loop (issue 25): Basilisk's reaction-wheel scenario, linear control
theory, B-dot detumbling, conservation, modes, slews, delay, your own step function."""

from __future__ import annotations

import math

import astropy.units as u
import numpy as np
import pytest
from scipy.linalg import expm

import attitude
from attitude import canonical as C
from attitude import frames
from attitude import quaternion as qt
from attitude.actuators import Magnetorquer, ReactionWheel, pyramid
from attitude.control import BDot, MRPFeedback, QuaternionFeedback, RateDamping, WheelAllocation
from attitude.errors import AttitudeTypeError, AttitudeValueError, PropagationError
from attitude.software import FlightSoftware, Mode, RateBelow, Slew

RPM = 2 * np.pi / 60


def hr16_spacecraft():
    """scenarioAttitudeFeedbackRW's spacecraft: 900/800/600 kg m², three HR16 wheels (50 N m s,
    6000 rpm, 0.2 N m) on the body axes at 100, 200, 300 rpm."""
    body = attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2")
    js = 50.0 / (6000 * RPM)
    wheels = [
        ReactionWheel(
            np.eye(3)[k], js, speed=[100, 200, 300][k] * RPM, max_torque=0.2, max_speed=6000 * RPM
        )
        for k in range(3)
    ]
    return attitude.Spacecraft(body, wheels)


def test_reaction_wheel_scenario_against_basilisk():
    """Basilisk's scenarioAttitudeFeedbackRW (mrpFeedback K = 3.5, P = 30; rwMotorTorque;
    0.1 s, 600 s): attitude and wheel speeds at every tick agree with Basilisk's converged
    run (its dynamics at 0.025 s, software at 0.1 s) to near round-off, far below its own
    step-halving change at 0.1 s; the commands and the saturated ticks are the same."""
    pytest.importorskip("Basilisk")
    import basilisk_reference as br

    ref = br.rw_feedback_scenario(0.1, 600.0)
    fine = br.rw_feedback_scenario(0.1, 600.0, dyn_dt=0.025)
    half = br.rw_feedback_scenario(0.1, 600.0, dyn_dt=0.05)
    craft = hr16_spacecraft()
    q0 = br.mrp_to_quaternion([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    fsw = FlightSoftware(0.1, guidance=frames.inertial(), control=MRPFeedback(3.5, 30.0))
    halving = qt.angle_between(
        br.mrp_to_quaternion(ref["sigma"]), br.mrp_to_quaternion(half["sigma"])
    ).max()
    for method in ("dop853", "taylor"):
        ds = attitude.propagate(
            craft, q0, Q0, ref["t"], software=fsw, method=method, rtol=1e-13, atol=1e-15
        )
        att = qt.angle_between(ds.q.values, br.mrp_to_quaternion(fine["sigma"])).max()
        assert att < 2e-14 and att < halving / 5
        np.testing.assert_allclose(ds.wheel_speed.values, fine["Omega"], rtol=0, atol=5e-12)
        np.testing.assert_allclose(
            ds.command_sent.values, ref["u"][: ds.sizes["tick"]], rtol=0, atol=1e-12
        )
        sat = np.abs(ds.command_sent.values) > 0.2
        np.testing.assert_array_equal(sat, np.abs(ref["u"][: ds.sizes["tick"]]) > 0.2)
        assert sat.sum() > 1000  # the scenario saturates for minutes


def _axis_run(period, K, P, theta0, t_end, I3=10.0, method="auto"):
    """A rotation about the principal axis b3 under MRPFeedback with an ideal torque."""
    body = attitude.RigidBody([12.0, 11.0, I3], units="kg m2")
    q0 = qt.from_rotation_vector([0.0, 0.0, theta0])
    Q0 = C.momenta_from_angular_velocity(q0, [0.0, 0.0, 0.0], body)
    fsw = FlightSoftware(period, guidance=frames.inertial(), control=MRPFeedback(K, P))
    t = np.arange(0.0, t_end + 1e-9, period)
    ds = attitude.propagate(body, q0, Q0, t, software=fsw, method=method, rtol=1e-13, atol=1e-16)
    theta = qt.to_rotation_vector(ds.q.values)[:, 2]
    return t, theta, ds


def test_fast_pd_control_matches_the_second_order_response():
    """σ = tan(θ/4) ≈ θ/4: I θ̈ + P θ̇ + (K/4) θ = 0, ω_n = √(K/(4I)), ζ = P/(2√(IK/4)). At a
    tick 1/5000 of the natural period (the hold lags by half a tick: ω_n T/2 = 6e-4) the
    response, its frequency and its overshoot match to 1e-3 (small angle: θ0 = 1e-3 rad)."""
    I3, K, P = 10.0, 4.0, 1.2
    wn = math.sqrt(K / (4 * I3))
    zeta = P / (2 * math.sqrt(I3 * K / 4))
    wd = wn * math.sqrt(1 - zeta**2)
    th0 = 1e-3
    t, th, _ = _axis_run(2 * math.pi / wn / 5000, K, P, th0, 2.5 * 2 * math.pi / wd, I3)
    ref = (
        th0
        * np.exp(-zeta * wn * t)
        * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    )
    assert np.max(np.abs(th - ref)) < 1e-3 * th0
    overshoot = -th.min() / th0
    assert abs(overshoot - math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2))) < 1e-3
    # the time of the first minimum: half a damped period
    assert abs(t[np.argmin(th)] - math.pi / wd) < 1e-3 * math.pi / wd + t[1]


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_slow_pd_control_is_the_exact_zero_order_hold_discretisation(method):
    """At a slow tick the samples follow x_{k+1} = Φ x_k + Γ u_k of the linearised plant
    (Φ = e^{AT}, Γ = ∫ e^{As} ds B), u_k = −(K/4) θ_k − P θ̇_k: the hold, not the continuous law.
    Both methods apply the ideal control torque ("auto" picks taylor here)."""
    I3, K, P, T = 10.0, 4.0, 1.2, 2.0
    th0 = 1e-3
    t, th, ds = _axis_run(T, K, P, th0, 200.0, I3, method)
    assert ds.attrs["method"] == method
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([0.0, 1.0 / I3])
    Phi = expm(A * T)
    Gam = np.array([T**2 / (2 * I3), T / I3])
    x = np.array([th0, 0.0])
    xs = [x]
    for _ in range(t.size - 1):
        u = -(K / 4) * x[0] - P * x[1]
        x = Phi @ x + Gam * u
        xs.append(x)
    xs = np.array(xs)
    assert np.max(np.abs(th - xs[:, 0])) < 1e-3 * th0
    np.testing.assert_allclose(ds.omega.values[:, 2], xs[:, 1], rtol=0, atol=1e-3 * th0 / T)
    _ = B


def test_wheels_alone_in_closed_loop_conserve_G_to_round_off():
    """A pyramid under MRP feedback tracking LVLH-free inertial pointing, no environment: the
    total angular momentum G is unchanged by the loop (internal torques only)."""
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    craft = attitude.Spacecraft(
        body,
        pyramid(0.02, max_torque=0.05, max_speed=600.0),
    )
    q0 = qt.normalize([0.7, 0.3, -0.5, 0.4])
    Q0 = C.momenta_from_angular_velocity(q0, [0.05, -0.03, 0.02], craft)
    fsw = FlightSoftware(
        0.5,
        guidance=frames.inertial(),
        control=MRPFeedback(0.5, 4.0),
        allocation=WheelAllocation(null_gain=0.05),
    )
    t = np.linspace(0.0, 600.0, 601)
    for method in ("dop853", "taylor"):
        ds = attitude.propagate(
            craft, q0, Q0, t, software=fsw, method=method, rtol=1e-13, atol=1e-15
        )
        G = ds.G.values
        assert np.max(np.linalg.norm(G - G[0], axis=1)) < 1e-12 * np.linalg.norm(G[0])
        assert ds.error_angle.values[-1] < 1e-3  # and it points


def test_null_space_management_spreads_the_momentum_without_a_body_torque():
    """With the pyramid's null-space term the wheel speeds converge to the minimum-norm
    distribution (orthogonal to the null space), and the attitude is the same as without it."""
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    wheels = pyramid(0.02, speeds=[150.0, 50.0, 100.0, 0.0])
    craft = attitude.Spacecraft(body, wheels)
    Q0 = C.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.0, 0.0, 0.0], craft)
    t = np.linspace(0.0, 300.0, 31)

    def run(kn):
        fsw = FlightSoftware(
            0.5,
            guidance=frames.inertial(),
            control=MRPFeedback(0.5, 4.0),
            allocation=WheelAllocation(null_gain=kn),
        )
        return attitude.propagate(craft, [1.0, 0, 0, 0], Q0, t, software=fsw, rtol=1e-13)

    a, b = run(0.0), run(0.1)
    np.testing.assert_allclose(a.q.values, b.q.values, atol=1e-10)
    G = craft.wheel_axes.T
    N = np.eye(4) - np.linalg.pinv(G) @ G
    # the null-space component of the momenta decays as exp(−k t); without it, it stays
    assert np.linalg.norm(N @ b.wheel_momentum.values[-1]) < 1e-10 * np.linalg.norm(
        N @ a.wheel_momentum.values[-1]
    )


def test_bdot_detumbles_the_cubesat_to_twice_the_orbital_rate():
    """The 3U CubeSat from its TLE with three 0.2 A m² rods and the normalized B-dot law at
    Avanzini & Giulietti's gain, 10°/s: the quarter-orbit mean of |ω| falls at every quarter
    until it is below 0.5°/s, within 1.5 orbits, and settles near 2 n (Stickler & Alfriend
    1976: the body follows the field, which turns twice per orbit). With the sign flipped
    (your own step function), the same run does not detumble."""
    import orbit

    tle = (
        "1 40027U PLANET   20053.08335648  .00000000  00000+0  34079-4 0    09",
        "2 40027 097.9376 341.9424 0011991 325.7224 261.4362 14.90036668    06",
    )
    o = orbit.EphemerisOrbit.from_tle(*tle, start="2020-02-22T02:00:00", stop="2020-02-22T06:00:00")
    body = attitude.RigidBody([0.04343, 0.04177, 0.009], units="kg m2")
    rods = [Magnetorquer(np.eye(3)[k], 0.2) for k in range(3)]
    craft = attitude.Spacecraft(body, magnetorquers=rods, orbit=o)
    k = BDot.optimal_gain(o, body)
    w0 = np.array([6.0, -4.8, 6.4]) / np.linalg.norm([6.0, -4.8, 6.4]) * np.radians(10.0)
    Q0 = C.momenta_from_angular_velocity([1.0, 0, 0, 0], w0, craft)
    period = 5800.0
    n = 2 * np.pi / period
    t = np.arange(0.0, 2.0 * period, 20.0)
    fsw = FlightSoftware(1.0, control=BDot(k, normalized=True), record_every=60)
    ds = attitude.propagate(craft, [1.0, 0, 0, 0], Q0, t, software=fsw, rtol=1e-10)
    w = np.linalg.norm(ds.omega.values, axis=1)
    q = t.size // 8
    means = [w[i * q : (i + 1) * q].mean() for i in range(8)]
    below = np.argmax(np.array(means) < math.radians(0.5))
    assert below > 0 and all(means[i + 1] < means[i] for i in range(below))
    assert t[np.argmax(w < math.radians(0.5))] < 1.5 * period
    assert 1.5 * n < np.mean(w[-q:]) < 3.0 * n

    def flipped(tt, m):
        # the same law with the sign flipped: m = +(k/|B|) ḃ
        b = m.field / np.linalg.norm(m.field)
        prev = flipped.prev
        flipped.prev = (b, np.linalg.norm(m.field))
        if prev is None:
            return {"dipole": np.zeros(3)}
        return {"dipole": +k / np.linalg.norm(m.field) * (b - prev[0]) / 1.0}

    flipped.prev = None
    bad = attitude.propagate(
        craft,
        [1.0, 0, 0, 0],
        Q0,
        t[t <= 0.5 * period],
        software=FlightSoftware(1.0, control=flipped),
        rtol=1e-10,
    )
    assert np.linalg.norm(bad.omega.values[-1]) > w0.dot(w0) ** 0.5 * 0.8


def test_your_own_step_function_equals_the_compiled_law():
    """The MRP law written in Python as a step function gives the compiled run's results; the
    measurements are those of the state at the tick."""
    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    t = np.linspace(0.0, 20.0, 21)
    law = FlightSoftware(0.1, guidance=frames.inertial(), control=MRPFeedback(3.5, 30.0))
    a = attitude.propagate(craft, q0, Q0, t, software=law, rtol=1e-13)
    I = np.diag([900.0, 800.0, 600.0])
    G = np.eye(3)
    js = craft.wheel_inertias

    def step(tt, m):
        w = m.omega
        h = js * (G.T @ w + m.wheel_speeds)
        Lr = 3.5 * m.sigma_error + 30.0 * m.omega_error
        Lr = Lr - np.cross(m.omega_ref, I @ w + G @ h) + I @ np.cross(w, m.omega_ref)
        return np.linalg.solve(G @ G.T, G).T @ Lr  # u = −G⁺(−Lr)

    b = attitude.propagate(
        craft, q0, Q0, t, software=FlightSoftware(0.1, frames.inertial(), step), rtol=1e-13
    )
    np.testing.assert_allclose(b.q.values, a.q.values, atol=1e-13)
    np.testing.assert_allclose(b.command_sent.values, a.command_sent.values, atol=1e-12)


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_a_compiled_step_equals_the_compiled_law(method):
    """The same law as a numba function step(t, m) (tests/compiled_steps.py) gives the built-in
    law's run."""
    import compiled_steps as cs

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    t = np.linspace(0.0, 20.0, 21)
    law = FlightSoftware(0.1, guidance=frames.inertial(), control=MRPFeedback(3.5, 30.0))
    a = attitude.propagate(craft, q0, Q0, t, software=law, rtol=1e-13, method=method)
    fsw = FlightSoftware(0.1, frames.inertial(), cs.mrp_feedback)
    assert "compiled mrp_feedback" in fsw.describe()
    b = attitude.propagate(craft, q0, Q0, t, software=fsw, rtol=1e-13, method=method)
    np.testing.assert_allclose(b.q.values, a.q.values, atol=1e-13)
    np.testing.assert_allclose(b.wheel_speed.values, a.wheel_speed.values, atol=1e-10)
    np.testing.assert_allclose(b.command_sent.values, a.command_sent.values, atol=1e-12)


# (taylor: slow. Each step function compiles the method's whole closed-loop driver again in its
# own module, ~10 s of a fresh cache a step; the run stops on the step's refused commands in
# the method-independent loop of attitude._holds, reached from the Taylor driver by the same
# boundary status as its full tick records: test_sparse_tick_records_are_the_dense_ones_
# subsampled[taylor]; and test_a_compiled_step_equals_the_compiled_law[taylor] runs a compiled
# step in the Taylor driver.)
@pytest.mark.parametrize("method", ["dop853", pytest.param("taylor", marks=pytest.mark.slow)])
def test_a_compiled_step_with_bad_commands_stops_the_run_at_its_tick(method):
    """Commands of the wrong length or non-finite from a compiled step stop the run with the
    tick named, keeping the samples before it."""
    import compiled_steps as cs

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    t = np.linspace(0.0, 20.0, 21)
    fsw = FlightSoftware(0.1, control=cs.fails_in_time)  # five values from t = 3 s
    with pytest.raises(PropagationError, match=r"compiled step .* tick 0 .* returned 5 values"):
        attitude.propagate(craft, q0, Q0, 3.0 + t, software=fsw, method=method)
    with pytest.raises(PropagationError, match=r"tick 20 \(t = 2.0 s\).*non-finite") as exc:
        attitude.propagate(craft, q0, Q0, t, software=fsw, method=method)  # NaN from t = 2 s
    assert exc.value.partial.sizes["time"] == 2  # t = 0, 1 s: the samples before the tick


def test_your_own_step_sees_what_the_sensors_and_the_estimator_give():
    """With a gyro, a star tracker and the MEKF, the measurements of your own step are the
    estimate (attitude, bias-corrected gyro rate), taken once per tick: the MRP law written in
    Python gives the compiled law's run with the same seeds."""
    from attitude.estimation import MEKF
    from attitude.sensors import Gyro, StarTracker

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.02, -0.01, 0.03])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, 0.0, -0.002], craft)
    t = np.linspace(0.0, 30.0, 7)

    def sensors():
        gyro = Gyro(0.05 * u.deg / u.hour**0.5, 2e-9 * u.rad / u.s**1.5, bias=[2e-5, -1e-5, 0],
                    seed=3)  # fmt: skip
        return [gyro, StarTracker([6 * u.arcsec, 45 * u.arcsec], [0.0, 0.6, 0.8], seed=4)]

    def fsw(control):
        return FlightSoftware(0.5, frames.inertial(), control, sensors=sensors(),
                              estimator=MEKF(), record_every=1)  # fmt: skip

    a = attitude.propagate(craft, q0, Q0, t, software=fsw(MRPFeedback(3.5, 30.0)), rtol=1e-12)
    I = np.diag([900.0, 800.0, 600.0])
    js = craft.wheel_inertias
    seen = []

    def step(tt, m):
        seen.append((m.q, m.omega))
        w = m.omega
        h = js * (w + m.wheel_speeds)
        lr = 3.5 * m.sigma_error + 30.0 * m.omega_error
        return lr - np.cross(m.omega_ref, I @ w + h) + I @ np.cross(w, m.omega_ref)

    b = attitude.propagate(craft, q0, Q0, t, software=fsw(step), rtol=1e-12)
    np.testing.assert_allclose(b.q.values, a.q.values, atol=1e-12)
    np.testing.assert_array_equal(b.gyro_rate.values, a.gyro_rate.values)
    qs = np.array([s[0] for s in seen])
    ws = np.array([s[1] for s in seen])
    ok = ~np.isnan(b.estimate_q.values[:, 0])
    np.testing.assert_allclose(qs[ok], b.estimate_q.values[ok], atol=1e-15)
    np.testing.assert_allclose(
        ws[ok], b.gyro_rate.values[ok] - b.bias_estimate.values[ok], atol=1e-18
    )


def test_a_step_function_that_raises_keeps_the_samples_computed():
    body = attitude.RigidBody([1.0, 2.0, 3.0], units="kg m2")
    t = np.linspace(0.0, 10.0, 11)

    def step(tt, m):
        if tt >= 4.0:
            raise RuntimeError("sensor fault")
        return np.zeros(3)

    with pytest.raises(PropagationError, match=r"tick 8 \(t = 4.0 s\).*sensor fault") as exc:
        attitude.propagate(
            body, [1.0, 0, 0, 0], np.zeros(4), t, software=FlightSoftware(0.5, control=step)
        )
    assert exc.value.partial.sizes["time"] == 4  # the samples before the failing tick

    def wrong(tt, m):
        return np.zeros(5)

    # commands that cannot be applied stop the run as an exception does (issue 39)
    with pytest.raises(PropagationError, match=r"tick 0 .*returned shape \(5,\)") as exc:
        attitude.propagate(
            body, [1.0, 0, 0, 0], np.zeros(4), t, software=FlightSoftware(0.5, control=wrong)
        )
    assert exc.value.partial is not None


def test_modes_delay_and_slew():
    """Rate damping until |ω| < 0.5°/s, then a slew onto an offset frame at ≤ 1°/s and
    0.05°/s²; the mode switches at the first tick below the threshold; the slew's reference
    rate never exceeds its limit and the spacecraft ends on the target. With delay = 1 the
    applied command is the one sent a tick earlier."""
    craft = attitude.Spacecraft(
        attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2"), pyramid(0.05, max_torque=0.1)
    )
    target = frames.inertial().offset(qt.from_euler([0.6, -0.3, 1.2], "321"))
    Q0 = C.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.02, 0.01, -0.015], craft)
    fsw = FlightSoftware(
        0.5,
        modes=[
            (None, Mode(control=RateDamping(2.0), name="damp")),
            (
                RateBelow(math.radians(0.5)),
                Mode(
                    Slew(target, math.radians(1.0), math.radians(0.05)),
                    QuaternionFeedback(2.0, 6.0),
                    name="slew",
                ),
            ),
        ],
        delay=1,
    )
    t = np.linspace(0.0, 400.0, 801)
    ds = attitude.propagate(craft, [1.0, 0, 0, 0], Q0, t, software=fsw, rtol=1e-12)
    mode = ds["mode"].values
    w = np.linalg.norm(ds.rate_error.values + 0, axis=1)
    first = int(np.argmax(mode == 1))
    assert mode[first - 1] == 0 and np.all(mode[first:] == 1)
    wt = np.linalg.norm(ds.omega.values, axis=1)
    k = int(np.argmin(np.abs(t - ds.tick.values[first])))
    assert wt[k] < math.radians(0.5) and wt[k - 1] >= math.radians(0.5) - 1e-12
    np.testing.assert_array_equal(ds.command_applied.values[1:], ds.command_sent.values[:-1])
    err = qt.angle_between(ds.q.values[-1], target.quaternion(400.0))
    assert err < math.radians(0.05)
    _ = w


def test_bad_software_is_refused_before_any_work():
    body = attitude.RigidBody([1.0, 2.0, 3.0], units="kg m2")
    t = np.linspace(0.0, 1.0, 3)
    with pytest.raises(AttitudeValueError, match="period"):
        FlightSoftware(0.0)
    with pytest.raises(AttitudeValueError, match="period"):
        FlightSoftware(-1.0)
    with pytest.raises(AttitudeValueError, match="magnetorquers"):
        attitude.propagate(
            body, [1.0, 0, 0, 0], np.zeros(4), t, software=FlightSoftware(0.1, control=BDot(1.0))
        )
    with pytest.raises(AttitudeValueError, match="P"):
        MRPFeedback(1.0, [[1.0, 2.0]])
    with pytest.raises(AttitudeValueError, match="K"):
        MRPFeedback(-1.0, 1.0)
    with pytest.raises(AttitudeTypeError, match="control"):
        FlightSoftware(1.0, control="pd")
    with pytest.raises(AttitudeValueError, match=r"delay|integer"):
        FlightSoftware(1.0, delay=-1)
    craft = attitude.Spacecraft(body, pyramid(0.01))
    with pytest.raises(AttitudeValueError, match="commands"):
        attitude.propagate(
            craft,
            [1.0, 0, 0, 0],
            np.zeros(4),
            t,
            software=FlightSoftware(1.0),
            commands=attitude.CommandSchedule([0.0], np.zeros((1, 4))),
        )


def test_momentum_dumping_unloads_the_wheels_at_its_gain():
    """Inertial pointing in a constant field (space axes): B_B is constant, the attitude loop
    holds the body, and the cross-product law's torque −k Δh⊥ takes the wheel momentum
    perpendicular to B out at the rate k, exp(−k t), leaving the parallel part."""
    from attitude.control import MomentumDumping

    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    rods = [Magnetorquer(np.eye(3)[k], 1000.0) for k in range(3)]  # never saturated here
    craft = attitude.Spacecraft(body, pyramid(0.02, speeds=[150.0, 50.0, 100.0, 0.0]), rods,
                                field=[2e-5, -1e-5, 3e-5])  # fmt: skip
    Q0 = C.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.0, 0.0, 0.0], craft)
    k = 1e-3
    fsw = FlightSoftware(0.5, frames.inertial(), (MRPFeedback(1.0, 10.0), MomentumDumping(k)))
    t = np.linspace(0.0, 3000.0, 31)
    ds = attitude.propagate(craft, [1.0, 0, 0, 0], Q0, t, software=fsw, rtol=1e-12)
    hw = ds.wheel_momentum.values @ craft.wheel_axes  # body axes
    b = np.array([2e-5, -1e-5, 3e-5]) / np.linalg.norm([2e-5, -1e-5, 3e-5])
    par = hw @ b
    perp = np.linalg.norm(hw - np.outer(par, b), axis=1)
    np.testing.assert_allclose(par, par[0], rtol=1e-3)
    np.testing.assert_allclose(perp, perp[0] * np.exp(-k * t), rtol=0.01)
    assert perp[-1] < 0.1 * perp[0]


def test_your_own_step_measures_against_closed_forms_and_astropys_sun():
    """What your own step sees, on a sphere spinning at a constant rate (torque-free, the
    rods' dipole zero) on a circular orbit with LVLH guidance, against independent truth at
    every tick: q = q0∘exp(ω t/2) and ω (closed form); r and v on the circle
    r = a (cos u P + sin u Q), u = ω_p + n t; the LVLH reference's axes (x along track, y = −ĥ,
    z to nadir) and rate n ĥ; σ_BR, the MRP of q_R⁻¹∘q (shorter rotation); ω − ω_R; the Sun's
    direction from astropy and the field of the dipole model, in body axes."""
    import orbit
    from orbit.sun import sun_position

    a, inc, raan, argp = 7000.0, 0.9, 0.4, 0.3
    o = orbit.KeplerOrbit(a, 0.0, inc, raan, argp, f0=0.0, epoch="2024-03-20T12:00:00")
    rods = [Magnetorquer(np.eye(3)[k], 0.2) for k in range(3)]
    craft = attitude.Spacecraft(
        attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2"), magnetorquers=rods, orbit=o
    )
    w = np.array([0.01, -0.02, 0.015])
    q0 = qt.normalize([0.8, 0.3, -0.2, 0.4])
    seen = []

    def step(tt, m):
        seen.append(m)
        return {"dipole": np.zeros(3)}

    fsw = FlightSoftware(10.0, frames.lvlh(o), step)
    Q0 = C.momenta_from_angular_velocity(q0, w, craft)
    attitude.propagate(craft, q0, Q0, [0.0, 600.0], software=fsw, rtol=1e-13)
    t = np.array([m.t for m in seen])
    np.testing.assert_array_equal(t, 10.0 * np.arange(t.size))
    assert t.size >= 60

    def stack(name):
        return np.array([getattr(m, name) for m in seen])

    q = qt.multiply(q0, qt.from_rotation_vector(w[None, :] * t[:, None]))
    np.testing.assert_allclose(qt.to_matrix(stack("q")), qt.to_matrix(q), rtol=0, atol=1e-11)
    np.testing.assert_allclose(stack("omega"), np.broadcast_to(w, (t.size, 3)), atol=1e-14)
    n = math.sqrt(o.mu / a**3)
    P = np.array([math.cos(raan), math.sin(raan), 0.0])
    Qv = np.array([-math.cos(inc) * math.sin(raan), math.cos(inc) * math.cos(raan), math.sin(inc)])
    h = np.cross(P, Qv)
    u_ = argp + n * t
    r = a * (np.cos(u_)[:, None] * P + np.sin(u_)[:, None] * Qv)
    v = a * n * (-np.sin(u_)[:, None] * P + np.cos(u_)[:, None] * Qv)
    np.testing.assert_allclose(stack("r"), r, rtol=0, atol=1e-8)
    np.testing.assert_allclose(stack("v"), v, rtol=0, atol=1e-11)
    rh = r / a
    axes = np.stack([np.cross(h, rh), np.broadcast_to(-h, rh.shape), -rh], axis=-1)
    np.testing.assert_allclose(qt.to_matrix(stack("q_ref")), axes, rtol=0, atol=1e-12)
    w_ref = qt.rotate_inverse(q, np.broadcast_to(n * h, (t.size, 3)))
    np.testing.assert_allclose(stack("omega_ref"), w_ref, rtol=0, atol=1e-14)
    np.testing.assert_allclose(stack("omega_error"), w - w_ref, rtol=0, atol=1e-14)
    e = qt.multiply(qt.conjugate(stack("q_ref")), q)
    e *= np.where(e[:, :1] < 0.0, -1.0, 1.0)
    np.testing.assert_allclose(stack("sigma_error"), e[:, 1:] / (1.0 + e[:, :1]), atol=1e-11)
    s = sun_position(o.epoch, t) - r
    s /= np.linalg.norm(s, axis=1)[:, None]
    np.testing.assert_allclose(stack("sun"), qt.rotate_inverse(q, s), rtol=0, atol=1e-8)
    B = attitude.MagneticDipole(o, [0, 0, 0]).magnetic_field(t)
    np.testing.assert_allclose(stack("field"), qt.rotate_inverse(q, B), rtol=0, atol=1e-9 * 3e-5)


@pytest.mark.parametrize("angle", [1.4, 0.1])
def test_slew_reference_is_the_trapezoidal_rate_profile(angle):
    """A body at rest, slewing onto an inertial target an angle θ₀ away about e (target axes):
    the reference your step sees is q_R = q_T∘exp(θ e/2) with θ(t) the rest-to-rest profile
    written out here (accelerate at a to the rate limit w, coast, decelerate; triangular,
    peak √(θ₀ a), when θ₀ < w²/a), and ω_R = θ̇ e in body axes; then the target."""
    wmax, amax = math.radians(1.0), math.radians(0.05)
    e = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q_t = qt.from_euler([0.6, -0.3, 1.2], "321")
    q0 = qt.multiply(q_t, qt.from_rotation_vector(angle * e))  # θ₀ about e from the target
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    seen = []

    def step(tt, m):
        seen.append(m)
        return np.zeros(3)

    fsw = FlightSoftware(0.5, Slew(frames.inertial(q_t), wmax, amax), step, record_every=1)
    Q0 = C.momenta_from_angular_velocity(q0, [0.0, 0.0, 0.0], body)
    ds = attitude.propagate(body, q0, Q0, [0.0, 120.0], software=fsw, rtol=1e-12)
    t = np.array([m.t for m in seen])
    np.testing.assert_array_equal(ds.tick.values, t)
    if angle * amax > wmax**2:  # trapezoid
        t1, tc, wp = wmax / amax, angle / wmax - wmax / amax, wmax
    else:
        t1, tc, wp = math.sqrt(angle / amax), 0.0, math.sqrt(angle * amax)
    te = 2 * t1 + tc
    assert te < 110.0
    phases = [t < t1, t < t1 + tc, t < te]
    theta = np.select(
        phases,
        [
            angle - amax * t**2 / 2,
            angle - amax * t1**2 / 2 - wp * (t - t1),
            amax * (te - t) ** 2 / 2,
        ],
        0.0,
    )
    rate = np.select(phases, [-amax * t, -wp, -amax * (te - t)], 0.0)
    q_ref = qt.multiply(q_t, qt.from_rotation_vector(theta[:, None] * e))
    got = np.array([m.q_ref for m in seen])
    np.testing.assert_allclose(qt.to_matrix(got), qt.to_matrix(q_ref), rtol=0, atol=1e-12)
    # ω_R = θ̇ e in the reference axes, seen in body axes (the body at rest: q = q0)
    w_ref = qt.rotate_inverse(qt.multiply(qt.conjugate(q_ref), q0), rate[:, None] * e)
    np.testing.assert_allclose(np.array([m.omega_ref for m in seen]), w_ref, rtol=0, atol=1e-15)
    # the recorded error: the angle θ₀ − θ about e, σ_BR = tan((θ₀ − θ)/4) e
    np.testing.assert_allclose(ds.error_angle.values, angle - theta, rtol=0, atol=1e-12)
    sig = np.tan((angle - theta) / 4)[:, None] * e
    np.testing.assert_allclose(ds.sigma_error.values, sig, rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", ["python", "compiled"])
def test_own_steps_with_three_torques_or_one_wheel_are_the_exact_hold_discretisation(kind):
    """Steps returning three body torques (no actuators) or one wheel's torque, written in
    Python and as numba functions (tests/compiled_steps.py), against the exact discretisation
    of their zero-order hold at the ticks: a sphere damped by −c ω, ω_n = (1 − T c/I)ⁿ ω₀; a
    wheel on the symmetry axis from rest (angular momentum 0) on its tachometer,
    u = −c (Ω − Ω_r): Ω̇ = u k, k = 1/J + 1/(I₃ − J), so Ω_n − Ω_r = (1 − T k c)ⁿ (Ω₀ − Ω_r),
    and ω₃ = −J Ω / I₃ (G = 0)."""
    import compiled_steps as cs

    if kind == "python":
        damp = lambda tt, m: -2.0 * m.omega  # noqa: E731
        loop = lambda tt, m: np.array([-0.02 * (m.wheel_speeds[0] - 10.0)])  # noqa: E731
    else:
        damp = loop = cs.rate_damping_or_wheel_loop
    T = 0.5
    t = T * np.arange(21)
    sphere = attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2")
    w0 = np.array([0.02, -0.01, 0.03])
    ds = attitude.propagate(
        sphere, [1.0, 0, 0, 0], C.momenta_from_angular_velocity([1.0, 0, 0, 0], w0, sphere), t,
        software=FlightSoftware(T, control=damp), rtol=1e-13,
    )  # fmt: skip
    want = (1 - T * 2.0 / 10.0) ** np.arange(21)[:, None] * w0
    np.testing.assert_allclose(ds.omega.values, want, rtol=1e-11, atol=1e-16)

    J = 0.05
    craft = attitude.Spacecraft(
        attitude.RigidBody([10.0, 10.0, 8.0], units="kg m2"), [ReactionWheel([0, 0, 1], J)]
    )
    ds = attitude.propagate(
        craft, [1.0, 0, 0, 0], np.zeros(4), t, software=FlightSoftware(T, control=loop),
        rtol=1e-13,
    )  # fmt: skip
    k = 1 / J + 1 / (8.0 - J)
    want = 10.0 - 10.0 * (1 - T * k * 0.02) ** np.arange(21)
    np.testing.assert_allclose(ds.wheel_speed.values[:, 0], want, rtol=1e-11)
    np.testing.assert_allclose(ds.omega.values[:, 2], -J * want / 8.0, rtol=1e-11)  # G = 0


@pytest.mark.parametrize("frame", ["lvlh", "inertial"])
@pytest.mark.parametrize("law_type,Ki", [(0, None), (1, None), (0, 0.01), (1, 0.01)])
def test_your_own_mrp_law_equals_the_compiled_law(law_type, Ki, frame):
    """Basilisk's mrpFeedback written in Python (Schaub & Junkins: L_r = K σ + P δω + P K_I z
    − v × (I ω + Σ h a) + I (ω × ω_r), v = ω_r + K_I z for law type 0, ω for 1, the integral
    z = ∫ K σ dt + I δω summed at the ticks, each component of ∫ K σ dt limited; u = L_r on
    three wheels along the body axes), tracking LVLH on a circular orbit (ω_r ≠ 0,
    ω̇_r = 0) or pointing at a fixed attitude (ω_r = 0: the compiled law skips the reference
    rates' terms): the same run as the compiled law, in both of Basilisk's law types, with
    and without the integral term."""
    import orbit

    o = orbit.KeplerOrbit(7000.0, 0.0, 0.9, 0.4, 0.3, f0=0.0)
    guide = frames.lvlh(o) if frame == "lvlh" else frames.inertial(qt.from_mrp([0.0, 0.1, 0.2]))
    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    t = np.linspace(0.0, 20.0, 21)
    K, P, lim = 3.5, 30.0, 0.05
    law = MRPFeedback(K, P, Ki=Ki, integral_limit=lim if Ki else None, law_type=law_type)
    a = attitude.propagate(craft, q0, Q0, t, software=FlightSoftware(0.1, guide, law), rtol=1e-13)
    I = np.diag([900.0, 800.0, 600.0])
    js = craft.wheel_inertias
    state = {"int": np.zeros(3), "prior": None}

    def step(tt, m):
        w, wr = m.omega, m.omega_ref
        Kz = np.zeros(3)
        if Ki:
            dt = 0.0 if state["prior"] is None else tt - state["prior"]
            v = state["int"] + K * dt * m.sigma_error
            v = np.where(np.abs(v) > lim, lim * np.sign(v), v)
            state["int"] = v
            Kz = Ki * (v + I @ m.omega_error)
        state["prior"] = tt
        H = I @ w + js * (w + m.wheel_speeds)
        v8 = wr + Kz if law_type == 0 else w
        lr = K * m.sigma_error + P * m.omega_error + P * Kz - np.cross(v8, H)
        return lr + I @ np.cross(w, wr)

    b = attitude.propagate(craft, q0, Q0, t, software=FlightSoftware(0.1, guide, step), rtol=1e-13)
    assert np.abs(a.command_sent.values).max() > 1e-3
    if Ki:
        assert np.abs(state["int"]).max() == lim  # the limit reached
    np.testing.assert_allclose(b.command_sent.values, a.command_sent.values, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.q.values, a.q.values, rtol=0, atol=1e-13)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_mode_conditions_switch_at_the_first_tick_the_closed_form_says(sign):
    """A sphere spinning at W about z from the inertial frame, the software moving on through
    PointingBeyond (total angle W t > 1.02 rad: first tick past 10.2 s), PointingWithin about
    body x (angle between body and frame x, W t folded, < 0.5 rad again: first tick past
    (2π − 0.5)/W), After(70.2 s) and RateAbove(1.5 W) (never): the recorded mode at each tick
    against these closed-form times; the same from −q (the same attitude)."""
    from attitude.software import After, PointingBeyond, PointingWithin, RateAbove

    W, T = 0.1, 0.5
    sphere = attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2")

    inertial = frames.inertial()
    fsw = FlightSoftware(
        T,
        modes=[
            (None, Mode(name="coast")),
            (PointingBeyond(inertial, 1.02), Mode(name="coast")),
            (PointingWithin(inertial, 0.5, axis=[1.0, 0.0, 0.0]), Mode(name="coast")),
            (After(70.2), Mode(name="coast")),
            (RateAbove(1.5 * W), Mode(name="coast")),
        ],
    )
    q0 = [sign, 0.0, 0.0, 0.0]
    Q0 = C.momenta_from_angular_velocity(q0, [0.0, 0.0, W], sphere)
    ds = attitude.propagate(sphere, q0, Q0, [0.0, 80.0], software=fsw, rtol=1e-12)
    t = ds.tick.values
    t1 = T * math.ceil(1.02 / W / T + 1e-9)
    t2 = T * math.ceil((2 * math.pi - 0.5) / W / T)
    t3 = T * math.ceil(70.2 / T)
    assert (t1, t2, t3) == (10.5, 58.0, 70.5)
    want = (t >= t1).astype(int) + (t >= t2) + (t >= t3)
    np.testing.assert_array_equal(ds["mode"].values, want)


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_sparse_tick_records_are_the_dense_ones_subsampled(method):
    """record_every = 3 over more records than the first tick buffer holds (4 096): every
    tick variable equals the every-tick run's at the kept ticks, bit for bit (an unrecorded
    tick once wrote its record over the last kept row of a full buffer). The sensors and the
    MEKF's record (estimation error, NEES) included."""
    from attitude.estimation import MEKF
    from attitude.sensors import Gyro, StarTracker

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)

    def fsw(every):
        sensors = [
            Gyro(0.05 * u.deg / u.hour**0.5, 2e-9 * u.rad / u.s**1.5, seed=1),
            StarTracker([6 * u.arcsec, 45 * u.arcsec], [0.0, 0.6, 0.8], rate=2.0, seed=2),
        ]
        return FlightSoftware(0.1, frames.inertial(), MRPFeedback(3.5, 30.0), sensors=sensors,
                              estimator=MEKF(), record_every=every)  # fmt: skip

    t = np.array([0.0, 1300.0])
    dense = attitude.propagate(craft, q0, Q0, t, software=fsw(1), method=method, rtol=1e-12)
    sparse = attitude.propagate(craft, q0, Q0, t, software=fsw(3), method=method, rtol=1e-12)
    assert sparse.sizes["tick"] == -(-dense.sizes["tick"] // 3) > 4096
    names = [v for v in dense.variables if "tick" in dense[v].dims]
    assert {"error_angle", "command_sent", "estimation_error"} <= set(names)
    for v in names:
        np.testing.assert_array_equal(sparse[v].values, dense[v].values[::3], err_msg=v)
    np.testing.assert_array_equal(sparse.q.values, dense.q.values)

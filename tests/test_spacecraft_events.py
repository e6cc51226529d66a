"""Events of a spacecraft run (attitude._core.spacecraft_events): located by DOP853 between the
command boundaries, on the gyrostat's rates and, for a spacecraft carrying its orbit, on the
propagated orbit; against closed forms, astropy's Sun, and the run's own samples."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import attitude
import attitude.scenario
import orbit
from attitude import CommandSchedule, RigidBody, Spacecraft
from attitude.actuators import ReactionWheel, Thruster
from attitude.events import EclipseEntry, EclipseExit, PointingExceeds, RateExceeds

EPOCH = "2026-03-20T00:00:00"
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])
SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


@pytest.mark.parametrize("terminal", [False, True])
def test_rate_event_of_a_wheel_spin_up_at_the_closed_form(terminal):
    # From rest, a wheel along z driven by u: ω₃ = −u t / (I₃ − J) (test_actuators); |ω| reaches
    # `rate` at t* = rate (I₃ − J) / u, between two samples and three hold boundaries.
    body = RigidBody([10.0, 10.0, 8.0], units="kg m2")
    J, u, rate = 0.05, 0.01, 1e-3
    craft = Spacecraft(body, [ReactionWheel([0, 0, 1], J)])
    cmd = CommandSchedule([0.0, 0.3, 0.6, 0.7], wheel_torque=[[u], [u], [u], [u]])
    t = np.linspace(0.0, 10.0, 11)
    ds = attitude.propagate(craft, Q_ID, np.zeros(4), t, commands=cmd, rtol=1e-12, atol=1e-15,
                            events=[RateExceeds(rate, terminal=terminal)])  # fmt: skip
    t_star = rate * (8.0 - J) / u
    assert ds.sizes["event"] == 1
    assert abs(float(ds.event_time[0]) - t_star) < 1e-12
    # the gyrostat's ω at the event (the rigid body's g/I would be off by the wheel's share)
    np.testing.assert_allclose(ds.event_omega.values[0], [0.0, 0.0, -rate], rtol=0, atol=1e-15)
    if terminal:
        assert ds.attrs["status"] == "event" and ds.time.values[-1] == ds.event_time.values[0]
        assert ds.attrs["terminal_event"].startswith("rate_exceeds at t = 0.79")
        assert abs(float(np.linalg.norm(ds.omega.values[-1])) - rate) < 1e-15
        assert ds.sizes["time"] == 2  # t = 0, then the event
    else:
        assert ds.attrs["status"] == "success" and ds.sizes["time"] == 11
        assert int(ds.detector_count[0]) == 1


def _thrusting():
    """A spacecraft carrying its orbit, pushed along its velocity for ten minutes (2 N on
    100 kg, Δv = 12 m/s): its eclipses move by tens of seconds from the orbit's own."""
    o = orbit.NumericalOrbit([7000.0, 0.0, 0.0], [0.0, 7.546, 0.1], EPOCH)
    th = Thruster([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 2.0)
    sc = Spacecraft(RigidBody([10.0, 12.0, 14.0]), thrusters=[th], orbit=o, mass=100.0)
    return o, sc, CommandSchedule([0.0, 600.0], thrust=[[1.0], [0.0]])


def test_eclipses_of_a_coupled_run_are_those_of_the_propagated_orbit():
    from orbit.sun import shadow_function, sun_position

    o, sc, cmd = _thrusting()
    period = 2 * math.pi * math.sqrt(7000.0**3 / o.mu)
    t = np.linspace(0.0, 2 * period, 201)
    events = [EclipseEntry(o), EclipseExit(o)]
    ds = attitude.propagate(sc, Q_ID, np.zeros(4), t, commands=cmd, rtol=1e-12, atol=1e-12,
                            events=events)  # fmt: skip
    assert list(ds.event_detector.values) == [0, 1, 0, 1]
    te = ds.event_time.values
    # the penumbra boundary function at the recorded position, the Sun from astropy directly:
    # zero to round-off (|ġ| ≈ 1e-3 rad/s: 1e-12 rad is a nanosecond)
    _, g, _ = shadow_function(ds.event_position.values / 1e3, sun_position(EPOCH, te),
                              margins=True)  # fmt: skip
    assert np.max(np.abs(g)) < 1e-12
    # the recorded position is the run's own trajectory there (a run sampled at the events)
    at = attitude.propagate(sc, Q_ID, np.zeros(4), np.concatenate([[0.0], te]), commands=cmd,
                            rtol=1e-12, atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(ds.event_position.values, at.position.values[1:], rtol=0, atol=1e-3)
    assert ds.event_position.attrs["units"] == "m" and ds.event_mass.values[0] == 100.0
    # ... and not the orbit's own: the same events on the orbit alone come 10 s to 40 s earlier
    alone = attitude.propagate(RigidBody([10.0, 12.0, 14.0]), Q_ID, np.zeros(4), t,
                               rtol=1e-12, atol=1e-12, events=events, epoch=EPOCH)  # fmt: skip
    shift = te - alone.event_time.values
    assert np.all(shift > 5.0) and np.all(shift < 60.0)


def test_impact_with_events_and_in_chunks():
    # A ballistic arc from 200 km (test_coupling) with an event that never occurs: the run
    # still stops at the surface, says so, and a run in chunks of 7 samples (a progress bar's
    # calls) keeps the same samples and the state at the surface.
    o = orbit.NumericalOrbit([6578.0, 0, 0], [0.5, 3.0, 0.0], EPOCH)
    sc = Spacecraft(RigidBody([10.0, 12.0, 14.0]), orbit=o, mass=100.0)
    t = np.linspace(0.0, 3600.0, 361)
    kw = dict(method="dop853", rtol=1e-12, atol=1e-12)
    ds = attitude.propagate(sc, Q_ID, np.zeros(4), t, **kw)
    got = attitude.propagate(sc, Q_ID, np.zeros(4), t, events=[RateExceeds(1.0)], chunk=7, **kw)
    assert got.attrs["status"] == "event" and got.attrs["event"] == "impact"
    assert "terminal_event" not in got.attrs and got.sizes["event"] == 0
    assert got.attrs["impact_time"] == ds.attrs["impact_time"] == got.time.values[-1]
    np.testing.assert_array_equal(got.position.values, ds.position.values)
    np.testing.assert_array_equal(got.q.values, ds.q.values)


@pytest.mark.parametrize("terminal", [False, True])
def test_events_of_the_step_that_reaches_the_surface(terminal):
    # The arc's last step (about 30 s) ends at the surface, 297.87 s: an event at 297.5 s in it
    # is located (a terminal one stops the run there, not at the surface); one at 297.9 s,
    # below the surface, is not.
    o = orbit.NumericalOrbit([6578.0, 0, 0], [0.5, 3.0, 0.0], EPOCH)
    sc = Spacecraft(RigidBody([10.0, 12.0, 14.0]), orbit=o, mass=100.0)
    t = np.linspace(0.0, 3600.0, 361)

    def before(t, q, omega):
        return t - 297.5

    def after(t, q, omega):
        return t - 297.9

    events = [attitude.events.Custom(before, terminal=terminal), attitude.events.Custom(after)]
    ds = attitude.propagate(sc, Q_ID, np.zeros(4), t, method="dop853", rtol=1e-12, atol=1e-12,
                            events=events)  # fmt: skip
    assert list(ds.detector_count.values) == [1, 0]
    assert abs(float(ds.event_time[0]) - 297.5) < 1e-9
    if terminal:
        assert ds.attrs["status"] == "event" and "impact_time" not in ds.attrs
        assert ds.time.values[-1] == ds.event_time.values[0]
    else:
        assert ds.attrs["event"] == "impact" and 297.8 < ds.attrs["impact_time"] < 297.9


def _closed_loop():
    """Basilisk's scenarioAttitudeFeedbackRW (the shipped scenario), two minutes of it."""
    sc = attitude.scenario.load(SCENARIOS / "rw_inertial_pointing.toml")
    return sc, np.arange(0.0, 120.0 + 1e-9, 0.5)


def test_closed_loop_event_leaves_the_run_unchanged():
    # The attitude error falls through 40° as the wheels slew the body: located between ticks,
    # the run's samples before it identical to a run without events, the angle at the event
    # the threshold (from the event's own q: the target is the inertial frame).
    sc, t = _closed_loop()
    kw = dict(software=sc.software, method="dop853", rtol=sc.rtol, atol=sc.atol)
    plain = attitude.propagate(sc.spacecraft, sc.q0, sc.Q0, t, sc.potential, **kw)
    ev = PointingExceeds(attitude.frames.inertial(), None, 40.0 * math.pi / 180.0,
                         direction="falling", terminal=True)  # fmt: skip
    ds = attitude.propagate(sc.spacecraft, sc.q0, sc.Q0, t, sc.potential, events=[ev], **kw)
    te = float(ds.event_time[0])
    n = ds.sizes["time"] - 1
    assert plain.time.values[n - 1] < te < plain.time.values[n]
    np.testing.assert_array_equal(ds.q.values[:n], plain.q.values[:n])
    np.testing.assert_array_equal(ds.wheel_speed.values[:n], plain.wheel_speed.values[:n])
    q = ds.event_q.values[0]
    angle = 2.0 * math.atan2(np.linalg.norm(q[1:]), abs(q[0]))
    assert abs(angle - 40.0 * math.pi / 180.0) < 1e-12
    # the sampled error of the run without events crosses 40° in the same half second
    err = 2.0 * np.arctan2(np.linalg.norm(plain.q.values[:, 1:], axis=1), np.abs(plain.q[:, 0]))
    assert err[n - 1] > 40.0 * math.pi / 180.0 > err[n]
    assert ds.attrs["status"] == "event" and ds.time.values[-1] == te


@pytest.mark.parametrize("terminal", [False, True])
def test_ensemble_members_locate_their_own_events(terminal):
    # Three wheel torques: |ω| reaches the rate at t* = rate (I₃ − J) / u_k (the closed form of
    # the first test) in each member; a terminal event ends the member on its last sample before
    # it (its rows are the shared samples' times), status terminal_event.
    from attitude.ensemble import propagate_ensemble

    body = RigidBody([10.0, 10.0, 8.0], units="kg m2")
    J, rate, us = 0.05, 1e-3, np.array([0.01, 0.02, 0.005])
    craft = Spacecraft(body, [ReactionWheel([0, 0, 1], J)])
    cmds = [CommandSchedule([0.0], wheel_torque=[[u]]) for u in us]
    t = np.linspace(0.0, 10.0, 11)
    ens = propagate_ensemble(craft, np.tile(Q_ID, (3, 1)), np.zeros((3, 4)), t, commands=cmds,
                             rtol=1e-12, atol=1e-15,
                             events=[RateExceeds(rate, terminal=terminal)])  # fmt: skip
    np.testing.assert_allclose(ens.event_first_time.values[:, 0], rate * (8.0 - J) / us,
                               rtol=0, atol=1e-12)  # fmt: skip
    assert list(ens.event_count.values[:, 0]) == [1, 1, 1]
    assert list(ens.detector_label.values) == ["rate_exceeds"]
    if terminal:
        assert list(ens.member_status.values) == [4, 4, 4]
        last = np.sum(~np.isnan(ens.q.values[:, :, 0]), axis=1)  # samples kept: t < t*
        assert list(last) == [1, 1, 2]
    else:
        assert list(ens.member_status.values) == [0, 0, 0] and not np.isnan(ens.q.values).any()


def test_ensemble_of_coupled_members_sees_each_propagated_orbit():
    # Burns of 0, 1 and 2 N: each member's eclipse times are its single run's, bit for bit
    # (the same driver, its own orbit written into its own event data).
    from attitude.ensemble import propagate_ensemble

    o = orbit.NumericalOrbit([7000.0, 0.0, 0.0], [0.0, 7.546, 0.1], EPOCH)
    th = Thruster([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 2.0)
    crafts = [Spacecraft(RigidBody([10.0, 12.0, 14.0]), thrusters=[th], orbit=o, mass=100.0)] * 3
    cmds = [CommandSchedule([0.0, 600.0], thrust=[[f], [0.0]]) for f in (0.0, 0.5, 1.0)]
    t = np.linspace(0.0, 6000.0, 61)
    events = [EclipseEntry(o), EclipseExit(o)]
    kw = dict(rtol=1e-12, atol=1e-12, events=events)
    ens = propagate_ensemble(crafts, np.tile(Q_ID, (3, 1)), np.zeros((3, 4)), t, commands=cmds,
                             **kw)  # fmt: skip
    firsts = ens.event_first_time.values
    for k in range(3):
        one = attitude.propagate(crafts[k], Q_ID, np.zeros(4), t, commands=cmds[k], **kw)
        assert np.array_equal(firsts[k], one.detector_first_time.values)
    assert firsts[2, 0] - firsts[0, 0] > 5.0  # the burn moved the eclipse


def test_many_occurrences_grow_the_record_buffers():
    # The wheel torque flips sign every 5 s: |ω| = u (t − 10k)/(I₃ − J) rises and falls in each
    # 10 s period and passes `rate` twice, 140 times in 700 s (the records start with room for
    # 64): every crossing at its closed form, in order.
    body = RigidBody([10.0, 10.0, 8.0], units="kg m2")
    J, u, rate = 0.05, 0.01, 3e-3
    craft = Spacecraft(body, [ReactionWheel([0, 0, 1], J)])
    flips = np.arange(0.0, 700.0, 5.0)
    cmd = CommandSchedule(flips, wheel_torque=u * (1 - 2 * (np.arange(flips.size) % 2))[:, None])
    t = np.linspace(0.0, 700.0, 71)
    ds = attitude.propagate(craft, Q_ID, np.zeros(4), t, commands=cmd, rtol=1e-12, atol=1e-15,
                            events=[RateExceeds(rate, direction="both")])  # fmt: skip
    dt = rate * (8.0 - J) / u
    start = 10.0 * np.arange(70)
    want = np.sort(np.concatenate([start + dt, start + 10.0 - dt]))
    assert ds.sizes["event"] == 140
    np.testing.assert_allclose(ds.event_time.values, want, rtol=0, atol=1e-10)
    assert list(ds.event_direction.values[:4]) == [1, -1, 1, -1]

"""Closed-loop ensembles (issues 24, 25, 26): spacecraft with wheels, flight software with a
gyro, a star tracker and the MEKF, dispersed per member. Every member equals its single run bit
for bit (DOP853, and Taylor in SIMD batches of gyrostats), re-runs alone from its stored sensor
seeds, and the pointing error's spread agrees with the linear covariance analysis of
docs/closed_loop_covariance.md within sampling error."""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy import units as u
from scipy import stats

import attitude
from attitude import canonical as C
from attitude import frames
from attitude.actuators import ReactionWheel
from attitude.control import MRPFeedback, RateDamping
from attitude.ensemble import (
    disperse_spacecraft,
    error_angle_percentiles,
    propagate_ensemble,
    rerun_member,
    settling_times,
)
from attitude.ensemble._members import member_seeds
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.estimation import MEKF
from attitude.sensors import Gyro, StarTracker
from attitude.software import FlightSoftware

RPM = 2 * math.pi / 60
JS = 50.0 / (6000 * RPM)  # HR16 axial inertia (kg m²)
SPEEDS = np.array([100.0, 200.0, 300.0]) * RPM
ARCSEC = math.radians(1 / 3600)


def craft():
    """scenarioAttitudeFeedbackRW's spacecraft: 900/800/600 kg m², three HR16 wheels."""
    wheels = [
        ReactionWheel(np.eye(3)[k], JS, speed=SPEEDS[k], max_torque=0.2, max_speed=6000 * RPM)
        for k in range(3)
    ]
    return attitude.Spacecraft(attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2"), wheels)


def software(period=1.0, K=100.0, P=300.0, noise=(10 * ARCSEC, 30 * ARCSEC), record_every=1):
    gyro = Gyro(1.45e-5, 3e-7, bias=np.radians([3.0, -2.0, 1.5]) / 3600.0)
    st = StarTracker(list(noise), [0.0, 0.0, 1.0])
    return FlightSoftware(
        period, guidance=frames.inertial(), control=MRPFeedback(K, P), sensors=[gyro, st],
        estimator=MEKF(), record_every=record_every,
    )  # fmt: skip


def _same(a, b, names):
    for v in names:
        x, y = np.asarray(a[v].values), np.asarray(b[v].values)
        assert x.shape == y.shape, v
        assert np.array_equal(x, y, equal_nan=True), v


# (taylor in the default suite: what "auto" picks for a closed-loop ensemble; every member of
# one stopped at its first step while this test was marked slow)
@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_dispersed_members_equal_their_single_runs_bit_for_bit(method):
    """Inertia, rates, wheel inertias, gains, sensor noise and gyro bias dispersed; each member
    (in a chunk of SIMD lanes for Taylor) equals ``propagate`` of its own spacecraft and software
    with its stored sensor seeds, and rerun_member gives the same bits; the chunking does not
    matter."""
    n = 6
    d = disperse_spacecraft(
        craft(), [1.0, 0, 0, 0], np.radians([0.05, -0.03, 0.02]), n, software=software(0.5),
        seed=3, attitude_error=0.01, rate_error=2e-4, inertia_error=0.05,
        wheel_inertia_error=0.02, gain_error=0.1, sensor_noise_error=0.2, gyro_bias_error=1e-5,
    )  # fmt: skip
    t = np.linspace(0.0, 20.0, 5)
    kw = dict(method=method, rtol=1e-10)
    ds = propagate_ensemble(d.spacecraft, d.q, d.Q, t, software=d.software, seed=11, **kw)
    assert ds.sizes["member"] == n and int(ds.attrs["ensemble_seed"]) == 11
    seeds = ds.sensor_seed.values
    assert np.array_equal(seeds, member_seeds(11, np.arange(n), 2))
    assert len(np.unique(seeds)) == 2 * n  # independent streams
    names = ["q", "Q", "omega", "wheel_speed", "wheel_torque", "error_angle", "sigma_error",
             "command_applied", "estimation_error"]  # fmt: skip
    for i in (0, 3, n - 1):
        sw = d.software[i].with_sensor_seeds([int(s) for s in seeds[i]])
        one = attitude.propagate(d.spacecraft[i], d.q[i], d.Q[i], t, software=sw, **kw)
        _same(ds.isel(member=i), one, names)
        again = rerun_member(ds, i, spacecraft=d.spacecraft[i], software=d.software[i])
        _same(ds.isel(member=i), again, names)
    # the members differ (dispersed), and chunks of 2 give the same bits
    assert not np.array_equal(ds.q.values[0], ds.q.values[1])
    if method == "dop853":
        two = propagate_ensemble(d.spacecraft, d.q, d.Q, t, software=d.software, seed=11,
                                 chunk_size=2, **kw)  # fmt: skip
        _same(ds, two, names)


# (in the default suite: "auto" picks the Taylor lanes for open-loop spacecraft ensembles;
# ~25 s in a fresh cache, the single-run Taylor driver included)
def test_open_loop_taylor_ensemble_in_simd_lanes_equals_single_runs():
    """Open-loop wheel schedules with dispersed wheel inertias and torque limits (saturating):
    the Taylor SIMD lanes of gyrostats give each member's single run bit for bit."""
    n = 5
    d = disperse_spacecraft(craft(), [1.0, 0, 0, 0], [0.01, 0.0, -0.01], n, seed=5,
                            rate_error=1e-3, wheel_inertia_error=0.05,
                            wheel_max_torque_error=0.1)  # fmt: skip
    sched = attitude.CommandSchedule(
        [0.0, 3.0, 7.0], wheel_torque=[[0.1, -0.25, 0.05], [-0.3, 0.1, 0.0], [0.0, 0.0, 0.2]]
    )
    t = np.linspace(0.0, 10.0, 6)
    ds = propagate_ensemble(d.spacecraft, d.q, d.Q, t, commands=sched, method="taylor",
                            rtol=1e-12)  # fmt: skip
    assert "sensor_seed" not in ds
    for i in (0, 4):
        one = attitude.propagate(d.spacecraft[i], d.q[i], d.Q[i], t, commands=sched,
                                 method="taylor", rtol=1e-12)  # fmt: skip
        _same(ds.isel(member=i), one, ["q", "Q", "wheel_speed", "wheel_torque", "wheel_limit"])
    assert (ds.wheel_limit.values != 0).any()  # some members saturate


def test_auto_picks_for_the_ensemble_what_the_single_runs_pick():
    """``method="auto"`` (the default) resolves as each member's single run resolves it: a
    member whose wheel has a Stribeck regime (which taylor does not expand) makes the whole
    ensemble dop853, and every member is then bit for bit its single run with "auto"."""
    stribeck = ReactionWheel([1.0, 0.0, 0.0], JS, speed=SPEEDS[0], coulomb_friction=1e-3,
                             static_friction=2e-3, stribeck_speed=0.01)  # fmt: skip
    plain, c = craft(), craft()
    rough = attitude.Spacecraft(c.body, [stribeck, *c.wheels[1:]])
    crafts = [plain, rough]
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (2, 1))
    Q0 = np.tile(C.momenta_from_angular_velocity(q0[0], [0.01, 0.0, 0.0], plain), (2, 1))
    sched = attitude.CommandSchedule([0.0, 2.0], wheel_torque=[[0.1, 0.0, 0.0], [0.0, 0.1, 0.0]])
    t = np.linspace(0.0, 4.0, 3)
    ds = propagate_ensemble(crafts, q0, Q0, t, commands=sched)
    assert ds.attrs["method"] == "dop853" and ds.attrs["method_requested"] == "auto"
    one = attitude.propagate(rough, q0[1], Q0[1], t, commands=sched)
    assert one.attrs["method"] == "dop853"
    _same(ds.isel(member=1), one, ["q", "Q", "wheel_speed", "wheel_torque"])
    with pytest.raises(AttitudeValueError, match="Stribeck"):
        propagate_ensemble(crafts, q0, Q0, t, commands=sched, method="taylor")


def test_draws_do_not_depend_on_the_ensemble_size_or_on_what_is_dispersed():
    big = disperse_spacecraft(craft(), [1.0, 0, 0, 0], [0, 0, 0], 8, software=software(),
                              seed=2, inertia_error=0.05, gain_error=0.1)  # fmt: skip
    part = disperse_spacecraft(craft(), [1.0, 0, 0, 0], [0, 0, 0], 3, software=software(),
                               seed=2, inertia_error=0.05, gain_error=0.1, start=5)  # fmt: skip
    assert np.array_equal(big.errors["gain"][5:], part.errors["gain"])
    assert np.array_equal(big.spacecraft[6].body.inertia, part.spacecraft[1].body.inertia)
    law = big.software[4].modes[0][1].control
    assert law.K == pytest.approx(100.0 * (1 + big.errors["gain"][4, 0]), rel=1e-15)
    np.testing.assert_allclose(law.P, 300.0 * (1 + big.errors["gain"][4, 1]) * np.eye(3))
    # the relative errors are truncated at 3 sigma
    many = disperse_spacecraft(craft(), [1.0, 0, 0, 0], [0, 0, 0], 2000, seed=1,
                               wheel_inertia_error=0.1)  # fmt: skip
    e = many.errors["wheel_inertia"]
    assert np.abs(e).max() <= 0.3 and 0.09 < e.std() < 0.11
    # the sensors' seeds: reproducible, independent of N
    assert np.array_equal(
        member_seeds(7, np.arange(3, 5), 2), member_seeds(7, np.arange(9), 2)[3:5]
    )


def test_bad_closed_loop_ensemble_input_is_refused_before_any_work():
    rigid = attitude.Spacecraft(attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2"))
    q, w = [1.0, 0, 0, 0], [0.0, 0, 0]
    with pytest.raises(AttitudeValueError, match="wheel_inertia_error: the spacecraft has no"):
        disperse_spacecraft(rigid, q, w, 3, wheel_inertia_error=0.1)
    with pytest.raises(AttitudeValueError, match="magnetorquer_max_dipole_error"):
        disperse_spacecraft(craft(), q, w, 3, magnetorquer_max_dipole_error=0.1)
    with pytest.raises(AttitudeValueError, match="thruster_max_thrust_error"):
        disperse_spacecraft(craft(), q, w, 3, thruster_max_thrust_error=0.1)
    with pytest.raises(AttitudeValueError, match="gain_error: no flight software"):
        disperse_spacecraft(craft(), q, w, 3, gain_error=0.1)
    with pytest.raises(AttitudeValueError, match="gyro_bias_error"):
        fs = FlightSoftware(1.0, control=RateDamping(10.0))
        disperse_spacecraft(craft(), q, w, 3, software=fs, gyro_bias_error=1e-5)
    with pytest.raises(AttitudeValueError, match=r"gain_error: a relative error up to 1\.2"):
        disperse_spacecraft(craft(), q, w, 3, software=software(), gain_error=0.4)
    no_limit = attitude.Spacecraft(craft().body, [ReactionWheel([0, 0, 1.0], JS)])
    with pytest.raises(AttitudeValueError, match="no torque limit"):
        disperse_spacecraft(no_limit, q, w, 3, wheel_max_torque_error=0.1)
    with pytest.raises(AttitudeTypeError, match="spacecraft: expected an attitude"):
        disperse_spacecraft(craft().body, q, w, 3)
    c = craft()
    q0 = np.tile(q, (2, 1))
    Q0 = np.tile(C.momenta_from_angular_velocity(q, w, c), (2, 1))
    t = [0.0, 2.0]  # (two ticks of the 1 s software: a period as long as the run is refused)
    with pytest.raises(AttitudeTypeError, match="seed: expected a non-negative integer"):
        propagate_ensemble(c, q0, Q0, t, software=software(), seed=1.5)
    with pytest.raises(AttitudeValueError, match="commands: the flight software commands"):
        cmd = attitude.CommandSchedule([0.0], wheel_torque=[[0, 0, 0]])
        propagate_ensemble(c, q0, Q0, t, software=software(), commands=cmd)
    with pytest.raises(AttitudeValueError, match="software: 3 given for 2 members"):
        propagate_ensemble(c, q0, Q0, t, software=[software()] * 3)
    with pytest.raises(AttitudeValueError, match="seed: the ensemble seed of noisy sensors"):
        propagate_ensemble(c.body, q0, Q0, t, seed=3)
    with pytest.raises(AttitudeValueError, match="every member needs the same structure"):
        propagate_ensemble([c, rigid], q0, Q0, t, software=software())
    with pytest.raises(AttitudeTypeError, match=r"^events\[0\]: expected an attitude.events"):
        propagate_ensemble(c, q0, Q0, t, software=software(), events=[object()])
    with pytest.raises(AttitudeValueError, match=r"^events: method='taylor' does not locate"):
        propagate_ensemble(c, q0, Q0, t, software=software(), method="taylor",
                           events=[attitude.events.RateExceeds(1.0)])  # fmt: skip


def test_closed_loop_statistics_of_pointing_error_and_settling_time():
    """A small dispersed ensemble (inertia, initial rates, gains) with perfect sensors, below
    the wheels' torque limit: each member's pointing error at every tick against the
    linearised closed loop (zero-order-hold plant θ̇ = ω, Ĩ ω̇ = [h×] ω + L with the member's
    inertia, L = −(K/4) θ − P ω with its gains), to 1e-3 relative; settling_times and
    error_angle_percentiles against the same numbers computed from the records directly."""
    import closed_loop_covariance as lc

    n = 24
    fs = FlightSoftware(1.0, guidance=frames.inertial(), control=MRPFeedback(100.0, 300.0),
                        record_every=1)  # fmt: skip
    d = disperse_spacecraft(
        craft(), [1.0, 0, 0, 0], [0.0, 0.0, 0.0], n, software=fs, seed=4,
        rate_error=np.radians(0.005), inertia_error=0.05, gain_error=0.1,
    )  # fmt: skip
    # dop853 named: "auto" would pick taylor here (its members are tested bit for bit above)
    ds = propagate_ensemble(d.spacecraft, d.q, d.Q, [0.0, 120.0], software=d.software,
                            method="dop853")  # fmt: skip
    e = ds.error_angle.values
    tick = ds.tick.values
    K = 100.0 * (1 + d.errors["gain"][:, 0])
    P = 300.0 * (1 + d.errors["gain"][:, 1])
    linear = np.zeros_like(e)
    for i in range(n):
        phi, gam = lc.plant(d.spacecraft[i].locked_less_wheels(), JS * SPEEDS, 1.0)
        x = np.concatenate([np.zeros(3), d.errors["rate"][i]])
        for k in range(tick.size):
            linear[i, k] = np.linalg.norm(x[:3])
            x = phi @ x + gam @ (-(K[i] / 4) * x[:3] - P[i] * x[3:])
    peak = e.max(axis=1)
    assert np.all(np.abs(e - linear) <= 1e-3 * peak[:, None])
    thr = 0.02 * float(np.median(peak))
    st = settling_times(ds, thr * u.rad).values
    for i in range(n):
        above = np.flatnonzero(~(e[i] <= thr))
        assert st[i] == (tick[above[-1] + 1] if above.size else tick[0])
        above_lin = np.flatnonzero(linear[i] > thr)
        assert abs(st[i] - tick[above_lin[-1] + 1]) <= 1.0  # within a tick of the linear one
    assert np.all(np.isfinite(st)) and np.ptp(st) > 0
    p = error_angle_percentiles(ds, [50, 95])
    np.testing.assert_array_equal(p.sel(percentile=95).values, np.percentile(e, 95, axis=0))


def _covariance_run(n, t_end):
    import closed_loop_covariance as lc

    c = craft()
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    Q0 = np.tile(C.momenta_from_angular_velocity(q0[0], [0.0, 0.0, 0.0], c), (n, 1))
    fs = software(record_every=100)
    # dop853 named: "auto" would pick taylor (slow to compile in a fresh cache)
    ds = propagate_ensemble(c, q0, Q0, [0.0, t_end], software=fs, seed=1, method="dop853")
    q = ds.q.isel(time=-1).values
    theta = 2.0 * q[:, 1:] * np.sign(q[:, :1])  # the true pointing error (rotation vector)
    sc, sb = 10 * ARCSEC, 30 * ARCSEC
    R = np.diag([sc**2, sc**2, sb**2])
    P0 = np.diag([sb**2] * 3 + [1e-10] * 3)
    Xss, X = lc.pointing_covariance(c.locked_less_wheels(), JS * SPEEDS, 1.0, 100.0, 300.0,
                                    1.45e-5, 3e-7, R, P0, int(t_end))  # fmt: skip
    return theta, Xss, X


def _check_covariance(theta, Xss, X, alpha):
    """(N − 1) s² / σ² ~ χ²(N − 1) per axis (Gaussian: a linear system driven by Gaussian
    noise); two-sided at ``alpha`` per axis."""
    n = theta.shape[0]
    var = np.diag(Xss)[:3]
    # the transient left at the end of the run: far below the sampling error
    assert np.all(np.abs(np.diag(X)[:3] / var - 1) < 0.01)
    s2 = theta.var(axis=0, ddof=1)
    lo, hi = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], n - 1) / (n - 1)
    ratio = s2 / var
    assert np.all((ratio > lo) & (ratio < hi)), (np.sqrt(ratio), np.sqrt([lo, hi]))
    # the mean error is zero within its standard error (the filter removes the gyro's bias)
    assert np.all(np.abs(theta.mean(axis=0)) < 4 * np.sqrt(var / n))


def test_pointing_error_spread_agrees_with_linear_covariance_analysis():
    """Inertial pointing with wheels, a gyro (ARW, RRW, bias) and a star tracker through the
    MEKF at 1 Hz: the sample variance of each axis' pointing error over 1 000 members at
    t = 200 s against the steady-state covariance of the linearised closed loop (discrete
    Lyapunov equation, docs/closed_loop_covariance.md), within the χ² sampling interval
    (99.9 % per axis: about ±15 % in variance, ±7 % in standard deviation, for 1 000)."""
    theta, Xss, X = _covariance_run(1000, 200.0)
    _check_covariance(theta, Xss, X, 1e-3)


def test_closed_loop_ensemble_records_are_allocated_in_interruptible_blocks(monkeypatch):
    """issue 39: Ctrl-C took 2.1-2.3 s in a closed-loop ensemble (8 members, 3e5 ticks) but
    0.02-0.35 s in single runs: the members' tick records were NaN-filled by one np.full of
    every tick (and copied by one np.ascontiguousarray after the run), C calls in which no
    signal is handled. They are now filled FILL_BLOCK elements at a time, and copied a member
    at a time (measured after: 0.01-0.26 s). Asserted: the size of each fill."""
    from attitude.ensemble import _members as sm

    sizes: list[int] = []

    class Counted(np.ndarray):
        def __setitem__(self, key, value):
            sizes.append(np.asarray(self)[key].size)
            np.asarray(self)[key] = value

    empty = np.empty
    checks = []
    monkeypatch.setattr(np, "empty", lambda shape: empty(shape).view(Counted))
    monkeypatch.setattr(sm._interrupt, "check", lambda: checks.append(1))
    monkeypatch.setattr(sm, "FILL_BLOCK", 100)
    rec = np.asarray(sm.nan_records(3, 1000, 7))
    monkeypatch.undo()
    assert rec.shape == (3, 1000, 7) and np.isnan(rec).all()
    assert max(sizes) <= 100 and len(sizes) == 3 * -(-1000 // (100 // 7))  # 14 rows a fill
    assert len(checks) == 3  # a swallowed request is raised again after each member
    assert sm.FILL_BLOCK * 8 <= 16 * 2**20  # the default: milliseconds a fill

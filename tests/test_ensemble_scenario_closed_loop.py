"""Scenario files with ``[ensemble]`` beside actuators and ``[software]`` (issue 39): member k of
``run_scenario`` is, bit for bit, ``propagate`` of that member's spacecraft, state and software
built here by hand from the scenario's draws (docs/ensemble.md, "Closed-loop scenarios")."""

from __future__ import annotations

import numpy as np
import pytest

import attitude
from attitude import canonical, frames, io, scenario
from attitude import quaternion as qt
from attitude.actuators import ReactionWheel
from attitude.control import MRPFeedback
from attitude.ensemble import run_scenario
from attitude.estimation import MEKF
from attitude.scenario import ScenarioError
from attitude.sensors import Gyro, StarTracker
from attitude.software import FlightSoftware

JS = 0.07957747154594767
SPEEDS = (10.0, 20.0, 30.0)  # rad/s
INERTIA = np.array([900.0, 800.0, 600.0])

WHEELS = "".join(
    f"""
[[spacecraft.wheels]]
axis = {np.eye(3)[k].tolist()}
inertia = {JS}
inertia_unit = "kg m2"
speed = {SPEEDS[k]}
speed_unit = "rad/s"
max_torque = 0.2
max_torque_unit = "N m"
"""
    for k in range(3)
)

TOML = f"""
[scenario]
name = "cl_ensemble"

[body]
inertia = {INERTIA.tolist()}
inertia_unit = "kg m2"
{WHEELS}
[software]
period = 0.5
guidance = "inertial"
control = "mrp_feedback"
K = 100.0
P = 300.0

[[software.sensors]]
type = "gyro"
arw = 1.45e-5
arw_unit = "rad/s(1/2)"
rrw = 3e-7
rrw_unit = "rad/s(3/2)"
bias = [1e-5, -2e-5, 5e-6]
bias_unit = "rad/s"
seed = 7

[[software.sensors]]
type = "star_tracker"
noise = [5e-5, 1.5e-4]
noise_unit = "rad"
seed = 8

[software.estimator]
type = "mekf"

[initial_state]
form = "body_rates"
q = [0.9914448613738104, 0.0, 0.0, 0.13052619222087722]
omega = [0.001, -0.002, 0.003]
omega_unit = "rad/s"

[time]
start = 0.0
stop = 6.0
step = 1.5
unit = "s"

[integrator]
method = "dop853"

[ensemble]
size = 4
seed = 31
chunk = 3
attitude_error = 0.5
attitude_error_unit = "deg"
rate_error = 0.01
rate_error_unit = "deg/s"
inertia_error = 0.05
"""

NAMES = ["q", "Q", "omega", "wheel_speed", "wheel_torque", "error_angle", "sigma_error",
         "command_applied", "estimation_error", "mode"]  # fmt: skip


def _member_by_hand(sc, k):
    """Member k from the documented recipe: the table's draws about the nominal state, the
    spacecraft's body scaled, the nominal wheels, the software with the nominal inertia as its
    model and the sensors seeded from SeedSequence(seed).spawn(N)[k]."""
    disp = sc.ensemble
    dtheta, domega, eps = disp.draws(k, k + 1)
    wheels = [ReactionWheel(np.eye(3)[j], JS, speed=SPEEDS[j], max_torque=0.2) for j in range(3)]
    nominal = attitude.Spacecraft(attitude.RigidBody(INERTIA, units="kg m2"), wheels)
    q0, Q0, _ = canonical.project_state(sc.q0, sc.Q0)
    w0 = canonical.angular_velocity(q0, Q0, nominal)  # the nominal body rate
    np.testing.assert_allclose(w0, [0.001, -0.002, 0.003], rtol=0, atol=1e-15)
    craft = attitude.Spacecraft(attitude.RigidBody(INERTIA * (1 + eps[0]), units="kg m2"), wheels)
    q = qt.multiply(q0, qt.from_rotation_vector(dtheta[0]))
    Q = canonical.momenta_from_angular_velocity(q, w0 + domega[0], craft)
    seeds = np.random.SeedSequence(disp.seed, spawn_key=(k,)).generate_state(2, np.uint64) >> 1
    sw = FlightSoftware(
        0.5, guidance=frames.inertial(), control=MRPFeedback(100.0, 300.0),
        sensors=[Gyro(1.45e-5, 3e-7, bias=[1e-5, -2e-5, 5e-6], seed=int(seeds[0])),
                 StarTracker([5e-5, 1.5e-4], seed=int(seeds[1]))],
        estimator=MEKF(), inertia=INERTIA,
    )  # fmt: skip
    return craft, q, Q, sw, (dtheta[0], domega[0], eps[0])


#: An [events] table: the attitude error passing 14.5° (both ways) and |ω| passing 0.2°/s.
EVENTS = """
[events.error]
type = "pointing_exceeds"
frame = "inertial"
angle = 14.5
angle_unit = "deg"
direction = "both"

[events.rate]
type = "rate_exceeds"
rate = 0.2
rate_unit = "deg/s"
direction = "both"

[ensemble]"""


def test_scenario_member_equals_propagate_of_its_dispersed_spacecraft_bit_for_bit(tmp_path):
    sc = scenario.loads(TOML.replace("[ensemble]", EVENTS))
    info = run_scenario(sc, tmp_path / "cl.nc")
    assert info["run_status"] == "complete"
    ds = io.read(tmp_path / "cl.nc")
    assert ds.sizes["member"] == 4 and int(ds.attrs["ensemble_seed"]) == 31
    assert ds["event_count"].values[:, 1].min() >= 1  # |ω| passes 0.2°/s in every member
    t = ds["time"].values
    np.testing.assert_array_equal(t, np.arange(0.0, 6.1, 1.5))
    for k in (0, 2, 3):  # members of both chunks
        craft, q, Q, sw, (dtheta, domega, eps) = _member_by_hand(sc, k)
        one = attitude.propagate(craft, q, Q, t, software=sw, method="dop853", rtol=1e-10,
                                 atol=1e-12, events=sc.events)  # fmt: skip
        m = ds.isel(member=k)
        for v in NAMES:
            assert np.array_equal(m[v].values, one[v].values, equal_nan=True), v
        # each member's events are its single run's
        assert np.array_equal(m["event_count"].values, one["detector_count"].values)
        assert np.array_equal(m["event_first_time"].values, one["detector_first_time"].values,
                              equal_nan=True)  # fmt: skip
        # the inputs stored per member
        assert np.array_equal(m["inertia"].values, INERTIA * (1 + eps))
        assert np.array_equal(m["dispersion_attitude"].values, dtheta)
        assert np.array_equal(m["dispersion_rate"].values, domega)
        assert np.array_equal(m["dispersion_inertia"].values, eps)
        assert [int(s) for s in m["sensor_seed"].values] == [x.seed for x in sw.sensors]
    assert ds["dispersion_rate"].attrs["units"] == ds["omega"].attrs["units"] == "rad s^-1"
    # the members differ from one another, and from the nominal run
    assert not np.array_equal(ds.q.values[0], ds.q.values[1])
    nominal = sc.run()
    assert not np.array_equal(ds.q.values[0], nominal.q.values)


def test_without_inertia_error_the_members_share_the_spacecraft_and_its_software():
    """No inertia dispersion: one spacecraft for all, the software's inertia model left as given
    (the true one); only the state and the sensors' seeds differ."""
    from attitude.ensemble._spacecraft_scenario import members_of

    sc = scenario.loads(TOML.replace("inertia_error = 0.05", "inertia_error = 0.0"))
    crafts, q, Q, sw = members_of(sc, sc.ensemble)
    assert crafts is sc.spacecraft and sw is sc.software and sw.inertia is None
    dtheta, domega, _ = sc.ensemble.draws(0, 4)
    w = canonical.angular_velocity(q, Q, sc.spacecraft)
    q0, Q0, _ = canonical.project_state(sc.q0, sc.Q0)
    w0 = canonical.angular_velocity(q0, Q0, sc.spacecraft)
    np.testing.assert_allclose(w, w0 + domega, rtol=0, atol=1e-15)
    np.testing.assert_allclose(q, qt.multiply(q0, qt.from_rotation_vector(dtheta)), atol=0)


@pytest.mark.parametrize(
    ("change", "key"),
    [
        (("size = 4", 'size = 4\noutput = "statistics"'), "ensemble.output: .* stores its members"),
    ],
)  # fmt: skip
def test_what_a_spacecraft_ensemble_cannot_store_is_refused_naming_the_key(change, key):
    with pytest.raises(ScenarioError, match=rf"^{key}"):
        scenario.loads(TOML.replace(*change))


class _Stop(Exception):
    pass


def test_too_large_an_ensemble_is_refused_before_its_members_are_drawn(tmp_path, monkeypatch):
    """10⁹ members would not fit in memory: the size, from 1- and 2-member probes, is refused
    before the members are drawn; the probes' estimate is the run's own."""
    from attitude.ensemble import _plan
    from attitude.ensemble import _spacecraft_scenario as S
    from attitude.errors import OutputSizeError

    members_of, check_size = S.members_of, _plan.check_size
    drawn, expected = [], []

    def spy(sc, d):
        drawn.append(d.size)
        return members_of(sc, d)

    def check(nbytes, *args):
        expected.append(nbytes)
        return check_size(nbytes, *args)

    monkeypatch.setattr(S, "members_of", spy)
    monkeypatch.setattr(_plan, "check_size", check)
    sc = scenario.loads(TOML.replace("size = 4", "size = 1000000000"))
    with pytest.raises(OutputSizeError, match=r"^max_output_size: .*\(1000000000 members"):
        run_scenario(sc, tmp_path / "big.nc")
    assert drawn == [1, 2] and not (tmp_path / "big.nc").exists()

    def stop(nbytes):
        raise _Stop(nbytes)

    monkeypatch.setattr(S, "PROBE_ABOVE", 0)
    drawn.clear()
    expected.clear()
    sc = scenario.loads(TOML.replace("size = 4", "size = 5"))
    with pytest.raises(_Stop):
        run_scenario(sc, tmp_path / "five.nc", on_estimate=stop)
    assert drawn == [1, 2, 5] and len(expected) == 4  # probes 1, 2; the probes' 5; the run's 5
    assert expected[2] == expected[3]


def test_shipped_closed_loop_ensemble_scenario_runs_from_the_cli(tmp_path, capsys):
    """scenarios/ensemble_rw_inertial_pointing.toml through `attitude run` (30 s of its 3 min):
    the ensemble file with every member, read back by info; --scheduler is refused clearly."""
    from pathlib import Path

    from attitude.cli import main

    path = Path(__file__).resolve().parents[1] / "scenarios/ensemble_rw_inertial_pointing.toml"
    out = tmp_path / "rw.nc"
    assert main(["run", str(path), "-o", str(out), "--stop", "30"]) == 0
    text = capsys.readouterr().out
    assert "ensemble    8 members (seed 2026)" in text and "max | |q| - 1 |" in text
    ds = io.read(out)
    assert ds.sizes["member"] == 8 and ds.sizes["sensor"] == 2
    assert (ds.member_status.values == 0).all() and ds.time.values[-1] == 30.0
    assert np.isfinite(ds.error_angle.values).all() and np.isfinite(ds.estimation_error).all()
    assert len(np.unique(ds.inertia.values[:, 0])) == 8  # dispersed
    assert main(["info", str(out)]) == 0
    assert "invariants  max" in capsys.readouterr().out
    code = main(["run", str(path), "-o", str(tmp_path / "x.nc"), "--scheduler", "tcp://h:1"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("attitude: error: --scheduler: ") and err.count("\n") == 1

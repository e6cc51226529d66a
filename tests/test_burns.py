"""attitude.software.Burn: thrusters fired by the flight software for an orbit manoeuvre while
its modes hold the attitude (attitude/software/_burns.py)."""

from __future__ import annotations

import numpy as np
import pytest

import attitude
import orbit
from attitude import RigidBody, Spacecraft, frames
from attitude.actuators import ReactionWheel, Thruster
from attitude.control import MRPFeedback
from attitude.software import Burn, FlightSoftware

EPOCH = "2026-03-20T00:00:00"


def _craft(mass):
    o = orbit.NumericalOrbit([1e5, 0.0, 0.0], [0.0, 0.0, 0.0], EPOCH, mu=1e-20)  # no pull
    wheels = [ReactionWheel(a, 1e-3, max_torque=0.05) for a in np.eye(3)]
    th = Thruster([-0.5, 0.0, 0.0], [1.0, 0.0, 0.0], 2.0, name="main")
    return Spacecraft(RigidBody([10.0, 12.0, 14.0]), wheels, thrusters=[th], orbit=o, mass=mass)


def test_a_burn_fires_its_thruster_for_its_window():
    # the window [3.05, 7.05) s at 10 Hz: on at the ticks 3.1 ... 7.0 (the first tick at or
    # after the start), the last one for the 0.05 s of its period left
    craft = _craft(200.0)
    fsw = FlightSoftware(0.1, frames.inertial(), MRPFeedback(1.0, 5.0), record_every=1,
                         burns=[Burn(3.05, 4.0, "main")])  # fmt: skip
    t = np.linspace(0.0, 10.0, 101)
    ds = attitude.propagate(craft, [1.0, 0, 0, 0], np.zeros(4), t, software=fsw,
                            method="dop853", rtol=1e-12, atol=1e-12)  # fmt: skip
    dv = ds.velocity.values[-1, 0] - ds.velocity.values[0, 0]
    impulse = 2.0 * (7.05 - 3.1)  # N s: whole periods from 3.1 s, then half of the last
    assert abs(dv / (impulse / 200.0) - 1.0) < 1e-9
    force = ds.thruster_force.values[:, 0]
    assert np.all(force[(t > 3.15) & (t < 6.95)] == 2.0) and np.all(force[t < 3.05] == 0.0)


def test_bad_burns():
    with pytest.raises(attitude.AttitudeValueError, match="duration"):
        Burn(0.0, -1.0)
    with pytest.raises(attitude.AttitudeTypeError, match="thrusters"):
        Burn(0.0, 1.0, thrusters=[True])
    with pytest.raises(attitude.AttitudeTypeError, match="burns"):
        FlightSoftware(0.1, frames.inertial(), MRPFeedback(1.0, 5.0), burns=["soon"])
    craft = _craft(200.0)
    for bad, match in ((Burn(1.0, 1.0, "aux"), "no thruster named"), (Burn(1.0, 1.0, 3), "of a")):
        fsw = FlightSoftware(0.1, frames.inertial(), MRPFeedback(1.0, 5.0), burns=[bad])
        with pytest.raises(attitude.AttitudeValueError, match=match):
            attitude.propagate(craft, [1.0, 0, 0, 0], np.zeros(4), [0.0, 1.0], software=fsw)

"""docs/figures/closed_loop_*.png: the closed-loop figures of the README and docs/sensors.md.

Run from the repository root: ``python docs/scripts/closed_loop_figures.py`` (about 5 min on
two cores, most of it compiling the first time). The three shipped closed-loop scenarios are
exactly ``attitude run scenarios/NAME.toml && attitude plot NAME.nc``; the fourth is the
inertial-pointing spacecraft of docs/sensors.md (a gyro and a 2 Hz star tracker through the
MEKF) that damps its rates for a minute, then points: the estimation error inside its ±3σ
bounds and the gyro bias estimate against the truth.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import numpy as np
from astropy import units as u

import attitude
from attitude import frames, io, scenario
from attitude.actuators import ReactionWheel
from attitude.control import MRPFeedback, RateDamping
from attitude.estimation import MEKF
from attitude.plotting import plot_result
from attitude.sensors import Gyro, StarTracker
from attitude.software import After, FlightSoftware, Mode

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "docs" / "figures"

for name in ("rw_inertial_pointing", "cubesat_bdot", "nadir_wheels_dumping"):
    with tempfile.TemporaryDirectory() as tmp:
        nc = Path(tmp) / f"{name}.nc"
        scenario.load(ROOT / "scenarios" / f"{name}.toml").run_to_file(nc)
        plot_result(io.read(nc), OUT / f"closed_loop_{name}.png")

rpm = 2 * np.pi / 60
wheels = [
    ReactionWheel(a, 50 / (6000 * rpm), speed=s * rpm, max_torque=0.2, max_speed=6000 * rpm)
    for a, s in zip(np.eye(3), (100, 200, 300), strict=True)
]
craft = attitude.Spacecraft(attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2"), wheels)
q0 = attitude.quaternion.from_mrp([0.1, 0.2, -0.3])
Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
gyro = Gyro(arw=0.05 * u.deg / u.hour**0.5, rrw=2e-9 * u.rad / u.s**1.5,
            bias=[3.0, -2.0, 1.5] * u.deg / u.hour, seed=1)  # fmt: skip
tracker = StarTracker([6, 45] * u.arcsec, boresight=[0.0, 0.6, 0.8], rate=2 * u.Hz, seed=2)
modes = [
    (None, Mode(control=RateDamping(30.0), name="damping")),
    (After(60.0), Mode(frames.inertial(), MRPFeedback(3.5, 30.0), name="pointing")),
]
fsw = FlightSoftware(0.5, modes=modes, sensors=[gyro, tracker], estimator=MEKF())
ds = attitude.propagate(craft, q0, Q0, np.linspace(0.0, 1200.0, 1201), software=fsw)
ds.attrs["title"] = (
    "Rate damping, then inertial pointing through a gyro, a star tracker and the MEKF"
)
plot_result(ds, OUT / "closed_loop_mekf.png")

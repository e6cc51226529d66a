"""A class where the closed-loop API expects an instance (issue 39): refused at once, naming
the parameter, the class and how to make one, never at the first tick."""

from __future__ import annotations

import astropy.units as u
import numpy as np
import pytest

from attitude import frames
from attitude.control import MomentumDumping, MRPFeedback, RateDamping, WheelAllocation
from attitude.errors import AttitudeTypeError
from attitude.estimation import MEKF
from attitude.sensors import Gyro, StarTracker
from attitude.software import FlightSoftware, Mode, RateBelow, Slew


@pytest.mark.parametrize(
    ("kwargs", "expected"),
    [
        ({"control": MRPFeedback}, "control: got the class MRPFeedback; give an instance, "
         "e.g. MRPFeedback(K=..., P=...)"),
        ({"control": (MRPFeedback(K=1.0, P=2.0), MomentumDumping)},
         "control: got the class MomentumDumping; give an instance, "
         "e.g. MomentumDumping(gain=...)"),
        ({"control": RateDamping(1.0), "allocation": WheelAllocation},
         "allocation: got the class WheelAllocation; give an instance, e.g. WheelAllocation()"),
        ({"guidance": Slew}, "guidance: got the class Slew; give an instance, "
         "e.g. Slew(target=..., max_rate=..., max_accel=...)"),
        ({"sensors": Gyro}, "sensors: got the class Gyro; give an instance, e.g. Gyro(arw=...)"),
        ({"sensors": [Gyro(1e-6), StarTracker]},
         "sensors[1]: got the class StarTracker; give an instance, e.g. StarTracker(noise=...)"),
        ({"sensors": [Gyro(1e-6)], "estimator": MEKF}, "estimator: got the class MEKF; "),
    ],
)  # fmt: skip
def test_flight_software_refuses_classes(kwargs, expected):
    with pytest.raises(AttitudeTypeError) as err:
        FlightSoftware(0.1, **kwargs)
    assert str(err.value).startswith(expected)


def test_mode_and_condition_classes_refused():
    with pytest.raises(AttitudeTypeError, match=r"^control: got the class MRPFeedback; give an"):
        Mode(frames.inertial(), MRPFeedback)
    rate = RateDamping(1.0)
    with pytest.raises(AttitudeTypeError, match=r"^modes\[1\]: got the class Mode; give an"):
        FlightSoftware(0.1, modes=[(None, Mode(control=rate)), (RateBelow(1e-3), Mode)])
    with pytest.raises(
        AttitudeTypeError,
        match=r"^modes\[1\] condition: got the class RateBelow; .*RateBelow\(rate=\.\.\.\)$",
    ):
        FlightSoftware(0.1, modes=[(None, Mode(control=rate)), (RateBelow, Mode(control=rate))])


def test_instances_still_accepted():
    fsw = FlightSoftware(
        0.1,
        modes=[
            (None, Mode(control=RateDamping(1.0))),
            (RateBelow(0.5 * u.deg / u.s), Mode(frames.inertial(), MRPFeedback(K=1.0, P=2.0))),
        ],
        sensors=[Gyro(1e-6)],
    )
    assert len(fsw.modes) == 2
    assert isinstance(fsw.modes[1][1].control, MRPFeedback)
    assert np.isclose(fsw.modes[1][0].threshold, np.deg2rad(0.5))

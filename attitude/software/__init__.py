"""Flight software in the loop: :class:`FlightSoftware`, its modes, guidance and conditions.

The loop of a real spacecraft, run inside the propagation at the software's own task rate
(docs/flight_software.md): sensors → estimator → guidance → control law
(:mod:`attitude.control`) → allocation → actuators (:mod:`attitude.actuators`), the commands
held from one tick to the next. Passed as ``propagate(spacecraft, ..., software=fsw)``.
"""

from __future__ import annotations

from ._burns import Burn
from ._guidance import Slew
from ._modes import After, Condition, PointingBeyond, PointingWithin, RateAbove, RateBelow
from ._software import FlightSoftware, MeasurementIndex, Measurements, Mode

__all__ = [
    "After",
    "Burn",
    "Condition",
    "FlightSoftware",
    "MeasurementIndex",
    "Measurements",
    "Mode",
    "PointingBeyond",
    "PointingWithin",
    "RateAbove",
    "RateBelow",
    "Slew",
]

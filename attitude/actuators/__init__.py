"""Actuators: reaction wheels, magnetorquers, thrusters, and open-loop command schedules.

The actuators of an :class:`attitude.Spacecraft`; commanded open loop by a
:class:`CommandSchedule` (``propagate(spacecraft, ..., commands=schedule)``) or, tick by tick,
by the flight software. The physics (the gyrostat in canonical variables, friction and
command limits as Basilisk's reaction-wheel effector) is in docs/actuators.md; the compiled
kernels in :mod:`attitude._core.actuators` and :mod:`attitude._core.gyrostat`.
"""

from __future__ import annotations

from ._common import AxisNormalizedWarning
from .commands import CommandSchedule
from .magnetorquers import Magnetorquer
from .thrusters import Thruster
from .wheels import ISOTROPIC_ELEVATION, ReactionWheel, pyramid

__all__ = [
    "ISOTROPIC_ELEVATION",
    "AxisNormalizedWarning",
    "CommandSchedule",
    "Magnetorquer",
    "ReactionWheel",
    "Thruster",
    "pyramid",
]

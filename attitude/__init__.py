"""attitude: rigid-body attitude propagation in canonical quaternion variables.

Arribas, Elipe & Palacios (2006) write rigid-body rotation as a canonical Hamiltonian system in
two quaternions, the Euler parameters ``q`` and their conjugate momenta ``Q``. This package
propagates that system (and the classical formulations beside it) with compiled integrators,
driven by potentials such as the gravity gradient of a Keplerian orbit (package ``orbit``).

>>> import numpy as np, attitude
>>> body = attitude.RigidBody([1.25, 1.0, 0.75])
>>> q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
>>> Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.1, 0.7, 0.3], body)
>>> ds = attitude.propagate(body, q0, Q0, np.linspace(0, 100, 1001))

Conventions (docs/conventions.md): quaternions are ``(..., 4)`` float arrays, scalar first,
Hamilton product; ``q`` maps body components to space components, x_S = q∘x_B∘q̃.
"""

# ruff: noqa: E402  (the imports after the command's early signal handlers)
from __future__ import annotations

from . import _interrupt

# The command (python -m attitude, the console script): exit 130 on Ctrl-C or SIGTERM during
# the imports below (~0.7 s), before the command installs its handlers.
_interrupt.guard_command_start()

from . import accessor as _accessor  # registers the ``ds.attitude`` xarray accessor
from . import (
    actuators,
    canonical,
    control,
    errors,
    estimation,
    events,
    exact,
    formulations,
    frames,
    potentials,
    quaternion,
    sensors,
    software,
)
from ._version import __version__
from .actuators import CommandSchedule, Magnetorquer, ReactionWheel, Thruster
from .body import RigidBody
from .ensemble import (
    disperse,
    event_time_percentiles,
    pointing_error_percentiles,
    propagate_ensemble,
    rate_percentiles,
)
from .errors import (
    AttitudeError,
    AttitudeTypeError,
    AttitudeValueError,
    PropagationError,
    SingularityError,
)
from .exact import torque_free
from .facets import Facet, box_wing
from .frames import initial_state
from .potentials import (
    AerodynamicDrag,
    CustomPotential,
    CustomTorque,
    EddyCurrentDamping,
    GravityGradient,
    HeavyTop,
    MagneticDipole,
    Potential,
    SolarRadiation,
    TorqueFree,
)
from .propagate import propagate
from .results import Trajectory
from .software import FlightSoftware
from .spacecraft import Spacecraft

del _accessor

__all__ = [
    "AerodynamicDrag",
    "AttitudeError",
    "AttitudeTypeError",
    "AttitudeValueError",
    "CommandSchedule",
    "CustomPotential",
    "CustomTorque",
    "EddyCurrentDamping",
    "Facet",
    "FlightSoftware",
    "GravityGradient",
    "HeavyTop",
    "MagneticDipole",
    "Magnetorquer",
    "Potential",
    "PropagationError",
    "ReactionWheel",
    "RigidBody",
    "SingularityError",
    "SolarRadiation",
    "Spacecraft",
    "Thruster",
    "TorqueFree",
    "Trajectory",
    "__version__",
    "actuators",
    "box_wing",
    "canonical",
    "control",
    "disperse",
    "errors",
    "estimation",
    "event_time_percentiles",
    "events",
    "exact",
    "formulations",
    "frames",
    "initial_state",
    "pointing_error_percentiles",
    "potentials",
    "propagate",
    "propagate_ensemble",
    "quaternion",
    "rate_percentiles",
    "sensors",
    "software",
    "torque_free",
]

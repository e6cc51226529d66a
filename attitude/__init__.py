"""attitude: rigid-body attitude propagation in canonical quaternion variables.

Arribas, Elipe & Palacios (2006) write rigid-body rotation as a canonical Hamiltonian system in
two quaternions, the Euler parameters ``q`` and their conjugate momenta ``Q``. This package
propagates that system (and the classical formulations beside it) with compiled integrators,
driven by potentials such as the gravity gradient of a Keplerian orbit (package ``orbit``).
"""

from __future__ import annotations

from . import errors, quaternion
from ._version import __version__
from .errors import (
    AttitudeError,
    AttitudeTypeError,
    AttitudeValueError,
    PropagationError,
    SingularityError,
)

__all__ = [
    "AttitudeError",
    "AttitudeTypeError",
    "AttitudeValueError",
    "PropagationError",
    "SingularityError",
    "__version__",
    "errors",
    "quaternion",
]

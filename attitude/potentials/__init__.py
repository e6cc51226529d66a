"""Potentials and torques acting on the body.

The torque models of the public namespace ``attitude.potentials`` (a contract: every name below
is imported from here), one family a module: the base class and sums (``_base``), gravity
(``_gravity``), the environment of a spacecraft in Earth orbit (``_environment_torques``) and
your own models (``_user``), each a small class over data for the compiled kernels; their kernels
live in ``_core/potentials.py`` and ``_core/environment.py``, the environment along the orbit in
``attitude/environment.py``.

A potential gives, for an attitude ``q`` at time ``t``: its value U(q, t), the body-frame torque
τ_B(q, t) and the generalised force that enters Hamilton's equations (Arribas et al. eq. 7),

    F = 2 q∘(0, τ_B)        (Schwab eq. 25)

which is minus the tangential part of ∂U/∂q. Using F instead of a plain −∂U/∂q of the
quadratic forms in eqs. 18 and 20 keeps |q| = 1 and q·Q = 0 exact invariants of the flow.

Built in: :class:`TorqueFree`, :class:`HeavyTop`, :class:`GravityGradient`, and the
environment of a spacecraft in Earth orbit: :class:`MagneticDipole`, :class:`EddyCurrentDamping`,
:class:`AerodynamicDrag`, :class:`SolarRadiation` (surfaces: :class:`attitude.Facet`). User physics:
:class:`CustomPotential` (write U(q, t), the torque is derived exactly by complex-step
differentiation) and :class:`CustomTorque` (write τ_B(q, t) directly). All of them run inside
the compiled integrators.
"""

from __future__ import annotations

# The public models (``__all__``), and (``X as X``: re-exported) the other names of the module
# this package replaced, which code in and out of the package imports from here: the
# propagators' check of ``potential``, the environment's length, the checks of a field setting
# and of user functions (attitude.events), and the helpers that module imported.
from orbit._shared_jit import JIT_DISABLED as JIT_DISABLED

from .._validation import as_float_array as as_float_array
from .._validation import as_quaternion as as_quaternion
from .._validation import as_scalar as as_scalar
from ..body import RigidBody as RigidBody
from ..errors import AttitudeTypeError as AttitudeTypeError
from ..errors import AttitudeValueError as AttitudeValueError
from ..facets import Facet
from ..facets import drag_groups as drag_groups
from ..facets import facet_array as facet_array
from ..facets import optical_groups as optical_groups
from ._base import Potential, Sum, TorqueFree
from ._base import as_potential as as_potential
from ._environment_torques import (
    AerodynamicDrag,
    EddyCurrentDamping,
    MagneticDipole,
    SolarRadiation,
)
from ._environment_torques import check_field as check_field
from ._gravity import GravityGradient, HeavyTop
from ._user import ENVIRONMENT_SIZE as ENVIRONMENT_SIZE
from ._user import CustomPotential, CustomTorque, EnvironmentIndex
from ._user import _arity as _arity
from ._user import _compile_user as _compile_user

__all__ = [
    "AerodynamicDrag",
    "CustomPotential",
    "CustomTorque",
    "EddyCurrentDamping",
    "EnvironmentIndex",
    "Facet",
    "GravityGradient",
    "HeavyTop",
    "MagneticDipole",
    "Potential",
    "SolarRadiation",
    "Sum",
    "TorqueFree",
]

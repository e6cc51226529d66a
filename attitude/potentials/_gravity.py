"""Gravity: the heavy top (uniform gravity about a fixed point) and the gravity gradient of a
central mass along an orbit (Arribas et al. Sect. 6), built-in models: data behind the package's
cached kernels (:mod:`attitude._core.potentials`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._core import models as _models
from .._core import potentials as _kp
from .._validation import as_float_array, as_scalar
from ..body import RigidBody
from ..errors import AttitudeTypeError, AttitudeValueError
from ._base import Potential

__all__ = [
    "GravityGradient",
    "HeavyTop",
]


class HeavyTop(Potential):
    """A heavy body about a fixed point O in uniform gravity along −s3 (Arribas et al. Sect. 6.1).

    Parameters
    ----------
    weight : float or Quantity
        M g > 0 (force units consistent with the inertia and time units: N for a body in SI,
        i.e. with units; a Quantity is converted to N).
    center_of_mass : array_like or Quantity, shape (3,)
        Position of the centre of mass relative to O, in body axes (m for a Quantity). With
        the inertia in kg m² the torque is in N m and the energy in J.

    Notes
    -----
    V(q) = weight · (q∘x^c∘q̃)·s3, the physical potential energy (height of the centre of mass
    times the weight). Arribas et al. eq. 18 prints U = x^c·F with F = −Mg s3 in body axes,
    which is −V: with that sign the "heavy" top would fall upwards. The torque is
    τ_B = x^c × F_B, F_B = q̃∘(−weight s3)∘q. See docs/potentials.md.
    """

    name = "heavy_top"
    _kind = _kp.KIND_HEAVY_TOP

    def __init__(self, weight: Any, center_of_mass: Any):
        w = as_scalar(weight, "weight", unit="N")
        if not w > 0:
            raise AttitudeValueError(f"weight: must be M g > 0, got {w}")
        c = as_float_array(center_of_mass, "center_of_mass", unit="m")
        if c.shape != (3,):
            raise AttitudeValueError(
                f"center_of_mass: expected 3 body-axis components, got shape {c.shape}"
            )
        self.weight = w
        self.center_of_mass = c

    def _potential_params(self) -> list[float]:
        # the block after its kind (attitude._core.potentials HEAVY_TOP)
        return list(_kp.HEAVY_TOP.pack(weight=self.weight, cm=self.center_of_mass)[1:])

    def __repr__(self) -> str:
        return f"HeavyTop(weight={self.weight!r}, center_of_mass={self.center_of_mass.tolist()})"


class GravityGradient(Potential):
    """Gravity-gradient torque of a central mass on a body moving along an orbit (eq. 20).

    U = 3μ/(2r³) x̂_B·I x̂_B, x̂_B = q̃∘r̂_S∘q, with r(t) and the radial direction r̂_S(t) from the
    orbit at the same t, evaluated inside the compiled right-hand side (Arribas et al.
    Sect. 6.2). Torque τ_B = 3μ/r³ x̂_B × (I x̂_B).

    Parameters
    ----------
    orbit : orbit.KeplerOrbit, orbit.SecularJ2Orbit or orbit.EphemerisOrbit
        The orbit of the centre of mass (any :class:`orbit.base.Orbit`: km, s; μ in km³ s⁻²).
        The compiled kernels read it through ``orbit.kernel_data()`` (one dispatcher over the
        orbit types), so every source runs in the same cached integrator.
    inertia : RigidBody or array_like, optional
        The body's principal moments (a RigidBody with units is in kg m²). Needed only to
        evaluate ``value``/``torque`` directly; :func:`attitude.propagate` takes them from the
        body.

    Notes
    -----
    3μ/r³ is in s⁻² whatever the length unit (μ in km³ s⁻², r in km), so a body in SI
    (kg m²) gets U in J and τ_B in N m with no conversion.
    """

    name = "gravity_gradient"
    _kind = _kp.KIND_GRAVITY_GRADIENT
    time_dependent = True

    def __init__(self, orbit: Any, inertia: Any = None):
        if not hasattr(orbit, "kernel_data"):
            raise AttitudeTypeError(
                "orbit: expected an orbit (orbit.KeplerOrbit, orbit.SecularJ2Orbit, "
                f"orbit.EphemerisOrbit), got {type(orbit).__name__}"
            )
        self.orbit = orbit
        if inertia is None:
            self.inertia = None
        elif isinstance(inertia, RigidBody):
            self.inertia = inertia.inertia
        else:
            self.inertia = RigidBody(inertia).inertia

    @property
    def _orbit_data(self) -> np.ndarray:
        # read at each use: a NumericalOrbit's table grows as its orbit is integrated on
        return np.ascontiguousarray(self.orbit.kernel_data(), dtype=np.float64)

    def _params(self, inertia: np.ndarray) -> np.ndarray:
        head = np.array([*inertia, self._kind], dtype=np.float64)
        return np.concatenate([head, self._orbit_data])

    def _potential_params(self) -> list[float]:
        return list(self._orbit_data)

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise if the orbit is not defined at some of the times (an ephemeris table's span)."""
        self.orbit.check_times(t, name)

    def _entry_points(self, closed_loop: bool = False):
        return _models.entry_points(self._kind, self._orbit_data, closed_loop=closed_loop)

    def _inertia_for_eval(self) -> np.ndarray:
        if self.inertia is None:
            raise AttitudeValueError(
                "inertia: GravityGradient needs the body's principal moments to evaluate U or "
                "the torque; give GravityGradient(orbit, inertia=...) (propagate supplies them)"
            )
        return self.inertia

    def bind(self, body: RigidBody) -> GravityGradient:
        if self.inertia is not None and not np.allclose(self.inertia, body.inertia, rtol=1e-12):
            raise AttitudeValueError(
                f"inertia: the GravityGradient was built for inertia {self.inertia.tolist()} but "
                f"the body has {body.inertia.tolist()}; they must be the same body"
            )
        return GravityGradient(self.orbit, body)

    def __repr__(self) -> str:
        return f"GravityGradient(orbit={self.orbit!r})"

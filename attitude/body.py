"""The rigid body: principal moments of inertia, validated once.

A body with units is held in SI (kg m²): inertia given in any unit (a Quantity, or plain numbers
with ``units=``) is converted once, here, so that every result of such a body is in SI (angular
momentum kg m² s⁻¹, torque N m, energy J; docs/results.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ._validation import as_float_array
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["SI_INERTIA", "RigidBody"]

#: The unit of the inertia of a body with units (and the ``units`` label it carries): SI, in a
#: spelling that astropy, UDUNITS (cf_units) and pint's default registry all parse.
SI_INERTIA = "kg m^2"

# Relative slack allowed in the triangle inequalities I_i + I_j >= I_k (a flat plate meets
# one of them with equality, and rounding of measured inertias must not reject it).
_TRIANGLE_RTOL = 1e-12


@dataclass(frozen=True)
class RigidBody:
    """A rigid body described by its principal moments of inertia.

    Parameters
    ----------
    inertia : array_like or Quantity, shape (3,)
        Principal moments ``(I1, I2, I3)`` about the body axes b1, b2, b3. Plain numbers are
        taken in the caller's consistent unit system (the paper's examples are dimensionless);
        an astropy Quantity is converted to kg m² (SI).
    units : str, optional
        Unit of plain-number ``inertia``, e.g. ``"kg m2"`` or ``"kg km2"``: the numbers are
        converted to kg m². ``None`` (default) means dimensionless unless ``inertia`` is a
        Quantity. After construction ``units`` is :data:`SI_INERTIA` or None.

    Raises
    ------
    AttitudeValueError
        If a moment is not finite and positive or the triangle inequalities fail.
    """

    inertia: np.ndarray
    units: str | None = None

    def __init__(self, inertia: Any, units: str | None = None):
        try:
            from astropy import units as u

            is_quantity = isinstance(inertia, u.Quantity)
        except ImportError:  # pragma: no cover
            is_quantity = False
        if is_quantity:
            arr = as_float_array(inertia, "inertia", unit=SI_INERTIA)
            units = SI_INERTIA
        else:
            arr = as_float_array(inertia, "inertia")
            if units is not None:
                from astropy import units as u

                if not isinstance(units, str):
                    raise AttitudeTypeError(
                        f"units: expected a unit string such as 'kg m2', got {type(units).__name__}"
                    )
                try:
                    arr = (arr * u.Unit(units)).to_value(SI_INERTIA)
                except (ValueError, TypeError, u.UnitConversionError) as exc:
                    raise AttitudeValueError(
                        f"units: {units!r} is not a moment-of-inertia unit (e.g. 'kg m2')"
                    ) from exc
                units = SI_INERTIA
        if arr.shape != (3,):
            raise AttitudeValueError(
                f"inertia: expected the three principal moments (I1, I2, I3), got shape "
                f"{arr.shape}; for a full tensor use RigidBody.from_tensor(J)"
            )
        moments = arr.tolist()  # plain floats: the checks below cost ~1 µs, not ~5
        if not all(m > 0 for m in moments):
            raise AttitudeValueError(f"inertia: principal moments must be positive, got {arr}")
        for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            if moments[i] + moments[j] < moments[k] * (1.0 - _TRIANGLE_RTOL):
                raise AttitudeValueError(
                    f"inertia: violates the triangle inequality I{i + 1} + I{j + 1} >= I{k + 1} "
                    f"({arr[i]} + {arr[j]} < {arr[k]}); no rigid body has these moments"
                )
        arr.setflags(write=False)
        object.__setattr__(self, "inertia", arr)
        object.__setattr__(self, "units", units)

    @classmethod
    def from_tensor(cls, J: Any, units: str | None = None) -> tuple[RigidBody, np.ndarray]:
        """Diagonalise a symmetric inertia tensor.

        Parameters
        ----------
        J : array_like or Quantity, shape (3, 3)
            Inertia tensor in some body-fixed frame F.
        units : str, optional
            As for :class:`RigidBody`.

        Returns
        -------
        body : RigidBody
            Principal moments in ascending order.
        q_pf : ndarray, shape (4,)
            Unit quaternion from the principal frame P to F: ``x_F = q_pf∘x_P∘q̃_pf``, so
            ``J = R diag(I) Rᵀ`` with ``R = quaternion.to_matrix(q_pf)``. An attitude of the
            principal axes in space is ``q_sp = q_sf∘q_pf``.
        """
        from astropy import units as u

        from_quantity = isinstance(J, u.Quantity)
        J = as_float_array(J, "J", unit=SI_INERTIA if from_quantity else None)
        if J.shape != (3, 3):
            raise AttitudeValueError(f"J: expected a 3x3 inertia tensor, got shape {J.shape}")
        scale = np.max(np.abs(J))
        if not np.allclose(J, J.T, rtol=0.0, atol=1e-12 * scale):
            raise AttitudeValueError("J: the inertia tensor must be symmetric")
        moments, vecs = np.linalg.eigh(0.5 * (J + J.T))
        if np.linalg.det(vecs) < 0:
            vecs[:, 2] = -vecs[:, 2]
        from .quaternion import from_matrix

        if from_quantity:
            body = cls(moments * u.Unit(SI_INERTIA))
        else:
            body = cls(moments, units=units)
        return body, from_matrix(vecs)

    @property
    def is_dimensionless(self) -> bool:
        """True when the inertia carries no unit (the paper's dimensionless examples)."""
        return self.units is None

    def __repr__(self) -> str:
        u = f", units={self.units!r}" if self.units else ""
        return f"RigidBody(inertia={self.inertia.tolist()}{u})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RigidBody):
            return NotImplemented
        return bool(np.array_equal(self.inertia, other.inertia)) and self.units == other.units

    def __hash__(self) -> int:
        return hash((tuple(self.inertia.tolist()), self.units))

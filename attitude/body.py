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

__all__ = ["SI_INERTIA", "RigidBody", "inertia_rows"]

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
        arr = arr.copy()  # (read-only: the caller's array stays writable)
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


def inertia_rows(
    inertia: Any, name: str = "inertia", row: str = "row"
) -> tuple[np.ndarray, str | None]:
    """The principal moments of one body, shape (3,), or of many, shape (N, 3) (one row per
    ensemble member), checked as :class:`RigidBody` checks one (positive, triangle
    inequalities), vectorised.

    Parameters
    ----------
    inertia : RigidBody, sequence of RigidBody, array_like or Quantity, shape (3,) or (N, 3)
        Plain numbers are dimensionless (as :class:`RigidBody`); a Quantity is converted to
        kg m² (SI).
    name, row : str
        The parameter's name and what a row is (``"member"``), for messages.

    Returns
    -------
    moments : ndarray, shape (3,) or (N, 3)
    units : str or None
        :data:`SI_INERTIA`, or None for dimensionless bodies.
    """
    if isinstance(inertia, RigidBody):
        return inertia.inertia, inertia.units
    if isinstance(inertia, (list, tuple)) and inertia and isinstance(inertia[0], RigidBody):
        if not all(isinstance(b, RigidBody) for b in inertia):
            raise AttitudeTypeError(f"{name}: a sequence mixing RigidBody and other objects")
        units = {b.units for b in inertia}
        if len(units) > 1:
            raise AttitudeValueError(
                f"{name}: the bodies mix unit systems {sorted(map(str, units))}; give them all "
                "in one (e.g. all as astropy Quantities in kg m2)"
            )
        return np.stack([b.inertia for b in inertia]), inertia[0].units
    from astropy import units as u

    is_quantity = isinstance(inertia, u.Quantity)
    arr = as_float_array(inertia, name, unit=SI_INERTIA if is_quantity else None)
    units = SI_INERTIA if is_quantity else None
    if arr.shape == (3,):
        return RigidBody(arr * u.Unit(SI_INERTIA) if is_quantity else arr).inertia, units
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise AttitudeValueError(
            f"{name}: expected the three principal moments (3,) of one body, or one row of "
            f"principal moments per member (N, 3), got shape {arr.shape}; for a full tensor "
            "use RigidBody.from_tensor(J)"
        )
    bad = ~np.all(arr > 0, axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise AttitudeValueError(
            f"{name}: {row} {i}: principal moments must be positive, got {arr[i].tolist()}"
        )
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        bad = arr[:, a] + arr[:, b] < arr[:, c] * (1.0 - _TRIANGLE_RTOL)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise AttitudeValueError(
                f"{name}: {row} {i}: {arr[i].tolist()} violates the triangle inequality "
                f"I{a + 1} + I{b + 1} >= I{c + 1}; no rigid body has these moments (dispersed "
                "inertia: attitude.ensemble.disperse truncates the errors so that every member "
                "is a rigid body)"
            )
    return arr, units

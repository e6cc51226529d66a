"""Magnetorquers: body-fixed coils whose commanded dipole acts in the geomagnetic field."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import AttitudeValueError
from ._common import limit, optional_name, unit_axis

__all__ = ["Magnetorquer", "magnetorquer_record"]


@dataclass(frozen=True, init=False)
class Magnetorquer:
    """A magnetic torque rod (or air coil) along a body-fixed axis.

    Its commanded dipole m (A m², clipped to ±``max_dipole``) acts along ``axis``; the torque
    on the spacecraft is τ = m â × B_B (Wertz 1978, Sect. 17.2.3), B_B the geomagnetic field
    in body axes from the same tables as :class:`attitude.MagneticDipole` (IGRF through
    ppigrf along the spacecraft's orbit, the same epoch rules).

    Parameters
    ----------
    axis : array_like, shape (3,)
        Dipole axis â in body axes (normalised; a warning if |â| is more than 1e-6 from 1).
    max_dipole : float or Quantity
        Largest dipole magnitude (A m²).
    name : str, optional
        Label in results (default ``magnetorquer<j>``).
    """

    axis: np.ndarray
    max_dipole: float
    name: str | None

    def __init__(self, axis: Any, max_dipole: Any, *, name: str | None = None):
        object.__setattr__(self, "axis", unit_axis(axis, "axis"))
        m = limit(max_dipole, "max_dipole", "A m2", "dipole limit")
        if not math.isfinite(m):
            raise AttitudeValueError("max_dipole: the dipole limit must be finite")
        object.__setattr__(self, "max_dipole", m)
        object.__setattr__(self, "name", optional_name(name, "magnetorquer"))

    def __repr__(self) -> str:
        tail = f", name={self.name!r}" if self.name else ""
        return f"Magnetorquer(axis={self.axis.tolist()}, max_dipole={self.max_dipole!r}{tail})"


def magnetorquer_record(m: Magnetorquer) -> np.ndarray:
    """The magnetorquer's record of the spacecraft block (held slots zero)."""
    from .._core import actuators as _ka

    return _ka.MTQ.pack(axis=m.axis, max=m.max_dipole)

"""Validation shared by the actuator classes: axes, limits, non-negative coefficients."""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from .._validation import as_float_array, as_scalar
from ..errors import AttitudeTypeError, AttitudeValueError

#: Relative departure from |axis| = 1 above which an axis is normalised with a warning.
AXIS_TOLERANCE = 1e-6


class AxisNormalizedWarning(UserWarning):
    """An actuator axis given with |a| more than 1e-6 away from 1 was normalised."""


def unit_axis(x: Any, name: str) -> np.ndarray:
    """A unit 3-vector from ``x`` (normalised; a warning when it was more than 1e-6 off)."""
    a = as_float_array(x, name)
    if a.shape != (3,):
        raise AttitudeValueError(f"{name}: expected 3 body-axis components, got shape {a.shape}")
    n = float(np.linalg.norm(a))
    if not n > 0.0 or not math.isfinite(n):
        raise AttitudeValueError(f"{name}: the zero vector has no direction; give a unit vector")
    if abs(n - 1.0) > AXIS_TOLERANCE:
        warnings.warn(
            f"{name}: |{name}| = {n:.9g}, normalised to a unit vector",
            AxisNormalizedWarning,
            stacklevel=3,
        )
    out = a / n
    out.setflags(write=False)
    return out


def limit(x: Any, name: str, unit: str, what: str) -> float:
    """A positive limit, ``math.inf`` for none (the default)."""
    if isinstance(x, (int, float)) and not isinstance(x, bool) and x == math.inf:
        return math.inf
    v = _scalar(x, name, unit)
    if v == math.inf:
        return v
    if not v > 0.0:
        raise AttitudeValueError(
            f"{name}: the {what} must be positive (or inf for none), got {v!r}"
        )
    return v


def nonnegative(x: Any, name: str, unit: str, what: str) -> float:
    """A finite number >= 0."""
    v = _scalar(x, name, unit)
    if not (v >= 0.0 and math.isfinite(v)):
        raise AttitudeValueError(f"{name}: the {what} must be finite and >= 0, got {v!r}")
    return v


def _scalar(x: Any, name: str, unit: str) -> float:
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            x = x.to_value(unit, equivalencies=u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(
                f"{name}: units {x.unit} cannot be converted to {u.Unit(unit)}"
            ) from None
    if isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_)):
        if float(x) == math.inf:
            return math.inf
    return as_scalar(x, name)


def speeds_value(x: Any, name: str) -> Any:
    """Wheel speeds from rad/s numbers or angular-rate Quantities (rpm: ``u.cycle / u.min``)."""
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            return x.to_value(u.rad / u.s, u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(
                f"{name}: units {x.unit} are not an angular rate (rad/s, or rpm as u.cycle / u.min)"
            ) from None
    return x


def optional_name(name: Any, what: str) -> str | None:
    """A label for results (``None``: numbered by position)."""
    if name is None:
        return None
    if not isinstance(name, str) or not name or any(ord(c) < 32 for c in name):
        raise AttitudeTypeError(f"name: expected a non-empty one-line string for the {what}")
    return name

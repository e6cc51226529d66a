"""Input validation and unit conversion at the public boundary.

Every public function converts its arguments here, once, before any work: plain float64
arrays come out, or an :mod:`attitude.errors` exception naming the argument and the fix.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "as_float_array",
    "as_quaternion",
    "as_rate",
    "as_times",
    "as_vector",
    "to_value",
]


def to_value(x: Any, name: str, unit: Any = None) -> Any:
    """Strip astropy units from ``x`` after converting to ``unit`` (a string or Unit).

    Plain numbers and arrays pass through unchanged (they are taken to be in ``unit``).
    """
    try:
        from astropy import units as u
    except ImportError:  # pragma: no cover - astropy is a dependency
        return x
    if isinstance(x, u.Quantity):
        if unit is None:
            if x.unit.is_equivalent(u.dimensionless_unscaled):
                return x.to_value(u.dimensionless_unscaled)
            raise AttitudeTypeError(
                f"{name}: expected a plain number or dimensionless quantity, got units {x.unit}"
            )
        try:
            return x.to_value(unit)
        except u.UnitConversionError as exc:
            raise AttitudeTypeError(
                f"{name}: units {x.unit} cannot be converted to {u.Unit(unit)}; "
                f"give {name} in units compatible with {u.Unit(unit)}"
            ) from exc
    return x


def as_float_array(
    x: Any, name: str, *, trailing: int | None = None, unit: Any = None, ndim: int | None = None
) -> np.ndarray:
    """Convert ``x`` to a finite float64 array, checking its trailing dimension.

    Raises
    ------
    AttitudeTypeError
        If ``x`` is not numeric.
    AttitudeValueError
        If the trailing dimension or ndim is wrong or any entry is NaN or infinite.
    """
    x = to_value(x, name, unit)
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise AttitudeTypeError(f"{name}: expected an array of real numbers, got {x!r}") from exc
    if ndim is not None and arr.ndim != ndim:
        raise AttitudeValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if trailing is not None and (arr.ndim == 0 or arr.shape[-1] != trailing):
        raise AttitudeValueError(f"{name}: expected shape (..., {trailing}), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise AttitudeValueError(f"{name}: contains a non-finite value (NaN or inf) at index {bad}")
    return arr


def as_quaternion(x: Any, name: str = "q", *, nonzero: bool = True) -> np.ndarray:
    """Convert to a finite ``(..., 4)`` float array; reject zero quaternions if ``nonzero``."""
    arr = as_float_array(x, name, trailing=4)
    if nonzero:
        if np.any(np.all(arr == 0.0, axis=-1)):
            raise AttitudeValueError(f"{name}: the zero quaternion does not represent a rotation")
    return arr


def as_vector(x: Any, name: str = "v", *, unit: Any = None) -> np.ndarray:
    """Convert to a finite ``(..., 3)`` float array."""
    return as_float_array(x, name, trailing=3, unit=unit)


def as_rate(x: Any, name: str, *, dimensional: bool, trailing: int | None = 3) -> np.ndarray:
    """Angular rates as a float array in rad/s (``dimensional``) or rad per time unit.

    A Quantity in any angular-rate unit (``deg/s``, ``rpm``, ``rad/min``...) is converted to
    rad/s for a body with units; for a dimensionless body (no time unit) only a Quantity in an
    angle unit is accepted (taken per time unit). Plain numbers are rad per time unit.
    """
    from astropy import units as u

    if isinstance(x, u.Quantity):
        target = u.rad / u.s if dimensional else u.rad
        try:
            x = x.to_value(target, equivalencies=u.dimensionless_angles())
        except u.UnitConversionError:
            hint = (
                "an angular rate such as deg/s or rad/s"
                if dimensional
                else "plain numbers (rad per time unit): the body is dimensionless, so there is "
                "no time unit to convert a rate to; give the body units (e.g. 'kg m2') to use "
                "deg/s"
            )
            raise AttitudeTypeError(
                f"{name}: units {x.unit} cannot be used here; give {hint}"
            ) from None
    return as_float_array(x, name, trailing=trailing)


def as_times(t: Any, name: str = "t", *, unit: Any = "s") -> np.ndarray:
    """Convert output times to a finite, strictly increasing 1-D float array (at least 1 entry)."""
    arr = as_float_array(t, name, unit=unit)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise AttitudeValueError(f"{name}: expected a 1-D array of times, got shape {arr.shape}")
    if arr.size < 1:
        raise AttitudeValueError(f"{name}: needs at least one time (the initial epoch)")
    if arr.size > 1:
        # boolean comparisons (1 byte per sample), not np.diff: long runs pass 1e7 times
        up = arr[1:] > arr[:-1]
        if not up.all():
            down = arr[1:] < arr[:-1]
            if not down.all():
                i = int(np.argmin(up)) if up[0] else int(np.argmin(down))
                a, b = float(arr[i]), float(arr[i + 1])
                raise AttitudeValueError(
                    f"{name}: times must be strictly monotonic (increasing, or decreasing for a "
                    f"backward run); {name}[{i}] = {a!r} and {name}[{i + 1}] = {b!r}"
                )
    return arr

"""Input validation and unit conversion at the public boundary.

Every public function converts its arguments here, once, before any work: plain float64
arrays come out, or an :mod:`attitude.errors` exception naming the argument and the fix.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._times import TimeGrid
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "ATOL_MIN",
    "as_atol",
    "as_bool",
    "as_float_array",
    "as_int",
    "as_positive",
    "as_quaternion",
    "as_rate",
    "as_scalar",
    "as_times",
    "as_vector",
    "refuse_class",
    "to_value",
]

#: dtype kinds that are not real numbers: strings, bytes, void, booleans, complex, dates.
_NOT_REAL = {
    "U": "strings",
    "S": "bytes",
    "V": "raw bytes",
    "b": "booleans",
    "c": "complex numbers",
    "m": "time deltas",
    "M": "dates",
}


def refuse_class(x: Any, name: str) -> None:
    """Raise :class:`AttitudeTypeError` if ``x`` is a class where an instance is expected.

    ``control=MRPFeedback`` (the class, not ``MRPFeedback(K=..., P=...)``) is callable, so it
    would pass for your own step function and fail at the first tick; the message names the
    class and its required parameters.
    """
    if not isinstance(x, type):
        return
    import inspect

    try:
        params = inspect.signature(x).parameters.values()
        required = [
            p.name
            for p in params
            if p.default is inspect.Parameter.empty
            and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)
        ]
    except (TypeError, ValueError):  # pragma: no cover - a class without a signature
        required = []
    args = ", ".join(f"{p}=..." for p in required)
    raise AttitudeTypeError(
        f"{name}: got the class {x.__name__}; give an instance, e.g. {x.__name__}({args})"
    )


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
    if isinstance(x, (str, bytes)):
        raise AttitudeTypeError(
            f"{name}: expected an array of real numbers, got the string {_short(x)}"
        )
    try:
        raw = np.asarray(x)
    except (TypeError, ValueError) as exc:  # ragged nested sequences, odd objects
        raise AttitudeTypeError(
            f"{name}: expected an array of real numbers, got {_short(x)}"
        ) from exc
    kind = raw.dtype.kind
    if kind in _NOT_REAL:
        raise AttitudeTypeError(
            f"{name}: expected an array of real numbers, got {_NOT_REAL[kind]} ({_short(x)})"
        )
    try:
        arr = raw.astype(np.float64, copy=False)
    except OverflowError as exc:
        raise AttitudeValueError(f"{name}: a value is too large for double precision") from exc
    except (TypeError, ValueError) as exc:
        raise AttitudeTypeError(
            f"{name}: expected an array of real numbers, got {_short(x)}"
        ) from exc
    if ndim is not None and arr.ndim != ndim:
        raise AttitudeValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    if trailing is not None and (arr.ndim == 0 or arr.shape[-1] != trailing):
        raise AttitudeValueError(f"{name}: expected shape (..., {trailing}), got shape {arr.shape}")
    if not np.isfinite(arr).all():
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        raise AttitudeValueError(f"{name}: contains a non-finite value (NaN or inf) at index {bad}")
    return arr


def _short(x: Any) -> str:
    r = repr(x)
    return r if len(r) <= 60 else r[:57] + "..."


def as_scalar(x: Any, name: str, *, unit: Any = None) -> float:
    """One finite real number (a Python or numpy number, a 0-d array or a scalar Quantity).

    Strings, booleans, complex numbers and arrays are refused with an
    :class:`~attitude.errors.AttitudeTypeError` naming ``name``.
    """
    if type(x) is float and math.isfinite(x):  # the common case, without numpy (µs per call)
        return x
    if isinstance(x, (bool, np.bool_)):
        raise AttitudeTypeError(f"{name}: expected a number, got the boolean {x!r}")
    arr = as_float_array(x, name, unit=unit)
    if arr.ndim != 0:
        raise AttitudeTypeError(
            f"{name}: expected a single number, got an array of shape {arr.shape}"
        )
    return float(arr)


def as_bool(x: Any, name: str) -> bool:
    """A flag: ``True`` or ``False`` (Python or numpy booleans; anything else is refused)."""
    if not isinstance(x, (bool, np.bool_)):
        raise AttitudeTypeError(f"{name}: expected True or False, got {_short(x)}")
    return bool(x)


def as_positive(x: Any, name: str, *, unit: Any = None, allow_inf: bool = False) -> float:
    """A positive finite number (``math.inf`` too if ``allow_inf``), see :func:`as_scalar`."""
    if allow_inf and isinstance(x, (int, float)) and not isinstance(x, bool) and x == np.inf:
        return float("inf")
    v = as_scalar(x, name, unit=unit)
    if not v > 0:
        raise AttitudeValueError(f"{name}: must be a positive number, got {v!r}")
    return v


#: The widest relative tolerance accepted: rtol = 10 lets the error control accept any step
#: (the run then fails midway, or returns noise).
RTOL_MAX = 0.1


def as_rtol(x: Any, name: str = "rtol") -> float:
    """A relative tolerance of the adaptive methods, in [1e-15, :data:`RTOL_MAX`]."""
    v = as_positive(x, name)
    if v < 1e-15:
        raise AttitudeValueError(
            f"{name}: {v:g} is below what double precision can deliver; use >= 1e-15"
        )
    if v > RTOL_MAX:
        raise AttitudeValueError(
            f"{name}: {v:g} is not a relative tolerance the error control can work with; use "
            f"at most {RTOL_MAX:g} (1e-10 is the default, 1e-6 a coarse run)"
        )
    return v


#: Smallest accepted ``atol``. The error norm divides by atol + rtol |y| and squares: for a
#: component that is 0, below ~1e-154 the square overflows and every step is rejected as
#: non-finite (the run stops at t0). 1e-100 leaves a wide margin; a tolerance that small is
#: purely relative anyway (rtol governs every component that is not 0).
ATOL_MIN = 1e-100


def as_atol(x: Any, scale: float | None = None, name: str = "atol") -> float:
    """An absolute tolerance in [:data:`ATOL_MIN`, :data:`RTOL_MAX` × ``scale``].

    ``scale`` is the size of the state's largest component (the canonical state: max(1, |Q0|
    components), |q| = 1); an absolute error above RTOL_MAX times it is wider than the widest
    relative tolerance accepted, for every component: the error control accepts any step.
    None: the floor only.
    """
    v = as_positive(x, name)
    if v < ATOL_MIN:
        raise AttitudeValueError(
            f"{name}: {v:g} is below the floor {ATOL_MIN:g} (the scaled error norm overflows "
            "double precision below ~1e-154); use atol >= 1e-100 (rtol controls every "
            "component that is not 0)"
        )
    if scale is not None and v > RTOL_MAX * scale:
        raise AttitudeValueError(
            f"{name}: {v:g} is above {RTOL_MAX:g} times the state's scale {scale:g} (its "
            "largest component: |q| = 1 and the momenta Q0): an absolute error that wide lets "
            f"the error control accept any step, as rtol above {RTOL_MAX:g} would; use at most "
            f"{RTOL_MAX * scale:g} (1e-12 is the default)"
        )
    return v


def as_int(x: Any, name: str, *, low: int = 1) -> int:
    """An integer >= ``low`` (Python or numpy integer; booleans and floats are refused)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, np.integer)):
        raise AttitudeTypeError(f"{name}: expected an integer >= {low}, got {_short(x)}")
    if x < low:
        raise AttitudeValueError(f"{name}: expected an integer >= {low}, got {x!r}")
    return int(x)


def as_quaternion(x: Any, name: str = "q", *, nonzero: bool = True) -> np.ndarray:
    """Convert to a finite ``(..., 4)`` float array; reject zero quaternions if ``nonzero``."""
    arr = as_float_array(x, name, trailing=4)
    if nonzero:
        if np.any(np.all(arr == 0.0, axis=-1)):
            raise AttitudeValueError(f"{name}: the zero quaternion does not represent a rotation")
    return arr


def as_unit_quaternion(x: Any, name: str = "q", *, tol: float = 1e-6) -> np.ndarray:
    """:func:`as_quaternion`, refusing any ``|q|`` off 1 by more than ``tol`` (where a non-unit
    q would scale what is computed from it)."""
    arr = as_quaternion(x, name)
    dn = np.abs(np.linalg.norm(arr, axis=-1) - 1.0)
    if np.any(dn > tol):
        i = np.unravel_index(int(np.argmax(dn)), dn.shape) if dn.ndim else ()
        where = f" at index {tuple(int(k) for k in i)}" if dn.ndim else ""
        raise AttitudeValueError(
            f"{name}: |{name}|{where} = {float(np.linalg.norm(arr[i])):.17g} is not 1 (off by "
            f"{float(dn[i]):.3g} > {tol:g}); pass a unit quaternion "
            "(attitude.quaternion.normalize) if that is what you mean"
        )
    return arr


def as_vector(x: Any, name: str = "v", *, unit: Any = None) -> np.ndarray:
    """Convert to a finite ``(..., 3)`` float array."""
    return as_float_array(x, name, trailing=3, unit=unit)


def as_rate(x: Any, name: str, *, dimensional: bool, trailing: int | None = 3) -> np.ndarray:
    """Angular rates as a float array in rad/s (``dimensional``) or rad per time unit.

    A Quantity in any angular-rate unit (``deg/s``, ``cycle/min`` for rpm, ``rad/min``...) is
    converted to rad/s for a body with units; for a dimensionless body (no time unit) only a
    Quantity in an angle unit is accepted (taken per time unit). Plain numbers are rad per
    time unit.
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


def as_times(t: Any, name: str = "t", *, unit: Any = "s", lazy: bool = False) -> Any:
    """Convert output times to a finite, strictly increasing 1-D float array (at least 1 entry).

    A :class:`~attitude._times.TimeGrid` is valid by construction: it is returned as it is
    with ``lazy=True`` (the caller slices it), else materialised.
    """
    if isinstance(t, TimeGrid):
        return t if lazy else np.asarray(t)
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
    # C-ordered and writable (a copy only if not): the compiled loops take one array type
    # (a read-only one, e.g. a result's time values, compiled them a second time)
    return np.require(arr, np.float64, ["C", "W"])

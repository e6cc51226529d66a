"""Mode conditions: when the flight software moves on to its next mode."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_float_array, as_scalar
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "After",
    "Condition",
    "PointingBeyond",
    "PointingWithin",
    "RateAbove",
    "RateBelow",
    "as_condition",
]


def _rate(x: Any, name: str) -> float:
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            x = x.to_value(u.rad / u.s, u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(f"{name}: expected an angular rate, got {x.unit}") from None
    v = as_scalar(x, name)
    if not v > 0:
        raise AttitudeValueError(f"{name}: must be positive, got {v!r}")
    return v


def _angle(x: Any, name: str) -> float:
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            x = x.to_value(u.rad)
        except u.UnitConversionError:
            raise AttitudeTypeError(f"{name}: expected an angle, got {x.unit}") from None
    v = as_scalar(x, name)
    if not 0 < v <= np.pi:
        raise AttitudeValueError(f"{name}: expected an angle in (0, 180] degrees, got {v!r} rad")
    return v


class Condition:
    """Base class: a condition on the measured state at a tick (kernel: ``condition_holds``)."""

    _kind: int = 0
    threshold: float = 0.0
    frame: Any = None
    axis: np.ndarray | None = None


@dataclass(frozen=True, init=False)
class RateBelow(Condition):
    """|ω| below ``rate`` (rad/s, or an angular-rate Quantity)."""

    threshold: float
    _kind = 1

    def __init__(self, rate: Any):
        object.__setattr__(self, "threshold", _rate(rate, "rate"))


@dataclass(frozen=True, init=False)
class RateAbove(Condition):
    """|ω| above ``rate`` (rad/s, or an angular-rate Quantity)."""

    threshold: float
    _kind = 2

    def __init__(self, rate: Any):
        object.__setattr__(self, "threshold", _rate(rate, "rate"))


@dataclass(frozen=True, init=False)
class PointingWithin(Condition):
    """The attitude within ``angle`` of a reference frame: the total rotation angle, or, with
    ``axis``, the angle between that body axis and the frame's same axis."""

    frame: Any
    threshold: float
    axis: np.ndarray | None
    _kind = 3

    def __init__(self, frame: Any, angle: Any, axis: Any = None):
        from ..frames import Frame

        if not isinstance(frame, Frame):
            raise AttitudeTypeError(
                f"frame: expected a frame of attitude.frames, got {type(frame).__name__}"
            )
        object.__setattr__(self, "frame", frame)
        object.__setattr__(self, "threshold", _angle(angle, "angle"))
        a = None
        if axis is not None:
            a = as_float_array(axis, "axis")
            if a.shape != (3,) or not float(np.linalg.norm(a)) > 0:
                raise AttitudeValueError("axis: expected a nonzero body-axis vector (3,)")
            a = a / np.linalg.norm(a)
        object.__setattr__(self, "axis", a)


@dataclass(frozen=True, init=False)
class PointingBeyond(PointingWithin):
    """The attitude more than ``angle`` from a reference frame (see :class:`PointingWithin`)."""

    _kind = 4


@dataclass(frozen=True, init=False)
class After(Condition):
    """The time (s since the run's start epoch, the time axis of the run) at or after ``time``."""

    threshold: float
    _kind = 5

    def __init__(self, time: Any):
        v = as_float_array(time, "time", unit="s")
        if v.shape != ():
            raise AttitudeValueError("time: expected one time")
        object.__setattr__(self, "threshold", float(v))


def as_condition(x: Any) -> Condition | None:
    """A condition from a :class:`Condition`, None (always), or an event of
    :mod:`attitude.events` (``RateExceeds(rate)``: |ω| above; ``PointingExceeds``: beyond)."""
    if x is None or isinstance(x, Condition):
        return x
    from .. import events as E

    if isinstance(x, E.RateExceeds):
        return RateAbove(x.rate)
    if isinstance(x, E.PointingExceeds):
        return PointingBeyond(x.frame, x.angle, x.axis)
    raise AttitudeTypeError(
        f"modes: a condition is a RateBelow, RateAbove, PointingWithin, PointingBeyond, After, "
        f"an attitude.events.RateExceeds or PointingExceeds, or None; got {type(x).__name__}"
    )

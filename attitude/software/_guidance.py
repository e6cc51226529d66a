"""Guidance: the reference attitude, rate and acceleration the control law tracks.

Any reference frame of :mod:`attitude.frames` (inertial, LVLH, nadir, Sun-pointing, ground
target, their offsets) is guidance as it is: q_R(t), ω_R(t) exactly from the frame's kernels,
ω̇_R by a central difference of the exact ω_R (:func:`attitude._core.fsw.frame_reference`).
:class:`Slew` turns onto a frame along an eigen-axis with rate and acceleration limits.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .._validation import as_scalar, refuse_class
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = ["Slew", "as_guidance"]


def _positive(x: Any, name: str, unit: str) -> float:
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            x = x.to_value(u.Unit(unit), u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(f"{name}: units {x.unit} are not {unit}") from None
    v = as_scalar(x, name)
    if not v > 0:
        raise AttitudeValueError(f"{name}: must be positive, got {v!r}")
    return v


@dataclass(frozen=True, init=False)
class Slew:
    """A rest-to-rest eigen-axis slew onto a reference frame, with rate and acceleration limits.

    At the tick the mode starts, the rotation from the target frame to the spacecraft is an
    angle θ₀ about an axis e (target axes); the reference is the target turned back by
    θ(t) about e, q_R = q_T∘exp(θ e/2), with θ going from θ₀ to 0 on a trapezoidal rate profile
    (|θ̇| <= ``max_rate``, |θ̈| <= ``max_accel``; triangular when θ₀ is small), then the target
    itself. ω_R and ω̇_R carry the target's motion and the slew's (docs/flight_software.md).

    Parameters
    ----------
    target : Frame
        The frame to slew onto (any of :mod:`attitude.frames`).
    max_rate : float or Quantity
        Slew rate limit (rad/s).
    max_accel : float or Quantity
        Slew acceleration limit (rad/s²).
    """

    target: Any
    max_rate: float
    max_accel: float

    def __init__(self, target: Any, max_rate: Any, max_accel: Any):
        from ..frames import Frame

        if not isinstance(target, Frame):
            raise AttitudeTypeError(
                f"target: expected a frame of attitude.frames, got {type(target).__name__}"
            )
        object.__setattr__(self, "target", target)
        object.__setattr__(self, "max_rate", _positive(max_rate, "max_rate", "rad / s"))
        object.__setattr__(self, "max_accel", _positive(max_accel, "max_accel", "rad / s2"))

    def describe(self) -> str:
        return (
            f"slew onto {self.target.describe()} (<= {self.max_rate:.3g} rad/s, "
            f"{self.max_accel:.3g} rad/s2)"
        )


def as_guidance(x: Any) -> Any:
    """A frame, a :class:`Slew` or None (checked)."""
    from ..frames import Frame

    if x is None or isinstance(x, (Frame, Slew)):
        return x
    refuse_class(x, "guidance")
    raise AttitudeTypeError(
        f"guidance: expected a frame of attitude.frames (inertial, lvlh(orbit), nadir, "
        f"sun_pointing, target...), a Slew, or None; got {type(x).__name__}"
    )

"""Thrusters: forces at body-fixed points, fired for a fraction of each hold."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_float_array
from ..errors import AttitudeValueError
from ._common import limit, nonnegative, optional_name, unit_axis

__all__ = ["Thruster", "thruster_record"]


@dataclass(frozen=True, init=False)
class Thruster:
    """An on–off thruster at a body-fixed point.

    Commanded by the fraction of each hold it fires (pulse-width modulation, from the start of
    the hold): the force F = max_thrust d̂ acts for fraction × hold length, its torque about
    the centre of mass is (r − r_cm) × F. The force is recorded; the orbit stays prescribed
    (thrust does not change it: docs/actuators.md).

    Parameters
    ----------
    position : array_like or Quantity, shape (3,)
        Point of application r in body axes (m).
    direction : array_like, shape (3,)
        Direction d̂ of the force on the spacecraft (normalised; a warning if more than 1e-6
        from unit length).
    max_thrust : float or Quantity
        Thrust when firing (N).
    min_impulse_bit : float or Quantity
        Smallest impulse the valve delivers (N s): a firing shorter than
        min_impulse_bit / max_thrust is dropped (default 0).
    name : str, optional
        Label in results (default ``thruster<j>``).
    """

    position: np.ndarray
    direction: np.ndarray
    max_thrust: float
    min_impulse_bit: float
    name: str | None

    def __init__(
        self,
        position: Any,
        direction: Any,
        max_thrust: Any,
        *,
        min_impulse_bit: Any = 0.0,
        name: str | None = None,
    ):
        r = as_float_array(position, "position", unit="m")
        if r.shape != (3,):
            raise AttitudeValueError(
                f"position: expected 3 body-axis components (m), got shape {r.shape}"
            )
        r = r.copy()  # (read-only: the caller's array stays writable)
        r.setflags(write=False)
        object.__setattr__(self, "position", r)
        object.__setattr__(self, "direction", unit_axis(direction, "direction"))
        f = limit(max_thrust, "max_thrust", "N", "thrust")
        if not math.isfinite(f):
            raise AttitudeValueError("max_thrust: the thrust must be finite")
        object.__setattr__(self, "max_thrust", f)
        object.__setattr__(
            self,
            "min_impulse_bit",
            nonnegative(min_impulse_bit, "min_impulse_bit", "N s", "minimum impulse bit"),
        )
        object.__setattr__(self, "name", optional_name(name, "thruster"))

    @property
    def min_on_time(self) -> float:
        """The shortest firing delivered (s): min_impulse_bit / max_thrust."""
        return self.min_impulse_bit / self.max_thrust

    def __repr__(self) -> str:
        tail = f", min_impulse_bit={self.min_impulse_bit!r}" if self.min_impulse_bit else ""
        tail += f", name={self.name!r}" if self.name else ""
        return (
            f"Thruster(position={self.position.tolist()}, direction={self.direction.tolist()}, "
            f"max_thrust={self.max_thrust!r}{tail})"
        )


def thruster_record(th: Thruster, center_of_mass: np.ndarray) -> np.ndarray:
    """The thruster's record of the spacecraft block (held slots zero)."""
    from .._core import actuators as _ka

    arm = np.cross(th.position - center_of_mass, th.direction)
    return _ka.THR.pack(arm=arm, dir=th.direction, fmax=th.max_thrust, min_on=th.min_on_time)

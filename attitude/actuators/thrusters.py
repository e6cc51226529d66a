"""Thrusters: forces at body-fixed points, fired for a fraction of each hold."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_float_array
from ..errors import AttitudeValueError
from ._common import limit, nonnegative, optional_name, unit_axis

__all__ = ["G0", "Thruster", "thruster_record"]

#: Standard gravity (m/s²), the specific impulse's conversion (CGPM 1901).
G0 = 9.80665


@dataclass(frozen=True, init=False)
class Thruster:
    """An on–off thruster at a body-fixed point.

    Commanded by the fraction of each hold it fires (pulse-width modulation, from the start of
    the hold): the force F = max_thrust d̂ acts for fraction × hold length, its torque about
    the centre of mass is (r − r_cm) × F. The force is recorded; it moves the orbit of a
    spacecraft with a mass on an :class:`orbit.NumericalOrbit` (propagated with the attitude),
    and with a specific impulse the propellant it burns lowers the mass (docs/actuators.md);
    on a given orbit it acts on the attitude only.

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
    isp : float or Quantity, optional
        Specific impulse (s): while firing the mass falls at F / (isp g0), g0 = 9.80665 m/s²
        (the rocket equation). None (default): no propellant is counted.
    name : str, optional
        Label in results (default ``thruster<j>``).
    """

    position: np.ndarray
    direction: np.ndarray
    max_thrust: float
    min_impulse_bit: float
    name: str | None
    isp: float | None

    def __init__(
        self,
        position: Any,
        direction: Any,
        max_thrust: Any,
        *,
        min_impulse_bit: Any = 0.0,
        name: str | None = None,
        isp: Any = None,
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
        if isp is not None:
            isp = limit(isp, "isp", "s", "specific impulse")
            if not (math.isfinite(isp) and isp > 0.0):
                raise AttitudeValueError(
                    f"isp: the specific impulse must be a positive number of seconds, got {isp!r}"
                )
        object.__setattr__(self, "isp", isp)

    @property
    def mass_flow(self) -> float:
        """Propellant burnt while firing (kg/s): max_thrust / (isp g0); 0 without an isp."""
        return 0.0 if self.isp is None else self.max_thrust / (self.isp * G0)

    @property
    def min_on_time(self) -> float:
        """The shortest firing delivered (s): min_impulse_bit / max_thrust."""
        return self.min_impulse_bit / self.max_thrust

    def __repr__(self) -> str:
        tail = f", min_impulse_bit={self.min_impulse_bit!r}" if self.min_impulse_bit else ""
        tail += f", name={self.name!r}" if self.name else ""
        tail += f", isp={self.isp!r}" if self.isp is not None else ""
        return (
            f"Thruster(position={self.position.tolist()}, direction={self.direction.tolist()}, "
            f"max_thrust={self.max_thrust!r}{tail})"
        )


def thruster_record(th: Thruster, center_of_mass: np.ndarray) -> np.ndarray:
    """The thruster's record of the spacecraft block (held slots zero)."""
    from .._core import actuators as _ka

    arm = np.cross(th.position - center_of_mass, th.direction)
    return _ka.THR.pack(
        arm=arm, dir=th.direction, fmax=th.max_thrust, min_on=th.min_on_time, mdot=th.mass_flow
    )

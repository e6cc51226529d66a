"""Allocation: actuator commands from a torque or dipole request."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validation import as_float_array
from ..errors import AttitudeValueError
from ._laws import positive_gain

__all__ = ["WheelAllocation"]


@dataclass(frozen=True, init=False)
class WheelAllocation:
    """Wheel torques from a body torque request: u = −G⁺ L_r − k N J (Ω − Ω_ref).

    G = [a_1 ... a_n] (3 × n, the wheels' axes), G⁺ = Gᵀ (G Gᵀ)⁻¹ its minimum-norm
    pseudo-inverse (Basilisk's ``rwMotorTorque``; any n >= 3 wheels spanning the body axes),
    N = 1 − G⁺ G the projector on its null space: the second term changes the wheel speeds
    towards Ω_ref without a torque on the body (Markley & Crassidis 2014, Sect. 7.2.3).

    Parameters
    ----------
    null_gain : float
        k (1/s; 0, the default: no null-space management).
    null_speeds : array_like (n_wheels,), optional
        Ω_ref (rad/s; default 0: the wheel momentum is spread to minimise the speeds).
    """

    null_gain: float
    null_speeds: np.ndarray | None

    def __init__(self, null_gain: Any = 0.0, null_speeds: Any = None):
        object.__setattr__(self, "null_gain", positive_gain(null_gain, "null_gain", "1 / s",
                                                     allow_zero=True))  # fmt: skip
        sp = None
        if null_speeds is not None:
            from ..actuators._common import speeds_value

            sp = as_float_array(speeds_value(null_speeds, "null_speeds"), "null_speeds")
            if sp.ndim != 1:
                raise AttitudeValueError("null_speeds: expected one speed per wheel")
        object.__setattr__(self, "null_speeds", sp)

    def __repr__(self) -> str:
        return f"WheelAllocation(null_gain={self.null_gain!r})"

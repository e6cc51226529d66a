"""Attitude control laws and actuator allocation for :class:`attitude.FlightSoftware`.

Laws (each computes a body torque request, or a dipole request for the magnetic laws, at
every tick of the flight software; the compiled kernels are in :mod:`attitude._core.fsw`):

* :class:`MRPFeedback` — Basilisk's ``mrpFeedback`` (Schaub & Junkins), with its gyroscopic
  and feed-forward terms and the wheels' momentum;
* :class:`QuaternionFeedback` — Wie's quaternion feedback with gyroscopic decoupling;
* :class:`RateDamping` — −K_d (ω − ω_r);
* :class:`BDot` — detumbling with magnetorquers, m = −k Ḃ_B;
* :class:`MomentumDumping` — the cross-product law, beside a wheel law.

Allocation: :class:`WheelAllocation` (minimum-norm pseudo-inverse for any number of wheels,
with null-space management of the wheel speeds); magnetorquers take m = B × L / |B|² for a
torque request and the rods' pseudo-inverse for a dipole.
"""

from __future__ import annotations

from ._allocation import WheelAllocation
from ._laws import BDot, ControlLaw, MomentumDumping, MRPFeedback, QuaternionFeedback, RateDamping

__all__ = [
    "BDot",
    "ControlLaw",
    "MRPFeedback",
    "MomentumDumping",
    "QuaternionFeedback",
    "RateDamping",
    "WheelAllocation",
]

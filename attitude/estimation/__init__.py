"""Attitude determination in the loop: the multiplicative extended Kalman filter.

:class:`MEKF` estimates the attitude and the gyro bias from a gyro and a star tracker (and a
magnetometer and a Sun sensor if asked), at every tick of the flight software
(:class:`attitude.FlightSoftware`, ``estimator=MEKF(...)``); the control law then acts on the
estimate. The filter and its equations: :mod:`attitude._core.mekf`, docs/sensors.md.
"""

from __future__ import annotations

from ._mekf import MEKF

__all__ = ["MEKF"]

"""Sensors whose noise is what their parameters say: gyro, star tracker, magnetometer, Sun sensor.

What the flight software measures (:class:`attitude.FlightSoftware`, ``sensors=[...]``); the
models and their exact discretisation in docs/sensors.md, the kernels in
:mod:`attitude._core.sensors`. A quantity without a sensor is measured perfectly (the truth):
:class:`Truth` is the empty set. Every noisy sensor has its own random stream from its seed
(drawn from the operating system when not given, and recorded in the results), so a run is
reproducible bit for bit.
"""

from __future__ import annotations

from ._models import Gyro, Magnetometer, Sensor, StarTracker, SunSensor, Truth, as_sensor_set

__all__ = [
    "Gyro",
    "Magnetometer",
    "Sensor",
    "StarTracker",
    "SunSensor",
    "Truth",
    "as_sensor_set",
]

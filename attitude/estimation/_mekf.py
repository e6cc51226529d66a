"""The MEKF's parameters, validated, and its record of the flight software's program."""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._core import mekf as _km
from .._validation import as_float_array, as_quaternion, as_scalar
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = ["MEKF"]


def _sigma(x: Any, name: str, unit: str) -> float:
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            x = x.to_value(u.Unit(unit), u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(f"{name}: units {x.unit} are not {unit}") from None
    v = as_scalar(x, name)
    if not v > 0 or not math.isfinite(v):
        raise AttitudeValueError(f"{name}: must be a positive 1-sigma value, got {v!r}")
    if not (v * v >= sys.float_info.min and math.isfinite(v * v)):
        raise AttitudeValueError(
            f"{name}: {v!r} {unit} squared ({v * v!r}) is not a usable variance (the initial "
            "covariance would be singular or infinite); give a 1-sigma between 1e-150 and 1e150"
        )
    return v


@dataclass(frozen=True, init=False)
class MEKF:
    """The multiplicative extended Kalman filter of attitude and gyro bias.

    Lefferts, Markley & Shuster (1982); Markley & Crassidis (2014), Sect. 6.2. Propagated with
    the gyro at every tick, updated with each valid star tracker measurement (and the
    magnetometer and Sun sensor with ``use_magnetometer``, ``use_sun_sensor``). Process noise
    from the gyro's σ_v and σ_u, measurement noise from the sensors' parameters.

    Parameters
    ----------
    initial_attitude : array_like (4,), optional
        q̂₀ (body → space). Default: the first valid star tracker measurement.
    initial_bias : array_like (3,) or Quantity, optional
        β̂₀ (rad/s; default 0).
    attitude_sigma : float or Quantity, optional
        1-σ of the initial attitude error per axis (rad). Default: 10° with an
        ``initial_attitude``, else three times the star tracker's largest noise.
    bias_sigma : float or Quantity, optional
        1-σ of the initial bias error per axis (rad/s). Default: the gyro's |bias|, at least
        1e-5 rad/s (2°/h).
    use_magnetometer, use_sun_sensor : bool
        Also update with the magnetometer (against the IGRF field of the same tables: the
        filter knows the field model exactly, an idealisation) and the Sun sensor.
    """

    initial_attitude: np.ndarray | None
    initial_bias: np.ndarray
    attitude_sigma: float | None
    bias_sigma: float | None
    use_magnetometer: bool
    use_sun_sensor: bool

    def __init__(
        self,
        initial_attitude: Any = None,
        initial_bias: Any = None,
        attitude_sigma: Any = None,
        bias_sigma: Any = None,
        use_magnetometer: bool = False,
        use_sun_sensor: bool = False,
    ):
        s = object.__setattr__
        q = None
        if initial_attitude is not None:
            q = as_quaternion(initial_attitude, "initial_attitude")
            if q.shape != (4,):
                raise AttitudeValueError("initial_attitude: expected one quaternion (4,)")
            q = q / np.linalg.norm(q)
        s(self, "initial_attitude", q)
        b = np.zeros(3)
        if initial_bias is not None:
            b = as_float_array(initial_bias, "initial_bias", unit="rad / s")
            if b.shape != (3,):
                raise AttitudeValueError("initial_bias: expected 3 body-axis components")
        s(self, "initial_bias", b)
        s(self, "attitude_sigma", None if attitude_sigma is None else _sigma(
            attitude_sigma, "attitude_sigma", "rad"))  # fmt: skip
        s(self, "bias_sigma", None if bias_sigma is None else _sigma(
            bias_sigma, "bias_sigma", "rad / s"))  # fmt: skip
        for k, v in (("use_magnetometer", use_magnetometer), ("use_sun_sensor", use_sun_sensor)):
            if not isinstance(v, (bool, np.bool_)):
                raise AttitudeTypeError(f"{k}: expected True or False")
            s(self, k, bool(v))

    def record(self, sensors: tuple) -> np.ndarray:
        """The filter's record of the program (the EP layout) for these sensors."""
        from ..sensors import Gyro, Magnetometer, StarTracker, SunSensor

        by = {type(x): x for x in sensors}
        g = by.get(Gyro)
        st = by.get(StarTracker)
        if g is None:
            raise AttitudeValueError(
                "estimator: the MEKF propagates with a gyro; add a Gyro to the sensors"
            )
        if st is None and self.initial_attitude is None:
            raise AttitudeValueError(
                "estimator: the MEKF starts from the first star tracker measurement; add a "
                "StarTracker or give initial_attitude"
            )
        if st is None and not (self.use_magnetometer or self.use_sun_sensor):
            raise AttitudeValueError(
                "estimator: no attitude measurement to update the MEKF with (a StarTracker, "
                "or use_magnetometer / use_sun_sensor with those sensors)"
            )
        if self.use_magnetometer and Magnetometer not in by:
            raise AttitudeValueError("estimator: use_magnetometer without a Magnetometer")
        if self.use_sun_sensor and SunSensor not in by:
            raise AttitudeValueError("estimator: use_sun_sensor without a SunSensor")
        p: dict[str, Any] = dict(sv=max(g.arw, 1e-12), su=max(g.rrw, 1e-15))
        if self.attitude_sigma is not None:
            sa = self.attitude_sigma
        elif self.initial_attitude is not None:
            sa = math.radians(10.0)
        else:
            sa = 3.0 * max(st.noise)
        sb = self.bias_sigma if self.bias_sigma is not None else max(
            float(np.linalg.norm(g.bias)), 1e-5)  # fmt: skip
        p["p0"] = [sa * sa] * 3 + [sb * sb] * 3
        if self.initial_attitude is not None:
            p.update(init=1.0, q0=self.initial_attitude)
        p["b0"] = self.initial_bias
        if st is not None:
            p["st_r"] = st.covariance
        if self.use_magnetometer:
            p["mag"] = max(by[Magnetometer].noise, 1e-12)
        if self.use_sun_sensor:
            p["sun"] = max(by[SunSensor].noise, 1e-6)
        return _km.EP.pack(**p)

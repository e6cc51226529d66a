"""The sensor classes: parameters validated once, and their records of the sensor program."""

from __future__ import annotations

import math
import secrets
from dataclasses import dataclass
from typing import Any

import numpy as np

from orbit._layout import Appender

from .._core import rng as _rng
from .._core import sensors as _ks
from .._validation import as_float_array, as_scalar, refuse_class
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "Gyro",
    "Magnetometer",
    "Sensor",
    "StarTracker",
    "SunSensor",
    "Truth",
    "as_sensor_set",
    "sensor_program",
]


def _q(x: Any, name: str, unit: str, *, allow_zero: bool = True, allow_inf: bool = False) -> float:
    """A non-negative number from a plain number (SI) or a Quantity in ``unit``'s dimension."""
    from astropy import units as u

    if isinstance(x, u.Quantity):
        try:
            x = x.to_value(u.Unit(unit), u.dimensionless_angles())
        except u.UnitConversionError:
            raise AttitudeTypeError(
                f"{name}: units {x.unit} cannot be converted to {u.Unit(unit)}"
            ) from None
    if allow_inf and isinstance(x, (int, float)) and not isinstance(x, bool) and x == math.inf:
        return math.inf
    v = as_scalar(x, name)
    if v < 0 or (v == 0 and not allow_zero):
        raise AttitudeValueError(
            f"{name}: must be {'>= 0' if allow_zero else 'positive'}, got {v!r} ({unit})"
        )
    if not math.isfinite(v * v):  # noise densities are squared (variances): 1e308 overflows
        raise AttitudeValueError(f"{name}: {v!r} ({unit}) is too large: its square overflows")
    return v


#: Largest accepted Frobenius norm of MᵀM − I of a gyro's misalignment matrix M.
ROTATION_TOL = 1e-6

#: Largest accepted gyro quantization step (rad/s): 57°/s per count.
GYRO_QUANTIZATION_MAX = 1.0

#: Largest accepted magnetometer noise σ (T): the Earth's field is at most ~6.6e-5 T at the
#: surface, ~5e-5 T in low orbit.
MAGNETOMETER_NOISE_MAX = 1e-3


def _check_rotation(M: np.ndarray, name: str) -> None:
    """Refuse a 3 × 3 matrix that is not a rotation (orthonormal, det +1, to ROTATION_TOL)."""
    err = float(np.linalg.norm(M.T @ M - np.eye(3)))
    if not err <= ROTATION_TOL:
        raise AttitudeValueError(
            f"{name}: not a rotation matrix: ||MᵀM − I|| = {err:.3g} exceeds {ROTATION_TOL:g} "
            "(the zero matrix, a scaled or sheared matrix are not a turn of the sensor axes; "
            "scale errors are scale_factor); give a rotation matrix, or a rotation vector (rad)"
        )
    if not np.linalg.det(M) > 0:
        raise AttitudeValueError(
            f"{name}: det M = {np.linalg.det(M):.3g} < 0: a reflection (such as −I) is not a "
            "rotation of the sensor axes (it makes them left-handed); give a rotation matrix "
            "(det +1), or a rotation vector (rad)"
        )


def _vector(x: Any, name: str, unit: str | None = None) -> np.ndarray:
    a = as_float_array(x, name, unit=unit)
    if a.ndim == 0:
        a = np.full(3, float(a))
    if a.shape != (3,):
        raise AttitudeValueError(f"{name}: expected a number or 3 body-axis components")
    return a


def _seed(seed: Any) -> int:
    if seed is None:
        return secrets.randbits(63)
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise AttitudeTypeError(
            f"seed: expected a non-negative integer (or None for a fresh one), got {seed!r}"
        )
    if not 0 <= int(seed) < 2**64:
        raise AttitudeValueError(f"seed: expected an integer in [0, 2**64), got {seed!r}")
    return int(seed)


class Sensor:
    """Base class of the sensors."""

    seed: int
    kind: str = "sensor"

    def with_seed(self, seed: Any) -> Sensor:
        """The same sensor drawing from the stream of ``seed`` (an integer in [0, 2**64);
        None: a fresh one from the operating system)."""
        new = object.__new__(type(self))
        for k, v in vars(self).items():
            object.__setattr__(new, k, v)
        object.__setattr__(new, "seed", _seed(seed))
        return new

    @property
    def stream_extra(self) -> int:
        """Slots of the sensor's state after its random stream (the gyro's drift memory)."""
        return 7 if self.kind == "gyro" else 0


def stream_state(sensor: Sensor) -> np.ndarray:
    """The initial state of a sensor in the sensor state ``ss``: its random stream seeded from
    ``sensor.seed`` (SplitMix64), then its memory (zeros)."""
    st = np.zeros(_rng.RNG_SIZE + sensor.stream_extra)
    _rng.seed_stream(st, 0, np.uint64(sensor.seed))
    return st


@dataclass(frozen=True, init=False)
class Gyro(Sensor):
    """A three-axis rate-integrating gyro (Farrenkopf's model, discretised exactly).

    Parameters
    ----------
    arw : float or Quantity
        Angle random walk σ_v (rad/√s; a Quantity such as ``0.01 * u.deg / u.hour**0.5``).
    rrw : float or Quantity
        Rate random walk σ_u (rad/s^{3/2}).
    bias : float, array_like (3,) or Quantity
        Constant bias b₀ (rad/s).
    scale_factor : float or array_like (3,)
        Scale factor errors S (dimensionless, e.g. 1e-4 for 100 ppm).
    misalignment : array_like (3,) or (3, 3), optional
        Small rotation of the sensor axes (rad, a rotation vector) or its matrix M: a rotation
        (orthonormal to :data:`ROTATION_TOL`, det +1; non-orthogonal axes are not modelled,
        scale errors are ``scale_factor``).
    quantization : float or Quantity
        Output resolution (rad/s; 0: none), below the saturation and below
        :data:`GYRO_QUANTIZATION_MAX` = 1 rad/s.
    saturation : float or Quantity
        Largest |rate| per axis (rad/s; inf: none).
    seed : int, optional
    """

    arw: float
    rrw: float
    bias: np.ndarray
    scale_factor: np.ndarray
    misalignment: np.ndarray
    quantization: float
    saturation: float
    seed: int
    kind = "gyro"

    def __init__(self, arw: Any, rrw: Any = 0.0, bias: Any = 0.0, scale_factor: Any = 0.0,
                 misalignment: Any = None, quantization: Any = 0.0, saturation: Any = math.inf,
                 seed: Any = None):  # fmt: skip
        s = object.__setattr__
        s(self, "arw", _q(arw, "arw", "rad / s(1/2)"))
        s(self, "rrw", _q(rrw, "rrw", "rad / s(3/2)"))
        s(self, "bias", _vector(bias, "bias", "rad / s"))
        s(self, "scale_factor", _vector(scale_factor, "scale_factor"))
        if misalignment is None:
            M = np.eye(3)
        else:
            m = as_float_array(misalignment, "misalignment", unit="rad")
            if m.shape == (3,):
                from ..quaternion import from_rotation_vector, to_matrix

                M = to_matrix(from_rotation_vector(m))
            elif m.shape == (3, 3):
                M = m.copy()
                _check_rotation(M, "misalignment")
            else:
                raise AttitudeValueError(
                    "misalignment: expected a rotation vector (3,) or a matrix (3, 3)"
                )
        s(self, "misalignment", M)
        s(self, "quantization", _q(quantization, "quantization", "rad / s"))
        s(self, "saturation", _q(saturation, "saturation", "rad / s", allow_zero=False,
                                 allow_inf=True))  # fmt: skip
        qmax = min(GYRO_QUANTIZATION_MAX, self.saturation)
        if self.quantization >= qmax:
            why = (
                f"at or above the saturation {self.saturation!r} rad/s the gyro reads only 0 "
                "or its saturation"
                if self.saturation <= GYRO_QUANTIZATION_MAX
                else f"a step of {GYRO_QUANTIZATION_MAX:g} rad/s (57°/s) or more is coarser "
                "than any rate gyro's resolution (a 16-bit gyro over ±2000°/s: 1e-3 rad/s)"
            )
            raise AttitudeValueError(
                f"quantization: {self.quantization!r} rad/s: {why}; give the output's "
                "resolution (rad/s per count), below both"
            )
        if np.any(np.abs(self.bias) >= self.saturation):
            raise AttitudeValueError(
                f"bias: {self.bias.tolist()!r} rad/s reaches the saturation {self.saturation!r} "
                "rad/s: the gyro would read its saturation only; give a bias below it"
            )
        s(self, "seed", _seed(seed))

    @property
    def matrix(self) -> np.ndarray:
        """C = (1 + S) M: the sensor's response to the true rate."""
        return np.diag(1.0 + self.scale_factor) @ self.misalignment

    def allan_variance(self, tau: Any) -> np.ndarray:
        """The model's Allan variance σ_v²/τ + σ_u² τ/3 (rad²/s²) at averaging times τ (s)."""
        tt = as_float_array(tau, "tau", unit="s")
        return self.arw**2 / tt + self.rrw**2 * tt / 3.0


@dataclass(frozen=True, init=False)
class StarTracker(Sensor):
    """A star tracker: the attitude with noise about and across its boresight.

    Parameters
    ----------
    noise : float, (cross, about) or Quantity
        1-σ noise across the boresight and about it (rad; a Quantity in arcsec); one number:
        the same across, 8 times larger about (a typical tracker's ratio).
    boresight : array_like (3,)
        Boresight in body axes.
    rate : float or Quantity, optional
        Update rate (Hz): a new measurement every 1/(rate·period) ticks of the software
        (default: every tick).
    sun_exclusion, earth_exclusion : float or Quantity, optional
        Half-angles (rad, or an angle Quantity) from the Sun and from the Earth's limb inside
        which the measurement is flagged invalid (needs the spacecraft's orbit).
    seed : int, optional
    """

    noise: tuple[float, float]
    boresight: np.ndarray
    rate: float | None
    sun_exclusion: float
    earth_exclusion: float
    seed: int
    kind = "star_tracker"

    def __init__(self, noise: Any, boresight: Any = (0.0, 0.0, 1.0), rate: Any = None,
                 sun_exclusion: Any = None, earth_exclusion: Any = None,
                 seed: Any = None):  # fmt: skip
        from astropy import units as u

        s = object.__setattr__
        if (isinstance(noise, u.Quantity) and noise.isscalar) or isinstance(
            noise, (int, float, np.integer, np.floating)
        ):
            c = _q(noise, "noise", "rad", allow_zero=False)
            n = (c, 8.0 * c)
        else:
            items = (
                list(noise) if isinstance(noise, (list, tuple, u.Quantity, np.ndarray)) else None
            )
            if items is None or len(items) != 2:
                raise AttitudeValueError(
                    "noise: expected the 1-sigma noise across and about the boresight (2 "
                    "positive numbers, rad, or angle Quantities), or one number"
                )
            n = (
                _q(items[0], "noise", "rad", allow_zero=False),
                _q(items[1], "noise", "rad", allow_zero=False),
            )
        if max(n) >= math.pi:
            raise AttitudeValueError(
                f"noise: a 1-sigma attitude noise of {max(n)!r} rad (>= 180°) measures nothing; "
                "expected arcseconds (e.g. 6 * u.arcsec)"
            )
        s(self, "noise", n)
        b = as_float_array(boresight, "boresight")
        if b.shape != (3,) or not float(np.linalg.norm(b)) > 0:
            raise AttitudeValueError("boresight: expected a nonzero body-axis vector (3,)")
        s(self, "boresight", b / np.linalg.norm(b))
        s(self, "rate", None if rate is None else _q(rate, "rate", "Hz", allow_zero=False))
        sun = 0.0 if sun_exclusion is None else _q(sun_exclusion, "sun_exclusion", "rad")
        earth = -1.0 if earth_exclusion is None else _q(earth_exclusion, "earth_exclusion", "rad")
        for name, angle in (("sun_exclusion", sun), ("earth_exclusion", earth)):
            if angle >= math.pi:
                raise AttitudeValueError(
                    f"{name}: a half-angle of {angle!r} rad (>= 180°) blinds the star tracker "
                    "in every attitude; expected an angle below 180° (e.g. 30 * u.deg)"
                )
        s(self, "sun_exclusion", sun)
        s(self, "earth_exclusion", earth)
        s(self, "seed", _seed(seed))

    @property
    def frame(self) -> np.ndarray:
        """Rows: the sensor axes x, y, z (= boresight) in body axes."""
        z = self.boresight
        trial = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = trial - z * float(trial @ z)
        x /= np.linalg.norm(x)
        return np.array([x, np.cross(z, x), z])

    @property
    def covariance(self) -> np.ndarray:
        """The noise covariance in body axes (rad²)."""
        C = self.frame
        d = np.diag([self.noise[0] ** 2, self.noise[0] ** 2, self.noise[1] ** 2])
        return C.T @ d @ C


@dataclass(frozen=True, init=False)
class Magnetometer(Sensor):
    """A three-axis magnetometer: B̃ = B_B + b + σ N on the IGRF field along the orbit.

    Parameters
    ----------
    noise : float or Quantity
        σ (T; a Quantity such as ``100 * u.nT``), at most :data:`MAGNETOMETER_NOISE_MAX` =
        1e-3 T (the Earth's field is ~5e-5 T in low orbit).
    bias : float, array_like (3,) or Quantity
        b (T).
    seed : int, optional
    """

    noise: float
    bias: np.ndarray
    seed: int
    kind = "magnetometer"

    def __init__(self, noise: Any, bias: Any = 0.0, seed: Any = None):
        v = _q(noise, "noise", "T")
        if v > MAGNETOMETER_NOISE_MAX:
            raise AttitudeValueError(
                f"noise: σ = {v!r} T is above {MAGNETOMETER_NOISE_MAX:g} T, while the Earth's "
                "field it measures is at most ~6.6e-5 T: not a magnetometer of the Earth's "
                "field; give σ in T (100 nT = 1e-7 T, or a Quantity such as 100 * u.nT)"
            )
        object.__setattr__(self, "noise", v)
        object.__setattr__(self, "bias", _vector(bias, "bias", "T"))
        object.__setattr__(self, "seed", _seed(seed))


@dataclass(frozen=True, init=False)
class SunSensor(Sensor):
    """A coarse Sun sensor: heads with a cosine law, dark in the Earth's shadow.

    Each head's current is ν max(0, n·ŝ) + σ N (ν the fraction of the Sun seen). The measured
    direction is the least-squares solution over the heads above 3σ, solved again without
    any head facing away from the first solution (a dark head whose noise passed 3σ); it is
    invalid (NaN) with fewer than three independent heads left.

    Parameters
    ----------
    normals : array_like (n, 3), optional
        The heads' normals in body axes (default: the six faces ±x, ±y, ±z).
    noise : float
        σ of each head's current, as a fraction of its full-Sun current (below 1).
    seed : int, optional
    """

    normals: np.ndarray
    noise: float
    seed: int
    kind = "sun_sensor"

    def __init__(self, normals: Any = None, noise: Any = 0.01, seed: Any = None):
        if normals is None:
            n = np.vstack([np.eye(3), -np.eye(3)])
        else:
            n = as_float_array(normals, "normals")
            if n.ndim != 2 or n.shape[1] != 3 or n.shape[0] < 3:
                raise AttitudeValueError("normals: expected at least 3 head normals (n, 3)")
            nn = np.linalg.norm(n, axis=1)
            if not np.all(nn > 0):
                raise AttitudeValueError("normals: a zero normal has no direction")
            n = n / nn[:, None]
        object.__setattr__(self, "normals", n)
        v = _q(noise, "noise", "1")
        if not v < 1.0:
            raise AttitudeValueError(
                f"noise: σ = {v!r} full-Sun currents: noise at or above the signal it measures "
                "(a head's full-Sun current is 1); give σ as a fraction of it (0.01: 1 %)"
            )
        object.__setattr__(self, "noise", v)
        object.__setattr__(self, "seed", _seed(seed))


class Truth(tuple):
    """The perfect sensor set (the default): every quantity is measured exactly."""

    def __new__(cls):
        return super().__new__(cls, ())


def as_sensor_set(x: Any) -> tuple:
    """A tuple of distinct sensors (at most one of each kind) from a sensor, a sequence, a
    :class:`Truth` or None."""
    if x is None:
        return ()
    refuse_class(x, "sensors")
    if isinstance(x, Sensor):
        x = (x,)
    if isinstance(x, (str, bytes)) or not hasattr(x, "__iter__"):
        raise AttitudeTypeError(
            f"sensors: expected attitude.sensors objects (Gyro, StarTracker, Magnetometer, "
            f"SunSensor) or a sequence of them, got {type(x).__name__}"
        )
    out = tuple(x)
    kinds = set()
    for i, s in enumerate(out):
        refuse_class(s, f"sensors[{i}]")
        if not isinstance(s, Sensor):
            raise AttitudeTypeError(f"sensors[{i}]: expected a sensor, got {type(s).__name__}")
        if s.kind in kinds:
            raise AttitudeValueError(f"sensors[{i}]: a second {s.kind} (one of each kind)")
        kinds.add(s.kind)
    return out


def sensor_program(sensors: tuple, period: float, craft: Any, t0: float, t_end: float) -> tuple:
    """(the sensor program ``sn``, the initial sensor state ``ss``) of a sensor set: a header
    and a record per sensor, each packed through its declaration (:mod:`attitude._core.sensors`)."""
    out = Appender(np.zeros(_ks.SN.SIZE))
    h: dict[str, Any] = {}
    states: list[np.ndarray] = []
    ss_size = [0]

    def stream(sensor):
        at = ss_size[0]
        st = stream_state(sensor)
        states.append(st)
        ss_size[0] += st.size
        return at

    needs_sky = False
    for s in sensors:
        if isinstance(s, Gyro):
            sd, sq = _ks.gyro_tick_sigmas(s.arw, s.rrw, period)
            identity = float(np.array_equal(s.matrix, np.eye(3)))
            h["gyro"] = out.append(
                _ks.GYRO.pack(
                    sv=s.arw,
                    su=s.rrw,
                    sd=sd,
                    sq=sq,
                    b0=s.bias,
                    c=s.matrix,
                    identity=identity,
                    quant=s.quantization,
                    sat=s.saturation,
                    state=stream(s),
                )
            )
        elif isinstance(s, StarTracker):
            every = 1
            if s.rate is not None:
                k = 1.0 / (s.rate * period)
                every = round(k) if math.isfinite(k) and k < 2**53 else 0
                if every < 1 or abs(every - k) > 1e-9 * k:
                    raise AttitudeValueError(
                        f"sensors: the star tracker's rate {s.rate:g} Hz is not the software's "
                        f"{1 / period:g} Hz divided by a whole number"
                    )
            h["st"] = out.append(
                _ks.ST.pack(
                    sc=s.noise[0],
                    sb=s.noise[1],
                    cbs=s.frame,
                    every=every,
                    sun_excl=s.sun_exclusion,
                    earth_excl=s.earth_exclusion,
                    state=stream(s),
                )
            )
            needs_sky = needs_sky or s.sun_exclusion > 0 or s.earth_exclusion >= 0
        elif isinstance(s, Magnetometer):
            if craft.orbit is None:
                raise AttitudeValueError(
                    "sensors: a magnetometer measures the field along the orbit; give "
                    "Spacecraft(..., orbit=...)"
                )
            h["mag"] = out.append(_ks.MAG.pack(sigma=s.noise, bias=s.bias, state=stream(s)))
        elif isinstance(s, SunSensor):
            r = _ks.SUNS.pack(nheads=s.normals.shape[0], sigma=s.noise, state=stream(s))
            h["sun"] = out.append(np.concatenate([r, s.normals.reshape(-1)]))  # the normals' tail
            needs_sky = True
    if needs_sky or "mag" in h:
        if craft.orbit is None:
            raise AttitudeValueError(
                "sensors: Sun and Earth exclusions and Sun sensors need the spacecraft's orbit "
                "(Spacecraft(..., orbit=...), dated)"
            )
        h["orbit"] = out.append(craft.orbit.kernel_data())
        if needs_sky:
            if getattr(craft.orbit, "epoch", None) is None:
                raise AttitudeValueError(
                    "sensors: the Sun's direction needs a dated orbit (give the orbit an epoch)"
                )
            from orbit import sun as _sun

            h["suntab"] = out.append(
                _sun.SunTable(craft.orbit.epoch, t0 - 60.0, t_end + 60.0).kernel_data()
            )
    sn = _ks.SN.pack_into(out.array(), 0, **h)
    ss = np.concatenate(states) if states else np.zeros(0)
    return sn, ss

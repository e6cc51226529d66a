"""Reference frames: the attitudes a spacecraft is asked to hold, as functions of time.

A frame R gives its attitude quaternion q_R(t) — reference components → space components, the
same convention as the body attitude q (docs/conventions.md) — and its angular velocity ω_R(t)
in reference axes. Frames are small composable objects (``frame.offset(q)``), evaluated
vectorised (:meth:`Frame.quaternion`, :meth:`Frame.angular_velocity`) and, as one float64
array (:meth:`Frame.kernel_data`), inside compiled code by the dispatcher
:func:`attitude._core.frames.frame_eval`: events (``events.PointingExceeds``) and attitude laws
read them inside the integrator.

=================================  ===========================================================
``inertial(q)``                    a fixed attitude q (ω_R = 0)
``lvlh(orbit)``                    CCSDS / Vallado LVLH: z to nadir (−r̂), y to minus the orbit
                                   normal (−ĥ), x = y × z (along-track; v̂ on a circle)
``rsw(orbit)``                     x radial (r̂), z orbit normal (ĥ), y = z × x: the orbital
                                   frame p(t) of Arribas et al. (2006) Sect. 6.2
``vnc(orbit)``                     x velocity (v̂), y orbit normal (ĥ), z = x × y (co-normal)
``nadir(orbit, axis, secondary)``  body ``axis`` to nadir, ``secondary`` as close as possible
                                   to the velocity (``toward=``)
``sun_pointing(orbit, ...)``       ``axis`` to the Sun (seen from the spacecraft), secondary
                                   toward the orbit normal by default; needs an epoch
``target(orbit, lat, lon, h)``     ``axis`` to a ground station (WGS 84 geodetic), secondary
                                   toward the velocity; needs an epoch
``aligned(orbit, primary, ...)``   any two-vector frame: (axis, direction) pairs
=================================  ===========================================================

Directions (seen from the spacecraft, space frame): ``"zenith"`` (r̂), ``"nadir"``,
``"velocity"``, ``"-velocity"``, ``"normal"`` (ĥ = r × v / |r × v|), ``"-normal"``, ``"sun"``,
``"-sun"``, ``"target"``, ``"-target"``, or a fixed inertial vector (3 numbers). Axes:
``"+x"``, ``"-y"``, ... or 3 numbers. Times are seconds since the orbit's epoch.

The Sun comes from astropy (:mod:`orbit.sun`, apparent geocentric Sun in the GCRS) and a ground
station's GCRS position from astropy's ITRS → GCRS (:func:`orbit.frames.itrs_to_gcrs`, offline
IERS policy of :mod:`orbit.timescales`), both sampled once on a grid covering the times asked
for (:mod:`orbit.tables`: Sun every hour, station every 10 min) and interpolated in compiled
code. The derivatives behind ω_R are exact (orbit velocity and acceleration, table
velocities), not finite differences: see :mod:`attitude._core.frames`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from orbit._layout import Appender
from orbit._shared_jit import interpreted as _interpreted

from ._core import frames as _kf
from ._validation import as_float_array, as_quaternion, as_scalar
from .body import RigidBody
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "NAMED",
    "Frame",
    "aligned",
    "by_name",
    "inertial",
    "initial_state",
    "lvlh",
    "nadir",
    "rsw",
    "sun_pointing",
    "target",
    "vnc",
]

#: Spacing of the tables of a ground station's GCRS position [s].
TARGET_STEP = 600.0

_AXES = {
    "+x": (1.0, 0.0, 0.0),
    "x": (1.0, 0.0, 0.0),
    "-x": (-1.0, 0.0, 0.0),
    "+y": (0.0, 1.0, 0.0),
    "y": (0.0, 1.0, 0.0),
    "-y": (0.0, -1.0, 0.0),
    "+z": (0.0, 0.0, 1.0),
    "z": (0.0, 0.0, 1.0),
    "-z": (0.0, 0.0, -1.0),
}

_DIRECTIONS = {
    "zenith": _kf.DIR_ZENITH,
    "radial": _kf.DIR_ZENITH,
    "nadir": _kf.DIR_NADIR,
    "velocity": _kf.DIR_VELOCITY,
    "-velocity": _kf.DIR_ANTI_VELOCITY,
    "normal": _kf.DIR_NORMAL,
    "-normal": _kf.DIR_ANTI_NORMAL,
    "sun": _kf.DIR_SUN,
    "-sun": _kf.DIR_ANTI_SUN,
    "target": _kf.DIR_TARGET,
    "-target": _kf.DIR_ANTI_TARGET,
}
_NAMES = {v: k for k, v in _DIRECTIONS.items() if k != "radial"}


def as_axis(axis: Any, name: str = "axis") -> np.ndarray:
    """A unit 3-vector from ``"+x"``, ``"-z"``, ... or 3 numbers."""
    if isinstance(axis, str):
        key = axis.strip().lower()
        if key not in _AXES:
            raise AttitudeValueError(
                f"{name}: expected a body axis such as '+x', '-z' or three numbers, got {axis!r}"
            )
        return np.array(_AXES[key])
    v = as_float_array(axis, name, trailing=3, ndim=1)
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise AttitudeValueError(f"{name}: the zero vector is not a direction")
    return v / n


def _as_direction(direction: Any, name: str) -> tuple[int, np.ndarray]:
    if isinstance(direction, str):
        key = direction.strip().lower()
        if key not in _DIRECTIONS:
            raise AttitudeValueError(
                f"{name}: expected one of {', '.join(_DIRECTIONS)} or a fixed inertial vector "
                f"(3 numbers), got {direction!r}"
            )
        return _DIRECTIONS[key], np.zeros(3)
    return _kf.DIR_FIXED, as_axis(direction, name)


def _seconds(t: Any, name: str = "t") -> np.ndarray:
    return as_float_array(t, name, unit="s")


def _check_orbit(orbit: Any, what: str) -> Any:
    if not hasattr(orbit, "kernel_data"):
        raise AttitudeTypeError(
            f"orbit: {what} needs an orbit (orbit.KeplerOrbit, orbit.SecularJ2Orbit, "
            f"orbit.EphemerisOrbit), got {type(orbit).__name__}"
        )
    return orbit


def _continuous(q: np.ndarray) -> np.ndarray:
    if q.ndim != 2 or q.shape[0] < 2:
        return q
    dots = np.einsum("ij,ij->i", q[1:], q[:-1])
    s = np.concatenate([[1.0], np.cumprod(np.where(dots < 0.0, -1.0, 1.0))])
    return q * s[:, None]


class Frame:
    """A reference attitude q_R(t) (reference → space) with angular velocity ω_R(t).

    Subclasses describe themselves to compiled code by :meth:`kernel_data`.
    """

    name: str = "frame"
    orbit: Any = None

    def __init__(self) -> None:
        self._offset = np.array([1.0, 0.0, 0.0, 0.0])

    # -- identity -----------------------------------------------------------------------------
    @property
    def epoch(self) -> Any:
        """The time origin (astropy Time) of the frame's orbit, or None."""
        return getattr(self.orbit, "epoch", None)

    @property
    def needs_epoch(self) -> bool:
        """Whether the frame needs a date (the Sun, the Earth's rotation)."""
        return False

    def describe(self) -> str:
        """One line for result attrs."""
        off = (
            ""
            if np.array_equal(self._offset, [1.0, 0.0, 0.0, 0.0])
            else (f" offset {np.round(self._offset, 12).tolist()}")
        )
        return self._describe() + off

    def _describe(self) -> str:
        return self.name

    def __repr__(self) -> str:
        return f"<Frame {self.describe()}>"

    # -- composition --------------------------------------------------------------------------
    def offset(self, rotation: Any) -> Frame:
        """This frame turned by a fixed rotation about its own axes: q = q_R∘rotation.

        Parameters
        ----------
        rotation : array_like, shape (4,)
            Unit quaternion (e.g. ``attitude.quaternion.from_euler(angles, "321")``).

        Returns
        -------
        Frame
            A new frame; ω is carried into the new axes (ω = r̃∘ω_R∘r).
        """
        r = as_quaternion(rotation, "rotation")
        if r.shape != (4,) or abs(float(np.linalg.norm(r)) - 1.0) > 1e-6:
            raise AttitudeValueError("rotation: expected one unit quaternion of shape (4,)")
        import copy

        from .quaternion import multiply

        new = copy.copy(self)
        new._offset = multiply(self._offset, r / np.linalg.norm(r))
        return new

    def with_orbit(self, orbit: Any) -> Frame:
        """The same frame on another orbit (e.g. a run's propagated orbit,
        ``ds.attitude.propagated_orbit()``), its offset kept.

        Parameters
        ----------
        orbit : orbit.Orbit
            Any orbit the frame's constructor accepts.

        Returns
        -------
        Frame
        """
        if self.orbit is None:
            raise AttitudeValueError(
                f"orbit: the frame {self.describe()!r} has no orbit to replace"
            )
        import copy

        new = copy.copy(self)
        new.orbit = _check_orbit(orbit, "orbit")
        if hasattr(new, "_cache"):
            new._cache = None
        if new.needs_epoch and getattr(new.orbit, "epoch", None) is None:
            raise AttitudeValueError(
                f"orbit: the frame {self.describe()!r} needs an orbit with an epoch"
            )
        return new

    # -- compiled-layer data ------------------------------------------------------------------
    def kernel_data(self, start: float = 0.0, stop: float = 0.0) -> np.ndarray:
        """The float64 array :func:`attitude._core.frames.frame_eval` reads.

        Parameters
        ----------
        start, stop : float
            Span [s since the epoch] the tabulated inputs (Sun, ground station) must cover.
        """
        d = self._data(float(start), float(stop))
        d[_kf.FRAME.OFFSET : _kf.FRAME.OFFSET + 4] = self._offset
        return d

    def _data(self, start: float, stop: float) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise if the frame is undefined at some of the times ``t`` (an ephemeris' span)."""
        if self.orbit is not None and hasattr(self.orbit, "check_times"):
            try:
                self.orbit.check_times(t, name)
            except ValueError as exc:
                raise AttitudeValueError(str(exc)) from None

    # -- vectorised evaluation ----------------------------------------------------------------
    def evaluate(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """q_R(t) and ω_R(t) (reference axes, rad/s).

        Parameters
        ----------
        t : float, array_like or Quantity
            Seconds since the orbit's epoch.

        Returns
        -------
        q : ndarray, shape t.shape + (4,)
            Continuous in sign along a 1-D ``t``.
        omega : ndarray, shape t.shape + (3,)
        """
        return self._evaluate(t)

    def _evaluate(self, t: Any, interpreted: bool = False) -> tuple[np.ndarray, np.ndarray]:
        # interpreted: the kernels run as plain Python (orbit._shared_jit.interpreted: the same
        # results, nothing compiled), for a sample or two such as an initial state, where
        # compiling the frame dispatcher would cost a fresh install seconds before a run starts.
        tt = _seconds(t)
        flat = np.ascontiguousarray(tt.ravel())
        self.check_times(flat)
        out = np.empty((flat.size, 7))
        if flat.size:
            d = self.kernel_data(float(flat.min()), float(flat.max()))
            try:
                (_interpreted(_kf) if interpreted else _kf).frame_loop(d, flat, out)
            except (ArithmeticError, ValueError):  # Python raised where compiled code gives NaN
                _kf.frame_loop(d, flat, out)
        q = out[:, :4]
        if tt.ndim == 1:
            q = _continuous(q)
        return q.reshape((*tt.shape, 4)), out[:, 4:].reshape((*tt.shape, 3))

    def quaternion(self, t: Any) -> np.ndarray:
        """q_R(t), reference → space, shape t.shape + (4,)."""
        return self.evaluate(t)[0]

    def angular_velocity(self, t: Any) -> np.ndarray:
        """ω_R(t) in reference axes [rad/s], shape t.shape + (3,)."""
        return self.evaluate(t)[1]


class Inertial(Frame):
    """A fixed attitude: q_R = q, ω_R = 0."""

    name = "inertial"

    def __init__(self, q: Any = (1.0, 0.0, 0.0, 0.0)):
        super().__init__()
        qq = as_quaternion(q, "q")
        if qq.shape != (4,) or abs(float(np.linalg.norm(qq)) - 1.0) > 1e-6:
            raise AttitudeValueError("q: expected one unit quaternion of shape (4,)")
        self.q = qq / np.linalg.norm(qq)

    def _describe(self) -> str:
        return f"inertial(q={np.round(self.q, 12).tolist()})"

    def _data(self, start: float, stop: float) -> np.ndarray:
        d = _kf.INERTIAL.pack(type=_kf.FRAME_INERTIAL, q=self.q)
        return d


class Aligned(Frame):
    """A two-vector frame: ``primary`` axis along a direction, ``secondary`` as close as possible.

    Parameters
    ----------
    orbit : orbit.Orbit
        The spacecraft's orbit (position, velocity, acceleration, epoch).
    primary, secondary : (axis, direction)
        Reference axes (``"+z"``, 3 numbers) and space directions (``"nadir"``, ``"sun"``, a
        fixed vector, ...; see the module docstring). The axes must not be parallel.
    target_itrs : array_like, shape (3,), optional
        ITRS position [km] of the ground point the ``"target"`` directions refer to.
    name : str
        Shown in descriptions.
    """

    def __init__(
        self,
        orbit: Any,
        primary: tuple[Any, Any],
        secondary: tuple[Any, Any],
        *,
        target_itrs: Any = None,
        name: str = "aligned",
    ):
        super().__init__()
        self.orbit = _check_orbit(orbit, name)
        self.name = name
        for nm, pair in (("primary", primary), ("secondary", secondary)):
            if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
                raise AttitudeValueError(
                    f"{nm}: expected (axis, direction), e.g. ('+z', 'nadir'), got {pair!r}"
                )
        self.primary_axis = as_axis(primary[0], "primary axis")
        self.secondary_axis = as_axis(secondary[0], "secondary axis")
        self.primary_code, self.primary_vec = _as_direction(primary[1], "primary direction")
        self.secondary_code, self.secondary_vec = _as_direction(secondary[1], "secondary direction")
        c = np.cross(self.primary_axis, self.secondary_axis)
        if np.linalg.norm(c) < 1e-9:
            raise AttitudeValueError(
                "secondary: the secondary axis is parallel to the primary one; give another "
                "axis (e.g. '+x' with a primary '+z')"
            )
        if self.primary_code == self.secondary_code and self.primary_code != _kf.DIR_FIXED:
            raise AttitudeValueError(
                "secondary: the two directions are the same; the frame would be undefined"
            )
        codes = (self.primary_code, self.secondary_code)
        self._uses_sun = any(k in (_kf.DIR_SUN, _kf.DIR_ANTI_SUN) for k in codes)
        self._uses_target = any(k in (_kf.DIR_TARGET, _kf.DIR_ANTI_TARGET) for k in codes)
        if self._uses_target:
            if target_itrs is None:
                raise AttitudeValueError(
                    "target_itrs: a 'target' direction needs the ground point's ITRS position"
                )
            self.target_itrs = as_float_array(target_itrs, "target_itrs", trailing=3, ndim=1)
        else:
            self.target_itrs = None
        if self.needs_epoch and getattr(self.orbit, "epoch", None) is None:
            what = "the Sun's position" if self._uses_sun else "the Earth's rotation"
            raise AttitudeValueError(
                f"orbit: the {name} frame needs {what}, so a date: build the orbit with an "
                "epoch (e.g. orbit.KeplerOrbit(..., epoch='2024-03-20T12:00:00'))"
            )
        t1 = self.primary_axis
        t2 = c / np.linalg.norm(c)
        self._body = np.concatenate([t1, t2, np.cross(t1, t2)])
        self._cache: tuple[tuple[float, float], np.ndarray] | None = None

    @property
    def needs_epoch(self) -> bool:
        return self._uses_sun or self._uses_target

    def _describe(self) -> str:
        def d(code, vec):
            return _NAMES.get(code) or np.round(vec, 12).tolist()

        src = getattr(self.orbit, "describe", lambda: type(self.orbit).__name__)()
        return (
            f"{self.name}: {np.round(self.primary_axis, 12).tolist()} to "
            f"{d(self.primary_code, self.primary_vec)}, "
            f"{np.round(self.secondary_axis, 12).tolist()} toward "
            f"{d(self.secondary_code, self.secondary_vec)} ({src})"
        )

    def _tables(self, start: float, stop: float) -> list[np.ndarray]:
        if self._cache is not None:
            (lo, hi), tabs = self._cache
            if lo <= start and stop <= hi:
                return tabs
        from orbit import sun as _sun
        from orbit import tables as _tables

        out = []
        if self._uses_sun:
            out.append(_sun.SunTable(self.orbit.epoch, start, stop).kernel_data())
        if self._uses_target:
            from astropy.time import TimeDelta

            from orbit.frames import itrs_to_gcrs
            from orbit.timescales import check_dates

            ep = self.orbit.epoch
            x = self.target_itrs

            def positions(t: np.ndarray) -> np.ndarray:
                check_dates(ep, t, "t")
                return itrs_to_gcrs(ep + TimeDelta(t, format="sec"), x, "t")

            out.append(_tables.tabulate(positions, start, stop, TARGET_STEP))
        self._cache = ((start, stop), out)
        return out

    def _data(self, start: float, stop: float) -> np.ndarray:
        h = dict(
            type=_kf.FRAME_ALIGNED,
            pdir=self.primary_code,
            sdir=self.secondary_code,
            body=self._body,
            pvec=self.primary_vec,
            svec=self.secondary_vec,
        )
        out = Appender(np.zeros(_kf.ALIGNED.SIZE))
        h["orbit"] = out.append(self.orbit.kernel_data())
        tabs = iter(self._tables(start, stop) if self.needs_epoch else [])
        if self._uses_sun:
            h["sun"] = out.append(next(tabs))
        if self._uses_target:
            h["target"] = out.append(next(tabs))
        return _kf.ALIGNED.pack_into(out.array(), 0, **h)


# ---------------------------------------------------------------------------------------------
# the named frames
# ---------------------------------------------------------------------------------------------


def inertial(q: Any = (1.0, 0.0, 0.0, 0.0)) -> Frame:
    """A fixed reference attitude q (reference → space); ω_R = 0."""
    return Inertial(q)


def lvlh(orbit: Any) -> Frame:
    """CCSDS / Vallado local-vertical local-horizontal frame: z to nadir, y to −(orbit normal).

    x = y × z is along-track (the velocity direction on a circular orbit). ω_R = (0, −ḟ, 0) on
    a Keplerian orbit (ḟ the true-anomaly rate).
    """
    return Aligned(orbit, ("+z", "nadir"), ("+y", "-normal"), name="lvlh")


def rsw(orbit: Any) -> Frame:
    """Radial, along-track, cross-track: x = r̂, z = ĥ, y = z × x (Vallado's RSW).

    The orbital frame p(t) of Arribas, Elipe & Palacios (2006) Sect. 6.2
    (``orbit.frame_quaternion``, the ``p`` variable of gravity-gradient results) and the
    ``frame = "orbital"`` of scenarios.
    """
    return Aligned(orbit, ("+x", "zenith"), ("+z", "normal"), name="rsw")


def vnc(orbit: Any) -> Frame:
    """Velocity, normal, co-normal: x = v̂, y = ĥ, z = x × y."""
    return Aligned(orbit, ("+x", "velocity"), ("+y", "normal"), name="vnc")


def nadir(orbit: Any, axis: Any = "+z", secondary: Any = "+x", toward: Any = "velocity") -> Frame:
    """Body ``axis`` to nadir, ``secondary`` axis as close as possible to ``toward``.

    The defaults (z to nadir, x toward the velocity) are :func:`lvlh`.
    """
    return Aligned(orbit, (axis, "nadir"), (secondary, toward), name="nadir")


def sun_pointing(
    orbit: Any, axis: Any = "+z", secondary: Any = "+x", toward: Any = "normal"
) -> Frame:
    """Body ``axis`` to the Sun (seen from the spacecraft), ``secondary`` toward ``toward``.

    The Sun is astropy's apparent geocentric Sun (:mod:`orbit.sun`), tabulated over the span
    used; the orbit needs an epoch. The default secondary direction, the orbit normal, keeps
    the frame nearly inertial (it turns with the Sun, ~1°/day, and the orbit plane).
    """
    return Aligned(orbit, (axis, "sun"), (secondary, toward), name="sun_pointing")


#: Heights of a ground target accepted [km]: from below the deepest ocean floor (−11 km) to
#: the edge of space (a height of −7000 km is on the far side of the Earth's centre).
TARGET_HEIGHTS = (-12.0, 100.0)


def target(
    orbit: Any,
    latitude: Any,
    longitude: Any,
    height: Any = 0.0,
    *,
    axis: Any = "+z",
    secondary: Any = "+x",
    toward: Any = "velocity",
) -> Frame:
    """Body ``axis`` to a ground station, ``secondary`` as close as possible to ``toward``.

    Parameters
    ----------
    orbit : orbit.Orbit
        With an epoch (the station turns with the Earth: ITRS → GCRS by astropy).
    latitude, longitude : float or Quantity
        WGS 84 geodetic latitude and longitude [rad, or an angle Quantity].
    height : float or Quantity
        Height above the ellipsoid [km, or a length Quantity].
    """
    from orbit.frames import itrs_from_geodetic

    lat = as_scalar(latitude, "latitude", unit="rad")
    lon = as_scalar(longitude, "longitude", unit="rad")
    h = as_scalar(height, "height", unit="km")
    if abs(lat) > math.pi / 2:
        raise AttitudeValueError(f"latitude: must lie in [-90°, 90°], got {math.degrees(lat)}°")
    if not TARGET_HEIGHTS[0] <= h <= TARGET_HEIGHTS[1]:
        raise AttitudeValueError(
            f"height: a ground target's height above the WGS 84 ellipsoid must lie in "
            f"[{TARGET_HEIGHTS[0]:g}, {TARGET_HEIGHTS[1]:g}] km (the ocean floor to the edge "
            f"of space), got {h!r} km"
        )
    x = itrs_from_geodetic(lat, lon, h)
    fr = Aligned(orbit, (axis, "target"), (secondary, toward), target_itrs=x, name="target")
    fr.site = (lat, lon, h)
    return fr


def aligned(orbit: Any, primary: tuple[Any, Any], secondary: tuple[Any, Any], **kw: Any) -> Frame:
    """Any two-vector frame (see :class:`Aligned`), e.g. ``aligned(o, ("+x", "sun"), ("+z",
    "nadir"))``."""
    return Aligned(orbit, primary, secondary, **kw)


# ---------------------------------------------------------------------------------------------
# initial states
# ---------------------------------------------------------------------------------------------


#: The frames that :func:`by_name` builds on an orbit (scenario files, ``attitude plot --frame``):
#: name -> (maker, description). ``orbital`` is ``rsw``.
NAMED = {
    "orbital": "rsw",
    "rsw": "rsw",
    "lvlh": "lvlh",
    "vnc": "vnc",
    "nadir": "nadir",
    "sun_pointing": "sun_pointing",
}


def by_name(name: str, orbit: Any, q: Any = None) -> Frame:
    """A frame by its name: ``"inertial"`` (``q``, default the identity: the space axes), or
    one of :data:`NAMED` on ``orbit`` (``"orbital"`` is :func:`rsw`), with its defaults.

    Raises
    ------
    AttitudeValueError
        An unknown name, or a frame on an orbit without one.
    """
    if name == "inertial":
        return inertial((1.0, 0.0, 0.0, 0.0) if q is None else q)
    if name not in NAMED:
        raise AttitudeValueError(
            f"frame: expected inertial or one of {', '.join(NAMED)} ('orbital' is rsw), got "
            f"{name!r}"
        )
    if orbit is None:
        raise AttitudeValueError(f"frame: {name!r} is a frame on an orbit; this run has none")
    return globals()[NAMED[name]](orbit)


def initial_state(
    body: Any, frame: Frame, t0: Any = 0.0, offset: Any = None, rates: Any = None
) -> tuple[np.ndarray, np.ndarray]:
    """The canonical initial state (q0, Q0) of a body aligned with a reference frame.

    The body's attitude is the frame's, turned by ``offset`` about the frame's axes,
    q0 = q_R(t0)∘offset, and it rotates with the frame plus ``rates``:
    ω_B = õ∘ω_R(t0)∘o + rates (body axes), Q0 = 2 q0∘(0, I ω_B).

    Parameters
    ----------
    body : RigidBody, Spacecraft or array_like, shape (3,)
        The body (principal moments); a spacecraft's wheels keep their initial speeds
        relative to the body (Q0 holds the total momentum of body and wheels).
    frame : Frame
        From :mod:`attitude.frames` (``lvlh(orbit)``, ...).
    t0 : float or Quantity
        Time [s since the frame's epoch].
    offset : array_like, shape (4,), optional
        Attitude of the body relative to the frame (unit quaternion; identity by default).
    rates : array_like or Quantity, shape (3,), optional
        Body angular velocity relative to the frame, in body axes [rad/s, or a Quantity such
        as ``[0.1, 0, 0] * u.deg / u.s``].

    Returns
    -------
    q0 : ndarray, shape (4,)
    Q0 : ndarray, shape (4,)
        In the body's unit system (as :func:`attitude.propagate` takes them).
    """
    from .canonical import momenta_from_angular_velocity
    from .quaternion import multiply, rotate_inverse

    if not isinstance(frame, Frame):
        raise AttitudeTypeError(
            f"frame: expected a reference frame from attitude.frames (lvlh(orbit), ...), got "
            f"{type(frame).__name__}"
        )
    from .spacecraft import Spacecraft

    b = body if isinstance(body, (RigidBody, Spacecraft)) else RigidBody(body)
    t = as_scalar(t0, "t0", unit="s")
    qR, wR = frame._evaluate(np.array([t]), interpreted=True)
    qR, wR = qR[0], wR[0]
    if not (np.all(np.isfinite(qR)) and np.all(np.isfinite(wR))):
        raise AttitudeValueError(f"frame: {frame.describe()} is undefined at t0 = {t}")
    o = np.array([1.0, 0.0, 0.0, 0.0])
    if offset is not None:
        o = as_quaternion(offset, "offset")
        if o.shape != (4,) or abs(float(np.linalg.norm(o)) - 1.0) > 1e-6:
            raise AttitudeValueError("offset: expected one unit quaternion of shape (4,)")
        o = o / np.linalg.norm(o)
    q0 = multiply(qR, o)
    w = rotate_inverse(o, wR)
    if rates is not None:
        w = w + as_float_array(rates, "rates", trailing=3, ndim=1, unit="rad / s")
    return q0, momenta_from_angular_velocity(q0, w, b)

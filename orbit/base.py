"""The orbit interface (:class:`Orbit`, a Protocol) and the shared implementation.

Every orbit source — :class:`orbit.KeplerOrbit`, :class:`orbit.SecularJ2Orbit`,
:class:`orbit.EphemerisOrbit` — offers the same members, so ``attitude.GravityGradient``,
scenarios, results and exports take any of them:

==========================  =====================================================================
``epoch``                   astropy ``Time`` of t = 0, or None (an orbit without a date)
``mu``                      gravitational parameter [km³/s²]
``frame``                   ``"GCRS"`` when there is an epoch, else ``"inertial"``
``source``                  one line saying where the orbit comes from (for attrs and ``info``)
``time_span``               (t_min, t_max) [s] where the orbit is defined (±inf if everywhere)
``position(t)``             (..., 3) [km], space frame
``velocity(t)``             (..., 3) [km/s]
``acceleration(t)``         (..., 3) [km/s²], d(velocity)/dt of the model
``radius(t)``               (...) [km]
``radial_direction(t)``     (..., 3) unit vectors r/|r|
``frame_quaternion(t)``     (..., 4) the paper's p(t): p∘s1∘p̃ = r̂, p∘s3∘p̃ = orbit normal
``true_anomaly(t)``         (...) [rad] (osculating for non-Keplerian orbits)
``itrs_position(t)``        (..., 3) [km], Earth-fixed (needs an epoch)
``geodetic(t)``             (lat [rad], lon [rad], height [km]) WGS 84 (needs an epoch)
``kernel_data()``           float64 array read by the compiled kernels (:mod:`orbit._state_kernels`)
``check_times(t, name)``    raise :class:`OrbitValueError` naming ``name`` outside ``time_span``
==========================  =====================================================================

``t`` is seconds since the epoch (float, array or Quantity); an astropy ``Time`` is accepted too
and converted (elapsed SI seconds, so leap seconds count).
"""

from __future__ import annotations

import math
from typing import Any, Protocol, runtime_checkable

import numpy as np

from . import _state_kernels as _sk
from .errors import OrbitValueError
from .kepler import _as_array
from .timescales import check_dates, quiet_erfa

__all__ = ["Orbit", "OrbitBase"]


@runtime_checkable
class Orbit(Protocol):
    """What every orbit source provides (see the module docstring for units and shapes)."""

    @property
    def epoch(self) -> Any: ...

    @property
    def mu(self) -> float: ...

    @property
    def frame(self) -> str: ...

    @property
    def source(self) -> str: ...

    @property
    def time_span(self) -> tuple[float, float]: ...

    def position(self, t: Any) -> np.ndarray: ...

    def velocity(self, t: Any) -> np.ndarray: ...

    def radius(self, t: Any) -> Any: ...

    def radial_direction(self, t: Any) -> np.ndarray: ...

    def frame_quaternion(self, t: Any) -> np.ndarray: ...

    def true_anomaly(self, t: Any) -> Any: ...

    def itrs_position(self, t: Any) -> np.ndarray: ...

    def geodetic(self, t: Any) -> tuple[Any, Any, Any]: ...

    def kernel_data(self) -> np.ndarray: ...

    def check_times(self, t: Any, name: str = "t") -> None: ...


def _continuous_sign(p: np.ndarray) -> np.ndarray:
    """Flip signs along the first axis so consecutive quaternions have p_k·p_{k−1} >= 0."""
    if p.shape[0] < 2:
        return p
    dots = np.einsum("ij,ij->i", p[1:], p[:-1])
    s = np.concatenate([[1.0], np.cumprod(np.where(dots < 0.0, -1.0, 1.0))])
    return p * s[:, None]


class OrbitBase:
    """Shared implementation of :class:`Orbit` on top of :meth:`kernel_data` (one compiled
    dispatcher, :mod:`orbit._state_kernels`). Subclasses set the array with
    :meth:`_set_data` and ``self._epoch``."""

    _data: np.ndarray  # read-only view of the kernel array
    _kdata: np.ndarray  # the same memory, writable: what the compiled loops are given
    _epoch: Any = None

    def _set_data(self, d: np.ndarray) -> None:
        """Keep the kernel array ``d``: a read-only view as ``_data``, and ``d`` itself, never
        written, for the compiled loops. numba types a read-only array as another type, and the
        models read writable copies (``kernel_data()``): given the read-only one, every orbit
        kernel compiled twice."""
        self._kdata = d
        v = d.view()
        v.setflags(write=False)
        self._data = v

    # -- identity ---------------------------------------------------------------------------
    @property
    def epoch(self) -> Any:
        """astropy ``Time`` of t = 0 (None: the orbit has no date)."""
        return self._epoch

    @property
    def mu(self) -> float:
        """Gravitational parameter [km³/s²]."""
        return float(self._data[_sk.MU])

    @property
    def frame(self) -> str:
        """Space frame of positions and velocities: ``"GCRS"`` with an epoch, else
        ``"inertial"`` (an undated inertial frame)."""
        return "GCRS" if self._epoch is not None else "inertial"

    @property
    def source(self) -> str:
        """Where the orbit comes from (one line)."""
        return type(self).__name__

    @property
    def time_span(self) -> tuple[float, float]:
        """(t_min, t_max) [s since the epoch] where the orbit is defined."""
        return float(self._data[_sk.T_MIN]), float(self._data[_sk.T_MAX])

    def kernel_data(self) -> np.ndarray:
        """A copy of the float64 array the compiled kernels read (:mod:`orbit._state_kernels`)."""
        return self._data.copy()

    def describe(self) -> str:
        """Source, epoch and frame on one line (recorded in result attrs)."""
        from .timescales import format_epoch

        ep = "no epoch" if self._epoch is None else f"epoch {format_epoch(self._epoch)}"
        return f"{self.source}; {ep}; frame {self.frame}"

    # -- times ------------------------------------------------------------------------------
    def seconds_since_epoch(self, time: Any, name: str = "t") -> Any:
        """Elapsed SI seconds from the epoch to ``time`` (astropy Time or ISO 8601 string)."""
        from astropy.time import Time

        from .timescales import as_epoch

        if self._epoch is None:
            raise OrbitValueError(
                f"{name}: this orbit has no epoch, so absolute times mean nothing to it; give "
                "seconds, or build the orbit with epoch=..."
            )
        if isinstance(time, str):
            time = as_epoch(time, name)
        if not isinstance(time, Time):
            raise OrbitValueError(f"{name}: expected an astropy Time or ISO 8601 string")
        d = (time - self._epoch).sec
        return float(d) if np.ndim(d) == 0 else np.asarray(d, dtype=np.float64)

    def absolute_times(self, t: Any) -> Any:
        """``epoch + t`` as an astropy Time (UTC), t in seconds."""
        from astropy.time import TimeDelta

        if self._epoch is None:
            raise OrbitValueError(
                "epoch: this orbit has no epoch; Earth-fixed positions and absolute times need "
                "one (give epoch='2024-03-20T12:00:00' or an astropy Time)"
            )
        flat, shape = self._seconds(t, "t", check=False)
        check_dates(self._epoch, flat, "t")
        with quiet_erfa():
            return (self._epoch + TimeDelta(flat, format="sec")).utc.reshape(shape)

    def _seconds(self, t: Any, name: str, check: bool = True) -> tuple[np.ndarray, tuple]:
        from astropy.time import Time

        if isinstance(t, Time):
            ta = np.asarray(self.seconds_since_epoch(t, name), dtype=np.float64)
        else:
            ta = _as_array(t, name, "s")
        flat = np.ascontiguousarray(ta, dtype=np.float64).ravel()
        if check:
            self.check_times(flat, name)
        return flat, ta.shape

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise :class:`OrbitValueError` (naming ``name``) for times outside ``time_span``."""
        lo, hi = self.time_span
        if math.isinf(lo) and math.isinf(hi):
            arr = np.asarray(t, dtype=np.float64)
            if arr.size and not np.all(np.isfinite(arr)):
                raise OrbitValueError(f"{name}: times must be finite")
            return
        arr = np.asarray(t, dtype=np.float64)
        if arr.size == 0:
            return
        tol = 1e-12 * max(1.0, abs(lo), abs(hi))
        tmin, tmax = float(np.min(arr)), float(np.max(arr))
        if not (np.all(np.isfinite(arr)) and tmin >= lo - tol and tmax <= hi + tol):
            raise OrbitValueError(
                f"{name}: times from {tmin!r} s to {tmax!r} s since the epoch leave the "
                f"{self.source} table, which covers {lo!r} s to {hi!r} s; an ephemeris is "
                "not extrapolated: give times inside it or a longer table"
            )

    @staticmethod
    def _shape(out: np.ndarray, shape: tuple) -> Any:
        if shape == ():
            return float(out[0])
        return out.reshape(shape)

    # -- state ------------------------------------------------------------------------------
    def _state_rows(self, t: Any) -> tuple[np.ndarray, tuple]:
        flat, shape = self._seconds(t, "t")
        out = np.empty((flat.size, 6))
        _sk.state_loop(self._kdata, flat, out)
        return out, shape

    def position(self, t: Any) -> np.ndarray:
        """Position in the space frame [km].

        Parameters
        ----------
        t : float, array_like, Quantity or astropy Time
            Seconds since the epoch (or absolute times).

        Returns
        -------
        r : ndarray, shape t.shape + (3,)
        """
        out, shape = self._state_rows(t)
        return out[:, :3].reshape((*shape, 3))

    def velocity(self, t: Any) -> np.ndarray:
        """Velocity in the space frame [km/s], shape t.shape + (3,)."""
        out, shape = self._state_rows(t)
        return out[:, 3:].reshape((*shape, 3))

    def acceleration(self, t: Any) -> np.ndarray:
        """Time derivative of the model's velocity [km/s²], shape t.shape + (3,)
        (:func:`orbit._state_kernels.orbit_acceleration`)."""
        flat, shape = self._seconds(t, "t")
        out = np.empty((flat.size, 3))
        _sk.acceleration_loop(self._kdata, flat, out)
        return out.reshape((*shape, 3))

    def to_state(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """Position [km] and velocity [km/s] at t, shape t.shape + (3,) each."""
        out, shape = self._state_rows(t)
        return out[:, :3].reshape((*shape, 3)), out[:, 3:].reshape((*shape, 3))

    def _radial(self, t: Any) -> tuple[np.ndarray, tuple]:
        flat, shape = self._seconds(t, "t")
        out = np.empty((flat.size, 4))
        _sk.radial_loop(self._kdata, flat, out)
        return out, shape

    def radius(self, t: Any) -> Any:
        """Distance from the centre [km], shape of t."""
        out, shape = self._radial(t)
        return self._shape(np.ascontiguousarray(out[:, 0]), shape)

    def radial_direction(self, t: Any) -> np.ndarray:
        """Unit vector r/|r| in the space frame, shape t.shape + (3,)."""
        out, shape = self._radial(t)
        return out[:, 1:].reshape((*shape, 3))

    def frame_quaternion(self, t: Any) -> np.ndarray:
        """Orbital-frame quaternion p(t), scalar first: p∘s1∘p̃ = r̂, p∘s3∘p̃ = (r × v)/|r × v|.

        For a 1-D t the signs are chosen continuous along the array (p and −p are the same
        rotation).

        Returns
        -------
        p : ndarray, shape t.shape + (4,)
        """
        flat, shape = self._seconds(t, "t")
        out = np.empty((flat.size, 5))
        _sk.frame_loop(self._kdata, flat, out)
        p = out[:, 1:]
        if len(shape) == 1:
            p = _continuous_sign(p)
        return p.reshape((*shape, 4))

    def true_anomaly(self, t: Any) -> Any:
        """Osculating true anomaly [rad] in (−π, π] (from r, v and μ).

        Ill-conditioned for near-circular orbits (the periapsis is then barely defined).
        """
        out, shape = self._state_rows(t)
        r, v = out[:, :3], out[:, 3:]
        mu = self.mu
        rn = np.linalg.norm(r, axis=-1)
        h = np.linalg.norm(np.cross(r, v), axis=-1)
        p = h * h / mu
        ecosf = p / rn - 1.0
        esinf = np.sqrt(p / mu) * np.einsum("ij,ij->i", r, v) / rn
        return self._shape(np.arctan2(esinf, ecosf), shape)

    # -- Earth-fixed ------------------------------------------------------------------------
    def itrs_position(self, t: Any) -> np.ndarray:
        """Earth-fixed (ITRS) position [km] through astropy GCRS → ITRS, bundled IERS tables.

        Returns
        -------
        r : ndarray, shape t.shape + (3,)
        """
        from .frames import gcrs_to_itrs

        flat, shape = self._seconds(t, "t")
        times = self.absolute_times(flat)
        out = np.empty((flat.size, 6))
        _sk.state_loop(self._kdata, flat, out)
        return gcrs_to_itrs(times, out[:, :3]).reshape((*shape, 3))

    def geodetic(self, t: Any) -> tuple[Any, Any, Any]:
        """WGS 84 geodetic latitude [rad], longitude [rad] in (−π, π], height [km].

        Returns
        -------
        lat, lon, height : float or ndarray, shape of t
        """
        from .frames import geodetic_from_itrs

        flat, shape = self._seconds(t, "t")
        lat, lon, h = geodetic_from_itrs(self.itrs_position(flat))
        return self._shape(lat, shape), self._shape(lon, shape), self._shape(h, shape)

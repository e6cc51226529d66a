"""The Sun for attitude and environment models: its position in the GCRS and Earth's shadow.

One module for everything Sun-related, so that pointing laws, events (``attitude.events``) and
environment torques (solar radiation pressure) share it:

* :func:`sun_position` — the Sun's geocentric position [km] in the GCRS at given times, from
  astropy (``get_body("sun")`` with its built-in ERFA ephemeris, no network): the *apparent*
  Sun seen from the geocentre (light time and annual aberration included, 20″), which is where
  the light that casts Earth's shadow and reaches a Sun sensor comes from;
* :class:`SunTable` — the same, sampled once on a uniform grid (default 1 h) covering a run and
  stored as a Hermite table (:mod:`orbit.tables`; the layout of an ephemeris orbit), so compiled
  code reads it with ``orbit._state_kernels.orbit_state(table, t)`` or :func:`sun_state`;
  interpolation error below 1e-6 km at 1 h spacing (tests/test_sun.py measures it against
  astropy evaluated directly), far below the ephemeris' own error (ERFA ``epv00``, ~km);
* the **conical shadow** of a spherical Earth, Montenbruck & Gill, *Satellite Orbits* (2000),
  Sect. 3.4.2: seen from the satellite, the Sun's disk (apparent radius a = asin(R☉/|s − r|))
  and the Earth's disk (b = asin(R⊕/|r|)) are a distance c apart (the angle between −r and
  s − r). Full light for c ≥ a + b (ν = 1), umbra for c ≤ b − a (ν = 0), otherwise the visible
  fraction ν of the solar disk (their eqs. 3.85–3.88; annular for c < a − b, ν = 1 − b²/a²).
  The two boundary functions ``c − (a + b)`` (penumbra) and ``c − (b − a)`` (umbra) are smooth
  in time, positive in light: their roots are the eclipse entry and exit times.
  :func:`conical_shadow` (compiled) and :func:`shadow_function` (vectorised) evaluate them.

Radii: R⊕ = 6378.137 km (WGS 84 equatorial; the Earth is a sphere here: its oblateness moves
shadow boundaries by up to ~20 km at the poles, ~1–3 s in LEO) and R☉ = 695 700 km (IAU 2015
nominal solar radius). Times are seconds since an epoch (elapsed SI seconds; astropy does the
scales and leap seconds).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _state_kernels as _sk
from . import tables as _tables
from ._shared_jit import jit
from .errors import OrbitValueError
from .timescales import as_epoch, check_dates, offline_iers

__all__ = [
    "R_EARTH",
    "R_SUN",
    "SunTable",
    "conical_shadow",
    "shadow_function",
    "sun_position",
    "sun_state",
]

#: Earth radius for the shadow [km] (WGS 84 equatorial).
R_EARTH = 6378.137
#: Solar radius [km] (IAU 2015 Resolution B3 nominal value).
R_SUN = 695700.0
#: Default spacing of a Sun table [s].
SUN_STEP = 3600.0


def _seconds(epoch: Any, t: Any) -> tuple[Any, np.ndarray]:
    from astropy.time import Time

    if isinstance(t, Time):
        return t, np.asarray((t - epoch).sec, dtype=np.float64)
    tt = np.asarray(getattr(t, "to_value", lambda u: t)("s"), dtype=np.float64)
    return None, tt


def sun_position(epoch: Any, t: Any) -> np.ndarray:
    """Geocentric position of the (apparent) Sun in the GCRS [km], straight from astropy.

    Parameters
    ----------
    epoch : astropy Time or str
        Time origin.
    t : float, array_like or Quantity
        Seconds since ``epoch`` (or an astropy Time).

    Returns
    -------
    ndarray, shape t.shape + (3,)
    """
    from astropy import units as u
    from astropy.coordinates import get_body
    from astropy.time import TimeDelta

    ep = as_epoch(epoch, "epoch", allow_none=False)
    times, tt = _seconds(ep, t)
    flat = tt.ravel()
    check_dates(ep, flat, "t")
    if times is None:
        times = ep + TimeDelta(flat, format="sec")
    with offline_iers():
        s = get_body("sun", times.reshape(flat.shape))
        xyz = s.cartesian.xyz.to_value(u.km).T
    return np.ascontiguousarray(xyz).reshape((*tt.shape, 3))


_TABLES: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}  # (read-only view, array)
_TABLES_MAX = 16


class SunTable:
    """The Sun's GCRS position on a uniform grid over [start, stop], for compiled code.

    Tables are memoised per (epoch, start, stop, step) (the last 16): repeated runs over the
    same span do not call astropy again.

    Parameters
    ----------
    epoch : astropy Time or str
        Time origin of ``t``.
    start, stop : float
        Span to cover [s since the epoch]; the grid extends two steps beyond each end.
    step : float
        Grid spacing [s] (default 3600).
    """

    def __init__(self, epoch: Any, start: float, stop: float, step: float = SUN_STEP):
        self.epoch = as_epoch(epoch, "epoch", allow_none=False)
        ep = self.epoch
        tai = ep.tai
        key = (float(tai.jd1), float(tai.jd2), float(start), float(stop), float(step))
        if key not in _TABLES:

            def positions(t: np.ndarray) -> np.ndarray:
                return sun_position(ep, t)

            # a wide velocity stencil: astropy's positions scatter by ~1e-5 km (1e-13 relative)
            data = _tables.tabulate(positions, start, stop, step, delta=step / 6.0)
            view = data.view()
            view.setflags(write=False)
            if len(_TABLES) >= _TABLES_MAX:
                _TABLES.pop(next(iter(_TABLES)))
            _TABLES[key] = (view, data)
        # a read-only view, and the same memory writable for the compiled loops (never written:
        # numba would compile a read-only array as another type than the models' copies)
        self._data, self._kdata = _TABLES[key]

    @property
    def time_span(self) -> tuple[float, float]:
        """(t_min, t_max) [s] of the grid."""
        return float(self._data[_sk.T_MIN]), float(self._data[_sk.T_MAX])

    def kernel_data(self) -> np.ndarray:
        """A copy of the table (ephemeris layout; read it with :func:`sun_state`)."""
        return self._data.copy()

    def _state(self, t: Any) -> np.ndarray:
        tt = np.asarray(getattr(t, "to_value", lambda u: t)("s"), dtype=np.float64)
        lo, hi = self.time_span
        if tt.size and (np.min(tt) < lo or np.max(tt) > hi or not np.all(np.isfinite(tt))):
            raise OrbitValueError(
                f"t: times outside the Sun table [{lo}, {hi}] s; build it over the span you need"
            )
        return _tables.evaluate(self._kdata, tt)

    def position(self, t: Any) -> np.ndarray:
        """Interpolated Sun position [km], shape t.shape + (3,)."""
        return self._state(t)[..., :3]

    def velocity(self, t: Any) -> np.ndarray:
        """Interpolated Sun velocity [km/s], shape t.shape + (3,)."""
        return self._state(t)[..., 3:]


# ---------------------------------------------------------------------------------------------
# compiled kernels
@jit
def sun_state(d, t):
    """(x, y, z, vx, vy, vz) of the Sun [km, km/s] from a :class:`SunTable`'s kernel data."""
    return _sk.orbit_state(d, t)


@jit
def conical_shadow(rx, ry, rz, sx, sy, sz, re, rs):
    """(ν, g_penumbra, g_umbra) for a satellite at r and the Sun at s (geocentric, km).

    ν ∈ [0, 1] is the visible fraction of the solar disk (Montenbruck & Gill 2000, eqs.
    3.85–3.88); g_penumbra = c − (a + b) and g_umbra = c − (b − a) [rad] are positive in full
    light and outside the umbra, and vanish on the shadow boundaries.
    """
    ux = sx - rx
    uy = sy - ry
    uz = sz - rz
    du = math.sqrt(ux * ux + uy * uy + uz * uz)
    dr = math.sqrt(rx * rx + ry * ry + rz * rz)
    a = math.asin(rs / du)
    b = math.asin(re / dr)
    # c: angle between the directions to the Earth's centre (−r) and to the Sun (u)
    cx = ry * uz - rz * uy
    cy = rz * ux - rx * uz
    cz = rx * uy - ry * ux
    c = math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), -(rx * ux + ry * uy + rz * uz))
    gp = c - (a + b)
    gu = c - (b - a)
    if gp >= 0.0:
        nu = 1.0
    elif gu <= 0.0:
        nu = 0.0
    elif c <= a - b:
        nu = 1.0 - (b * b) / (a * a)
    else:
        x = (c * c + a * a - b * b) / (2.0 * c)
        y = math.sqrt(max(a * a - x * x, 0.0))
        area = (
            a * a * math.acos(min(1.0, max(-1.0, x / a)))
            + b * b * math.acos(min(1.0, max(-1.0, (c - x) / b)))
            - c * y
        )
        nu = 1.0 - area / (math.pi * a * a)
    return nu, gp, gu


@jit
def _shadow_loop(r, s, re, rs, out):
    for i in range(r.shape[0]):
        nu, gp, gu = conical_shadow(r[i, 0], r[i, 1], r[i, 2], s[i, 0], s[i, 1], s[i, 2], re, rs)
        out[i, 0] = nu
        out[i, 1] = gp
        out[i, 2] = gu


def shadow_function(
    r_sat: Any,
    r_sun: Any,
    *,
    earth_radius: float = R_EARTH,
    sun_radius: float = R_SUN,
    margins: bool = False,
) -> Any:
    """Conical shadow function ν (1 in full light, 0 in umbra) of satellites at ``r_sat``.

    Parameters
    ----------
    r_sat, r_sun : array_like, shape (..., 3)
        Geocentric positions of the satellite and the Sun [km], same frame (broadcast).
    earth_radius, sun_radius : float
        Radii [km] (defaults :data:`R_EARTH`, :data:`R_SUN`).
    margins : bool
        Also return the boundary functions (penumbra, umbra) [rad].

    Returns
    -------
    nu : ndarray, shape (...)
        Visible fraction of the solar disk.
    g_penumbra, g_umbra : ndarray, shape (...)
        With ``margins=True``: c − (a + b) and c − (b − a), positive in light.
    """
    r = np.asarray(r_sat, dtype=np.float64)
    s = np.asarray(r_sun, dtype=np.float64)
    if r.shape[-1:] != (3,) or s.shape[-1:] != (3,):
        raise OrbitValueError("r_sat, r_sun: expected positions of shape (..., 3)")
    shape = np.broadcast_shapes(r.shape, s.shape)[:-1]
    # C-ordered writable float64 (a read-only broadcast view compiles the loop again)
    rf = np.require(np.broadcast_to(r, (*shape, 3)).reshape(-1, 3), np.float64, ["C", "W"])
    sf = np.require(np.broadcast_to(s, (*shape, 3)).reshape(-1, 3), np.float64, ["C", "W"])
    out = np.empty((rf.shape[0], 3))
    _shadow_loop(rf, sf, float(earth_radius), float(sun_radius), out)
    out = out.reshape((*shape, 3))
    if margins:
        return out[..., 0], out[..., 1], out[..., 2]
    return out[..., 0]

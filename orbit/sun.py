"""The Sun seen from the Earth: its position in the GCRS and the Earth's shadow.

* :func:`sun_position_gcrs`: the geometric geocentric position of the Sun [km], GCRS axes, from
  astropy's built-in solar-system ephemeris (ERFA ``epv00``, the Earth's heliocentric position
  to within ~5 km, 1900–2100; no file, no network). Geometric: no light time or annual
  aberration (20.5", which moves a shadow boundary by < 0.1 s in LEO; documented, not applied).
* :func:`shadow_fraction`: the fraction ν of the solar disc seen from a satellite, 1 in full
  sunlight, 0 in the umbra, in between in the penumbra — the conical model of Montenbruck &
  Gill (2000), *Satellite Orbits*, Sect. 3.4.2 (p. 81): apparent radii a of the Sun and b of the
  Earth and their apparent separation c, then the area of overlap of two discs. A spherical
  Earth of radius :data:`R_EARTH_KM` (oblateness shifts LEO shadow boundaries by up to ~3 s at
  high latitudes; not modelled). ``model="cylindrical"`` is the cylindrical shadow of the same
  section (no penumbra).
* :func:`shadow_fraction_kernel` / :func:`cylindrical_shadow_kernel`: the same on scalars, for
  compiled right-hand sides (``attitude``'s solar-radiation torque calls them).

Constants: IAU 2012 Resolution B2 astronomical unit, IAU 2015 Resolution B3 nominal solar
radius, WGS 84 equatorial radius.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._shared_jit import jit
from .errors import OrbitTypeError, OrbitValueError

__all__ = [
    "AU_KM",
    "R_EARTH_KM",
    "R_SUN_KM",
    "cylindrical_shadow_kernel",
    "shadow_fraction",
    "shadow_fraction_kernel",
    "sun_position_gcrs",
]

#: Astronomical unit [km] (IAU 2012 Resolution B2, exact).
AU_KM = 149_597_870.7
#: Nominal solar radius [km] (IAU 2015 Resolution B3).
R_SUN_KM = 695_700.0
#: Earth's equatorial radius [km] (WGS 84): the spherical occulting body of the shadow models.
R_EARTH_KM = 6378.137


def _epoch_of(orbit_or_epoch: Any) -> Any:
    from .timescales import as_epoch

    if hasattr(orbit_or_epoch, "kernel_data"):  # an orbit
        epoch = getattr(orbit_or_epoch, "epoch", None)
        if epoch is None:
            raise OrbitValueError(
                "orbit: this orbit has no epoch, so the Sun's position is unknown; build it with "
                "epoch='2024-03-20T12:00:00' (or from a TLE/OEM, which carry one)"
            )
        return epoch
    try:
        return as_epoch(orbit_or_epoch, "epoch", allow_none=False)
    except OrbitTypeError:
        raise OrbitTypeError(
            "orbit_or_epoch: expected an orbit with an epoch, an astropy Time or an ISO 8601 "
            f"string, got {type(orbit_or_epoch).__name__}"
        ) from None


def sun_position_gcrs(orbit_or_epoch: Any, t: Any) -> np.ndarray:
    """Geometric geocentric position of the Sun in GCRS axes [km].

    Parameters
    ----------
    orbit_or_epoch : orbit with an epoch, astropy Time or ISO 8601 string
        The date of t = 0.
    t : float or array_like or Quantity
        Seconds since that date (any shape).

    Returns
    -------
    r_sun : ndarray, shape t.shape + (3,)
        km. From astropy's built-in ephemeris (ERFA ``epv00``), vectorised; the GCRS axes are
        those of the ICRS, so the barycentric difference Sun − Earth is the GCRS vector.
    """
    from astropy import units as u
    from astropy.coordinates import get_body_barycentric
    from astropy.time import TimeDelta

    from .kepler import _as_array
    from .timescales import offline_iers

    epoch = _epoch_of(orbit_or_epoch)
    ta = _as_array(t, "t", "s")
    flat = np.ascontiguousarray(ta, dtype=np.float64).ravel()
    if flat.size and not np.all(np.isfinite(flat)):
        raise OrbitValueError("t: times must be finite")
    times = epoch + TimeDelta(flat, format="sec")
    with offline_iers():
        sun = get_body_barycentric("sun", times, ephemeris="builtin")
        earth = get_body_barycentric("earth", times, ephemeris="builtin")
    r = (sun - earth).xyz.to_value(u.km).T
    return np.ascontiguousarray(r).reshape((*np.shape(ta), 3))


@jit
def shadow_fraction_kernel(rx, ry, rz, sx, sy, sz, r_sun, r_body):
    """Conical shadow ν (Montenbruck & Gill 2000, Sect. 3.4.2) at satellite r, Sun s [km].

    a = asin(R_sun/|s − r|), b = asin(R_body/|r|), c = angle between −r and s − r; ν = 1 for
    c ≥ a + b, 0 for c ≤ b − a, 1 − b²/a² (annular) for c ≤ a − b, else 1 − A/(π a²) with A
    the area of overlap of the two discs. The sunlit and umbra cases are decided on cosines
    (square roots only); trigonometric functions are evaluated in the penumbra only.
    """
    dx = sx - rx
    dy = sy - ry
    dz = sz - rz
    rn = math.sqrt(rx * rx + ry * ry + rz * rz)
    dn = math.sqrt(dx * dx + dy * dy + dz * dz)
    if rn <= r_body:
        return 0.0
    sa = r_sun / dn
    sb = r_body / rn
    ca = math.sqrt(1.0 - sa * sa)
    cb = math.sqrt(1.0 - sb * sb)
    cc = -(rx * dx + ry * dy + rz * dz) / (rn * dn)
    if cc <= ca * cb - sa * sb:  # c >= a + b: no occultation
        return 1.0
    if sb > sa and cc >= cb * ca + sb * sa:  # c <= b - a: umbra
        return 0.0
    a = math.asin(sa)
    b = math.asin(sb)
    c = math.acos(min(1.0, max(-1.0, cc)))
    if c <= a - b:  # the Earth's disc inside the Sun's: annular
        return 1.0 - (b * b) / (a * a)
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = math.sqrt(max(0.0, a * a - x * x))
    area = (
        a * a * math.acos(min(1.0, max(-1.0, x / a)))
        + b * b * math.acos(min(1.0, max(-1.0, (c - x) / b)))
        - c * y
    )
    nu = 1.0 - area / (math.pi * a * a)
    return min(1.0, max(0.0, nu))


@jit
def cylindrical_shadow_kernel(rx, ry, rz, sx, sy, sz, r_body):
    """Cylindrical shadow (Montenbruck & Gill 2000, Sect. 3.4.2): 0 behind the Earth within a
    cylinder of radius R_body along the Sun direction, else 1 (no penumbra)."""
    sn = math.sqrt(sx * sx + sy * sy + sz * sz)
    ux = sx / sn
    uy = sy / sn
    uz = sz / sn
    p = rx * ux + ry * uy + rz * uz
    if p >= 0.0:
        return 1.0
    qx = rx - p * ux
    qy = ry - p * uy
    qz = rz - p * uz
    if qx * qx + qy * qy + qz * qz < r_body * r_body:
        return 0.0
    return 1.0


@jit
def _shadow_loop(r, s, out, conical, r_sun, r_body):
    for i in range(r.shape[0]):
        if conical:
            out[i] = shadow_fraction_kernel(
                r[i, 0], r[i, 1], r[i, 2], s[i, 0], s[i, 1], s[i, 2], r_sun, r_body
            )
        else:
            out[i] = cylindrical_shadow_kernel(
                r[i, 0], r[i, 1], r[i, 2], s[i, 0], s[i, 1], s[i, 2], r_body
            )


def shadow_fraction(
    r_sat: Any,
    r_sun: Any,
    model: str = "conical",
    *,
    r_body: float = R_EARTH_KM,
    r_source: float = R_SUN_KM,
) -> Any:
    """Fraction ν of the solar disc visible from the satellite (1 sunlit … 0 umbra).

    Parameters
    ----------
    r_sat : array_like or Quantity, shape (..., 3)
        Geocentric satellite positions [km] (any frame).
    r_sun : array_like or Quantity, shape (..., 3)
        Geocentric Sun positions [km], same frame (broadcast against ``r_sat``).
    model : {"conical", "cylindrical"}
        Conical with penumbra (Montenbruck & Gill 2000, Sect. 3.4.2) or cylindrical.
    r_body, r_source : float
        Radii [km] of the occulting body (default the WGS 84 equatorial radius) and of the Sun.

    Returns
    -------
    nu : float or ndarray, shape (...)
    """
    from .kepler import _as_array

    if model not in ("conical", "cylindrical"):
        raise OrbitValueError(f"model: expected 'conical' or 'cylindrical', got {model!r}")
    r = _as_array(r_sat, "r_sat", "km")
    s = _as_array(r_sun, "r_sun", "km")
    if r.shape[-1:] != (3,) or s.shape[-1:] != (3,):
        raise OrbitValueError(f"r_sat, r_sun: expected shape (..., 3), got {r.shape} and {s.shape}")
    shape = np.broadcast_shapes(r.shape[:-1], s.shape[:-1])
    rf = np.ascontiguousarray(np.broadcast_to(r, (*shape, 3)).reshape(-1, 3), dtype=np.float64)
    sf = np.ascontiguousarray(np.broadcast_to(s, (*shape, 3)).reshape(-1, 3), dtype=np.float64)
    if not (np.all(np.isfinite(rf)) and np.all(np.isfinite(sf))):
        raise OrbitValueError("r_sat, r_sun: positions must be finite")
    out = np.empty(rf.shape[0])
    _shadow_loop(rf, sf, out, model == "conical", float(r_source), float(r_body))
    return float(out[0]) if shape == () else out.reshape(shape)

"""The Sun seen from the Earth: its position in the GCRS and the Earth's shadow.

This module has the interface of ``orbit/sun.py`` on the ``events`` branch (written in
parallel; the same names, signatures and meaning, so either file serves both branches):

* :func:`sun_position` — the Sun's geocentric position [km] in the GCRS, from astropy
  (``get_body("sun")`` with the built-in ERFA ephemeris, no file, no network): the apparent
  Sun seen from the geocentre (light time and annual aberration included), where the light
  that casts the Earth's shadow and pushes on the spacecraft comes from;
* :func:`conical_shadow` (compiled) and :func:`shadow_function` (vectorised) — the conical
  shadow of a spherical Earth, Montenbruck & Gill, *Satellite Orbits* (2000), Sect. 3.4.2:
  seen from the satellite, the Sun's disc (apparent radius a = asin(R☉/|s − r|)) and the
  Earth's disc (b = asin(R⊕/|r|)) are an angle c apart (between −r and s − r); ν = 1 for
  c ≥ a + b, 0 for c ≤ b − a (umbra), 1 − b²/a² for c ≤ a − b (annular), else the visible
  fraction of the solar disc, 1 − A/(π a²) with A the area of overlap of the two discs.
  The boundary functions c − (a + b) (penumbra) and c − (b − a) (umbra) are smooth in time
  and positive in light; their roots are the eclipse entry and exit times.

Radii: R⊕ = 6378.137 km (WGS 84 equatorial; the Earth is a sphere here, its oblateness moves
LEO shadow boundaries by ~1–3 s) and R☉ = 695 700 km (IAU 2015 Resolution B3 nominal solar
radius).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ._shared_jit import jit
from .errors import OrbitValueError
from .timescales import as_epoch, offline_iers

__all__ = [
    "R_EARTH",
    "R_SUN",
    "conical_shadow",
    "shadow_function",
    "sun_position",
]

#: Earth radius for the shadow [km] (WGS 84 equatorial).
R_EARTH = 6378.137
#: Solar radius [km] (IAU 2015 Resolution B3 nominal value).
R_SUN = 695700.0


def sun_position(epoch: Any, t: Any) -> np.ndarray:
    """Geocentric position of the (apparent) Sun in the GCRS [km], from astropy, vectorised.

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
    from astropy.time import Time, TimeDelta

    ep = as_epoch(epoch, "epoch", allow_none=False)
    if isinstance(t, Time):
        times = t.reshape(-1)
        shape = t.shape
    else:
        tt = np.asarray(getattr(t, "to_value", lambda unit: t)("s"), dtype=np.float64)
        if tt.size and not np.all(np.isfinite(tt)):
            raise OrbitValueError("t: times must be finite")
        times = ep + TimeDelta(tt.ravel(), format="sec")
        shape = tt.shape
    with offline_iers():
        s = get_body("sun", times, ephemeris="builtin")
        xyz = s.cartesian.xyz.to_value(u.km).T
    return np.ascontiguousarray(xyz).reshape((*shape, 3))


@jit
def conical_shadow(rx, ry, rz, sx, sy, sz, re, rs):
    """(ν, g_penumbra, g_umbra) for a satellite at r and the Sun at s (geocentric, km).

    ν ∈ [0, 1] is the visible fraction of the solar disc (Montenbruck & Gill 2000, Sect.
    3.4.2); g_penumbra = c − (a + b) and g_umbra = c − (b − a) [rad] are positive in full light
    and outside the umbra, and vanish on the shadow boundaries. ``re``, ``rs``: the radii of
    the Earth and of the Sun [km].
    """
    ux = sx - rx
    uy = sy - ry
    uz = sz - rz
    du = math.sqrt(ux * ux + uy * uy + uz * uz)
    dr = math.sqrt(rx * rx + ry * ry + rz * rz)
    a = math.asin(rs / du)
    b = math.asin(min(1.0, re / dr))
    # c from atan2(|r × u|, −r·u): accurate at every angle
    cx = ry * uz - rz * uy
    cy = rz * ux - rx * uz
    cz = rx * uy - ry * ux
    c = math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), -(rx * ux + ry * uy + rz * uz))
    gp = c - (a + b)
    gu = c - (b - a)
    if gp >= 0.0:
        return 1.0, gp, gu
    if gu <= 0.0:
        return 0.0, gp, gu
    if c <= a - b:  # the Earth's disc inside the Sun's
        return 1.0 - (b * b) / (a * a), gp, gu
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = math.sqrt(max(0.0, a * a - x * x))
    area = (
        a * a * math.acos(min(1.0, max(-1.0, x / a)))
        + b * b * math.acos(min(1.0, max(-1.0, (c - x) / b)))
        - c * y
    )
    return min(1.0, max(0.0, 1.0 - area / (math.pi * a * a))), gp, gu


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
    """Conical shadow function ν (1 in full light, 0 in the umbra) of satellites at ``r_sat``.

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
        Visible fraction of the solar disc.
    g_penumbra, g_umbra : ndarray, shape (...)
        With ``margins=True``: c − (a + b) and c − (b − a), positive in light.
    """
    r = np.asarray(getattr(r_sat, "to_value", lambda unit: r_sat)("km"), dtype=np.float64)
    s = np.asarray(getattr(r_sun, "to_value", lambda unit: r_sun)("km"), dtype=np.float64)
    if r.shape[-1:] != (3,) or s.shape[-1:] != (3,):
        raise OrbitValueError("r_sat, r_sun: expected positions of shape (..., 3)")
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(s))):
        raise OrbitValueError("r_sat, r_sun: positions must be finite")
    shape = np.broadcast_shapes(r.shape, s.shape)[:-1]
    rf = np.ascontiguousarray(np.broadcast_to(r, (*shape, 3)).reshape(-1, 3))
    sf = np.ascontiguousarray(np.broadcast_to(s, (*shape, 3)).reshape(-1, 3))
    out = np.empty((rf.shape[0], 3))
    _shadow_loop(rf, sf, float(earth_radius), float(sun_radius), out)
    out = out.reshape((*shape, 3))
    if margins:
        return out[..., 0], out[..., 1], out[..., 2]
    return out[..., 0]

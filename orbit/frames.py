"""Frame conversions of orbit states, all through astropy/ERFA (vectorised, outside hot loops).

* The space frame of an orbit with an epoch is the **GCRS** (geocentric celestial reference
  system, axes of the ICRS). EME2000 (mean equator and equinox of J2000.0, the frame of most
  flight-dynamics products) differs from it by the constant IAU 2000 *frame bias*, a rotation of
  about 23 mas (ξ0 = −16.6 mas, η0 = −6.8 mas, dα0 = −14.6 mas; IERS Conventions 2010,
  Sect. 5.5.1): 0.8 m at 7000 km. :func:`eme2000_to_gcrs` applies it (ERFA ``bp06``).
* TEME (the frame of SGP4 output) → GCRS: astropy's ``TEME`` → ``GCRS`` transformation
  (:func:`teme_to_gcrs`), never by hand; for long tables its rotation every hour, interpolated
  between (:func:`teme_to_gcrs_matrix`).
* GCRS → ITRS (Earth-fixed) and WGS 84 geodetic coordinates: astropy, with the IERS policy of
  :mod:`orbit.timescales` (bundled tables, no network).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from .timescales import check_iers_range, offline_iers

__all__ = [
    "eme2000_to_gcrs",
    "frame_bias",
    "gcrs_to_itrs",
    "gcrs_to_itrs_matrix",
    "geodetic_from_itrs",
    "itrs_from_geodetic",
    "itrs_to_gcrs",
    "teme_to_gcrs",
    "teme_to_gcrs_matrix",
    "teme_to_gcrs_positions",
]


@lru_cache(maxsize=1)
def _frame_bias() -> np.ndarray:
    """The IAU 2006 frame-bias matrix B (x_EME2000 = B x_GCRS), from ERFA ``bp06``."""
    import erfa

    rb, _, _ = erfa.bp06(2451545.0, 0.0)  # B is constant; any date
    return np.array(rb, dtype=np.float64)


def frame_bias() -> np.ndarray:
    """The IAU 2006 frame-bias matrix B, shape (3, 3): x_EME2000 = B x_GCRS (a copy)."""
    return _frame_bias().copy()


def eme2000_to_gcrs(x: np.ndarray) -> np.ndarray:
    """Rotate vectors (..., 3) from EME2000 (J2000 mean equator/equinox) to GCRS axes."""
    return np.asarray(x, dtype=np.float64) @ _frame_bias()  # Bᵀ x, row vectors


def gcrs_to_eme2000(x: np.ndarray) -> np.ndarray:
    """Rotate vectors (..., 3) from GCRS to EME2000 axes (inverse of :func:`eme2000_to_gcrs`)."""
    return np.asarray(x, dtype=np.float64) @ _frame_bias().T


def teme_to_gcrs(times: Any, r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """TEME position [km] and velocity [km/s], shape (n, 3), at ``times`` → GCRS (astropy).

    The TEME → GCRS chain (through ITRS and CIRS) uses UT1 and polar motion twice with opposite
    effect (GMST82 and the Earth rotation angle advance with UT1 at rates equal to 1e-7), so a
    UT1 error of 1 s changes the result by ~1e-11 rad: no IERS range warning is given for it.
    """
    from astropy import units as u
    from astropy.coordinates import (
        GCRS,
        TEME,
        CartesianDifferential,
        CartesianRepresentation,
    )

    rep = CartesianRepresentation(
        np.asarray(r).T * u.km,
        differentials=CartesianDifferential(np.asarray(v).T * (u.km / u.s)),
    )
    with offline_iers():
        g = TEME(rep, obstime=times).transform_to(GCRS(obstime=times))
        cr = g.cartesian
        rg = cr.xyz.to_value(u.km).T
        vg = cr.differentials["s"].d_xyz.to_value(u.km / u.s).T
    return np.ascontiguousarray(rg), np.ascontiguousarray(vg)


def teme_to_gcrs_positions(times: Any, r: np.ndarray, step: float | None = None) -> np.ndarray:
    """TEME positions [km], shape (n, 3), at ``times`` → GCRS positions [km] (astropy).

    With ``step`` [s], astropy's rotation every ``step`` seconds, interpolated between
    (:func:`teme_to_gcrs_matrix`)."""
    if step is not None:
        m = teme_to_gcrs_matrix(times, step=step)
        return np.ascontiguousarray(np.einsum("nij,nj->ni", m, np.asarray(r, dtype=np.float64)))
    from astropy import units as u
    from astropy.coordinates import GCRS, TEME, CartesianRepresentation

    rep = CartesianRepresentation(np.asarray(r).T * u.km)
    with offline_iers():
        g = TEME(rep, obstime=times).transform_to(GCRS(obstime=times))
        return np.ascontiguousarray(g.cartesian.xyz.to_value(u.km).T)


def teme_to_gcrs_matrix(times: Any, step: float | None = None) -> np.ndarray:
    """Rotation matrices R(t), shape (n, 3, 3), with x_GCRS = R x_TEME (astropy).

    For positions astropy's TEME → GCRS chain (ITRS, CIRS) is a rotation: GMST82 and the Earth
    rotation angle turn by the same angle to 1e-7 of a day's turn, so what is left, precession,
    nutation and the equation of the equinoxes, changes over days. With ``step`` [s] astropy
    gives R every ``step`` seconds only, interpolated between (degree-7 Lagrange): 1.1e-13 rad
    from astropy's at every time over a day for steps of 600 to 7200 s (0.8 µm at 7000 km;
    tests/test_time_frames.py), 50 times faster for a day's TLE table at 60 s.
    """
    from astropy.coordinates import GCRS, TEME

    t1 = times.reshape(-1)
    return _interpolated(t1, step, lambda t: _astropy_matrix(t, TEME, GCRS), earth_rotation=False)


def gcrs_to_itrs(times: Any, r: np.ndarray, name: str = "t") -> np.ndarray:
    """GCRS positions [km], shape (n, 3), at ``times`` → ITRS (Earth-fixed) positions [km]."""
    from astropy import units as u
    from astropy.coordinates import GCRS, ITRS, CartesianRepresentation

    check_iers_range(times, name)
    rep = CartesianRepresentation(np.asarray(r).T * u.km)
    with offline_iers():
        it = GCRS(rep, obstime=times).transform_to(ITRS(obstime=times))
        return np.ascontiguousarray(it.cartesian.xyz.to_value(u.km).T)


def _astropy_matrix(times: Any, source: Any, target: Any) -> np.ndarray:
    """R(t) of astropy's geocentric ``source`` → ``target`` frame rotation (x_target = R
    x_source): the images of two axis vectors (the third is their cross product)."""
    from astropy import units as u
    from astropy.coordinates import CartesianRepresentation
    from astropy.time import Time

    t1 = times.reshape(-1)
    n = len(t1)
    tt = Time(np.concatenate([t1.jd1] * 2), np.concatenate([t1.jd2] * 2), format="jd",
              scale=t1.scale)  # fmt: skip
    axes = np.repeat(np.eye(3)[:2], n, axis=0)  # (2n, 3): e1 × n, then e2 × n
    rep = CartesianRepresentation(axes.T * u.km)
    with offline_iers():
        it = source(rep, obstime=tt).transform_to(target(obstime=tt))
        cols = it.cartesian.xyz.to_value(u.km).T.reshape(2, n, 3)  # [axis j, time, comp]
    c1, c2 = cols[0], cols[1]
    out = np.empty((n, 3, 3))
    out[:, :, 0] = c1
    out[:, :, 1] = c2
    out[:, :, 2] = np.cross(c1, c2)
    return out


def _astropy_gcrs_to_itrs_matrix(times: Any) -> np.ndarray:
    """R(t), x_ITRS = R x_GCRS, from astropy at every time."""
    from astropy.coordinates import GCRS, ITRS

    return _astropy_matrix(times, GCRS, ITRS)


def _earth_rotation_angle(times: Any) -> np.ndarray:
    """ERA(UT1) [rad] (IAU 2000, ERFA ``era00``), UT1 from the IERS table of our policy."""
    import erfa

    with offline_iers():
        ut1 = times.reshape(-1).ut1
        return np.asarray(erfa.era00(ut1.jd1, ut1.jd2), dtype=np.float64)


def _spin(theta: np.ndarray) -> np.ndarray:
    """R3(θ) (n, 3, 3): the rotation of the Earth by its rotation angle, CIRS → TIRS."""
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros((theta.size, 3, 3))
    out[:, 0, 0] = c
    out[:, 0, 1] = s
    out[:, 1, 0] = -s
    out[:, 1, 1] = c
    out[:, 2, 2] = 1.0
    return out


def _lagrange8(tc: np.ndarray, yc: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Degree-7 Lagrange interpolation of rows ``yc`` at uniform nodes ``tc`` to times ``t``."""
    h = tc[1] - tc[0]
    i = np.clip(np.floor((t - tc[0]) / h).astype(np.int64), 0, tc.size - 2)
    j0 = np.clip(i - 3, 0, tc.size - 8)
    x = (t - tc[j0]) / h
    out = np.zeros((t.size, *yc.shape[1:]))
    for j in range(8):
        w = np.ones_like(x)
        for k in range(8):
            if k != j:
                w *= (x - k) / (j - k)
        out += w.reshape(-1, *([1] * (yc.ndim - 1))) * yc[j0 + j]
    return out


def gcrs_to_itrs_matrix(times: Any, name: str = "t", step: float | None = None) -> np.ndarray:
    """Rotation matrices R(t), shape (n, 3, 3), with x_ITRS = R x_GCRS (astropy, IERS policy).

    The geocentric GCRS → ITRS transformation of astropy is a rotation (precession-nutation,
    Earth rotation angle, polar motion); R is obtained by transforming two axis vectors (the
    third column is their cross product), so it is what :func:`gcrs_to_itrs` applies (to
    round-off), for rotating free vectors such as a magnetic field or a velocity between the
    frames. Cost: ~0.3 ms per time (the IAU 2000A nutation series is evaluated per time).

    With ``step`` [s], astropy gives R every ``step`` seconds only, and between those nodes
    R(t) = R3(θ(t)) M(t): the Earth rotation angle θ (ERFA ``era00`` of UT1, exact at every
    time) is factored out, and M = R3(θ)ᵀ R, which changes only with precession-nutation and
    the diurnal turn of polar motion, is interpolated (degree-7 Lagrange). At step = 600 s the
    difference from astropy at every time is 2e-12 rad (0.01 mm at 7000 km; measured over a
    day, tests/test_environment.py), 25 times faster for a day at 30 s.
    """
    check_iers_range(times, name)
    return _interpolated(times.reshape(-1), step, _astropy_gcrs_to_itrs_matrix, earth_rotation=True)


def _interpolated(t1: Any, step: float | None, exact: Any, earth_rotation: bool) -> np.ndarray:
    """``exact(times)`` (n, 3, 3) at every time, or with ``step`` at nodes ``step`` apart and
    interpolated between (degree-7 Lagrange); ``earth_rotation``: R = R3(θ) M with the Earth
    rotation angle θ exact at every time and M interpolated."""
    n = len(t1)
    if step is None or n < 64:
        return exact(t1)
    from astropy.time import TimeDelta

    sec = np.asarray((t1 - t1[0]).sec, dtype=np.float64)
    lo, hi = float(sec.min()), float(sec.max())
    nc = max(8, int(np.ceil((hi - lo) / step)) + 9)
    tc = lo - 4.0 * step + step * np.arange(nc, dtype=np.float64)
    if tc.size >= n:
        return exact(t1)
    coarse = t1[0] + TimeDelta(tc, format="sec")
    rc = exact(coarse)
    if not earth_rotation:
        return _lagrange8(tc, rc, sec)
    mc = np.einsum("nji,njk->nik", _spin(_earth_rotation_angle(coarse)), rc)  # R3ᵀ R
    m = _lagrange8(tc, mc, sec)
    return np.einsum("nij,njk->nik", _spin(_earth_rotation_angle(t1)), m)


def geodetic_from_itrs(r_itrs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """WGS 84 geodetic latitude [rad], longitude [rad] in (−π, π] and height [km]."""
    from astropy import units as u
    from astropy.coordinates import EarthLocation

    r = np.asarray(r_itrs, dtype=np.float64)
    loc = EarthLocation.from_geocentric(r[..., 0], r[..., 1], r[..., 2], unit=u.km)
    g = loc.to_geodetic("WGS84")
    return (
        np.asarray(g.lat.to_value(u.rad), dtype=np.float64),
        np.asarray(g.lon.wrap_at(180 * u.deg).to_value(u.rad), dtype=np.float64),
        np.asarray(g.height.to_value(u.km), dtype=np.float64),
    )


def itrs_to_gcrs(times: Any, r: np.ndarray, name: str = "t") -> np.ndarray:
    """ITRS (Earth-fixed) positions [km], shape (n, 3) or (3,), at ``times`` → GCRS [km].

    astropy ITRS → GCRS (IAU 2006/2000A, CIO based) with the IERS policy of
    :mod:`orbit.timescales`; the inverse of :func:`gcrs_to_itrs`.
    """
    from astropy import units as u
    from astropy.coordinates import GCRS, ITRS, CartesianRepresentation

    check_iers_range(times, name)
    rr = np.asarray(r, dtype=np.float64)
    if rr.ndim == 1:
        rr = np.broadcast_to(rr, (np.size(times.jd1), 3))
    rep = CartesianRepresentation(np.asarray(rr).T * u.km)
    with offline_iers():
        g = ITRS(rep, obstime=times).transform_to(GCRS(obstime=times))
        return np.ascontiguousarray(g.cartesian.xyz.to_value(u.km).T)


def itrs_from_geodetic(latitude: Any, longitude: Any, height: Any = 0.0) -> np.ndarray:
    """ITRS position [km] of WGS 84 geodetic latitude, longitude [rad] and height [km]."""
    from astropy import units as u
    from astropy.coordinates import EarthLocation

    loc = EarthLocation.from_geodetic(
        np.asarray(longitude) * u.rad,
        np.asarray(latitude) * u.rad,
        np.asarray(height) * u.km,
        ellipsoid="WGS84",
    )
    return np.stack([c.to_value(u.km) for c in loc.to_geocentric()], axis=-1)

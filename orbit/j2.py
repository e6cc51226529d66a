"""Kepler motion with the first-order secular J2 drift of Ω, ω and M: :class:`SecularJ2Orbit`.

Mean elements a, e, i are constant; the node, the argument of periapsis and the mean anomaly
drift linearly (first-order secular theory of the Earth's oblateness; Vallado, *Fundamentals of
Astrodynamics and Applications*, 4th ed. 2013, Ch. 9, secular J2 effects; Montenbruck & Gill,
*Satellite Orbits* 2000, Ch. 3, the secular perturbations of the oblateness). With n = √(μ/a³),
p = a (1 − e²), η = √(1 − e²) and k = J2 (R/p)²::

    dΩ/dt = −(3/2) n k cos i
    dω/dt =  (3/4) n k (5 cos² i − 1)
    dM/dt =  n [1 + (3/4) k η (3 cos² i − 1)]          (= n̄, the anomalistic mean motion)

The position at t is that of the Keplerian ellipse (a, e, i, Ω(t), ω(t)) at mean anomaly M(t):
no short-period terms, so it is a *mean* orbit (positions differ from an osculating
propagation by the J2 short-period terms, ~10 km in LEO); what it gets right is the secular
motion of the orbital plane (sun-synchronism, nodal regression) that matters over days. The
velocity is the exact time derivative of that position (the in-plane motion at rate n̄ plus
Ω̇ ẑ × r + ω̇ ĥ × r), so position and velocity are consistent (interpolation, finite
differences).

Default constants: R = 6378.137 km, the WGS 84 semi-major axis, and J2 = 1.08263e-3 =
−√5 C̄2,0 with the WGS 84 ellipsoid's C̄2,0 = −0.484166774985e-3 (NIMA TR8350.2, 3rd ed.,
2000, Ch. 3); μ = astropy's GM_earth (398600.4 km³/s², the IAU 2015 nominal value).

A sun-synchronous orbit has dΩ/dt = 360°/365.2422 d (one revolution per tropical year);
tests/test_j2.py checks it for an inclination solved from the formula independently.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _kernels as _k
from . import _state_kernels as _sk
from .base import OrbitBase
from .errors import OrbitValueError
from .keplerorbit import ClassicalElements, KeplerOrbit, _scalar

__all__ = [
    "EARTH_J2",
    "EARTH_RADIUS",
    "SecularJ2Orbit",
    "energy_semi_major_axis",
    "j2_secular_rates",
]

#: Earth's J2 (WGS 84, NIMA TR8350.2 3rd ed. 2000).
EARTH_J2 = 1.08263e-3
#: Largest J2 accepted: the first-order secular rates are meaningless for a large J2 (and
#: 2**63 gave NaN positions).
MAX_J2 = 0.1
#: Earth's equatorial radius [km] (WGS 84 semi-major axis).
EARTH_RADIUS = 6378.137


def energy_semi_major_axis(
    r: Any, v: Any, mu: float, j2: float = 0.0, radius: float = EARTH_RADIUS
) -> np.ndarray:
    """The semi-major axis of the orbital energy in a point mass and its J2, a = −μ/(2ε).

    ε = v²/2 − μ/r + μ J2 R² P₂(z/r)/r³ (P₂(x) = (3x² − 1)/2, z along the pole): constant in an
    axisymmetric field, it moves only with thrust, drag and the field's smaller terms, where the
    osculating two-body a swings by ~±10 km over each LEO orbit with J2. It is not the mean
    elements' a (they differ by a constant of order J2).

    Parameters
    ----------
    r, v : array_like, shape (..., 3) [km, km/s]
        Positions and velocities, z along the Earth's pole (the GCRS to ~0.3°: the term's
        error then stays below ~1 % of its ±10 km).
    mu : float [km³/s²]
    j2 : float
        The field's J2 (0: the two-body a).
    radius : float [km]
        The field's reference radius.

    Returns
    -------
    ndarray, shape (...) [km]
    """
    r = np.asarray(r, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    rn = np.linalg.norm(r, axis=-1)
    s = r[..., 2] / rn
    eps = 0.5 * np.sum(v * v, axis=-1) - mu / rn + mu * j2 * radius**2 * (1.5 * s * s - 0.5) / rn**3
    return -mu / (2.0 * eps)


def j2_secular_rates(a: float, e: float, inc: float, mu: float, j2: float, radius: float):
    """(dΩ/dt, dω/dt, dM/dt) [rad/s] of the first-order secular J2 theory (module docstring)."""
    n = math.sqrt(mu / a**3)
    p = a * (1.0 - e) * (1.0 + e)
    eta = math.sqrt((1.0 - e) * (1.0 + e))
    k = j2 * (radius / p) ** 2
    c = math.cos(inc)
    raan_dot = -1.5 * n * k * c
    argp_dot = 0.75 * n * k * (5.0 * c * c - 1.0)
    m_dot = n * (1.0 + 0.75 * k * eta * (3.0 * c * c - 1.0))
    return raan_dot, argp_dot, m_dot


class SecularJ2Orbit(ClassicalElements, OrbitBase):
    """Kepler motion with the first-order secular J2 drift of Ω, ω and M (mean elements).

    Parameters
    ----------
    a : float or Quantity [km]
        Mean semi-major axis, a > 0 (elliptic orbits only).
    e : float
        Mean eccentricity, 0 <= e < 1.
    inc, raan, argp : float or Quantity [rad]
        Mean inclination, and Ω, ω at ``t0``.
    f0 : float or Quantity [rad]
        True anomaly at ``t0`` (default 0).
    epoch : astropy Time or str, optional
        Date of t = 0 (UTC unless a scale is given); the space frame is then the GCRS.
    mu : float or Quantity [km³/s²], optional
        Default astropy's GM_earth.
    j2 : float, optional
        Default 1.08263e-3 (WGS 84).
    radius : float or Quantity [km], optional
        Equatorial radius of the J2 term, default 6378.137 km (WGS 84).
    t0 : float or Quantity [s], keyword-only
        Time of the elements (seconds since the epoch), default 0.
    M0 : float or Quantity [rad], keyword-only
        Mean anomaly at ``t0`` instead of ``f0``.

    Raises
    ------
    OrbitValueError
        The element checks of :class:`KeplerOrbit`, e >= 1, j2 outside [0, MAX_J2 = 0.1] or
        not finite, radius <= 0.
    """

    def __init__(
        self,
        a: Any,
        e: Any,
        inc: Any,
        raan: Any,
        argp: Any,
        f0: Any = None,
        epoch: Any = None,
        mu: Any = None,
        j2: Any = None,
        radius: Any = None,
        *,
        t0: Any = 0.0,
        M0: Any = None,
    ) -> None:
        kep = KeplerOrbit(a, e, inc, raan, argp, f0=f0, mu=mu, t0=t0, M0=M0, epoch=epoch)
        if kep.is_hyperbolic:
            raise OrbitValueError(
                f"e: SecularJ2Orbit is for closed orbits (e < 1), got e = {kep.e!r}"
            )
        j2_ = EARTH_J2 if j2 is None else _scalar(j2, "j2", None)
        rad = EARTH_RADIUS if radius is None else _scalar(radius, "radius", "km")
        if not 0.0 < rad < math.inf:
            raise OrbitValueError(f"radius: equatorial radius must be > 0 km, got {rad!r}")
        if not (math.isfinite(j2_) and 0.0 <= j2_ <= MAX_J2):
            raise OrbitValueError(
                f"j2: must be a number in [0, {MAX_J2:g}] (first-order secular theory is for a "
                f"small J2: the Earth's is 1.0826e-3, Saturn's 1.6e-2), got {j2_!r}"
            )
        if not (math.isfinite(rad) and rad > 0.0):
            raise OrbitValueError(f"radius: equatorial radius must be > 0 km, got {rad!r}")
        self._kep = kep
        self._epoch = kep.epoch
        self._j2 = j2_
        self._radius = rad
        raan_dot, argp_dot, m_dot = j2_secular_rates(kep.a, kep.e, kep.inc, kep.mu, j2_, rad)
        el = kep.kernel_elements()
        el[_k.N] = m_dot
        el.setflags(write=False)
        self._el = el
        d = np.empty(_sk.J_LEN, dtype=np.float64)
        d[_sk.TYPE] = _sk.TYPE_SECULAR_J2
        d[_sk.MU] = kep.mu
        d[_sk.T_MIN] = -math.inf
        d[_sk.T_MAX] = math.inf
        d[_sk.J_EL : _sk.J_EL + _k.NEL] = el
        d[_sk.J_RAAN_DOT] = raan_dot
        d[_sk.J_ARGP_DOT] = argp_dot
        d[_sk.J_RATIO] = m_dot / kep.mean_motion
        d[_sk.J_COSI] = math.cos(kep.inc)
        d[_sk.J_SINI] = math.sin(kep.inc)
        self._set_data(d)

    # -- the orbits users type most -------------------------------------------------------------
    @classmethod
    def circular(
        cls,
        altitude: Any,
        inc: Any,
        raan: Any = 0.0,
        arg_lat: Any = 0.0,
        *,
        epoch: Any = None,
        mu: Any = None,
        j2: Any = None,
        radius: Any = None,
        t0: Any = 0.0,
    ) -> SecularJ2Orbit:
        """The circular (mean) orbit ``altitude`` km above the equatorial radius ``radius``.

        a = radius + altitude (default radius 6378.137 km); e = 0, ω = 0 and the argument of
        latitude ``arg_lat`` (default 0: at the ascending node) at ``t0``. The other
        parameters are those of :class:`SecularJ2Orbit`; altitude <= 0 is refused
        (:class:`OrbitValueError`).
        """
        from ._constructors import circular_radius

        rad = EARTH_RADIUS if radius is None else _scalar(radius, "radius", "km")
        if not 0.0 < rad < math.inf:
            raise OrbitValueError(f"radius: equatorial radius must be > 0 km, got {rad!r}")
        a = circular_radius(altitude, rad)
        u = _scalar(arg_lat, "arg_lat", "rad")
        return cls(a, 0.0, inc, raan, 0.0, f0=u, epoch=epoch, mu=mu, j2=j2, radius=rad, t0=t0)

    @classmethod
    def sun_synchronous(
        cls,
        altitude: Any,
        local_time_of_node: Any,
        epoch: Any,
        *,
        arg_lat: Any = 0.0,
        mu: Any = None,
        j2: Any = None,
        radius: Any = None,
    ) -> SecularJ2Orbit:
        """The circular sun-synchronous orbit at ``altitude`` whose ascending node is at mean
        local solar time ``local_time_of_node`` at ``epoch``.

        Parameters
        ----------
        altitude : float or Quantity [km]
            Height above the equatorial radius, > 0 and below the highest sun-synchronous
            circular orbit (about 5970 km for the Earth).
        local_time_of_node : str, float or Quantity
            Mean local solar time of the **ascending** node: ``"10:30"``, ``"22:30:00"`` or
            hours (10.5). A "10:30 descending node" orbit has its ascending node at 22:30.
        epoch : astropy Time or str
            The date of t = 0 (required: the node is placed relative to the Sun).
        arg_lat : float or Quantity [rad], optional
            Argument of latitude at t = 0 (default 0: at the ascending node).
        mu, j2, radius :
            As for :class:`SecularJ2Orbit` (defaults: the Earth's); j2 must be > 0.

        Returns
        -------
        SecularJ2Orbit
            With Ω̇ = 2π / 365.2421897 d (the mean Sun's rate), so the node keeps its local
            time; :meth:`local_time_of_node` gives it back.

        Raises
        ------
        OrbitValueError
            altitude <= 0 or too high (cos i < −1), an unreadable or out-of-range local time,
            no epoch, j2 <= 0.

        Notes
        -----
        cos i = −(2/3) (dΩ/dt)_ss a^(7/2) / (J2 R² √μ) (the secular J2 node rate for e = 0),
        and Ω = ERA(epoch) + 15°/h (LTAN − UT1 hours): the node's longitude is its mean local
        time (:mod:`orbit._constructors`; docs/orbit.md).

        Examples
        --------
        >>> o = SecularJ2Orbit.sun_synchronous(800.0, "10:30", "2024-03-20T12:00:00")
        >>> round(math.degrees(o.inc), 2)
        98.6
        """
        from . import _constructors as c
        from .keplerorbit import earth_mu
        from .timescales import as_epoch

        ep = as_epoch(epoch, "epoch", allow_none=False)
        lt = c.local_time_hours(local_time_of_node)
        rad = EARTH_RADIUS if radius is None else _scalar(radius, "radius", "km")
        if not 0.0 < rad < math.inf:
            raise OrbitValueError(f"radius: equatorial radius must be > 0 km, got {rad!r}")
        j2_ = EARTH_J2 if j2 is None else _scalar(j2, "j2", None)
        if not j2_ > 0.0:
            raise OrbitValueError(
                f"j2: a sun-synchronous orbit needs the J2 drift of the node (j2 > 0), got {j2_!r}"
            )
        mu_ = earth_mu() if mu is None else _scalar(mu, "mu", "km3 / s2")
        if not mu_ > 0.0:
            raise OrbitValueError(f"mu: gravitational parameter must be > 0 km³/s², got {mu_!r}")
        a = c.circular_radius(altitude, rad)
        inc = c.sun_synchronous_inclination(a, mu_, j2_, rad)
        raan = c.raan_from_local_time(lt, ep)
        u = _scalar(arg_lat, "arg_lat", "rad")
        return cls(a, 0.0, inc, raan, 0.0, f0=u, epoch=ep, mu=mu_, j2=j2_, radius=rad)

    def local_time_of_node(self, t: Any = 0.0) -> float:
        """Mean local solar time [h, in [0, 24)] of the ascending node at time ``t`` [s since
        the epoch]: UT1 + λ/15°/h at the node's longitude λ (:mod:`orbit._constructors`).

        Raises :class:`OrbitValueError` for an orbit without an epoch.
        """
        from ._constructors import local_time_of_node

        if self._epoch is None:
            raise OrbitValueError(
                "epoch: the local time of the node needs a date; give the orbit an epoch"
            )
        ts = _scalar(t, "t", "s")
        from astropy import units as u

        return local_time_of_node(float(self.raan_at(ts)), self._epoch + ts * u.s)

    # -- elements (ClassicalElements: a, e, inc, raan, argp, M0, t0) and rates ------------------
    @property
    def j2(self) -> float:
        """J2 used."""
        return self._j2

    @property
    def equatorial_radius(self) -> float:
        """Equatorial radius R of the J2 term [km]."""
        return self._radius

    @property
    def raan_rate(self) -> float:
        """dΩ/dt [rad/s]."""
        return float(self._data[_sk.J_RAAN_DOT])

    @property
    def argp_rate(self) -> float:
        """dω/dt [rad/s]."""
        return float(self._data[_sk.J_ARGP_DOT])

    @property
    def mean_motion(self) -> float:
        """dM/dt = n̄ [rad/s] (anomalistic mean motion, J2 included)."""
        return float(self._el[_k.N])

    @property
    def keplerian_mean_motion(self) -> float:
        """n = √(μ/a³) [rad/s]."""
        return self._kep.mean_motion

    @property
    def period(self) -> float:
        """Anomalistic period 2π/n̄ [s] (periapsis to periapsis)."""
        return 2.0 * math.pi / self.mean_motion

    @property
    def nodal_period(self) -> float:
        """Draconic period 2π/(n̄ + ω̇) [s] (node to node)."""
        return 2.0 * math.pi / (self.mean_motion + self.argp_rate)

    @property
    def source(self) -> str:
        return (
            f"secular J2 (a = {self.a!r} km, e = {self.e!r}, J2 = {self.j2!r}, "
            f"R = {self.equatorial_radius!r} km)"
        )

    def _angle_rates(self) -> tuple[float, float, float]:
        return self.raan_rate, self.argp_rate, self.mean_motion

    def raan_at(self, t: Any) -> Any:
        """Ω(t) = Ω0 + Ω̇ (t − t0) [rad], not wrapped."""
        flat, shape = self._seconds(t, "t")
        return self._shape(self.raan + self.raan_rate * (flat - self.t0), shape)

    def argp_at(self, t: Any) -> Any:
        """ω(t) = ω0 + ω̇ (t − t0) [rad], not wrapped."""
        flat, shape = self._seconds(t, "t")
        return self._shape(self.argp + self.argp_rate * (flat - self.t0), shape)

    def mean_anomaly(self, t: Any) -> Any:
        """M(t) = M0 + n̄ (t − t0) [rad], not wrapped."""
        flat, shape = self._seconds(t, "t")
        return self._shape(self.M0 + self.mean_motion * (flat - self.t0), shape)

    def true_anomaly(self, t: Any) -> Any:
        """True anomaly of the mean ellipse [rad], continuous in t (not wrapped)."""
        flat, shape = self._seconds(t, "t")
        out = np.empty(flat.size)
        _k.true_anomaly_loop(self._el, flat, out)
        return self._shape(out, shape)

    def __repr__(self) -> str:
        ep = "" if self._epoch is None else f", epoch={self._epoch.utc.isot!r}"
        return (
            f"SecularJ2Orbit(a={self.a!r}, e={self.e!r}, inc={self.inc!r}, raan={self.raan!r}, "
            f"argp={self.argp!r}, M0={self.M0!r}, mu={self.mu!r}, j2={self.j2!r}, "
            f"radius={self.equatorial_radius!r}, t0={self.t0!r}{ep})  # km, rad, s"
        )

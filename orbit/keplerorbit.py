"""Keplerian (two-body) orbits: :class:`KeplerOrbit`.

Units: km, s, rad and km³/s² inside; astropy Quantities of any compatible units are accepted
and converted once, in the constructor (times in the methods are converted on entry). All
outputs are plain float64 arrays in km, km/s, rad.

The computations run in the compiled kernels of :mod:`orbit._kernels` on the element array
returned by :meth:`KeplerOrbit.kernel_elements`, the same ones the attitude integrators call
inside their right-hand sides.
"""

from __future__ import annotations

import math
import warnings
from functools import lru_cache
from typing import Any

import numpy as np

from . import _kernels as _k
from . import _state_kernels as _sk
from ._shared_jit import interpreted
from .base import OrbitBase
from .errors import BeyondHillSphereWarning, OrbitValueError, PerigeeInsideEarthWarning
from .kepler import MAX_HYPERBOLIC_E, MAX_MEAN_ANOMALY, _as_array, _scalar

__all__ = ["KeplerOrbit", "earth_mu"]


@lru_cache(maxsize=1)
def earth_mu() -> float:
    """Earth's gravitational parameter GM from :mod:`astropy.constants`, in km³/s²."""
    from astropy import constants

    return float(constants.GM_earth.to_value("km3 / s2"))


#: Earth's GM (km³/s²; WGS 84) and equatorial radius (km; WGS 84) for the perigee check. Any
#: mu within EARTH_MU_RTOL of it is the Earth's (IAU 2015 398600.4, WGS 72 398600.8 too).
EARTH_MU = 398600.4418
EARTH_MU_RTOL = 1e-5
EARTH_RADIUS = 6378.137
#: The Earth's Hill sphere [km]: 1 au (m⊕ / 3 M☉)^(1/3).
EARTH_HILL_RADIUS = 1.5e6


def _check_perigee(a: float, e: float, mu: float) -> None:
    """Warn (:class:`PerigeeInsideEarthWarning`) if an Earth orbit's perigee is inside the Earth,
    (:class:`BeyondHillSphereWarning`) if it is beyond the Earth's Hill sphere."""
    rp = a * (1.0 - e)  # also |a| (e − 1) for a hyperbola (a < 0)
    earth = abs(mu - EARTH_MU) <= EARTH_MU_RTOL * EARTH_MU
    if earth and rp > EARTH_HILL_RADIUS:
        warnings.warn(
            BeyondHillSphereWarning(
                f"perigee radius a (1 - e) = {rp:.4g} km: this Earth orbit lies beyond the "
                f"Earth's Hill sphere ({EARTH_HILL_RADIUS:.2g} km), where the Sun governs the "
                "motion. Plain numbers are km: for metres give a Quantity (a=7000e3 * u.m), or "
                "give mu of another central body"
            ),
            stacklevel=3,
        )
    if earth and rp < EARTH_RADIUS:
        warnings.warn(
            PerigeeInsideEarthWarning(
                f"perigee altitude {rp - EARTH_RADIUS:.1f} km: this Earth orbit's perigee radius "
                f"a (1 - e) = {rp:.1f} km is inside the Earth (equatorial radius "
                f"{EARTH_RADIUS} km); check a and e (or give mu of another central body)"
            ),
            stacklevel=3,
        )


def _vector3(x: Any, name: str, unit: str) -> np.ndarray:
    arr = _as_array(x, name, unit)
    if arr.shape != (3,):
        raise OrbitValueError(f"{name}: expected a 3-vector (shape (3,)), got shape {arr.shape}")
    return arr


def _wrap_2pi(x: float) -> float:
    """x modulo 2π in [0, 2π)."""
    y = math.fmod(x, 2.0 * math.pi)
    if y < 0.0:
        y += 2.0 * math.pi
    return 0.0 if y >= 2.0 * math.pi else y


def kepler_kernel_data(el: np.ndarray) -> np.ndarray:
    """The dispatcher array (:mod:`orbit._state_kernels`, type Kepler) of a 9-element ``el``.

    The cos/sin of the constant angles are computed here once, with the same expressions the
    kernels of :mod:`orbit._kernels` evaluate per call, so results are bit-identical.
    """
    d = np.empty(_sk.K_LEN, dtype=np.float64)
    d[_sk.TYPE] = _sk.TYPE_KEPLER
    d[_sk.MU] = el[_k.MU]
    d[_sk.T_MIN] = -math.inf
    d[_sk.T_MAX] = math.inf
    d[_sk.K_EL : _sk.K_EL + _k.NEL] = el
    raan, inc, argp = float(el[_k.RAAN]), float(el[_k.INC]), float(el[_k.ARGP])
    d[_sk.K_TRIG : _sk.K_TRIG + 6] = (
        math.cos(raan),
        math.sin(raan),
        math.cos(inc),
        math.sin(inc),
        math.cos(argp),
        math.sin(argp),
    )
    hp = 0.5 * (raan + argp)
    hm = 0.5 * (raan - argp)
    d[_sk.K_HALF : _sk.K_HALF + 6] = (
        math.cos(0.5 * inc),
        math.sin(0.5 * inc),
        math.cos(hp),
        math.sin(hp),
        math.cos(hm),
        math.sin(hm),
    )
    return d


def _mean_from_true(f: float, e: float, hyperbolic: bool) -> float:
    """Mean anomaly from the true anomaly, by the kernels of orbit._kernels run as plain Python
    (one scalar: compiling them would cost a fresh install's first run ~0.4 s); where Python
    raises (an overflow), the compiled kernel's inf/NaN, which the caller then rejects."""
    for k in (interpreted(_k), _k):
        try:
            if hyperbolic:
                return k.mean_from_hyperbolic_scalar(k.hyperbolic_from_true_scalar(f, e), e)
            return k.mean_from_eccentric_scalar(k.eccentric_from_true_scalar(f, e), e)
        except (ArithmeticError, ValueError):
            continue
    raise AssertionError("unreachable: the compiled kernels do not raise")


class ClassicalElements:
    """The classical elements at t0 of an orbit whose element array ``_el`` has the layout of
    :mod:`orbit._kernels` (Kepler elements; a :class:`orbit.SecularJ2Orbit`'s mean elements)."""

    _el: np.ndarray

    @property
    def a(self) -> float:
        """Semi-major axis [km] (negative for a hyperbola; the mean one under J2)."""
        return float(self._el[_k.A])

    @property
    def e(self) -> float:
        """Eccentricity (the mean one under J2)."""
        return float(self._el[_k.ECC])

    @property
    def inc(self) -> float:
        """Inclination [rad] (the mean one under J2)."""
        return float(self._el[_k.INC])

    @property
    def raan(self) -> float:
        """Right ascension of the ascending node Ω at t0 [rad]."""
        return float(self._el[_k.RAAN])

    @property
    def argp(self) -> float:
        """Argument of periapsis ω at t0 [rad]."""
        return float(self._el[_k.ARGP])

    @property
    def M0(self) -> float:
        """Mean anomaly at t0 [rad]."""
        return float(self._el[_k.M0])

    @property
    def t0(self) -> float:
        """Time of the elements [s since the epoch]."""
        return float(self._el[_k.T0])

    def _angle_rates(self) -> tuple[float, float, float]:
        """(Ω̇, ω̇, n) [rad/s]: the rates of the angles that grow with t (Kepler: n only)."""
        return 0.0, 0.0, float(self._el[_k.N])

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise :class:`OrbitValueError` (naming ``name``) for times so far from t0 that the
        mean anomaly (or a node or periapsis angle that drifts) exceeds 2**50 rad: no accuracy
        is left modulo one revolution (the kernels would return NaN or noise)."""
        OrbitBase.check_times(self, t, name)  # (finite times)
        arr = np.asarray(t, dtype=np.float64)
        if not arr.size or self._el[_k.A] < 0.0:  # a hyperbola's anomaly does not wrap
            return
        dt = max(abs(float(np.max(arr)) - self.t0), abs(float(np.min(arr)) - self.t0))
        for what, x0, rate in zip(
            ("node Ω0 + Ω̇", "periapsis ω0 + ω̇", "mean anomaly M0 + n"),
            (self.raan, self.argp, self.M0),
            self._angle_rates(),
            strict=True,
        ):
            if abs(x0) + abs(rate) * dt > MAX_MEAN_ANOMALY:
                raise OrbitValueError(
                    f"{name}: the {what} (t − t0) exceeds 2**50 rad at some t (|t − t0| up "
                    f"to {dt:.3g} s); times that far from t0 have no accuracy left modulo one "
                    "revolution"
                )


class KeplerOrbit(ClassicalElements, OrbitBase):
    """A Keplerian orbit about a point mass: elliptic (0 <= e < 1) or hyperbolic (e > 1).

    Parameters
    ----------
    a : float or Quantity [km]
        Semi-major axis: a > 0 for an ellipse, a < 0 for a hyperbola.
    e : float
        Eccentricity, 0 <= e < 1 or e > 1 (a parabola, e = 1, is not supported).
    inc : float or Quantity [rad]
        Inclination, 0 <= inc <= π.
    raan : float or Quantity [rad]
        Right ascension of the ascending node Ω.
    argp : float or Quantity [rad]
        Argument of periapsis ω.
    f0 : float or Quantity [rad], optional
        True anomaly at ``t0`` (default 0: periapsis). For a hyperbola |f0| < acos(−1/e).
    mu : float or Quantity [km³/s²], optional
        Gravitational parameter of the central body, mu > 0. Default: Earth's GM from
        :mod:`astropy.constants` (398600.4 km³/s², IAU 2015 nominal value).
    t0 : float or Quantity [s], optional
        Epoch of ``f0``/``M0``: seconds since the origin of the times passed to the methods.
    M0 : float or Quantity [rad], keyword-only, optional
        Mean anomaly at ``t0``, instead of ``f0``.
    epoch : astropy Time or str, keyword-only, optional
        The date of t = 0 (ISO 8601 strings are UTC unless a scale follows, e.g.
        ``"2024-03-20T12:00:00 TT"``). With an epoch the space frame is the GCRS and
        :meth:`geodetic` / :meth:`itrs_position` are available; times t stay seconds since it.

    Raises
    ------
    OrbitValueError
        A non-finite element, e < 0, e = 1, a <= 0 with e < 1, a >= 0 with e > 1, inc outside
        [0, π], mu <= 0, both f0 and M0 given, or f0 beyond the asymptotes of a hyperbola.
    OrbitTypeError
        Non-numeric input or units incompatible with the parameter.

    Notes
    -----
    The mean anomaly is M(t) = M0 + n (t − t0), n = sqrt(mu/|a|³). The orbital-frame
    quaternion :meth:`frame_quaternion` is p(t) of Arribas, Elipe & Palacios (2006) Sect. 6.2,
    built from (Ω, i, ω + f) like their eq. 12 (3-1-3 sequence).

    Examples
    --------
    The orbit of Arribas et al. Sect. 6.2:

    >>> import math
    >>> orb = KeplerOrbit(7000.0, 0.2, math.pi / 6, math.pi / 4, math.pi / 12)
    >>> round(orb.period, 3)
    5828.517
    """

    def __init__(
        self,
        a: Any,
        e: Any,
        inc: Any,
        raan: Any,
        argp: Any,
        f0: Any = None,
        mu: Any = None,
        t0: Any = 0.0,
        *,
        M0: Any = None,
        epoch: Any = None,
    ) -> None:
        from .timescales import as_epoch

        self._epoch = as_epoch(epoch, "epoch")
        a_ = _scalar(a, "a", "km")
        e_ = _scalar(e, "e", None)
        inc_ = _scalar(inc, "inc", "rad")
        raan_ = _scalar(raan, "raan", "rad")
        argp_ = _scalar(argp, "argp", "rad")
        t0_ = _scalar(t0, "t0", "s")
        mu_ = earth_mu() if mu is None else _scalar(mu, "mu", "km3 / s2")
        if f0 is not None and M0 is not None:
            raise OrbitValueError("f0, M0: give the anomaly at t0 as either f0 or M0, not both")
        f0_ = None if f0 is None else _scalar(f0, "f0", "rad")
        M0_ = None if M0 is None else _scalar(M0, "M0", "rad")

        if e_ < 0.0:
            raise OrbitValueError(f"e: eccentricity must be >= 0, got e = {e_!r}")
        if e_ == 1.0:
            raise OrbitValueError(
                "e: a parabolic orbit (e = 1) is not supported; give 0 <= e < 1 (ellipse, a > 0) "
                "or e > 1 (hyperbola, a < 0)"
            )
        if e_ > MAX_HYPERBOLIC_E:
            raise OrbitValueError(f"e: eccentricity must be at most 1e100, got e = {e_!r}")
        hyperbolic = e_ > 1.0
        if not hyperbolic and not a_ > 0.0:
            raise OrbitValueError(
                f"a: an elliptic orbit (e = {e_!r} < 1) needs a semi-major axis a > 0, got {a_!r}"
            )
        if hyperbolic and not a_ < 0.0:
            raise OrbitValueError(
                f"a: a hyperbolic orbit (e = {e_!r} > 1) needs a negative semi-major axis "
                f"(a = -|a|), got a = {a_!r}"
            )
        if not 0.0 <= inc_ <= math.pi:
            raise OrbitValueError(
                f"inc: inclination must be in [0, π] rad, got {inc_!r} (for a retrograde orbit "
                "use inc > π/2; shift raan by π instead of using a negative inclination)"
            )
        if not mu_ > 0.0:
            raise OrbitValueError(f"mu: gravitational parameter must be > 0 km³/s², got {mu_!r}")
        if f0_ is None and M0_ is None:
            f0_ = 0.0
        if hyperbolic:
            if f0_ is not None:
                lim = math.acos(-1.0 / e_)
                if not abs(f0_) < lim:
                    raise OrbitValueError(
                        f"f0: a hyperbola with e = {e_!r} only reaches |f| < acos(−1/e) = "
                        f"{lim!r} rad, got f0 = {f0_!r}"
                    )
                M0_ = _mean_from_true(f0_, e_, hyperbolic)
        else:
            if f0_ is not None:
                if abs(f0_) > MAX_MEAN_ANOMALY:
                    raise OrbitValueError(f"f0: |f0| must be at most 2**50 rad, got {f0_!r}")
                M0_ = _mean_from_true(f0_, e_, hyperbolic)
            elif abs(M0_) > MAX_MEAN_ANOMALY:
                raise OrbitValueError(f"M0: |M0| must be at most 2**50 rad, got {M0_!r}")
        try:  # |a|³ overflows (a = 1e300 km) or vanishes (a = 1e-300 km): no orbit
            n = math.sqrt(mu_ / abs(a_) ** 3)
        except (OverflowError, ZeroDivisionError):
            n = math.nan
        if not (math.isfinite(n) and n > 0.0):
            raise OrbitValueError(
                f"a, mu: the mean motion sqrt(mu/|a|³) is not a positive finite number "
                f"(a = {a_!r} km, mu = {mu_!r} km³/s²)"
            )
        _check_perigee(a_, e_, mu_)
        el = np.empty(_k.NEL, dtype=np.float64)
        el[_k.A] = a_
        el[_k.ECC] = e_
        el[_k.INC] = inc_
        el[_k.RAAN] = raan_
        el[_k.ARGP] = argp_
        el[_k.M0] = M0_
        el[_k.T0] = t0_
        el[_k.MU] = mu_
        el[_k.N] = n
        # Writable (never modified): the loops then run on the compiled code of the gravity
        # gradient's orbit kernels (numba compiles a read-only array as another type).
        self._el = el
        # The kernels this orbit's loops run on: an ellipse's are compiled without the
        # hyperbolic solver.
        self._kernels = _k.ELLIPTIC if e_ < 1.0 else _k
        self._f0 = f0_
        self._set_data(kepler_kernel_data(el))

    # -----------------------------------------------------------------------------------------
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
        t0: Any = 0.0,
    ) -> KeplerOrbit:
        """The circular orbit ``altitude`` km above the Earth's equatorial radius (6378.137 km).

        Parameters
        ----------
        altitude : float or Quantity [km]
            Height above the equatorial radius, > 0: a = 6378.137 km + altitude.
        inc : float or Quantity [rad]
            Inclination, 0 <= inc <= π.
        raan : float or Quantity [rad], optional
            Right ascension of the ascending node Ω (default 0).
        arg_lat : float or Quantity [rad], optional
            Argument of latitude u at ``t0`` (angle from the ascending node; default 0: at
            the node). Stored as ω = 0, f0 = u.
        epoch, mu, t0 :
            As for :class:`KeplerOrbit`.

        Raises
        ------
        OrbitValueError
            altitude <= 0, and the element checks of :class:`KeplerOrbit`.

        Examples
        --------
        >>> import math
        >>> o = KeplerOrbit.circular(500.0, math.radians(51.6))
        >>> round(o.a, 3), o.e
        (6878.137, 0.0)

        For a sun-synchronous orbit (the J2 drift of the node) see
        :meth:`orbit.SecularJ2Orbit.sun_synchronous`.
        """
        from ._constructors import circular_radius

        a = circular_radius(altitude, EARTH_RADIUS)
        u = _scalar(arg_lat, "arg_lat", "rad")
        return cls(a, 0.0, inc, raan, 0.0, f0=u, mu=mu, t0=t0, epoch=epoch)

    # -----------------------------------------------------------------------------------------
    @classmethod
    def from_state(
        cls, r: Any, v: Any, mu: Any = None, t0: Any = 0.0, *, epoch: Any = None
    ) -> KeplerOrbit:
        """The orbit through position ``r`` with velocity ``v`` at time ``t0``.

        Parameters
        ----------
        r : array_like, shape (3,) [km]
            Position in the space frame (Quantity of length accepted).
        v : array_like, shape (3,) [km/s]
            Velocity in the space frame (Quantity of speed accepted).
        mu : float or Quantity [km³/s²], optional
            Gravitational parameter; default Earth's GM.
        t0 : float or Quantity [s], optional
            Time of the state (the epoch of the returned elements).
        epoch : astropy Time or str, optional
            Date of t = 0 (the state is then in the GCRS).

        Returns
        -------
        KeplerOrbit

        Raises
        ------
        OrbitValueError
            r = 0, a radial trajectory (r × v = 0: it passes through the centre), a parabolic
            state (e = 1 to round-off), non-finite input, mu <= 0.

        Notes
        -----
        e cos f = p/|r| − 1 and e sin f = sqrt(p/mu) (r·v)/|r| with p = |r × v|²/mu give e and f
        without cancellation; a = p/(1 − e²). Angles that the state does not define get
        conventional values: Ω = 0 for an equatorial orbit (inc = 0 or π); for a circular orbit
        f is the angle of round-off-sized e cos f, e sin f and ω = u − f, so the argument of
        latitude u = ω + f (what the position depends on) is always right. Ω and ω are returned
        in [0, 2π).
        """
        rv = _vector3(r, "r", "km")
        vv = _vector3(v, "v", "km / s")
        mu_ = earth_mu() if mu is None else _scalar(mu, "mu", "km3 / s2")
        if not mu_ > 0.0:
            raise OrbitValueError(f"mu: gravitational parameter must be > 0 km³/s², got {mu_!r}")
        rn = float(np.linalg.norm(rv))
        vn = float(np.linalg.norm(vv))
        if rn == 0.0:
            raise OrbitValueError("r: the position is the centre of attraction (|r| = 0)")
        h = np.cross(rv, vv)
        hn = float(np.linalg.norm(h))
        if not hn > 1e-14 * rn * vn:
            raise OrbitValueError(
                "r, v: r × v = 0, a radial trajectory that passes through the centre of "
                "attraction; Keplerian elements do not describe it"
            )
        p = hn * hn / mu_  # semi-latus rectum
        rdotv = float(rv @ vv)
        ecosf = p / rn - 1.0
        esinf = math.sqrt(p / mu_) * rdotv / rn
        e = math.hypot(ecosf, esinf)
        f = math.atan2(esinf, ecosf)
        if abs(e - 1.0) <= 1e-12:
            raise OrbitValueError(
                f"r, v: the state is parabolic to round-off (e = {e!r}); parabolic orbits are not "
                "supported"
            )
        a = p / ((1.0 - e) * (1.0 + e))
        hxy = math.hypot(h[0], h[1])
        inc = math.atan2(hxy, h[2])
        raan = math.atan2(h[0], -h[1]) if hxy > 0.0 else 0.0
        cO, sO = math.cos(raan), math.sin(raan)
        ci, si = math.cos(inc), math.sin(inc)
        # Argument of latitude u from the node line N̂ and M̂ = ĥ × N̂.
        x_n = rv[0] * cO + rv[1] * sO
        x_m = -rv[0] * sO * ci + rv[1] * cO * ci + rv[2] * si
        u = math.atan2(x_m, x_n)
        argp = _wrap_2pi(u - f)
        return cls(a, e, inc, _wrap_2pi(raan), argp, f0=f, mu=mu_, t0=t0, epoch=epoch)

    # -----------------------------------------------------------------------------------------
    @property
    def f0(self) -> float:
        """True anomaly at t0 [rad]."""
        if self._f0 is not None:
            return float(self._f0)
        return float(self.true_anomaly(self.t0))

    @property
    def mu(self) -> float:
        """Gravitational parameter [km³/s²]."""
        return float(self._el[_k.MU])

    @property
    def source(self) -> str:
        """'Kepler elements' (for attrs and ``attitude info``)."""
        kind = "hyperbolic" if self.is_hyperbolic else "elliptic"
        return f"Kepler elements ({kind}, a = {self.a!r} km, e = {self.e!r})"

    @property
    def mean_motion(self) -> float:
        """Mean motion n = sqrt(mu/|a|³) [rad/s]."""
        return float(self._el[_k.N])

    @property
    def period(self) -> float:
        """Orbital period 2π/n [s]; ``math.inf`` for a hyperbola."""
        if self.is_hyperbolic:
            return math.inf
        return 2.0 * math.pi / self.mean_motion

    @property
    def is_hyperbolic(self) -> bool:
        """True for e > 1."""
        return self.e > 1.0

    @property
    def periapsis_radius(self) -> float:
        """Periapsis distance |a| |1 − e| [km]."""
        return abs(self.a) * abs(1.0 - self.e)

    @property
    def semi_latus_rectum(self) -> float:
        """p = |a| |1 − e²| [km]."""
        return abs(self.a * (1.0 - self.e) * (1.0 + self.e))

    def kernel_elements(self) -> np.ndarray:
        """A copy of the float64 element array of :mod:`orbit._kernels` (length 9).

        Layout ``[a, e, inc, raan, argp, M0, t0, mu, n]`` (indices ``orbit._kernels.A`` ...
        ``N``) in km, rad, s, km³/s², rad/s.
        """
        return self._el.copy()

    # -----------------------------------------------------------------------------------------
    def _times(self, t: Any) -> tuple[np.ndarray, tuple[int, ...]]:
        from astropy.time import Time

        if isinstance(t, Time):
            ta = np.asarray(self.seconds_since_epoch(t, "t"), dtype=np.float64)
        else:
            ta = _as_array(t, "t", "s")
        flat = np.ascontiguousarray(ta).ravel()
        if not self.is_hyperbolic and flat.size:
            m = self.M0 + self.mean_motion * (flat - self.t0)
            if np.max(np.abs(m)) > MAX_MEAN_ANOMALY:
                raise OrbitValueError(
                    "t: the mean anomaly M0 + n (t − t0) exceeds 2**50 rad at some t; times "
                    "that far from t0 have no accuracy left modulo one revolution"
                )
        return flat, ta.shape

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise :class:`OrbitValueError` (naming ``name``) for times that are not finite, or
        (an ellipse) where the mean anomaly exceeds 2**50 rad, which the methods refuse."""
        super().check_times(t, name)
        arr = np.asarray(t, dtype=np.float64)
        if not self.is_hyperbolic and arr.size:
            m = self.M0 + self.mean_motion * (arr - self.t0)
            if np.max(np.abs(m)) > MAX_MEAN_ANOMALY:
                raise OrbitValueError(
                    f"{name}: the mean anomaly M0 + n (t − t0) exceeds 2**50 rad at some t; "
                    "times that far from t0 have no accuracy left modulo one revolution"
                )

    @staticmethod
    def _shape(out: np.ndarray, shape: tuple[int, ...]) -> Any:
        if shape == ():
            return float(out[0])
        return out.reshape(shape)

    def mean_anomaly(self, t: Any) -> Any:
        """Mean anomaly M(t) = M0 + n (t − t0) [rad], not wrapped.

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        M : float or ndarray, shape of t
        """
        flat, shape = self._times(t)
        return self._shape(self.M0 + self.mean_motion * (flat - self.t0), shape)

    def eccentric_anomaly(self, t: Any) -> Any:
        """Eccentric anomaly E(t) [rad] (continuous in t), or H(t) for a hyperbola.

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        E : float or ndarray, shape of t
        """
        flat, shape = self._times(t)
        out = np.empty(flat.size)
        self._kernels.eccentric_anomaly_loop(self._el, flat, out)
        return self._shape(out, shape)

    def true_anomaly(self, t: Any) -> Any:
        """True anomaly f(t) [rad], continuous in t (not wrapped to [0, 2π)).

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        f : float or ndarray, shape of t
        """
        flat, shape = self._times(t)
        out = np.empty(flat.size)
        self._kernels.true_anomaly_loop(self._el, flat, out)
        return self._shape(out, shape)

    def _radial(self, t: Any) -> tuple[np.ndarray, tuple[int, ...]]:
        flat, shape = self._times(t)
        out = np.empty((flat.size, 4))
        self._kernels.radial_loop(self._el, flat, out)
        return out, shape

    def radius(self, t: Any) -> Any:
        """Distance from the centre r(t) [km].

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        r : float or ndarray, shape of t
        """
        out, shape = self._radial(t)
        return self._shape(np.ascontiguousarray(out[:, 0]), shape)

    def radial_direction(self, t: Any) -> np.ndarray:
        """Unit vector r/|r| in the space frame.

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        rhat : ndarray, shape t.shape + (3,)
        """
        out, shape = self._radial(t)
        return out[:, 1:].reshape((*shape, 3))

    def _state(self, t: Any) -> tuple[np.ndarray, tuple[int, ...]]:
        flat, shape = self._times(t)
        out = np.empty((flat.size, 6))
        self._kernels.state_loop(self._el, flat, out)
        return out, shape

    def position(self, t: Any) -> np.ndarray:
        """Position in the space frame [km].

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        r : ndarray, shape t.shape + (3,)
        """
        out, shape = self._state(t)
        return out[:, :3].reshape((*shape, 3))

    def velocity(self, t: Any) -> np.ndarray:
        """Velocity in the space frame [km/s].

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        v : ndarray, shape t.shape + (3,)
        """
        out, shape = self._state(t)
        return out[:, 3:].reshape((*shape, 3))

    def to_state(self, t: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """Position [km] and velocity [km/s] at t (default t0).

        Parameters
        ----------
        t : float or array_like [s], optional

        Returns
        -------
        r, v : ndarray, shape t.shape + (3,) each
        """
        out, shape = self._state(self.t0 if t is None else t)
        return out[:, :3].reshape((*shape, 3)), out[:, 3:].reshape((*shape, 3))

    def frame_quaternion(self, t: Any) -> np.ndarray:
        """Orbital-frame quaternion p(t), scalar first (Arribas et al. 2006, Sect. 6.2).

        p maps the space axes onto the orbital frame: p∘s1∘p̃ = r/|r| and p∘s3∘p̃ = the orbit
        normal (r × v)/|r × v|. Built from (Ω, i, u = ω + f) as in eq. 12::

            p = (cos(i/2) cos((Ω+u)/2), sin(i/2) cos((Ω−u)/2),
                 sin(i/2) sin((Ω−u)/2), cos(i/2) sin((Ω+u)/2))

        Continuous in t (so it changes sign each revolution: p and −p are the same rotation).

        Parameters
        ----------
        t : float or array_like [s]

        Returns
        -------
        p : ndarray, shape t.shape + (4,)
        """
        flat, shape = self._times(t)
        out = np.empty((flat.size, 5))
        self._kernels.frame_loop(self._el, flat, out)
        return out[:, 1:].reshape((*shape, 4))

    def __repr__(self) -> str:
        kind = "hyperbolic" if self.is_hyperbolic else "elliptic"
        ep = "" if self._epoch is None else f", epoch={self._epoch.utc.isot!r}"
        return (
            f"KeplerOrbit(a={self.a!r}, e={self.e!r}, inc={self.inc!r}, raan={self.raan!r}, "
            f"argp={self.argp!r}, M0={self.M0!r}, mu={self.mu!r}, t0={self.t0!r}{ep})  # "
            f"{kind}, km, rad, s"
        )

"""A numerically propagated Earth orbit: ``NumericalOrbit(r0, v0, epoch, gravity, third_bodies)``.

The orbit obeys r̈ = a(t, r) in the GCRS, with a the Earth's attraction (a point mass, or the
spherical harmonics of :class:`orbit.SphericalHarmonics` in the Earth-fixed frame, turned by the
IAU 2006/2000A Earth orientation of astropy) plus the Sun's and the Moon's pull
(:class:`orbit.ThirdBody`), integrated by the package's DOP853 stepper (:mod:`orbit._rk`,
compiled with the force model of :mod:`orbit._force_kernels`) or, with ``method="taylor"``, by
the orbit's Taylor-series integrator (:mod:`orbit._taylor`: the same force model expanded in
series).

It is an :class:`orbit.Orbit` like the others: positions, velocities, the orbital frame, usable
as a given orbit by everything that takes one. Behind that interface is a Hermite table of the
integrator's states (the table of :class:`orbit.EphemerisOrbit`), extended on demand: asking for
a time (``position(t)``, ``check_times(t)``) integrates on from the last state reached, and the
integration's steps never depend on which times were asked for (the stepper is never stopped at
an output time), so the orbit is one trajectory however it is queried. ``propagate(t)`` returns
the integrator's own dense output as a Dataset.
"""

from __future__ import annotations

import math
import secrets
from collections.abc import Sequence
from typing import Any

import numpy as np

from . import _force_kernels as _fk
from . import _rk, _taylor
from . import _state_kernels as _sk
from .ephemeris import EphemerisOrbit
from .errors import OrbitTypeError, OrbitValueError
from .gravity_field import POLAR_RADIUS, SphericalHarmonics
from .kepler import _as_array
from .keplerorbit import earth_mu
from .third_body import ThirdBody
from .timescales import as_epoch, check_dates, format_epoch

__all__ = ["Impact", "NumericalOrbit"]

#: WGS 84 equatorial radius (m): the surface an orbit impacts.
EQUATORIAL_RADIUS = 6_378_137.0
#: Earth-orientation nodes (s): M and the ERA residual interpolated between them.
EO_STEP = 600.0
#: Third-body table nodes (s).
BODY_STEP = 3600.0
#: Force tables are built for whole blocks of this many seconds (anchored at t = 0), so that
#: extending the orbit appends nodes and never changes an interpolated value already used.
BLOCK = 86_400.0
#: Table room beyond the span an integration reaches (a step's stages look ahead).
PAD = 4.0 * 3600.0

_ROTATIONS = ("iers", "uniform")
_METHODS = ("dop853", "taylor")


class Impact(OrbitValueError):
    """The orbit reached the Earth's surface (WGS 84 ellipsoid) at ``time`` [s since the epoch]
    with ``state`` (6,) [m, m/s] in the GCRS; nothing beyond it exists."""

    def __init__(self, time: float, state: np.ndarray, epoch: Any) -> None:
        self.time = float(time)
        self.state = np.asarray(state, dtype=np.float64).copy()
        when = format_epoch(epoch + self.time * _sec()) if epoch is not None else ""
        super().__init__(
            f"t: the orbit reaches the Earth's surface at t = {self.time:.6f} s ({when}); "
            "it has no state beyond: ask for times before the impact"
        )


def _sec() -> Any:
    from astropy import units as u

    return u.s


def _bodies(third_bodies: Any) -> tuple[ThirdBody, ...]:
    if third_bodies is None:
        return ()
    if isinstance(third_bodies, (str, ThirdBody)):
        third_bodies = (third_bodies,)
    if not isinstance(third_bodies, Sequence):
        raise OrbitTypeError(
            f"third_bodies: a sequence of orbit.ThirdBody (or 'sun', 'moon'), got "
            f"{type(third_bodies).__name__}"
        )
    out = []
    for i, b in enumerate(third_bodies):
        if isinstance(b, str):
            b = ThirdBody(b)
        if not isinstance(b, ThirdBody):
            raise OrbitTypeError(
                f"third_bodies[{i}]: an orbit.ThirdBody or 'sun'/'moon', got {type(b).__name__}"
            )
        out.append(b)
    names = [b.body for b in out]
    if len(set(names)) != len(names):
        raise OrbitValueError(f"third_bodies: each body once, got {names}")
    return tuple(out)


class ForceModel:
    """The accelerations on the orbit, as data for compiled code (:mod:`orbit._force_kernels`).

    Parameters
    ----------
    epoch : astropy Time
    gravity : SphericalHarmonics or None
        None: a point-mass Earth of gravitational parameter ``mu`` [m³/s²].
    third_bodies : tuple of ThirdBody
    mu : float
        The point mass's μ [m³/s²] (ignored with a field: its own GM).
    earth_rotation : {"iers", "uniform"}
    """

    def __init__(
        self, epoch: Any, gravity: Any, third_bodies: tuple, mu: float, earth_rotation: str
    ) -> None:
        self.epoch = epoch
        self.gravity = gravity
        self.third_bodies = third_bodies
        self.mu = float(gravity.mu if gravity is not None else mu)
        self.earth_rotation = earth_rotation
        self._blocks: tuple[int, int] | None = None
        self.data = np.zeros(0)
        self._theta0 = None

    def describe(self) -> str:
        g = "point-mass Earth" if self.gravity is None else repr(self.gravity)
        b = "".join(f" + {t.body}" for t in self.third_bodies)
        return f"{g}{b} (Earth rotation: {self.earth_rotation})"

    def cover(self, lo: float, hi: float) -> np.ndarray:
        """The data array, its tables covering [lo, hi] seconds (rebuilt by whole blocks)."""
        b0 = math.floor((lo - PAD) / BLOCK)
        b1 = math.ceil((hi + PAD) / BLOCK)
        if self._blocks is not None and self._blocks[0] <= b0 and b1 <= self._blocks[1]:
            return self.data
        if self._blocks is not None:
            b0, b1 = min(b0, self._blocks[0]), max(b1, self._blocks[1])
        check_dates(self.epoch, np.array([b0 * BLOCK, b1 * BLOCK]), "t")
        self._blocks = (b0, b1)
        self.data = self._build(b0 * BLOCK, b1 * BLOCK)
        return self.data

    def _build(self, lo: float, hi: float) -> np.ndarray:
        from astropy.time import TimeDelta

        from . import frames as _fr
        from . import tables as _tab
        from .timescales import offline_iers

        F = _fk.FORCES
        parts = [np.zeros(F.SIZE)]
        size = 0 if self.gravity is None else self.gravity.degree + 2

        def put(a: np.ndarray) -> int:
            off = sum(p.size for p in parts)
            parts.append(np.ascontiguousarray(a, dtype=np.float64).ravel())
            return off

        head: dict[str, Any] = {"mu": self.mu, "surface_a": EQUATORIAL_RADIUS,
                                "surface_b": POLAR_RADIUS}  # fmt: skip
        if self.gravity is not None:
            g = self.gravity
            head.update(n_max=g.degree, m_max=g.order, radius=g.radius)
            head["c"] = put(g.C)
            head["s"] = put(g.S)
            head["f"] = put(g._factors)
            head["scratch"] = put(np.zeros(size * size + 2 * size))
        if self._theta0 is None:
            self._theta0 = float(_fr._earth_rotation_angle(self.epoch.reshape(1))[0])
        omega = 2.0 * math.pi * 1.00273781191135448 / 86400.0  # ERA per UT1 second (IERS 2010)
        head.update(theta0=self._theta0, omega=omega)
        if self.earth_rotation == "iers":
            tc = np.arange(lo - 4 * EO_STEP, hi + 4.5 * EO_STEP, EO_STEP)
            times = self.epoch + TimeDelta(tc, format="sec")
            rc = _fr._astropy_gcrs_to_itrs_matrix(times)
            era = _fr._earth_rotation_angle(times)
            mc = np.einsum("nji,njk->nik", _fr._spin(era), rc)  # R3(θ)ᵀ R
            dth = np.remainder(era - self._theta0 - omega * tc + math.pi, 2.0 * math.pi) - math.pi
            head.update(eo_n=tc.size, eo_t0=tc[0], eo_h=EO_STEP)
            head["eo_m"] = put(mc.reshape(-1, 9))
            head["eo_dth"] = put(dth)
        recs = []
        for body in self.third_bodies:
            with offline_iers():
                table = _tab.tabulate(
                    lambda t, b=body: b.position(self.epoch, t) * 1e-3,
                    lo - 8 * BODY_STEP, hi + 8 * BODY_STEP, BODY_STEP,
                )  # fmt: skip
            recs.append((body.mu, put(table)))
        head["n_bodies"] = len(recs)
        head["bodies"] = put(np.array(recs, dtype=np.float64).reshape(-1))
        F.pack_into(parts[0], 0, **head)
        return np.ascontiguousarray(np.concatenate(parts))


class _Integrator:
    """One direction of the integration from the epoch, continued call after call: DOP853's
    arrays (orbit._rk), or with ``rows`` the Taylor integrator's (orbit._taylor)."""

    def __init__(self, direction: float, taylor: tuple[int, int, int] | None = None) -> None:
        self.direction = direction
        if taylor is None:
            self.work, self.tstate, self.counters = _rk.new_state(6)
            self.field = None
        else:  # (degree, order, number of third bodies)
            self.work, self.field, self.tstate, self.counters = _taylor.new_state(*taylor)
        self.impact: Impact | None = None


def _state_vectors(r0: Any, v0: Any) -> tuple[np.ndarray, np.ndarray]:
    """r0 [km] and v0 [km/s] as (3,) float arrays, checked: finite, and of an Earth orbit."""
    r = np.asarray(_as_array(r0, "r0", "km"), dtype=np.float64)
    v = np.asarray(_as_array(v0, "v0", "km / s"), dtype=np.float64)
    for name, x in (("r0", r), ("v0", v)):
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise OrbitValueError(f"{name}: three finite components, got {x!r}")
    # An Earth orbit stays inside the Earth's Hill sphere (1.5e6 km) and below ~100 km/s:
    # numbers beyond are most likely metres (m/s) given where km (km/s) are read.
    for name, x, limit, unit in (("r0", r, 2e6, "km"), ("v0", v, 100.0, "km/s")):
        if np.linalg.norm(x) > limit:
            raise OrbitValueError(
                f"{name}: |{name}| = {np.linalg.norm(x):.4g} {unit}, more than {limit:g} "
                f"{unit}: no Earth orbit; plain numbers are read in {unit} (metres given? "
                f"divide by 1000, or pass an astropy Quantity with its unit)"
            )
    return r, v


class NumericalOrbit(EphemerisOrbit):
    """An Earth orbit propagated numerically under a gravity field and third bodies.

    Parameters
    ----------
    r0 : array_like or Quantity, shape (3,) [km]
        Position at the epoch (GCRS, or ``frame``).
    v0 : array_like or Quantity, shape (3,) [km/s]
        Velocity at the epoch.
    epoch : astropy Time or str
        Date of t = 0 (required: the Earth's orientation and the ephemerides need it).
    gravity : SphericalHarmonics, optional
        The Earth's field (in the Earth-fixed frame). None: a point mass of ``mu``.
    third_bodies : sequence of ThirdBody or str, optional
        ``ThirdBody("sun")``, ``ThirdBody("moon")`` (or their names).
    frame : {"GCRS", "EME2000"}
        Frame of ``r0`` and ``v0`` (EME2000 states are turned into the GCRS by the frame bias).
    mu : float or Quantity [km³/s²], optional
        The point-mass Earth's μ (default :func:`orbit.earth_mu`); not with ``gravity``.
    earth_rotation : {"iers", "uniform"}
        ``"iers"``: the IAU 2006/2000A orientation with the IERS table (astropy).
        ``"uniform"``: the Earth turns about the GCRS z axis at the rate of the Earth rotation
        angle from its value at the epoch (an idealised Earth, e.g. for conservation studies).
    rtol, atol : float
        DOP853: tolerances per component (positions in m, velocities in m/s). Taylor: ``rtol``
        sets the order, p = ⌈−½ ln rtol + 1⌉ (16 at 1e-13), and both the step (Jorba & Zou
        2005): relative to |r| and |v| per block, absolute below ``atol/rtol`` (m, m/s).
    max_step : float [s], optional
        Largest step. Default for DOP853: half the time the orbit takes to cross the field's
        shortest wavelength, π |r0| / (degree |v0|) (at most an hour): DOP853's error estimate
        does not see a harmonic the step strides over (a 70 × 70 field at 500 km: 40 s; left at
        an hour, a day drifts 15 mm from Orekit's, tests/test_numerical.py). For Taylor an hour
        (its series see every harmonic: their high orders set the step).
    method : {"dop853", "taylor"}
        The integrator: the package's DOP853 (:mod:`orbit._rk`) or the adaptive Taylor-series
        method (:mod:`orbit._taylor`); every force model, both Earth rotations and the impact
        work with both. Recorded in ``propagate``'s attrs.
    field_step : float [s]
        When the orbit is propagated with a spacecraft's attitude by DOP853 (a
        :class:`attitude.Spacecraft` with a mass): the field's terms beyond the point mass and
        the third bodies are evaluated every ``field_step`` seconds and taken between samples
        from the cubic through the last four (their error ~ (ω h)⁴ times a term of frequency
        ω: 1e-13 m/s² for a 20 × 20 field in low orbit at 1 s); the attitude's steps, set by
        its control (0.1 s at 10 Hz), would otherwise evaluate them a dozen times a step.
        0: at every evaluation of the right-hand side. Only steps of at most half the interval
        sample (longer ones evaluate the field at every stage: they are few), so a flight
        software ticking every P seconds samples with ``field_step >= 2 P``. This orbit's own
        ``propagate`` and Taylor runs evaluate the field exactly.

    Examples
    --------
    >>> import orbit
    >>> o = orbit.NumericalOrbit([6878.137, 0, 0], [0, 7.6127, 0], "2026-03-20T00:00:00",
    ...                          gravity=orbit.SphericalHarmonics(20), third_bodies=("sun", "moon"))
    >>> r = o.position(3600.0)  # km, GCRS
    """

    def __init__(
        self,
        r0: Any,
        v0: Any,
        epoch: Any = None,
        gravity: SphericalHarmonics | None = None,
        third_bodies: Sequence[ThirdBody | str] = (),
        frame: str = "GCRS",
        *,
        mu: Any = None,
        earth_rotation: str = "iers",
        rtol: float = 1e-12,
        atol: float = 1e-9,
        max_step: float | None = None,
        method: str = "dop853",
        field_step: float = 1.0,
    ) -> None:
        if epoch is None:
            raise OrbitValueError(
                "epoch: a NumericalOrbit needs a date (the Earth's orientation and the Sun and "
                "Moon depend on it): give epoch='2026-03-20T00:00:00' or an astropy Time"
            )
        ep = as_epoch(epoch, "epoch", allow_none=False)
        check_dates(ep, np.zeros(1), "epoch")
        self._epoch = ep
        r, v = _state_vectors(r0, v0)
        fr = str(frame).upper()
        if fr in ("EME2000", "J2000"):
            from .frames import eme2000_to_gcrs

            r, v = eme2000_to_gcrs(r), eme2000_to_gcrs(v)
        elif fr not in ("GCRS", "GCRF"):
            raise OrbitValueError(f"frame: 'GCRS' or 'EME2000', got {frame!r}")
        if gravity is not None and not isinstance(gravity, SphericalHarmonics):
            raise OrbitTypeError(
                f"gravity: an orbit.SphericalHarmonics or None (a point mass), got "
                f"{type(gravity).__name__}"
            )
        if gravity is not None and mu is not None:
            raise OrbitValueError(
                "mu: the field's own GM is used with a gravity field; give mu only without one"
            )
        mu_km = earth_mu() if mu is None else float(_as_array(mu, "mu", "km3 / s2"))
        if not (math.isfinite(mu_km) and mu_km > 0.0):
            raise OrbitValueError(f"mu: a positive gravitational parameter (km³/s²), got {mu_km}")
        if earth_rotation not in _ROTATIONS:
            raise OrbitValueError(f"earth_rotation: one of {_ROTATIONS}, got {earth_rotation!r}")
        if not isinstance(method, str) or method.lower() not in _METHODS:
            raise OrbitValueError(
                f"method: 'dop853' (adaptive Runge–Kutta) or 'taylor' (adaptive Taylor series), "
                f"got {method!r}"
            )
        method = method.lower()
        for name, x, lo in (("rtol", rtol, 1e-15), ("atol", atol, 1e-100)):
            if not (isinstance(x, (int, float)) and math.isfinite(x) and lo <= x <= 0.1):
                raise OrbitValueError(f"{name}: a number in [{lo:g}, 0.1], got {x!r}")
        if max_step is None:
            max_step = 3600.0
            if method == "dop853" and gravity is not None and gravity.degree >= 2:
                vn = float(np.linalg.norm(v))
                if vn > 0.0:
                    max_step = min(
                        max_step, math.pi * float(np.linalg.norm(r)) / (gravity.degree * vn)
                    )
        if not (isinstance(max_step, (int, float)) and 0.0 < max_step <= PAD / 2):
            raise OrbitValueError(f"max_step: seconds in (0, {PAD / 2:g}], got {max_step!r}")
        if not (isinstance(field_step, (int, float)) and 0.0 <= field_step <= 60.0):
            raise OrbitValueError(
                f"field_step: seconds in [0, 60] between samples of the field in a coupled run "
                f"(0: exact at every evaluation), got {field_step!r}"
            )
        self.field_step = float(field_step)
        self._forces = ForceModel(ep, gravity, _bodies(third_bodies), mu_km * 1e9, earth_rotation)
        self._options = (float(rtol), float(atol), float(max_step))
        self._method = method
        self._start(r, v)

    def _start(self, r: np.ndarray, v: np.ndarray) -> None:
        """Start from the state (r [km], v [km/s]) at the epoch: checks, node spacing, the
        integrators, the first nodes."""
        self._y0 = np.concatenate([r, v]) * 1e3
        try:
            d = self._forces.cover(0.0, 0.0)
        except OrbitValueError as exc:  # the tables start with a day around the epoch
            raise OrbitValueError(
                f"epoch: the force model's tables cover whole days around the epoch, and "
                f"{str(exc).partition(': ')[2]}; give an epoch a day or more inside that range"
            ) from None
        inside = np.empty(1)
        _fk.surface_loop(d, np.zeros(1), self._y0[None, :3].copy(), inside)
        if inside[0] <= 0.0:
            raise OrbitValueError(
                f"r0: {np.linalg.norm(r):.3f} km from the Earth's centre is inside the Earth "
                "(WGS 84 ellipsoid); give a position above the surface"
            )
        energy = 0.5 * float(v @ v) - self._forces.mu * 1e-9 / float(np.linalg.norm(r))
        if energy < 0.0:
            a = -self._forces.mu * 1e-9 / (2.0 * energy)
            period = 2.0 * math.pi * math.sqrt(a**3 / (self._forces.mu * 1e-9))
            self._h = min(60.0, period / 100.0)
        else:
            self._h = 60.0
        self._mu_km = self._forces.mu * 1e-9
        self._fwd = self._integrator(1.0)
        self._bwd = self._integrator(-1.0)
        self._nodes: dict[int, np.ndarray] = {0: self._y0.copy()}
        self._covered = (0, 0)
        #: A mark in the table's reserved word (orbit._state_kernels E_H + 1, else 0).
        self.token = float(secrets.randbits(52)) + 0.5
        self._cover(0.0, 2.0 * self._h)

    def with_state(self, r0: Any, v0: Any) -> NumericalOrbit:
        """The same orbit model (epoch, field, third bodies, Earth rotation, tolerances) from
        another state at the epoch: an ensemble's dispersed members (they share the force
        model's tables).

        Parameters
        ----------
        r0 : array_like or Quantity, shape (3,) [km]
            Position at the epoch (GCRS).
        v0 : array_like or Quantity, shape (3,) [km/s]
            Velocity at the epoch.
        """
        r, v = _state_vectors(r0, v0)
        new = object.__new__(NumericalOrbit)
        new._epoch = self._epoch
        new._forces = self._forces
        new._options = self._options
        new._method = self._method
        new.field_step = self.field_step
        new._start(r, v)
        return new

    # -- identity ---------------------------------------------------------------------------
    @property
    def gravity(self) -> SphericalHarmonics | None:
        return self._forces.gravity

    @property
    def third_bodies(self) -> tuple[ThirdBody, ...]:
        return self._forces.third_bodies

    @property
    def earth_rotation(self) -> str:
        return self._forces.earth_rotation

    @property
    def perturbed(self) -> bool:
        """Whether anything acts beyond the point mass (a field of degree ≥ 1, third bodies)."""
        g = self._forces.gravity
        return bool(self._forces.third_bodies) or (g is not None and g.degree > 0)

    @property
    def initial_state(self) -> np.ndarray:
        """(6,) [m, m/s] in the GCRS at the epoch."""
        return self._y0.copy()

    @property
    def source(self) -> str:
        name = "Taylor" if self._method == "taylor" else "DOP853"
        return f"numerical orbit: {self._forces.describe()}, {name} rtol={self._options[0]:g}"

    @property
    def method(self) -> str:
        """The integrator: ``"dop853"`` or ``"taylor"``."""
        return self._method

    @property
    def time_span(self) -> tuple[float, float]:
        """(−inf, inf) until an impact: the orbit is integrated on demand."""
        lo = self._bwd.impact.time if self._bwd.impact else -math.inf
        hi = self._fwd.impact.time if self._fwd.impact else math.inf
        return lo, hi

    def __repr__(self) -> str:
        r = np.round(self._y0[:3] * 1e-3, 6).tolist()
        v = np.round(self._y0[3:] * 1e-3, 9).tolist()
        return (
            f"NumericalOrbit({r}, {v}, {format_epoch(self._epoch)!r}, gravity="
            f"{self.gravity!r}, third_bodies={tuple(b.body for b in self.third_bodies)!r})"
        )

    # -- the integration --------------------------------------------------------------------
    def _integrator(self, direction: float) -> _Integrator:
        if self._method == "taylor":
            g = self._forces.gravity
            n, m = (0, 0) if g is None else (g.degree, g.order)
            return _Integrator(direction, (n, m, len(self._forces.third_bodies)))
        return _Integrator(direction)

    def _advance(self, it: _Integrator, t_out: np.ndarray) -> tuple[np.ndarray, int, float]:
        """Continue ``it`` through ``t_out`` (monotonic in its direction)."""
        rtol, atol, max_step = self._options
        reach = float(t_out[-1]) + it.direction * max_step
        d = self._forces.cover(min(0.0, reach), max(0.0, reach))
        y_out = np.empty((t_out.size, 6))
        impact = np.zeros(6)
        t_out = np.ascontiguousarray(t_out)
        t_stop = it.direction * math.inf
        if self._method == "taylor":
            status, k, ti = _taylor.run(
                d, self._y0, 0.0, t_out, y_out, it.work, it.field, it.tstate, it.counters,
                rtol, atol, t_stop, max_step, 100_000_000, impact,
            )  # fmt: skip
        else:
            status, k, ti = _fk.run(
                d, self._y0, 0.0, t_out, y_out, it.work, it.tstate, it.counters, rtol, atol,
                t_stop, max_step, 100_000_000, impact,
            )  # fmt: skip
        if status == _fk.IMPACT:
            it.impact = Impact(ti, impact, self._epoch)
        elif status != _rk.SUCCESS:
            raise OrbitValueError(
                f"t: the orbit's integration stopped at t = {it.tstate[0]:.6g} s: "
                f"{_rk.STATUS_MESSAGES.get(status, status)}"
            )
        return y_out, k, ti

    def _cover(self, lo: float, hi: float) -> None:
        """Integrate on until the table's nodes cover [lo, hi] (and two nodes beyond)."""
        h = self._h
        j0, j1 = self._covered
        want0 = min(j0, math.floor(lo / h) - 2)
        want1 = max(j1, math.ceil(hi / h) + 2)
        for it, new in (
            (self._fwd, range(j1 + 1, want1 + 1)),
            (self._bwd, range(j0 - 1, want0 - 1, -1)),
        ):
            if not len(new):
                continue
            if it.impact is not None:
                raise it.impact
            idx = np.array(list(new))
            y, k, _ = self._advance(it, idx * h)
            for j in range(k):
                self._nodes[int(idx[j])] = y[j]
            if k < idx.size:
                raise it.impact  # type: ignore[misc]
        self._covered = (want0, want1)
        self._set_table()

    def _set_table(self) -> None:
        """The Hermite table of the nodes reached (marked with the orbit's token: a run that
        propagates the orbit with the attitude finds the models' copies of it by the mark)."""
        keys = sorted(self._nodes)
        st = np.array([self._nodes[j] for j in keys]) * 1e-3
        EphemerisOrbit.__init__(self, np.array(keys, dtype=np.float64) * self._h, st[:, :3],
                                st[:, 3:], self._epoch, self._mu_km,
                                source="numerical orbit")  # fmt: skip
        self._kdata[_sk.E_H + 1] = self.token

    def check_times(self, t: Any, name: str = "t") -> None:
        """Integrate on to cover ``t`` (raise :class:`Impact` for times past an impact)."""
        arr = np.asarray(t, dtype=np.float64)
        if arr.size == 0:
            return
        if not np.all(np.isfinite(arr)):
            raise OrbitValueError(f"{name}: times must be finite")
        lo, hi = float(arr.min()), float(arr.max())
        check_dates(self._epoch, np.array([lo, hi]), name)
        for it, beyond in ((self._fwd, hi), (self._bwd, lo)):
            if it.impact is not None and it.direction * (beyond - it.impact.time) > 0.0:
                raise it.impact
        try:
            self._cover(lo, hi)
        except Impact as exc:
            if hi >= exc.time >= 0.0 or lo <= exc.time <= 0.0:
                raise
            # The impact lies beyond the nodes' margin only: the asked times stay valid.
            self._set_table()

    # -- the Dataset ------------------------------------------------------------------------
    def propagate(self, t: Any) -> Any:
        """The integrator's states at the times ``t`` (its dense output), as a Dataset.

        Parameters
        ----------
        t : array_like or Quantity, shape (n,) [s since the epoch]

        Returns
        -------
        xarray.Dataset
            ``position`` (time, axis) [m] and ``velocity`` [m/s] in the GCRS; attrs ``epoch``,
            ``frame``, ``source``, ``method`` (``"dop853"`` or ``"taylor"``), ``status``
            (``"success"`` or ``"impact"``, then the samples stop at the impact and
            ``impact_time`` [s] gives when).
        """
        import xarray as xr

        tt = np.ascontiguousarray(_as_array(t, "t", "s"), dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(tt)):
            raise OrbitValueError("t: times must be finite")
        check_dates(self._epoch, tt, "t")
        out = np.full((tt.size, 6), np.nan)
        keep = np.ones(tt.size, dtype=bool)
        impact_time = None
        for direction, sel in ((1.0, tt >= 0.0), (-1.0, tt < 0.0)):
            idx = np.flatnonzero(sel)
            if idx.size == 0:
                continue
            order = idx[np.argsort(direction * tt[idx], kind="stable")]
            it = self._integrator(direction)
            y, k, _ti = self._advance(it, tt[order])
            out[order[:k]] = y[:k]
            keep[order[k:]] = False
            if it.impact is not None:
                impact_time = it.impact.time
        time = tt[keep]
        ds = xr.Dataset(
            {
                "position": (
                    ("time", "axis"),
                    out[keep, :3],
                    {"units": "m", "long_name": "position (GCRS)"},
                ),
                "velocity": (
                    ("time", "axis"),
                    out[keep, 3:],
                    {"units": "m s-1", "long_name": "velocity (GCRS)"},
                ),
            },
            coords={
                "time": ("time", time, {"units": "s", "long_name": "time since the epoch"}),
                "axis": ("axis", np.array(["x", "y", "z"])),
            },
            attrs={
                "epoch": format_epoch(self._epoch),
                "frame": "GCRS",
                "source": self.source,
                "status": "impact" if impact_time is not None else "success",
                "method": self._method,
            },
        )
        if impact_time is not None:
            ds.attrs["impact_time"] = impact_time
        return ds

"""The spacecraft: a rigid body with actuators (reaction wheels, magnetorquers, thrusters).

:class:`Spacecraft` is accepted wherever a body is (:func:`attitude.propagate`,
:func:`attitude.propagate_ensemble`, :func:`attitude.initial_state`, the :mod:`attitude.canonical`
conversions). With reaction wheels it is a gyrostat, integrated in the canonical variables of
Arribas et al. (2006) with the wheels' axial momenta beside (q, Q): docs/actuators.md,
:mod:`attitude._core.gyrostat`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._core import actuators as _ka
from ._validation import as_float_array
from .actuators.magnetorquers import Magnetorquer, magnetorquer_record
from .actuators.thrusters import Thruster, thruster_record
from .actuators.wheels import ReactionWheel, wheel_record
from .body import SI_INERTIA, RigidBody
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["Spacecraft"]


def _items(x: Any, cls: type, name: str) -> tuple:
    if x is None:
        return ()
    if isinstance(x, cls):
        return (x,)
    if isinstance(x, (str, bytes)) or not isinstance(x, Sequence):
        raise AttitudeTypeError(
            f"{name}: expected a sequence of attitude.{cls.__name__}, got {type(x).__name__}"
        )
    out = tuple(x)
    for i, item in enumerate(out):
        if not isinstance(item, cls):
            raise AttitudeTypeError(
                f"{name}[{i}]: expected an attitude.{cls.__name__}, got {type(item).__name__}"
            )
    return out


@dataclass(frozen=True, init=False, eq=False)
class Spacecraft:
    """A rigid body with actuators.

    Parameters
    ----------
    body : RigidBody or array_like, shape (3,)
        The spacecraft with its wheels locked: principal moments of inertia I (Basilisk's hub
        inertia of balanced wheels), in the principal axes every actuator is given in. For an
        inertia tensor with products of inertia use :meth:`from_tensor`.
    wheels : sequence of ReactionWheel, optional
        Reaction wheels (:func:`attitude.actuators.pyramid` gives the usual four).
    magnetorquers : sequence of Magnetorquer, optional
    thrusters : sequence of Thruster, optional
    orbit : orbit.Orbit, optional
        Where the actuators (and sensors) find the magnetic field, the Sun and the position;
        needed with magnetorquers (a dated orbit for the IGRF field). It must be the orbit of
        the environment models when both are given.
    center_of_mass : array_like or Quantity, shape (3,), optional
        Centre of mass in body axes (m): the thrusters' lever arms are taken from it
        (default: the origin of the body axes).
    field : {"igrf", "dipole"} or array_like, shape (3,)
        The magnetorquers' field, as for :class:`attitude.MagneticDipole` (default IGRF).
    mass : float or Quantity, optional
        The spacecraft's mass (kg), propellant included. With an :class:`orbit.NumericalOrbit`
        the orbit and the attitude are propagated together (:mod:`attitude._core.coupled`):
        the gravity gradient's back-reaction and the thrusters' force act on the orbit, and
        the thrusters' propellant (``Thruster(..., isp=...)``) lowers the mass. Such a run is
        in SI: a body given in plain numbers is read in kg m² (``body.units`` says so).

    Raises
    ------
    AttitudeValueError
        Ĩ = I − Σ J_k a_k a_kᵀ is not positive definite (the wheels' axial inertia is larger
        than the spacecraft's about their axes), magnetorquers without an orbit...
    """

    body: RigidBody
    wheels: tuple[ReactionWheel, ...]
    magnetorquers: tuple[Magnetorquer, ...]
    thrusters: tuple[Thruster, ...]
    orbit: Any
    center_of_mass: np.ndarray
    field: Any
    mass: float | None

    def __init__(
        self,
        body: Any,
        wheels: Any = (),
        magnetorquers: Any = (),
        thrusters: Any = (),
        orbit: Any = None,
        *,
        center_of_mass: Any = None,
        field: Any = "igrf",
        mass: Any = None,
    ):
        s = object.__setattr__
        if isinstance(body, Spacecraft):
            raise AttitudeTypeError("body: expected a RigidBody, got a Spacecraft")
        b = body if isinstance(body, RigidBody) else RigidBody(body)
        s(self, "body", b)
        s(self, "wheels", _items(wheels, ReactionWheel, "wheels"))
        s(self, "magnetorquers", _items(magnetorquers, Magnetorquer, "magnetorquers"))
        s(self, "thrusters", _items(thrusters, Thruster, "thrusters"))
        if center_of_mass is None:
            cm = np.zeros(3)
        else:
            cm = as_float_array(center_of_mass, "center_of_mass", unit="m")
            if cm.shape != (3,):
                raise AttitudeValueError(
                    f"center_of_mass: expected 3 body-axis components (m), got shape {cm.shape}"
                )
        cm = cm.copy()  # (read-only: the caller's array stays writable)
        cm.setflags(write=False)
        s(self, "center_of_mass", cm)
        if orbit is not None and not hasattr(orbit, "kernel_data"):
            raise AttitudeTypeError(
                f"orbit: expected an orbit (orbit.KeplerOrbit, orbit.SecularJ2Orbit, "
                f"orbit.EphemerisOrbit), got {type(orbit).__name__}"
            )
        s(self, "orbit", orbit)
        if mass is not None:
            m = float(as_float_array(mass, "mass", unit="kg").reshape(()))
            if not (math.isfinite(m) and m > 0.0):
                raise AttitudeValueError(f"mass: a positive number of kilograms, got {m!r}")
            mass = m
        s(self, "mass", mass)
        if self.coupled and b.units is None:
            # its orbit's forces are SI (kg, m, s): a body in plain numbers is in kg m² here,
            # and its results say so
            s(self, "body", RigidBody(b.inertia, units=SI_INERTIA))
        from .potentials import check_field

        check_field(field)  # an unknown name is refused with or without magnetorquers
        s(self, "field", field)
        self._field_model()  # checks the field setting and the orbit before any work
        # Ĩ = I − Σ J a aᵀ must be positive definite (the rest of the body has positive inertia
        # about every axis).
        it = self.locked_less_wheels()
        ev = np.linalg.eigvalsh(it)
        if not ev[0] > 1e-12 * float(np.max(b.inertia)):
            axis = np.linalg.eigh(it)[1][:, 0]
            raise AttitudeValueError(
                f"wheels: the wheels' axial inertias leave the rest of the spacecraft with "
                f"inertia {ev[0]:.3g} about {np.round(axis, 6).tolist()} (I − Σ J a aᵀ must be "
                "positive definite): a wheel's inertia cannot exceed the spacecraft's about "
                "its axis; check the wheel inertias (kg m²) against the body's"
            )
        s(self, "_minv", np.linalg.inv(it))

    # --- construction helpers ----------------------------------------------------------
    @classmethod
    def from_tensor(
        cls,
        J: Any,
        wheels: Any = (),
        magnetorquers: Any = (),
        thrusters: Any = (),
        orbit: Any = None,
        *,
        center_of_mass: Any = None,
        field: Any = "igrf",
        units: str | None = None,
        mass: Any = None,
    ) -> tuple[Spacecraft, np.ndarray]:
        """A spacecraft from its inertia tensor and actuators given in a structural frame F.

        The tensor is diagonalised (:meth:`attitude.RigidBody.from_tensor`) and every
        actuator's geometry (wheel and magnetorquer axes, thruster positions and directions,
        the centre of mass) is rotated from F to the principal axes P, where the spacecraft is
        integrated; wheel axes then rarely lie on principal axes, which the gyrostat handles
        (Ĩ is a full matrix).

        Returns
        -------
        spacecraft : Spacecraft
            In principal axes.
        q_pf : ndarray, shape (4,)
            The rotation from P to F (``x_F = q_pf∘x_P∘q̃_pf``): the attitude of the principal
            axes is ``q_sp = q_sf∘q_pf`` for a structural attitude ``q_sf``, and
            ``quaternion.multiply(ds.q, quaternion.conjugate(q_pf))`` turns results back.
        """
        from .quaternion import to_matrix

        body, q_pf = RigidBody.from_tensor(J, units=units)
        R = to_matrix(q_pf)  # x_F = R x_P

        def to_p(v):
            return R.T @ np.asarray(v, dtype=np.float64)

        ws = tuple(_replace(w, axis=to_p(w.axis)) for w in _items(wheels, ReactionWheel, "wheels"))
        ms = tuple(
            _replace(m, axis=to_p(m.axis))
            for m in _items(magnetorquers, Magnetorquer, "magnetorquers")
        )
        ts = tuple(
            _replace(t, position=to_p(t.position), direction=to_p(t.direction))
            for t in _items(thrusters, Thruster, "thrusters")
        )
        cm = None
        if center_of_mass is not None:
            cm = to_p(as_float_array(center_of_mass, "center_of_mass", unit="m"))
        sc = cls(body, ws, ms, ts, orbit, center_of_mass=cm, field=field, mass=mass)
        return sc, q_pf

    def with_wheel_speeds(self, speeds: Any) -> Spacecraft:
        """The same spacecraft with its wheels starting at ``speeds`` (n_wheels, rad/s)."""
        from .actuators._common import speeds_value

        sp = as_float_array(speeds_value(speeds, "speeds"), "speeds")
        if sp.shape != (len(self.wheels),):
            raise AttitudeValueError(
                f"speeds: expected {len(self.wheels)} wheel speeds, got shape {sp.shape}"
            )
        ws = tuple(w.with_speed(float(v)) for w, v in zip(self.wheels, sp, strict=True))
        return Spacecraft(
            self.body, ws, self.magnetorquers, self.thrusters, self.orbit,
            center_of_mass=self.center_of_mass, field=self.field, mass=self.mass,
        )  # fmt: skip

    # --- properties ------------------------------------------------------------------------
    @property
    def has_actuators(self) -> bool:
        """True with any wheel, magnetorquer or thruster."""
        return bool(self.wheels or self.magnetorquers or self.thrusters)

    @property
    def coupled(self) -> bool:
        """True when the orbit is propagated with the attitude: a mass on a NumericalOrbit."""
        from orbit import NumericalOrbit

        return self.mass is not None and isinstance(self.orbit, NumericalOrbit)

    @property
    def counts(self) -> tuple[int, int, int]:
        """(wheels, magnetorquers, thrusters)."""
        return len(self.wheels), len(self.magnetorquers), len(self.thrusters)

    @property
    def units(self) -> str | None:
        """The body's unit system (``"kg m^2"``: SI; None: dimensionless)."""
        return self.body.units

    @property
    def inertia(self) -> np.ndarray:
        """Principal moments of the spacecraft with its wheels locked, shape (3,)."""
        return self.body.inertia

    def locked_less_wheels(self) -> np.ndarray:
        """Ĩ = I − Σ J_k a_k a_kᵀ, shape (3, 3): the inertia the wheels' spin leaves out."""
        it = np.diag(self.body.inertia).astype(np.float64)
        for w in self.wheels:
            it = it - w.inertia * np.outer(w.axis, w.axis)
        return it

    @property
    def wheel_axes(self) -> np.ndarray:
        """Spin axes, shape (n_wheels, 3)."""
        return np.array([w.axis for w in self.wheels]).reshape(-1, 3)

    @property
    def wheel_inertias(self) -> np.ndarray:
        """Axial inertias J_k, shape (n_wheels,)."""
        return np.array([w.inertia for w in self.wheels], dtype=np.float64)

    @property
    def wheel_speeds(self) -> np.ndarray:
        """Initial wheel speeds relative to the body (rad/s), shape (n_wheels,)."""
        return np.array([w.speed for w in self.wheels], dtype=np.float64)

    def names(self) -> tuple[list[str], list[str], list[str]]:
        """Result labels of the wheels, magnetorquers and thrusters."""

        def label(items, stem):
            out = []
            for i, a in enumerate(items):
                n = a.name or f"{stem}{i + 1}"
                k = 2
                base = n
                while n in out:
                    n, k = f"{base}_{k}", k + 1
                out.append(n)
            return out

        return (
            label(self.wheels, "wheel"),
            label(self.magnetorquers, "magnetorquer"),
            label(self.thrusters, "thruster"),
        )

    # --- the gyrostat's state ----------------------------------------------------------------
    def wheel_momenta(self, omega: Any, speeds: Any = None) -> np.ndarray:
        """Axial momenta h_k = J_k (a_k·ω + Ω_k), shape (..., n_wheels).

        Parameters
        ----------
        omega : array_like, shape (..., 3)
            Body angular velocity.
        speeds : array_like, shape (..., n_wheels), optional
            Wheel speeds relative to the body (default: the wheels' initial speeds).
        """
        om = np.asarray(omega, dtype=np.float64)
        sp = self.wheel_speeds if speeds is None else np.asarray(speeds, dtype=np.float64)
        return self.wheel_inertias * (om @ self.wheel_axes.T + sp)

    def body_momentum(self, omega: Any, speeds: Any = None) -> np.ndarray:
        """Total angular momentum in body axes g = I ω + Σ J_k Ω_k a_k, shape (..., 3)."""
        om = np.asarray(omega, dtype=np.float64)
        sp = self.wheel_speeds if speeds is None else np.asarray(speeds, dtype=np.float64)
        return om * self.body.inertia + (sp * self.wheel_inertias) @ self.wheel_axes

    def rate_from_momentum(self, g: Any, speeds: Any = None) -> np.ndarray:
        """Body angular velocity ω = I⁻¹ (g − Σ J_k Ω_k a_k) from the total body momentum."""
        gg = np.asarray(g, dtype=np.float64)
        sp = self.wheel_speeds if speeds is None else np.asarray(speeds, dtype=np.float64)
        return (gg - (sp * self.wheel_inertias) @ self.wheel_axes) / self.body.inertia

    # --- compiled-layer data -------------------------------------------------------------------
    def _field_model(self) -> Any:
        """The MagneticDipole whose table the magnetorquers read (None without them)."""
        if not self.magnetorquers:
            return None
        from .potentials import MagneticDipole

        if self.orbit is None and isinstance(self.field, str):
            raise AttitudeValueError(
                "orbit: magnetorquers act in the geomagnetic field along the spacecraft's orbit; "
                "give Spacecraft(..., orbit=...) (a dated orbit for field='igrf')"
            )
        cache = self.__dict__.get("_field_cache")
        if cache is None:
            cache = MagneticDipole(self.orbit, [0.0, 0.0, 0.0], self.field)
            object.__setattr__(self, "_field_cache", cache)
        return cache

    def block(self, t: Any) -> np.ndarray:
        """The spacecraft block of the compiled kernels for a run at the times ``t`` (the field
        table of the magnetorquers covers them); held slots zero."""
        nw, nm, nt = self.counts
        head = _ka.SC.pack(nw=nw, nm=nm, nt=nt, minv=self._minv, mtq=-1.0, coupled=-1.0)
        parts = [head]
        parts += [wheel_record(w) for w in self.wheels]
        parts += [magnetorquer_record(m) for m in self.magnetorquers]
        parts += [thruster_record(th, self.center_of_mass) for th in self.thrusters]
        sc = np.concatenate(parts) if len(parts) > 1 else head
        fm = self._field_model()
        if fm is not None:
            tt = np.asarray(t, dtype=np.float64).reshape(-1)
            fm.prepare(tt)
            fb = fm._kernel_params(tt)
            sc[_ka.SC.MTQ] = sc.shape[0]
            sc = np.concatenate([sc, fb])
        if self.coupled:
            from orbit import Impact
            from orbit import _state_kernels as _sk

            from ._core import coupled as _kc
            from .environment import OMEGA_EARTH

            tt = np.asarray(t, dtype=np.float64).reshape(-1)
            try:  # the orbit's own path (without the spacecraft's forces) over the run
                self.orbit.check_times(tt, "t")
            except Impact:  # it ends at the surface: the run itself stops where it does
                pass
            forces = self.orbit._forces.cover(float(tt.min()), float(tt.max()))
            path = np.array(self.orbit.kernel_data(), dtype=np.float64)  # its own path
            co = sc.shape[0]
            head = _kc.COUPLED.pack(
                iy=8 + nw, forces=co + _kc.COUPLED.SIZE, pred=co + _kc.COUPLED.SIZE + forces.size,
                mu=self.orbit.mu * 1e9, inertia=self.body.inertia, omega_earth=OMEGA_EARTH,
                field_step=self.orbit.field_step if self.orbit.perturbed else 0.0,
            )  # fmt: skip
            path[_sk.E_H + 1] = 0.0  # (not the orbit's mark: this copy stays a table)
            sc[_ka.SC.COUPLED] = co
            sc = np.concatenate([sc, head, forces, path])
        return np.ascontiguousarray(sc, dtype=np.float64)

    def check_orbit(self, potential_orbit: Any) -> None:
        """Raise unless the environment models' orbit is this spacecraft's (when both exist);
        a spacecraft carrying its orbit may also take a model on another state of the same
        orbit model (an ensemble's dispersed member and the model's nominal orbit:
        ``NumericalOrbit.with_state``)."""
        if self.orbit is None or potential_orbit is None or potential_orbit is self.orbit:
            return
        if self.coupled and getattr(potential_orbit, "_forces", None) is self.orbit._forces:
            return
        a = np.asarray(self.orbit.kernel_data())
        b = np.asarray(potential_orbit.kernel_data())
        same = a.shape == b.shape and bool(np.array_equal(a, b))
        ea, eb = getattr(self.orbit, "epoch", None), getattr(potential_orbit, "epoch", None)
        if same and (ea is None) != (eb is None):
            same = False
        elif same and ea is not None:
            from orbit.timescales import same_epoch

            same = same_epoch(ea, eb)
        if not same:
            raise AttitudeValueError(
                "orbit: the spacecraft's orbit differs from the orbit of the environment models "
                "(potential.orbit); one run has one orbit: build both from the same orbit object"
            )

    def describe(self) -> str:
        """One-line description recorded in result attrs."""
        return repr(self)

    def __repr__(self) -> str:
        parts = [f"body={self.body!r}"]
        nw, nm, nt = self.counts
        if nw:
            parts.append(f"wheels={nw}")
        if nm:
            parts.append(f"magnetorquers={nm}")
        if nt:
            parts.append(f"thrusters={nt}")
        if self.orbit is not None:
            parts.append(f"orbit={type(self.orbit).__name__}")
        if self.mass is not None:
            parts.append(f"mass={self.mass!r}")
        return f"Spacecraft({', '.join(parts)})"


def _replace(obj: Any, **changes: Any) -> Any:
    """A copy of a frozen actuator with some fields replaced (already validated values)."""
    new = object.__new__(type(obj))
    for k, v in vars(obj).items():
        object.__setattr__(new, k, v)
    for k, v in changes.items():
        arr = np.asarray(v, dtype=np.float64)
        if arr.ndim == 1:
            arr = arr / (np.linalg.norm(arr) if k in ("axis", "direction") else 1.0)
            arr.setflags(write=False)
        object.__setattr__(new, k, arr)
    return new


def as_spacecraft(body: Any) -> Spacecraft | None:
    """The Spacecraft if ``body`` is one with actuators (or a coupled orbit), else None."""
    if isinstance(body, Spacecraft) and (body.has_actuators or body.coupled):
        return body
    return None

"""Potentials and torques acting on the body.

One concept, the torque models of the public namespace ``attitude.potentials`` (a contract):
the base class and sums, the built-in, environment and user models side by side, each a small
class over data for the compiled kernels; their kernels live in ``_core/potentials.py`` and
``_core/environment.py``, the environment along the orbit in ``attitude/environment.py``.

A potential gives, for an attitude ``q`` at time ``t``: its value U(q, t), the body-frame torque
τ_B(q, t) and the generalised force that enters Hamilton's equations (Arribas et al. eq. 7),

    F = 2 q∘(0, τ_B)        (Schwab eq. 25)

which is minus the tangential part of ∂U/∂q. Using F instead of a plain −∂U/∂q of the
quadratic forms in eqs. 18 and 20 keeps |q| = 1 and q·Q = 0 exact invariants of the flow.

Built in: :class:`TorqueFree`, :class:`HeavyTop`, :class:`GravityGradient`, and the
environment of a spacecraft in Earth orbit: :class:`MagneticDipole`, :class:`EddyCurrentDamping`,
:class:`AerodynamicDrag`, :class:`SolarRadiation` (surfaces: :class:`attitude.Facet`). User physics:
:class:`CustomPotential` (write U(q, t), the torque is derived exactly by complex-step
differentiation) and :class:`CustomTorque` (write τ_B(q, t) directly). All of them run inside
the compiled integrators.
"""

from __future__ import annotations

import math
from enum import IntEnum
from typing import Any, ClassVar

import numpy as np

from orbit._shared_jit import JIT_DISABLED

from . import _user_kernels
from . import environment as _env
from ._core import environment as _ke
from ._core import models as _models
from ._core import potentials as _kp
from ._validation import as_float_array, as_quaternion, as_scalar
from .body import RigidBody
from .errors import AttitudeTypeError, AttitudeValueError
from .facets import Facet, drag_groups, facet_array, optical_groups

__all__ = [
    "AerodynamicDrag",
    "CustomPotential",
    "CustomTorque",
    "EddyCurrentDamping",
    "EnvironmentIndex",
    "Facet",
    "GravityGradient",
    "HeavyTop",
    "MagneticDipole",
    "Potential",
    "SolarRadiation",
    "Sum",
    "TorqueFree",
]


class Potential:
    """Base class: a torque model acting on a rigid body, with its potential where it has one.

    Models add: ``GravityGradient(orbit) + CustomTorque(tau)`` is one model (:class:`Sum`)
    whose torque is the sum of its terms' torques. Subclasses provide either a built-in kind
    code and numbers (the package's cached entry points, :mod:`attitude._core.entry_points`)
    or user functions, compiled into entry points of their own in the user cache
    (:mod:`attitude._user_kernels`).
    """

    #: Short name recorded in result attrs and naming the model's torque in results.
    name: str = "potential"
    #: Whether U is known (False for a torque given without its potential).
    has_potential: bool = True
    #: Whether the model depends explicitly on time.
    time_dependent: bool = False
    #: Whether the torque depends on the body angular velocity (e.g. damping).
    rate_dependent: bool = False

    # --- compiled-layer hooks -------------------------------------------------------------
    _kind: int | None = None  # built-in kind code, or None for user kernels

    def _potential_params(self) -> list[float]:
        return []

    def _params(self, inertia: np.ndarray) -> np.ndarray:
        """Parameter vector for the compiled kernels (inertia first, see _core.potentials)."""
        kind = _kp.KIND_USER if self._kind is None else self._kind
        head = np.array([*inertia, kind, *self._potential_params()], dtype=np.float64)
        env = self._user_env_blocks()
        if not env:
            return head
        # a user model alone: the environment's directory at P0 (_core.potentials)
        assert kind == _kp.KIND_USER and head.shape[0] == _kp.P0
        return np.concatenate([head, _user_environment(_kp.P0, env)])

    def _user_terms(self) -> tuple:
        """The user terms (kind, torque, potential) compiled into a user module; () if none."""
        return ()

    def _user_env_blocks(self) -> tuple[np.ndarray, ...]:
        """The environment blocks of the user terms that read it, in order; () if none."""
        return ()

    def _entry_points(self):
        """The compiled entry points of this model (:mod:`attitude._core.entry_points`, or their
        copy for this kind of model alone: :mod:`attitude._core.models`)."""
        terms = self._user_terms()
        if terms:
            return _user_kernels.entry_points(terms, potential=self)
        return _models.entry_points(self._kind)

    def _inertia_for_eval(self) -> np.ndarray:
        return np.ones(3)

    @property
    def terms(self) -> tuple[Potential, ...]:
        """The models this one adds up, in the order of the compiled terms (itself if one)."""
        return (self,)

    def term_names(self) -> list[str]:
        """Names of the terms (unique: a repeated name gets ``_2``, ``_3``, ...)."""
        out: list[str] = []
        for term in self.terms:
            name, k = term.name, 2
            while name in out:
                name, k = f"{term.name}_{k}", k + 1
            out.append(name)
        return out

    def __add__(self, other: Any) -> Potential:
        if not isinstance(other, Potential):
            return NotImplemented
        return Sum(self, other)

    def __radd__(self, other: Any) -> Potential:
        if isinstance(other, (int, float)) and other == 0:  # sum([...]) starts from 0
            return self
        return NotImplemented

    # --- public evaluation --------------------------------------------------------------------
    def _eval(self, q: Any, t: Any, omega: Any = None) -> tuple[np.ndarray, np.ndarray]:
        q = as_quaternion(q, "q")
        nq = np.linalg.norm(q, axis=-1)
        if np.any(np.abs(nq - 1.0) > 1e-6):
            raise AttitudeValueError("q: potentials are evaluated at unit quaternions")
        t = as_float_array(t, "t", unit="s")
        self.check_times(t, "t")  # e.g. an ephemeris orbit's table span
        if omega is None:
            if self.rate_dependent:
                raise AttitudeValueError(
                    f"omega: the {self.name} torque depends on the body angular velocity; give "
                    "omega= (rad/s, body axes)"
                )
            w = np.zeros(3)
        else:
            w = as_float_array(omega, "omega", trailing=3, unit="rad / s")
        shape = np.broadcast_shapes(q.shape[:-1], t.shape, w.shape[:-1])
        # C-ordered writable float64 (a read-only broadcast view compiles the loop again)
        qf = np.require(np.broadcast_to(q, (*shape, 4)).reshape(-1, 4), np.float64, ["C", "W"])
        wf = np.require(np.broadcast_to(w, (*shape, 3)).reshape(-1, 3), np.float64, ["C", "W"])
        tf = np.require(np.broadcast_to(t, shape).reshape(-1), np.float64, ["C", "W"])
        params = self.prepare(tf)._params(self._inertia_for_eval())
        tau = np.empty((qf.shape[0], 3))
        u = np.empty(qf.shape[0])
        self._entry_points().evaluate(qf, wf, tf, params, tau, u)
        return tau.reshape((*shape, 3)), u.reshape(shape)

    def value(self, q: Any, t: Any = 0.0) -> np.ndarray:
        """Potential energy U(q, t) (of a sum: of the terms that have one).

        Parameters
        ----------
        q : array_like, shape (..., 4)
            Unit attitude quaternion (body → space).
        t : float or array_like
            Time (broadcast against q).

        Returns
        -------
        U : ndarray, shape (...)
        """
        if not self.has_potential:
            raise AttitudeValueError(
                f"{self.name}: the potential is unknown (the torque was given directly); give "
                f"potential= to CustomTorque to have energies"
            )
        return self._eval(q, t, None if not self.rate_dependent else np.zeros(3))[1]

    def torque(self, q: Any, t: Any = 0.0, omega: Any = None) -> np.ndarray:
        """Body-frame torque τ_B(q, ω, t).

        Parameters
        ----------
        q : array_like, shape (..., 4)
            Unit attitude quaternion (body → space).
        t : float or array_like
            Time (broadcast against q).
        omega : array_like, shape (..., 3), optional
            Body angular velocity (rad/s, body axes); needed by rate-dependent models only.

        Returns
        -------
        tau : ndarray, shape (..., 3)
        """
        return self._eval(q, t, omega)[0]

    def generalized_force(self, q: Any, t: Any = 0.0, omega: Any = None) -> np.ndarray:
        """Generalised force 2 q∘(0, τ_B) of Schwab eq. 25 (the Q̇ term of eq. 7).

        Returns
        -------
        F : ndarray, shape (..., 4)
        """
        from .quaternion import multiply

        tau = self.torque(q, t, omega)
        q = as_quaternion(q, "q")
        return 2.0 * multiply(q, np.concatenate([np.zeros((*tau.shape[:-1], 1)), tau], -1))

    def describe(self) -> str:
        """One-line description recorded in result attrs."""
        return repr(self)

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise if the model is undefined at some of the times ``t`` (default: never)."""

    def bind(self, body: RigidBody) -> Potential:
        """The potential as used with ``body`` (checks consistency; most return self)."""
        return self

    def prepare(self, t: Any) -> Potential:
        """The model ready for a run at the times ``t`` (most return self).

        Models that tabulate the environment along the orbit (magnetic field, atmosphere, Sun)
        compute their tables here, once, for the span of ``t`` (:mod:`attitude.environment`);
        :func:`attitude.propagate` calls it before building the compiled parameters, and so do
        ``torque``/``value`` for the times they are given.

        Parameters
        ----------
        t : array_like, shape (m,)
            The run's times [s] (only the smallest and largest matter).
        """
        return self


class TorqueFree(Potential):
    """No external torque: the Euler–Poinsot problem (Arribas et al. Sect. 6.1 with x^c = 0)."""

    name = "torque_free"
    _kind = _kp.KIND_TORQUE_FREE

    def __repr__(self) -> str:
        return "TorqueFree()"


class HeavyTop(Potential):
    """A heavy body about a fixed point O in uniform gravity along −s3 (Arribas et al. Sect. 6.1).

    Parameters
    ----------
    weight : float or Quantity
        M g > 0 (force units consistent with the inertia and time units: N for a body in SI,
        i.e. with units; a Quantity is converted to N).
    center_of_mass : array_like or Quantity, shape (3,)
        Position of the centre of mass relative to O, in body axes (m for a Quantity). With
        the inertia in kg m² the torque is in N m and the energy in J.

    Notes
    -----
    V(q) = weight · (q∘x^c∘q̃)·s3, the physical potential energy (height of the centre of mass
    times the weight). Arribas et al. eq. 18 prints U = x^c·F with F = −Mg s3 in body axes,
    which is −V: with that sign the "heavy" top would fall upwards. The torque is
    τ_B = x^c × F_B, F_B = q̃∘(−weight s3)∘q. See docs/potentials.md.
    """

    name = "heavy_top"
    _kind = _kp.KIND_HEAVY_TOP

    def __init__(self, weight: Any, center_of_mass: Any):
        w = as_scalar(weight, "weight", unit="N")
        if not w > 0:
            raise AttitudeValueError(f"weight: must be M g > 0, got {w}")
        c = as_float_array(center_of_mass, "center_of_mass", unit="m")
        if c.shape != (3,):
            raise AttitudeValueError(
                f"center_of_mass: expected 3 body-axis components, got shape {c.shape}"
            )
        self.weight = w
        self.center_of_mass = c

    def _potential_params(self) -> list[float]:
        return [self.weight, *self.center_of_mass]

    def __repr__(self) -> str:
        return f"HeavyTop(weight={self.weight!r}, center_of_mass={self.center_of_mass.tolist()})"


class GravityGradient(Potential):
    """Gravity-gradient torque of a central mass on a body moving along an orbit (eq. 20).

    U = 3μ/(2r³) x̂_B·I x̂_B, x̂_B = q̃∘r̂_S∘q, with r(t) and the radial direction r̂_S(t) from the
    orbit at the same t, evaluated inside the compiled right-hand side (Arribas et al.
    Sect. 6.2). Torque τ_B = 3μ/r³ x̂_B × (I x̂_B).

    Parameters
    ----------
    orbit : orbit.KeplerOrbit, orbit.SecularJ2Orbit or orbit.EphemerisOrbit
        The orbit of the centre of mass (any :class:`orbit.base.Orbit`: km, s; μ in km³ s⁻²).
        The compiled kernels read it through ``orbit.kernel_data()`` (one dispatcher over the
        orbit types), so every source runs in the same cached integrator.
    inertia : RigidBody or array_like, optional
        The body's principal moments (a RigidBody with units is in kg m²). Needed only to
        evaluate ``value``/``torque`` directly; :func:`attitude.propagate` takes them from the
        body.

    Notes
    -----
    3μ/r³ is in s⁻² whatever the length unit (μ in km³ s⁻², r in km), so a body in SI
    (kg m²) gets U in J and τ_B in N m with no conversion.
    """

    name = "gravity_gradient"
    _kind = _kp.KIND_GRAVITY_GRADIENT
    time_dependent = True

    def __init__(self, orbit: Any, inertia: Any = None):
        if not hasattr(orbit, "kernel_data"):
            raise AttitudeTypeError(
                "orbit: expected an orbit (orbit.KeplerOrbit, orbit.SecularJ2Orbit, "
                f"orbit.EphemerisOrbit), got {type(orbit).__name__}"
            )
        self.orbit = orbit
        self._orbit_data = np.ascontiguousarray(orbit.kernel_data(), dtype=np.float64)
        if inertia is None:
            self.inertia = None
        elif isinstance(inertia, RigidBody):
            self.inertia = inertia.inertia
        else:
            self.inertia = RigidBody(inertia).inertia

    def _params(self, inertia: np.ndarray) -> np.ndarray:
        head = np.array([*inertia, self._kind], dtype=np.float64)
        return np.concatenate([head, self._orbit_data])

    def _potential_params(self) -> list[float]:
        return list(self._orbit_data)

    def check_times(self, t: Any, name: str = "t") -> None:
        """Raise if the orbit is not defined at some of the times (an ephemeris table's span)."""
        self.orbit.check_times(t, name)

    def _entry_points(self):
        return _models.entry_points(self._kind, self._orbit_data)

    def _inertia_for_eval(self) -> np.ndarray:
        if self.inertia is None:
            raise AttitudeValueError(
                "inertia: GravityGradient needs the body's principal moments to evaluate U or "
                "the torque; give GravityGradient(orbit, inertia=...) (propagate supplies them)"
            )
        return self.inertia

    def bind(self, body: RigidBody) -> GravityGradient:
        if self.inertia is not None and not np.allclose(self.inertia, body.inertia, rtol=1e-12):
            raise AttitudeValueError(
                f"inertia: the GravityGradient was built for inertia {self.inertia.tolist()} but "
                f"the body has {body.inertia.tolist()}; they must be the same body"
            )
        return GravityGradient(self.orbit, body)

    def __repr__(self) -> str:
        return f"GravityGradient(orbit={self.orbit!r})"


# --------------------------------------------------------------------------------------------
# User physics
# --------------------------------------------------------------------------------------------


def _compile_user(func: Any, what: str):
    if JIT_DISABLED:
        return func
    import numba
    from numba.core.registry import CPUDispatcher

    if isinstance(func, CPUDispatcher):
        return func
    if not callable(func):
        raise AttitudeTypeError(f"{what}: expected a function, got {type(func).__name__}")
    return numba.njit(func)


class CustomPotential(Potential):
    """A user potential U(q, t); the torque is derived exactly by complex-step differentiation.

    Parameters
    ----------
    potential : callable
        ``U(q, t) -> float`` with ``q`` a length-4 array. It is compiled with numba (a plain
        function is jitted for you) and must also accept a *complex* ``q``: use arithmetic and
        numpy functions (``np.sqrt``, ``np.cos``), not ``math.*`` or comparisons on q.
    name : str, optional
        Recorded in result attrs.
    time_dependent : bool
        Whether U depends on t explicitly (informs the splitting integrators).

    Notes
    -----
    With ∇U the four partial derivatives, τ_B = −½ vec(q̃∘∇U): the generalised force
    2 q∘(0, τ_B) is then minus the tangential part of ∇U, and any radial part (U not
    homogeneous of degree 0 in q) drops out. See docs/potentials.md for examples (a constant
    body torque, a magnetic dipole in a fixed field).
    """

    def __init__(self, potential: Any, *, name: str = "custom_potential", time_dependent=True):
        U = _compile_user(potential, "potential")
        self._U = U
        self.name = name
        self.time_dependent = bool(time_dependent)
        try:
            val = U(np.array([1.0, 0.0, 0.0, 0.0]) + 0j, 0.0)
            complex(val)
        except Exception as exc:
            raise AttitudeTypeError(
                "potential: must be a numba-compilable function U(q, t) -> float that also "
                "accepts a complex q (complex-step differentiation): use arithmetic and numpy "
                "functions (np.sqrt, np.cos), or give the torque directly with CustomTorque. "
                f"Compiling it with a complex q failed: {_user_kernels.compile_failure(exc)}"
            ) from None

    def _user_terms(self) -> tuple:
        return (("potential", None, self._U),)

    def __repr__(self) -> str:
        return f"CustomPotential({getattr(self._U, '__name__', 'U')}, name={self.name!r})"


class EnvironmentIndex(IntEnum):
    """Where each quantity sits in the array ``env`` a :class:`CustomTorque` with an orbit reads.

    ``env[EnvironmentIndex.FIELD : EnvironmentIndex.FIELD + 3]`` is the geomagnetic field, and so
    on (vectors of 3 unless noted; NaN where unavailable: the field with ``field=None``, the
    Sun's entries for an orbit without an epoch). numba reads the members as constants.

    ============  ==========================================================================
    FIELD         geomagnetic field B [T], body axes (the table of :class:`MagneticDipole`)
    SUN           unit vector from the spacecraft to the Sun, body axes
    R             position [km], space axes (GCRS)
    V             velocity [km/s], space axes
    Q_RSW         4: the orbital frame (x radial, y along-track, z orbit normal; the frame
                  :func:`attitude.frames.rsw`) → space quaternion, scalar first
    SUN_DISTANCE  distance from the spacecraft to the Sun [km]
    SHADOW        fraction of the Sun's disk seen past the Earth (conical shadow with penumbra,
                  Montenbruck & Gill 2000): 1 sunlit, 0 umbra
    ============  ==========================================================================

    ``len(env)`` is :data:`ENVIRONMENT_SIZE`. The field and the Sun's direction are those of the
    flight software's measurements (:class:`attitude.software.MeasurementIndex` FIELD, SUN, R,
    V), computed from the same tables.
    """

    FIELD = _ke.ENV_FIELD
    SUN = _ke.ENV_SUN
    R = _ke.ENV_R
    V = _ke.ENV_V
    Q_RSW = _ke.ENV_Q_RSW  # 4
    SUN_DISTANCE = _ke.ENV_SUN_DISTANCE  # 1
    SHADOW = _ke.ENV_SHADOW  # 1


#: Length of the environment vector ``env`` of a :class:`CustomTorque` with an orbit.
ENVIRONMENT_SIZE = _ke.ENV_SIZE


def _probe_environment() -> np.ndarray:
    """A plausible environment (LEO, lit) to compile and check a user's torque with."""
    env = np.zeros(_ke.ENV_SIZE)
    env[_ke.ENV_FIELD : _ke.ENV_FIELD + 3] = (1.0e-5, -2.0e-5, 3.0e-5)
    env[_ke.ENV_SUN : _ke.ENV_SUN + 3] = (0.6, 0.0, 0.8)
    env[_ke.ENV_R : _ke.ENV_R + 3] = (7000.0, 0.0, 0.0)
    env[_ke.ENV_V : _ke.ENV_V + 3] = (0.0, 7.5, 0.0)
    env[_ke.ENV_Q_RSW] = 1.0
    env[_ke.ENV_SUN_DISTANCE] = 1.496e8
    env[_ke.ENV_SHADOW] = 1.0
    return env


def _user_environment(start: int, blocks: tuple[np.ndarray, ...]) -> np.ndarray:
    """The environment blocks of the user terms placed at ``params[start]``: their offsets
    (absolute, in the order of the terms), then the blocks (the layout of
    :mod:`attitude._core.potentials`); empty without blocks."""
    if not blocks:
        return np.zeros(0)
    offsets, at = [], start + len(blocks)
    for b in blocks:
        offsets.append(at)
        at += b.shape[0]
    return np.concatenate([np.array(offsets, dtype=np.float64), *blocks])


class _TorqueEnvironment:
    """The tables a user torque's ``env`` reads, over a run's span (built once per span).

    The field is the table of a :class:`MagneticDipole` on the same orbit (field model and
    step), the orbit its ``kernel_data()``, the Sun the table of :class:`orbit.sun.SunTable`
    over the span with the flight software's one-minute margins; the block layout is in
    :mod:`attitude._core.environment` (``environment_vector``).
    """

    def __init__(self, orbit: Any, field: Any, step: Any):
        self.orbit = orbit
        self.field = field
        # the field's table is a magnetic dipole's (a zero dipole: only its table is read)
        self._field = None
        if field is not None:
            self._field = MagneticDipole(orbit, np.zeros(3), field, step=step)
        self._orbit_data = np.ascontiguousarray(orbit.kernel_data(), dtype=np.float64)
        self._block: np.ndarray | None = None
        self._covers: tuple[float, float] | None = None

    def prepare(self, t: Any) -> None:
        arr = np.asarray(t, dtype=np.float64).reshape(-1)
        if arr.size == 0:
            return
        lo, hi = float(np.min(arr)), float(np.max(arr))
        c = self._covers
        if self._block is not None and c is not None and c[0] <= lo and hi <= c[1]:
            return
        self.orbit.check_times(arr, "t")
        span = np.array([lo, hi])
        parts: list[np.ndarray] = []
        head = np.zeros(_ke.E_HEAD)
        at = _ke.E_HEAD
        if self._field is not None:
            self._field.prepare(span)
            fb = self._field._kernel_params(span)
            head[_ke.E_FIELD] = at
            parts.append(fb)
            at += fb.shape[0]
        head[_ke.E_ORBIT] = at
        parts.append(self._orbit_data)
        at += self._orbit_data.shape[0]
        epoch = getattr(self.orbit, "epoch", None)
        if epoch is not None:
            from orbit import sun as _sun

            sun = np.asarray(_sun.SunTable(epoch, lo - 60.0, hi + 60.0).kernel_data(), np.float64)
            head[_ke.E_SUN] = at
            parts.append(sun)
        self._block = np.concatenate([head, *parts])
        self._covers = (lo, hi)

    def block(self, what: str) -> np.ndarray:
        if self._block is None:
            lo, hi = self.orbit.time_span
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise AttitudeValueError(
                    f"t: the environment tables of {what} cover the times of a run; "
                    "attitude.propagate prepares them, and torque() for the times it is given; "
                    "to build the parameters yourself call model.prepare(t) first"
                )
            self.prepare(np.array([lo, hi]))
        assert self._block is not None
        return self._block


class CustomTorque(Potential):
    """A user torque τ_B given directly (optionally with its potential, for energies).

    Parameters
    ----------
    torque : callable
        ``tau(q, t)`` or, for a torque that depends on the body rates, ``tau(q, omega, t)``,
        returning the body-frame torque (3 numbers, tuple or array; N·m for a body in SI
        units). ``q`` is the unit attitude quaternion (length-4 array, body → space),
        ``omega`` the body angular velocity (length-3 array, rad/s, body axes), ``t`` the time
        (s). With ``orbit=``, the environment at t comes last: ``tau(q, t, env)`` or
        ``tau(q, omega, t, env)``, ``env`` a 1-D array laid out by :class:`EnvironmentIndex`
        (field and Sun direction in body axes, r, v, the orbital frame, the Sun's distance and
        the Earth's shadow). Numba-compilable (a plain function is jitted for you).
    potential : callable, optional
        ``U(q, t) -> float`` (J); without it results report the kinetic energy only.
    orbit : orbit.Orbit, optional
        The orbit whose environment ``env`` holds, computed inside the compiled kernels from
        tables built once per run (as :class:`MagneticDipole` and the flight software build
        them); in a sum with environment models it must be theirs (the same epoch). The
        field and the Sun need a dated orbit (``epoch=``); without an epoch, give
        ``field=None`` or a constant field, and the Sun's entries are NaN.
    field : {"igrf", "dipole"}, array_like (3,) or None
        The field in ``env`` (as :class:`MagneticDipole`): IGRF-14, its tilted dipole, a
        constant space-frame field [T], or None (no field: NaN). Only with ``orbit``.
    step : float or Quantity, optional
        Node spacing of the field table [s] (as :class:`MagneticDipole`). Only with ``orbit``.
    name : str, optional
        Names the torque in results (``torque`` variable, ``model`` dimension).
    time_dependent : bool
        Whether the torque depends on t explicitly.

    Examples
    --------
    Linear rate damping τ = −k ω:

    >>> def damping(q, omega, t):                                     # doctest: +SKIP
    ...     return -1e-3 * omega
    >>> attitude.CustomTorque(damping, name="damper")                  # doctest: +SKIP

    A magnetorquer dipole along body z, τ = m × B_B, reading the field from ``env``:

    >>> F = attitude.potentials.EnvironmentIndex.FIELD                  # doctest: +SKIP
    >>> def rod(q, t, env):                                           # doctest: +SKIP
    ...     return np.cross(np.array([0.0, 0.0, 0.2]), env[F : F + 3])
    >>> attitude.CustomTorque(rod, orbit=o)                            # doctest: +SKIP
    """

    orbit: Any = None

    def __init__(
        self,
        torque: Any,
        potential: Any = None,
        *,
        orbit: Any = None,
        field: Any = "igrf",
        step: Any = None,
        name: str = "custom_torque",
        time_dependent: bool = True,
    ):
        if not isinstance(name, str) or not name.isidentifier():
            raise AttitudeValueError(
                f"name: expected a short identifier such as 'damper' (it names the torque in "
                f"results), got {name!r}"
            )
        with_env = orbit is not None
        if with_env:
            forms = "tau(q, t, env) or tau(q, omega, t, env) (with orbit=)"
            n_args = _arity(torque, "torque", (3, 4), forms)
        else:
            n_args = _arity(torque, "torque", (2, 3, 4), "tau(q, t) or tau(q, omega, t)")
            if n_args == 4:
                raise AttitudeTypeError(
                    "orbit: a torque tau(q, omega, t, env) reads the environment along an orbit; "
                    "give CustomTorque(tau, orbit=o) (an orbit.KeplerOrbit, SecularJ2Orbit or "
                    "EphemerisOrbit, dated for the field and the Sun), or write tau(q, t) or "
                    "tau(q, omega, t)"
                )
            default_field = isinstance(field, str) and field == "igrf"
            if not default_field or step is not None:
                what = "field" if not default_field else "step"
                raise AttitudeValueError(
                    f"{what}: sets the environment of a torque that reads it; give orbit= too "
                    "(CustomTorque(tau, orbit=o, ...), with tau taking env last)"
                )
        tau = _compile_user(torque, "torque")
        U = None if potential is None else _compile_user(potential, "potential")
        self.name = name
        self.time_dependent = bool(time_dependent)
        self.rate_dependent = n_args == (4 if with_env else 3)
        self.has_potential = U is not None
        self._tau = tau
        self._U = U
        self._env: _TorqueEnvironment | None = None
        if with_env:
            self.orbit = _torque_orbit(orbit, field)
            self._env = _TorqueEnvironment(self.orbit, field, step)
        q = np.array([1.0, 0.0, 0.0, 0.0])
        args: tuple = (q, np.zeros(3), 0.0) if self.rate_dependent else (q, 0.0)
        if with_env:
            args = (*args, _probe_environment())
        form = ("tau(q, omega, t" if self.rate_dependent else "tau(q, t") + (
            ", env)" if with_env else ")"
        )
        try:
            r = tau(*args)
            if len(r) != 3 or not all(math.isfinite(float(x)) for x in r):
                raise ValueError("it must return three finite numbers")
        except Exception as exc:
            raise AttitudeTypeError(
                f"torque: must be a numba-compilable function {form} returning the three "
                "body-frame torque components; calling it failed: "
                + _user_kernels.compile_failure(exc)
            ) from None

    def _user_terms(self) -> tuple:
        kind = "torque_rates" if self.rate_dependent else "torque"
        if self._env is not None:
            kind += "_env"
        return ((kind, self._tau, self._U),)

    def _user_env_blocks(self) -> tuple[np.ndarray, ...]:
        return () if self._env is None else (self._env.block(self.name),)

    def prepare(self, t: Any) -> Potential:
        if self._env is not None:
            self._env.prepare(t)
        return self

    def check_times(self, t: Any, name: str = "t") -> None:
        if self.orbit is not None:
            try:
                self.orbit.check_times(t, name)
            except ValueError as exc:
                raise AttitudeValueError(str(exc)) from None

    def environment(self, t: Any, q: Any = (1.0, 0.0, 0.0, 0.0)) -> np.ndarray:
        """The environment vector ``env`` the torque sees at times ``t`` and attitudes ``q``.

        Parameters
        ----------
        t : float or array_like
            Times [s since the orbit's epoch].
        q : array_like, shape (..., 4)
            Unit attitude quaternions (body → space; broadcast against t); the body-axis
            entries (field, Sun) depend on it.

        Returns
        -------
        env : ndarray, shape (..., ENVIRONMENT_SIZE)
            Laid out by :class:`EnvironmentIndex`.
        """
        if self._env is None:
            raise AttitudeValueError(
                "orbit: this CustomTorque reads no environment; build it with orbit= "
                "(CustomTorque(tau, orbit=o) with tau taking env last)"
            )
        qa = as_quaternion(q, "q")
        if np.any(np.abs(np.linalg.norm(qa, axis=-1) - 1.0) > 1e-6):
            raise AttitudeValueError("q: the environment is evaluated at unit quaternions")
        tt = as_float_array(t, "t", unit="s")
        shape = np.broadcast_shapes(qa.shape[:-1], tt.shape)
        # C-ordered writable float64 (a read-only broadcast view compiles the loop again)
        qf = np.require(np.broadcast_to(qa, (*shape, 4)).reshape(-1, 4), np.float64, ["C", "W"])
        tf = np.require(np.broadcast_to(tt, shape).reshape(-1), np.float64, ["C", "W"])
        self.check_times(tf, "t")
        self._env.prepare(tf)
        block = self._env.block(self.name)
        out = np.empty((tf.shape[0], _ke.ENV_SIZE))
        _ke.environment_loop(qf, tf, block, 0, out)
        return out.reshape((*shape, _ke.ENV_SIZE))

    def __repr__(self) -> str:
        head = f"CustomTorque({getattr(self._tau, '__name__', 'tau')}, name={self.name!r}"
        if self._env is None:
            return head + ")"
        f = self._env.field
        f = f.tolist() if isinstance(f, np.ndarray) else f
        return head + f", orbit={self.orbit!r}, field={f!r})"


def _torque_orbit(orbit: Any, field: Any) -> Any:
    """The orbit of a CustomTorque's environment, checked (dated when the field needs it)."""
    if not hasattr(orbit, "kernel_data"):
        raise AttitudeTypeError(
            "orbit: the environment of a CustomTorque is that of an orbit (orbit.KeplerOrbit, "
            f"orbit.SecularJ2Orbit, orbit.EphemerisOrbit), got {type(orbit).__name__}"
        )
    if isinstance(field, str) and getattr(orbit, "epoch", None) is None:
        if field in ("igrf", "dipole"):
            raise AttitudeValueError(
                f"orbit: the environment's field (field={field!r}) is evaluated at the orbit's "
                "Earth-fixed positions and date, so it needs a dated orbit: build the orbit "
                "with epoch='2024-03-20T12:00:00' (an astropy Time or ISO 8601 string; TLE "
                "and OEM orbits carry their own), or give field=None (no field) or a constant "
                "field vector (T, space axes)"
            )
    return orbit


def _common_orbit(terms: list[Potential]) -> Any:
    """The one orbit of the terms that have one (they must share its epoch), or None."""
    orbits = [t.orbit for t in terms if getattr(t, "orbit", None) is not None]
    if not orbits:
        return None
    first = orbits[0]
    for other in orbits[1:]:
        e1, e2 = getattr(first, "epoch", None), getattr(other, "epoch", None)
        if (e1 is None) != (e2 is None) or (e1 is not None and abs((e1 - e2).sec) > 0.0):
            from orbit.timescales import format_epoch

            def show(e):
                return "none" if e is None else format_epoch(e)

            raise AttitudeValueError(
                f"orbit: the terms of this model use orbits with different epochs ({show(e1)} "
                f"and {show(e2)}); one run has one time origin: build them on one orbit"
            )
    return first


def _arity(func: Any, what: str, allowed: tuple[int, ...], forms: str) -> int:
    """Number of positional parameters of a user function (checked against ``allowed``)."""
    import inspect

    f = getattr(func, "py_func", func)
    if not callable(f):
        raise AttitudeTypeError(f"{what}: expected a function {forms}, got {type(func).__name__}")
    try:
        sig = inspect.signature(f)
    except (TypeError, ValueError):  # builtins without a signature: let the call check it
        return allowed[0]
    kinds = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
    n = sum(1 for prm in sig.parameters.values() if prm.kind in kinds)
    if n not in allowed:
        raise AttitudeTypeError(f"{what}: expected a function {forms}, got one of {n} arguments")
    return n


class Sum(Potential):
    """Models that add up: the torque is the sum of the terms' torques.

    Made by ``+`` (``GravityGradient(o) + CustomTorque(tau)``); a sum of sums is flattened and
    torque-free terms are dropped, and a "sum" of one model is that model itself, so it runs
    exactly as alone (bit for bit). Built-in terms are data behind the package's cached kernels
    (a sum of built-in models compiles nothing in a fresh process); user terms are compiled like
    any user kernel.

    The potential energy is that of the terms that have one; results name the terms that do
    not (``energy`` then excludes them). The compiled terms, and the ``model`` dimension of the
    per-model torque in results, list the built-in terms first, then the user terms, each in
    the order given.
    """

    name = "sum"
    _kind = _kp.KIND_SUM

    def __new__(cls, *terms: Potential) -> Any:
        flat: list[Potential] = []
        for k, term in enumerate(terms):
            if not isinstance(term, Potential):
                raise AttitudeTypeError(
                    f"terms[{k}]: expected an attitude.potentials model, got {type(term).__name__}"
                )
            flat.extend(t for t in term.terms if not isinstance(t, TorqueFree))
        if not flat:
            return TorqueFree()
        if len(flat) == 1:
            return flat[0]
        self = super().__new__(cls)
        builtin = [t for t in flat if t._kind is not None]
        user = [t for t in flat if t._kind is None]
        self._terms = tuple(builtin + user)
        self._builtin = tuple(builtin)
        self._user = tuple(user)
        self.time_dependent = any(t.time_dependent for t in flat)
        self.rate_dependent = any(t.rate_dependent for t in flat)
        self.has_potential = any(t.has_potential for t in flat)
        self.orbit = _common_orbit(flat)
        return self

    @property
    def terms(self) -> tuple[Potential, ...]:
        return self._terms

    @property
    def terms_without_potential(self) -> list[str]:
        """Names of the terms whose potential is unknown (energies exclude them)."""
        return [
            n for n, t in zip(self.term_names(), self._terms, strict=True) if not t.has_potential
        ]

    def _params(self, inertia: np.ndarray) -> np.ndarray:
        # [I1, I2, I3, KIND_SUM, n, offsets (n), blocks]: _core.potentials
        # the environment blocks of user terms (if any) between the offsets and the blocks
        n = len(self._builtin)
        env = _user_environment(_kp.P_OFFSETS + n if n else _kp.P0, self._user_env_blocks())
        if n == 0:
            return np.concatenate([np.array([*inertia, _kp.KIND_USER], dtype=np.float64), env])
        blocks = [[t._kind, *t._potential_params()] for t in self._builtin]
        offsets, at = [], _kp.P_OFFSETS + n + env.shape[0]
        for b in blocks:
            offsets.append(at)
            at += len(b)
        flat = [x for b in blocks for x in b]
        head = np.array([*inertia, _kp.KIND_SUM, n, *offsets], dtype=np.float64)
        return np.concatenate([head, env, np.array(flat, dtype=np.float64)])

    def _user_terms(self) -> tuple:
        return tuple(u for t in self._user for u in t._user_terms())

    def _user_env_blocks(self) -> tuple[np.ndarray, ...]:
        return tuple(b for t in self._user for b in t._user_env_blocks())

    def check_times(self, t: Any, name: str = "t") -> None:
        for term in self._terms:
            term.check_times(t, name)

    def _inertia_for_eval(self) -> np.ndarray:
        for t in self._terms:
            if getattr(t, "inertia", None) is not None:
                return t._inertia_for_eval()
        return np.ones(3)

    def bind(self, body: RigidBody) -> Potential:
        return Sum(*(t.bind(body) for t in self._terms))

    def prepare(self, t: Any) -> Potential:
        terms = [term.prepare(t) for term in self._terms]
        if all(a is b for a, b in zip(terms, self._terms, strict=True)):
            return self
        return Sum(*terms)

    def describe(self) -> str:
        return repr(self)

    def __repr__(self) -> str:
        return " + ".join(repr(t) for t in self._terms)


# --------------------------------------------------------------------------------------------
# The environment of a spacecraft in Earth orbit
# --------------------------------------------------------------------------------------------


def _seconds(x: Any, name: str) -> float:
    v = as_float_array(x, name, unit="s")
    if v.shape != () or not float(v) > 0.0:
        raise AttitudeValueError(f"{name}: expected a positive time step (s), got {x!r}")
    return float(v)


def _span(span: Any) -> tuple[float, float] | None:
    if span is None:
        return None
    v = as_float_array(span, "span", unit="s")
    if v.shape != (2,) or not v[1] >= v[0]:
        raise AttitudeValueError(
            f"span: expected (start, stop) in seconds since the epoch with stop >= start, got "
            f"{span!r}"
        )
    return float(v[0]), float(v[1])


def _check_orbit(orbit: Any, what: str, needs_epoch: bool, why: str) -> Any:
    if orbit is None and not needs_epoch:
        return None
    if not hasattr(orbit, "kernel_data"):
        raise AttitudeTypeError(
            f"orbit: {what} needs an orbit (orbit.KeplerOrbit, orbit.SecularJ2Orbit, "
            f"orbit.EphemerisOrbit), got {type(orbit).__name__}"
        )
    if needs_epoch and getattr(orbit, "epoch", None) is None:
        raise AttitudeValueError(
            f"orbit: {what} {why}, so it needs a dated orbit: build the orbit with "
            "epoch='2024-03-20T12:00:00' (an astropy Time or ISO 8601 string; TLE and OEM "
            "orbits carry their own)"
        )
    return orbit


class _EnvironmentModel(Potential):
    """Base of the models whose torque reads the environment along the orbit from tables.

    The tables (:mod:`attitude.environment`) span the run: :meth:`prepare` computes them for
    the times of a run (``attitude.propagate`` calls it), once, and keeps them while later runs
    fit in the same span. Subclasses give ``_table(grid)``, the environment on a
    :class:`attitude.environment.Grid`, and ``_head()``, the block's numbers before the table;
    ``_table`` runs first and may record what it chose for ``_head`` (drag: whether the table
    holds √ρ v; radiation: whether the shadow margins may decide the umbra).
    """

    time_dependent = True
    orbit: Any = None

    def _entry_points(self):
        """The entry points of this model alone, specialised to its orbit's type too (the
        Dataset's orbit variables: :mod:`attitude._core.models`)."""
        data = None if self.orbit is None else self.orbit.kernel_data()
        return _models.entry_points(self._kind, data)

    def _setup(self, orbit: Any, step: Any, span: Any) -> None:
        self.step = _env.DEFAULT_STEP if step is None else _seconds(step, "step")
        self.span = _span(span)
        self._block: np.ndarray | None = None
        self._covers: tuple[float, float] | None = None

    # subclass hooks
    def _head(self) -> list[float]:
        raise NotImplementedError

    def _table(self, g: Any) -> np.ndarray:
        raise NotImplementedError

    def _constant_table(self) -> np.ndarray | None:
        return None

    def prepare(self, t: Any) -> Potential:
        const = self._constant_table()
        if const is not None:
            if self._block is None:
                self._block = self._assemble(const)
            return self
        arr = np.asarray(t, dtype=np.float64).reshape(-1)
        if arr.size == 0:
            return self
        lo, hi = float(np.min(arr)), float(np.max(arr))
        c = self._covers
        if self._block is not None and c is not None and c[0] <= lo and hi <= c[1]:
            return self
        self.check_times(arr, "t")
        g = _env.grid(self.orbit, lo, hi, self.step)
        self._block = self._assemble(self._table(g))
        self._covers = (lo, hi)
        return self

    def _assemble(self, table: np.ndarray) -> np.ndarray:
        head = self._head()
        # block = [kind, tab, *head[1:], table]: head[0] is the placeholder of tab
        return np.concatenate([[1 + len(head)], head[1:], table]).astype(np.float64)

    def _potential_params(self) -> Any:
        if self._block is None:
            span = self.span
            if span is None and self.orbit is not None:
                lo, hi = self.orbit.time_span
                span = (lo, hi) if math.isfinite(lo) and math.isfinite(hi) else None
            if span is None:
                raise AttitudeValueError(
                    f"span: the {self.name} tables cover the times of a run; "
                    "attitude.propagate prepares them, and torque()/value() for the times "
                    "they are given; to build the parameters yourself call "
                    f"model.prepare(t) or give {type(self).__name__}(..., span=(start, stop))"
                )
            self.prepare(np.array(span))
        return self._block

    def check_times(self, t: Any, name: str = "t") -> None:
        if self.orbit is not None:
            try:
                self.orbit.check_times(t, name)
            except ValueError as exc:
                raise AttitudeValueError(str(exc)) from None

    def _kernel_params(self, t: np.ndarray) -> np.ndarray:
        self.prepare(t)
        return np.concatenate([[self._kind], self._block])

    def _table_values(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """(params, values (m, ncomp)) of the table at times ``t`` (compiled interpolation)."""
        tt = np.ascontiguousarray(as_float_array(t, "t", unit="s"), dtype=np.float64)
        flat = tt.reshape(-1)
        self.check_times(flat, "t")
        params = self._kernel_params(flat)
        o = int(params[_ke.B_TAB])
        s0 = o + int(params[o + 1])  # first segment: ncomp is the same in all
        out = np.empty((flat.size, int(params[s0 + _ke.T_NCOMP])))
        _ke.table_loop(flat, params, o, out)
        return params, out.reshape((*tt.shape, out.shape[-1]))


def check_field(field: Any) -> np.ndarray | None:
    """The constant field [T] of a ``field`` setting, or None for a model name ('igrf' or
    'dipole'); anything else is refused, naming ``field`` and the choices."""
    if isinstance(field, str):
        if field not in ("igrf", "dipole"):
            raise AttitudeValueError(
                f"field: expected 'igrf' (IGRF-14 through ppigrf), 'dipole' (its tilted "
                f"dipole) or a constant field vector (T, space axes), got {field!r}"
            )
        return None
    b = as_float_array(field, "field", unit="T")
    if b.shape != (3,):
        raise AttitudeValueError(
            f"field: a constant field is 3 space-frame components (T), got shape {b.shape}"
        )
    return b


def _field_setting(field: Any, orbit: Any, what: str) -> tuple[str, np.ndarray | None, Any]:
    """('igrf' | 'dipole' | 'constant', constant field [T] or None, orbit)."""
    b = check_field(field)
    if b is None:
        why = "evaluates the geomagnetic field at the orbit's Earth-fixed positions and date"
        orbit = _check_orbit(orbit, what, True, why)
        _env.check_igrf_dates(np.array([orbit.epoch.utc.to_value("datetime64")], "datetime64[ns]"))
        return field, None, orbit
    return "constant", b, _check_orbit(orbit, what, False, "")


class MagneticDipole(_EnvironmentModel):
    """Torque on a body-fixed magnetic dipole in the geomagnetic field: τ = m × B_B.

    U = −m·B_B (a time-dependent potential: the energy of the dipole in the field).

    Parameters
    ----------
    orbit : orbit.Orbit
        The orbit, with an epoch (the field is evaluated at its Earth-fixed positions and
        date); may be None with a constant ``field``.
    dipole : array_like or Quantity, shape (3,)
        m in body axes [A m²] (a residual dipole, or a magnetorquer's constant moment).
    field : {"igrf", "dipole"} or array_like, shape (3,)
        ``"igrf"``: IGRF-14 (degree 13) through ``ppigrf``; ``"dipole"``: the tilted dipole of
        the same IGRF coefficients (degree 1, closed form); or a constant field in the space
        frame [T] (Quantity accepted, e.g. nT).
    step : float or Quantity, optional
        Node spacing of the field table [s] (default :data:`attitude.environment.DEFAULT_STEP`).
    span : (float, float), optional
        Times [s] the tables must cover when the model is used outside ``attitude.propagate``.

    Notes
    -----
    The field is computed once per run along the orbit (ITRS positions by astropy, IGRF by
    ppigrf, rotated to the GCRS by astropy) and interpolated in the compiled right-hand side
    (degree-7 Lagrange, :mod:`attitude._core.environment`); docs/potentials.md gives the
    measured interpolation error.
    """

    name = "magnetic_dipole"
    _kind = _kp.KIND_MAGNETIC_DIPOLE

    def __init__(
        self, orbit: Any, dipole: Any, field: Any = "igrf", *, step: Any = None, span: Any = None
    ):
        self.field, self._const, self.orbit = _field_setting(field, orbit, "MagneticDipole")
        m = as_float_array(dipole, "dipole", unit="A m2")
        if m.shape != (3,):
            raise AttitudeValueError(
                f"dipole: expected 3 body-axis components (A m²), got shape {m.shape}"
            )
        self.dipole = m
        self._setup(self.orbit, step, span)

    def _head(self) -> list[float]:
        return [0.0, *self.dipole]

    def _constant_table(self) -> np.ndarray | None:
        return None if self._const is None else _env.constant_table(self._const)

    def _table(self, g: Any) -> np.ndarray:
        return _env.table(g, _env.magnetic_field_gcrs(g, self.field))

    def magnetic_field(self, t: Any) -> np.ndarray:
        """The field the torque uses [T], space-frame components, shape t.shape + (3,)."""
        return self._table_values(t)[1]

    def __repr__(self) -> str:
        f = self.field if self._const is None else self._const.tolist()
        return f"MagneticDipole(dipole={self.dipole.tolist()}, field={f!r})"


class EddyCurrentDamping(_EnvironmentModel):
    """Eddy-current torque on a conducting body: τ = m × B_B, m = −M dB_B/dt
    = M (ω × B_B − q̃∘Ḃ_S∘q) (body axes; (M (ω × B)) × B in a field fixed in space).

    The tensor model of Ortiz Gómez & Walker (2015), "Eddy currents applied to de-tumbling of
    space debris: analysis and validation of approximate proposed methods", Acta Astronautica
    114, 34–53: the currents induced in the conductor give a magnetic moment M (ω × B) when
    the body rotates in a field B fixed in space, whose torque in B damps the rotation
    perpendicular to B and leaves the spin about B alone: ω·τ = −(ω × B)·M (ω × B) <= 0,
    τ ⊥ B. The moment answers the change of the field seen from the body (Faraday's law in
    the low-frequency limit, the assumption of the tensor model), and along an orbit the field
    also changes in space: dB_B/dt = −ω × B_B + q̃∘Ḃ_S∘q, with Ḃ_S the rate of the field along
    the orbit (up to ~4e-3 rad/s of rotation in LEO: 2–4 % of a 5 °/s tumble, all of it for a
    body slowed to a few times the orbital rate). Praly et al. (2012), "Study on the eddy
    current damping of the spin dynamics of space debris from the Ariane launcher upper
    stages", Acta Astronautica 76, 145–153, model the induction of a conductor orbiting
    through the geomagnetic field. Ḃ_S is tabulated with B: the derivative of the degree-8
    polynomial through the 9 nearest nodes (:func:`orbit.ephemeris.position_derivative`).
    This is what de-spins defunct satellites and spent stages over months (Praly et al. 2012).

    Parameters
    ----------
    orbit : orbit.Orbit
        The orbit with an epoch (or None with a constant ``field``).
    tensor : float, array_like (3,) or (3, 3), or Quantity
        The magnetic tensor M in body axes [S m⁴ = A m² / (T s⁻¹ T)]: a number (isotropic), the
        diagonal, or the symmetric positive semi-definite matrix. A thin spherical shell of
        radius R, wall thickness e and conductivity σ has M = (2π/3) σ e R⁴ 1
        (:meth:`spherical_shell`).
    field, step, span
        As :class:`MagneticDipole`.
    """

    name = "eddy_current_damping"
    _kind = _kp.KIND_EDDY_CURRENTS
    rate_dependent = True
    has_potential = False

    def __init__(
        self, orbit: Any, tensor: Any, field: Any = "igrf", *, step: Any = None, span: Any = None
    ):
        self.field, self._const, self.orbit = _field_setting(field, orbit, "EddyCurrentDamping")
        m = as_float_array(tensor, "tensor", unit="S m4")
        if m.shape == ():
            m = float(m) * np.eye(3)
        elif m.shape == (3,):
            m = np.diag(m)
        elif m.shape != (3, 3):
            raise AttitudeValueError(
                f"tensor: expected a number, 3 diagonal entries or a 3 × 3 matrix (S m⁴), got "
                f"shape {m.shape}"
            )
        scale = max(float(np.max(np.abs(m))), np.finfo(float).tiny)
        if np.max(np.abs(m - m.T)) > 1e-12 * scale:
            raise AttitudeValueError("tensor: the magnetic tensor must be symmetric")
        if float(np.min(np.linalg.eigvalsh(m))) < -1e-12 * scale:
            raise AttitudeValueError(
                "tensor: must be positive semi-definite (a conductor dissipates energy: "
                "ω·τ = −(ω × B)·M (ω × B) <= 0)"
            )
        self.tensor = m
        self._setup(self.orbit, step, span)

    @staticmethod
    def spherical_shell(radius: Any, thickness: Any, conductivity: Any) -> np.ndarray:
        """M = (2π/3) σ e R⁴ 1 of a thin spherical shell [S m⁴] (Ortiz Gómez & Walker 2015).

        Parameters
        ----------
        radius, thickness : float or Quantity
            R and e [m].
        conductivity : float or Quantity
            σ [S/m] (aluminium alloys: 2e7 to 3.8e7 S/m).
        """
        r = as_scalar(radius, "radius", unit="m")
        e = as_scalar(thickness, "thickness", unit="m")
        s = as_scalar(conductivity, "conductivity", unit="S / m")
        for name, v in (("radius", r), ("thickness", e), ("conductivity", s)):
            if not v > 0:
                raise AttitudeValueError(f"{name}: must be > 0, got {v!r}")
        return (2.0 * math.pi / 3.0) * s * e * r**4 * np.eye(3)

    def _head(self) -> list[float]:
        return [0.0, *self.tensor.ravel()]

    def _constant_table(self) -> np.ndarray | None:
        if self._const is None:
            return None
        return _env.constant_table(np.concatenate([self._const, np.zeros(3)]))

    def _table(self, g: Any) -> np.ndarray:
        from orbit.ephemeris import position_derivative

        b = _env.magnetic_field_gcrs(g, self.field)
        return _env.table(g, np.hstack([b, position_derivative(g.t, b)]))

    def magnetic_field(self, t: Any) -> np.ndarray:
        """The field the torque uses [T], space-frame components, shape t.shape + (3,)."""
        return self._table_values(t)[1][..., :3]

    def magnetic_field_rate(self, t: Any) -> np.ndarray:
        """Its rate of change along the orbit, dB/dt [T/s], space-frame components."""
        return self._table_values(t)[1][..., 3:6]

    def __repr__(self) -> str:
        f = self.field if self._const is None else self._const.tolist()
        return f"EddyCurrentDamping(tensor={self.tensor.tolist()}, field={f!r})"


def _check_above_surface(height: np.ndarray, t: np.ndarray) -> None:
    """Refuse an orbit that goes below the Earth's surface while drag is computed (NRLMSIS
    returns 0 there, the exponential table 1e48 kg/m³ at −800 km: no atmosphere model means
    anything below the ground)."""
    if not height.size or float(np.min(height)) >= 0.0:
        return
    i = int(np.argmin(height))
    raise AttitudeValueError(
        f"orbit: AerodynamicDrag needs the atmosphere along the orbit, and this orbit passes "
        f"{-float(height[i]):.1f} km below the Earth's surface (WGS 84 height "
        f"{float(height[i]):.1f} km at t ≈ {float(t[i]):.6g} s): check "
        "the orbit (its perigee radius a (1 − e) is the geocentric distance of its lowest "
        "point), or leave drag out"
    )


class AerodynamicDrag(_EnvironmentModel):
    """Aerodynamic torque on flat-plate facets in the co-rotating atmosphere.

    A facet whose outward normal faces the flow (cos θ = n̂·v̂ > 0) feels
    F = −½ ρ C_D A cos θ |v|² v̂ at its centre, v the velocity relative to an atmosphere
    co-rotating with the Earth (v − ω⊕ × r); τ = Σ c × F. The flow around facets that shadow
    each other is not modelled (every facet facing the flow counts in full), nor the velocity
    ω × c of the facets from the body's own rotation (|ω × c| / |v| ~ 1e-6 for a CubeSat).

    Parameters
    ----------
    orbit : orbit.Orbit
        With an epoch (the density depends on the date, local time and the Earth-fixed
        position).
    facets : sequence of attitude.Facet
        The surfaces (body axes, SI).
    density : {"msis", "exponential"}
        NRLMSIS 2.1 through ``pymsis`` with the indices below, or the exponential atmosphere of
        Vallado (2013), Table 8-4 (no indices).
    f107, f107a : float
        Daily F10.7 of the previous day and its 81-day mean [sfu], each in [50, 400]; given,
        never fetched (pymsis is called with all indices, so it never opens or downloads its
        space-weather file).
    ap : float
        Daily Ap in [0, 400].
    step, span
        As :class:`MagneticDipole`.
    """

    name = "aerodynamic_drag"
    _kind = _kp.KIND_AERODYNAMIC_DRAG
    has_potential = False

    def __init__(
        self,
        orbit: Any,
        facets: Any,
        density: str = "msis",
        f107: Any = 150.0,
        f107a: Any = 150.0,
        ap: Any = 4.0,
        *,
        step: Any = None,
        span: Any = None,
    ):
        if not isinstance(density, str) or density not in ("msis", "exponential"):
            raise AttitudeValueError(
                f"density: expected 'msis' (NRLMSIS 2.1 through pymsis) or 'exponential' "
                f"(Vallado's table), got {density!r}"
            )
        why = "evaluates the atmosphere at the orbit's Earth-fixed positions and date"
        self.orbit = _check_orbit(orbit, "AerodynamicDrag", True, why)
        self.facets = facet_array(facets)
        self.density = density
        self.f107 = as_scalar(f107, "f107")
        self.f107a = as_scalar(f107a, "f107a")
        self.ap = as_scalar(ap, "ap")
        _env.check_space_weather(self.f107, self.f107a, self.ap)
        self._density_code = (
            _ke.DENSITY_EXPONENTIAL if density == "exponential" else _ke.DENSITY_TABLE
        )
        self._setup(self.orbit, step, span)

    def _head(self) -> list[float]:
        bands = _env.VALLADO_EXPONENTIAL
        code = self._density_code
        groups = drag_groups(self.facets)
        bands_at = _ke.D_FACETS + _ke.D_STRIDE * len(groups)
        return [0.0, len(groups), code, bands_at, len(bands), *groups.ravel(), *bands.ravel()]

    def _rows(self, g: Any) -> np.ndarray:
        key = ("drag_rows", self.density, self.f107, self.f107a, self.ap)
        if key not in g._memo:
            lat, lon, h = g.geodetic
            _check_above_surface(h, g.t)
            if self.density == "exponential":
                x = h
            else:
                x = np.log(
                    _env.msis_density(g.datetime64, lat, lon, h, self.f107, self.f107a, self.ap)
                )
            g._memo[key] = np.concatenate([_env.relative_velocity(g), x[:, None]], axis=1)
        return g._memo[key]

    def _folded_rows(self, g: Any) -> np.ndarray:
        rows = self._rows(g).copy()
        rows[:, :3] *= np.exp(0.5 * rows[:, 3:4])  # √ρ v
        return rows

    def _table(self, g: Any) -> np.ndarray:
        if self.density == "exponential":
            self._density_code = _ke.DENSITY_EXPONENTIAL
            return _env.table(g, self._rows(g))
        # pymsis's density jumps at 00:00 UTC: tables cut there
        plain = _env.table_by_utc_day(g, self._rows)
        folded = _env.table_by_utc_day(g, self._folded_rows)
        if _env.folds_density(plain, folded, g):
            self._density_code = _ke.DENSITY_FOLDED
            return folded
        self._density_code = _ke.DENSITY_TABLE
        return plain

    def atmosphere(self, t: Any) -> dict[str, np.ndarray]:
        """What the torque uses at times ``t``: ``density`` [kg/m³] and ``velocity`` [m/s],
        the velocity relative to the atmosphere in space-frame components."""
        _, v = self._table_values(t)
        if self.density == "exponential":
            rho = _env.exponential_density(v[..., 3])
        else:
            rho = np.exp(v[..., 3])
        if self._density_code == _ke.DENSITY_FOLDED:
            return {"density": rho, "velocity": v[..., :3] * np.exp(-0.5 * v[..., 3:4])}
        return {"density": rho, "velocity": v[..., :3]}

    def __repr__(self) -> str:
        extra = f", f107={self.f107!r}, f107a={self.f107a!r}, ap={self.ap!r}"
        return (
            f"AerodynamicDrag({len(self.facets)} facets, density={self.density!r}"
            + (extra if self.density == "msis" else "")
            + ")"
        )


class SolarRadiation(_EnvironmentModel):
    """Solar-radiation-pressure torque on flat-plate facets, with the Earth's shadow.

    A facet facing the Sun (cos θ = n̂·ŝ > 0) feels
    F = −P A cos θ [(1 − C_s) ŝ + 2 (C_s cos θ + C_d/3) n̂] (absorbed, specular and diffuse
    parts: Wertz 1978, Sect. 17.2.2; Montenbruck & Gill 2000, Sect. 3.4.1), with
    P = ν P⊙ (1 AU / d)², P⊙ = 1361 W m⁻² / c = 4.54e-6 N m⁻² (IAU 2015 nominal irradiance),
    d the satellite–Sun distance and ν the shadow fraction; τ = Σ c × F. Facets shadowing each
    other, Earth albedo and infrared are not modelled.

    Parameters
    ----------
    orbit : orbit.Orbit
        With an epoch (the Sun's position is dated).
    facets : sequence of attitude.Facet
        The surfaces with their optical coefficients.
    eclipse : {"conical", "cylindrical", "none"}
        Earth shadow: conical with penumbra (Montenbruck & Gill 2000, Sect. 3.4.2; default),
        cylindrical, or none.
    step, span
        As :class:`MagneticDipole`.
    """

    name = "solar_radiation"
    _kind = _kp.KIND_SOLAR_RADIATION
    has_potential = False

    _ECLIPSE: ClassVar[dict[str, int]] = {
        "conical": _ke.ECLIPSE_CONICAL,
        "cylindrical": _ke.ECLIPSE_CYLINDRICAL,
        "none": _ke.ECLIPSE_NONE,
    }

    def __init__(
        self,
        orbit: Any,
        facets: Any,
        eclipse: str = "conical",
        *,
        step: Any = None,
        span: Any = None,
    ):
        if not isinstance(eclipse, str) or eclipse not in self._ECLIPSE:
            raise AttitudeValueError(
                f"eclipse: expected 'conical' (with penumbra), 'cylindrical' or 'none', got "
                f"{eclipse!r}"
            )
        why = "needs the Sun's position at the orbit's dates"
        self.orbit = _check_orbit(orbit, "SolarRadiation", True, why)
        self.facets = facet_array(facets)
        self.eclipse = eclipse
        self._umbra = False
        self._setup(self.orbit, step, span)

    def _head(self) -> list[float]:
        from orbit.sun import R_EARTH, R_SUN

        groups = optical_groups(self.facets)
        return [
            0.0,
            len(groups),
            self._ECLIPSE[self.eclipse],
            _env.P_SUN_1AU,
            _env.AU_KM,
            R_SUN,
            R_EARTH,
            float(self._umbra),  # the shadow margins may decide the umbra (set by _table)
            *groups.ravel(),
        ]

    def _table(self, g: Any) -> np.ndarray:
        rows = _env.sun_shadow(g)
        self._umbra = _env.earth_disk_larger(rows)
        return _env.table(g, rows)

    def sunlight(self, t: Any) -> dict[str, np.ndarray]:
        """What the torque uses at times ``t``: ``shadow`` ν (1 sunlit, 0 umbra),
        ``distance`` to the Sun [km] and ``direction`` (unit vector to the Sun, space axes)."""
        tt = np.ascontiguousarray(as_float_array(t, "t", unit="s"), dtype=np.float64)
        flat = tt.reshape(-1)
        self.check_times(flat, "t")
        params = self._kernel_params(flat)
        out = np.empty((flat.size, 5))
        _ke.solar_state_loop(flat, params, 0, out)
        out = out.reshape((*tt.shape, 5))
        return {"shadow": out[..., 0], "distance": out[..., 1], "direction": out[..., 2:]}

    def __repr__(self) -> str:
        return f"SolarRadiation({len(self.facets)} facets, eclipse={self.eclipse!r})"


def as_potential(potential: Any) -> Potential:
    """Validate the ``potential`` argument of the propagators (None means torque-free)."""
    if potential is None:
        return TorqueFree()
    if isinstance(potential, Potential):
        return potential
    raise AttitudeTypeError(
        f"potential: expected an attitude.potentials model (TorqueFree, HeavyTop, "
        f"GravityGradient, MagneticDipole, EddyCurrentDamping, AerodynamicDrag, "
        f"SolarRadiation, CustomPotential, CustomTorque, or a sum of them with +) or None, "
        f"got {type(potential).__name__}"
    )

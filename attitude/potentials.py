"""Potentials and torques acting on the body.

A potential gives, for an attitude ``q`` at time ``t``: its value U(q, t), the body-frame torque
τ_B(q, t) and the generalised force that enters Hamilton's equations (Arribas et al. eq. 7),

    F = 2 q∘(0, τ_B)        (Schwab eq. 25)

which is minus the tangential part of ∂U/∂q. Using F instead of a plain −∂U/∂q of the
quadratic forms in eqs. 18 and 20 keeps |q| = 1 and q·Q = 0 exact invariants of the flow.

Built in: :class:`TorqueFree`, :class:`HeavyTop`, :class:`GravityGradient`. User physics:
:class:`CustomPotential` (write U(q, t), the torque is derived exactly by complex-step
differentiation) and :class:`CustomTorque` (write τ_B(q, t) directly). All of them run inside
the compiled integrators.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from orbit._shared_jit import JIT_DISABLED

from . import _user_kernels
from ._core import entry_points as _entry_points
from ._core import potentials as _kp
from ._validation import as_float_array, as_quaternion
from .body import RigidBody
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "CustomPotential",
    "CustomTorque",
    "GravityGradient",
    "HeavyTop",
    "Potential",
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
        return np.array([*inertia, kind, *self._potential_params()], dtype=np.float64)

    def _user_terms(self) -> tuple:
        """The user terms (kind, torque, potential) compiled into a user module; () if none."""
        return ()

    def _entry_points(self):
        """The compiled entry points of this model (:mod:`attitude._core.entry_points`)."""
        terms = self._user_terms()
        return _user_kernels.entry_points(terms) if terms else _entry_points

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
        qf = np.ascontiguousarray(np.broadcast_to(q, (*shape, 4)).reshape(-1, 4))
        wf = np.ascontiguousarray(np.broadcast_to(w, (*shape, 3)).reshape(-1, 3))
        tf = np.ascontiguousarray(np.broadcast_to(t, shape).reshape(-1))
        params = self._params(self._inertia_for_eval())
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
        return self._eval(q, t)[1]

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
        w = float(as_float_array(weight, "weight", unit="N"))
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
                f"Compiling it with a complex q failed: {type(exc).__name__}: "
                f"{str(exc).splitlines()[0] if str(exc) else ''}"
            ) from None

    def _user_terms(self) -> tuple:
        return (("potential", None, self._U),)

    def __repr__(self) -> str:
        return f"CustomPotential({getattr(self._U, '__name__', 'U')}, name={self.name!r})"


class CustomTorque(Potential):
    """A user torque τ_B given directly (optionally with its potential, for energies).

    Parameters
    ----------
    torque : callable
        ``tau(q, t)`` or, for a torque that depends on the body rates, ``tau(q, omega, t)``,
        returning the body-frame torque (3 numbers, tuple or array; N·m for a body in SI
        units). ``q`` is the unit attitude quaternion (length-4 array, body → space),
        ``omega`` the body angular velocity (length-3 array, rad/s, body axes), ``t`` the time
        (s). Numba-compilable (a plain function is jitted for you).
    potential : callable, optional
        ``U(q, t) -> float`` (J); without it results report the kinetic energy only.
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
    """

    def __init__(
        self,
        torque: Any,
        potential: Any = None,
        *,
        name: str = "custom_torque",
        time_dependent: bool = True,
    ):
        if not isinstance(name, str) or not name.isidentifier():
            raise AttitudeValueError(
                f"name: expected a short identifier such as 'damper' (it names the torque in "
                f"results), got {name!r}"
            )
        n_args = _arity(torque, "torque", (2, 3), "tau(q, t) or tau(q, omega, t)")
        tau = _compile_user(torque, "torque")
        U = None if potential is None else _compile_user(potential, "potential")
        self.name = name
        self.time_dependent = bool(time_dependent)
        self.rate_dependent = n_args == 3
        self.has_potential = U is not None
        self._tau = tau
        self._U = U
        q = np.array([1.0, 0.0, 0.0, 0.0])
        form = "tau(q, omega, t)" if self.rate_dependent else "tau(q, t)"
        try:
            r = tau(q, np.zeros(3), 0.0) if self.rate_dependent else tau(q, 0.0)
            if len(r) != 3 or not all(math.isfinite(float(x)) for x in r):
                raise ValueError("it must return three finite numbers")
        except Exception as exc:
            raise AttitudeTypeError(
                f"torque: must be a numba-compilable function {form} returning the three "
                f"body-frame torque components; calling it failed: {type(exc).__name__}: "
                f"{str(exc).splitlines()[0] if str(exc) else ''}"
            ) from None

    def _user_terms(self) -> tuple:
        return (("torque_rates" if self.rate_dependent else "torque", self._tau, self._U),)

    def __repr__(self) -> str:
        return f"CustomTorque({getattr(self._tau, '__name__', 'tau')}, name={self.name!r})"


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
        n = len(self._builtin)
        if n == 0:
            return np.array([*inertia, _kp.KIND_USER], dtype=np.float64)
        blocks = [[t._kind, *t._potential_params()] for t in self._builtin]
        offsets, at = [], _kp.P_OFFSETS + n
        for b in blocks:
            offsets.append(at)
            at += len(b)
        flat = [x for b in blocks for x in b]
        return np.array([*inertia, _kp.KIND_SUM, n, *offsets, *flat], dtype=np.float64)

    def _user_terms(self) -> tuple:
        return tuple(u for t in self._user for u in t._user_terms())

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

    def describe(self) -> str:
        return repr(self)

    def __repr__(self) -> str:
        return " + ".join(repr(t) for t in self._terms)


def as_potential(potential: Any) -> Potential:
    """Validate the ``potential`` argument of the propagators (None means torque-free)."""
    if potential is None:
        return TorqueFree()
    if isinstance(potential, Potential):
        return potential
    raise AttitudeTypeError(
        f"potential: expected an attitude.potentials model (TorqueFree, HeavyTop, "
        f"GravityGradient, CustomPotential, CustomTorque, or a sum of them with +) or None, "
        f"got {type(potential).__name__}"
    )

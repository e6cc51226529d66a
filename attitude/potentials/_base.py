"""The base class of the torque models, and how models add up.

:class:`Potential` gives, for any model, its parameters and entry points for the compiled kernels
and U, τ_B and the generalised force at given attitudes and times; :class:`TorqueFree` is the
zero of the sum, :class:`Sum` the models that add up (terms flattened, the built-in ones first;
their blocks and the environment blocks of the user terms laid out as
:mod:`attitude._core.potentials` reads them); :func:`as_potential` checks the ``potential``
argument of the propagators.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _user_kernels
from .._core import models as _models
from .._core import potentials as _kp
from .._validation import as_float_array, as_quaternion
from ..body import RigidBody
from ..errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "Potential",
    "Sum",
    "TorqueFree",
    "as_potential",
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

    def _entry_points(self, closed_loop: bool = False):
        """The compiled entry points of this model (:mod:`attitude._core.entry_points`, or their
        copy for this kind of model alone: :mod:`attitude._core.models`; ``closed_loop``: the
        ones every built-in model shares under flight software)."""
        terms = self._user_terms()
        if terms:
            return _user_kernels.entry_points(terms, potential=self)
        return _models.entry_points(self._kind, closed_loop=closed_loop)

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
        from ..quaternion import multiply

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

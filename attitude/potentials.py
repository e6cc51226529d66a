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

from orbit._jit import JIT_DISABLED, jit

from ._core import potentials as _kp
from ._core.quat import conj_mul
from ._validation import as_float_array, as_quaternion
from .body import RigidBody
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "CustomPotential",
    "CustomTorque",
    "GravityGradient",
    "HeavyTop",
    "Potential",
    "TorqueFree",
]


@jit
def _evaluate(torque, potential, q, t, params, tau_out, u_out):
    for k in range(q.shape[0]):
        tau = torque(q[k], t[k], params)
        tau_out[k, 0] = tau[0]
        tau_out[k, 1] = tau[1]
        tau_out[k, 2] = tau[2]
        u_out[k] = potential(q[k], t[k], params)


class Potential:
    """Base class: a potential or torque model acting on a rigid body.

    Subclasses provide either a built-in kind code and parameters (cached compiled kernels) or
    compiled ``torque(q, t, params)`` / ``potential(q, t, params)`` functions.
    """

    #: Short name recorded in result attrs.
    name: str = "potential"
    #: Whether U is known (False for a torque given without its potential).
    has_potential: bool = True
    #: Whether the model depends explicitly on time.
    time_dependent: bool = False

    # --- compiled-layer hooks -------------------------------------------------------------
    _kind: int | None = None  # built-in kind code, or None for user kernels

    def _potential_params(self) -> list[float]:
        return []

    def _params(self, inertia: np.ndarray) -> np.ndarray:
        """Parameter vector for the compiled kernels (inertia first, see _core.potentials)."""
        kind = -1 if self._kind is None else self._kind
        return np.array([*inertia, kind, *self._potential_params()], dtype=np.float64)

    def _kernels(self):
        """(torque, potential) compiled functions of (q, t, params), or None when built in."""
        return None

    def _inertia_for_eval(self) -> np.ndarray:
        return np.ones(3)

    # --- public evaluation --------------------------------------------------------------------
    def _eval(self, q: Any, t: Any) -> tuple[np.ndarray, np.ndarray]:
        q = as_quaternion(q, "q")
        nq = np.linalg.norm(q, axis=-1)
        if np.any(np.abs(nq - 1.0) > 1e-6):
            raise AttitudeValueError("q: potentials are evaluated at unit quaternions")
        t = as_float_array(t, "t", unit="s")
        shape = np.broadcast_shapes(q.shape[:-1], t.shape)
        qf = np.ascontiguousarray(np.broadcast_to(q, (*shape, 4)).reshape(-1, 4))
        tf = np.ascontiguousarray(np.broadcast_to(t, shape).reshape(-1))
        params = self._params(self._inertia_for_eval())
        tau = np.empty((qf.shape[0], 3))
        u = np.empty(qf.shape[0])
        kernels = self._kernels()
        if kernels is None:
            _evaluate(_kp.builtin_torque, _kp.builtin_potential, qf, tf, params, tau, u)
        else:
            _evaluate(kernels[0], kernels[1], qf, tf, params, tau, u)
        return tau.reshape((*shape, 3)), u.reshape(shape)

    def value(self, q: Any, t: Any = 0.0) -> np.ndarray:
        """Potential energy U(q, t).

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

    def torque(self, q: Any, t: Any = 0.0) -> np.ndarray:
        """Body-frame torque τ_B(q, t).

        Returns
        -------
        tau : ndarray, shape (..., 3)
        """
        return self._eval(q, t)[0]

    def generalized_force(self, q: Any, t: Any = 0.0) -> np.ndarray:
        """Generalised force 2 q∘(0, τ_B) of Schwab eq. 25 (the Q̇ term of eq. 7).

        Returns
        -------
        F : ndarray, shape (..., 4)
        """
        from .quaternion import multiply

        tau = self.torque(q, t)
        q = as_quaternion(q, "q")
        return 2.0 * multiply(q, np.concatenate([np.zeros((*tau.shape[:-1], 1)), tau], -1))

    def describe(self) -> str:
        """One-line description recorded in result attrs."""
        return repr(self)

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
    """Gravity-gradient torque of a central mass on a body in a Keplerian orbit (eq. 20).

    U = 3μ/(2r³) x̂_B·I x̂_B, x̂_B = q̃∘(p∘s1∘p̃)∘q, with r(t) and the orbital-frame quaternion
    p(t) from the orbit at the same t, evaluated inside the compiled right-hand side (Arribas
    et al. Sect. 6.2). Torque τ_B = 3μ/r³ x̂_B × (I x̂_B).

    Parameters
    ----------
    orbit : orbit.KeplerOrbit
        The orbit of the centre of mass (km, s; μ in km³ s⁻²).
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
        if not hasattr(orbit, "kernel_elements"):
            raise AttitudeTypeError(
                f"orbit: expected an orbit.KeplerOrbit, got {type(orbit).__name__}"
            )
        self.orbit = orbit
        self._el = np.asarray(orbit.kernel_elements(), dtype=np.float64)
        if inertia is None:
            self.inertia = None
        elif isinstance(inertia, RigidBody):
            self.inertia = inertia.inertia
        else:
            self.inertia = RigidBody(inertia).inertia

    def _potential_params(self) -> list[float]:
        return list(self._el)

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

#: Complex-step size: derivatives are exact to round-off for any h this small
#: (Squire & Trapp, SIAM Rev. 40, 110, 1998): Im U(q + i h e_k) / h = ∂U/∂q_k + O(h²).
COMPLEX_STEP = 1e-30


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


def _make_potential_kernels(U):
    h = COMPLEX_STEP

    @jit(cache=False)
    def torque(q, t, params):
        qc = np.empty(4, dtype=np.complex128)
        grad = np.empty(4)
        for i in range(4):
            for j in range(4):
                qc[j] = q[j]
            qc[i] = q[i] + 1j * h
            grad[i] = U(qc, t).imag / h
        # τ_B = −½ vec(q̃∘∇U): minus the tangential gradient, read in body axes (Schwab eq. 25).
        w = conj_mul(q, grad)
        return (-0.5 * w[1], -0.5 * w[2], -0.5 * w[3])

    @jit(cache=False)
    def potential(q, t, params):
        return U(q, t)

    return torque, potential


def _make_torque_kernels(tau_fn, U):
    @jit(cache=False)
    def torque(q, t, params):
        tau = tau_fn(q, t)
        return (float(tau[0]), float(tau[1]), float(tau[2]))

    if U is None:

        @jit(cache=False)
        def potential(q, t, params):
            return 0.0

    else:

        @jit(cache=False)
        def potential(q, t, params):
            return U(q, t)

    return torque, potential


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
        self._k = _make_potential_kernels(U)
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

    def _kernels(self):
        return self._k

    def __repr__(self) -> str:
        return f"CustomPotential({getattr(self._U, '__name__', 'U')}, name={self.name!r})"


class CustomTorque(Potential):
    """A user torque τ_B(q, t) given directly (optionally with its potential, for energies).

    Parameters
    ----------
    torque : callable
        ``tau(q, t) -> (3,)`` body-frame torque (tuple or array), numba-compilable.
    potential : callable, optional
        ``U(q, t) -> float``; without it results report the kinetic energy only.
    name : str, optional
    time_dependent : bool
    """

    def __init__(
        self,
        torque: Any,
        potential: Any = None,
        *,
        name: str = "custom_torque",
        time_dependent: bool = True,
    ):
        tau = _compile_user(torque, "torque")
        U = None if potential is None else _compile_user(potential, "potential")
        self.name = name
        self.time_dependent = bool(time_dependent)
        self.has_potential = U is not None
        self._k = _make_torque_kernels(tau, U)
        self._tau = tau
        try:
            r = tau(np.array([1.0, 0.0, 0.0, 0.0]), 0.0)
            if len(r) != 3 or not all(math.isfinite(float(x)) for x in r):
                raise ValueError("it must return three finite numbers")
        except Exception as exc:
            raise AttitudeTypeError(
                "torque: must be a numba-compilable function tau(q, t) returning the three "
                f"body-frame torque components; calling it failed: {type(exc).__name__}: "
                f"{str(exc).splitlines()[0] if str(exc) else ''}"
            ) from None

    def _kernels(self):
        return self._k

    def __repr__(self) -> str:
        return f"CustomTorque({getattr(self._tau, '__name__', 'tau')}, name={self.name!r})"


def as_potential(potential: Any) -> Potential:
    """Validate the ``potential`` argument of the propagators (None means torque-free)."""
    if potential is None:
        return TorqueFree()
    if isinstance(potential, Potential):
        return potential
    raise AttitudeTypeError(
        f"potential: expected an attitude.potentials.Potential (TorqueFree, HeavyTop, "
        f"GravityGradient, CustomPotential, CustomTorque) or None, got {type(potential).__name__}"
    )

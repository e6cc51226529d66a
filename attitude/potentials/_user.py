"""Your own physics: :class:`CustomPotential` (U(q, t); the torque by complex-step
differentiation) and :class:`CustomTorque` (τ_B given, optionally reading the environment along
an orbit, laid out by :class:`EnvironmentIndex`); the checks of a user's function (compiled with
numba, its number of arguments), also used by :mod:`attitude.events`. The user's functions are
compiled into entry points of their own (:mod:`attitude._user_kernels`).
"""

from __future__ import annotations

import math
from enum import IntEnum
from typing import Any

import numpy as np

from orbit._layout import Appender
from orbit._shared_jit import JIT_DISABLED

from .. import _user_kernels
from .._core import environment as _ke
from .._validation import as_float_array, as_quaternion
from ..errors import AttitudeTypeError, AttitudeValueError
from ._base import Potential
from ._environment_torques import MagneticDipole

__all__ = [
    "ENVIRONMENT_SIZE",
    "CustomPotential",
    "CustomTorque",
    "EnvironmentIndex",
]


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

    FIELD = _ke.ENV.FIELD
    SUN = _ke.ENV.SUN
    R = _ke.ENV.R
    V = _ke.ENV.V
    Q_RSW = _ke.ENV.Q_RSW  # 4
    SUN_DISTANCE = _ke.ENV.SUN_DISTANCE  # 1
    SHADOW = _ke.ENV.SHADOW  # 1


#: Length of the environment vector ``env`` of a :class:`CustomTorque` with an orbit.
ENVIRONMENT_SIZE = _ke.ENV.SIZE


def _probe_environment() -> np.ndarray:
    """A plausible environment (LEO, lit) to compile and check a user's torque with."""
    return _ke.ENV.pack(
        field=(1.0e-5, -2.0e-5, 3.0e-5),
        sun=(0.6, 0.0, 0.8),
        r=(7000.0, 0.0, 0.0),
        v=(0.0, 7.5, 0.0),
        q_rsw=(1.0, 0.0, 0.0, 0.0),
        sun_distance=1.496e8,
        shadow=1.0,
    )


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
        out = Appender(np.zeros(_ke.ENVB.SIZE))
        h = {}
        if self._field is not None:
            self._field.prepare(span)
            h["field"] = out.append(self._field._kernel_params(span))
        # (the orbit's table now: a NumericalOrbit's grows as its orbit is integrated on)
        h["orbit"] = out.append(np.ascontiguousarray(self.orbit.kernel_data(), dtype=np.float64))
        epoch = getattr(self.orbit, "epoch", None)
        if epoch is not None:
            from orbit import sun as _sun

            h["sun"] = out.append(_sun.SunTable(epoch, lo - 60.0, hi + 60.0).kernel_data())
        self._block = _ke.ENVB.pack_into(out.array(), 0, **h)
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
        out = np.empty((tf.shape[0], _ke.ENV.SIZE))
        _ke.environment_loop(qf, tf, block, 0, out)
        return out.reshape((*shape, _ke.ENV.SIZE))

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

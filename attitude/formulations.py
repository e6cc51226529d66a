"""The other formulations of rigid-body rotation in the two papers, side by side.

:func:`attitude.propagate` integrates Hamilton's equations in the canonical quaternion
variables (q, Q) (Arribas, Elipe & Palacios 2006, eq. 7) by default. With
``formulation=<name>`` it integrates one of the classical alternatives instead, with the same
potential (through its torque) and the same method, and converts the samples back to (q, Q)
so that every formulation returns the same Dataset:

``"canonical"``
    Eq. 7 in (q, Q) (the default; every method).
``"euler_angles"``
    Hamilton's equations of the 3-1-3 Euler-angle Hamiltonian, eq. 10, in
    (φ, ϑ, ψ, Φ, Θ, Ψ). The initial state comes from eqs. 13 and 15, the samples go back
    through eqs. 12 and 14. Singular at ϑ ∈ {0, π}: the run stops with a
    :class:`~attitude.errors.PropagationError` that says when and how close it came.
``"schwab"``
    The second-order equations in the Euler parameters with the norm-constraint multiplier λ
    (Schwab eqs. 19–24) and torque parameters f = 2 q∘(0, M') (eq. 25), as a first-order
    system in (q, q̇). The constraint |q| = 1 is only enforced at the acceleration level, so
    it drifts; the drift is reported.
``"euler_equations"``
    Euler's equations I ω̇ = τ − ω × Iω with q̇ = ½ q∘(0, ω) (Schwab eqs. 19 and 16): what
    most flight software integrates.

The non-canonical formulations accept ``method="dop853"`` and ``"scipy:<solver>"``; the
geometric methods (``"exact"``, ``"nosquish"``, ``"splitting"``) are built on the structure of
eq. 7 and apply to ``"canonical"`` only. See docs/formulations.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from orbit import _rk

from ._core import formulations as _kf
from ._methods import SAMPLE_BUDGET, RunResult, dop853_call
from .canonical import from_euler_canonical, to_euler_canonical
from .errors import AttitudeTypeError, AttitudeValueError, SingularityError
from .quaternion import conjugate, multiply

__all__ = [
    "EULER_STOP_SIN_THETA",
    "FORMULATIONS",
    "SINGULAR",
    "Canonical",
    "EulerAngles",
    "EulerEquations",
    "Formulation",
    "Schwab",
    "get_formulation",
]

#: Default threshold on sin ϑ below which the Euler-angle run stops (ϑ within ~1e-6 rad of
#: 0 or π): there the right-hand side of eq. 10 grows like 1/sin ϑ and the angles φ, ψ lose
#: their meaning individually.
EULER_STOP_SIN_THETA = 1e-6

#: RunResult status of a run stopped at the Euler-angle singularity.
SINGULAR = 10

#: Methods that exploit the structure of eq. 7 and exist for the canonical formulation only.
CANONICAL_ONLY_METHODS = ("exact", "nosquish", "splitting", "taylor")


def _pure(v: np.ndarray) -> np.ndarray:
    return np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)


def _vec_conj_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """vec(ã∘b) for stacks of quaternions (no unit-norm check: a may be off the sphere)."""
    return multiply(conjugate(a), b)[..., 1:]


class Formulation:
    """Base class: equations of motion in some variables, converted to and from (q, Q).

    Subclasses define the state size, the conversions, the compiled right-hand sides and,
    optionally, extra statistics. :meth:`run` integrates with ``"dop853"`` or
    ``"scipy:<solver>"``.
    """

    #: Registry name (the value of ``propagate(formulation=...)``).
    name: str = ""
    #: Number of state variables.
    n_state: int = 0

    # --- to be provided by subclasses -----------------------------------------------------
    def initial_state(self, problem: Any) -> np.ndarray:
        """The formulation's state at ``problem.t[0]`` from the canonical ``problem.y0``."""
        raise NotImplementedError

    def to_canonical(self, problem: Any, y: np.ndarray) -> np.ndarray:
        """Canonical states (m, 8) from the formulation's states (m, n_state)."""
        raise NotImplementedError

    # --- shared machinery -------------------------------------------------------------------
    def applies_to(self, method: str) -> bool:
        """Whether ``method`` can integrate this formulation."""
        return method == "dop853" or method.startswith("scipy:")

    def params(self, problem: Any) -> np.ndarray:
        """Kernel parameters: the potential's, then the slots of ``_core.formulations``."""
        extra = np.zeros(_kf.N_EXTRA)
        extra[_kf.X_MIN_SIN] = math.inf
        extra[_kf.X_TOL] = 0.0
        return np.concatenate([np.asarray(problem.params, dtype=np.float64), extra])

    def rhs(self, problem: Any) -> Callable:
        """Compiled right-hand side ``rhs(t, y, params, dydt)`` for the problem's potential."""
        return getattr(problem.entry, f"{self.name}_rhs")

    def extra_stats(self, problem: Any, y: np.ndarray) -> dict[str, Any]:
        """Formulation-specific statistics (recorded in the Dataset attrs)."""
        return {}

    def failure(self, problem: Any, params: np.ndarray, status: int, t_stop: float, y_last):
        """(status, message) for a failed run (subclasses may recognise their own causes)."""
        return status, _rk.STATUS_MESSAGES.get(status, "failure")

    def run(self, problem: Any, method: str, runner: Callable | None = None, **options: Any):
        """Integrate ``problem`` in this formulation and return canonical samples.

        Parameters
        ----------
        problem : attitude._methods.Problem
            Validated problem; ``problem.y0`` is the projected canonical initial state.
        method : str
            ``"dop853"`` or ``"scipy:<solver>"``.
        runner : callable, optional
            The canonical runner chosen by :func:`attitude.propagate` (unused: the runners
            are written for the 8 canonical variables).
        **options
            ``rtol``, ``atol``, ``max_step``, ``max_steps``, ``progress``, ``chunk``,
            ``solver`` (as passed by :func:`attitude.propagate`).

        Returns
        -------
        attitude._methods.RunResult
            ``y`` of shape (n_done, 8): canonical (q, Q) at ``problem.t[:n_done]``.
        """
        if not self.applies_to(method):
            raise AttitudeValueError(_method_message(self.name, method))
        y0 = self.initial_state(problem)
        params = self.params(problem)
        if method == "dop853":
            y, status, message, stats = self._run_dop853(problem, params, y0, **options)
        else:
            y, status, message, stats = self._run_scipy(problem, params, y0, **options)
        yc = self.to_canonical(problem, y) if y.shape[0] else np.empty((0, 8))
        stats.update(self.extra_stats(problem, y))
        stats.update(rtol=options["rtol"], atol=options["atol"], formulation=self.name)
        t_stop = stats.pop("t_stop", None)
        return RunResult(yc, int(status), message, stats, t_stop=t_stop)

    def _run_dop853(
        self,
        problem: Any,
        params: np.ndarray,
        y0: np.ndarray,
        *,
        rtol: float,
        atol: float,
        max_step: float = math.inf,
        max_steps: int = 100_000_000,
        progress: Callable[[int, int, float], None] | None = None,
        chunk: int | None = None,
        **_: Any,
    ):
        t = problem.t
        m = t.shape[0]
        n = self.n_state
        y_out = np.empty((m, n))
        work, tstate, counters = _rk.new_state(n)
        chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
        entry = getattr(problem.entry, f"dop853_{self.name}")
        done = 0
        status = _rk.SUCCESS
        while done < m:
            stop = min(m, done + chunk)
            args = (
                params,
                y0,
                t[0],
                t[done:stop],
                y_out[done:stop],
                work,
                tstate,
                counters,
                rtol,
                atol,
                t[-1],
                max_step,
                max_steps,
            )
            status, k = dop853_call(entry, *args)  # in step budgets: Ctrl-C acts
            done += int(k)
            if progress is not None:
                progress(done, m, float(tstate[0]))
            if status != _rk.SUCCESS:
                break
        stats = {
            "n_steps": int(counters[0]),
            "n_rhs": int(counters[1]),
            "n_rejected": int(counters[2]),
        }
        message = "success"
        if status != _rk.SUCCESS:
            stats["t_stop"] = float(tstate[0])
            status, message = self.failure(
                problem, params, int(status), float(tstate[0]), work[_rk.WORK.Y].copy()
            )
        return y_out[:done], status, message, stats

    def _scipy_event(self, params: np.ndarray):
        return None

    def _run_scipy(
        self,
        problem: Any,
        params: np.ndarray,
        y0: np.ndarray,
        *,
        solver: str,
        rtol: float,
        atol: float,
        max_step: float = math.inf,
        **_: Any,
    ):
        from scipy.integrate import solve_ivp

        rhs = self.rhs(problem)
        n = self.n_state

        def fun(tt, yy):
            out = np.empty(n)
            rhs(tt, np.ascontiguousarray(yy, dtype=np.float64), params, out)
            return out

        t = problem.t
        if t.shape[0] == 1:
            return y0[None, :].copy(), _rk.SUCCESS, "success", {"n_steps": 0, "n_rhs": 0}
        event = self._scipy_event(params)
        sol = solve_ivp(
            fun,
            (t[0], t[-1]),
            y0,
            method=solver,
            t_eval=t,
            rtol=rtol,
            atol=atol,
            max_step=max_step,
            events=event,
        )
        y = sol.y.T.copy()
        stats = {"n_rhs": int(sol.nfev)}
        good = np.all(np.isfinite(y), axis=1)
        n_ok = int(np.argmin(good)) if not np.all(good) else y.shape[0]
        y = y[:n_ok]
        if sol.status == 0 and n_ok == t.shape[0]:
            return y, _rk.SUCCESS, "success", stats
        if sol.status == 1:  # a terminal event (the formulation's own stop condition)
            t_stop = float(sol.t_events[0][0])
            y_last = sol.y_events[0][0]
            status = SINGULAR
        else:
            t_stop = float(sol.t[-1]) if sol.t.size else float(t[0])
            y_last = y[-1] if n_ok else y0
            status = _rk.NONFINITE
        stats["t_stop"] = t_stop
        status, message = self.failure(problem, params, status, t_stop, y_last)
        if status == _rk.NONFINITE:
            message = f"scipy {solver}: {sol.message}"
        return y, status, message, stats


# --------------------------------------------------------------------------------------------
# The formulations
# --------------------------------------------------------------------------------------------


class Canonical(Formulation):
    """Eq. 7 in (q, Q): the default; runs with every method through the canonical runner."""

    name = "canonical"
    n_state = 8

    def applies_to(self, method: str) -> bool:
        return True

    def run(self, problem: Any, method: str, runner: Callable | None = None, **options: Any):
        if runner is None:
            raise AttitudeTypeError(
                "runner: the canonical formulation runs the method's own runner; call it "
                "through attitude.propagate"
            )
        result = runner(problem, **options)
        result.stats.setdefault("formulation", self.name)
        return result


class EulerAngles(Formulation):
    """Hamilton's equations of the 3-1-3 Euler-angle Hamiltonian (Arribas et al. eq. 10).

    State (φ, ϑ, ψ, Φ, Θ, Ψ). The kinetic energy is eq. 9 written with eq. 8,

        H = ½ (sin²ψ/I1 + cos²ψ/I2) A² + Ψ²/(2 I3) + ½ (cos²ψ/I1 + sin²ψ/I2) Θ²
            + (1/I1 − 1/I2) A Θ sin ψ cos ψ + V(φ, ϑ, ψ),     A = (Φ − Ψ cos ϑ)/sin ϑ

    (eq. 10 as printed has ½ Ψ² for Ψ²/(2 I3)), and the potential enters through the torque:
    −∂V/∂φ = τ·s3, −∂V/∂ϑ = τ·ℓ, −∂V/∂ψ = τ·b3.

    Parameters
    ----------
    singular_tol : float
        The run stops when sin ϑ falls below this (default :data:`EULER_STOP_SIN_THETA`).
    """

    name = "euler_angles"
    n_state = 6

    def __init__(self, singular_tol: float = EULER_STOP_SIN_THETA):
        tol = float(singular_tol)
        if not (1e-12 <= tol < 1.0):
            raise AttitudeValueError(f"singular_tol: must be in [1e-12, 1), got {singular_tol!r}")
        self.singular_tol = tol

    def params(self, problem: Any) -> np.ndarray:
        p = super().params(problem)
        p[_kf.X_TOL] = self.singular_tol
        return p

    def initial_state(self, problem: Any) -> np.ndarray:
        q0, Q0 = problem.y0[:4], problem.y0[4:]
        s = 2.0 * math.hypot(q0[1], q0[2]) * math.hypot(q0[0], q0[3])  # sin ϑ (after eq. 14)
        if s < max(self.singular_tol, 1e-9):
            raise SingularityError(
                f"q0: the initial attitude has sin ϑ = {s:.3g} (b3 within {s:.2g} rad of ±s3), "
                f"where the 3-1-3 Euler angles are singular (threshold {self.singular_tol:g}); "
                f"use formulation='canonical'"
            )
        angles, momenta = to_euler_canonical(q0, Q0)  # eqs. 13 and 15
        return np.concatenate([angles, momenta])

    def to_canonical(self, problem: Any, y: np.ndarray) -> np.ndarray:
        q, Q = from_euler_canonical(y[:, :3], y[:, 3:])  # eqs. 12 and 14
        # Eq. 12 returns ±q0 at t0 (the angles fix the rotation, not the sign): keep the sign
        # of the caller's q0 along the (continuous) trajectory.
        sign = 1.0 if float(np.dot(q[0], problem.y0[:4])) >= 0.0 else -1.0
        return np.concatenate([sign * q, sign * Q], axis=1)

    def extra_stats(self, problem: Any, y: np.ndarray) -> dict[str, Any]:
        if y.shape[0] == 0:
            return {}
        return {"min_sin_theta": float(np.min(np.sin(y[:, 1])))}

    def failure(self, problem, params, status, t_stop, y_last):
        # A NaN derivative was met below the threshold and the step could not get past it
        # (trial stages that merely overshoot are rejected and retried, and do not count).
        hit = not math.isinf(params[_kf.X_MIN_SIN])
        stuck = status in (_rk.NONFINITE, _rk.STEP_TOO_SMALL)
        if (hit and stuck) or status == SINGULAR:
            theta = float(y_last[1])
            return SINGULAR, (
                f"the 3-1-3 Euler-angle equations are singular at ϑ = 0 or π: the run stopped "
                f"at t = {t_stop!r}, where sin ϑ = {math.sin(theta):.3g} (ϑ = {theta:.9g} rad), "
                f"the closest it came; one step further sin ϑ falls below singular_tol = "
                f"{self.singular_tol:g}. The canonical quaternion formulation has no such "
                f"singularity (formulation='canonical')"
            )
        return status, _rk.STATUS_MESSAGES.get(status, "failure")

    def _run_scipy(self, problem, params, y0, **options):
        # scipy only looks for events at accepted steps: let the right-hand side go NaN (and
        # reject trial stages) only below half the threshold, so that a step can end past
        # the threshold and the terminal event below locates the crossing.
        params[_kf.X_TOL] = 0.5 * self.singular_tol
        return super()._run_scipy(problem, params, y0, **options)

    def _scipy_event(self, params: np.ndarray):
        tol = self.singular_tol

        def near_singularity(t, y):
            return math.sin(y[1]) - tol

        near_singularity.terminal = True
        near_singularity.direction = -1.0
        return near_singularity


class Schwab(Formulation):
    """Euler-parameter equations with the norm-constraint multiplier (Schwab eqs. 19–25).

    State (q, q̇). Eq. 23 is solved for (q̈, λ) in closed form at every evaluation (see
    :func:`attitude._core.formulations.schwab_accelerations`); the constraint |q| = 1 enters
    only through its second derivative, so |q| − 1 and q·q̇ drift with the integration error.
    Samples go back to the canonical variables through the Legendre map of Arribas et al.
    Sect. 3, Q = 4 q∘(0, J vec(q̃∘q̇)) (= 2 q∘(0, J ω') on the manifold), without
    renormalisation: the Dataset's ``norm_error`` is the drift of |q|, and the attrs
    ``max_abs_qdot_q`` and ``max_abs_norm_error`` summarise both drifts.
    """

    name = "schwab"
    n_state = 8

    def initial_state(self, problem: Any) -> np.ndarray:
        q0, Q0 = problem.y0[:4], problem.y0[4:]
        inertia = problem.body.inertia
        omega = 0.5 * _vec_conj_mul(q0, Q0) / inertia
        qd0 = 0.5 * multiply(q0, _pure(omega))  # Schwab eq. 16
        return np.concatenate([q0, qd0])

    def to_canonical(self, problem: Any, y: np.ndarray) -> np.ndarray:
        q, qd = y[:, :4], y[:, 4:]
        Q = 4.0 * multiply(q, _pure(problem.body.inertia * _vec_conj_mul(q, qd)))
        return np.concatenate([q, Q], axis=1)

    def extra_stats(self, problem: Any, y: np.ndarray) -> dict[str, Any]:
        if y.shape[0] == 0:
            return {}
        q, qd = y[:, :4], y[:, 4:]
        nq = np.sqrt(np.sum(q * q, axis=1))
        return {
            "max_abs_qdot_q": float(np.max(np.abs(np.sum(q * qd, axis=1)))),
            "max_abs_norm_error": float(np.max(np.abs(nq - 1.0))),
        }


class EulerEquations(Formulation):
    """Euler's equations with quaternion kinematics (Schwab eqs. 19 and 16).

    State (q, ω). Samples go back through Q = 2 q∘(0, I ω), without renormalising q: the
    Dataset's ``norm_error`` is the drift of |q| (attr ``max_abs_norm_error``).
    """

    name = "euler_equations"
    n_state = 7

    def initial_state(self, problem: Any) -> np.ndarray:
        q0, Q0 = problem.y0[:4], problem.y0[4:]
        omega = 0.5 * _vec_conj_mul(q0, Q0) / problem.body.inertia
        return np.concatenate([q0, omega])

    def to_canonical(self, problem: Any, y: np.ndarray) -> np.ndarray:
        q, omega = y[:, :4], y[:, 4:]
        Q = 2.0 * multiply(q, _pure(problem.body.inertia * omega))
        return np.concatenate([q, Q], axis=1)

    def extra_stats(self, problem: Any, y: np.ndarray) -> dict[str, Any]:
        if y.shape[0] == 0:
            return {}
        nq = np.sqrt(np.sum(y[:, :4] ** 2, axis=1))
        return {"max_abs_norm_error": float(np.max(np.abs(nq - 1.0)))}


#: Registered formulations: name -> formulation object.
FORMULATIONS: dict[str, Formulation] = {
    f.name: f for f in (Canonical(), EulerAngles(), Schwab(), EulerEquations())
}


def _method_message(name: str, method: str) -> str:
    if method in CANONICAL_ONLY_METHODS:
        return (
            f"method: {method!r} is built on the structure of the canonical equations (eq. 7) "
            f"and applies only to formulation='canonical', not {name!r}; use 'dop853' or "
            f"'scipy:<solver>'"
        )
    return (
        f"method: {method!r} does not apply to formulation {name!r}; use 'dop853' or "
        f"'scipy:<solver>'"
    )


def get_formulation(name: str | Formulation, method: str = "dop853") -> Formulation:
    """The formulation called ``name``, checked against ``method``.

    Parameters
    ----------
    name : str or Formulation
        A key of :data:`FORMULATIONS` (``"canonical"``, ``"euler_angles"``, ``"schwab"``,
        ``"euler_equations"``), or a formulation object (e.g.
        ``EulerAngles(singular_tol=1e-4)``), which is returned after the check.
    method : str
        The integration method that will run it.

    Returns
    -------
    Formulation

    Raises
    ------
    AttitudeValueError
        Unknown name, or a method that does not apply to the formulation.
    AttitudeTypeError
        ``name`` or ``method`` of the wrong type.
    """
    if isinstance(name, Formulation):
        form = name
    elif isinstance(name, str):
        if name not in FORMULATIONS:
            raise AttitudeValueError(
                f"formulation: unknown formulation {name!r}; known: "
                + ", ".join(repr(k) for k in FORMULATIONS)
            )
        form = FORMULATIONS[name]
    else:
        raise AttitudeTypeError(
            f"formulation: expected a name ({', '.join(FORMULATIONS)}) or a Formulation, got "
            f"{type(name).__name__}"
        )
    if not isinstance(method, str):
        raise AttitudeTypeError(f"method: expected a string, got {type(method).__name__}")
    if not form.applies_to(method):
        raise AttitudeValueError(_method_message(form.name, method))
    return form

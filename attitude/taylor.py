"""``method="taylor"``: adaptive Taylor-series integration of the canonical equations.

Its runner is in :data:`attitude.propagate.METHODS`:
``propagate(..., method="taylor", rtol=1e-12)``.

The canonical equations (Arribas, Elipe & Palacios 2006, eq. 7) are polynomial in (q, Q), so the
Taylor coefficients of the solution follow from automatic-differentiation recurrences (Cauchy
products) in compiled code; the order p = ⌈−½ ln rtol + 1⌉ and the step ρ/e² exp(−0.7/(p − 1))
come from the tolerance and an estimate ρ of the radius of convergence as in Jorba & Zou (2005);
output times inside a step are read off its Taylor polynomial (dense output). Built-in
potentials only (torque-free, heavy top, gravity gradient, whose orbit is restarted exactly at
every step); the kernels are in :mod:`attitude._core.taylor`, the derivation and the measured
accuracy and speed in docs/integrators.md.

:class:`TaylorStepper` exposes the integrator one step at a time together with the Taylor
polynomial of the current step (``stepper.dense(t)``), for root finding on it (event location).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from orbit import _rk
from orbit._state_kernels import TYPE_KEPLER

from ._core import taylor as _kt
from ._methods import SAMPLE_BUDGET, Problem, RunResult, dop853_call
from .body import RigidBody
from .errors import AttitudeValueError, PropagationError
from .potentials import GravityGradient, HeavyTop, TorqueFree

__all__ = ["TaylorStepper", "check_potential", "run_taylor"]


def check_potential(pot: Any) -> None:
    """Raise :class:`AttitudeValueError` (naming ``method``) unless ``method="taylor"`` can
    expand the potential ``pot``: torque-free, heavy top, gravity gradient of a Kepler orbit."""
    if not isinstance(pot, (TorqueFree, HeavyTop, GravityGradient)):
        raise AttitudeValueError(
            f"method: 'taylor' expands the built-in potentials (TorqueFree, HeavyTop, "
            f"GravityGradient of a Kepler orbit) in Taylor series and cannot expand "
            f"{' + '.join(pot.term_names())} ({type(pot).__name__}); use method='dop853' for it"
        )
    if isinstance(pot, GravityGradient) and int(pot.orbit.kernel_data()[0]) != TYPE_KEPLER:
        raise AttitudeValueError(
            f"method: 'taylor' restarts the orbit from Kepler's equation at every step; the "
            f"gravity gradient of a {type(pot.orbit).__name__} needs method='dop853'"
        )


def _check_builtin(problem: Problem) -> None:
    check_potential(problem.potential)


def run_taylor(
    problem: Problem,
    *,
    rtol: float,
    atol: float,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    on_chunk: Callable[[int, np.ndarray], None] | None = None,
    **_: Any,
) -> RunResult:
    """Runner of ``method="taylor"`` (see the module docstring)."""
    _check_builtin(problem)
    t = problem.t
    m = t.shape[0]
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    streaming = on_chunk is not None
    y_out = np.empty((min(chunk, m) if streaming else m, 8))
    work, tstate, counters = _kt.new_state()
    done = 0
    k = 0
    status = _rk.SUCCESS
    y_chunk = y_out[:0]
    while done < m:
        stop = min(m, done + chunk)
        t_chunk = t[done:stop]
        y_chunk = y_out[: stop - done] if streaming else y_out[done:stop]
        pause = None
        if progress is not None:

            def pause(kk, done=done):
                progress(done + kk, m, float(tstate[0]))

        # at most STEP_BUDGET steps a compiled call (Ctrl-C acts in between), the work
        # estimated after the first steps; continued bit for bit (same layout as DOP853's)
        status, k = dop853_call(
            _kt.taylor_canonical_builtin, problem.params, problem.y0, float(t[0]),
            np.ascontiguousarray(t_chunk), y_chunk, work, tstate, counters, rtol, atol,
            float(t[m - 1]), max_step, max_steps, pause,
        )  # fmt: skip
        if streaming and k:
            on_chunk(done, y_chunk[: int(k)])
        done += int(k)
        if progress is not None:
            progress(done, m, float(tstate[0]))
        if status != _rk.SUCCESS:
            break
    stats = {
        "rtol": rtol,
        "atol": atol,
        "order": int(tstate[3]),
        "n_steps": int(counters[0]),
    }
    msg = _rk.STATUS_MESSAGES[int(status)]
    t_stop = None if status == _rk.SUCCESS else float(tstate[0])
    if streaming:  # keep only the last state (the samples went to on_chunk)
        last = max(done - 1, 0)
        keep = y_chunk[: int(k)][-1:].copy()
        return RunResult(keep, int(status), msg, stats, first=last, t_stop=t_stop)
    return RunResult(y_out[:done], int(status), msg, stats, t_stop=t_stop)


run_taylor.streams = True  # type: ignore[attr-defined]


class TaylorStepper:
    """The ``"taylor"`` integrator one step at a time, with the polynomial of the current step.

    Parameters
    ----------
    problem : Problem
        A validated problem with a built-in potential (as the runners receive it).
    rtol, atol : float
        Tolerances (the order follows from ``rtol``).
    t_end : float
        Final time [s]: no step crosses it.
    max_step : float
        Largest step [s].

    Examples
    --------
    Locate a sign change of q0 on the step polynomials (bisection inside the step)::

        st = TaylorStepper.from_state(body, q0, Q0, 0.0, 100.0, HeavyTop(0.5, [1, 0, 0]))
        while st.t < 100.0:
            s0 = st.y[0]
            st.step()
            if s0 * st.y[0] < 0.0:
                lo, hi = st.t_old, st.t
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if s0 * st.dense(mid)[0] > 0.0 else (lo, mid)
    """

    def __init__(
        self,
        problem: Problem,
        *,
        rtol: float = 1e-10,
        atol: float = 1e-12,
        t_end: float,
        max_step: float = math.inf,
    ) -> None:
        _check_builtin(problem)
        self.params = problem.params
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.t_end = float(t_end)
        self.max_step = float(max_step)
        self.work, self.tstate, self.counters = _kt.new_state()
        self.work[_kt.Y, :8] = problem.y0
        self.tstate[0] = self.tstate[2] = float(problem.t[0])
        _kt.set_order(self.tstate, _kt.order_from_tolerance(self.rtol))
        self.counters[3] = 1

    @classmethod
    def from_state(
        cls,
        body: Any,
        q0: Any,
        Q0: Any,
        t0: float,
        t_end: float,
        potential: Any = None,
        *,
        rtol: float = 1e-10,
        atol: float = 1e-12,
        max_step: float = math.inf,
    ) -> TaylorStepper:
        """A stepper from an initial state, validated and projected as by ``propagate``.

        Parameters
        ----------
        body : RigidBody or array_like, shape (3,)
        q0, Q0 : array_like, shape (4,)
            Initial attitude quaternion and conjugate momenta.
        t0, t_end : float
            Initial and final time [s] (``t_end < t0`` integrates backwards).
        potential : Potential, optional
            A built-in potential (default torque-free).
        """
        from ._validation import as_float_array, as_times
        from .canonical import project_state
        from .potentials import as_potential

        b = body if isinstance(body, RigidBody) else RigidBody(body)
        pot = as_potential(potential).bind(b)
        tt = as_times([t0, t_end], "t0, t_end")
        q, Q, _ = project_state(
            as_float_array(q0, "q0", trailing=4, ndim=1),
            as_float_array(Q0, "Q0", trailing=4, ndim=1),
        )
        problem = Problem(
            b, pot, pot._params(b.inertia), np.concatenate([q, Q]), tt, pot._entry_points()
        )
        return cls(problem, rtol=rtol, atol=atol, t_end=float(tt[1]), max_step=max_step)

    @property
    def order(self) -> int:
        """Order p of the Taylor polynomials."""
        return int(self.tstate[3])

    @property
    def t(self) -> float:
        """Current time [s] (end of the last step)."""
        return float(self.tstate[0])

    @property
    def t_old(self) -> float:
        """Start of the last step [s]."""
        return float(self.tstate[2])

    @property
    def y(self) -> np.ndarray:
        """Current state (q, Q), shape (8,)."""
        return self.work[_kt.Y, :8].copy()

    @property
    def coefficients(self) -> np.ndarray:
        """Taylor coefficients of the last step, shape (order + 1, 8): y(t_old + τ) = Σ c_k τ^k."""
        return self.work[: self.order + 1, :8].copy()

    def step(self) -> None:
        """Take one step (towards ``t_end``; a step ending there stops there).

        Raises
        ------
        PropagationError
            The step failed (non-finite state, step below round-off); the state is unchanged.
        """
        status = _kt.taylor_step(
            self.params, self.work, self.tstate, self.counters, self.rtol, self.atol,
            self.t_end, self.max_step,
        )  # fmt: skip
        if status != _rk.SUCCESS:
            raise PropagationError(
                f"taylor step at t = {self.t!r}: {_rk.STATUS_MESSAGES[status]}", time=self.t
            )

    def dense(self, t: float) -> np.ndarray:
        """State (q, Q), shape (8,), at a time ``t`` inside the last step, from its polynomial."""
        if self.counters[4] == 0:
            raise AttitudeValueError("t: no step taken yet; call step() first")
        lo, hi = sorted((self.t_old, self.t))
        if not lo <= t <= hi:
            raise AttitudeValueError(f"t: {t!r} is outside the last step [{lo!r}, {hi!r}]")
        out = np.empty(8)
        _kt.dense_eval(self.work, self.order, float(t) - self.t_old, out)
        return out

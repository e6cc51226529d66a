"""What a method runner receives and returns, and the two built-in runners.

A *method runner* is ``runner(problem, **options) -> RunResult``: it integrates a validated
:class:`Problem` (plain floats, the model's compiled entry points) to the problem's output times.
:func:`attitude.propagate` chooses the runner by name from its registry ``METHODS``, built from
this module (``"dop853"``, ``"scipy:<solver>"``) and the modules of the other methods
(:mod:`attitude.exact`, :mod:`attitude.splitting`), which import this one and never
:mod:`attitude.propagate` (no import cycles).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from orbit import _rk

from . import _interrupt
from .body import RigidBody
from .errors import AttitudeValueError
from .potentials import Potential

__all__ = [
    "SAMPLE_BUDGET",
    "SCIPY_SOLVERS",
    "STEP_BUDGET",
    "EventRecords",
    "Problem",
    "RunResult",
    "check_work",
    "dop853_call",
    "run_dop853",
    "run_scipy",
]

#: Most integration steps one compiled call takes before it returns to Python, where a pending
#: Ctrl-C (KeyboardInterrupt) is raised: a step costs 1-15 µs (torque-free to gravity gradient;
#: more with a user potential), so a call lasts ~0.02-0.3 s. Results do not depend on it: the
#: integrator state lives in caller arrays and a call continues bit for bit where the last one
#: stopped (tests/test_reliability.py).
STEP_BUDGET = 20_000
#: Most output samples one compiled call fills (dense output and diagnostics), for the same
#: reason: a run of 1e7 samples in one call would not answer Ctrl-C for seconds.
SAMPLE_BUDGET = 65_536

#: Steps after which an adaptive run estimates its work: (steps so far) + (time left) / (step
#: size reached). The first step itself is no guide: DOP853's starting-step formula (Hairer,
#: Nørsett & Wanner II.4) is 10 to 19 000 times smaller than the steps the controller settles
#: on (torque-free to gravity gradient, measured), while this estimate is within a factor
#: 0.2-2.3 of the steps taken over whole runs (17 cases; docs/reliability.md).
PROBE_STEPS = 64
#: A run estimated to need more than this many times ``max_steps`` is stopped right after the
#: probe, with an AttitudeValueError (it cannot finish); above ``max_steps`` it warns.
WORK_MARGIN = 100.0

#: ``scipy.integrate.solve_ivp`` methods reachable as ``method="scipy:<name>"``.
SCIPY_SOLVERS = ("RK23", "RK45", "DOP853", "Radau", "BDF", "LSODA")


@dataclass
class Problem:
    """A validated propagation problem in plain floats (what the method runners receive)."""

    body: RigidBody
    potential: Potential
    params: np.ndarray  # compiled-kernel parameters (inertia, kind, potential numbers)
    y0: np.ndarray  # (8,) projected initial state
    t: np.ndarray  # (m,) output times; t[0] is the initial epoch
    entry: Any  # the model's compiled entry points (attitude._core.entry_points or a user copy)
    events: Any = None  # attitude.events.EventSet, or None
    spacecraft: Any = None  # attitude._holds.SpacecraftRun of a spacecraft with actuators

    @property
    def rhs(self) -> Callable:
        """Compiled canonical right-hand side rhs(t, y, params, dydt)."""
        return self.entry.canonical_rhs


@dataclass
class RunResult:
    """What a method runner returns."""

    y: np.ndarray  # (n_done, 8)
    status: int = _rk.SUCCESS
    message: str = "success"
    stats: dict[str, Any] = field(default_factory=dict)
    first: int = 0  # index in problem.t of y[0] (> 0 when earlier samples were streamed out)
    t_stop: float | None = None  # time the integration reached when it failed
    # With events: the occurrences (EventRecords); status EVENT: the last row of y is the state
    # at the terminal event, at time t_event (not one of problem.t).
    events: Any = None
    t_event: float | None = None


@dataclass
class EventRecords:
    """Occurrences of the events of a run (``attitude._core.events`` buffers, trimmed)."""

    t: np.ndarray  # (k,) times
    which: np.ndarray  # (k,) int64 event number
    direction: np.ndarray  # (k,) int64, +1 rising, −1 falling
    y: np.ndarray  # (k, 8) canonical states at the events
    count: np.ndarray  # (n_events,) int64 occurrences of each (also those not recorded)
    first: np.ndarray  # (n_events,) time of the first occurrence (NaN: none)


class EventBuffers:
    """Per-run event state and growable record buffers for the compiled events drivers."""

    def __init__(self, n_events: int, n_state: int = 8, capacity: int = 64):
        from ._core import events as _ke

        self.evs = np.zeros((n_events, _ke.EVS.SIZE))
        self.count = np.zeros(2, dtype=np.int64)
        self.t = np.empty(capacity)
        self.k = np.empty((capacity, 2), dtype=np.int64)
        self.y = np.empty((capacity, n_state))
        self.scr: np.ndarray | None = None

    def kernel_args(self, evd: np.ndarray) -> tuple:
        """The event arrays of a spacecraft run's hold driver
        (:mod:`attitude._core.spacecraft_events`), with the locator's scratch."""
        width = max(self.y.shape[1], self.evs.shape[0], 6)
        if self.scr is None or self.scr.shape[1] != width:
            self.scr = np.empty((7, width))
        return (evd, self.evs, self.count, self.t, self.k, self.y, self.scr)

    def grow(self) -> None:
        n = self.t.shape[0]
        self.t = np.concatenate([self.t, np.empty(n)])
        self.k = np.concatenate([self.k, np.empty((n, 2), dtype=np.int64)])
        self.y = np.concatenate([self.y, np.empty((n, self.y.shape[1]))])

    def records(self) -> EventRecords:
        from ._core import events as _ke

        k = int(self.count[0])
        return EventRecords(
            self.t[:k].copy(),
            self.k[:k, 0].copy(),
            self.k[:k, 1].copy(),
            self.y[:k].copy(),
            self.evs[:, _ke.EVS.COUNT].astype(np.int64),
            self.evs[:, _ke.EVS.FIRST].copy(),
        )


# --------------------------------------------------------------------------------------------
# Method runners
# --------------------------------------------------------------------------------------------


def check_work(steps: int, t: float, h: float, t_end: float, max_steps: int) -> None:
    """After ``steps`` steps at ``t`` with step size ``h``: refuse or warn about the run.

    Raises
    ------
    AttitudeValueError
        The estimated number of steps exceeds ``WORK_MARGIN * max_steps``: the run cannot
        finish (a rotation too fast, a span too long or tolerances too tight for max_steps).
    """
    if not (math.isfinite(h) and h > 0.0 and math.isfinite(t)):
        return
    need = steps + abs(t_end - t) / h
    if need <= max_steps:
        return
    what = (
        f"this run needs about {need:.2g} steps (its step size settles at {h:.3g} after "
        f"{steps} steps, with {abs(t_end - t):.6g} of the time span left), more than "
        f"max_steps = {max_steps}"
    )
    if need > WORK_MARGIN * max_steps:
        raise AttitudeValueError(
            f"max_steps: {what}: it cannot finish; shorten the time span, loosen rtol/atol, "
            "or raise max_steps (a body spinning that fast needs steps that short)"
        )
    warnings.warn(f"{what}: it will probably stop early", RuntimeWarning, stacklevel=_user_level())


def _user_level() -> int:
    """``stacklevel`` of the first caller outside the package (for warnings from runners)."""
    import os
    import sys

    pkg = os.path.dirname(os.path.abspath(__file__)) + os.sep
    f, level = sys._getframe(2), 2
    while f is not None and os.path.abspath(f.f_code.co_filename).startswith(pkg):
        f, level = f.f_back, level + 1
    return level


def dop853_call(
    entry: Callable,
    params: np.ndarray,
    y0: np.ndarray,
    t0: float,
    t_out: np.ndarray,
    y_out: np.ndarray,
    work: np.ndarray,
    tstate: np.ndarray,
    counters: np.ndarray,
    rtol: float,
    atol: float,
    t_end: float,
    max_step: float,
    max_steps: int,
    on_pause: Callable[[int], None] | None = None,
) -> tuple[int, int]:
    """A compiled DOP853 entry point through ``t_out``, at most :data:`STEP_BUDGET` steps a call.

    The arguments are those of :func:`orbit._rk.dop853_run` (``entry`` is one of the
    ``dop853_*`` entry points, or ``attitude._core.taylor.taylor_canonical_builtin``, which has
    the same layout). Each call is given the step limit ``min(max_steps, steps so far
    + STEP_BUDGET)``; when it stops at that limit short of ``max_steps`` it is called again,
    continuing from the stored state bit for bit, after Python has had the chance to raise a
    pending ``KeyboardInterrupt`` (and :func:`attitude._interrupt.check`). ``on_pause(k)`` is
    called then with the number of rows of ``y_out`` filled so far (a progress report). A
    fresh run (``counters`` all 0) first takes :data:`PROBE_STEPS` steps and estimates its work
    (:func:`check_work`: an error if it cannot finish within ``max_steps``).

    Returns
    -------
    status, n_done : int
        As :func:`~orbit._rk.dop853_run` over the whole of ``t_out``.
    """
    k = 0
    probe = int(counters[0]) == 0  # a fresh run: estimate the work after its first steps
    while True:
        budget = PROBE_STEPS if probe else STEP_BUDGET
        limit = min(max_steps, int(counters[0]) + budget)
        status, kk = entry(
            params, y0, t0, t_out[k:], y_out[k:], work, tstate, counters,
            rtol, atol, t_end, max_step, limit,
        )  # fmt: skip
        k += int(kk)
        _interrupt.check()
        if int(status) == _rk.TOO_MANY_STEPS and (limit < max_steps or probe):
            if probe:
                probe = False
                h = min(float(tstate[1]), max_step)
                check_work(int(counters[0]), float(tstate[0]), h, t_end, max_steps)
                if limit >= max_steps:
                    return int(status), k
            if on_pause is not None:
                on_pause(k)
            continue
        return int(status), k


def run_dop853(
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
    if problem.events is not None:
        return _run_dop853_events(
            problem, rtol=rtol, atol=atol, max_step=max_step, max_steps=max_steps,
            progress=progress, chunk=chunk, on_chunk=on_chunk,
        )  # fmt: skip
    t = problem.t
    m = t.shape[0]
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    # Streaming (on_chunk): one chunk-sized buffer, handed out and reused, so memory is
    # bounded whatever the number of output samples.
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, 8))
    work, tstate, counters = _rk.new_state(8)
    t0, t_end = float(t[0]), float(t[m - 1])
    done = 0
    k = 0
    status = _rk.SUCCESS
    y_chunk = y_out[:0]
    while done < m:
        stop = min(m, done + chunk)
        t_chunk = np.ascontiguousarray(t[done:stop])
        y_chunk = y_out[: stop - done] if on_chunk is not None else y_out[done:stop]
        pause = None
        if progress is not None:

            def pause(kk, done=done):
                progress(done + kk, m, float(tstate[0]))

        status, k = dop853_call(
            problem.entry.dop853_canonical, problem.params, problem.y0, t0, t_chunk, y_chunk,
            work, tstate, counters, rtol, atol, t_end, max_step, max_steps, pause,
        )  # fmt: skip
        if on_chunk is not None and k:
            on_chunk(done, y_chunk[:k])
        done += k
        if progress is not None:
            progress(done, m, float(tstate[0]))
        if status != _rk.SUCCESS:
            break
    stats = {
        "rtol": rtol,
        "atol": atol,
        "n_steps": int(counters[0]),
        "n_rhs": int(counters[1]),
        "n_rejected": int(counters[2]),
    }
    msg = _rk.STATUS_MESSAGES[int(status)]
    t_stop = None if status == _rk.SUCCESS else float(tstate[0])
    if on_chunk is not None:  # keep only the last state (the samples went to on_chunk)
        last = max(done - 1, 0)
        y_last = y_chunk[:k][-1:].copy()
        return RunResult(y_last, int(status), msg, stats, first=last, t_stop=t_stop)
    return RunResult(y_out[:done], int(status), msg, stats, t_stop=t_stop)


run_dop853.streams = True  # type: ignore[attr-defined]


def _run_dop853_events(
    problem: Problem,
    *,
    rtol: float,
    atol: float,
    max_step: float,
    max_steps: int,
    progress: Callable[[int, int, float], None] | None,
    chunk: int | None,
    on_chunk: Callable[..., None] | None,
) -> RunResult:
    """:func:`run_dop853` with events located inside the compiled loop."""
    ev = problem.events
    t = problem.t
    m = t.shape[0]
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, 8))
    work, tstate, counters = _rk.new_state(8)
    buf = EventBuffers(ev.n)
    done = 0
    status = _rk.SUCCESS
    last_y = y_out[:0]

    def entry(params, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, n):
        # the events entry point with dop853_run's arguments (the buffers read at each call:
        # they grow)
        return problem.entry.dop853_canonical_events(
            params, ev.data, buf.evs, buf.count, buf.t, buf.k, buf.y, y0, t0, t_out, y_o, work,
            tstate, counters, rtol, atol, t_end, h, n,
        )  # fmt: skip

    while done < m:
        stop = min(m, done + chunk)
        while True:
            y_chunk = y_out[: stop - done] if on_chunk is not None else y_out[done:stop]
            pause = None
            if progress is not None:

                def pause(kk, done=done):
                    progress(done + kk, m, float(tstate[0]))

            # the step budget, Ctrl-C and the work estimate as for the run without events
            status, k = dop853_call(
                entry, problem.params, problem.y0, float(t[0]), t[done:stop], y_chunk, work,
                tstate, counters, rtol, atol, float(t[m - 1]), max_step, max_steps, pause,
            )  # fmt: skip
            if k:
                last_y = y_chunk[:k]
                if on_chunk is not None:
                    on_chunk(done, y_chunk[:k])
            done += k
            if status != _rk.EVENT_BUFFER_FULL:
                break
            buf.grow()
        if progress is not None:
            progress(done, m, float(tstate[0]))
        if status != _rk.SUCCESS:
            break
    stats = {
        "rtol": rtol,
        "atol": atol,
        "n_steps": int(counters[0]),
        "n_rhs": int(counters[1]),
        "n_rejected": int(counters[2]),
    }
    msg = _rk.STATUS_MESSAGES[int(status)]
    t_event = None
    y_all = y_out[:done] if on_chunk is None else last_y[-1:].copy()
    first = 0 if on_chunk is None else max(done - 1, 0)
    if status == _rk.EVENT:
        t_event = float(tstate[0])
        if not (done and t[done - 1] == t_event):  # the state at the event: one more sample
            y_ev = work[_rk.WORK.Y].copy()[None, :]
            if on_chunk is not None:
                on_chunk(done, y_ev, t_event)
                first = done
                y_all = y_ev
            else:
                y_all = np.concatenate([y_all, y_ev])
        else:
            t_event = None  # it is the last output sample itself
    ok = status in (_rk.SUCCESS, _rk.EVENT)
    return RunResult(
        y_all,
        int(status),
        msg,
        stats,
        first=first,
        t_stop=None if ok else float(tstate[0]),
        events=buf.records(),
        t_event=t_event,
    )


class _NonFiniteDerivative(Exception):
    """The right-hand side of a ``scipy:*`` run became non-finite (raised inside ``fun``)."""


_NONFINITE_RHS = "the derivative of the state became non-finite (NaN or inf)"


def run_scipy(
    problem: Problem,
    *,
    solver: str,
    rtol: float,
    atol: float,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    on_chunk: Callable[[int, np.ndarray], None] | None = None,
    **_: Any,
) -> RunResult:
    """``scipy.integrate`` solver ``solver`` on eq. 7, stepped here, output streamed.

    The loop is that of ``solve_ivp(..., t_eval=t)`` (one ``step()`` of the solver, then its
    dense output at the output times the step passed), so the samples are those of
    ``solve_ivp``; but the output times are taken a chunk at a time and the samples handed to
    ``on_chunk`` as they are computed, so memory does not grow with the number of samples
    (``solve_ivp`` keeps every sample and an interpolant per step).
    """
    import scipy.integrate

    rhs = problem.rhs
    params = problem.params

    def fun(tt, yy):
        out = np.empty(8)
        rhs(tt, np.ascontiguousarray(yy), params, out)
        if not np.isfinite(out).all():
            # scipy's step loops shrink the step on a NaN error estimate and leave only below
            # their minimum step, which a NaN size never is (they would spin); its implicit
            # solvers raise a raw ValueError. Stop here instead.
            raise _NonFiniteDerivative(tt)
        return out

    t = problem.t
    m = t.shape[0]
    stats: dict[str, Any] = {"rtol": rtol, "atol": atol, "n_steps": 0, "n_rhs": 0}
    if m == 1:
        y1 = problem.y0[None, :].copy()
        if on_chunk is not None:
            on_chunk(0, y1)
        return RunResult(y1, stats=stats)
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    streaming = on_chunk is not None
    t0, tf = float(t[0]), float(t[m - 1])
    try:
        ode = getattr(scipy.integrate, solver)(
            fun, t0, problem.y0, tf, rtol=rtol, atol=atol, max_step=max_step
        )
    except _NonFiniteDerivative:
        return RunResult(np.empty((0, 8)), _rk.NONFINITE, _NONFINITE_RHS, stats, t_stop=t0)
    direction = 1.0 if tf > t0 else -1.0
    y_all = None if streaming else np.empty((m, 8))
    buf = np.empty((chunk if streaming else 0, 8))  # samples not handed out yet
    n_buf = 0
    done = 0  # samples computed
    win0, win = 0, np.ascontiguousarray(t[0 : min(m, 2 * SAMPLE_BUDGET)])  # upcoming times
    status, message = _rk.SUCCESS, "success"
    n_steps = 0
    last = problem.y0

    def emit(rows: np.ndarray) -> None:
        nonlocal n_buf
        if not streaming:
            y_all[done : done + rows.shape[0]] = rows
            return
        i = 0
        while i < rows.shape[0]:
            take = min(chunk - n_buf, rows.shape[0] - i)
            buf[n_buf : n_buf + take] = rows[i : i + take]
            n_buf += take
            i += take
            if n_buf == chunk:
                on_chunk(done - n_buf + i, buf[:n_buf])
                n_buf = 0

    while done < m:
        if n_steps >= max_steps:
            status, message = _rk.TOO_MANY_STEPS, _rk.STATUS_MESSAGES[_rk.TOO_MANY_STEPS]
            break
        t_before = ode.t
        try:
            msg = ode.step()
        except _NonFiniteDerivative:
            status, message = _rk.NONFINITE, _NONFINITE_RHS
            break
        except ValueError as exc:  # e.g. Radau/BDF: LU of a Jacobian that overflowed
            status, message = _rk.NONFINITE, f"scipy {solver}: {exc}"
            break
        n_steps += 1
        if ode.status == "failed":
            status, message = _rk.NONFINITE, f"scipy {solver}: {msg}"
            break
        tn = ode.t
        if tn == t_before and ode.status != "finished":
            # LSODA reports steps of size 0 as successes (an overflowing torque): they would
            # be repeated up to max_steps
            status, message = _rk.STEP_TOO_SMALL, f"scipy {solver}: the step size fell to 0"
            break
        if n_steps == PROBE_STEPS:
            check_work(n_steps, float(tn), float(ode.step_size or math.nan), tf, max_steps)
        sol = None
        # The output times this step passed (those equal to tn included), evaluated as
        # solve_ivp does, in one call, unless there are more than SAMPLE_BUDGET of them.
        while done < m:
            if done + SAMPLE_BUDGET > win0 + win.shape[0] and win0 + win.shape[0] < m:
                win0, win = done, np.ascontiguousarray(t[done : min(m, done + 2 * SAMPLE_BUDGET)])
            piece = win[done - win0 : done - win0 + SAMPLE_BUDGET]
            j = int(np.searchsorted(direction * piece, direction * tn, side="right"))
            if j == 0:
                break
            if sol is None:
                sol = ode.dense_output()
            rows = sol(piece[:j]).T
            ok = np.all(np.isfinite(rows), axis=1)
            if not ok.all():
                good = int(np.argmin(ok))
                emit(rows[:good])
                done += good
                status, message = _rk.NONFINITE, _rk.STATUS_MESSAGES[_rk.NONFINITE]
                break
            emit(rows)
            done += j
            last = rows[-1]
            if j < piece.shape[0]:
                break
        if status != _rk.SUCCESS:
            break
        if progress is not None:
            progress(done, m, float(tn))
        if n_steps % 64 == 0:
            _interrupt.check()
        if ode.status == "finished" and done < m:  # cannot happen: tn == tf serves the rest
            status, message = _rk.NONFINITE, f"scipy {solver}: stopped at t = {tn!r}"
            break
    stats.update(n_steps=n_steps, n_rhs=int(ode.nfev))
    t_stop = None if status == _rk.SUCCESS else float(ode.t)
    if streaming:
        if n_buf:
            on_chunk(done - n_buf, buf[:n_buf])
        y_last = np.asarray(last, dtype=np.float64).reshape(1, 8).copy()
        return RunResult(y_last if done else y_last[:0], status, message, stats,
                         first=max(done - 1, 0), t_stop=t_stop)  # fmt: skip
    return RunResult(y_all[:done], status, message, stats, t_stop=t_stop)


run_scipy.streams = True  # type: ignore[attr-defined]

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
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._core import rk as _rk
from .body import RigidBody
from .potentials import Potential

__all__ = ["SCIPY_SOLVERS", "EventRecords", "Problem", "RunResult", "run_dop853", "run_scipy"]

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


class _EventBuffers:
    """Per-run event state and growable record buffers for the compiled events drivers."""

    def __init__(self, n_events: int, n_state: int = 8, capacity: int = 64):
        from ._core import events as _ke

        self.evs = np.zeros((n_events, _ke.EVS_COLS))
        self.count = np.zeros(2, dtype=np.int64)
        self.t = np.empty(capacity)
        self.k = np.empty((capacity, 2), dtype=np.int64)
        self.y = np.empty((capacity, n_state))

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
            self.evs[:, _ke.EVS_COUNT].astype(np.int64),
            self.evs[:, _ke.EVS_FIRST].copy(),
        )


# --------------------------------------------------------------------------------------------
# Method runners
# --------------------------------------------------------------------------------------------


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
    chunk = m if chunk is None else max(1, int(chunk))
    # Streaming (on_chunk): one chunk-sized buffer, handed out and reused, so memory is
    # bounded whatever the number of output samples.
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, 8))
    work, tstate, counters = _rk.new_state(8)
    done = 0
    status = _rk.SUCCESS
    while done < m:
        stop = min(m, done + chunk)
        t_chunk = t[done:stop]
        y_chunk = y_out[: stop - done] if on_chunk is not None else y_out[done:stop]
        status, k = problem.entry.dop853_canonical(
            problem.params,
            problem.y0,
            t[0],
            t_chunk,
            y_chunk,
            work,
            tstate,
            counters,
            rtol,
            atol,
            t[-1],
            max_step,
            max_steps,
        )
        if on_chunk is not None and k:
            on_chunk(done, y_chunk[: int(k)])
        done += int(k)
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
        y_last = y_chunk[: int(k)][-1:].copy()
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
    chunk = m if chunk is None else max(1, int(chunk))
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, 8))
    work, tstate, counters = _rk.new_state(8)
    buf = _EventBuffers(ev.n)
    done = 0
    status = _rk.SUCCESS
    last_y = y_out[:0]
    while done < m:
        stop = min(m, done + chunk)
        while True:
            y_chunk = y_out[: stop - done] if on_chunk is not None else y_out[done:stop]
            status, k = problem.entry.dop853_canonical_events(
                problem.params, ev.data, buf.evs, buf.count, buf.t, buf.k, buf.y, problem.y0,
                t[0], t[done:stop], y_chunk, work, tstate, counters, rtol, atol, t[-1],
                max_step, max_steps,
            )  # fmt: skip
            k = int(k)
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
            y_ev = work[_rk.Y].copy()[None, :]
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


def run_scipy(
    problem: Problem, *, solver: str, rtol: float, atol: float, max_step=math.inf, **_: Any
) -> RunResult:
    from scipy.integrate import solve_ivp

    rhs = problem.rhs
    params = problem.params

    def fun(tt, yy):
        out = np.empty(8)
        rhs(tt, np.ascontiguousarray(yy), params, out)
        return out

    t = problem.t
    if t.shape[0] == 1:
        return RunResult(problem.y0[None, :].copy(), stats={"rtol": rtol, "atol": atol, "n_rhs": 0})
    sol = solve_ivp(
        fun,
        (t[0], t[-1]),
        problem.y0,
        method=solver,
        t_eval=t,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
    )
    y = sol.y.T.copy()
    stats = {"rtol": rtol, "atol": atol, "n_rhs": int(sol.nfev)}
    ok = sol.status == 0 and np.all(np.isfinite(y))
    if ok:
        return RunResult(y, stats=stats)
    good = np.all(np.isfinite(y), axis=1)
    n = int(np.argmin(good)) if not np.all(good) else y.shape[0]
    return RunResult(y[:n], _rk.NONFINITE, f"scipy {solver}: {sol.message}", stats)

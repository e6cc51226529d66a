"""Symplectic, time-reversible fixed-step methods: ``"nosquish"`` and ``"splitting"``.

Their runners are in :data:`attitude.propagate.METHODS`, so they are called as
``propagate(..., method="splitting", dt=..., order=4)``.

``"nosquish"``
    The NO_SQUISH splitting of Miller et al., J. Chem. Phys. 116, 8649 (2002), written for the
    canonical quaternions (q, Q) of Arribas, Elipe & Palacios (2006): a half kick of the
    potential, the free rotor split into exact rotations about the principal axes
    T₁(h/2) T₂(h/2) T₃(h) T₂(h/2) T₁(h/2), another half kick. Orders 4 and 6 are symmetric
    compositions of that 2nd-order step (Suzuki's 5-stage fractal; Kahan & Li's 9-stage s9odr6).
    Cheap (no special functions), but the rotor splitting itself is only 2nd order, so its
    error does not vanish with the torque.
``"splitting"``
    H = T + U split into the *exact* torque-free flow (:mod:`attitude._core.exact`, Jacobi
    elliptic functions) and potential kicks: Strang for order 2 and Blanes & Moan's (2002)
    symmetric S₆ (order 4) and S₁₀ (order 6) partitioned methods. Its error is proportional to
    the torque, so for the weak torques of spacecraft it is orders of magnitude more accurate
    than ``"nosquish"`` at the same step, and exact (to round-off) without torque.

Both methods are compositions of exact flows, hence symplectic and time-reversible; |q| = 1 and
q·Q = 0 are conserved to round-off and the energy error stays bounded (no drift) over very long
runs. A time-dependent potential is handled in the extended phase space (t as a coordinate with
conjugate momentum p_t, H = T + p_t + U(q, t)): the free flows advance t, the kicks use the
frozen t. See docs/integrators.md.

Output times and steps
----------------------
``dt`` is the largest step. Each interval between consecutive output times is covered by the
fewest *equal* steps no longer than ``dt`` (a relative excess of 1e-9 is tolerated so that
``t = arange(...) * dt`` does not gain a step to round-off). Every step is the same symmetric
composition, so the run stays symplectic and reversible; with equally spaced outputs the step is
constant over the whole run (and equal to ``dt`` when the spacing is a multiple of it), which is
what backward error analysis needs for the bounded-energy property. A last partial step instead
would change the step, and with it the modified Hamiltonian, at every output time.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from orbit import _rk

from . import _interrupt, _methods
from ._core import splitting as _ks
from ._methods import SAMPLE_BUDGET, Problem, RunResult
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "ORDERS", "check_step_budget", "check_step_options", "count_steps", "run_nosquish",
    "run_splitting",
]  # fmt: skip

#: Orders available for both methods.
ORDERS = (2, 4, 6)


def check_step_options(method: str, dt: Any, order: Any) -> tuple[float, int]:
    """``dt`` (a positive finite float) and ``order`` (2, 4 or 6) of a fixed-step method."""
    if dt is None:
        raise AttitudeValueError(
            f"dt: method {method!r} is a fixed-step method and needs the step, e.g. "
            f"propagate(..., method={method!r}, dt=0.01)"
        )
    try:
        dtf = float(dt)
    except (TypeError, ValueError):
        raise AttitudeTypeError(f"dt: expected a positive number, got {dt!r}") from None
    if not (np.isfinite(dtf) and dtf > 0.0):
        raise AttitudeValueError(f"dt: must be a positive finite number, got {dt!r}")
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)):
        raise AttitudeTypeError(f"order: expected 2, 4 or 6, got {order!r}")
    if int(order) not in ORDERS:
        raise AttitudeValueError(f"order: method {method!r} has orders 2, 4 and 6, got {order!r}")
    return dtf, int(order)


def count_steps(t: Any, dt: float) -> int:
    """Steps over the output times ``t`` (an array or a TimeGrid, read a slice at a time)."""
    m = t.shape[0]
    total = 0
    for i in range(0, m - 1, SAMPLE_BUDGET):
        spans = np.abs(np.diff(np.asarray(t[i : min(m, i + SAMPLE_BUDGET + 1)])))
        spans = spans[spans > 0]
        if spans.size:
            total += int(np.sum(np.maximum(1, np.ceil(spans / dt * (1.0 - 1e-9)))))
    return total


def check_step_budget(t: Any, dt: float, max_steps: int) -> None:
    """Refuse, before any work, a run whose steps over the output times ``t``
    (:func:`count_steps`) are more than ``max_steps``."""
    n_total = count_steps(t, dt)
    if n_total > max_steps:
        raise AttitudeValueError(
            f"dt: {dt:g} needs {n_total} steps over the output times, more than "
            f"max_steps={max_steps}; use a larger dt or raise max_steps"
        )


def _run(
    name: str,
    problem: Problem,
    *,
    dt: Any = None,
    order: Any = 4,
    max_steps: int = 100_000_000,
    progress: Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    on_chunk: Callable[[int, np.ndarray], None] | None = None,
) -> RunResult:
    dt, order = check_step_options(name, dt, order)
    if problem.potential.rate_dependent:
        raise AttitudeValueError(
            f"method: {name!r} composes exact flows of the potential, so its torque must depend "
            f"on the attitude and time only; the {problem.potential.name} model depends on the "
            "body rates: use method='dop853'"
        )
    t = problem.t
    m = t.shape[0]
    check_step_budget(t, dt, max_steps)
    kinds, coefs, toffs = _ks.method_tables(name, order)
    if problem.events is not None:
        return _run_events(problem, kinds, coefs, toffs, dt, order, progress, chunk, on_chunk)
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    streaming = on_chunk is not None
    # Streaming: one chunk-sized buffer, handed to on_chunk and reused (bounded memory).
    y_out = np.empty((min(chunk, m) if streaming else m, 8))
    state = np.empty(8)
    _ks.canonical_to_state(problem.y0, state)
    counters = np.zeros(_ks.N_COUNTERS, dtype=np.int64)
    counters[4] = _methods.STEP_BUDGET  # steps per compiled call: Ctrl-C acts in between
    run = problem.entry.composition
    done = 0
    status = _ks.SUCCESS
    buf = y_out[:0]
    filled = 0
    while done < m:
        stop = min(m, done + chunk)
        buf = y_out[: stop - done] if streaming else y_out[done:stop]
        pos = 0
        if done == 0:  # the initial state is the first sample, as given
            buf[0] = problem.y0
            pos = 1
        while True:
            status, k = run(
                problem.params, kinds, coefs, toffs, state, float(t[done + pos - 1]),
                np.ascontiguousarray(t[done + pos : stop]), dt, buf[pos:], counters,
            )  # fmt: skip
            pos += int(k)
            _interrupt.check()
            if status != _ks.PAUSED:
                break
            if progress is not None:
                progress(done + pos, m, float(t[done + pos - 1]))
        filled = pos
        if streaming and filled:
            on_chunk(done, buf[:filled])
        done += filled
        if progress is not None:
            progress(done, m, float(t[done - 1]))
        if status != _ks.SUCCESS:
            break
    stats = {
        "n_steps": int(counters[0]),
        "n_torque": int(counters[1]),
        "n_free_flow": int(counters[2]),
        "dt": dt,
        "order": order,
    }
    status = _rk.NONFINITE if status == _ks.NONFINITE else _rk.SUCCESS
    msg = _rk.STATUS_MESSAGES[int(status)]
    if streaming:  # keep only the last state (the samples went to on_chunk)
        last = max(done - 1, 0)
        keep = buf[:filled][-1:].copy() if done else y_out[:0].copy()
        return RunResult(keep, int(status), msg, stats, first=last)
    return RunResult(y_out[:done], int(status), msg, stats)


def _run_events(problem, kinds, coefs, toffs, dt, order, progress, chunk, on_chunk) -> RunResult:
    """:func:`_run` with events (each step whole; :mod:`attitude._core.events`)."""
    from ._methods import EventBuffers

    ev = problem.events
    t = problem.t
    m = t.shape[0]
    chunk = m if chunk is None else max(1, int(chunk))
    streaming = on_chunk is not None
    y_out = np.empty((min(chunk, m) if streaming else m, 8))
    state = np.empty(8)
    _ks.canonical_to_state(problem.y0, state)
    counters = np.zeros(_ks.N_COUNTERS, dtype=np.int64)
    counters[4] = _methods.STEP_BUDGET  # steps per compiled call: Ctrl-C acts in between
    buf = EventBuffers(ev.n)
    g0 = np.empty((1, ev.n))
    problem.entry.event_values(t[:1], problem.y0[None, :], problem.params, ev.data, g0)
    buf.evs[:, 0] = g0[0]
    buf.evs[:, 2] = np.nan
    done = 0
    status = _rk.SUCCESS
    last = y_out[:0]
    while done < m:
        stop = min(m, done + chunk)
        while True:
            buf_y = y_out[: stop - done] if streaming else y_out[done:stop]
            first = 0
            if done == 0:
                buf_y[0] = problem.y0
                first = 1
            status, k = problem.entry.composition_events(
                problem.params, kinds, coefs, toffs, state, t[done + first - 1],
                t[done + first : stop], dt, buf_y[first:], counters, ev.data, buf.evs,
                buf.count, buf.t, buf.k, buf.y,
            )  # fmt: skip
            filled = first + int(k)
            if filled:
                last = buf_y[:filled]
                if streaming:
                    on_chunk(done, buf_y[:filled])
            done += filled
            _interrupt.check()
            if status == _rk.TOO_MANY_STEPS:  # paused at the step budget: go on from there
                if progress is not None and done:
                    progress(done, m, float(t[done - 1]))
                continue
            if status != _rk.EVENT_BUFFER_FULL:
                break
            buf.grow()
        if progress is not None:
            progress(done, m, float(t[done - 1]))
        if status != _rk.SUCCESS:
            break
    stats = {
        "n_steps": int(counters[0]),
        "n_torque": int(counters[1]),
        "n_free_flow": int(counters[2]),
        "dt": dt,
        "order": order,
    }
    y_all = y_out[:done] if not streaming else last[-1:].copy()
    first_row = 0 if not streaming else max(done - 1, 0)
    t_event = None
    if status == _rk.EVENT:
        y_ev = np.empty((1, 8))
        _ks.state_to_canonical(state, y_ev[0])
        t_event = float(buf.t[int(buf.count[0]) - 1])
        if done and t[done - 1] == t_event:
            t_event = None
        elif streaming:
            on_chunk(done, y_ev, t_event)
            first_row, y_all = done, y_ev
        else:
            y_all = np.concatenate([y_all, y_ev])
    elif status != _rk.SUCCESS:
        status = _rk.NONFINITE
    msg = _rk.STATUS_MESSAGES[int(status)]
    return RunResult(
        y_all, int(status), msg, stats, first=first_row, events=buf.records(), t_event=t_event
    )


def run_nosquish(problem: Problem, *, dt: Any = None, order: Any = 4, **options: Any) -> RunResult:
    """Runner of ``method="nosquish"`` (see the module docstring)."""
    return _run("nosquish", problem, dt=dt, order=order, **_pick(options))


def run_splitting(problem: Problem, *, dt: Any = None, order: Any = 4, **options: Any) -> RunResult:
    """Runner of ``method="splitting"`` (see the module docstring)."""
    return _run("splitting", problem, dt=dt, order=order, **_pick(options))


def _pick(options: dict[str, Any]) -> dict[str, Any]:
    return {k: options[k] for k in ("max_steps", "progress", "chunk", "on_chunk") if k in options}


run_nosquish.streams = True  # type: ignore[attr-defined]
run_splitting.streams = True  # type: ignore[attr-defined]

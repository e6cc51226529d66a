"""Runs of a spacecraft with actuators: the state (q, Q, h), held commands, the runners.

A :class:`~attitude.spacecraft.Spacecraft` with reaction wheels is a gyrostat whose state
carries the wheels' axial momenta h beside (q, Q) (:mod:`attitude._core.gyrostat`); its
commands are held from one boundary to the next, and the integrators restart at every boundary
(:mod:`attitude._core.holds`). This module prepares such a run (:func:`prepare`: the spacecraft
block, the initial wheel momenta, the command arrays) and runs it (:func:`run_dop853`, the
runner of ``method="dop853"`` for a spacecraft), and turns its output rows into the diagnostics
the Dataset needs (:func:`diagnostics`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ._core import holds as _kh
from ._core import rk as _rk
from ._methods import SAMPLE_BUDGET, Problem, RunResult, dop853_call
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = [
    "SPACECRAFT_METHODS",
    "SpacecraftRun",
    "check_taylor",
    "diagnostics",
    "prepare",
    "run_dop853",
    "run_taylor",
]

#: Methods that integrate a spacecraft with actuators.
SPACECRAFT_METHODS = ("dop853", "taylor")


@dataclass
class SpacecraftRun:
    """What a spacecraft run adds to a :class:`~attitude._methods.Problem`."""

    spacecraft: Any
    sc: np.ndarray  # the spacecraft block (held slots written during the run)
    hold_t: np.ndarray  # (K,) hold start times
    hold_u: np.ndarray  # (K, n_cmd) raw commands
    n_state: int  # 8 + n_wheels
    n_rec: int  # record columns after the state in an output row
    ideal_control: bool = False  # flight software acting through an ideal torque

    def fresh_block(self) -> np.ndarray:
        """A copy of the spacecraft block for one run (its held slots are written)."""
        return self.sc.copy()


def prepare(
    spacecraft: Any, q0: np.ndarray, Q0: np.ndarray, t: np.ndarray, commands: Any
) -> tuple[SpacecraftRun, np.ndarray]:
    """The spacecraft run's data and the initial state (q0, Q0, h0).

    The initial wheel momenta follow from the total body momentum g0 = ½ vec(q̃0∘Q0) and the
    wheels' initial speeds Ω_k relative to the body: ω0 = I⁻¹ (g0 − Σ J_k Ω_k a_k),
    h_k = J_k (a_k·ω0 + Ω_k).
    """
    from .actuators.commands import CommandSchedule
    from .quaternion import conjugate, multiply

    tt = np.asarray(t, dtype=np.float64)
    if tt.shape[0] > 1 and tt[-1] < tt[0]:
        raise AttitudeValueError(
            "t: a spacecraft with actuators is propagated forward in time (its commands are "
            "held from one time to the next); give increasing times"
        )
    nw, nm, nt = spacecraft.counts
    if commands is None:
        hold_t = np.zeros(0)
        hold_u = np.zeros((0, nw + nm + nt))
    else:
        if not isinstance(commands, CommandSchedule):
            raise AttitudeTypeError(
                f"commands: expected an attitude.CommandSchedule, got {type(commands).__name__}"
            )
        hold_t, hold_u = commands.arrays(nw, nm, nt)
        hold_t = np.ascontiguousarray(hold_t, dtype=np.float64)
        hold_u = np.ascontiguousarray(hold_u, dtype=np.float64)
    sc = spacecraft.block(np.array([tt[0], tt[-1]]))
    g0 = 0.5 * multiply(conjugate(q0), Q0)[1:]
    w0 = spacecraft.rate_from_momentum(g0)
    h0 = spacecraft.wheel_momenta(w0)
    y0 = np.concatenate([q0, Q0, h0]).astype(np.float64)
    run = SpacecraftRun(
        spacecraft=spacecraft,
        sc=sc,
        hold_t=hold_t,
        hold_u=hold_u,
        n_state=8 + nw,
        n_rec=_kh.record_width(nw, nm, nt),
    )
    return run, y0


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
    """``method="dop853"`` for a spacecraft: DOP853 restarted at every hold boundary.

    Output rows are the state (8 + n_wheels) then the record of the commands in force
    (:func:`attitude._core.holds.record`).
    """
    sr: SpacecraftRun = problem.spacecraft
    t = problem.t
    m = t.shape[0]
    n = sr.n_state
    width = n + sr.n_rec
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, width))
    work, tstate, counters = _rk.new_state(n)
    hs = np.zeros(_kh.HS_SIZE)
    P = (problem.params, sr.fresh_block())
    ctl = (hs, sr.hold_t, sr.hold_u, np.zeros(sr.hold_u.shape[1]))
    entry_point = problem.entry.dop853_spacecraft

    def entry(params, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, nmax):
        return entry_point(
            P, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, nmax, ctl
        )

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
            entry, problem.params, problem.y0, t0, t_chunk, y_chunk, work, tstate, counters,
            rtol, atol, t_end, max_step, max_steps, pause,
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
        "n_holds": int(hs[_kh.HS_NEXT]),
    }
    msg = _rk.STATUS_MESSAGES[int(status)]
    t_stop = None if status == _rk.SUCCESS else float(tstate[0])
    if on_chunk is not None:
        last = max(done - 1, 0)
        return RunResult(
            y_chunk[:k][-1:].copy(), int(status), msg, stats, first=last, t_stop=t_stop
        )
    return RunResult(y_out[:done], int(status), msg, stats, t_stop=t_stop)


run_dop853.streams = True  # type: ignore[attr-defined]


def check_taylor(spacecraft: Any, potential: Any) -> None:
    """Raise :class:`AttitudeValueError` (naming ``method``) unless ``method="taylor"`` expands
    this spacecraft: a built-in potential it expands (torque-free, heavy top, gravity gradient
    of a Kepler orbit), wheels whose friction is piecewise affine (Coulomb + viscous with a
    limit-cycle speed, no Stribeck regime), thrusters; no magnetorquers (the field is a table,
    not a series)."""
    from .taylor import check_potential

    check_potential(potential)
    if spacecraft.magnetorquers:
        raise AttitudeValueError(
            "method: 'taylor' does not expand the magnetorquers' torque (the geomagnetic field "
            "is tabulated, not a series); use method='dop853'"
        )
    for i, w in enumerate(spacecraft.wheels):
        if w.stribeck_speed is not None:
            raise AttitudeValueError(
                f"method: 'taylor' expands piecewise-affine wheel friction; wheel {i} has a "
                "Stribeck regime (exp and tanh of the speed): use method='dop853'"
            )
        if w.coulomb_friction > 0.0 and w.limit_cycle_speed == 0.0:
            raise AttitudeValueError(
                f"method: wheel {i}'s Coulomb friction with limit_cycle_speed = 0 jumps at "
                "zero speed; give it a limit-cycle speed (Basilisk's default 1e-4 rad/s) or "
                "use method='dop853'"
            )


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
    """``method="taylor"`` for a spacecraft: the gyrostat's Taylor series, restarted at every
    hold boundary, the order chosen for each hold (:mod:`attitude._core.taylor_gyrostat`)."""
    from ._core import taylor as _kt
    from ._core import taylor_gyrostat as _ktg

    sr: SpacecraftRun = problem.spacecraft
    check_taylor(sr.spacecraft, problem.potential)
    t = problem.t
    m = t.shape[0]
    n = sr.n_state
    nw = n - 8
    width = n + sr.n_rec
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, width))
    work = np.zeros((_kt.WORK_ROWS, _ktg.work_columns(nw)))
    tstate = np.zeros(_ktg.TS_SIZE + nw)
    counters = np.zeros(5, dtype=np.int64)
    hs = np.zeros(_kh.HS_SIZE)
    P = (problem.params, sr.fresh_block())
    ctl = (hs, sr.hold_t, sr.hold_u, np.zeros(sr.hold_u.shape[1]))
    kernel = _ktg.taylor_holds_run

    def entry(params, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, nmax):
        return kernel(
            P, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, nmax, ctl
        )

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
            entry, problem.params, problem.y0, t0, t_chunk, y_chunk, work, tstate, counters,
            rtol, atol, t_end, max_step, max_steps, pause,
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
        "order": int(tstate[3]),
        "n_steps": int(counters[0]),
        "n_series_terms": int(counters[1]),
        "n_holds": int(hs[_kh.HS_NEXT]),
    }
    msg = _rk.STATUS_MESSAGES[int(status)]
    t_stop = None if status == _rk.SUCCESS else float(tstate[0])
    if on_chunk is not None:
        last = max(done - 1, 0)
        return RunResult(
            y_chunk[:k][-1:].copy(), int(status), msg, stats, first=last, t_stop=t_stop
        )
    return RunResult(y_out[:done], int(status), msg, stats, t_stop=t_stop)


run_taylor.streams = True  # type: ignore[attr-defined]


def diagnostics(problem: Problem, t: np.ndarray, rows: np.ndarray) -> dict[str, np.ndarray]:
    """Per-sample diagnostics of a spacecraft run's output rows.

    Returns
    -------
    dict
        ``diag`` (m, 13) (the columns of :func:`attitude._core.dynamics.diagnostics_with`, with
        the gyrostat's ω and energy), ``torques`` (m, n_terms + 1, 3) (the model's terms and
        their sum), ``actuators`` (m, 4, 3) (the torques of the wheels on the body, the
        magnetorquers, the thrusters and the ideal control torque), ``wheels``
        (m, n_wheels, 2) (speed Ω relative to the body, friction torque), ``records``
        (m, n_rec).
    """
    from ._core import gyrostat as _kg

    sr: SpacecraftRun = problem.spacecraft
    n = sr.n_state
    m = rows.shape[0]
    y = np.ascontiguousarray(rows[:, :n])
    rec = np.ascontiguousarray(rows[:, n:])
    diag = np.empty((m, 13))
    n_terms = len(problem.potential.terms)
    torques = np.empty((m, n_terms + 1, 3))
    act = np.empty((m, 4, 3))
    nw = n - 8
    wheels = np.empty((m, nw, 2))
    sc = sr.fresh_block()
    for i in range(0, m, SAMPLE_BUDGET):
        j = min(m, i + SAMPLE_BUDGET)
        problem.entry.spacecraft_diagnostics(t[i:j], y[i:j], problem.params, sc, diag[i:j])
        problem.entry.term_torques_at_rates(
            t[i:j], y[i:j, :8], diag[i:j, 0:3], problem.params, torques[i:j]
        )
        _kg.actuator_diagnostics(t[i:j], y[i:j], rec[i:j], sc, act[i:j], wheels[i:j])
    return {"diag": diag, "torques": torques, "actuators": act, "wheels": wheels, "records": rec}

"""Runs of a spacecraft with actuators: the state (q, Q, h), held commands, the runners.

A :class:`~attitude.spacecraft.Spacecraft` with reaction wheels is a gyrostat whose state
carries the wheels' axial momenta h beside (q, Q) (:mod:`attitude._core.gyrostat`); its
commands are held from one boundary to the next, and the integrators restart at every boundary
(:mod:`attitude._core.holds`). The commands come from an open-loop schedule or from the flight
software at its ticks (:mod:`attitude._core.fsw`; your own Python ``step`` is called between
compiled calls). This module prepares such a run (:func:`prepare`: the spacecraft block, the
initial wheel momenta, the command source), runs it (:func:`run_dop853`, :func:`run_taylor`),
and turns its output rows into the diagnostics the Dataset needs (:func:`diagnostics`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from orbit import _rk

from . import _compiling
from ._core import holds as _kh
from ._methods import SAMPLE_BUDGET, EventBuffers, Problem, RunResult, dop853_call
from ._validation import as_float_array
from .errors import AttitudeError, AttitudeTypeError, AttitudeValueError

__all__ = [
    "SPACECRAFT_METHODS",
    "SpacecraftRun",
    "check_taylor",
    "diagnostics",
    "event_state_variables",
    "initial_state",
    "prepare",
    "run_dop853",
    "run_taylor",
]

#: Methods that integrate a spacecraft with actuators.
SPACECRAFT_METHODS = ("dop853", "taylor")
#: Tick records allocated at first (the buffer doubles when full).
TICK_BUFFER = 4096


@dataclass
class SpacecraftRun:
    """What a spacecraft run adds to a :class:`~attitude._methods.Problem`."""

    spacecraft: Any
    sc: np.ndarray  # the spacecraft block (held slots written during the run)
    hold_t: np.ndarray  # (K,) hold start times
    hold_u: np.ndarray  # (K, n_cmd) raw commands
    n_state: int  # 8 + n_wheels (+ 7: r, v, m when the orbit is propagated with the attitude)
    n_rec: int  # record columns after the state in an output row
    ideal_control: bool = False  # flight software acting through an ideal torque
    program: Any = None  # attitude.software._software.Program of a flight software
    software: Any = None  # the FlightSoftware
    ticks: np.ndarray | None = None  # (k, width) tick records of the last run
    # streaming: tick_sink(records) takes the tick records as they fill a buffer, and at the
    # end; ``ticks`` is then empty
    tick_sink: Callable[[np.ndarray], None] | None = None

    @property
    def coupled(self) -> bool:
        """The orbit is in the state (attitude._core.coupled)."""
        return bool(self.spacecraft.coupled)

    def fresh_block(self) -> np.ndarray:
        """A copy of the spacecraft block for one run (its held slots are written)."""
        return self.sc.copy()


def prepare(
    spacecraft: Any,
    q0: np.ndarray,
    Q0: np.ndarray,
    t: np.ndarray,
    commands: Any,
    software: Any = None,
    max_steps: int | None = None,
    samples: Any = None,
) -> tuple[SpacecraftRun, np.ndarray]:
    """The spacecraft run's data and the initial state (q0, Q0, h0).

    The initial wheel momenta follow from the total body momentum g0 = ½ vec(q̃0∘Q0) and the
    wheels' initial speeds Ω_k relative to the body: ω0 = I⁻¹ (g0 − Σ J_k Ω_k a_k),
    h_k = J_k (a_k·ω0 + Ω_k).
    """
    from .actuators.commands import CommandSchedule

    tt = np.asarray(t, dtype=np.float64)
    if tt.shape[0] > 1 and tt[-1] < tt[0]:
        raise AttitudeValueError(
            "t: a spacecraft with actuators is propagated forward in time (its commands are "
            "held from one time to the next); give increasing times"
        )
    nw, nm, nt = spacecraft.counts
    if commands is not None and software is not None:
        raise AttitudeValueError(
            "commands: the flight software commands the actuators; give commands= (open "
            "loop) or software= (closed loop), not both"
        )
    if commands is None:
        hold_t = np.zeros(0)
        hold_u = np.zeros((0, nw + nm + nt))
    else:
        if not isinstance(commands, CommandSchedule):
            raise AttitudeTypeError(
                f"commands: expected an attitude.CommandSchedule, got {type(commands).__name__}"
            )
        hold_t, hold_u = commands.arrays(nw, nm, nt)
        # writable C-ordered copies, as without a schedule: the schedule's read-only arrays
        # would compile the drivers a second time (numba types a read-only array apart)
        hold_t = np.array(hold_t, dtype=np.float64, order="C")
        hold_u = np.array(hold_u, dtype=np.float64, order="C")
    prog = None
    if software is not None:
        from .software import FlightSoftware
        from .software._software import program

        if not isinstance(software, FlightSoftware):
            raise AttitudeTypeError(
                f"software: expected an attitude.FlightSoftware, got {type(software).__name__}"
            )
        check_software_span(software, float(tt[0]), float(tt[-1]), max_steps)
        prog = program(software, spacecraft, float(tt[0]), float(tt[-1]), samples)
    sc = spacecraft.block(np.array([tt[0], tt[-1]]))
    y0 = initial_state(spacecraft, q0, Q0)
    n_orbit = 0
    if spacecraft.coupled:
        from ._coupling import N_ORBIT, attach_software, initial_orbit_state

        n_orbit = N_ORBIT
        y0 = np.concatenate([y0, initial_orbit_state(spacecraft, float(tt[0]))])
        if prog is not None:
            attach_software(prog.fw, sc, spacecraft)
    run = SpacecraftRun(
        spacecraft=spacecraft,
        sc=sc,
        hold_t=hold_t,
        hold_u=hold_u,
        n_state=8 + nw + n_orbit,
        n_rec=_kh.record_width(nw, nm, nt),
        ideal_control=bool(prog is not None and prog.ideal),
        program=prog,
        software=software,
    )
    return run, y0


def check_software_span(software: Any, t0: float, t1: float, max_steps: int | None) -> None:
    """Refuse, before any work, flight software whose ticks t0 + phase + k·period the run
    t < t1 of the run [t0, t1] cannot hold: a period as long as the run or longer (one tick,
    at t0 + phase, and its command held to the end), a phase at or past the end (no tick),
    more ticks than ``max_steps`` (each tick ends an integration
    step: a period of 1e-300 s would run ~1e300 ticks). A single time (t1 = t0) runs only
    the tick at t0."""
    span = t1 - t0
    if not span > 0.0:
        return
    period, phase = software.period, software.phase
    run = f"the run's span {span:g} s (t = {t0:g} … {t1:g} s)"
    if period >= span:
        raise AttitudeValueError(
            f"period: the software's period {period:g} s is not shorter than {run}: it would "
            f"tick once, at t = {t0 + phase:g} s, and hold that command to the end (no tick "
            f"runs at the end itself); give a period below {span:g} s (a few ticks at "
            "least), or a longer run"
        )
    if phase >= span:
        raise AttitudeValueError(
            f"phase: the first tick t0 + phase = {t0 + phase:g} s is at or after the end of "
            f"{run}: the software would never act; give a phase below {span:g} s (it is "
            "measured from the start of the run), or a longer run"
        )
    if max_steps is not None and span / period > max_steps:
        raise AttitudeValueError(
            f"period: a tick every {period!r} s over the time span {span:g} s is "
            f"{span / period:.3g} ticks, more than max_steps = {max_steps}: the run cannot "
            "finish; lengthen the software's period (or raise max_steps)"
        )


def initial_state(spacecraft: Any, q0: np.ndarray, Q0: np.ndarray) -> np.ndarray:
    """The gyrostat's initial state (q0, Q0, h0), shape (8 + n_wheels,), from a projected
    (q0, Q0): the wheel momenta from g0 = ½ vec(q̃0∘Q0) and the wheels' initial speeds Ω_k,
    ω0 = I⁻¹ (g0 − Σ J_k Ω_k a_k), h_k = J_k (a_k·ω0 + Ω_k)."""
    from .quaternion import conjugate, multiply

    g0 = 0.5 * multiply(conjugate(q0), Q0)[1:]
    w0 = spacecraft.rate_from_momentum(g0)
    h0 = spacecraft.wheel_momenta(w0)
    return np.concatenate([q0, Q0, h0]).astype(np.float64)


def check_taylor(spacecraft: Any, potential: Any) -> None:
    """Raise :class:`AttitudeValueError` (naming ``method``) unless ``method="taylor"`` expands
    this spacecraft: a built-in potential it expands (torque-free, heavy top, gravity gradient
    of a Kepler orbit), wheels whose friction is piecewise affine (Coulomb + viscous with a
    limit-cycle speed, no Stribeck regime), thrusters; no magnetorquers (the field is a table,
    not a series)."""
    from .taylor import check_potential

    if spacecraft.coupled:
        from ._coupled_taylor import check_spacecraft

        check_spacecraft(spacecraft, potential)
        return
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


class _Source:
    """The command source of a run: the driver's ``ctl`` tuple, and what to do when the driver
    asks for commands (your own step function) or for room for its tick records."""

    def __init__(self, run: SpacecraftRun, problem: Problem):
        self.run = run
        self.problem = problem
        self.hs = np.zeros(_kh.HS.SIZE)
        prog = run.program
        self.prog = prog
        if prog is None:
            self.ctl = (self.hs, run.hold_t, run.hold_u, np.zeros(run.hold_u.shape[1]))
            return
        self.fs = prog.fresh_state()
        self.cmd = np.zeros(max(prog.n_cmd, 3))
        self.sink = run.tick_sink
        # every record at once in memory (the run checked its size), else a buffer the sink
        # empties; one spare row (an unrecorded tick writes nothing there)
        rows = prog.n_recorded + 1
        self.rec = np.full(
            (rows if self.sink is None else min(rows, TICK_BUFFER), prog.rec_width), np.nan
        )
        self.rc = np.zeros(1, dtype=np.int64)
        self.ctl = (self.hs, prog.fw, self.fs, self.cmd, self.rec, self.rc)

    def handle(self, status: int, y: np.ndarray, t: float, sc: np.ndarray) -> None:
        """Answer the driver: grow the tick records, or call your own step function."""
        if status == _kh.RECORDS_FULL:
            if self.sink is not None:
                self.flush()
                return
            self.rec = np.concatenate([self.rec, np.full_like(self.rec, np.nan)])
            self.ctl = (self.hs, self.prog.fw, self.fs, self.cmd, self.rec, self.rc)
            return
        self._step(y, t, sc)
        self.hs[_kh.HS.READY] = 1.0

    def flush(self) -> None:
        """Hand the tick records so far to the sink; the buffer starts again."""
        k = int(self.rc[0])
        if k:
            self.sink(self.rec[:k].copy())
            self.rc[0] = 0

    def _step(self, y: np.ndarray, t: float, sc: np.ndarray) -> None:
        from ._core import fsw as _kf
        from ._core import fsw_step as _ks
        from .software._software import Measurements

        prog = self.prog
        craft = self.run.spacecraft
        nw = craft.counts[0]
        meas = np.empty(_ks.MEAS.WHEEL_SPEEDS + 2 * nw)
        _ks.measure_from_python(t, np.ascontiguousarray(y[: 8 + nw]), self.problem.params, sc,
                                prog.fw, self.fs, meas)  # fmt: skip

        got = _ks.MEAS.read(meas)  # views of this call's own array
        for k in ("field", "sun", "r", "v"):  # NaN: unavailable (no orbit, no epoch)
            if np.isnan(got[k]).any():
                got[k] = None
        w = _ks.MEAS.WHEEL_SPEEDS
        m = Measurements(
            **got, wheel_speeds=meas[w : w + nw], wheel_momenta=meas[w + nw : w + 2 * nw]
        )
        tick = int(self.fs[_kf.FS.TICK])
        try:
            out = prog.python_step(m.t, m)
        except Exception as exc:
            raise _StepFailed(exc, tick, t) from exc
        try:
            self.cmd[:] = _commands(out, craft, tick, t)
        except AttitudeError as exc:  # a PropagationError with .partial, as the compiled step's
            raise _StepFailed(exc, tick, t, refused=True) from exc


class _StepFailed(Exception):
    """Your own step function raised, or returned commands that cannot be applied
    (``refused``), carried to propagate with the tick and time."""

    def __init__(self, exc: BaseException, tick: int, t: float, refused: bool = False):
        super().__init__(str(exc))
        self.exc = exc
        self.tick = tick
        self.t = t
        self.refused = refused


def _commands(out: Any, craft: Any, tick: int, t: float) -> np.ndarray:
    """The raw command vector (length max(n_cmd, 3)) from what a step function returned."""
    nw, nm, nt = craft.counts
    n = nw + nm + nt
    where = f"software: your step function at tick {tick} (t = {t!r} s)"
    res = np.zeros(max(n, 3))
    if out is None:
        raise AttitudeTypeError(f"{where} returned None; expected an array of commands or a dict")
    if isinstance(out, dict):
        allowed = {"wheel_torque": (0, nw), "dipole": (nw, nm), "thrust": (nw + nm, nt)}
        if n == 0:
            allowed = {"torque": (0, 3)}
        for k, v in out.items():
            if k not in allowed:
                raise AttitudeValueError(
                    f"{where} returned the key {k!r}; expected {', '.join(sorted(allowed))}"
                )
            c0, cn = allowed[k]
            if v is None:
                raise AttitudeTypeError(f"{where} returned {k} = None; expected {cn} numbers")
            a = as_float_array(v, f"{where} returned {k}")
            a = a.reshape(1) if a.ndim == 0 else a  # one number: one actuator
            if a.shape != (cn,):
                raise AttitudeValueError(
                    f"{where} returned {k} of shape {a.shape}, expected ({cn},)"
                )
            res[c0 : c0 + cn] = a
    else:
        try:
            a = as_float_array(out, f"{where} returned {type(out).__name__}")
            a = a.reshape(1) if a.ndim == 0 else a  # (not flattened: (3, 1) is refused)
        except AttitudeTypeError:
            raise AttitudeTypeError(
                f"{where} returned {type(out).__name__}; expected an array of commands or a dict"
            ) from None
        want = n if n else 3
        if a.shape != (want,):
            what = (
                "the body torque (3,)"
                if n == 0
                else f"{want} raw commands (wheels, dipoles, thrust)"
            )
            raise AttitudeValueError(f"{where} returned shape {a.shape}; expected {what}")
        res[:want] = a
    if not np.all(np.isfinite(res)):
        raise AttitudeValueError(f"{where} returned a non-finite command")
    return res


def _compiled_step_failure(src: _Source, problem: Problem) -> str:
    """Why a compiled step's commands cannot be applied (the reason left in ``hs`` by
    :func:`attitude._core.fsw_step.step_boundary_with`)."""
    from ._core import fsw as _kf
    from ._core import fsw_step as _ks

    tick = int(src.fs[_kf.FS.TICK])
    t = float(src.fs[_kf.FS.NEXT])
    where = f"software: your compiled step function at tick {tick} (t = {t!r} s)"
    n = int(src.hs[_kh.HS.FAIL_N])
    nw, nm, nt = problem.spacecraft.spacecraft.counts
    want = nw + nm + nt
    if src.hs[_kh.HS.FAIL] == _ks.STEP_WRONG_LENGTH:
        what = (
            "the body torque (3,)"
            if want == 0
            else f"{want} raw commands (wheels, dipoles, thrust)"
        )
        return f"{where} returned {n} values; expected {what}"
    return f"{where} returned a non-finite command (entry {n})"


def _run(
    problem: Problem,
    kernel: Callable,
    work: np.ndarray,
    tstate: np.ndarray,
    counters: np.ndarray,
    y_row: int,
    *,
    rtol: float,
    atol: float,
    max_step: float,
    max_steps: int,
    progress: Callable[[int, int, float], None] | None,
    chunk: int | None,
    on_chunk: Callable[[int, np.ndarray], None] | None,
    stats: Callable[[], dict],
    hold_driver: bool = False,
) -> RunResult:
    """The chunked run loop shared by both integrators (the step budget and Ctrl-C through
    :func:`attitude._methods.dop853_call`), answering the command source between calls."""
    sr: SpacecraftRun = problem.spacecraft
    src = _Source(sr, problem)
    t = problem.t
    m = t.shape[0]
    n = sr.n_state
    width = n + sr.n_rec
    chunk = min(m, SAMPLE_BUDGET) if chunk is None else max(1, int(chunk))
    y_out = np.empty((min(chunk, m) if on_chunk is not None else m, width))
    P = (problem.params, sr.fresh_block())
    if sr.program is not None:  # a driver about to compile: the software's kernels meanwhile
        _compiling.closed_loop_helper(
            kernel, P, src.ctl, lambda: _diagnostics_kernels(problem), software=hold_driver
        )
    evb = EventBuffers(0 if problem.events is None else problem.events.n, n)
    if problem.events is None:
        from ._core.spacecraft_events import no_events

        evd = no_events()
    else:
        evd = problem.events.data

    def entry(params, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, nmax):
        extra = ()
        if hold_driver:  # its last argument: the event arrays (the record buffers can grow)
            extra = (evb.kernel_args(evd),)
        return kernel(
            P, y0, t0, t_out, y_o, work, tstate, counters, rtol, atol, t_end, h, nmax, src.ctl,
            *extra,
        )  # fmt: skip

    t0, t_end = float(t[0]), float(t[m - 1])
    done = 0
    k = 0
    status = _rk.SUCCESS
    y_chunk = y_out[:0]
    failure = None
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
        if status == _kh.STEP_FAILED:
            failure = _compiled_step_failure(src, problem)
            status = _rk.NONFINITE
            break
        if status == _rk.EVENT_BUFFER_FULL:
            evb.grow()
            continue
        if status in (_kh.NEEDS_COMMANDS, _kh.RECORDS_FULL):
            try:
                src.handle(status, work[y_row], float(tstate[0]), P[1])
            except _StepFailed as exc:
                failure = exc
                status = _rk.NONFINITE
                break
            continue
        if progress is not None:
            progress(done, m, float(tstate[0]))
        if status != _rk.SUCCESS:
            break
    if src.prog is not None:
        if src.sink is not None:
            src.flush()
        sr.ticks = src.rec[: int(src.rc[0])].copy()
    st = {"rtol": rtol, "atol": atol, **stats(), "n_holds": int(src.hs[_kh.HS.NEXT])}
    if src.prog is not None:
        from ._core import fsw as _kf

        del st["n_holds"]
        st["n_ticks"] = int(src.fs[_kf.FS.TICK])
    msg = _rk.STATUS_MESSAGES.get(int(status), "stopped")
    if isinstance(failure, str):
        msg = failure
    elif failure is not None and failure.refused:
        msg = str(failure.exc)
    elif failure is not None:
        msg = (
            f"your step function raised at tick {failure.tick} (t = {failure.t!r} s): "
            f"{type(failure.exc).__name__}: {failure.exc}"
        )
    t_stop = None if status == _rk.SUCCESS else float(tstate[0])
    t_event = None
    records = None if problem.events is None else evb.records()
    if status == _rk.EVENT:  # the last row is the state at the surface or the terminal event
        t_stop = None
        t_event = float(tstate[0])
        if not _terminal_event_at(problem.events, records, t_event):
            msg = f"the orbit reached the Earth's surface (Impact) at t = {t_event!r} s"
            st.update(status="event", event="impact", impact_time=t_event)
    if on_chunk is not None:
        last = max(done - 1, 0)
        return RunResult(y_chunk[:k][-1:].copy(), int(status), msg, st, first=last,
                         t_stop=t_stop, events=records, t_event=t_event)  # fmt: skip
    return RunResult(y_out[:done], int(status), msg, st, t_stop=t_stop, events=records,
                     t_event=t_event)  # fmt: skip


def _terminal_event_at(events: Any, records: Any, t: float) -> bool:
    """Whether the run stopped at one of its terminal events (else at the Earth's surface)."""
    if records is None or not records.t.shape[0] or records.t[-1] != t:
        return False
    return bool(events.events[int(records.which[-1])].terminal)


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
    entry = problem.entry
    kernel = entry.dop853_spacecraft if sr.program is None else entry.dop853_spacecraft_fsw
    work, tstate, counters = _rk.new_state(sr.n_state)

    def stats():
        return {
            "n_steps": int(counters[0]),
            "n_rhs": int(counters[1]),
            "n_rejected": int(counters[2]),
        }

    return _run(
        problem, kernel, work, tstate, counters, _rk.WORK.Y, rtol=rtol, atol=atol,
        max_step=max_step, max_steps=max_steps, progress=progress, chunk=chunk,
        on_chunk=on_chunk, stats=stats, hold_driver=True,
    )  # fmt: skip


run_dop853.streams = True  # type: ignore[attr-defined]


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
    nw = len(sr.spacecraft.wheels)
    work = np.zeros((_kt.WORK_ROWS, _ktg.work_columns(nw)))
    tstate = np.zeros(_ktg.TS.SIZE + nw)
    counters = np.zeros(5, dtype=np.int64)
    entry = problem.entry
    kernel = entry.taylor_spacecraft if sr.program is None else entry.taylor_spacecraft_fsw

    def stats():
        return {
            "order": int(tstate[3]),
            "n_steps": int(counters[0]),
            "n_series_terms": int(counters[1]),
        }

    return _run(
        problem, kernel, work, tstate, counters, _kt.Y, rtol=rtol, atol=atol,
        max_step=max_step, max_steps=max_steps, progress=progress, chunk=chunk,
        on_chunk=on_chunk, stats=stats,
    )  # fmt: skip


run_taylor.streams = True  # type: ignore[attr-defined]


def _diagnostics_entry(problem: Problem) -> Any:
    """The entry points of the diagnostics rows: the model's own when the run's module only adds
    your compiled step to a built-in model (the diagnostics never call the step, and the model's
    are compiled and cached with the package: compiled again in each step's module they cost
    seconds of a first run per step, for the same kernels and the same numbers)."""
    program = problem.spacecraft.program
    if program is not None and program.compiled_step is not None:
        if not problem.potential._user_terms():
            return problem.potential._entry_points(closed_loop=True)
    return problem.entry


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
    nw = len(sr.spacecraft.wheels)
    wheels = np.empty((m, nw, 2))
    sc = sr.fresh_block()
    entry = _diagnostics_entry(problem)
    params = problem.params
    orbit = None
    if sr.coupled and m:
        from ._coupling import reference_params, run_orbit

        # the models read the run's own orbit: its samples (the state there, to round-off)
        orbit = run_orbit(sr.spacecraft, t, y)
        params = reference_params(params, sc, orbit.kernel_data())
    for i in range(0, m, SAMPLE_BUDGET):
        j = min(m, i + SAMPLE_BUDGET)
        entry.spacecraft_diagnostics(t[i:j], y[i:j], params, sc, diag[i:j])
        # C-ordered copies of the (q, Q) columns and the rates: with wheels they are strided
        # views, without them not (two types: the kernel compiled twice)
        qQ = np.ascontiguousarray(y[i:j, :8])
        rates = np.ascontiguousarray(diag[i:j, 0:3])
        if orbit is not None and _has_live_environment(sc):
            # each sample's environment, not the one the right-hand side wrote last
            entry.term_torques_in_live_environment(t[i:j], y[i:j], qQ, rates, params, sc,
                                                   torques[i:j])  # fmt: skip
        else:
            entry.term_torques_at_rates(t[i:j], qQ, rates, params, torques[i:j])
        _kg.actuator_diagnostics(t[i:j], y[i:j], rec[i:j], sc, act[i:j], wheels[i:j])
    return {"diag": diag, "torques": torques, "actuators": act, "wheels": wheels, "records": rec,
            "orbit": orbit}  # fmt: skip


def _diagnostics_kernels(problem: Problem) -> list[tuple[str, str, tuple, bool]]:
    """What :func:`diagnostics` will compile, as items of :func:`attitude._compiling.helper`
    (the arguments' numba types), for a run of the package's entry points whose orbit is not in
    its state (a coupled run's diagnostics read the run's own orbit); none for a user's
    module."""
    from numba import typeof
    from numba.core import types

    sr: SpacecraftRun = problem.spacecraft
    home = _compiling.where(_diagnostics_entry(problem))
    if sr.coupled or home is None:
        return []
    a1, a2, a3 = (types.Array(types.float64, d, "C") for d in (1, 2, 3))
    params = typeof(problem.params)
    return [
        (home, "spacecraft_diagnostics", (a1, a2, params, a1, a2), True),
        (home, "term_torques_at_rates", (a1, a2, a2, params, a3), True),
        ("attitude._core.gyrostat", "actuator_diagnostics", (a1, a2, a2, a1, a3, a3), True),
    ]


def event_state_variables(problem: Problem, records: Any) -> tuple[np.ndarray, dict[str, Any]]:
    """The body rates (k, 3) at a spacecraft run's events (the gyrostat's ω), and for a run
    carrying its orbit the orbit there: ``event_position``, ``event_velocity`` (GCRS, m, m/s)
    and ``event_mass``."""
    from .results import _variable

    sr: SpacecraftRun = problem.spacecraft
    y = np.ascontiguousarray(records.y[:, : sr.n_state])
    # the samples' own diagnostics kernel (its ω; an event is recorded after a step, so a
    # coupled run's live orbit copies hold a state for its energy, which is not used)
    diag = np.empty((y.shape[0], 13))
    if y.shape[0]:
        _diagnostics_entry(problem).spacecraft_diagnostics(
            np.ascontiguousarray(records.t), y, problem.params, sr.fresh_block(), diag
        )
    more: dict[str, Any] = {}
    if sr.coupled:
        from ._coupling import orbit_variables

        for name, (dims, data, attrs) in orbit_variables(sr.spacecraft, y).items():
            attrs = {**attrs, "long_name": f"{attrs['long_name']} at the event"}
            more[f"event_{name}"] = _variable(("event", *dims[1:]), data, attrs)
    return diag[:, 0:3].copy(), more


def _has_live_environment(sc: np.ndarray) -> bool:
    """Whether a coupled run's drag or radiation models read the environment at the integrated
    state (their live words, written by the right-hand side)."""
    from ._core import actuators as _ka
    from ._core import coupled as _kc

    return int(sc[int(sc[_ka.SC.COUPLED]) + _kc.COUPLED.N_ENV]) > 0

"""Integration through held commands: the DOP853 driver restarted at every hold boundary.

Actuator commands are held piecewise constant (zero-order hold) from one boundary to the next:
the times of an open-loop :class:`attitude.CommandSchedule`, or the ticks of the flight
software. The right-hand side jumps there, so no step may straddle a boundary: every boundary
is the end of a step, the commands are configured there
(:func:`attitude._core.actuators.configure_hold`), the derivative is evaluated afresh
(first-same-as-last does not hold across a jump), and the integration continues with the step
size the controller had reached (no new starting-step estimate). Thrusters turning off inside a
hold add boundaries of their own. The continuous dynamics between boundaries keep the method's
accuracy: this is where a high-order method restarted at each boundary beats one fixed step per
tick (Basilisk integrates one RK4 step per task period).

:func:`holds_run` has the arguments of :func:`orbit._rk.dop853_run` with ``P =
(params, sc)`` (the model's numbers and the spacecraft block) and the command source ``ctl``:
``ctl``, a tuple whose first item is ``hs`` (HS.SIZE,), the driver's state between calls, and
the rest the command source's (:data:`BOUNDARY`); for an open-loop schedule
``(hs, hold_t, hold_u, zero)``: the start times (K,) and raw commands (K, n_cmd) (hold j on
[hold_t[j], hold_t[j + 1]), the last one to the end of the run, zero commands before the
first). Output rows of ``y_out`` hold
the state (n values) then the record of the commands in force at that sample
(:func:`record`: per wheel the command, the applied torque, the limit flags and the friction
regime; per magnetorquer the command and the applied dipole; per thruster the command and
whether it fires), so a chunked run and a run in one call fill the same rows.

A sample at a boundary time sees the commands that start there (right-continuous, as
Basilisk's recorder sees the command written at that tick).

Layout of ``hs``: ``[next hold index, boundary pending (0/1), end of the current segment, start
of the next hold]``.
"""

from __future__ import annotations

import math

from orbit._layout import Field, layout
from orbit._rk import (
    EVENT,
    EVENT_BUFFER_FULL,
    SUCCESS,
    TOO_MANY_STEPS,
    WORK,
    _dense_coefficients,
    _initial_step,
    _interpolate,
    crossing,
    dop853_step,
)
from orbit._shared_jit import jit

from .actuators import (
    MTQ,
    SC,
    THR,
    WHEEL,
    configure_hold,
    magnetorquer_base,
    next_thruster_off,
    thruster_base,
    thrusters_off_at,
)
from .coupled import below_surface, field_due, field_reset, field_sample, field_step_end

HS = layout(
    "hold driver state",
    next=Field(1, "", "index of the next hold"),
    pending=Field(1, "", "1: the hold at the next boundary is still to be configured"),
    seg_end=Field(1, "s", "end of the current segment"),
    hold_end=Field(1, "s", "end of the current hold (NaN: before the first)"),
    ready=Field(1, "", "the caller wrote the commands asked for (BOUNDARY_NEEDS_COMMANDS)"),
    fail=Field(1, "", "why a command source stopped the run (STEP_FAILED)"),
    fail_n=Field(1, "", "a number about it"),
    stop=Field(1, "", "1: the run stops at tstate[0] (the surface, a terminal event)"),
    sample=Field(1, "", "1: the last step ended at a sample of the coupled orbit's field"),
    samples_only=Field(1, "", "1: no row of its own at a stop (an ensemble member)"),
)

#: Statuses of a command source (:data:`BOUNDARY`).
BOUNDARY_DONE = 0
BOUNDARY_NEEDS_COMMANDS = 1
#: Status of :func:`holds_run` when the command source asked Python for commands (the run
#: continues with the next call, bit for bit).
NEEDS_COMMANDS = 6
#: Status when a record buffer of the command source is full (grow it and call again).
RECORDS_FULL = 7
#: Status when your own compiled step function returned commands that cannot be applied
#: (the reason in ``hs[HS.FAIL]``); the run stops there, its samples kept.
STEP_FAILED = 8

#: Record columns per wheel, magnetorquer and thruster, then of the ideal control torque.
WHEEL_REC = layout(
    "wheel record columns",
    cmd=Field(1, "N m", "commanded motor torque"),
    torque=Field(1, "N m", "applied motor torque (after the wheel's limits)"),
    flags=Field(1, "", "limit flags (FLAG_* bits)"),
    stribeck=Field(1, "", "1: the Stribeck friction regime"),
)
MTQ_REC = layout(
    "magnetorquer record columns",
    cmd=Field(1, "A m2", "commanded dipole"),
    applied=Field(1, "A m2", "applied dipole"),
)
THR_REC = layout(
    "thruster record columns",
    cmd=Field(1, "", "commanded on-time fraction of the hold"),
    firing=Field(1, "", "1 while firing"),
)
IDEAL_REC = layout("ideal control torque columns", torque=Field(3, "N m", "body axes"))


def record_width(n_w: int, n_m: int, n_t: int) -> int:
    """Number of record columns after the state in an output row."""
    return WHEEL_REC.SIZE * n_w + MTQ_REC.SIZE * n_m + THR_REC.SIZE * n_t + IDEAL_REC.SIZE


@jit
def record(sc, row, c0):
    """The commands in force into ``row[c0:]``: per wheel (command, applied torque, flags,
    Stribeck regime), per magnetorquer (command, applied dipole), per thruster (command,
    firing 0/1), then the ideal control torque (3)."""
    c = c0
    for k in range(int(sc[SC.NW])):
        b = SC.WHEELS + k * WHEEL.SIZE
        row[c + WHEEL_REC.CMD] = sc[b + WHEEL.UCMD]
        row[c + WHEEL_REC.TORQUE] = sc[b + WHEEL.U]
        row[c + WHEEL_REC.FLAGS] = sc[b + WHEEL.FLAGS]
        row[c + WHEEL_REC.STRIBECK] = sc[b + WHEEL.STRIBECK]
        c += WHEEL_REC.SIZE
    for j in range(int(sc[SC.NM])):
        b = magnetorquer_base(sc, j)
        row[c + MTQ_REC.CMD] = sc[b + MTQ.CMD]
        row[c + MTQ_REC.APPLIED] = sc[b + MTQ.APPLIED]
        c += MTQ_REC.SIZE
    for j in range(int(sc[SC.NT])):
        b = thruster_base(sc, j)
        row[c + THR_REC.CMD] = sc[b + THR.CMD]
        row[c + THR_REC.FIRING] = sc[b + THR.FIRING]
        c += THR_REC.SIZE
    for i in range(3):
        row[c + IDEAL_REC.TORQUE + i] = sc[SC.IDEAL + i]


@jit
def schedule_boundary(P, y, t, t_end, ctl):
    """The command source of an open-loop schedule (``ctl = (hs, hold_t, hold_u, zero)``): at
    a boundary ``t``, start the hold that begins there (or turn thrusters off), and set the end
    of the new segment. Returns BOUNDARY_DONE."""
    hs, hold_t, hold_u, zero = ctl
    sc = P[1]
    K = hold_t.shape[0]
    j = int(hs[HS.NEXT])
    if j < K and hold_t[j] <= t:
        # the last hold starting at or before t (several may share a time: the last wins)
        while j + 1 < K and hold_t[j + 1] <= t:
            j += 1
        t_next = hold_t[j + 1] if j + 1 < K else t_end
        configure_hold(sc, y, hold_u[j], t, t_next)
        hs[HS.NEXT] = j + 1
        hs[HS.HOLD_END] = t_next
    elif hs[HS.HOLD_END] != hs[HS.HOLD_END]:  # NaN: before the first hold (zero commands)
        t_next = hold_t[j] if j < K else t_end
        configure_hold(sc, y, zero, t, t_next)
        hs[HS.HOLD_END] = t_next
    thrusters_off_at(sc, t)
    t_hold_end = min(hs[HS.HOLD_END], t_end)
    hs[HS.SEG_END] = next_thruster_off(sc, t, t_hold_end)
    return BOUNDARY_DONE


@jit(inline="always")
def _stop(rhs, P, sc, hs, work, tstate, counters, t_out, y_out, k, n, t_stop, y_stop):
    """The run stops inside the last step, at ``t_stop`` with the state ``y_stop`` (the orbit
    reaches the surface, or a terminal event): the run's state moves there, the step's dense
    output kept for the samples before it (:func:`_serve_stop`)."""
    if counters[4] == 0:
        _dense_coefficients(rhs, P, work, tstate, counters)
    y = work[WORK.Y]
    for i in range(n):
        y[i] = y_stop[i]
    tstate[0] = t_stop
    hs[HS.STOP] = 1.0
    return _serve_stop(sc, hs, work, tstate, t_out, y_out, k, n)


@jit(inline="always")
def _serve_stop(sc, hs, work, tstate, t_out, y_out, k, n):
    """The samples before the stop (the last step's dense output), then the state at the stop
    in the next row (unless ``hs[HS.SAMPLES_ONLY]``: an ensemble member's rows are on the
    samples' times, its status and ``tstate[0]`` say where it stopped): ``(EVENT, rows
    filled)``; ``(SUCCESS, rows)`` when this call's samples all precede it (the next call
    serves the rest)."""
    m = t_out.shape[0]
    while k < m and t_out[k] < tstate[0]:
        _interpolate(work, tstate, t_out[k], y_out[k])
        record(sc, y_out[k], n)
        k += 1
    if hs[HS.SAMPLES_ONLY] != 0.0:
        return EVENT, k
    if k == m:
        return SUCCESS, k
    y = work[WORK.Y]
    for i in range(n):
        y_out[k, i] = y[i]
    record(sc, y_out[k], n)
    return EVENT, k + 1


@jit(inline="always")
def no_events_begin(P, t, y, ev):
    """The event hooks of the template :func:`holds_run` (never compiled itself): none."""


@jit(inline="always")
def no_events_room(ev):
    return True


@jit(inline="always")
def no_events_locate(rhs, P, work, tstate, counters, ev):
    return False, tstate[0], work[WORK.Y]


#: The right-hand side ``rhs(t, y, P, dydt)`` of a copy of :func:`holds_run` (bound by the entry
#: points with ``orbit._shared_jit.rebind``; the original here is never compiled).
RHS = None
#: The events of a copy (``ev`` its event arrays, :mod:`attitude._core.spacecraft_events`):
#: ``EV_BEGIN(P, t0, y0, ev)`` their values at the start, ``EV_ROOM(ev)`` whether the record
#: buffers hold one more step's occurrences, ``EV_LOCATE(rhs, P, work, tstate, counters, ev)
#: -> (stopped, t_stop, y_stop)`` after each accepted step (a terminal event's time and the
#: state there). Every copy of the entry points binds attitude._core.spacecraft_events' (events
#: as data: none is an empty set); these no-ops are the template's.
EV_BEGIN = no_events_begin
EV_ROOM = no_events_room
EV_LOCATE = no_events_locate
#: The command source ``boundary(P, y, t, t_end, ctl) -> status`` of a copy of
#: :func:`holds_run`: :func:`schedule_boundary` (open loop), the flight software's tick
#: (:mod:`attitude._core.fsw`), or a request for commands from Python (BOUNDARY_NEEDS_COMMANDS:
#: the driver returns, keeping the boundary pending; the caller writes the commands and calls
#: again).
BOUNDARY = schedule_boundary


@jit
def holds_run(
    P, y0, t0, t_out, y_out, work, tstate, counters, rtol, atol, t_end, max_step, max_steps, ctl,
    ev,
):  # fmt: skip
    """Integrate from the stored state through the output times ``t_out`` (forward in time),
    restarting at every hold boundary. Returns ``(status, n_done)`` as
    :func:`orbit._rk.dop853_run` (its layouts of ``work``, ``tstate``, ``counters``); ``EVENT``
    at the Earth's surface or a terminal event (the state there in the row after the samples
    before it, ``tstate[0]`` its time; when the samples of this call all precede it, the next
    call serves the rest first), ``EVENT_BUFFER_FULL`` when the event records need room (call
    again after growing them).
    """
    hs = ctl[0]
    sc = P[1]
    n = y0.shape[0]
    m = t_out.shape[0]
    y = work[WORK.Y]
    f = work[WORK.F0]
    if counters[3] == 0:
        for i in range(n):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        tstate[3] = 0.0
        hs[HS.NEXT] = 0.0
        hs[HS.PENDING] = 1.0
        hs[HS.HOLD_END] = math.nan
        hs[HS.STOP] = 0.0
        hs[HS.SAMPLE] = 0.0
        if sc[SC.COUPLED] >= 0.0:
            field_reset(sc, int(sc[SC.COUPLED]), t0)
        counters[3] = 1
        counters[4] = 0
        EV_BEGIN(P, t0, y, ev)
    if hs[HS.STOP] != 0.0:  # found by the last call, before which its samples ended
        return _serve_stop(sc, hs, work, tstate, t_out, y_out, 0, n)
    k = 0
    h_abs = tstate[1]
    while True:
        # Samples inside the last step (its dense output, with the commands it was taken with)
        # and at the current time (after a boundary there is configured).
        while k < m:
            to = t_out[k]
            t = tstate[0]
            if to == t:
                if hs[HS.PENDING] != 0.0:
                    break
                for i in range(n):
                    y_out[k, i] = y[i]
            elif counters[0] > 0 and to >= tstate[2] and t > to:
                if counters[4] == 0:
                    _dense_coefficients(RHS, P, work, tstate, counters)
                _interpolate(work, tstate, to, y_out[k])
            else:
                break
            record(sc, y_out[k], n)
            k += 1
        if hs[HS.PENDING] != 0.0 or hs[HS.SAMPLE] != 0.0:
            t = tstate[0]
            fresh = hs[HS.PENDING] != 0.0
            if fresh:
                bs = BOUNDARY(P, y, t, t_end, ctl)
                if bs == BOUNDARY_NEEDS_COMMANDS:
                    tstate[1] = h_abs
                    return NEEDS_COMMANDS, k
                if bs != BOUNDARY_DONE:  # the source's own status (RECORDS_FULL, STEP_FAILED)
                    tstate[1] = h_abs
                    return bs, k
            if sc[SC.COUPLED] >= 0.0:  # the field's samples (attitude._core.coupled)
                if field_sample(sc, int(sc[SC.COUPLED]), t, y, t - tstate[2]):
                    fresh = True
            if fresh:
                RHS(t, y, P, f)
                counters[1] += 1
                counters[4] = 0
            hs[HS.PENDING] = 0.0
            hs[HS.SAMPLE] = 0.0
            continue
        if k == m:
            tstate[1] = h_abs
            return SUCCESS, k
        if h_abs == 0.0:
            t = tstate[0]
            h_abs = _initial_step(RHS, P, t, y, f, 1.0, rtol, atol, abs(t_end - t), work, counters)
        if counters[0] >= max_steps:
            tstate[1] = h_abs
            return TOO_MANY_STEPS, k
        if not EV_ROOM(ev):
            tstate[1] = h_abs
            return EVENT_BUFFER_FULL, k
        seg_end = hs[HS.SEG_END]
        step_end = seg_end
        if sc[SC.COUPLED] >= 0.0:
            step_end = field_step_end(sc, int(sc[SC.COUPLED]), seg_end)
        status, h_abs = dop853_step(
            RHS, P, work, tstate, counters, h_abs, 1.0, step_end, rtol, atol, max_step
        )
        if status != SUCCESS:
            return status, k
        impact = sc[SC.COUPLED] >= 0.0 and below_surface(sc, tstate[0], y)
        if impact:
            # the surface, found by bisection on the step's dense output, ends the step: the
            # events are located up to it (a terminal one before it stops the run there)
            _dense_coefficients(RHS, P, work, tstate, counters)
            tstate[0] = crossing(below_surface, sc, work, tstate, work[WORK.YT])
            for i in range(n):
                y[i] = work[WORK.YT, i]
        stopped, t_stop, y_stop = EV_LOCATE(RHS, P, work, tstate, counters, ev)
        if impact and not stopped:
            return _stop(RHS, P, sc, hs, work, tstate, counters, t_out, y_out, k, n, tstate[0], y)
        if stopped:
            tstate[1] = h_abs
            return _stop(RHS, P, sc, hs, work, tstate, counters, t_out, y_out, k, n, t_stop, y_stop)
        if tstate[0] == seg_end and seg_end < t_end:
            hs[HS.PENDING] = 1.0
        elif sc[SC.COUPLED] >= 0.0 and field_due(sc, int(sc[SC.COUPLED]), tstate[0]):
            hs[HS.SAMPLE] = 1.0

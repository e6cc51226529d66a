"""Events inside the compiled integrators: event functions as data, root location, the loops.

An event is a scalar function g(t, q, ω) of the time, the attitude and the body angular
velocity; it *occurs* where g changes sign along the run (g = 0 counts as positive, so a
rising crossing goes from g < 0 to g >= 0). Built-in events are data (a kind code and numbers)
read by the dispatcher :func:`builtin_event`; a user's g is compiled into the user module of
:mod:`attitude._user_kernels` and reached through the module-global ``event`` of the entry
points (the package's own ``event`` is :func:`builtin_event`).

Layout of the event data ``evd`` (float64)::

    evd[EV.N]        n, the number of events
    evd[EV.NSUB]     sub-intervals sampled per step (>= 1)
    evd[EV.OFFSETS + j]  offset b_j of event j's block
    block:  evd[b] kind, evd[b + 1] direction (+1 rising, −1 falling, 0 both),
            evd[b + 2] terminal (1/0), then the kind's numbers:

    KIND_USER       [k]                                  user function number k
    KIND_POINTING   [angle, mode, a1, a2, a3, frame_off] mode 0: angle between the body axis
                                                         a in space and the frame's axis a;
                                                         mode 1: total rotation angle of q̃_R∘q;
                                                         the frame's data (attitude._core.frames)
                                                         at evd[frame_off:]
    KIND_RATE       [rate]                               |ω| − rate
    KIND_ECLIPSE    [umbra, R_earth, R_sun, orbit_off, sun_off]
                                                         the conical shadow boundary function
                                                         (orbit.sun): c − (a + b) (penumbra) or
                                                         c − (b − a) (umbra), positive in light
    KIND_SUN_ANGLE  [angle, a1, a2, a3, orbit_off, sun_off]
                                                         angle between the body axis a in space
                                                         and the Sun (seen from the orbit, or
                                                         from the geocentre if orbit_off = 0)

Per-event state ``evs`` (n, EVS.SIZE) float64: the value of g at the end of the last step, the
number of occurrences, the time of the first. Records (single runs): ``rec_t`` (cap,),
``rec_k`` (cap, 2) int64 (event number, direction), ``rec_y`` (cap, n_state), and ``ev_count``
(2,) int64: records written, occurrences in all. A capacity of 0 keeps no records (ensembles
keep only ``evs``).

Location (per accepted step [t_old, t_new]): g is evaluated at the step's end and at
``n_sub − 1`` interior points of the step's dense output (DOP853's 7th-order interpolant), so
several sign changes inside one step are seen as long as they are at least a sub-interval
apart; every sign change is then refined by Brent's method (the zeroin of Brent 1973, in
reverse-communication form) on g(t, y(t)) with y(t) the interpolant, to ``4 ulp(t) + 1e-12 s``.
Occurrences are recorded in time order; a terminal one ends the run at its root (status
``EVENT``) with the interpolated state there. For the fixed-step methods the state at a trial
time is one step of the method itself from the step's start (``composition_events_run``).
"""

from __future__ import annotations

import math

import numpy as np

from orbit._layout import Field, layout
from orbit._rk import (
    EVENT,
    EVENT_BUFFER_FULL,
    NONFINITE,
    SUCCESS,
    TOO_MANY_STEPS,
    WORK,
    _dense_coefficients,
    _initial_step,
    _interpolate,
    dop853_step,
)
from orbit._shared_jit import jit, jit_generic
from orbit._state_kernels import orbit_state
from orbit.sun import conical_shadow

from .ensemble import member_begin, member_end
from .frames import frame_attitude
from .quat import conj_mul, rotate
from .splitting import apply_stage, n_steps_for, state_to_canonical

# Layout.
EV = layout(
    "event set header",
    n=Field(1, "", "the number of events"),
    nsub=Field(1, "", "sub-intervals sampled per step (>= 1)"),
    offsets=Field(0, "", "offset b_j of event j's block, one per event"),
)
EVB = layout(
    "event block",
    kind=Field(1, "", "KIND_*"),
    direction=Field(1, "", "RISING, FALLING or BOTH"),
    terminal=Field(1, "", "1: the run stops at the event"),
    data=Field(0, "", "the event's numbers, then its arrays"),
)

KIND_USER = 0
KIND_POINTING = 1
KIND_RATE = 2
KIND_ECLIPSE = 3
KIND_SUN_ANGLE = 4

RISING = 1
FALLING = -1
BOTH = 0

# Per-event state columns.
EVS = layout(
    "event state",
    g=Field(1, "", "the event function at the last step"),
    count=Field(1, "", "occurrences so far"),
    first=Field(1, "s", "time of the first occurrence"),
)

#: Absolute time tolerance of the root refinement [s] (on top of 4 ulp of t).
XTOL = 1e-12
_EPS = 2.220446049250313e-16
_MAX_ITER = 200


# ---------------------------------------------------------------------------------------------
# the built-in event functions
@jit
def event_base(j, evd):
    """Offset of event j's block."""
    return int(evd[EV.OFFSETS + j])


@jit
def _angle(ux, uy, uz, vx, vy, vz):
    """Angle between two vectors, atan2(|u × v|, u·v) (accurate at 0 and π)."""
    cx = uy * vz - uz * vy
    cy = uz * vx - ux * vz
    cz = ux * vy - uy * vx
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ux * vx + uy * vy + uz * vz)


@jit
def builtin_event(j, t, q, w, evd):
    """g of built-in event j at time t, attitude q (4,) and body rates w (3-tuple)."""
    b = event_base(j, evd)
    kind = int(evd[b])
    p = b + EVB.DATA
    if kind == KIND_RATE:
        return math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) - evd[p]
    if kind == KIND_POINTING:
        qr = frame_attitude(evd[int(evd[p + 5]) :], t)
        if evd[p + 1] == 1.0:
            e = conj_mul(qr, q)
            ang = 2.0 * math.atan2(math.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]), abs(e[0]))
        else:
            a = (evd[p + 2], evd[p + 3], evd[p + 4])
            u = rotate(q, a)
            v = rotate(qr, a)
            ang = _angle(u[0], u[1], u[2], v[0], v[1], v[2])
        return ang - evd[p]
    if kind == KIND_ECLIPSE:
        x, y, z, _, _, _ = orbit_state(evd[int(evd[p + 3]) :], t)
        sx, sy, sz, _, _, _ = orbit_state(evd[int(evd[p + 4]) :], t)
        _, gp, gu = conical_shadow(x, y, z, sx, sy, sz, evd[p + 1], evd[p + 2])
        return gu if evd[p] == 1.0 else gp
    if kind == KIND_SUN_ANGLE:
        sx, sy, sz, _, _, _ = orbit_state(evd[int(evd[p + 5]) :], t)
        o = int(evd[p + 4])
        if o > 0:
            x, y, z, _, _, _ = orbit_state(evd[o:], t)
            sx -= x
            sy -= y
            sz -= z
        u = rotate(q, (evd[p + 1], evd[p + 2], evd[p + 3]))
        return _angle(u[0], u[1], u[2], sx, sy, sz) - evd[p]
    return math.nan


@jit_generic
def user_event(g_fn, t, q, w):
    """A user's ``g(t, q, omega)`` as a float; ``omega`` a length-3 array (body axes)."""
    return float(g_fn(t, q, np.array((w[0], w[1], w[2]))))


@jit
def body_rates(y, params):
    """ω = I⁻¹ ½ vec(q̃∘Q) of a canonical state y = (q, Q)."""
    w = conj_mul(y[0:4], y[4:8])
    return (0.5 * w[1] / params[0], 0.5 * w[2] / params[1], 0.5 * w[3] / params[2])


@jit_generic
def event_at(event, j, t, y, params, evd):
    """g_j at the canonical state y (q, Q)."""
    return event(j, t, y[0:4], body_rates(y, params), evd)


@jit_generic
def event_values_with(event, t, y, params, evd, out):
    """``out[k, j]`` = g_j(t[k], y[k]) for canonical states y (m, 8)."""
    n = int(evd[EV.N])
    for k in range(t.shape[0]):
        for j in range(n):
            out[k, j] = event_at(event, j, t[k], y[k], params, evd)


# ---------------------------------------------------------------------------------------------
# Brent's zeroin in reverse-communication form: s = [a, b, c, fa, fb, fc]
@jit
def zeroin_start(s, a, b, fa, fb):
    """Bracket [a, b] with g(a), g(b) of opposite signs (or g(b) = 0)."""
    s[0] = a
    s[1] = b
    s[2] = a
    s[3] = fa
    s[4] = fb
    s[5] = fa


@jit
def zeroin_next(s, xtol):
    """(done, t): the root estimate when done, else the next point where g is wanted."""
    a, b, c, fa, fb, fc = s[0], s[1], s[2], s[3], s[4], s[5]
    prev = b - a
    if abs(fc) < abs(fb):
        a, b, c = b, c, b
        fa, fb, fc = fb, fc, fb
    tol = 2.0 * _EPS * abs(b) + 0.5 * xtol
    step = 0.5 * (c - b)
    if abs(step) <= tol or fb == 0.0:
        s[0], s[1], s[2], s[3], s[4], s[5] = a, b, c, fa, fb, fc
        return True, b
    if abs(prev) >= tol and abs(fa) > abs(fb):
        cb = c - b
        if a == c:  # secant
            t1 = fb / fa
            p = cb * t1
            q = 1.0 - t1
        else:  # inverse quadratic interpolation
            q = fa / fc
            t1 = fb / fc
            t2 = fb / fa
            p = t2 * (cb * q * (q - t1) - (b - a) * (t1 - 1.0))
            q = (q - 1.0) * (t1 - 1.0) * (t2 - 1.0)
        if p > 0.0:
            q = -q
        else:
            p = -p
        if p < 0.75 * cb * q - 0.5 * abs(tol * q) and p < abs(0.5 * prev * q):
            step = p / q
    if abs(step) < tol:
        step = tol if step > 0.0 else -tol
    s[0], s[2], s[3], s[5] = b, c, fb, fc
    s[1] = b + step
    return False, s[1]


@jit
def zeroin_update(s, fb):
    """Give g at the point :func:`zeroin_next` asked for."""
    s[4] = fb
    if (fb > 0.0 and s[5] > 0.0) or (fb < 0.0 and s[5] < 0.0):
        s[2] = s[0]
        s[5] = s[3]


# ---------------------------------------------------------------------------------------------
# crossings and records
@jit
def crossing(ga, gb):
    """+1 rising (ga < 0 <= gb), −1 falling (ga >= 0 > gb), 0 none (g = 0 counts positive)."""
    if ga < 0.0 and gb >= 0.0:
        return 1
    if ga >= 0.0 and gb < 0.0:
        return -1
    return 0


@jit
def wanted(evd, j, sign):
    """Whether a crossing of direction ``sign`` is one event j records."""
    d = evd[event_base(j, evd) + EVB.DIRECTION]
    return d == 0.0 or d == sign


@jit
def is_terminal(evd, j):
    return evd[event_base(j, evd) + EVB.TERMINAL] != 0.0


@jit
def record(evs, ev_count, rec_t, rec_k, rec_y, j, sign, t, y):
    """Count an occurrence of event j at t (and keep it when there are record buffers)."""
    if evs[j, EVS.COUNT] == 0.0:
        evs[j, EVS.FIRST] = t
    evs[j, EVS.COUNT] += 1.0
    i = ev_count[0]
    if i < rec_t.shape[0]:
        rec_t[i] = t
        rec_k[i, 0] = j
        rec_k[i, 1] = sign
        for c in range(rec_y.shape[1]):  # (y may be a longer scratch row)
            rec_y[i, c] = y[c]
        ev_count[0] = i + 1
    ev_count[1] += 1


@jit
def reset_state(evs, ev_count):
    for j in range(evs.shape[0]):
        evs[j, EVS.G] = 0.0
        evs[j, EVS.COUNT] = 0.0
        evs[j, EVS.FIRST] = math.nan
    ev_count[0] = 0
    ev_count[1] = 0


@jit
def _insert(ct, cj, cs, nc, t, j, sign, direction):
    """Insert a candidate into the time-ordered lists (along the integration direction)."""
    i = nc
    while i > 0 and direction * (ct[i - 1] - t) > 0.0:
        ct[i] = ct[i - 1]
        cj[i] = cj[i - 1]
        cs[i] = cs[i - 1]
        i -= 1
    ct[i] = t
    cj[i] = j
    cs[i] = sign
    return nc + 1


# ---------------------------------------------------------------------------------------------
# DOP853 with events
@jit_generic
def locate_in_step(
    rhs, at, event, params, evd, evs, ev_count, rec_t, rec_k, rec_y, work, tstate, counters, scr
):
    """Find, refine and record the events of the step just accepted (``at(event, j, t, y,
    params, evd)``: g_j at a state of the integrated system, :func:`event_at` for eq. 7), up
    to ``tstate[0]`` (the step's end, or where it was cut short, its state in the work row).

    Returns (stopped, t_stop): a terminal event's root, where the run ends; the state there in
    ``scr[0]``.
    """
    n = work.shape[1]
    n_ev = int(evd[EV.N])
    nsub = int(evd[EV.NSUB])
    t_old = tstate[2]
    h = tstate[3]
    t_new = tstate[0]
    direction = 1.0 if h >= 0.0 else -1.0
    if counters[4] == 0:
        _dense_coefficients(rhs, params, work, tstate, counters)
    yb = scr[0]  # state at the sub-interval's end
    yr = scr[1]  # state at a trial time / at the root
    gb = scr[2]  # g at the sub-interval's end
    ct = scr[3]  # candidate roots: times, event numbers, directions (time order)
    cj = scr[4]
    cs = scr[5]
    zs = scr[6]  # zeroin state
    ta = t_old
    for s in range(1, nsub + 1):
        if s == nsub:
            tb = t_new
            for i in range(n):
                yb[i] = work[WORK.Y, i]
        else:
            tb = t_old + h * (s / nsub)
            if direction * (t_new - tb) <= 0.0:  # a step cut short (at the Earth's surface)
                continue
            _interpolate(work, tstate, tb, yb)
        for j in range(n_ev):
            gb[j] = at(event, j, tb, yb, params, evd)
        nc = 0
        for j in range(n_ev):
            ga = evs[j, EVS.G]
            sign = crossing(ga, gb[j])
            if sign == 0 or not wanted(evd, j, sign):
                continue
            # Brent on g_j(t, interpolant(t)) over [ta, tb]
            zeroin_start(zs, ta, tb, ga, gb[j])
            tr = tb
            for _ in range(_MAX_ITER):
                done, tt = zeroin_next(zs, XTOL)
                if done:
                    tr = tt
                    break
                _interpolate(work, tstate, tt, yr)
                zeroin_update(zs, at(event, j, tt, yr, params, evd))
            nc = _insert(ct, cj, cs, nc, tr, j, sign, direction)
        for c in range(nc):
            tr = ct[c]
            if tr == tb and s == nsub:
                for i in range(n):
                    yr[i] = work[WORK.Y, i]
            else:
                _interpolate(work, tstate, tr, yr)
            jc = int(cj[c])
            record(evs, ev_count, rec_t, rec_k, rec_y, jc, int(cs[c]), tr, yr)
            if is_terminal(evd, jc):
                # later candidates at the very same time are recorded too
                for c2 in range(c + 1, nc):
                    if ct[c2] == tr:
                        record(evs, ev_count, rec_t, rec_k, rec_y, int(cj[c2]), int(cs[c2]), tr, yr)
                for i in range(n):
                    scr[0, i] = yr[i]
                return True, tr
        for j in range(n_ev):
            evs[j, EVS.G] = gb[j]
        ta = tb
    return False, t_new


@jit_generic
def dop853_events_run(
    rhs,
    event,
    params,
    evd,
    evs,
    ev_count,
    rec_t,
    rec_k,
    rec_y,
    y0,
    t0,
    t_out,
    y_out,
    work,
    tstate,
    counters,
    rtol,
    atol,
    t_end,
    max_step,
    max_steps,
):
    """:func:`orbit._rk.dop853_run` with events (layouts: the module docstring).

    The steps taken are those of ``dop853_run`` (same step-size control); after each accepted
    step the events are located on its dense output. Output times are served as there, up to
    a terminal event's root.

    Returns
    -------
    status : int
        ``SUCCESS``, ``EVENT`` (a terminal event: ``tstate[0]`` is its time and ``work[WORK.Y]`` the
        state there), ``EVENT_BUFFER_FULL`` (the records need room: enlarge them and call again
        with the remaining output times; nothing is lost) or a failure of ``dop853_run``.
    n_done : int
        Rows of ``y_out`` filled.
    """
    n = y0.shape[0]
    m = t_out.shape[0]
    n_ev = int(evd[EV.N])
    nsub = int(evd[EV.NSUB])
    y = work[WORK.Y]
    f = work[WORK.F0]
    scr = np.empty((7, max(n, n_ev, 6)))
    if counters[3] == 0:
        for i in range(n):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        tstate[3] = 0.0
        rhs(t0, y, params, f)
        counters[1] += 1
        counters[3] = 1
        counters[4] = 0
        reset_state(evs, ev_count)
        for j in range(n_ev):
            evs[j, EVS.G] = event_at(event, j, t0, y, params, evd)
    direction = 1.0 if t_end >= tstate[0] else -1.0

    k = 0
    # Outputs already covered by the stored state (continuation of a chunked run).
    while k < m:
        to = t_out[k]
        if to == tstate[0]:
            for i in range(n):
                y_out[k, i] = y[i]
            k += 1
        elif (
            counters[0] > 0
            and direction * (to - tstate[2]) >= 0.0
            and direction * (tstate[0] - to) > 0.0
        ):
            if counters[4] == 0:
                _dense_coefficients(rhs, params, work, tstate, counters)
            _interpolate(work, tstate, to, y_out[k])
            k += 1
        else:
            break
    if k == m:
        return SUCCESS, k

    t = tstate[0]
    h_abs = tstate[1]
    if h_abs == 0.0:
        h_abs = _initial_step(
            rhs, params, t, y, f, direction, rtol, atol, abs(t_end - t), work, counters
        )
    cap = rec_t.shape[0]
    while k < m:
        if counters[0] >= max_steps:
            tstate[1] = h_abs
            return TOO_MANY_STEPS, k
        if cap > 0 and cap - ev_count[0] < n_ev * nsub:
            tstate[1] = h_abs
            return EVENT_BUFFER_FULL, k
        status, h_abs = dop853_step(
            rhs, params, work, tstate, counters, h_abs, direction, t_end, rtol, atol, max_step
        )
        if status != SUCCESS:
            return status, k
        t = tstate[0]
        stopped = False
        t_stop = t
        if n_ev > 0:
            stopped, t_stop = locate_in_step(
                rhs, event_at, event, params, evd, evs, ev_count, rec_t, rec_k, rec_y, work, tstate,
                counters, scr,
            )  # fmt: skip
        # Serve every output time inside the step just taken (up to a terminal event).
        while k < m and direction * (t_stop - t_out[k]) >= 0.0:
            if t_out[k] == t:
                for i in range(n):
                    y_out[k, i] = y[i]
            elif stopped and t_out[k] == t_stop:
                for i in range(n):
                    y_out[k, i] = scr[0, i]
            else:
                if counters[4] == 0:
                    _dense_coefficients(rhs, params, work, tstate, counters)
                _interpolate(work, tstate, t_out[k], y_out[k])
            k += 1
        if stopped:
            for i in range(n):
                y[i] = scr[0, i]
            tstate[0] = t_stop
            rhs(t_stop, y, params, f)
            counters[1] += 1
            return EVENT, k
    return SUCCESS, k


# ---------------------------------------------------------------------------------------------
# ensembles
@jit_generic
def member_events_run(
    dop853_events,
    diagnostics,
    i,
    params,
    evd,
    evs,
    y0,
    t,
    y_out,
    diag,
    work,
    tstate,
    counters,
    status,
    n_done,
    rtol,
    atol,
    max_step,
    max_steps,
    budget,
):
    """Member ``i`` of an ensemble with events: per-event first time and count in ``evs[i]``.

    As :func:`attitude._core.ensemble.member_run`: from a fresh state (``NOT_STARTED``) or on
    from where it paused (``RUNNING``), for at most ``budget`` steps (0: to the end). A
    terminal event ends the member (status ``EVENT``); its output rows after the event are
    NaN, as those of a failed member after its failure. Diagnostics are computed for the rows
    filled.
    """
    runs, k0, limit = member_begin(i, status, n_done, work, tstate, counters, max_steps, budget)
    if not runs:
        return
    m = t.shape[0]
    ev_count = np.zeros(2, dtype=np.int64)  # no records kept (capacity 0): counts in evs[i]
    rec_t = np.empty(0)
    rec_k = np.empty((0, 2), dtype=np.int64)
    rec_y = np.empty((0, y0.shape[1]))
    st, k = dop853_events(
        params[i], evd, evs[i], ev_count, rec_t, rec_k, rec_y, y0[i], t[0], t[k0:],
        y_out[i, k0:], work[i], tstate[i], counters[i], rtol, atol, t[m - 1], max_step, limit,
    )  # fmt: skip
    member_end(diagnostics, i, st, k + k0, limit, max_steps, params, t, y_out, diag, status, n_done)


# ---------------------------------------------------------------------------------------------
# the fixed-step methods (attitude._core.splitting) with events
@jit_generic
def composition_step(torque, params, kinds, coefs, toffs, state, ts, h, counters):
    """One whole step of a composition method (every stage; no merging with the next step)."""
    q = state[0:4]
    w = state[4:8]
    x = state[8:]  # empty (the coupled methods do not locate events)
    for o in range(kinds.shape[0]):
        apply_stage(torque, params, kinds[o], coefs[o] * h, ts + toffs[o] * h, q, w, x, counters)


@jit_generic
def composition_events_run(
    torque,
    event,
    params,
    kinds,
    coefs,
    toffs,
    state,
    t_start,
    t_out,
    dt,
    y_out,
    counters,
    evd,
    evs,
    ev_count,
    rec_t,
    rec_k,
    rec_y,
):
    """:func:`attitude._core.splitting.composition_run` with events.

    The steps are those of ``composition_run`` (the fewest equal steps <= dt between output
    times), each applied whole; g is evaluated at every step's end, and a sign change is
    refined by Brent's method on g(t_s + τ, Φ_τ(y_s)), Φ_τ one step of the method of size τ
    from the step's start y_s. ``evs[:, EVS.G]`` must hold g at ``t_start`` on the first call.

    ``counters`` (int64, 5): steps, kick and free-flow evaluations, then as in
    ``composition_run`` the step at which the first interval resumes and the most steps this
    call takes (0: no limit); when that budget runs out the call returns ``TOO_MANY_STEPS``
    with ``state`` mid-interval: called again with the same ``t_start`` and the remaining
    ``t_out`` it continues bit for bit (the steps are whole: nothing is pending).

    Returns (status, n_done) as ``composition_run``, or ``EVENT`` (``state`` then holds the
    state at the terminal event, also the last record), ``EVENT_BUFFER_FULL`` (at an output
    time: enlarge the records and call again from there) or ``TOO_MANY_STEPS`` (paused).
    """
    m = t_out.shape[0]
    n_ev = int(evd[EV.N])
    cap = rec_t.shape[0]
    sbak = np.empty(8)
    trial = np.empty(8)
    yc = np.empty(8)
    gb = np.empty(max(n_ev, 1))
    ct = np.empty(max(n_ev, 1))
    cj = np.empty(max(n_ev, 1))
    cs = np.empty(max(n_ev, 1))
    zs = np.empty(6)
    direction = 1.0 if (m == 0 or t_out[m - 1] >= t_start) else -1.0
    t_a = t_start
    budget = counters[4]
    taken = 0
    for k in range(m):
        t_b = t_out[k]
        span = t_b - t_a
        if span != 0.0:
            n = n_steps_for(span, dt)
            j0 = counters[3]
            if cap > 0 and cap - ev_count[0] < n_ev * (n - j0):
                return EVENT_BUFFER_FULL, k
            counters[3] = 0
            h = span / n
            for j in range(j0, n):
                if budget > 0 and taken >= budget:
                    counters[3] = j
                    return TOO_MANY_STEPS, k
                taken += 1
                ts = t_a + j * h
                for i in range(8):
                    sbak[i] = state[i]
                composition_step(torque, params, kinds, coefs, toffs, state, ts, h, counters)
                counters[0] += 1
                if not math.isfinite(
                    state[0]
                    + state[1]
                    + state[2]
                    + state[3]
                    + state[4]
                    + state[5]
                    + state[6]
                    + state[7]
                ):  # once per step, as composition_run
                    return NONFINITE, k
                te = t_b if j == n - 1 else ts + h
                state_to_canonical(state, yc)
                for e in range(n_ev):
                    gb[e] = event_at(event, e, te, yc, params, evd)
                nc = 0
                for e in range(n_ev):
                    ga = evs[e, EVS.G]
                    sign = crossing(ga, gb[e])
                    if sign == 0 or not wanted(evd, e, sign):
                        continue
                    zeroin_start(zs, 0.0, te - ts, ga, gb[e])
                    tr = te - ts
                    for _ in range(_MAX_ITER):
                        done, tau = zeroin_next(zs, XTOL)
                        if done:
                            tr = tau
                            break
                        for i in range(8):
                            trial[i] = sbak[i]
                        composition_step(
                            torque, params, kinds, coefs, toffs, trial, ts, tau, counters
                        )
                        state_to_canonical(trial, trial)
                        zeroin_update(zs, event_at(event, e, ts + tau, trial, params, evd))
                    nc = _insert(ct, cj, cs, nc, ts + tr, e, sign, direction)
                for c in range(nc):
                    troot = ct[c]
                    for i in range(8):
                        trial[i] = sbak[i]
                    if troot == te:
                        for i in range(8):
                            trial[i] = state[i]
                    else:
                        composition_step(
                            torque, params, kinds, coefs, toffs, trial, ts, troot - ts, counters
                        )
                    state_to_canonical(trial, yc)
                    jc = int(cj[c])
                    record(evs, ev_count, rec_t, rec_k, rec_y, jc, int(cs[c]), troot, yc)
                    if is_terminal(evd, jc):
                        for c2 in range(c + 1, nc):
                            if ct[c2] == troot:
                                record(
                                    evs, ev_count, rec_t, rec_k, rec_y, int(cj[c2]),
                                    int(cs[c2]), troot, yc,
                                )  # fmt: skip
                        for i in range(8):
                            state[i] = trial[i]
                        return EVENT, k
                for e in range(n_ev):
                    evs[e, EVS.G] = gb[e]
        state_to_canonical(state, y_out[k])
        ok = True
        for i in range(8):
            if not math.isfinite(y_out[k, i]):
                ok = False
        if not ok:
            return NONFINITE, k
        t_a = t_b
    return SUCCESS, m

"""Compiled adaptive Runge–Kutta integration (DOP853) with dense output.

One generic stepper: the method is the data in :mod:`orbit._tableaux`, the physics is
the right-hand side ``rhs(t, y, params, dydt)`` (a compiled function writing into ``dydt``:
an argument of the step kernels, which are inlined; the global ``RHS`` of the driver
:func:`dop853_run`, compiled once per right-hand side), and the whole step loop runs in
compiled code. Step-size control and error norm follow
Hairer, Nørsett & Wanner, *Solving ODEs I*, Sect. II.4 and II.10 (DOP853), as in SciPy's
``solve_ivp(method="DOP853")``, so the two paths take comparable steps.

The integrator state lives in caller-owned arrays, so a long run can be cut into chunks of
output times (for progress reporting and streaming to disk) and continued bit-for-bit as if it
had never stopped.

Layout of the persistent arrays
-------------------------------
``work`` : float64, shape (WORK_ROWS, n)
    rows (the WORK layout): the current state, the derivative there, the state at the start
    of the last step, its 16 stages (the 13th is the derivative at its end), its dense-output
    polynomial (7), two rows of scratch.
``tstate`` : float64, shape (4,)
    ``[t, h_next, t_old, h_last]``.
``counters`` : int64, shape (5,)
    ``[n_steps, n_rhs, n_rejected, started, dense_valid]``.
"""

from __future__ import annotations

import math

import numpy as np

from orbit._shared_jit import jit, jit_generic

from ._layout import Field, layout
from ._tableaux import DOP853_A, DOP853_B, DOP853_C, DOP853_D, DOP853_E3, DOP853_E5

# Rows of the work array.
WORK = layout(
    "DOP853 work rows",
    y=Field(1, "", "the current state"),
    f0=Field(1, "", "the derivative there"),
    yold=Field(1, "", "the state at the start of the last step"),
    k=Field(16, "", "the stages of the last step (k + 12: the derivative at its end)"),
    fd=Field(7, "", "the last step's dense-output polynomial"),
    yt=Field(1, "", "scratch"),
    yn=Field(1, "", "scratch"),
)
WORK_ROWS = WORK.SIZE

# Status codes returned by :func:`dop853_run` (EVENT and EVENT_BUFFER_FULL: by the events
# driver of attitude._core.events: a terminal event ended the run; the record buffer needs room).
SUCCESS = 0
NONFINITE = 1
STEP_TOO_SMALL = 2
TOO_MANY_STEPS = 3
EVENT = 4
EVENT_BUFFER_FULL = 5

STATUS_MESSAGES = {
    SUCCESS: "success",
    NONFINITE: "the state became non-finite (NaN or inf)",
    STEP_TOO_SMALL: "the step size fell below the round-off limit",
    TOO_MANY_STEPS: "the maximum number of steps was reached",
    EVENT: "a terminal event ended the run",
    EVENT_BUFFER_FULL: "the event record buffer is full",
}

_SAFETY = 0.9
_MIN_FACTOR = 0.2
_MAX_FACTOR = 10.0
_ERR_EXP = -1.0 / 8.0  # error estimator order 7


def new_state(n: int):
    """Fresh persistent arrays ``(work, tstate, counters)`` for a system of size ``n``."""
    return (
        np.zeros((WORK_ROWS, n)),
        np.zeros(4),
        np.zeros(5, dtype=np.int64),
    )


@jit
def _rms_scaled(v, y1, y2, rtol, atol, n):
    s = 0.0
    for i in range(n):
        sc = atol + rtol * max(abs(y1[i]), abs(y2[i]))
        s += (v[i] / sc) ** 2
    return math.sqrt(s / n)


@jit_generic
def _initial_step(rhs, params, t0, y0, f0, direction, rtol, atol, t_span, work, counters):
    # Hairer, Nørsett & Wanner, Sect. II.4, "Starting step size".
    n = y0.shape[0]
    d0 = _rms_scaled(y0, y0, y0, rtol, atol, n)
    d1 = _rms_scaled(f0, y0, y0, rtol, atol, n)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, t_span)
    yt = work[WORK.YT]
    for i in range(n):
        yt[i] = y0[i] + h0 * direction * f0[i]
    f1 = work[WORK.YN]
    rhs(t0 + h0 * direction, yt, params, f1)
    counters[1] += 1
    for i in range(n):
        yt[i] = f1[i] - f0[i]
    d2 = _rms_scaled(yt, y0, y0, rtol, atol, n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(min(100.0 * h0, h1), t_span)  # the two-argument min: compiled once


@jit_generic
def _dense_coefficients(rhs, params, work, tstate, counters):
    """The 7th-order interpolant of the last step (three extra stages, HNW II.10)."""
    n = work.shape[1]
    t_old = tstate[2]
    h = tstate[3]
    yold = work[WORK.YOLD]
    ynew = work[WORK.Y]
    yt = work[WORK.YT]
    for s in range(13, 16):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += DOP853_A[s, j] * work[WORK.K + j, i]
            yt[i] = yold[i] + h * acc
        rhs(t_old + DOP853_C[s] * h, yt, params, work[WORK.K + s])
    counters[1] += 3
    for i in range(n):
        dy = ynew[i] - yold[i]
        work[WORK.FD, i] = dy
        work[WORK.FD + 1, i] = h * work[WORK.K, i] - dy
        work[WORK.FD + 2, i] = 2.0 * dy - h * (work[WORK.K + 12, i] + work[WORK.K, i])
        for r in range(4):
            acc = 0.0
            for j in range(16):
                acc += DOP853_D[r, j] * work[WORK.K + j, i]
            work[WORK.FD + 3 + r, i] = h * acc
    counters[4] = 1


@jit
def _interpolate(work, tstate, t, out):
    n = work.shape[1]
    x = (t - tstate[2]) / tstate[3]
    for i in range(n):
        acc = 0.0
        for k in range(7):
            acc += work[WORK.FD + 6 - k, i]
            if k % 2 == 0:
                acc *= x
            else:
                acc *= 1.0 - x
        out[i] = acc + work[WORK.YOLD, i]


@jit_generic
def crossing(inside, data, work, tstate, out):
    """The first time in the last step (its dense output, computed) where ``inside(data, t,
    y)`` holds, when it holds at the step's end and not at its start: bisection to the last
    bit; the state there in ``out``. Returns the time."""
    lo = tstate[2]
    hi = tstate[0]
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid == lo or mid == hi:
            break
        _interpolate(work, tstate, mid, out)
        if inside(data, mid, out):
            hi = mid
        else:
            lo = mid
    _interpolate(work, tstate, hi, out)
    return hi


@jit_generic
def dop853_step(rhs, params, work, tstate, counters, h_abs, direction, t_end, rtol, atol, max_step):
    """One accepted DOP853 step from ``(tstate[0], work[WORK.Y])``, first trying the size ``h_abs``.

    On success the work rows and ``tstate`` hold the new state and the data of the step just
    taken (``WORK.YOLD``, the stages, ``t_old``, ``h``; its dense output is computed on demand by
    :func:`_dense_coefficients`). Never crosses ``t_end``.

    Returns
    -------
    status : int
        ``SUCCESS``, ``NONFINITE`` or ``STEP_TOO_SMALL`` (then nothing was accepted).
    h_abs : float
        The size to try next (also stored in ``tstate[1]``).
    """
    n = work.shape[1]
    y = work[WORK.Y]
    f = work[WORK.F0]
    yold = work[WORK.YOLD]
    yt = work[WORK.YT]
    yn = work[WORK.YN]
    t = tstate[0]
    min_step = 10.0 * abs(np.nextafter(t, direction * np.inf) - t)
    if h_abs > max_step:
        h_abs = max_step
    elif h_abs < min_step:
        h_abs = min_step
    elif not h_abs == h_abs:
        # A NaN size (from a non-finite derivative at the start) would never compare below
        # min_step: the rejection loop below would spin forever.
        tstate[1] = h_abs
        return NONFINITE, h_abs
    rejected = False
    while True:
        if h_abs < min_step:
            tstate[1] = h_abs
            return STEP_TOO_SMALL, h_abs
        h = h_abs * direction
        t_new = t + h
        if direction * (t_new - t_end) > 0.0:
            t_new = t_end
        h = t_new - t
        h_abs = abs(h)
        # Stages 1..11 (stage 0 is f, first-same-as-last).
        for i in range(n):
            work[WORK.K, i] = f[i]
        for s in range(1, 12):
            for i in range(n):
                acc = 0.0
                for j in range(s):
                    acc += DOP853_A[s, j] * work[WORK.K + j, i]
                yt[i] = y[i] + h * acc
            rhs(t + DOP853_C[s] * h, yt, params, work[WORK.K + s])
        for i in range(n):
            acc = 0.0
            for j in range(12):
                acc += DOP853_B[j] * work[WORK.K + j, i]
            yn[i] = y[i] + h * acc
        rhs(t_new, yn, params, work[WORK.K + 12])
        counters[1] += 12
        # Error estimate: the 5th- and 3rd-order embedded pairs (HNW II.10, eq. 10.17).
        e5 = 0.0
        e3 = 0.0
        finite = True
        for i in range(n):
            finite = finite and math.isfinite(yn[i])
            sc = atol + rtol * max(abs(y[i]), abs(yn[i]))
            a5 = 0.0
            a3 = 0.0
            for j in range(13):
                a5 += DOP853_E5[j] * work[WORK.K + j, i]
                a3 += DOP853_E3[j] * work[WORK.K + j, i]
            e5 += (a5 / sc) ** 2
            e3 += (a3 / sc) ** 2
        if e5 == 0.0 and e3 == 0.0:
            err = 0.0
        else:
            err = h_abs * e5 / math.sqrt((e5 + 0.01 * e3) * n)
        if not (finite and math.isfinite(err)):
            # A non-finite trial state (an overflowing state divides by an infinite scale and
            # can leave err finite): shrink hard; if that cannot help, report it.
            h_abs *= _MIN_FACTOR
            rejected = True
            counters[2] += 1
            if h_abs < min_step:
                tstate[1] = h_abs
                return NONFINITE, h_abs
            continue
        if err < 1.0:
            if err == 0.0:
                factor = _MAX_FACTOR
            else:
                factor = min(_MAX_FACTOR, _SAFETY * err**_ERR_EXP)
            if rejected:
                factor = min(1.0, factor)
            break
        h_abs *= max(_MIN_FACTOR, _SAFETY * err**_ERR_EXP)
        rejected = True
        counters[2] += 1
    # Accept the step.
    for i in range(n):
        yold[i] = y[i]
        y[i] = yn[i]
        f[i] = work[WORK.K + 12, i]
    tstate[2] = t
    tstate[3] = h
    t = t_new
    tstate[0] = t
    counters[0] += 1
    counters[4] = 0
    h_abs = h_abs * factor
    tstate[1] = h_abs
    return SUCCESS, h_abs


#: The right-hand side ``rhs(t, y, params, dydt)`` of a copy of :func:`dop853_run`: the entry
#: points bind it (``orbit._shared_jit.rebind``); the original here is never compiled.
RHS = None


@jit
def dop853_run(
    params,
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
    """Integrate from the stored state through the output times ``t_out``.

    On the first call (``counters[3] == 0``) the state is initialised from ``(t0, y0)``;
    later calls continue from ``work``/``tstate``. ``t_end`` is the final time of the whole run
    (steps never cross it), so a chunked run takes the same steps as a single call.

    Returns
    -------
    status : int
        One of ``SUCCESS``, ``NONFINITE``, ``STEP_TOO_SMALL``, ``TOO_MANY_STEPS``.
    n_done : int
        Number of rows of ``y_out`` filled (all of them on success).
    """
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
        RHS(t0, y, params, f)
        counters[1] += 1
        counters[3] = 1
        counters[4] = 0
    direction = 1.0 if t_end >= tstate[0] else -1.0

    k = 0
    h_abs = tstate[1]
    started = False
    stepped = False
    while True:
        # Serve the output times the stored state covers: the current time, and those before
        # it (inside the last step: its dense output). On entry, continuing a chunked run, only
        # those inside the last step. (One place serves them all, so the dense-output stages
        # are compiled once.)
        while k < m:
            to = t_out[k]
            if to == tstate[0]:
                for i in range(n):
                    y_out[k, i] = y[i]
            elif (
                counters[0] > 0
                and (stepped or direction * (to - tstate[2]) >= 0.0)
                and direction * (tstate[0] - to) > 0.0
            ):
                if counters[4] == 0:
                    _dense_coefficients(RHS, params, work, tstate, counters)
                _interpolate(work, tstate, to, y_out[k])
            else:
                break
            k += 1
        if k == m:
            return SUCCESS, k
        if not started:
            started = True
            if h_abs == 0.0:
                t = tstate[0]
                h_abs = _initial_step(
                    RHS, params, t, y, f, direction, rtol, atol, abs(t_end - t), work, counters
                )
        if counters[0] >= max_steps:
            tstate[1] = h_abs
            return TOO_MANY_STEPS, k
        status, h_abs = dop853_step(
            RHS, params, work, tstate, counters, h_abs, direction, t_end, rtol, atol, max_step
        )
        if status != SUCCESS:
            return status, k
        stepped = True

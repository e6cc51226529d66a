"""Stepping of the coupled orbit–attitude mode of the Taylor integrator (issue 41).

The series are those of :mod:`attitude._core.taylor` (module docstring, "Coupled orbit–attitude
mode"): :func:`~attitude._core.taylor.taylor_coefficients` with the model kind
``KIND_GRAVITY_GRADIENT_COUPLED`` expands q, g, Q and the body-axes orbit r, v, with the
back-reaction force in v̇. This module steps them: the state has 14 values (q, Q, r_B, v_B),
Jorba & Zou's radius ρ is taken over the four blocks q, Q, r, v (each with its own scale), and the
dense output evaluates the 14 polynomials.

Layout: ``work`` (WORK_ROWS, XCOL.SIZE): rows 0..p the coefficients (the columns of
:data:`~attitude._core.taylor.XCOL`), row Y the current state (the 14 values of
:data:`~attitude._core.taylor.XSTATE`); ``tstate`` and ``counters`` as in
:mod:`attitude._core.taylor`.
"""

from __future__ import annotations

import math

import numpy as np

from orbit._rk import NONFINITE, SUCCESS, TOO_MANY_STEPS
from orbit._shared_jit import jit

from .fma import fma as F
from .taylor import (
    COL,
    WORK_ROWS,
    XCOL,
    XSTATE,
    Y,
    _initial_row,
    order_from_tolerance,
    set_order,
    step_end,
    taylor_coefficients,
)

__all__ = ["coupled_run", "coupled_step", "dense_eval_coupled", "new_state"]


def new_state():
    """Fresh persistent arrays ``(work, tstate, counters)`` of the coupled mode."""
    return np.zeros((WORK_ROWS, XCOL.SIZE)), np.zeros(5), np.zeros(5, dtype=np.int64)


@jit(inline="always")
def _norm_inf(cf, k, c0, m):
    x = 0.0
    for i in range(c0, c0 + m):
        a = abs(cf[k, i])
        if a > x:
            x = a
    return x


@jit
def _radius(cf, p, rtol, atol):
    """Jorba & Zou's ρ (eq. 3.7) over the blocks q, Q, r, v (inf when every series ends)."""
    floor = atol / rtol
    starts = (0, 4, COL.A, COL.V)
    sizes = (4, 4, 3, 3)
    rho = math.inf
    for b in range(4):
        s = max(_norm_inf(cf, 0, starts[b], sizes[b]), floor)
        for j in (p - 1, p):
            nj = _norm_inf(cf, j, starts[b], sizes[b])
            if nj > 0.0:
                rho = min(rho, (s / nj) ** (1.0 / j))
    return rho


@jit
def dense_eval_coupled(work, p, tau, out):
    """Evaluate the 14 state polynomials (q, Q, r_B, v_B) of the last step at ``tau`` (Horner)."""
    for i in range(8):
        a = work[p, i]
        for k in range(p - 1, -1, -1):
            a = F(a, tau, work[k, i])
        out[i] = a
    for i in range(3):
        a = work[p, COL.A + i]
        b = work[p, COL.V + i]
        for k in range(p - 1, -1, -1):
            a = F(a, tau, work[k, COL.A + i])
            b = F(b, tau, work[k, COL.V + i])
        out[XSTATE.R + i] = a
        out[XSTATE.V + i] = b


@jit
def coupled_step(params, work, tstate, counters, rtol, atol, t_end, max_step):
    """One Taylor step of the coupled system from the state in ``work[Y]``; returns a status."""
    p = int(tstate[3])
    t = tstate[0]
    n, c = _initial_row(work, t, params)
    taylor_coefficients(work, p, params, n, c)
    counters[1] += p
    h_abs = _radius(work, p, rtol, atol) * tstate[4]  # Jorba & Zou eqs. 3.7–3.9
    status, t_new = step_end(t, h_abs, t_end, max_step)
    if status != SUCCESS:
        return status
    h = t_new - t
    y = work[Y]
    dense_eval_coupled(work, p, h, y)
    for i in range(XSTATE.SIZE):
        if not math.isfinite(y[i]):
            # Keep the state at the start of the step (row 0 of the table) as the current state.
            for ii in range(8):
                y[ii] = work[0, ii]
            for ii in range(3):
                y[XSTATE.R + ii] = work[0, COL.A + ii]
                y[XSTATE.V + ii] = work[0, COL.V + ii]
            return NONFINITE
    tstate[2] = t
    tstate[1] = h
    tstate[0] = t_new
    counters[0] += 1
    counters[4] = 1
    return SUCCESS


@jit
def _emit(work, tstate, counters, t_out, y_out, k, direction):
    """Write the output samples that need no further step (the current state at its time, the
    polynomial inside the last step); returns the next sample index."""
    m = t_out.shape[0]
    p = int(tstate[3])
    y = work[Y]
    while k < m:
        to = t_out[k]
        t = tstate[0]
        if to == t:
            for i in range(XSTATE.SIZE):
                y_out[k, i] = y[i]
        elif counters[4] == 1 and direction * (to - tstate[2]) >= 0.0 and direction * (t - to) > 0:
            dense_eval_coupled(work, p, to - tstate[2], y_out[k])
        else:
            break
        k += 1
    return k


@jit
def coupled_run(
    params, y0, t0, t_out, y_out, work, tstate, counters, rtol, atol, t_end, max_step, max_steps
):
    """Integrate the coupled system through the output times ``t_out`` (rows of ``y_out``: the
    14 state values): the arguments and the continuation of
    :func:`attitude._core.taylor.taylor_canonical_builtin`. Returns ``(status, n_done)``."""
    m = t_out.shape[0]
    y = work[Y]
    if counters[3] == 0:
        for i in range(XSTATE.SIZE):
            y[i] = y0[i]
        tstate[0] = t0
        tstate[1] = 0.0
        tstate[2] = t0
        set_order(tstate, order_from_tolerance(rtol))
        counters[3] = 1
        counters[4] = 0
    direction = 1.0 if t_end >= tstate[0] else -1.0
    k = 0
    while True:
        k = _emit(work, tstate, counters, t_out, y_out, k, direction)
        if k >= m:
            return SUCCESS, k
        if counters[0] >= max_steps:
            return TOO_MANY_STEPS, k
        status = coupled_step(params, work, tstate, counters, rtol, atol, t_end, max_step)
        if status != SUCCESS:
            return status, k

"""Compiled ensemble kernels: many independent members through the same DOP853 loop.

Every member is integrated on its own, with its own adaptive steps, its own work arrays and its
own parameter row ``params[i]`` (inertia, kind code, potential numbers; see
:mod:`attitude._core.potentials`). Nothing is shared between members and nothing is reduced
across them, so a member's result does not depend on how many members run beside it, how they
are chunked, or on how many threads run the loop: bit for bit.

:func:`member_run` is the member body; it calls the model's single-run entry points
(``dop853_canonical`` and ``diagnostics`` of :mod:`attitude._core.entry_points`), so a member
runs the very machine code of a single propagation. The driver over it, a GIL-free loop over
members (a block of them on each of a run's threads, or a Dask task's), is an entry point too:
``ensemble_member``, ``ensemble_serial``.

A member that fails keeps the samples it computed, with their diagnostics; the rest of its
rows are NaN. A call runs each member for at most ``budget`` steps (0: no limit) and leaves it
``RUNNING``; the next call continues it bit for bit (the DOP853 state is in the caller's
arrays), so a chunk of members returns to Python often enough for Ctrl-C to act.

Array layout (N members, m output times)
----------------------------------------
``params`` (N, P) · ``y0`` (N, 8) · ``t`` (m,) shared output times, ``t[0]`` the initial epoch ·
``y_out`` (N, m, 8) canonical states · ``diag`` (N, m, 13) diagnostics
(:func:`attitude._core.dynamics.diagnostics_with` columns) · ``work`` (N, WORK_ROWS, 8),
``tstate`` (N, 4), ``counters`` (N, 5): the DOP853 state of each member (layout in
:mod:`orbit._rk`) · ``status`` (N,) int64: ``NOT_STARTED`` before the first call, then
``RUNNING`` or a final code of :mod:`orbit._rk` · ``n_done`` (N,) int64 output rows
filled. All C-contiguous.
"""

from __future__ import annotations

import numpy as np

from orbit._rk import TOO_MANY_STEPS, WORK_ROWS
from orbit._shared_jit import jit, jit_generic

__all__ = [
    "NOT_STARTED",
    "RUNNING",
    "WORK_ROWS",
    "fresh_state",
    "invariant_maxima",
    "member_begin",
    "member_end",
    "member_run",
    "split_samples",
]

#: ``status`` of a member not integrated yet.
NOT_STARTED = -2
#: ``status`` of a member paused at the end of its step budget (call again).
RUNNING = -1


@jit(inline="always")
def fresh_state(w, ts, c):
    """A fresh integrator state (``dop853_run`` starts over when ``counters[3] == 0``)."""
    for r in range(w.shape[0]):
        for j in range(w.shape[1]):
            w[r, j] = 0.0
    for j in range(ts.shape[0]):
        ts[j] = 0.0
    for j in range(c.shape[0]):
        c[j] = 0


@jit(inline="always")
def member_begin(i, status, n_done, work, tstate, counters, max_steps, budget):
    """Start or resume member ``i``: (runs, first output row, step limit of this call).

    ``runs`` is False for a member that has ended; a ``NOT_STARTED`` one gets a fresh
    integrator state; the limit is ``max_steps``, or ``budget`` more steps (budget > 0).
    """
    st0 = status[i]
    if st0 != RUNNING and st0 != NOT_STARTED:
        return False, 0, 0
    c = counters[i]
    k0 = 0
    if st0 == NOT_STARTED:
        fresh_state(work[i], tstate[i], c)
    else:
        k0 = n_done[i]
    limit = max_steps
    if budget > 0 and c[0] + budget < max_steps:
        limit = c[0] + budget
    return True, k0, limit


@jit_generic
def member_end(diagnostics, i, st, k, limit, max_steps, params, t, y_out, diag, status, n_done):
    """Record a call's end for member ``i`` (``k`` output rows filled, status ``st``): paused
    at its budget (``RUNNING``), or ended: its diagnostics, and NaN after its last sample."""
    n_done[i] = k
    if st == TOO_MANY_STEPS and limit < max_steps:
        status[i] = RUNNING
        return
    status[i] = st
    yo = y_out[i]
    d = diag[i]
    diagnostics(t[:k], yo[:k], params[i], d[:k])
    for r in range(k, t.shape[0]):  # a failed member: the samples it did not reach
        for j in range(yo.shape[1]):
            yo[r, j] = np.nan
        for j in range(d.shape[1]):
            d[r, j] = np.nan


@jit_generic
def member_run(
    dop853,
    diagnostics,
    i,
    params,
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
    """Integrate member ``i`` (from a fresh state, or on from where it paused), for at most
    ``budget`` steps (0: to the end); when it ends, its diagnostics and NaN after a failure."""
    runs, k0, limit = member_begin(i, status, n_done, work, tstate, counters, max_steps, budget)
    if not runs:
        return
    m = t.shape[0]
    st, k = dop853(
        params[i], y0[i], t[0], t[k0:], y_out[i, k0:], work[i], tstate[i], counters[i],
        rtol, atol, t[m - 1], max_step, limit,
    )  # fmt: skip
    member_end(diagnostics, i, st, k + k0, limit, max_steps, params, t, y_out, diag, status, n_done)


@jit(nogil=True)
def split_samples(y, diag, q, Q, omega, g, G, energy, norm_error, qQ, potential_energy):
    """The per-variable arrays of a result from the states ``y`` (N, m, 8) and diagnostics
    ``diag`` (N, m, 13) (columns of :func:`attitude._core.dynamics.diagnostics_with`), in one
    pass (numpy copies strided columns several times slower)."""
    for i in range(y.shape[0]):
        for k in range(y.shape[1]):
            for j in range(4):
                q[i, k, j] = y[i, k, j]
                Q[i, k, j] = y[i, k, 4 + j]
            for j in range(3):
                omega[i, k, j] = diag[i, k, j]
                g[i, k, j] = diag[i, k, 3 + j]
                G[i, k, j] = diag[i, k, 6 + j]
            energy[i, k] = diag[i, k, 9]
            norm_error[i, k] = diag[i, k, 10]
            qQ[i, k] = diag[i, k, 11]
            potential_energy[i, k] = diag[i, k, 12]


#: ``kind`` of :func:`invariant_maxima`: which conserved quantities the model has.
INVARIANTS_NONE = 0
INVARIANTS_TORQUE_FREE = 1
INVARIANTS_HEAVY_TOP = 2
#: Smallest positive normal double (numpy's ``finfo(float).tiny``).
_TINY = 2.2250738585072014e-308


@jit(nogil=True)
def invariant_maxima(diag, ok, kind, inv):
    """The invariant maxima over the members ``i`` with ``ok[i]`` of ``diag`` (N, m, 13), in
    one pass, raised into ``inv`` (5,): max |norm_error|, max |q·Q|, max |q·Q| / max(2 |G|,
    tiny), the relative energy variation max |E − E₀| / max(|E₀|, tiny), and (``kind``) the
    relative change of G (torque-free: max |G − G₀| / max(|G₀|, 1e-300)) or of G_z (heavy top,
    same scale). NaN samples (after a terminal event) are skipped; every value is the one the
    numpy expressions of ``_Assembler.account`` give (the same operations per sample; the
    maxima are exact)."""
    for i in range(diag.shape[0]):
        if not ok[i]:
            continue
        e0 = diag[i, 0, 9]
        se = max(abs(e0), _TINY)
        g0 = diag[i, 0, 6]
        g1 = diag[i, 0, 7]
        g2 = diag[i, 0, 8]
        sg = max(np.sqrt(g0 * g0 + g1 * g1 + g2 * g2), 1e-300)
        for k in range(diag.shape[1]):
            a = abs(diag[i, k, 10])
            if a > inv[0]:
                inv[0] = a
            x0 = diag[i, k, 6]
            x1 = diag[i, k, 7]
            x2 = diag[i, k, 8]
            a = abs(diag[i, k, 11])
            if a > inv[1]:
                inv[1] = a
            a = a / max(2.0 * np.sqrt(x0 * x0 + x1 * x1 + x2 * x2), _TINY)
            if a > inv[2]:
                inv[2] = a
            a = abs(diag[i, k, 9] - e0) / se
            if a > inv[3]:
                inv[3] = a
            if kind == INVARIANTS_TORQUE_FREE:
                d0 = x0 - g0
                d1 = x1 - g1
                d2 = x2 - g2
                a = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / sg
                if a > inv[4]:
                    inv[4] = a
            elif kind == INVARIANTS_HEAVY_TOP:
                a = abs(x2 - g2) / sg
                if a > inv[4]:
                    inv[4] = a

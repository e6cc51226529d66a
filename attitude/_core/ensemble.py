"""Compiled ensemble kernels: many independent members through the same DOP853 loop.

Every member is integrated on its own, with its own adaptive steps, its own work arrays and its
own parameter row ``params[i]`` (inertia, kind code, potential numbers; see
:mod:`attitude._core.potentials`). Nothing is shared between members and nothing is reduced
across them, so a member's result does not depend on how many members run beside it, how they
are chunked, or on how many threads run the loop: bit for bit.

Built-in potentials: the member body :func:`member_builtin` calls the cached single-run entry
points of :func:`attitude.propagate`, :func:`attitude._core.dynamics.dop853_canonical_builtin`
and :func:`~attitude._core.dynamics.diagnostics_builtin`: a member runs the very machine code
of a single propagation, and the ensemble kernels compile in a moment once those exist.

Two drivers over that member body:

``run_builtin_parallel``
    ``prange`` over members (numba ``parallel=True``; threads set by ``numba.set_num_threads``).
``run_builtin_serial``
    A plain loop, releasing the GIL (``nogil``): what a Dask worker thread runs, since the
    worker's own threads already provide the parallelism (and numba's threading layers are
    not all safe under concurrent launches from several Python threads).

Everything is cached on disk. User kernels (``CustomPotential``, ``CustomTorque``) get the same
two drivers from :func:`make_user_drivers`, with the DOP853 loop inlined around the user's
right-hand side, compiled per process (not cacheable: numba cannot cache a function closing
over another dispatcher that is not a module global).

Diagnostics are computed for members that succeeded (a failed member fails its chunk, whose
results are not used).

Array layout (N members, m output times)
----------------------------------------
``params`` (N, P) · ``y0`` (N, 8) · ``t`` (m,) shared output times, ``t[0]`` the initial epoch ·
``y_out`` (N, m, 8) canonical states · ``diag`` (N, m, 13) diagnostics
(:func:`attitude._core.dynamics.diagnostics_with` columns) · ``work`` (N, WORK_ROWS, 8),
``tstate`` (N, 4), ``counters`` (N, 5): the DOP853 state of each member (layout in
:mod:`attitude._core.rk`) · ``status`` (N,) int64 · ``n_done`` (N,) int64 output rows filled.
All C-contiguous.
"""

from __future__ import annotations

import numba

from orbit._jit import jit, parallel_jit

from .dynamics import (
    canonical_rhs_with,
    diagnostics_builtin,
    diagnostics_with,
    dop853_canonical_builtin,
    user_rhs,
)
from .rk import SUCCESS, WORK_ROWS, dop853_run

__all__ = [
    "WORK_ROWS",
    "make_user_drivers",
    "member_builtin",
    "run_builtin_parallel",
    "run_builtin_serial",
]


@jit(inline="always")
def _fresh(w, ts, c):
    """A fresh integrator state (``dop853_run`` starts over when ``counters[3] == 0``)."""
    for r in range(w.shape[0]):
        for j in range(w.shape[1]):
            w[r, j] = 0.0
    for j in range(ts.shape[0]):
        ts[j] = 0.0
    for j in range(c.shape[0]):
        c[j] = 0


@jit(inline="always")
def _member(
    rhs,
    potential,
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
):
    """Integrate member ``i`` from a fresh integrator state, then its diagnostics."""
    m = t.shape[0]
    w = work[i]
    ts = tstate[i]
    c = counters[i]
    _fresh(w, ts, c)
    p = params[i]
    yo = y_out[i]
    st, k = dop853_run(
        rhs, p, y0[i], t[0], t, yo, w, ts, c, rtol, atol, t[m - 1], max_step, max_steps
    )
    status[i] = st
    n_done[i] = k
    if st == SUCCESS:
        diagnostics_with(potential, t, yo, p, diag[i])


@jit(nogil=True)
def member_builtin(
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
):
    """Member ``i`` with a built-in potential: the one compiled body both drivers call."""
    m = t.shape[0]
    w = work[i]
    ts = tstate[i]
    c = counters[i]
    _fresh(w, ts, c)
    p = params[i]
    yo = y_out[i]
    st, k = dop853_canonical_builtin(
        p, y0[i], t[0], t, yo, w, ts, c, rtol, atol, t[m - 1], max_step, max_steps
    )
    status[i] = st
    n_done[i] = k
    if st == SUCCESS:
        diagnostics_builtin(t, yo, p, diag[i])


@parallel_jit(nogil=True)
def run_builtin_parallel(
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
):
    """All members with a built-in potential, in parallel over members (``prange``)."""
    for i in numba.prange(y0.shape[0]):
        member_builtin(
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
        )


@jit(nogil=True)
def run_builtin_serial(
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
):
    """All members with a built-in potential, one after the other (GIL released)."""
    for i in range(y0.shape[0]):
        member_builtin(
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
        )


_USER_DRIVERS: dict[tuple[int, int], tuple] = {}


def make_user_drivers(torque, potential):
    """(parallel, serial) drivers for user kernels ``torque(q, t, params)``, ``potential``.

    Compiled once per process and pair of kernels (not cached on disk).
    """
    key = (id(torque), id(potential))
    if key in _USER_DRIVERS:
        return _USER_DRIVERS[key]

    rhs = user_rhs(canonical_rhs_with, torque)

    @jit(cache=False, nogil=True)
    def member(
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
    ):
        _member(
            rhs,
            potential,
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
        )

    @parallel_jit(cache=False, nogil=True)
    def run_parallel(
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
    ):
        for i in numba.prange(y0.shape[0]):
            member(
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
            )

    @jit(cache=False, nogil=True)
    def run_serial(
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
    ):
        for i in range(y0.shape[0]):
            member(
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
            )

    _USER_DRIVERS[key] = (run_parallel, run_serial)
    return _USER_DRIVERS[key]

"""Compiled ensembles of spacecraft with actuators: many gyrostats through held commands.

Every member runs the single-run driver of its method (:func:`attitude._core.holds.holds_run`
for DOP853, :func:`attitude._core.taylor_gyrostat.taylor_holds_run` for Taylor, each with the
open-loop schedule or the flight software as its command source) on its own rows of the arrays
below, from a fresh state: the same compiled code on the same numbers as
``propagate(spacecraft, ..., commands=... or software=...)``, so a member equals its single run
bit for bit whatever runs beside it, however the members are chunked, on however many threads.
With DOP853 it *is* the single run's compiled driver, called for each member from Python
threads (:mod:`attitude.ensemble._chunks`, GIL released; ``hs[HS.SAMPLES_ONLY]`` keeps a
member's rows on the shared samples). The SIMD batches of the Taylor method
(:mod:`attitude._core.gyrostat_batch`) use the same layout.

A call runs each member for at most ``budget`` steps (0: to its end) and leaves it ``RUNNING``
(:mod:`attitude._core.ensemble`); the next call goes on bit for bit (the integrator, the hold
driver and the software keep their state in the member's rows). A member whose tick records
are full pauses as ``RECORDS_WAIT``: the caller gives it more rows and calls again.

Array layout (C members, m output times, n = 8 + n_w state values, r record columns)
-------------------------------------------------------------------------------------
``params`` (C, P) · ``sc`` (S,) the members' spacecraft blocks one after the other, member i's
``sc[sc_at[i]:sc_at[i + 1]]`` (written during the run: its held slots) · ``y0`` (C, n) · ``t``
(m,) shared output times, ``t[0]`` the initial epoch · ``y_out`` (C, m, n + r) output rows (the
state, then the record of the commands in force, :func:`attitude._core.holds.record`) ·
``work``, ``tstate``, ``counters`` the method's integrator state, one row per member (the
single run's layouts) · ``status``, ``n_done`` (C,) int64 as in :mod:`attitude._core.ensemble`.

The command source of a member is a tuple of arrays, ``src``; :func:`schedule_ctl` and
:func:`fsw_ctl` cut member i's ``ctl`` tuple of the single run out of it:

* open loop: ``(hs (C, HS.SIZE), hold_t (K,), hold_u (K, n_cmd), hold_at (C + 1,), zero
  (n_cmd,))``: member i's schedule is ``hold_t[hold_at[i]:hold_at[i + 1]]``;
* flight software: ``(hs, fw (F,), fw_at (C, 2), fs (S',), fs_at (C + 1,), cmd (C, c), rec
  (C, R, w), rc (C, 1))``: member i's program ``fw[fw_at[i, 0]:fw_at[i, 1]]`` (read only:
  members with the same program share its rows), its software state
  ``fs[fs_at[i]:fs_at[i + 1]]``, its command scratch, tick records and their count.
"""

from __future__ import annotations

import math

from orbit._rk import TOO_MANY_STEPS
from orbit._shared_jit import jit

from .ensemble import RUNNING
from .holds import RECORDS_FULL

__all__ = [
    "RECORDS_WAIT",
    "fsw_ctl",
    "member_stop",
    "schedule_ctl",
]

#: ``status`` of a member paused because its tick records are full (give it more rows).
RECORDS_WAIT = -3


@jit(inline="always")
def schedule_ctl(i, src):
    """Member ``i``'s ``ctl`` of an open-loop schedule: ``(hs, hold_t, hold_u, zero)``."""
    hs, hold_t, hold_u, hold_at, zero = src
    a = hold_at[i]
    b = hold_at[i + 1]
    return (hs[i], hold_t[a:b], hold_u[a:b], zero)


@jit(inline="always")
def fsw_ctl(i, src):
    """Member ``i``'s ``ctl`` of the flight software: ``(hs, fw, fs, cmd, rec, rc)``."""
    hs, fw, fw_at, fs, fs_at, cmd, rec, rc = src
    return (hs[i], fw[fw_at[i, 0] : fw_at[i, 1]], fs[fs_at[i] : fs_at[i + 1]], cmd[i], rec[i],
            rc[i])  # fmt: skip


@jit(inline="always")
def member_stop(i, st, k, limit, max_steps, y_out, status, n_done):
    """Record a call's end for member ``i`` (``k`` output rows filled, status ``st``): paused
    at its step budget (``RUNNING``) or its full tick records (``RECORDS_WAIT``), or ended
    (its rows after the last sample NaN)."""
    n_done[i] = k
    if st == TOO_MANY_STEPS and limit < max_steps:
        status[i] = RUNNING
        return
    if st == RECORDS_FULL:
        status[i] = RECORDS_WAIT
        return
    status[i] = st
    yo = y_out[i]
    for r in range(k, yo.shape[0]):
        for j in range(yo.shape[1]):
            yo[r, j] = math.nan

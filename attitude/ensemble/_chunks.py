"""One chunk of members in compiled code (also the body of a Dask task)."""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._core import entry_points as _builtin_entry_points
from .._core import rk as _rk

_N_DIAG = 13

# ------------------------------------------------------------------------------------------------
# one chunk in compiled code (also the Dask task)
# ------------------------------------------------------------------------------------------------


@dataclass
class _Setup:
    """What every chunk needs besides its members (picklable: shipped to Dask workers)."""

    t: np.ndarray
    rtol: float
    atol: float
    max_step: float
    max_steps: int
    user_potential: Any = None  # a CustomPotential/CustomTorque, or None for built-ins
    events: Any = None  # attitude.events.EventSet, or None
    method: str = "dop853"  # "dop853" or "taylor"


def _compute_chunk(
    setup: _Setup,
    params: np.ndarray,
    y0: np.ndarray,
    *,
    parallel: bool,
    y_out: np.ndarray | None = None,
    diag: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Integrate the members of one chunk; arrays of the chunk's results (the states and
    diagnostics written into ``y_out`` (c, m, 8) and ``diag`` (c, m, 13) if given)."""
    c = y0.shape[0]
    t = setup.t
    m = t.shape[0]
    out = {
        "y": np.empty((c, m, 8)) if y_out is None else y_out,
        "diag": np.empty((c, m, _N_DIAG)) if diag is None else diag,
        "counters": np.empty((c, 5), dtype=np.int64),
        "status": np.empty(c, dtype=np.int64),
        "n_done": np.empty(c, dtype=np.int64),
    }
    if setup.method == "taylor":
        return _compute_chunk_taylor(setup, params, y0, out, parallel)
    work = np.empty((c, _rk.WORK_ROWS, 8))
    tstate = np.empty((c, 4))
    entry = _entry(setup)
    if setup.events is not None:
        return _compute_chunk_events(setup, entry, params, y0, out, work, tstate, parallel)
    fn = entry.ensemble_parallel if parallel else entry.ensemble_serial
    fn(
        params,
        y0,
        t,
        out["y"],
        out["diag"],
        work,
        tstate,
        out["counters"],
        out["status"],
        out["n_done"],
        setup.rtol,
        setup.atol,
        setup.max_step,
        setup.max_steps,
    )
    out["t_stop"] = tstate[:, 0].copy()  # time each member's integration reached
    return out


#: Fewest members per batch integrator of the parallel Taylor driver: when a group runs out of
#: members its lanes idle while the last ones finish (about 1.5 member runs per group).
TAYLOR_MIN_GROUP = 32


def _compute_chunk_taylor(setup, params, y0, out, parallel):
    """:func:`_compute_chunk` with ``method="taylor"``: members in SIMD batches
    (:mod:`attitude._core.taylor_batch`), in groups run in parallel."""
    from .._core import taylor_batch as _tb
    from .._core.potentials import KIND_GRAVITY_GRADIENT, P0, P_KIND

    c = y0.shape[0]
    tstate = np.empty((c, 5))
    orbit_tab = np.empty((0, 4))
    shared = (params[:, P_KIND:] == params[0, P_KIND:]).all()
    if int(params[0, P_KIND]) == KIND_GRAVITY_GRADIENT and shared:
        # one orbit for all: looked up once per output time for the diagnostics
        orbit_tab = np.empty((setup.t.shape[0], 4))
        _tb.orbit_radial_table(params[0, P0:], setup.t, orbit_tab)
    args = (
        params, y0, setup.t, out["y"], out["diag"], tstate, out["counters"], out["status"],
        out["n_done"], setup.rtol, setup.atol, setup.max_step, setup.max_steps, orbit_tab,
    )  # fmt: skip
    threads = 1
    if parallel:
        import numba

        threads = numba.get_num_threads()
    if threads == 1:
        _tb.taylor_ensemble_serial(*args, max(c, 1))
    else:
        # About 4 groups per thread, of equal size (balance), none below TAYLOR_MIN_GROUP.
        n_groups = max(1, min(4 * threads, c // TAYLOR_MIN_GROUP))
        old = numba.set_parallel_chunksize(1)  # a group at a time (they are few and long)
        try:
            _tb.taylor_ensemble_parallel(*args, -(-c // n_groups))
        finally:
            numba.set_parallel_chunksize(old)
    out["counters"][:, 1] = 0  # no right-hand side is evaluated (Taylor terms instead)
    out["t_stop"] = tstate[:, 0].copy()
    return out


def _entry(setup: _Setup) -> Any:
    """The compiled entry points of the chunk's model (and user event functions)."""
    ev = setup.events
    user_events = () if ev is None else ev.user_functions
    if setup.user_potential is None and not user_events:
        return _builtin_entry_points
    from .._user_kernels import entry_points

    terms = () if setup.user_potential is None else setup.user_potential._user_terms()
    return entry_points(terms, user_events)


def _compute_chunk_events(setup, entry, params, y0, out, work, tstate, parallel):
    """:func:`_compute_chunk` with events: per member and event, the count and first time."""
    from .._core import events as _ke

    ev = setup.events
    evs = np.zeros((y0.shape[0], ev.n, _ke.EVS_COLS))
    fn = entry.ensemble_events_parallel if parallel else entry.ensemble_events_serial
    fn(
        params, ev.data, evs, y0, setup.t, out["y"], out["diag"], work, tstate,
        out["counters"], out["status"], out["n_done"], setup.rtol, setup.atol,
        setup.max_step, setup.max_steps,
    )  # fmt: skip
    out["t_stop"] = tstate[:, 0].copy()
    out["event_count"] = evs[:, :, _ke.EVS_COUNT].astype(np.int64)
    out["event_first"] = evs[:, :, _ke.EVS_FIRST].copy()
    return out


def _chunk_task(setup: _Setup, params: np.ndarray, y0: np.ndarray) -> dict[str, np.ndarray]:
    """A chunk as a Dask task: the serial (GIL-free) driver; the worker threads parallelise."""
    return _compute_chunk(setup, params, y0, parallel=False)


#: Members handed to a thread at a time by the parallel loop (dynamic scheduling: a thread that
#: gets less CPU, or slower members, does not hold the others up at the end of a chunk).
PARALLEL_CHUNK = 8


@contextlib.contextmanager
def _numba_threads(threads: int | None):
    """Run the parallel driver with ``threads`` numba threads (restored afterwards)."""
    from orbit._shared_jit import JIT_DISABLED

    if JIT_DISABLED:
        yield
        return
    import numba

    old = numba.get_num_threads()
    old_chunk = numba.set_parallel_chunksize(PARALLEL_CHUNK)
    if threads is not None:
        numba.set_num_threads(int(threads))
    try:
        yield
    finally:
        numba.set_num_threads(old)
        numba.set_parallel_chunksize(old_chunk)


def _failure_message(out, bad, start, t) -> tuple[str, float]:
    idx = [int(start + i) for i in bad]
    shown = ", ".join(map(str, idx[:10])) + (f", ... ({len(idx)} in all)" if len(idx) > 10 else "")
    first = int(bad[0])
    msg = _rk.STATUS_MESSAGES.get(int(out["status"][first]), "failed")
    k = int(out["n_done"][first])
    t_stop = float(out["t_stop"][first])
    return (
        f"member(s) {shown} failed: member {idx[0]} stopped at t = {t_stop!r}: {msg} "
        f"({k} of {t.shape[0]} output samples computed)",
        t_stop,
    )

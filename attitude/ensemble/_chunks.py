"""One chunk of members in compiled code: rigid bodies (:func:`_compute_chunk`, also the body of
a Dask task) and spacecraft with actuators or flight software (:func:`compute_craft_chunk`: the
single run's compiled drivers themselves, a member a call, on threads, or SIMD batches for
``method="taylor"``, :mod:`attitude._core.gyrostat_batch`, then each member's diagnostics by the
single run's own); the chunks computed here one after the other (:func:`local_results`), a
failing chunk's members marked (:data:`CHUNK_FAILED`), and the failures named
(:class:`_Failures`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from orbit import _rk

from .. import _interrupt
from .._core import ensemble as _ke
from .._core import entry_points as _builtin_entry_points
from .._core import events as _kev
from .._core import fsw as _kf
from .._core import holds as _kh
from .._core import spacecraft_ensemble as _kse
from .._core import taylor as _kt
from .._core import taylor_gyrostat as _ktg
from ..errors import AttitudeTypeError, AttitudeValueError
from ._threads import PARALLEL_CHUNK, block_size, on_blocks, on_threads, thread_count

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


#: Integration steps per compiled call, summed over the members of a chunk and divided among
#: the threads (as ``attitude._methods.STEP_BUDGET`` for one run): each member gets
#: ``max(MIN_MEMBER_BUDGET, ENSEMBLE_STEP_BUDGET * threads // members)`` steps a call, then the
#: chunk returns to Python (Ctrl-C acts) and goes on where it stopped, bit for bit.
ENSEMBLE_STEP_BUDGET = 20_000
MIN_MEMBER_BUDGET = 16

#: ``member_status`` of the members of a chunk whose task failed as a whole (an exception in
#: the worker, not a member's integration): their rows are NaN. (Above the integrator's codes
#: of orbit._rk, EVENT = 4 and EVENT_BUFFER_FULL = 5 included.)
CHUNK_FAILED = 9

#: CF ``flag_values``/``flag_meanings`` of ``member_status``.
STATUS_FLAGS = {
    _rk.SUCCESS: "success",
    _rk.NONFINITE: "state_became_non_finite",
    _rk.STEP_TOO_SMALL: "step_size_below_round_off",
    _rk.TOO_MANY_STEPS: "max_steps_reached",
    _rk.EVENT: "terminal_event",
    _rk.EVENT_BUFFER_FULL: "event_buffer_full",
    CHUNK_FAILED: "chunk_task_failed",
}


def _compute_chunk(
    setup: _Setup,
    params: np.ndarray,
    y0: np.ndarray,
    *,
    parallel: bool,
    threads: int = 1,
    y_out: np.ndarray | None = None,
    diag: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Integrate the members of one chunk; arrays of the chunk's results (the states and
    diagnostics written into ``y_out`` (c, m, 8) and ``diag`` (c, m, 13) if given).

    Every member is run to its end, failed or not (``status``, ``n_done``, ``t_stop`` say
    how it ended; a failed member's rows after its last sample are NaN).
    """
    # The compiled drivers take C-ordered float64 (another layout compiles them again, and every
    # kernel they inline: tens of seconds on a fresh cache for the same results).
    params = np.ascontiguousarray(params, dtype=np.float64)
    y0 = np.ascontiguousarray(y0, dtype=np.float64)
    c = y0.shape[0]
    t = setup.t
    m = t.shape[0]
    out = {
        "y": np.empty((c, m, 8)) if y_out is None else y_out,
        "diag": np.empty((c, m, _N_DIAG)) if diag is None else diag,
        "counters": np.empty((c, 5), dtype=np.int64),
        "status": np.full(c, _ke.NOT_STARTED, dtype=np.int64),
        "n_done": np.zeros(c, dtype=np.int64),
    }
    if setup.method == "taylor":
        return _compute_chunk_taylor(setup, params, y0, out, threads if parallel else 1)
    work = np.empty((c, _rk.WORK_ROWS, 8))
    tstate = np.empty((c, 4))
    entry = _entry(setup)
    budget = max(MIN_MEMBER_BUDGET, ENSEMBLE_STEP_BUDGET * max(1, threads) // max(1, c))
    if setup.events is not None:
        return _compute_chunk_events(setup, entry, params, y0, out, work, tstate,
                                      threads if parallel else 1, budget)  # fmt: skip
    state = (work, tstate, out["counters"], out["status"], out["n_done"])
    tail = (setup.rtol, setup.atol, setup.max_step, setup.max_steps, budget)

    def block(a, b):  # members a..b-1 (their rows, views: the serial driver's types)
        entry.ensemble_serial(params[a:b], y0[a:b], t, out["y"][a:b], out["diag"][a:b],
                              *(x[a:b] for x in state), *tail)  # fmt: skip

    _serial_blocks(threads if parallel else 1, c, out["status"], block)
    out["t_stop"] = tstate[:, 0].copy()  # time each member's integration reached
    return out


def rigid_arrays(c: int, m: int, n_events: int, fill: float) -> dict[str, Any]:
    """Arrays shaped like a rigid-body chunk's results, states and diagnostics filled with
    ``fill`` (zeros: the size estimate's member; NaN: a chunk whose task failed)."""
    out = {
        "y": np.full((c, m, 8), fill),
        "diag": np.full((c, m, _N_DIAG), fill),
        "counters": np.zeros((c, 5), dtype=np.int64),
        "status": np.zeros(c, dtype=np.int64),
        "n_done": np.full(c, m, dtype=np.int64),
        "t_stop": np.zeros(c),
    }
    if n_events:  # the per-member event statistics of _compute_chunk_events
        out["event_count"] = np.zeros((c, n_events), dtype=np.int64)
        out["event_first"] = np.full((c, n_events), np.nan)
    return out


def _failed_chunk(setup: _Setup, c: int, exc: BaseException) -> dict[str, Any]:
    """The arrays of a chunk whose task failed as a whole: NaN rows, status CHUNK_FAILED."""
    n_events = 0 if setup.events is None else setup.events.n
    return _failed(rigid_arrays(c, setup.t.shape[0], n_events, np.nan), setup.t, exc)


def _failed(out: dict[str, Any], t: np.ndarray, exc: BaseException) -> dict[str, Any]:
    """``out`` (NaN arrays) marked as a chunk that raised: CHUNK_FAILED, nothing done."""
    out["status"][:] = CHUNK_FAILED
    out["n_done"][:] = 0
    out["t_stop"][:] = float(t[0])
    out["error"] = f"{type(exc).__name__}: {exc}"
    for key in ("n_records", "n_ticks"):  # (a spacecraft's flight software)
        if key in out:
            out[key][:] = 0
    return out


#: Fewest members per batch integrator of the parallel Taylor driver: when a group runs out of
#: members its lanes idle while the last ones finish (about 1.5 member runs per group).
TAYLOR_MIN_GROUP = 32


def _compute_chunk_taylor(setup, params, y0, out, threads):
    """:func:`_compute_chunk` with ``method="taylor"``: members in SIMD batches
    (:mod:`attitude._core.taylor_batch`), in groups run in parallel."""
    from .._core import taylor_batch as _tb0
    from .._core.potentials import (
        KIND_GRAVITY_GRADIENT,
        MODEL,
    )

    _tb = _tb0.batch()  # lanes sized to the CPU (same results at any width)

    c = y0.shape[0]
    tstate = np.empty((c, 5))
    orbit_tab = np.empty((0, 4))
    shared = (params[:, MODEL.KIND :] == params[0, MODEL.KIND :]).all()
    if int(params[0, MODEL.KIND]) == KIND_GRAVITY_GRADIENT and shared:
        # one orbit for all: looked up once per output time for the diagnostics
        orbit_tab = np.empty((setup.t.shape[0], 4))
        _tb.orbit_radial_table(params[0, MODEL.DATA :], setup.t, orbit_tab)
    args = (
        params, y0, setup.t, out["y"], out["diag"], tstate, out["counters"], out["status"],
        out["n_done"], setup.rtol, setup.atol, setup.max_step, setup.max_steps, orbit_tab,
    )  # fmt: skip
    # About 4 groups per thread, of equal size (balance), none below TAYLOR_MIN_GROUP; one
    # group on one thread.
    n_groups = 1 if threads == 1 else max(1, min(4 * threads, c // TAYLOR_MIN_GROUP))
    group = max(c, 1) if n_groups == 1 else -(-c // n_groups)
    n_groups = -(-c // group)  # (0 for no members: nothing to run)
    ws = _tb.new_workspaces(n_groups, _tb.LANES)
    # Batch steps (LANES member steps each) per group and call, ENSEMBLE_STEP_BUDGET member
    # steps per thread and call in all: the call returns to Python (Ctrl-C acts) and goes on.
    budget = max(MIN_MEMBER_BUDGET, ENSEMBLE_STEP_BUDGET * threads // (n_groups * _tb.LANES))
    while True:
        if threads == 1:
            _tb.taylor_ensemble_serial(*args, group, *ws, budget)
        else:
            on_threads(threads, n_groups,
                        lambda g: _tb.taylor_group_run(*args, group, *ws, budget, g),
                        more=lambda g: not ws[4][g, _tb.GROUP.DONE])  # fmt: skip
        _interrupt.check()
        if ws[4][:, _tb.GROUP.DONE].all():
            break
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
    return entry_points(terms, user_events, potential=setup.user_potential)


def _compute_chunk_events(setup, entry, params, y0, out, work, tstate, threads, budget):
    """:func:`_compute_chunk` with events: per member and event, the count and first time."""
    ev = setup.events
    evs = np.zeros((y0.shape[0], ev.n, _kev.EVS.SIZE))
    c = y0.shape[0]
    state = (work, tstate, out["counters"], out["status"], out["n_done"])
    tail = (setup.rtol, setup.atol, setup.max_step, setup.max_steps, budget)

    def block(a, b):  # members a..b-1 (their rows, views: the serial driver's types)
        entry.ensemble_events_serial(params[a:b], ev.data, evs[a:b], y0[a:b], setup.t,
                                     out["y"][a:b], out["diag"][a:b], *(x[a:b] for x in state),
                                     *tail)  # fmt: skip

    _serial_blocks(threads, c, out["status"], block)
    out["t_stop"] = tstate[:, 0].copy()
    out["event_count"] = evs[:, :, _kev.EVS.COUNT].astype(np.int64)
    out["event_first"] = evs[:, :, _kev.EVS.FIRST].copy()
    return out


def _serial_blocks(threads: int, c: int, status: np.ndarray, block: Any) -> None:
    """Members 0..c-1 through ``block(a, b)``, a serial driver over members a..b-1, on
    ``threads`` threads; a block is called again while any of its members is paused at its step
    budget (it goes on bit for bit; Ctrl-C acts between calls)."""
    on_blocks(threads, c, block, block_size(c, threads),
              lambda a, b: bool(np.any(status[a:b] == _ke.RUNNING)))  # fmt: skip


def _chunk_task(setup: _Setup, params: np.ndarray, y0: np.ndarray) -> dict[str, np.ndarray]:
    """A chunk as a Dask task: the serial (GIL-free) driver; the worker threads parallelise."""
    return _compute_chunk(setup, params, y0, parallel=False)


def _ranges(idx: list[int]) -> str:
    """'3, 7-9, 12' for [3, 7, 8, 9, 12] (sorted member indices)."""
    parts = []
    i = 0
    while i < len(idx):
        j = i
        while j + 1 < len(idx) and idx[j + 1] == idx[j] + 1:
            j += 1
        parts.append(str(idx[i]) if i == j else f"{idx[i]}-{idx[j]}")
        i = j + 1
    return ", ".join(parts)


class _Failures:
    """The failed members of a run, chunk by chunk; one message that names every one."""

    def __init__(self, m: int):
        self.m = m  # output samples per member
        self.by_status: dict[int, list[int]] = {}
        self.first: tuple[int, float, int, str] | None = None  # member, t_stop, n_done, why
        self.errors: list[str] = []

    def add(self, out: dict[str, Any], start: int) -> np.ndarray:
        """Record the failed members of a chunk; returns their positions in the chunk."""
        st_all = out["status"]
        bad = np.flatnonzero((st_all != _rk.SUCCESS) & (st_all != _rk.EVENT))
        for b in bad:
            st = int(out["status"][b])
            self.by_status.setdefault(st, []).append(int(start + b))
            if self.first is None:
                why = self._why(st, out)
                self.first = (int(start + b), float(out["t_stop"][b]), int(out["n_done"][b]), why)
        if bad.size and "error" in out:
            self.errors.append(
                f"members {start}-{start + out['status'].shape[0] - 1}: {out['error']}"
            )
        return bad

    @staticmethod
    def _why(st: int, out: dict[str, Any]) -> str:
        if st == CHUNK_FAILED:
            return f"its chunk's task failed ({out.get('error', '')})"
        return _rk.STATUS_MESSAGES.get(st, "failed")

    @property
    def count(self) -> int:
        return sum(len(v) for v in self.by_status.values())

    @property
    def members(self) -> list[int]:
        return sorted(i for v in self.by_status.values() for i in v)

    def message(self, n: int) -> str:
        """'member(s) 30, 170 failed (2 of 200): ...' naming every failed member and why."""
        first = self.first
        assert first is not None
        groups = "; ".join(
            f"{_ranges(sorted(v))}: {STATUS_FLAGS.get(st, str(st)).replace('_', ' ')}"
            for st, v in sorted(self.by_status.items())
        )
        msg = (
            f"member(s) {_ranges(self.members)} failed ({self.count} of {n}): member {first[0]} "
            f"stopped at t = {first[1]!r}: {first[3]} ({first[2]} of {self.m} output samples "
            f"computed)"
        )
        if len(self.by_status) > 1 or self.count > 1:
            msg += f"; by cause: {groups}"
        if self.errors:
            msg += "; failed tasks: " + "; ".join(self.errors[:3])
        return msg


def _failure_message(out, bad, start, t) -> tuple[str, float]:
    """Message naming every failed member of one chunk, and the time the first one stopped."""
    f = _Failures(t.shape[0])
    f.add(out, start)
    first = f.first
    return f.message(out["status"].shape[0]), (first[1] if first else float("nan"))


# ------------------------------------------------------------------------------------------------
# chunks computed here, one after the other
# ------------------------------------------------------------------------------------------------


def _each(bounds: list[tuple[int, int]], compute: Any):
    """``compute(start, stop)`` of each chunk in turn (a generator); a chunk that raises (not
    a member's integration: that is in its status) yields the exception and the next chunks
    go on (an invalid input raises)."""
    for start, stop in bounds:
        try:
            got = compute(start, stop)
        except (AttitudeValueError, AttitudeTypeError):
            raise
        except Exception as exc:
            got = exc
        yield got


def local_results(setup, members, bounds, threads, direct=None):
    """Rigid-body chunks computed here with the parallel driver, one after the other: (out,
    inertia, projection) each (:func:`_each`)."""
    n = thread_count(threads)

    def compute(start: int, stop: int) -> tuple:
        params, y0, inertia, corr = members.block(start, stop)
        buf = {} if direct is None else direct.buffers(start, stop)
        out = _compute_chunk(setup, params, y0, parallel=n > 1, threads=n, **buf)
        return out, inertia, corr

    return _each(bounds, compute)


def craft_results(members, bounds, t, entry, rtol, atol, max_step, max_steps, threads):
    """Spacecraft chunks computed here, one after the other: (out, block, projection) each
    (:func:`_each`)."""
    fsw = members.program is not None
    n_terms = len(members.potential.terms)

    def compute(start: int, stop: int) -> tuple:
        blk = members.block(start, stop)
        out = compute_craft_chunk(blk, t, entry, members.method, fsw, rtol, atol, max_step,
                                  max_steps, threads, n_terms, members.events)  # fmt: skip
        return out, blk, float(blk["projection"])

    return _each(bounds, compute)


def craft_arrays(members: Any, c: int, m: int, fill: float) -> dict[str, Any]:
    """Arrays shaped like a spacecraft chunk's results, filled with ``fill`` (zeros: the
    size estimate's member; NaN: a chunk whose computation raised)."""
    n = members.n_state
    out = {
        "rows": np.full((c, m, n + members.n_rec), fill),
        "diag": np.full((c, m, _N_DIAG), fill),
        "torques": np.full((c, m, len(members.potential.terms) + 1, 3), fill),
        "actuators": np.full((c, m, 4, 3), fill),
        "wheels": np.full((c, m, members.structure.counts[0], 2), fill),
        "counters": np.zeros((c, 5), dtype=np.int64),
        "status": np.zeros(c, dtype=np.int64),
        "n_done": np.full(c, m, dtype=np.int64),
        "t_stop": np.zeros(c),
    }
    if members.events is not None:
        out["event_count"] = np.zeros((c, members.events.n), dtype=np.int64)
        out["event_first"] = np.full((c, members.events.n), np.nan)
    if members.program is not None:
        k = members.tick_times().shape[0]
        out["records"] = np.full((c, k + 1, members.program.rec_width), fill)
        out["n_records"] = np.full(c, k, dtype=np.int64)
        out["n_ticks"] = np.full(c, k, dtype=np.int64)
    return out


def failed_craft_chunk(members, c: int, t: np.ndarray, exc: BaseException) -> dict[str, Any]:
    """The arrays of a spacecraft chunk whose computation raised: NaN rows, CHUNK_FAILED."""
    return _failed(craft_arrays(members, c, t.shape[0], np.nan), t, exc)


# ------------------------------------------------------------------------------------------------
# one chunk of spacecraft in compiled code
# ------------------------------------------------------------------------------------------------


def _state_arrays(method: str, c: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each member's integrator state (the single run's arrays, one row per member)."""
    if method == "taylor":
        nw = n - 8
        return (
            np.zeros((c, _kt.WORK_ROWS, _ktg.work_columns(nw))),
            np.zeros((c, _ktg.TS.SIZE + nw)),
            np.zeros((c, 5), dtype=np.int64),
        )
    return np.zeros((c, _rk.WORK_ROWS, n)), np.zeros((c, 4)), np.zeros((c, 5), dtype=np.int64)


def _grow_records(src: tuple, waiting: np.ndarray) -> tuple:
    """The flight software's source with twice the tick-record rows (members paused at full
    records go on with the next call)."""
    rec = src[6]
    more = np.full((rec.shape[0], rec.shape[1], rec.shape[2]), np.nan)
    return (*src[:6], np.ascontiguousarray(np.concatenate([rec, more], axis=1)), src[7])


def _diagnostics(blk, t, y_out, n_done, entry, n_terms):
    """Each member's diagnostics by the single run's own (:func:`attitude._holds.diagnostics`
    with the member's block and parameters), NaN after its last sample."""
    from types import SimpleNamespace

    from .. import _holds

    c, m = y_out.shape[:2]
    diag = np.full((c, m, 13), np.nan)
    torques = np.full((c, m, n_terms + 1, 3), np.nan)
    act = np.full((c, m, 4, 3), np.nan)
    wheels = np.full((c, m, len(blk["runs"][0].spacecraft.wheels), 2), np.nan)
    for r, run in enumerate(blk["runs"]):
        k = int(n_done[r])
        if not k:
            continue
        problem = SimpleNamespace(
            spacecraft=run, params=blk["params"][r], potential=blk["potential"], entry=entry
        )
        d = _holds.diagnostics(problem, t[:k], y_out[r, :k])
        diag[r, :k] = d["diag"]
        torques[r, :k] = d["torques"]
        act[r, :k] = d["actuators"]
        wheels[r, :k] = d["wheels"]
    return diag, torques, act, wheels


def _member_events(blk: dict[str, Any], sc: np.ndarray, n: int, events: Any) -> tuple:
    """The chunk's event arrays (:func:`attitude._core.spacecraft_events.member_events`): each
    member its own copy of the event data (none: an empty set), its copies of a carried orbit
    made live orbits its state writes (listed in its block ``sc``)."""
    c = blk["y0"].shape[0]
    if events is None:
        from .._core.spacecraft_events import no_events

        evd = np.ascontiguousarray(np.tile(no_events(), (c, 1)))
        n_ev = 0
    else:
        evd = np.ascontiguousarray(np.tile(events.data, (c, 1)))
        n_ev = events.n
        for r, run in enumerate(blk["runs"]):
            if run.coupled:
                from .._coupling import attach_events, orbit_tokens

                member_sc = sc[blk["sc_at"][r] : blk["sc_at"][r + 1]]
                tokens = orbit_tokens(run.spacecraft, blk["potential"])
                attach_events(evd[r], member_sc, run.spacecraft, tokens)
    width = max(n, n_ev, 6)
    return (
        evd, np.zeros((c, n_ev, _kev.EVS.SIZE)), np.zeros((c, 2), dtype=np.int64),
        np.empty(0), np.empty((0, 2), dtype=np.int64), np.empty((0, n)), np.empty((c, 7, width)),
    )  # fmt: skip


def _run_craft_members(kernel, arrays, n_threads, rtol, atol, max_step, max_steps, budget):
    """Each member of a DOP853 chunk for at most ``budget`` steps through ``kernel``, the single
    run's compiled hold driver (``propagate``'s own machine code: a member is its single run bit
    for bit, and an ensemble after a single run compiles nothing), on ``n_threads`` threads
    (the driver releases the GIL).

    Member i's arguments are cut out of the chunk's arrays as
    :mod:`attitude._core.spacecraft_ensemble` lays them out. Its start and end are the
    bookkeeping of :func:`attitude._core.ensemble.member_begin` and
    :func:`attitude._core.spacecraft_ensemble.member_stop`, here in Python: a compiled wrapper
    calling the driver would compile a second copy of it."""
    blk, sc, src, evsrc, t, y_out, work, tstate, counters, status, n_done = arrays
    params, sc_at, y0 = blk["params"], blk["sc_at"], blk["y0"]
    t0, t_end = t[0], t[t.shape[0] - 1]
    evd, evs, ev_count, rec_t, rec_k, rec_y, scr = evsrc

    def rows(i):
        """Member i's arguments: copies of the small arrays the driver writes (the rows of
        neighbouring members share cache lines, and two threads writing them slow each other
        down), views of the large ones; and the arrays the copies go back to."""
        if len(src) == 8:  # the flight software's
            hs, fw, fw_at, fs, fs_at, cmd, rec, rc = src
            held = (hs[i], fs[fs_at[i] : fs_at[i + 1]], cmd[i], rc[i])
        else:
            hs, hold_t, hold_u, hold_at, zero = src
            held = (hs[i],)
        own = (sc[sc_at[i] : sc_at[i + 1]], tstate[i], counters[i], evd[i], evs[i],
               ev_count[i], *held)  # fmt: skip
        copies = tuple(a.copy() for a in own)
        sc_i, ts, cn, evd_i, evs_i, evc = copies[:6]
        if len(src) == 8:
            hs_i, fs_i, cmd_i, rc_i = copies[6:]
            ctl = (hs_i, fw[fw_at[i, 0] : fw_at[i, 1]], fs_i, cmd_i, rec[i], rc_i)
        else:
            a, b = hold_at[i], hold_at[i + 1]
            ctl = (copies[6], hold_t[a:b], hold_u[a:b], zero)
        ev = (evd_i, evs_i, evc, rec_t, rec_k, rec_y, scr[i])
        return own, copies, (params[i], sc_i), ts, cn, ctl, ev

    def member(i):
        st0 = status[i]
        if st0 not in (_ke.RUNNING, _ke.NOT_STARTED, _kse.RECORDS_WAIT):
            return
        k0 = 0
        if st0 == _ke.NOT_STARTED:
            work[i] = 0.0
            tstate[i] = 0.0
            counters[i] = 0
        else:
            k0 = int(n_done[i])
        own, copies, P, ts, cn, ctl, ev = rows(i)
        limit = max_steps
        if budget > 0 and cn[0] + budget < max_steps:
            limit = int(cn[0] + budget)
        st, k = kernel(P, y0[i], t0, t[k0:], y_out[i, k0:], work[i], ts, cn, rtol, atol, t_end,
                       max_step, limit, ctl, ev)  # fmt: skip
        for a, b in zip(own, copies, strict=True):
            a[...] = b
        k += k0
        n_done[i] = k
        if st == _rk.TOO_MANY_STEPS and limit < max_steps:
            status[i] = _ke.RUNNING
        elif st == _kh.RECORDS_FULL:
            status[i] = _kse.RECORDS_WAIT
        else:
            status[i] = st
            y_out[i, k:] = np.nan

    on_threads(n_threads, y0.shape[0], member, PARALLEL_CHUNK,
                more=lambda i: status[i] == _ke.RUNNING)  # fmt: skip


def compute_craft_chunk(
    blk: dict[str, Any],
    t: np.ndarray,
    entry: Any,
    method: str,
    fsw: bool,
    rtol: float,
    atol: float,
    max_step: float,
    max_steps: int,
    threads: int | None,
    n_terms: int,
    events: Any = None,
) -> dict[str, Any]:
    """Integrate the members of a chunk (:meth:`CraftMembers.block` arrays) through ``t`` and
    compute their diagnostics; the chunk's results.

    Every member is run to its end, failed or not (``status``, ``n_done`` say how it ended; a
    failed member's rows after its last sample are NaN)."""
    c, n = blk["y0"].shape
    m = t.shape[0]
    n_rec = blk["runs"][0].n_rec
    y_out = np.full((c, m, n + n_rec), np.nan)
    work, tstate, counters = _state_arrays(method, c, n)
    status = np.full(c, _ke.NOT_STARTED, dtype=np.int64)
    n_done = np.zeros(c, dtype=np.int64)
    sc = blk["sc0"].copy()
    src = blk["src"]
    evsrc = None
    n_threads = thread_count(threads)
    budget = max(MIN_MEMBER_BUDGET, ENSEMBLE_STEP_BUDGET * n_threads // max(1, c))
    if method == "taylor":
        from .._core import gyrostat_batch as _kgb

        fn = _kgb.fsw_group_run if fsw else _kgb.schedule_group_run
        n_groups = max(1, min(4 * n_threads, c // TAYLOR_MIN_GROUP))
        group = -(-c // n_groups)
        n_groups = -(-c // group)
        spaces = _kgb.new_workspaces(n_groups, n - 8)
    else:
        kernel = entry.dop853_spacecraft_fsw if fsw else entry.dop853_spacecraft
        evsrc = _member_events(blk, sc, n, events)
    while True:
        if method == "taylor":
            args = (blk["params"], sc, blk["sc_at"], blk["y0"], t, y_out, work, tstate,
                    counters, src, status, n_done, rtol, atol, max_step, max_steps, budget,
                    group, *spaces)  # fmt: skip
            on_threads(n_threads, n_groups, lambda g, a=args: fn(*a, g),
                        more=lambda g: bool(np.any(status[g * group : (g + 1) * group]
                                                   == _ke.RUNNING)))  # fmt: skip
        else:
            arrays = (blk, sc, src, evsrc, t, y_out, work, tstate, counters, status, n_done)
            _run_craft_members(kernel, arrays, n_threads, rtol, atol, max_step, max_steps,
                               budget)  # fmt: skip
        _interrupt.check()
        waiting = status == _kse.RECORDS_WAIT
        if waiting.any():
            src = _grow_records(src, waiting)
            continue
        if not np.any(status == _ke.RUNNING):
            break
    diag, torques, act, wheels = _diagnostics(blk, t, y_out, n_done, entry, n_terms)
    out = {
        "rows": y_out,
        "diag": diag,
        "torques": torques,
        "actuators": act,
        "wheels": wheels,
        "counters": counters,
        "status": status,
        "n_done": n_done,
        "t_stop": tstate[:, 0].copy(),
    }
    if events is not None:
        out["event_count"] = evsrc[1][:, :, _kev.EVS.COUNT].astype(np.int64)
        out["event_first"] = evsrc[1][:, :, _kev.EVS.FIRST].copy()
    if fsw:
        fs, fs_at = src[3], src[4]
        out["records"] = src[6]
        out["n_records"] = src[7][:, 0].copy()
        out["n_ticks"] = fs[fs_at[:-1] + _kf.FS.TICK].astype(np.int64)
    return out

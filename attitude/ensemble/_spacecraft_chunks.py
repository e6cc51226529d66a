"""One chunk of spacecraft members in compiled code: integration, then diagnostics."""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _interrupt
from .._core import ensemble as _ke
from .._core import fsw as _kf
from .._core import rk as _rk
from .._core import spacecraft_ensemble as _kse
from .._core import taylor as _kt
from .._core import taylor_gyrostat as _ktg
from ._chunks import ENSEMBLE_STEP_BUDGET, MIN_MEMBER_BUDGET, TAYLOR_MIN_GROUP, _numba_threads

__all__ = ["compute_chunk"]


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
    n = blk["y0"].shape[1]
    diag = np.full((c, m, 13), np.nan)
    torques = np.full((c, m, n_terms + 1, 3), np.nan)
    act = np.full((c, m, 4, 3), np.nan)
    wheels = np.full((c, m, n - 8, 2), np.nan)
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


def compute_chunk(
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
) -> dict[str, Any]:
    """Integrate the members of a chunk (:meth:`CraftMembers.block` arrays) through ``t`` and
    compute their diagnostics; the chunk's results.

    Every member is run to its end, failed or not (``status``, ``n_done`` say how it ended; a
    failed member's rows after its last sample are NaN)."""
    from orbit._shared_jit import JIT_DISABLED

    c, n = blk["y0"].shape
    m = t.shape[0]
    n_rec = blk["runs"][0].n_rec
    y_out = np.full((c, m, n + n_rec), np.nan)
    work, tstate, counters = _state_arrays(method, c, n)
    status = np.full(c, _ke.NOT_STARTED, dtype=np.int64)
    n_done = np.zeros(c, dtype=np.int64)
    sc = blk["sc0"].copy()
    src = blk["src"]
    with _numba_threads(threads):
        n_threads = 1
        if not JIT_DISABLED:
            import numba

            n_threads = numba.get_num_threads()
        budget = max(MIN_MEMBER_BUDGET, ENSEMBLE_STEP_BUDGET * n_threads // max(1, c))
        if method == "taylor":
            from .._core import gyrostat_batch as _kgb

            fn = _kgb.fsw_parallel if fsw else _kgb.schedule_parallel
            n_groups = max(1, min(4 * n_threads, c // TAYLOR_MIN_GROUP))
            group = -(-c // n_groups)
            extra: tuple = (group, *_kgb.new_workspaces(-(-c // group), n - 8))
            if not JIT_DISABLED:
                numba.set_parallel_chunksize(1)  # a group at a time (few and long)
        else:
            fn = entry.spacecraft_fsw_parallel if fsw else entry.spacecraft_schedule_parallel
            extra = ()
        while True:
            fn(
                blk["params"], sc, blk["sc_at"], blk["y0"], t, y_out, work, tstate, counters,
                src, status, n_done, rtol, atol, max_step, max_steps, budget, *extra,
            )  # fmt: skip
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
    if fsw:
        fs, fs_at = src[3], src[4]
        out["records"] = src[6]
        out["n_records"] = src[7][:, 0].copy()
        out["n_ticks"] = fs[fs_at[:-1] + _kf.FS.TICK].astype(np.int64)
    return out

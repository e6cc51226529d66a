"""``propagate_ensemble`` of spacecraft with actuators or flight software: validate, build, run,
assemble.

Called by :func:`attitude.ensemble.propagate_ensemble` when the members have actuators, an
open-loop schedule or flight software (docs/ensemble.md, "Spacecraft with actuators and flight
software"). Every member is the single run ``propagate(spacecraft_i, q0_i, Q0_i, t, potential,
commands=commands_i, software=software_i)`` (its sensors reseeded from the ensemble seed), bit
for bit, computed by the single run's compiled drivers in a parallel loop over members
(:mod:`attitude._core.spacecraft_ensemble`), or for ``method="taylor"`` in SIMD batches
(:mod:`attitude._core.gyrostat_batch`).
"""

from __future__ import annotations

import math
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._core.rk import EVENT, SUCCESS
from ..errors import AttitudeTypeError, AttitudeValueError, PropagationError
from ..io import COMPLEVEL, _MemberWriter
from . import _plan
from ._chunks import CHUNK_FAILED, _Failures
from ._members import _member_states, _project
from ._output import _concat, _open_result
from ._spacecraft_chunks import compute_chunk
from ._spacecraft_members import CraftMembers, _one_or_list, as_crafts
from ._spacecraft_output import chunk_dataset, member_invariant_attrs

__all__ = ["propagate_spacecraft"]

#: Members per chunk by default: at most this many (the tick records and the per-member
#: diagnostics of a chunk are in memory), about 20 chunks for progress.
MAX_CHUNK = 1024

#: Arguments of propagate_ensemble the spacecraft ensembles do not take (yet), and why.
_NOT_FOR_SPACECRAFT = {
    "client": "Dask clusters run rigid-body ensembles only; run it locally (client=None)",
    "lazy": "a lazy Dask result is for rigid-body ensembles; run it eagerly (lazy=False)",
    "events": "events are not located for a spacecraft with actuators (as in propagate)",
    "nominal": "the pointing error of a spacecraft ensemble is the flight software's "
    "(error_angle per tick, from its guidance); attitude.ensemble.error_angle_percentiles",
    "reference": "the pointing error of a spacecraft ensemble is the flight software's "
    "(error_angle per tick); attitude.ensemble.error_angle_percentiles",
    "boresight": "only with output='statistics' of rigid-body ensembles",
}


def _check_seed(seed: Any) -> int | None:
    if seed is None:
        return None
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise AttitudeTypeError(
            f"seed: expected a non-negative integer (the ensemble's sensor seed), got {seed!r}"
        )
    if not 0 <= int(seed) < 2**63:
        raise AttitudeValueError(f"seed: expected an integer in [0, 2**63), got {seed!r}")
    return int(seed)


def propagate_spacecraft(
    body: Any,
    q0: Any,
    Q0: Any,
    tt: np.ndarray,
    potential: Any,
    plan: Any,
    *,
    method: str,
    rtol: float,
    atol: float,
    max_step: float,
    max_steps: int,
    chunk_size: int | None,
    path: Any,
    threads: int | None,
    progress: Any,
    attrs: dict | None,
    epoch: Any,
    on_estimate: Any,
    commands: Any,
    software: Any,
    seed: Any,
    refused: dict[str, Any],
    t_start: float,
    member_vars: Any = None,
) -> xr.Dataset:
    """The spacecraft ensemble of :func:`attitude.ensemble.propagate_ensemble` (its arguments,
    validated there except those of spacecraft)."""
    requested = method
    members, pot, run_attrs = _validate(
        body, q0, Q0, tt, potential, plan, method, epoch, commands, software, seed, refused
    )
    members.extra_vars = member_vars  # (start, stop) -> more per-member variables, or None
    method = members.method  # "auto" resolved as the single runs resolve it
    n = members.n
    threads_n = _threads(threads)
    csize = chunk_size or max(1, min(MAX_CHUNK, max(-(-n // 20), 16 * threads_n)))
    csize = min(csize, n)
    run_attrs.update(
        {
            "title": "attitude ensemble propagation",
            "method": method,
            **({"method_requested": requested} if requested != method else {}),
            "formulation": "canonical",
            "rtol": rtol,
            "atol": atol,
            "ensemble_size": np.int64(n),
            "chunk_size": np.int64(csize),
            "execution": f"local threads ({threads_n})",
        }
    )
    if not math.isinf(max_step):
        run_attrs["max_step"] = float(max_step)
    if method == "taylor":
        from .._core.taylor import order_from_tolerance

        run_attrs["taylor_order"] = np.int64(order_from_tolerance(rtol))
    run_attrs.update(plan.attrs())
    if attrs:
        run_attrs.update(attrs)
    out_path = None if path is None else Path(path)
    t_kernel = plan.kernel_t
    fsw = members.program is not None
    entry = pot._entry_points(closed_loop=fsw)
    n_terms = len(pot.terms)

    def chunk(start: int, stop: int) -> tuple[dict, dict]:
        blk = members.block(start, stop)
        out = compute_chunk(blk, t_kernel, entry, method, fsw, rtol, atol, max_step,
                            max_steps, threads, n_terms)  # fmt: skip
        return blk, out

    # the size: one member's Dataset (with zero samples' values), before any work
    one = _one_member(members, t_kernel, plan, run_attrs, fsw, n_terms)
    expected = _plan.estimate_bytes(one, n)
    sw = members.member(0)[2]
    every = None if sw is None else sw.record_every
    _plan.check_size(expected, plan, n, out_path is None, one, True, every)
    if out_path is not None:
        from .._files import OutputFile

        OutputFile(path, "path").check_space(float(expected), f"{n} members")
    run_attrs["expected_output_size"] = np.int64(expected)
    if on_estimate is not None:
        on_estimate(expected)
    return _run(members, chunk, plan, run_attrs, csize, out_path, progress, t_start)


def _threads(threads: int | None) -> int:
    from orbit._shared_jit import JIT_DISABLED

    if threads is not None:
        return int(threads)
    if JIT_DISABLED:
        return 1
    import numba

    return numba.get_num_threads()


def _choose(method: str, crafts: Any, pot: Any) -> str:
    """The method of every member: ``"auto"`` is ``"taylor"`` when every member's single run
    would pick it (:func:`attitude.propagate.choose_method` with its spacecraft), else
    ``"dop853"`` for all (one method runs the whole ensemble)."""
    from ..propagate import AUTO, choose_method

    if method != AUTO:
        return method
    for craft in crafts if isinstance(crafts, list) else [crafts]:
        if choose_method(AUTO, pot, spacecraft=craft) != "taylor":
            return "dop853"
    return "taylor"


def _validate(body, q0, Q0, tt, potential, plan, method, epoch, commands, software, seed,
              refused):  # fmt: skip
    """(CraftMembers, prepared potential, attrs): every input checked before any work."""
    from ..actuators.commands import CommandSchedule
    from ..potentials import Potential, as_potential
    from ..propagate import _epoch_attrs
    from ..software import FlightSoftware

    for name, value in refused.items():
        if value is not None and value is not False:
            raise AttitudeValueError(f"{name}: {_NOT_FOR_SPACECRAFT[name]}")
    if plan.output == "statistics":
        raise AttitudeValueError(
            "output: a spacecraft ensemble stores its members ('samples' or 'final'); take "
            "statistics afterwards (attitude.ensemble.error_angle_percentiles, settling_times)"
        )
    if tt.shape[0] > 1 and tt[-1] < tt[0]:
        raise AttitudeValueError(
            "t: a spacecraft with actuators is propagated forward in time (its commands are "
            "held from one time to the next); give increasing times"
        )
    seed = _check_seed(seed)
    crafts = as_crafts(body, software)
    units = crafts[0].units if isinstance(crafts, list) else crafts.units
    q, Q, n = _member_states(q0, Q0, units)
    if isinstance(crafts, list) and len(crafts) != n:
        raise AttitudeValueError(
            f"bodies_or_body: {len(crafts)} spacecraft for {n} members (the rows of q0/Q0); "
            "give one per member, or a single one for all"
        )
    cmds = _one_or_list(commands, n, "commands", CommandSchedule, "an attitude.CommandSchedule")
    sws = _one_or_list(software, n, "software", FlightSoftware, "an attitude.FlightSoftware")
    if cmds is not None and sws is not None:
        raise AttitudeValueError(
            "commands: the flight software commands the actuators; give commands= (open loop) "
            "or software= (closed loop), not both"
        )
    if isinstance(potential, (list, tuple)):
        raise AttitudeValueError(
            "potential: a spacecraft ensemble runs one potential for all members (its "
            "environment tables are shared); disperse the spacecraft and software instead"
        )
    if potential is not None and not isinstance(potential, Potential):
        raise AttitudeTypeError(
            f"potential: expected an attitude.potentials.Potential, got {type(potential).__name__}"
        )
    for start in range(0, n, 65536):  # every state checked (the exact projection per chunk)
        stop = min(n, start + 65536)
        rows = lambda a, s=start, e=stop: a[s:e] if a.ndim == 2 else a[None, :]  # noqa: E731
        _project(rows(q), rows(Q), start)
    first = crafts[0] if isinstance(crafts, list) else crafts
    pot = as_potential(potential).bind(first.body)
    method = _choose(method, crafts, pot)
    span = np.array([tt[0], tt[-1]], dtype=np.float64)
    run_attrs = _epoch_attrs(pot, epoch)
    try:
        pot.check_times(span, "t")
    except ValueError as exc:
        raise AttitudeValueError(str(exc)) from None
    pot = pot.prepare(span)
    if pot._user_terms() and method == "taylor":
        from ..taylor import check_potential

        check_potential(pot)
    members = CraftMembers(
        crafts, q, Q, n, cmds, sws, seed, span, pot, method, samples=plan.stored_t
    )
    c0, _, s0 = members.member(0)
    run_attrs["spacecraft"] = (
        c0.describe()
        if not isinstance(crafts, list)
        else f"{n} per-member spacecraft, member 0: {c0.describe()}"
    )
    if s0 is not None:
        run_attrs["software"] = (
            s0.describe()
            if not isinstance(sws, list)
            else f"{n} per-member flight software, member 0: {s0.describe()}"
        )
    if members.sensor_kinds:
        run_attrs["ensemble_seed"] = np.int64(members.seed)
        run_attrs["sensor_seeding"] = (
            "member i's sensors: SeedSequence(ensemble_seed).spawn(N)[i].generate_state("
            "n_sensors, uint64) >> 1, in the order of sensor_label (variable sensor_seed)"
        )
    elif seed is not None:
        run_attrs["ensemble_seed"] = np.int64(seed)
    return members, pot, run_attrs


def _one_member(members, t, plan, attrs, fsw, n_terms) -> xr.Dataset:
    """A one-member Dataset of the run's schema (zeros): for the size estimate."""
    blk = {k: v for k, v in members.block(0, 1).items()}
    m = t.shape[0]
    n = members.n_state
    out = {
        "rows": np.zeros((1, m, n + members.n_rec)),
        "diag": np.zeros((1, m, 13)),
        "torques": np.zeros((1, m, n_terms + 1, 3)),
        "actuators": np.zeros((1, m, 4, 3)),
        "wheels": np.zeros((1, m, n - 8, 2)),
        "counters": np.zeros((1, 5), dtype=np.int64),
        "status": np.zeros(1, dtype=np.int64),
        "n_done": np.full(1, m, dtype=np.int64),
        "t_stop": np.zeros(1),
    }
    if fsw:
        k = members.tick_times().shape[0]
        out["records"] = np.zeros((1, k + 1, members.program.rec_width))
        out["n_records"] = np.full(1, k, dtype=np.int64)
        out["n_ticks"] = np.full(1, k, dtype=np.int64)
    return chunk_dataset(members, 0, blk, out, plan.stored_t, plan.keep, attrs)


def _run(members, chunk, plan, attrs, csize, out_path, progress, t_start) -> xr.Dataset:
    """The chunks one after the other (in memory, or streamed to ``out_path``); failures
    named, the members done kept."""
    n = members.n
    bounds = [(s, min(n, s + csize)) for s in range(0, n, csize)]
    writer = _MemberWriter(out_path, complevel=COMPLEVEL) if out_path is not None else None
    kept: list[xr.Dataset] = []
    failures = _Failures(plan.stored_t.shape[0])
    totals = {"n_steps": 0, "n_rhs": 0, "n_rejected": 0}
    max_projection = 0.0
    invariants: dict[str, float] = {}  # maxima over members (scenario.InvariantTracker's)
    pot_name = members.potential.name
    counts = members.structure.counts
    try:
        for start, stop in bounds:
            try:
                blk, out = chunk(start, stop)
            except (AttitudeValueError, AttitudeTypeError, KeyboardInterrupt):
                raise
            except Exception as exc:  # the chunk as a whole: its members marked, the rest go on
                blk, out = _failed_chunk(members, start, stop, plan, exc)
            failures.add(out, start)
            max_projection = max(max_projection, float(blk["projection"]))
            cnt = out["counters"]
            totals["n_steps"] += int(cnt[:, 0].sum())
            if members.method != "taylor":
                totals["n_rhs"] += int(cnt[:, 1].sum())
                totals["n_rejected"] += int(cnt[:, 2].sum())
            ds = chunk_dataset(members, start, blk, out, plan.stored_t, plan.keep, attrs)
            ok = np.isin(out["status"], (SUCCESS, EVENT))
            for k, v in member_invariant_attrs(ds, ok, pot_name, counts).items():
                invariants[k] = max(invariants.get(k, 0.0), v)
            if writer is not None:
                writer.append(ds)
            else:
                kept.append(ds)
            if progress is not None:
                progress(stop, n, totals["n_steps"])
        failure = None
        if failures.count:
            failure = PropagationError(failures.message(n), time=failures.first[1])
        final = dict(attrs)
        final.update({k: np.int64(v) for k, v in totals.items()})
        final.update(invariants)
        final["initial_projection"] = float(max_projection)
        final["n_members_written"] = np.int64(n)
        final["n_members_failed"] = np.int64(failures.count)
        final["run_status"] = "complete" if failure is None else f"failed: {failure}"
        final["wall_time"] = time.perf_counter() - t_start
        if writer is not None:
            writer.attrs = final
            writer.commit()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    if max_projection > 1e-12:
        warnings.warn(
            f"initial states projected onto |q| = 1, q·Q = 0 (largest correction "
            f"{max_projection:.2g})",
            stacklevel=3,
        )
    if writer is not None:
        result = _open_result(out_path, len(bounds) and bounds[0][1] - bounds[0][0], False)
    else:
        result = _concat(kept, final)
    if failure is not None:
        ok = n - failures.count
        where = f"in {out_path}" if writer is not None else "in .partial"
        raise PropagationError(
            f"{failure}; the {ok} other members are complete ({where}; member_status marks the "
            "failed ones, their samples after the failure are NaN)",
            time=failure.time,
            partial=result,
        )
    return result


def _failed_chunk(members, start, stop, plan, exc) -> tuple[dict, dict]:
    """The arrays of a chunk whose computation raised: NaN rows, status CHUNK_FAILED."""
    blk = members.block(start, stop)
    c = stop - start
    m = plan.kernel_t.shape[0]
    n = members.n_state
    pot = members.potential
    out = {
        "rows": np.full((c, m, n + members.n_rec), np.nan),
        "diag": np.full((c, m, 13), np.nan),
        "torques": np.full((c, m, len(pot.terms) + 1, 3), np.nan),
        "actuators": np.full((c, m, 4, 3), np.nan),
        "wheels": np.full((c, m, n - 8, 2), np.nan),
        "counters": np.zeros((c, 5), dtype=np.int64),
        "status": np.full(c, CHUNK_FAILED, dtype=np.int64),
        "n_done": np.zeros(c, dtype=np.int64),
        "t_stop": np.full(c, float(plan.kernel_t[0])),
        "error": f"{type(exc).__name__}: {exc}",
    }
    if members.program is not None:
        k = members.tick_times().shape[0]
        out["records"] = np.full((c, k + 1, members.program.rec_width), np.nan)
        out["n_records"] = np.zeros(c, dtype=np.int64)
        out["n_ticks"] = np.zeros(c, dtype=np.int64)
    return blk, out

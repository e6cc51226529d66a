"""The ensemble runner: a validated :class:`~._spec.EnsembleSpec` computed chunk by chunk and
assembled into one Dataset (in memory, or streamed to netCDF).

Rigid bodies and spacecraft share the whole loop (:func:`_collect`: the chunks in member order,
their failures named, the totals, the output kept or written, the final attrs, the
PropagationError that keeps the members done); what differs, because the compiled drivers do,
is two small strategies: :func:`_bodies` (the rigid-body drivers of
:mod:`attitude._core.ensemble`, here or as Dask tasks, the statistics-only output, lazy
results) and :func:`_crafts` (the single run's spacecraft drivers, a member a call, on
threads).
"""

from __future__ import annotations

import contextlib
import math
import time
import warnings
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import xarray as xr

from .._run.spec import PROJECTION_WARN
from ..errors import AttitudeTypeError, PropagationError
from ..io import COMPLEVEL, _MemberWriter
from . import _chunks, _dask, _plan, _threads
from ._output import _Assembler, _concat, _CraftAssembler, _Direct, _open_result
from ._percentile_store import _PercentileStore
from ._spec import EnsembleSpec

__all__ = ["run"]

#: Output bytes per chunk the default chunk size aims at (states + diagnostics, float64).
CHUNK_BYTES = 32 * 2**20
#: Largest default chunk (members).
MAX_CHUNK = 4096
#: Largest default chunk of spacecraft members (the tick records and the per-member
#: diagnostics of a chunk are in memory).
MAX_CRAFT_CHUNK = 1024
#: Fewest members per thread in a default chunk, per method: a Taylor member takes a tenth of
#: a DOP853 member's time, and runs in SIMD batches of 4 that refill from a group of members.
MIN_PER_THREAD = {"dop853": 16, "taylor": 256}


def run(spec: EnsembleSpec) -> xr.Dataset:
    """The ensemble's Dataset (raises PropagationError naming the failed members; ``partial``:
    the members done)."""
    return _crafts(spec) if spec.spacecraft else _bodies(spec)


def _default_chunk(n: int, m: int, threads: int, method: str = "dop853") -> int:
    """Members per chunk: about 20 chunks (progress), at least :data:`MIN_PER_THREAD` per
    thread (balance, and the cost of a chunk), at most :data:`MAX_CHUNK` and
    ~:data:`CHUNK_BYTES` of output (memory)."""
    per_member = m * (8 + _chunks._N_DIAG) * 8
    cap = min(MAX_CHUNK, max(1, CHUNK_BYTES // per_member))
    want = max(-(-n // 20), MIN_PER_THREAD[method] * threads)
    return max(1, min(want, max(cap, threads)))


def _run_attrs(spec: EnsembleSpec, csize: int, execution: str) -> dict[str, Any]:
    """The global attrs every ensemble records: the run's, the method, tolerances, sizes."""
    a: dict[str, Any] = {
        **spec.run_attrs,
        "title": "attitude ensemble propagation",
        "method": spec.method,
        **({"method_requested": spec.requested} if spec.requested != spec.method else {}),
        "formulation": "canonical",
        "rtol": spec.rtol,
        "atol": spec.atol,
        "ensemble_size": np.int64(spec.members.n),
        "chunk_size": np.int64(csize),
        "execution": execution,
    }
    if spec.method == "taylor":
        from .._core.taylor import order_from_tolerance

        a["taylor_order"] = np.int64(order_from_tolerance(spec.rtol))
    if not math.isinf(spec.max_step):
        a["max_step"] = float(spec.max_step)
    return a


def _bounds(n: int, csize: int) -> list[tuple[int, int]]:
    return [(s, min(n, s + csize)) for s in range(0, n, csize)]


# ------------------------------------------------------------------------------------------------
# the two strategies
# ------------------------------------------------------------------------------------------------


def _crafts(spec: EnsembleSpec) -> xr.Dataset:
    """Spacecraft members: the single run's drivers, a member a call, on threads."""
    members, plan = spec.members, spec.plan
    n = members.n
    csize = spec.chunk_size or max(
        1, min(MAX_CRAFT_CHUNK, max(-(-n // 20), 16 * _threads.thread_count(spec.threads)))
    )
    csize = min(csize, n)
    attrs = _run_attrs(spec, csize, f"local threads ({_threads.thread_count(spec.threads)})")
    attrs.update(plan.attrs())
    if spec.attrs:
        attrs.update(spec.attrs)
    asm = _CraftAssembler(members, plan, attrs)
    t = plan.kernel_t
    # the size: one member's Dataset (with zero samples' values), before any work
    one = asm.dataset(0, _chunks.craft_arrays(members, 1, t.shape[0], 0.0), members.block(0, 1))
    expected = _plan.estimate_bytes(one, n)
    sw = members.member(0)[2]
    every = None if sw is None else sw.record_every
    _plan.check_size(expected, plan, n, spec.out_path is None, one, True, every)
    if spec.out_path is not None:
        from .._files import OutputFile

        OutputFile(spec.path, "path").check_space(float(expected), f"{n} members")
    attrs["expected_output_size"] = np.int64(expected)
    if spec.on_estimate is not None:
        spec.on_estimate(expected)
    bounds = _bounds(n, csize)
    # (the generic entry points read a coupled member's live orbit through the dispatcher)
    generic = members.program is not None or members.run(0).coupled
    entry = spec.potential._entry_points(closed_loop=generic)
    results = _chunks.craft_results(
        members, bounds, t, entry, spec.rtol, spec.atol, spec.max_step, spec.max_steps,
        spec.threads,
    )  # fmt: skip

    def failed(start: int, stop: int, exc: BaseException) -> tuple:
        blk = members.block(start, stop)
        out = _chunks.failed_craft_chunk(members, stop - start, t, exc)
        return out, blk, float(blk["projection"])

    return _collect(spec, asm, results, bounds, failed, plan.stored_t.shape[0])


def _bodies(spec: EnsembleSpec) -> xr.Dataset:
    """Rigid-body members: the compiled ensemble drivers, here or as Dask tasks."""
    members, plan, pot, n = spec.members, spec.plan, spec.potential, spec.members.n
    user = pot if pot._user_terms() else None
    client, owned = spec.client, False
    try:
        if client is not None:
            client, owned = _dask._connect(client, spec.timeout)
            if user is not None:
                _check_picklable(user)
            n_threads = _dask._worker_threads(client)
        else:
            n_threads = _threads.thread_count(spec.threads)
        m = plan.kernel_t.shape[0]
        csize = spec.chunk_size or _default_chunk(n, m, n_threads, spec.method)
        csize = min(csize, n)
        setup = _chunks._Setup(
            plan.kernel_t, spec.rtol, spec.atol, spec.max_step, spec.max_steps, user,
            spec.events, spec.method,
        )  # fmt: skip
        execution = "dask" if client is not None else f"local threads ({n_threads})"
        asm = _assembler(spec, csize, execution)
        store = _estimate(spec, asm, setup)
        bounds = _bounds(n, csize)
        if spec.lazy:
            asm.attrs["run_status"] = "lazy: computed on access; a failing member raises"
            ds = _dask._lazy_result(setup, members, bounds, asm)
            ds.attrs["initial_projection"] = float(asm.max_projection)
            if spec.out_path is None:
                return ds
            _dask._write_lazy(ds, spec.out_path, client)
            return _open_result(spec.out_path, csize, True)
        direct = None
        if spec.out_path is None and plan.output == "samples" and plan.keep is None:
            if client is None:  # in memory: the chunks write straight into the result's arrays
                direct = _Direct(n, m)
        if client is None:
            results = _chunks.local_results(setup, members, bounds, spec.threads, direct)
        else:
            results = _dask._dask_results(client, setup, members, bounds, n_threads)

        def failed(start: int, stop: int, exc: BaseException) -> tuple:
            # the chunk's task failed as a whole: its members are marked and NaN
            _, _, inertia, corr = members.block(start, stop)
            return _chunks._failed_chunk(setup, stop - start, exc), inertia, corr

        return _collect(spec, asm, results, bounds, failed, m, direct, store, client is not None)
    finally:
        if owned:
            with contextlib.suppress(Exception):
                client.close()


def _check_picklable(user: Any) -> None:
    import cloudpickle

    try:
        cloudpickle.dumps(user)
    except Exception as exc:
        raise AttitudeTypeError(
            f"potential: this {type(user).__name__} cannot be shipped to Dask workers "
            f"({type(exc).__name__}: {exc}); run it locally (client=None)"
        ) from None


def _assembler(spec: EnsembleSpec, csize: int, execution: str) -> _Assembler:
    """The rigid-body assembler with the run's attrs."""
    n, pot, pots, evset = spec.members.n, spec.potential, spec.potentials, spec.events
    attrs = _run_attrs(spec, csize, execution)
    if pots is not None:
        attrs["potential"] = f"{n} per-member potentials, member 0: {pot.describe()}"
    if evset is not None:
        attrs["events"] = evset.describe()
        if evset.epoch is not None:
            from orbit.timescales import format_epoch

            attrs["epoch"] = format_epoch(evset.epoch)
    attrs.update(spec.plan.attrs())
    if spec.attrs:
        attrs.update(spec.attrs)
    asm = _Assembler(spec.plan.stored_t, spec.unit, pot, pots, attrs, evset)
    if spec.members.shared_inertia is not None:
        asm.attrs["inertia"] = np.asarray(spec.members.shared_inertia, dtype=np.float64)
    asm.keep, asm.members = spec.plan.keep, spec.members
    asm.views = spec.plan.output == "statistics"
    return asm


def _estimate(spec: EnsembleSpec, asm: _Assembler, setup: Any) -> _PercentileStore | None:
    """The expected size, from one member's Dataset (whatever variables it has), refused
    above the limit before any work; then the pointing reference; the percentile store of a
    statistics-only output."""
    plan, members, n = spec.plan, spec.members, spec.members.n
    ms, m = plan.stored_t.shape[0], plan.kernel_t.shape[0]
    if spec.nominal is not None or spec.reference is not None:
        asm.reference = np.zeros((ms, 4))  # the size estimate's placeholder
    n_ev = 0 if spec.events is None else len(spec.events.labels)
    one = asm.dataset(0, _chunks.rigid_arrays(1, m, n_ev, 0.0), members.block(0, 1)[2])
    extra = None
    if plan.output == "statistics":
        probe = _PercentileStore(1, plan.stored_t, plan.percentiles, np.zeros((ms, 4)))
        try:
            one = probe.add(one)
            extra = probe.finish(one["time"].variable)
        finally:
            probe.close()
    expected = _plan.estimate_bytes(one, n, extra)
    _plan.check_size(expected, plan, n, spec.out_path is None, one)
    asm.attrs["expected_output_size"] = np.int64(expected)
    if spec.on_estimate is not None:
        spec.on_estimate(expected)
    if spec.nominal is not None:
        params = members.nominal_params(_nominal_inertia(spec.nominal, spec.unit))
        asm.reference = _plan.nominal_reference(setup, params, spec.nominal, plan)
        asm.attrs["pointing_reference"] = "nominal initial state, propagated once"
    elif spec.reference is not None:
        asm.reference = _plan.given_reference(spec.reference, plan)
        asm.attrs["pointing_reference"] = "given"
    if plan.output != "statistics" or spec.lazy:
        return None
    parent = None if spec.out_path is None else spec.out_path.parent
    return _PercentileStore(
        n, plan.stored_t, plan.percentiles, asm.reference, spec.boresight, parent
    )


def _nominal_inertia(nominal: Any, unit: str | None) -> np.ndarray | None:
    """The nominal body of ``nominal=(q0, Q0, body)`` (None for a pair), in the members'
    unit system."""
    from ..errors import AttitudeValueError
    from ._members import _member_inertia

    if not isinstance(nominal, (tuple, list)) or len(nominal) != 3:
        return None
    inertia, nominal_unit = _member_inertia(nominal[2], 1)
    if inertia.shape != (3,):
        raise AttitudeValueError(
            f"nominal: the nominal body is one body (3 principal moments), got shape "
            f"{inertia.shape}"
        )
    if nominal_unit != unit:
        raise AttitudeValueError(
            "nominal: the nominal body and the members' bodies are in different unit systems "
            f"({nominal_unit or 'dimensionless'} and {unit or 'dimensionless'}); give both as "
            "Quantities (or RigidBody with units), or both as plain numbers"
        )
    return inertia


# ------------------------------------------------------------------------------------------------
# the loop both share
# ------------------------------------------------------------------------------------------------


def _collect(spec: EnsembleSpec, asm: Any, results: Iterable, bounds: list[tuple[int, int]],
             failed: Callable[[int, int, BaseException], tuple], m: int,
             direct: _Direct | None = None, store: _PercentileStore | None = None,
             dask: bool = False) -> xr.Dataset:  # fmt: skip
    """The chunks in member order (in memory, or streamed to ``spec.out_path``); failed
    members named, the members done kept (``partial`` of the PropagationError)."""
    n, out_path, progress = spec.members.n, spec.out_path, spec.progress
    writer = _MemberWriter(out_path, complevel=COMPLEVEL) if out_path is not None else None
    kept: list[xr.Dataset] = []
    failures = _chunks._Failures(m)
    stats = None
    try:
        for (start, stop), got in zip(bounds, results, strict=False):
            out, info, corr = failed(start, stop, got) if isinstance(got, BaseException) else got
            failures.add(out, start)
            asm.max_projection = max(asm.max_projection, corr)
            if direct is not None:  # (split into the result's arrays; the Dataset at the end)
                asm.account(out)
                direct.add(out, info)
            else:
                ds = asm.dataset(start, out, info)
                asm.account(out, ds)
                if store is not None:  # statistics only: keep the scalars, drop the members
                    ds = store.add(ds)
                (writer.append if writer is not None else kept.append)(ds)
            if progress is not None:
                progress(stop, n, asm.totals["n_steps"])
        if direct is not None and direct.n:
            kept.append(direct.dataset(asm))
        failure: PropagationError | None = None
        if failures.count:
            failure = PropagationError(failures.message(n), time=failures.first[1])
        final = asm.final_attrs("complete" if failure is None else f"failed: {failure}")
        final["n_members_failed"] = np.int64(failures.count)
        if store is not None and asm.n_members:
            stats = store.finish(asm.template["time"].variable)
            final.update(store.attrs())
        final["wall_time"] = time.perf_counter() - spec.t_start
        if writer is not None:
            if writer.n:
                if stats is not None:
                    writer.add_variables(stats)
                writer.attrs = final
                writer.commit()
            else:
                writer.abort()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    finally:
        if store is not None:
            store.close()
    if asm.max_projection > PROJECTION_WARN:
        warnings.warn(
            f"initial states projected onto |q| = 1, q·Q = 0 (largest correction "
            f"{asm.max_projection:.2g})",
            stacklevel=5,  # (_collect, the strategy, run, propagate_ensemble, its caller)
        )
    if writer is not None:
        csize = bounds[0][1] - bounds[0][0]
        result = _open_result(out_path, csize, dask) if writer.n else None
    else:
        result = _concat(kept, final) if kept else None
        if result is not None and stats is not None:
            result = result.assign_coords(percentile=stats["percentile"]).assign(
                {k: v.variable for k, v in stats.data_vars.items()}
            )
    if failure is not None:
        ok = asm.n_members - failures.count
        where = (
            f"; the {ok} other members are complete; all {asm.n_members} are in {out_path} "
            "(member_status marks the failed ones, their samples after the failure are NaN)"
            if writer is not None and writer.n
            else f"; the {ok} other members are complete (in .partial; member_status marks "
            "the failed ones)"
        )
        raise PropagationError(f"{failure}{where}", time=failure.time, partial=result)
    return result

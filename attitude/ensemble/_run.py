"""``propagate_ensemble`` and ``run_scenario``: the ensemble entry points."""

from __future__ import annotations

import contextlib
import math
import os
import time
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import xarray as xr

from .._validation import as_atol, as_float_array, as_int, as_positive, as_rtol, as_times
from ..body import RigidBody
from ..errors import AttitudeFileError, AttitudeTypeError, AttitudeValueError, PropagationError
from ..io import COMPLEVEL, _MemberWriter, check_attrs
from ..potentials import Potential
from ..propagate import AUTO, PROJECTION_WARN, _check_max_step
from . import _dask, _plan
from ._chunks import (
    _N_DIAG,
    _compute_chunk,
    _failed_chunk,
    _Failures,
    _numba_threads,
    _Setup,
)
from ._dask import (
    _connect,
    _dask_results,
    _lazy_result,
    _worker_threads,
    _write_lazy,
)
from ._members import (
    _body_units,
    _ensemble_method,
    _member_inertia,
    _member_potentials,
    _member_states,
    _Members,
    _project,
)
from ._output import _Assembler, _concat, _Direct, _open_result
from ._percentile_store import _PercentileStore
from ._spacecraft_members import is_spacecraft_ensemble
from ._spacecraft_run import propagate_spacecraft
from .dispersions import _Sampled

#: Output bytes per chunk the default chunk size aims at (states + diagnostics, float64).
CHUNK_BYTES = 32 * 2**20
#: Largest default chunk (members).
MAX_CHUNK = 4096
#: The methods of the compiled ensemble loops.
ENSEMBLE_METHODS = ("dop853", "taylor")

# ------------------------------------------------------------------------------------------------
# the entry point
# ------------------------------------------------------------------------------------------------


def _positive(x: Any, name: str) -> float:
    return as_positive(x, name)


def _max_threads() -> int:
    """The most threads numba can run (NUMBA_NUM_THREADS, fixed when numba starts)."""
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


#: Fewest members per thread in a default chunk, per method: a Taylor member takes a tenth of
#: a DOP853 member's time, and runs in SIMD batches of 4 that refill from a group of members.
MIN_PER_THREAD = {"dop853": 16, "taylor": 256}


def _default_chunk(n: int, m: int, threads: int, method: str = "dop853") -> int:
    """Members per chunk: about 20 chunks (progress), at least :data:`MIN_PER_THREAD` per
    thread (balance, and the cost of a chunk), at most :data:`MAX_CHUNK` and
    ~:data:`CHUNK_BYTES` of output (memory)."""
    per_member = m * (8 + _N_DIAG) * 8
    cap = min(MAX_CHUNK, max(1, CHUNK_BYTES // per_member))
    want = max(-(-n // 20), MIN_PER_THREAD[method] * threads)
    return max(1, min(want, max(cap, threads)))


def _nominal_inertia(nominal: Any, unit: str | None) -> np.ndarray | None:
    """The nominal body of ``nominal=(q0, Q0, body)`` (None for a pair), in the members'
    unit system."""
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


def propagate_ensemble(
    bodies_or_body: RigidBody | Any,
    q0: Any,
    Q0: Any,
    t: Any,
    potential: Potential | Sequence[Potential] | None = None,
    method: str = "auto",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    *,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    chunk_size: int | None = None,
    path: str | os.PathLike | None = None,
    client: Any = None,
    threads: int | None = None,
    progress: Callable[[int, int, int], None] | None = None,
    scheduler_timeout: float | None = None,
    attrs: dict[str, Any] | None = None,
    lazy: bool = False,
    events: Any = None,
    epoch: Any = None,
    output: str = "samples",
    every: int = 1,
    percentiles: Sequence[float] | None = None,
    nominal: tuple[Any, Any] | None = None,
    reference: Any = None,
    boresight: Any = None,
    max_output_size: float | str | None = _plan.MAX_OUTPUT_SIZE,
    on_estimate: Callable[[int], None] | None = None,
    commands: Any = None,
    software: Any = None,
    seed: int | None = None,
    _source: Any = None,
    _member_vars: Callable | None = None,
) -> xr.Dataset:
    """Propagate an ensemble of N members in parallel compiled code.

    Each member is integrated independently by the compiled DOP853 loop of
    :func:`attitude.propagate` (Hamilton's equations in (q, Q), Arribas et al. eq. 7, with the
    torque as the generalised force of Schwab eq. 25), with its own adaptive steps; with
    ``method="taylor"`` (what ``"auto"`` picks for built-in potentials) by the Taylor method of
    ``propagate(method="taylor")``, 4 or 8 members per SIMD instruction (the CPU's width,
    chosen at run time; results bit for bit those of single runs, whatever the width).

    Parameters
    ----------
    bodies_or_body : RigidBody, array_like shape (3,) or (N, 3), or sequence of N RigidBody
        One body for all members, or one row of principal moments per member (an astropy
        Quantity is converted to kg m² (SI); plain numbers are dimensionless, as in ``propagate``).
    q0 : array_like, shape (N, 4)
        Initial attitudes (body → space, scalar first). A single (4,) row is shared by all.
    Q0 : array_like, shape (N, 4)
        Initial conjugate momenta Q0 = 2 q0∘(0, g0). A single (4,) row is shared by all.
        States within 1e-6 of |q| = 1, q·Q = 0 are projected (as in ``propagate``).
    t : array_like, shape (m,)
        Output times shared by all members, strictly monotonic; ``t[0]`` is the initial epoch.
    potential : Potential or sequence of N Potentials, optional
        One potential for all (default torque-free), or one built-in potential per member, all
        of the same kind (e.g. ``[GravityGradient(orbit_i) for ...]`` for per-member orbits,
        ``HeavyTop`` with per-member weights). ``CustomPotential``/``CustomTorque`` are
        supported as one potential for all members (compiled into the user cache, see
        docs/potentials.md).
    method : {"auto", "dop853", "taylor"}
        The integrator of every member (docs/integrators.md). ``"auto"`` (default):
        ``"taylor"`` for built-in potentials without events, else ``"dop853"``
        (:func:`attitude.propagate.choose_method`; attrs ``method``, ``method_requested``).
        ``"taylor"``: built-in potentials only (torque-free, heavy top, gravity gradient of a
        Kepler orbit), no events; ``member_n_rhs`` is 0 and the order is the attr ``taylor_order``.
    rtol, atol : float
        Tolerances, as in ``propagate`` (DOP853: per state component; Taylor: the order and
        the step of Jorba & Zou).
    max_step : float
        Largest step.
    max_steps : int
        A member that needs more steps fails (see Raises).
    chunk_size : int, optional
        Members per chunk. Default: about N / 20 (a progress report per chunk), at least 16
        per thread (taylor: 256), at most 4096 and ~32 MiB of output. Results do not depend on
        it; memory does (one chunk: ~2 kB of work arrays plus m × 168 bytes of output per
        member).
    path : str or Path, optional
        Stream each chunk to this netCDF4 file as soon as it is computed (atomic: written to a
        temporary file, renamed at the end). Memory then stays bounded by one chunk, and the
        returned Dataset reads the file lazily (close it with ``ds.close()``).
    client : dask.distributed.Client or str, optional
        Run the chunks as tasks on a Dask cluster (a Client, or a scheduler address such as
        ``"tcp://10.0.0.1:8786"``). ``None`` (default): local threads, no Dask needed.
        Workers need ``attitude`` importable; the results are gathered chunk by chunk, in
        member order, and written by this process (no shared file system needed).
    threads : int, optional
        Local run: number of numba threads of the parallel loop (default: numba's, all cores).
    progress : callable, optional
        ``progress(n_done, n_total, n_steps_done)`` after each chunk (members done so far).
    scheduler_timeout : float, optional
        Seconds to wait for a scheduler given by address (default 10 s,
        ``attitude.ensemble._dask.SCHEDULER_TIMEOUT``).
    attrs : dict, optional
        Extra global attributes of the result.
    lazy : bool
        Return a dask-backed Dataset at once, one task per chunk, computed on access by
        Dask's current scheduler (a ``Client`` you created is it); with ``path`` it is
        written with
        ``Dataset.to_netcdf``, computed by ``client`` (on a cluster the workers write, so
        they must see ``path``: a shared file system). ``progress`` is not called. All or
        nothing: a failing member raises when computed and
        nothing is kept; totals (``n_steps``...) are not in the attrs (sum
        ``member_n_steps``). Default False: chunks are computed eagerly, in member order,
        and streamed by this process, keeping completed chunks on failure.
    events : list, optional
        Events (:mod:`attitude.events`) located in every member's compiled loop; the result
        gets ``event_count`` and ``event_first_time`` (member, detector): how often each
        occurred and when first (NaN: never), for
        :func:`attitude.ensemble.statistics.event_time_percentiles`. A terminal event ends a
        member (status 4, ``EVENT``; its samples after the event are NaN), not the ensemble.
    epoch : astropy Time or str, optional
        Date of t = 0, as in :func:`attitude.propagate` (events that read the Sun need one).
    output : {"samples", "final", "statistics"}
        What is stored (docs/ensemble.md, "Output choices"): every member at the output times
        (default; ``every=k``: at ``t[::k]``), every member at ``t[-1]`` only, or no members'
        trajectories but percentiles over members of the pointing error (from the reference
        attitude) and of |ω| at the output times, computed as the members finish
        (``pointing_error_percentiles``, ``omega_norm_percentiles``: dims (percentile, time)).
        Every member is integrated to ``t[-1]`` whatever is stored, and a stored sample is bit
        for bit that of a run storing everything. Per-member inputs and statistics
        (``inertia``, ``initial_q``, ``member_status``...) are stored in every case.
    every : int
        Store every k-th output time, ``t[::every]`` (``"samples"``, ``"statistics"``).
    percentiles : sequence of float, optional
        ``output="statistics"``: percentiles in [0, 100], default (5, 50, 95, 100) (100 is the
        maximum over members). Exact: ``np.percentile`` over all members at each time.
    nominal : (q0, Q0) or (q0, Q0, body), optional
        The nominal initial state ((4,) each): propagated once by the same compiled loop with
        the members' shared body and potential, its attitude is the reference of the pointing
        error (stored as ``reference_q``). With per-member bodies (dispersed inertia) the
        nominal body is the third element (RigidBody, or (3,) moments as the members' are
        given; :func:`disperse` returns the triple as ``.nominal``). :func:`run_scenario` uses
        the scenario's state.
    reference : Dataset or array_like shape (4,) or (time, 4), optional
        Instead of ``nominal``: the reference attitude, a ``propagate`` result on ``t`` or
        quaternions. ``output="statistics"`` needs one of the two.
    boresight : array_like shape (3,), optional
        ``output="statistics"``: the pointing error is the angle between the directions this
        body axis points to (member and reference), instead of the total rotation angle.
    max_output_size : float, str, Quantity or None
        Refuse (:class:`~attitude.errors.OutputSizeError`, before any work) an output whose
        expected size is larger: bytes, or a string such as ``"2 GB"``; None: no limit. The
        default is 1 GB. With ``path`` it is the file, without it the memory of the result.
    on_estimate : callable, optional
        ``on_estimate(nbytes)``: called once with the expected output size before any work
        (also in the attr ``expected_output_size``).

    Returns
    -------
    xarray.Dataset
        Dimensions ``member`` (coordinate: the member index), ``time``, ``component``,
        ``axis``. Variables of :func:`attitude.propagate` with a leading ``member`` dimension
        (``q``, ``Q``, ``omega``, ``g``, ``G``, ``energy``, ``potential_energy``,
        ``norm_error``, ``qQ``; ``r``, ``f``, ``p`` with an orbit: per member only when the
        orbits are), plus ``inertia`` (member, axis) and per-member statistics
        ``member_n_steps``, ``member_n_rhs``, ``member_n_rejected``, ``member_status``.
        Attrs: totals ``n_steps``, ``n_rhs``, ``n_rejected``, ``ensemble_size``,
        ``chunk_size``, invariant maxima over members (``max_abs_norm_error``...),
        ``run_status``.

    Raises
    ------
    AttitudeValueError, AttitudeTypeError
        Bad input (shapes of q0, Q0, body or potentials that do not match, N = 0, a method
        other than dop853 or taylor, a potential or events that taylor cannot handle, a
        scheduler that does not answer within ``scheduler_timeout``), before any work and
        before anything is written.
    PropagationError
        Some members of a chunk failed (non-finite state, too many steps...), or a chunk's
        task failed on the cluster. The message names the members; chunks completed before
        are kept (in ``path``, committed with ``run_status = "failed: ..."``, and in
        ``.partial``).

    Notes
    -----
    Memory without ``path`` is that of the whole result, ``N × m × 21 × 8`` bytes; with
    ``path`` it is one chunk (and, for ``output="statistics"``, 16 bytes per member and
    stored time, in a temporary file beside ``path`` beyond 256 MiB). See docs/ensemble.md
    for Dask clusters and dispersions.
    """
    body = bodies_or_body
    t_start = time.perf_counter()
    requested = method
    if not isinstance(method, str) or method not in (*ENSEMBLE_METHODS, AUTO):
        raise AttitudeValueError(
            f"method: propagate_ensemble runs {' or '.join(map(repr, ENSEMBLE_METHODS))} (the "
            f"compiled parallel loops; 'auto' picks one), got {method!r}; for other methods "
            f"loop over attitude.propagate"
        )
    tt = as_times(t, "t")
    rtol = as_rtol(rtol, "rtol")
    atol = as_atol(atol)
    max_step = as_positive(max_step, "max_step", allow_inf=True)
    max_steps = as_int(max_steps, "max_steps")
    _check_max_step(abs(float(tt[-1]) - float(tt[0])), max_step, max_steps)
    if chunk_size is not None:
        chunk_size = as_int(chunk_size, "chunk_size")
    if threads is not None:
        threads = as_int(threads, "threads")
        from orbit._shared_jit import JIT_DISABLED

        if not JIT_DISABLED and threads > _max_threads():
            raise AttitudeValueError(
                f"threads: numba can run at most {_max_threads()} threads in this process "
                f"(NUMBA_NUM_THREADS, set before numba starts), got {threads}; give at most "
                f"{_max_threads()}, or set NUMBA_NUM_THREADS in the environment"
            )
    if progress is not None and not callable(progress):
        raise AttitudeTypeError("progress: expected a callable progress(n_done, n_total, steps)")
    if attrs is not None:
        if not isinstance(attrs, dict):
            raise AttitudeTypeError(f"attrs: expected a dict, got {type(attrs).__name__}")
        attrs = check_attrs(attrs, "attrs")  # what netCDF can store, before any work
    if scheduler_timeout is None:
        scheduler_timeout = _dask.SCHEDULER_TIMEOUT
    timeout = _positive(scheduler_timeout, "scheduler_timeout")
    plan = _plan.make_plan(tt, output, every, percentiles, max_output_size)
    if on_estimate is not None and not callable(on_estimate):
        raise AttitudeTypeError("on_estimate: expected a callable on_estimate(nbytes)")
    if _source is None and is_spacecraft_ensemble(body, commands, software):
        # spacecraft with actuators or flight software (docs/ensemble.md)
        refused = {"client": client, "lazy": lazy, "events": events, "nominal": nominal,
                   "reference": reference, "boresight": boresight}  # fmt: skip
        return propagate_spacecraft(
            body, q0, Q0, tt, potential, plan, method=method, rtol=rtol, atol=atol,
            max_step=max_step, max_steps=max_steps, chunk_size=chunk_size, path=path,
            threads=threads, progress=progress, attrs=attrs, epoch=epoch,
            on_estimate=on_estimate, commands=commands, software=software, seed=seed,
            refused=refused, t_start=t_start, member_vars=_member_vars,
        )  # fmt: skip
    if seed is not None:
        raise AttitudeValueError(
            "seed: the ensemble seed of noisy sensors, for members with flight software "
            "(software=); draw rigid-body members with attitude.ensemble.disperse(seed=...)"
        )
    if nominal is not None and reference is not None:
        raise AttitudeValueError("nominal, reference: give one of them (the pointing reference)")
    if plan.output == "statistics":
        if nominal is None and reference is None:
            raise AttitudeValueError(
                "nominal: output='statistics' measures the pointing error from one reference "
                "for all members; give nominal=(q0, Q0) (the nominal initial state, propagated "
                "once) or reference= (a propagate result on t, or quaternions)"
            )
        if lazy:
            raise AttitudeValueError(
                "lazy: output='statistics' is computed as the members finish; run it eagerly "
                "(lazy=False)"
            )
    elif boresight is not None:
        raise AttitudeValueError("boresight: only with output='statistics'")
    bore = None
    if boresight is not None:
        bore = as_float_array(boresight, "boresight", trailing=3, ndim=1)
        if not float(np.linalg.norm(bore)) > 0:
            raise AttitudeValueError("boresight: the zero vector is not a direction")
        bore = bore / float(np.linalg.norm(bore))

    if _source is None:
        q, Q, n = _member_states(q0, Q0, _body_units(body))
        inertia, unit = _member_inertia(body, n)
        if isinstance(potential, Potential):  # environment tables for this run's span
            potential = potential.prepare(tt)
        elif isinstance(potential, (list, tuple)):
            potential = [p.prepare(tt) if isinstance(p, Potential) else p for p in potential]
        pot, params, pots = _member_potentials(potential, n, inertia)
        members = _Members(q, Q, inertia, params, n)
        for start in range(0, n, 65536):  # validate every state before any work
            stop = min(n, start + 65536)
            _project(members._rows(q, start, stop), members._rows(Q, start, stop), start)
    else:  # a dispersion sampler (run_scenario): already validated
        members, unit, pot, pots = _source
        n = members.n
    user = pot if pot._user_terms() else None
    method = _ensemble_method(method, pot, pots, events)
    evset = None
    if events is not None:
        evset = _ensemble_events(events, tt, pot, epoch)

    out_path = None
    if path is not None:
        from .._files import OutputFile

        # checked before any work: type, a directory or device, room on the disk
        target = OutputFile(path, "path")
        if target.through:
            raise AttitudeFileError(
                f"path: {target.path} is a pipe or a device; an ensemble's result is opened "
                "from the file it was written to (members are read lazily from it), so it "
                "needs a regular file: write there and copy it"
            )
        target.check_space(
            float(n) * tt.shape[0] * (8 + _N_DIAG) * 8, f"{n} members x {tt.shape[0]} samples"
        )
        out_path = target.path

    owned = False
    if lazy:
        try:
            import dask  # noqa: F401
        except ImportError:
            raise AttitudeValueError(
                "lazy: needs Dask; install the optional extra (pip install 'attitude[dask]')"
            ) from None
        if isinstance(client, str) and path is None:
            raise AttitudeValueError(
                "lazy: a lazy result without a path keeps using the cluster; pass a "
                "dask.distributed.Client (that you close), not an address"
            )
    if client is not None:
        client, owned = _connect(client, timeout)
        if user is not None:
            import cloudpickle

            try:
                cloudpickle.dumps(user)
            except Exception as exc:
                raise AttitudeTypeError(
                    f"potential: this {type(user).__name__} cannot be shipped to Dask workers "
                    f"({type(exc).__name__}: {exc}); run it locally (client=None)"
                ) from None
        n_threads = _worker_threads(client)
    else:
        from orbit._shared_jit import JIT_DISABLED

        if threads is not None:
            n_threads = int(threads)
        elif JIT_DISABLED:
            n_threads = 1
        else:
            import numba

            n_threads = numba.get_num_threads()
    m = plan.kernel_t.shape[0]
    csize = int(chunk_size) if chunk_size is not None else _default_chunk(n, m, n_threads, method)
    csize = min(csize, n)
    setup = _Setup(plan.kernel_t, rtol, atol, float(max_step), int(max_steps), user, evset, method)
    run_attrs: dict[str, Any] = {
        "title": "attitude ensemble propagation",
        "method": method,
        **({"method_requested": requested} if requested != method else {}),
        "formulation": "canonical",
        "rtol": rtol,
        "atol": atol,
        "ensemble_size": np.int64(n),
        "chunk_size": np.int64(csize),
        "execution": "dask" if client is not None else f"local threads ({n_threads})",
    }
    if method == "taylor":
        from .._core.taylor import order_from_tolerance

        run_attrs["taylor_order"] = np.int64(order_from_tolerance(rtol))
    if pots is not None:
        run_attrs["potential"] = f"{n} per-member potentials, member 0: {pot.describe()}"
    if not math.isinf(max_step):
        run_attrs["max_step"] = float(max_step)
    if evset is not None:
        run_attrs["events"] = evset.describe()
        if evset.epoch is not None:
            from orbit.timescales import format_epoch

            run_attrs["epoch"] = format_epoch(evset.epoch)
    run_attrs.update(plan.attrs())
    if attrs:
        run_attrs.update(attrs)
    asm = _Assembler(plan.stored_t, unit, pot, pots, run_attrs, evset)
    if members.shared_inertia is not None:
        asm.attrs["inertia"] = np.asarray(members.shared_inertia, dtype=np.float64)
    asm.keep, asm.members = plan.keep, members
    asm.views = plan.output == "statistics"
    has_ref = nominal is not None or reference is not None
    ms = plan.stored_t.shape[0]
    if has_ref:
        asm.reference = np.zeros((ms, 4))  # the size estimate's placeholder
    # The expected size, from one member's Dataset (whatever variables it has), before any work.
    n_ev = 0 if evset is None else len(evset.labels)
    one = asm.dataset(0, _plan.dummy_chunk(m, 1, n_ev), members.block(0, 1)[2])
    extra = None
    if plan.output == "statistics":
        probe = _PercentileStore(1, plan.stored_t, plan.percentiles, np.zeros((ms, 4)))
        try:
            one = probe.add(one)
            extra = probe.finish(one["time"].variable)
        finally:
            probe.close()
    expected = _plan.estimate_bytes(one, n, extra)
    _plan.check_size(expected, plan, n, out_path is None, one)
    asm.attrs["expected_output_size"] = np.int64(expected)
    if on_estimate is not None:
        on_estimate(expected)
    if nominal is not None:
        params = members.nominal_params(_nominal_inertia(nominal, unit))
        asm.reference = _plan.nominal_reference(setup, params, nominal, plan)
    elif reference is not None:
        asm.reference = _plan.given_reference(reference, plan)
        asm.attrs["pointing_reference"] = "given"
    if nominal is not None:
        asm.attrs["pointing_reference"] = "nominal initial state, propagated once"

    bounds = [(s, min(n, s + csize)) for s in range(0, n, csize)]
    if lazy:
        asm.attrs["run_status"] = "lazy: computed on access; a failing member raises"
        try:
            ds = _lazy_result(setup, members, bounds, asm)
            ds.attrs["initial_projection"] = float(asm.max_projection)
            if out_path is None:
                return ds
            _write_lazy(ds, out_path, client)
        finally:
            if owned:
                with contextlib.suppress(Exception):
                    client.close()
        return _open_result(out_path, csize, True)

    writer = _MemberWriter(out_path, complevel=COMPLEVEL) if out_path is not None else None
    kept: list[xr.Dataset] = []
    failures = _Failures(m)
    # Every sample of every member in memory: the chunks write straight into the arrays of the
    # whole result, and its Dataset is assembled once at the end (not a Dataset per chunk).
    direct = None
    if writer is None and plan.output == "samples" and plan.keep is None and client is None:
        direct = _Direct(n, m)
    store = None
    stats = None
    if plan.output == "statistics":
        store = _PercentileStore(
            n,
            plan.stored_t,
            plan.percentiles,
            asm.reference,
            bore,
            None if out_path is None else out_path.parent,
        )
    try:
        if client is None:
            results = _local_results(setup, members, bounds, threads, direct)
        else:
            results = _dask_results(client, setup, members, bounds, n_threads)
        for (start, stop), got in zip(bounds, results, strict=False):
            if isinstance(got, BaseException):
                # The chunk's task failed as a whole: its members are marked and NaN, the
                # other chunks go on.
                _, _, inertia, corr = members.block(start, stop)
                out = _failed_chunk(setup, stop - start, got)
            else:
                out, inertia, corr = got
            failures.add(out, start)
            asm.max_projection = max(asm.max_projection, corr)
            asm.account(out)
            if direct is not None:
                direct.add(out, inertia)
                if progress is not None:
                    progress(stop, n, asm.totals["n_steps"])
                continue
            ds = asm.dataset(start, out, inertia)
            if store is not None:  # statistics only: keep the scalars, drop the members
                ds = store.add(ds)
            if writer is not None:
                writer.append(ds)
            else:
                kept.append(ds)
            if progress is not None:
                progress(stop, n, asm.totals["n_steps"])
        if direct is not None and direct.n:
            kept.append(direct.dataset(asm))
        failure: PropagationError | None = None
        if failures.count:
            failure = PropagationError(failures.message(n), time=failures.first[1])
        status = "complete" if failure is None else f"failed: {failure}"
        final = asm.final_attrs(status)
        final["n_members_failed"] = np.int64(failures.count)
        if store is not None and asm.n_members:
            stats = store.finish(asm.template["time"].variable)
            final.update(store.attrs())
        final["wall_time"] = time.perf_counter() - t_start
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
        if owned:
            with contextlib.suppress(Exception):
                client.close()
    if asm.max_projection > PROJECTION_WARN:
        warnings.warn(
            f"initial states projected onto |q| = 1, q·Q = 0 (largest correction "
            f"{asm.max_projection:.2g})",
            stacklevel=2,
        )

    if writer is not None:
        result = _open_result(out_path, csize, client is not None) if writer.n else None
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


def _ensemble_events(events: Any, t: np.ndarray, pot: Potential, epoch: Any) -> Any:
    """The validated events of an ensemble (attitude.events.build) with the run's epoch."""
    from orbit.errors import OrbitError
    from orbit.timescales import as_epoch

    from ..events import build

    try:
        e = as_epoch(epoch, "epoch")
    except OrbitError as exc:
        raise AttitudeValueError(str(exc)) from None
    if e is None:
        e = getattr(getattr(pot, "orbit", None), "epoch", None)
    return build(events, t, e)


def _local_results(setup, members, bounds, threads, direct=None):
    """Chunks computed here with the parallel driver, one after the other (generator).

    A chunk that raises (not a member's integration: that is in its status) yields the
    exception and the next chunks go on.
    """
    from orbit._shared_jit import JIT_DISABLED

    for start, stop in bounds:
        try:
            params, y0, inertia, corr = members.block(start, stop)
            buf = {} if direct is None else direct.buffers(start, stop)
            with _numba_threads(threads):
                if JIT_DISABLED:
                    out = _compute_chunk(setup, params, y0, parallel=False, **buf)
                else:
                    import numba

                    out = _compute_chunk(
                        setup, params, y0, parallel=True, threads=numba.get_num_threads(), **buf
                    )
        except (AttitudeValueError, AttitudeTypeError):
            raise
        except Exception as exc:
            yield exc
            continue
        yield out, inertia, corr


def run_scenario(
    sc: Any,
    path: str | os.PathLike | None = None,
    *,
    client: Any = None,
    progress: Callable[[int, int, int], None] | None = None,
    chunk_size: int | None = None,
    scheduler_timeout: float | None = None,
    output: str | None = None,
    every: int | None = None,
    percentiles: Sequence[float] | None = None,
    max_output_size: Any = ...,
    on_estimate: Callable[[int], None] | None = None,
    **overrides: Any,
) -> dict[str, Any]:
    """Run the dispersed ensemble of a scenario with an ``[ensemble]`` table, streamed to netCDF.

    Parameters
    ----------
    sc : attitude.scenario.Scenario
        A scenario whose ``ensemble`` (:class:`Dispersions`) is set.
    path : str or Path, optional
        Output file (default: the scenario's output path).
    client : dask.distributed.Client or str, optional
        Dask client or scheduler address (see :func:`propagate_ensemble`).
    progress : callable, optional
        ``progress(n_done, n_total, n_steps)`` after each chunk.
    chunk_size : int, optional
        Members per chunk (default: ``ensemble.chunk``, else automatic).
    output, every, percentiles, max_output_size : optional
        Replace the ``[ensemble]`` table's (see :func:`propagate_ensemble`; ``max_output_size``
        None: no limit). The pointing error is measured from the scenario's nominal state,
        propagated once (``reference_q``).
    on_estimate : callable, optional
        ``on_estimate(nbytes)`` with the expected file size, before any work.
    **overrides
        ``method``, ``rtol``, ``atol``, ``max_step`` replacing the scenario's.

    Returns
    -------
    dict
        ``path`` and the file's global attrs.

    Raises
    ------
    PropagationError
        As :func:`propagate_ensemble`; the file keeps the chunks done before the failure.
    """
    from ..canonical import project_state

    disp = sc.ensemble
    if disp is None:
        raise AttitudeValueError("scenario: no [ensemble] table; use Scenario.run_to_file")
    kw = sc._kwargs(overrides)
    for key in ("dt", "order", "formulation"):
        if key in kw:
            raise AttitudeValueError(
                f"integrator.{key}: ensembles run the canonical equations with method 'dop853' "
                f"or 'taylor' only; remove {key} from the [integrator] table of an [ensemble] "
                f"scenario"
            )
    from .._files import OutputFile

    out = OutputFile(path, "path").path if path is not None else sc.output
    if sc.spacecraft is not None:  # actuators, [commands] or [software]
        from ._spacecraft_scenario import run_spacecraft_scenario

        opts = dict(client=client, progress=progress, chunk_size=chunk_size, output=output,
                    scheduler_timeout=scheduler_timeout, every=every, percentiles=percentiles,
                    max_output_size=max_output_size, on_estimate=on_estimate)  # fmt: skip
        return run_spacecraft_scenario(sc, out, kw, propagate_ensemble, **opts)
    q0, Q0, _ = project_state(sc.q0, sc.Q0)
    pot = sc.potential.bind(sc.body).prepare(sc.t)
    inertia = np.asarray(sc.body.inertia, dtype=np.float64)
    params = pot._params(inertia)
    source = _Sampled(disp, q0, Q0, inertia, params)
    attrs = {**sc.attrs(kw), **disp.attrs()}
    if disp.inertia_error > 0:
        attrs["inertia"] = inertia  # the nominal body; each member's is the variable inertia
        attrs["inertia_note"] = "nominal; per-member moments in the variable inertia"
    ds = propagate_ensemble(
        sc.body,
        None,
        None,
        sc.t,
        pot,
        path=out,
        client=client,
        progress=progress,
        chunk_size=chunk_size or disp.chunk,
        scheduler_timeout=scheduler_timeout,
        attrs=attrs,
        events=sc.events,
        epoch=sc.epoch,
        output=disp.output if output is None else output,
        every=disp.every if every is None else every,
        percentiles=percentiles if percentiles is not None else disp.percentiles,
        nominal=(q0, Q0),
        max_output_size=disp.max_output_size if max_output_size is ... else max_output_size,
        on_estimate=on_estimate,
        _source=(source, sc.body.units, pot, None),
        **kw,
    )
    try:
        info = {"path": out, **ds.attrs}
    finally:
        ds.close()
    return info

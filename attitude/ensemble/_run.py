"""``propagate_ensemble`` and ``run_scenario``: the ensemble entry points (front ends of the
run pipeline: :class:`~._spec.EnsembleSpec` validates, :mod:`._runner` computes and
assembles)."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..body import RigidBody
from ..errors import AttitudeValueError
from ..potentials import Potential
from . import _plan, _runner
from ._spec import EnsembleSpec
from .dispersions import _Sampled


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
        Local run: number of threads running members (default and largest: the cores,
        numba's ``NUMBA_NUM_THREADS``).
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
    spec = EnsembleSpec.build(
        bodies_or_body, q0, Q0, t, potential, method, rtol, atol, max_step=max_step,
        max_steps=max_steps, chunk_size=chunk_size, path=path, client=client, threads=threads,
        progress=progress, scheduler_timeout=scheduler_timeout, attrs=attrs, lazy=lazy,
        events=events, epoch=epoch, output=output, every=every, percentiles=percentiles,
        nominal=nominal, reference=reference, boresight=boresight,
        max_output_size=max_output_size, on_estimate=on_estimate, commands=commands,
        software=software, seed=seed, _source=_source, _member_vars=_member_vars,
    )  # fmt: skip
    return _runner.run(spec)


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

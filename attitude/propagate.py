"""``propagate``: the one entry point of attitude propagation.

Physics (the body and a :mod:`~attitude.potentials` model), numerics (a method name and its
options) and output (an xarray Dataset, :mod:`attitude.results`) are separate pieces passed to
one function, as in ``scipy.integrate.solve_ivp``.

Methods
-------
``"dop853"``
    Adaptive 8th-order Dormand–Prince with error control and 7th-order dense output at the
    requested times; right-hand side and step loop in one compiled function (cached on disk).
``"scipy:<name>"``
    The same right-hand side through ``scipy.integrate.solve_ivp(method=<name>)`` (e.g.
    ``"scipy:DOP853"``, ``"scipy:Radau"``): a reference path, not a fast one.

``"exact"``, ``"nosquish"``, ``"splitting"``, ``"taylor"``
    The closed-form torque-free motion (:mod:`attitude.exact`), the structure-preserving
    splittings (:mod:`attitude.splitting`) and the adaptive Taylor series of eq. 7
    (:mod:`attitude.taylor`).

:data:`METHODS` maps each name to its runner (:mod:`attitude._methods` says what a runner is).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
import xarray as xr

from . import _compiling
from ._core import rk as _rk
from ._finish import _OVERFLOW_MESSAGE, _DiagnosticsOverflow, _finish, finish_dataset
from ._finish import _finite_prefix as _finite_prefix  # (moved to _finish; importable here)
from ._methods import SCIPY_SOLVERS, Problem, RunResult, run_dop853, run_scipy
from ._progress import ProgressBar as _ProgressBar
from ._spacecraft_results import add_tick_variables, tick_dataset
from ._validation import ATOL_MIN as ATOL_MIN  # (moved beside as_atol; still importable here)
from ._validation import as_atol, as_float_array, as_int, as_positive, as_rtol, as_times
from .body import RigidBody
from .canonical import _project
from .errors import AttitudeTypeError, AttitudeValueError, PropagationError
from .exact import run_exact
from .formulations import Formulation, get_formulation
from .potentials import Potential, as_potential
from .results import Trajectory, add_event_variables
from .spacecraft import Spacecraft
from .splitting import run_nosquish, run_splitting
from .taylor import run_taylor

__all__ = ["AUTO", "METHODS", "Problem", "RunResult", "choose_method", "propagate"]

#: Relative defect of the initial state above which a projection warns.
PROJECTION_WARN = 1e-12
#: Progress reports per run (the default chunk with ``progress``): the compiled loop returns
#: this often; results do not depend on it (dense output at the requested times).
PROGRESS_CHUNKS = 200


#: Largest number of output samples that is computed in memory before being handed to
#: ``on_chunk`` by the methods that do not stream (the non-canonical formulations): ~170 bytes
#: a sample, 0.34 GB at the limit.
MAX_UNSTREAMED_SAMPLES = 2_000_000


#: Registered methods: name -> runner(problem, **options) -> RunResult.
METHODS: dict[str, Callable[..., RunResult]] = {
    "dop853": run_dop853,
    "exact": run_exact,
    "nosquish": run_nosquish,
    "splitting": run_splitting,
    "taylor": run_taylor,
}


#: The default method: the fastest one that supports the model (:func:`choose_method`).
AUTO = "auto"


def choose_method(
    method: str,
    potential: Any,
    *,
    spacecraft: Any = None,
    formulation: Any = "canonical",
    events: Any = None,
) -> str:
    """The method a run with ``method`` takes: ``method`` itself unless it is ``"auto"``, which
    is ``"taylor"`` wherever the model supports it and ``"dop853"`` otherwise.

    ``taylor`` expands the built-in potentials (torque-free, heavy top, the gravity gradient of
    a Kepler orbit) and a spacecraft's wheels and thrusters (open or closed loop), in
    canonical variables without events (:func:`attitude.taylor.check_potential`,
    :func:`attitude._holds.check_taylor`); it takes several times fewer operations than
    ``dop853`` to the same accuracy (benchmarks/taylor.py). Everything else (user potentials,
    environment models, tabulated orbits, magnetorquers, events, other formulations) runs
    ``dop853``. A run with ``"auto"`` is bit for bit the run with the method it picks; the
    Dataset's attrs record both (``method``, ``method_requested``).

    Parameters
    ----------
    method : str
        The requested method.
    potential : Potential
        The bound potential of the run.
    spacecraft : Spacecraft, optional
        The spacecraft with actuators, if any.
    formulation : str or Formulation
        The run's formulation.
    events : list, optional
        The run's events.
    """
    if not isinstance(method, str):
        raise AttitudeTypeError(
            f"method: expected a method name such as 'dop853' or 'auto', got "
            f"{type(method).__name__} {method!r}"[:200]
        )
    if method != AUTO:
        return method
    if events is not None or not (isinstance(formulation, str) and formulation == "canonical"):
        return "dop853"
    try:
        if spacecraft is not None:
            from ._holds import check_taylor

            check_taylor(spacecraft, potential)
        else:
            from .taylor import check_potential

            check_potential(potential)
    except AttitudeValueError:
        return "dop853"
    return "taylor"


def _lookup_method(method: str) -> tuple[Callable[..., RunResult], dict[str, Any]]:
    if not isinstance(method, str):
        raise AttitudeTypeError(f"method: expected a string, got {type(method).__name__}")
    if method.startswith("scipy:"):
        solver = method.split(":", 1)[1]
        if solver not in SCIPY_SOLVERS:
            raise AttitudeValueError(
                f"method: unknown scipy solver {solver!r}; use one of "
                + ", ".join(f"'scipy:{s}'" for s in SCIPY_SOLVERS)
            )
        return run_scipy, {"solver": solver}
    if method not in METHODS:
        known = [*sorted(METHODS), "scipy:<solver>"]
        raise AttitudeValueError(f"method: unknown method {method!r}; known: {', '.join(known)}")
    return METHODS[method], {}


def _as_body(body: Any) -> RigidBody:
    if isinstance(body, RigidBody):
        return body
    if isinstance(body, Spacecraft):
        return body.body
    return RigidBody(body)


def _positive(x: Any, name: str) -> float:
    return as_positive(x, name)


def _check_max_step(span: float, max_step: float, max_steps: int) -> None:
    """Steps are at most ``max_step`` long: more than ``max_steps`` of them is certain failure."""
    if span / max_step > max_steps:
        raise AttitudeValueError(
            f"max_step: {max_step!r} over the time span {span:g} means at least "
            f"{span / max_step:.3g} steps, more than max_steps = {max_steps}: the run cannot "
            "finish; raise max_step (or max_steps)"
        )


def _check_work(problem: Problem, method: str, max_step: float, max_steps: int) -> None:
    """Refuse up front what cannot finish in ``max_steps`` (the work estimate of the adaptive
    methods is made from their first steps: :func:`attitude._methods.check_work`)."""
    if method != "dop853" and not method.startswith("scipy:"):
        return  # the fixed-step methods count their steps themselves; "exact" takes none
    t = problem.t
    span = abs(float(t[t.shape[0] - 1]) - float(t[0]))
    if span > 0.0:
        _check_max_step(span, max_step, max_steps)


def propagate(
    body: RigidBody | Any,
    q0: Any,
    Q0: Any,
    t: Any,
    potential: Potential | None = None,
    method: str = AUTO,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    dt: float | None = None,
    order: int = 4,
    *,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    progress: bool | Callable[[int, int, float], None] | None = None,
    chunk: int | None = None,
    formulation: str = "canonical",
    on_chunk: Callable[[xr.Dataset], None] | None = None,
    epoch: Any = None,
    events: Any = None,
    output: str = "dataset",
    commands: Any = None,
    software: Any = None,
    max_output_size: Any = "auto",
) -> xr.Dataset | Trajectory:
    """Propagate the attitude of a rigid body in canonical quaternion variables.

    Integrates Hamilton's equations in (q, Q) (Arribas, Elipe & Palacios 2006, eq. 7) with the
    potential's torque entering as the generalised force 2 q∘(0, τ_B) (Schwab eq. 25).

    Parameters
    ----------
    body : RigidBody, Spacecraft or array_like, shape (3,)
        The body (principal moments of inertia), or a :class:`~attitude.Spacecraft` with
        actuators: with reaction wheels a gyrostat, whose state adds the wheels' axial momenta
        (docs/actuators.md).
    q0 : array_like, shape (4,)
        Initial attitude quaternion (body → space, scalar first).
    Q0 : array_like, shape (4,)
        Initial conjugate momenta, Q0 = 2 q0∘(0, g0) (kg m² s⁻¹ for a body with units; a
        Quantity is converted). A state within 1e-6 (relative) of
        |q| = 1, q·Q = 0 is projected onto it (the correction is recorded in the attrs; a
        warning above 1e-12); anything further off is rejected.
    t : array_like, shape (m,)
        Output times, strictly monotonic; ``t[0]`` is the initial epoch. Decreasing times
        integrate backwards.
    potential : Potential, optional
        ``TorqueFree()`` (default), ``HeavyTop``, ``GravityGradient``, ``CustomPotential``,
        ``CustomTorque``.
    method : str
        ``"auto"`` (default): ``"taylor"`` wherever the model supports it (built-in
        potentials, wheels and thrusters, flight software; no events, canonical formulation),
        else ``"dop853"`` (:func:`choose_method`; attrs ``method`` and ``method_requested``).
        Or ``"dop853"``, ``"scipy:<solver>"``, and where available ``"exact"``,
        ``"nosquish"``, ``"splitting"``, ``"taylor"`` (built-in potentials).
    rtol, atol : float
        Tolerances of the adaptive methods (per-component, on the 8 state variables);
        ``rtol >= 1e-15``, ``atol >= ATOL_MIN`` (1e-100) and at most 0.1 times the state's
        largest component (max(1, |Q0| components)), as rtol <= 0.1.
    dt : float, optional
        Step of the fixed-step methods.
    order : int
        Order of the composition methods (2, 4 or 6).
    max_step : float
        Largest step of the adaptive methods (span / max_step must not exceed max_steps).
    max_steps : int
        Give up after this many steps. An adaptive run estimates its work after its first
        64 steps: more than 100 × max_steps is refused there (AttitudeValueError), more than
        max_steps warns (RuntimeWarning); see docs/reliability.md.
    progress : bool or callable, optional
        ``True``: a tqdm progress bar (on stderr; a widget in Jupyter) that advances during
        the run. A callable: ``progress(n_done, n_total, t_reached)`` called after each chunk
        of output times. A closed-loop run that will compile its kernels (the first one) says
        so before and how long it took after, through the bar (or a callable's ``note(text)``).
    chunk : int, optional
        Output samples per compiled call, an integer >= 1; results do not depend on it. With
        ``progress`` the default is :data:`PROGRESS_CHUNKS` chunks per run (the compiled loop
        returns that often to report). Compiled calls also return every
        ``attitude._methods.STEP_BUDGET`` steps, so Ctrl-C acts within a fraction of a second.
    formulation : str
        Equations integrated: ``"canonical"`` (default, eq. 7 in (q, Q)) or another of
        :data:`attitude.formulations.FORMULATIONS` (``"euler_angles"``, ``"schwab"``,
        ``"euler_equations"``). Every formulation returns the same Dataset schema.
    on_chunk : callable, optional
        Streaming: ``on_chunk(ds_chunk)`` receives, in time order, Datasets of consecutive
        output samples (``chunk`` of them, default 4096; the last one may be shorter, also
        when the run fails midway). With the canonical ``"dop853"`` runner the samples are
        not kept, so memory stays bounded (see :func:`attitude.io.write_streaming`); the
        returned Dataset then holds only the last sample (with the complete attrs). The
        flight software's tick records arrive as Datasets of their own, on ``tick`` without
        ``time``, 4096 ticks at a time (:class:`attitude.io.StreamWriter` appends both).
    epoch : astropy Time or str, optional
        Date of t = 0 (ISO 8601 strings are UTC unless a scale follows). Default: the epoch of
        the potential's orbit, if it has one. Recorded in the attrs (``epoch``, UTC ISO 8601),
        so ``ds.attitude.times()`` and the AEM export need nothing else. An epoch different
        from the orbit's is an error (one run has one time origin).
    events : list, optional
        Events to locate (:mod:`attitude.events`: ``PointingExceeds``, ``RateExceeds``,
        ``EclipseEntry``, ``EclipseExit``, ``AngleToSun``, ``Custom`` or plain functions
        g(t, q, omega)), with the methods ``"dop853"``, ``"nosquish"`` and ``"splitting"``
        (canonical formulation). Every occurrence is recorded in variables on an ``event``
        dimension (time, which event, direction, state); a terminal event ends the run at its
        root (attrs ``status = "event"``; the state there is the last sample). See
        docs/events.md.
    output : {"dataset", "arrays"}
        ``"dataset"`` (default): the result Dataset. ``"arrays"``: a
        :class:`~attitude.results.Trajectory` ``(t, q, Q, stats)`` of plain arrays, without
        diagnostics, torques or a Dataset (for loops and optimisers calling ``propagate`` many
        times: about half the overhead of a short call); not with ``events`` or ``on_chunk``.
    commands : CommandSchedule, optional
        Open-loop actuator commands of a :class:`~attitude.Spacecraft`, held from each time of
        the schedule to the next (the integrator restarts at every one of them).
    software : FlightSoftware, optional
        Closed-loop commands: the flight software runs at its own ticks inside the
        propagation (docs/flight_software.md); a body without actuators takes its torque
        request as an ideal torque. Its records are on a ``tick`` dimension: by default the
        ticks in effect at the output samples (``FlightSoftware(record_every=...)``).
    max_output_size : "auto", size or None
        The largest result held in memory (the samples and tick records not streamed to
        ``on_chunk``): bytes, a string such as ``"2 GB"``, or None for no limit; ``"auto"``
        (default) a quarter of the machine's memory. A larger run is refused before any work
        (:class:`~attitude.errors.OutputSizeError`, with the estimate and what to change).

    Returns
    -------
    xarray.Dataset or Trajectory
        Dimension ``time``; variables ``q``, ``Q``, ``omega``, ``g``, ``G``, ``energy``,
        ``potential_energy``, ``norm_error``, ``qQ`` (and ``r``, ``f``, ``p`` with an orbit;
        ``event_*`` and ``detector_*`` with events); attrs record the method, tolerances,
        statistics, body and potential. See docs/results.md. With ``output="arrays"`` the
        states as a :class:`~attitude.results.Trajectory` (the same numbers, bit for bit).

    Raises
    ------
    AttitudeValueError, AttitudeTypeError
        Bad input, before any work; or an adaptive run that cannot finish within max_steps
        (found after its first 64 steps).
    PropagationError
        The integration failed midway; ``.partial`` holds the samples computed so far (a
        Trajectory with ``output="arrays"``).
    """
    if not isinstance(output, str) or output not in ("dataset", "arrays"):
        raise AttitudeValueError(f"output: expected 'dataset' or 'arrays', got {output!r}")
    arrays = output == "arrays"
    if arrays and (events is not None or on_chunk is not None):
        raise AttitudeValueError(
            "output: 'arrays' returns the states only; events and on_chunk need the Dataset "
            "(output='dataset')"
        )
    craft = body if isinstance(body, Spacecraft) and body.has_actuators else None
    if software is not None and craft is None:
        craft = body if isinstance(body, Spacecraft) else Spacecraft(body)
    body = _as_body(body)
    pot = as_potential(potential).bind(body)
    requested = method
    method = choose_method(method, pot, spacecraft=craft, formulation=formulation, events=events)
    runner, extra = _lookup_method(method)
    if craft is not None:
        runner = _spacecraft_runner(craft, method, formulation, events, output, pot)
    elif commands is not None:
        raise AttitudeValueError(
            "commands: a CommandSchedule drives the actuators of an attitude.Spacecraft; this "
            "body has none (give Spacecraft(body, wheels=..., magnetorquers=..., thrusters=...))"
        )
    form = None
    if not isinstance(formulation, (str, Formulation)):
        raise AttitudeTypeError(
            f"formulation: expected a name such as 'canonical' or a Formulation, got "
            f"{type(formulation).__name__}"
        )
    if formulation != "canonical":
        form = get_formulation(formulation, method)
    q0a = as_float_array(q0, "q0", trailing=4, ndim=1)
    if not q0a.any():
        raise AttitudeValueError("q0: the zero quaternion does not represent a rotation")
    # Q has units of angular momentum: a Quantity is accepted when the body has units.
    Q0a = as_float_array(
        Q0, "Q0", trailing=4, ndim=1, unit=None if body.units is None else "kg m2 / s"
    )
    tt = as_times(t, "t", lazy=True)
    rtol = as_rtol(rtol, "rtol")
    atol = as_atol(atol, max(1.0, float(np.max(np.abs(Q0a)))))
    if dt is not None:
        dt = as_positive(dt, "dt")
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool):
        raise AttitudeTypeError(f"order: expected an integer (2, 4 or 6), got {order!r}")
    max_step = as_positive(max_step, "max_step", allow_inf=True)
    max_steps = as_int(max_steps, "max_steps")
    if chunk is not None:
        chunk = as_int(chunk, "chunk")
    if progress is False:
        progress = None
    if progress is not None and progress is not True and not callable(progress):
        raise AttitudeTypeError(
            "progress: expected True (a progress bar) or a callable progress(n_done, n_total, t)"
        )
    if on_chunk is not None and not callable(on_chunk):
        raise AttitudeTypeError("on_chunk: expected a callable on_chunk(ds_chunk)")
    run_attrs = _epoch_attrs(pot, epoch)
    span = np.array([tt[0], tt[-1]], dtype=np.float64)  # only the ends matter to the models
    try:
        pot.check_times(span, "t")  # e.g. an ephemeris orbit's table span
    except ValueError as exc:
        raise AttitudeValueError(str(exc)) from None
    pot = pot.prepare(span)  # environment tables along the orbit for this run's span
    evset = None
    if events is not None:
        tt = np.asarray(tt)  # events need the samples (no lazy grid)
        evset = _events(events, tt, method, formulation, run_attrs)
    streaming = (
        on_chunk is not None
        and form is None
        and evset is None
        and getattr(runner, "streams", False)
    )
    if on_chunk is not None and not streaming and tt.shape[0] > MAX_UNSTREAMED_SAMPLES:
        raise AttitudeValueError(
            f"t: {tt.shape[0]} output samples with method {method!r} and formulation "
            f"{formulation!r}, which are computed in memory before they are handed out "
            f"(at most {MAX_UNSTREAMED_SAMPLES} samples); use formulation='canonical' "
            "without events (streamed), or fewer samples"
        )
    if not (streaming or isinstance(tt, np.ndarray)):
        tt = np.asarray(tt)

    if progress is not None and chunk is None:  # report during the run, not once at the end
        chunk = max(1, -(-tt.shape[0] // PROGRESS_CHUNKS))
    q0p, Q0p, correction = _project(q0a, Q0a)  # q0a, Q0a validated above
    if correction > PROJECTION_WARN:
        warnings.warn(
            f"initial state projected onto |q| = 1, q·Q = 0 (correction {correction:.2g})",
            stacklevel=2,
        )
    y0 = np.concatenate([q0p, Q0p])
    sc_run = None
    if craft is not None:
        from . import _holds

        craft.check_orbit(getattr(pot, "orbit", None))
        # (the software's period, phase and ticks against the span: _holds.check_software_span)
        sc_run, y0 = _holds.prepare(
            craft, q0p, Q0p, span, commands, software, max_steps, samples=tt
        )
        run_attrs["spacecraft"] = craft.describe()
        if software is not None:
            run_attrs["software"] = software.describe()
    can_stream = form is None and evset is None and getattr(runner, "streams", False)
    _check_memory(max_output_size, tt.shape[0], sc_run, streaming, can_stream)
    problem = Problem(
        body=body,
        potential=pot,
        params=pot._params(body.inertia),
        y0=y0,
        t=tt,
        entry=_entry_points(pot, evset, sc_run),
        events=evset,
        spacecraft=sc_run,
    )
    _check_initial_state(problem)
    _check_work(problem, method, max_step, max_steps)
    options = dict(
        rtol=rtol,
        atol=atol,
        dt=dt,
        order=int(order),
        max_step=max_step,
        max_steps=int(max_steps),
        progress=progress,
        chunk=chunk,
        **extra,
    )
    if on_chunk is not None:
        options["chunk"] = chunk = 4096 if chunk is None else chunk
    bar = _ProgressBar(tt.shape[0]) if progress is True else None
    if bar is not None:
        options["progress"] = bar
    # the first closed-loop run compiles for most of a minute: said before, and how long after
    compiling = _compiling.watch(options["progress"], problem, method)
    if compiling is not None:
        options["progress"] = compiling
    try:
        if streaming:
            chunk_attrs = {"method": method, "formulation": formulation, **run_attrs}
            if requested != method:
                chunk_attrs["method_requested"] = requested
            if sc_run is not None and sc_run.program is not None:
                sc_run.tick_sink = lambda rec: on_chunk(tick_dataset(sc_run, rec, chunk_attrs))

            def emit(first: int, y: np.ndarray, t_last: float | None = None) -> None:
                part, n_ok = _finish(problem, y, chunk_attrs, first=first, t_last=t_last)
                if n_ok is not None:  # the diagnostics overflowed: hand out the rows before
                    if n_ok:
                        on_chunk(part.isel(time=slice(0, n_ok)))
                    raise _DiagnosticsOverflow(first + n_ok, float(problem.t[first + n_ok]))
                on_chunk(part)

            try:
                result = runner(problem, **options, on_chunk=emit)
            except _DiagnosticsOverflow as exc:
                result = RunResult(
                    np.empty((0, 8)), _rk.NONFINITE, _OVERFLOW_MESSAGE, first=exc.n,
                    t_stop=exc.t,
                )  # fmt: skip
        elif form is None:
            result = runner(problem, **options)
        else:
            # The formulation converts the canonical initial state to its own variables,
            # integrates its equations with the same method, and converts the samples back.
            result = form.run(problem, method=method, runner=runner, **options)
        if bar is not None:  # methods that do not report (scipy) complete the bar here
            bar(result.first + result.y.shape[0], tt.shape[0], math.nan)
    finally:
        if compiling is not None:
            compiling.close()
        if bar is not None:
            bar.close()

    attrs: dict[str, Any] = {
        **run_attrs,
        "method": method,
        **({"method_requested": requested} if requested != method else {}),
        "formulation": formulation,
        "initial_projection": float(correction),
        **{k: (np.int64(v) if isinstance(v, int) else v) for k, v in result.stats.items()},
    }
    if arrays:
        ds = Trajectory(tt[: result.y.shape[0]], result.y[:, :4], result.y[:, 4:8], attrs)
    elif streaming and result.status == _rk.NONFINITE and result.message == _OVERFLOW_MESSAGE:
        ds = finish_dataset(problem, result.y, attrs, first=result.first)
    else:
        ds, n_ok = _finish(problem, result.y, attrs, first=result.first, t_last=result.t_event)
        if n_ok is not None:  # a finite state whose energy or rates overflow: fail there
            ds = ds.isel(time=slice(0, n_ok))
            result = RunResult(
                result.y[:n_ok], _rk.NONFINITE, _OVERFLOW_MESSAGE, result.stats,
                first=result.first, t_stop=float(tt[result.first + n_ok]), events=result.events,
            )  # fmt: skip
    if on_chunk is not None and not streaming:  # hand the finished samples out in chunks
        for i in range(0, ds.sizes["time"], int(chunk)):
            on_chunk(ds.isel(time=slice(i, i + int(chunk))))
    if evset is not None:
        ds = add_event_variables(ds, evset, result.events, problem.body, result.status)
    if sc_run is not None and sc_run.program is not None:
        ds = add_tick_variables(ds, sc_run)  # (streamed: on the last sample's Dataset)
    if result.status not in (_rk.SUCCESS, _rk.EVENT):
        n = result.first + result.y.shape[0]
        t_fail = result.t_stop
        if t_fail is None:
            t_fail = float(tt[n - 1]) if n else float(tt[0])
        raise PropagationError(
            f"propagation stopped at t = {t_fail!r}: {result.message} "
            f"({n} of {tt.shape[0]} output samples computed"
            + (", passed on chunk by chunk)" if streaming else "; the error's partial holds them)"),
            time=t_fail,
            partial=ds,
        )
    return ds


def _check_memory(limit: Any, n: int, sc_run: Any, streaming: bool, can_stream: bool) -> None:
    """Refuse a run whose result in memory would exceed ``max_output_size`` (before any
    work): the samples unless streamed, the tick records unless streamed."""
    from ._memory import check_run_memory, default_memory_limit, parse_size

    if isinstance(limit, str) and limit.strip().lower() == "auto":
        limit = default_memory_limit()
    else:
        limit = parse_size(limit, "max_output_size")
    prog = None if sc_run is None else sc_run.program
    width = 8 if sc_run is None else sc_run.n_state + sc_run.n_rec
    check_run_memory(
        limit,
        0 if streaming else n,
        width,
        0 if (prog is None or streaming) else prog.n_recorded,
        0 if prog is None else prog.rec_width,
        every=None if prog is None else prog.record_every,
        streamable=can_stream,
    )


def _spacecraft_runner(
    craft: Spacecraft, method: str, formulation: Any, events: Any, output: str, pot: Potential
) -> Callable[..., RunResult]:
    """The runner of a spacecraft with actuators (the methods that integrate the gyrostat)."""
    from . import _holds

    if formulation != "canonical":
        raise AttitudeValueError(
            f"formulation: a spacecraft with actuators is integrated in canonical variables "
            f"(q, Q, h); got formulation={formulation!r}"
        )
    if method not in _holds.SPACECRAFT_METHODS:
        raise AttitudeValueError(
            f"method: a spacecraft with actuators (a gyrostat driven by held commands) is "
            f"integrated by {', '.join(repr(m) for m in _holds.SPACECRAFT_METHODS)}; "
            f"{method!r} does not model wheels, magnetorquers or thrusters"
        )
    if events is not None:
        raise AttitudeValueError(
            "events: not located yet for a spacecraft with actuators; run without events"
        )
    if output != "dataset":
        raise AttitudeValueError(
            "output: a spacecraft with actuators returns the Dataset (its wheel states and "
            "commands are in it); use output='dataset'"
        )
    if method == "taylor":
        _holds.check_taylor(craft, pot)
        return _holds.run_taylor
    return _holds.run_dop853


def _entry_points(pot: Potential, evset: Any, sc_run: Any = None) -> Any:
    """The compiled entry points of the model, of the user's event functions and of the user's
    compiled flight-software step."""
    user_events = () if evset is None else tuple(evset.user_functions)
    step = None if sc_run is None or sc_run.program is None else sc_run.program.compiled_step
    if not user_events and step is None:
        return pot._entry_points(closed_loop=sc_run is not None and sc_run.program is not None)
    from . import _user_kernels

    return _user_kernels.entry_points(pot._user_terms(), user_events, step=step, potential=pot)


#: Methods that locate events (inside their compiled loops).
EVENT_METHODS = ("dop853", "nosquish", "splitting")


def _events(events: Any, t: np.ndarray, method: str, formulation: str, run_attrs: dict) -> Any:
    """The validated events of the run (attitude.events.build); the run's epoch if they bring
    one."""
    from orbit.timescales import as_epoch, format_epoch

    from .events import build

    if method not in EVENT_METHODS or formulation != "canonical":
        raise AttitudeValueError(
            f"events: located by the methods {', '.join(EVENT_METHODS)} on the canonical "
            f"equations; got method={method!r}, formulation={formulation!r}"
        )
    e = run_attrs.get("epoch")
    evset = build(events, t, as_epoch(e.rstrip("Z")) if e else None)
    if evset.epoch is not None and not e:
        run_attrs["epoch"] = format_epoch(evset.epoch)
    run_attrs["events"] = evset.describe()
    return evset


def _epoch_attrs(pot: Potential, epoch: Any) -> dict[str, Any]:
    """Attrs ``epoch`` (UTC ISO 8601) and the orbit's description; checks the epochs agree."""
    from orbit.errors import OrbitError
    from orbit.timescales import as_epoch, format_epoch, same_epoch

    try:
        run_epoch = as_epoch(epoch, "epoch")
    except OrbitError as exc:
        raise AttitudeValueError(str(exc)) from None
    orbit = getattr(pot, "orbit", None)
    orbit_epoch = getattr(orbit, "epoch", None)
    if run_epoch is not None and orbit_epoch is not None and not same_epoch(run_epoch, orbit_epoch):
        raise AttitudeValueError(
            f"epoch: the run's epoch {format_epoch(run_epoch)} differs from the orbit's epoch "
            f"{format_epoch(orbit_epoch)} (potential.orbit.epoch); one run has one time origin: "
            "leave epoch=None to use the orbit's, or build the orbit with the same epoch"
        )
    out: dict[str, Any] = {}
    e = run_epoch if run_epoch is not None else orbit_epoch
    if e is not None:
        out["epoch"] = format_epoch(e)
    if orbit is not None and hasattr(orbit, "describe"):
        out["orbit"] = orbit.describe()
        out["orbit_frame"] = str(getattr(orbit, "frame", ""))
    return out


def _check_initial_state(problem: Problem) -> None:
    """Refuse an initial state whose body rates or kinetic energy overflow, before any work
    (|Q0| ≈ 1e160 is a finite number; its energy is not). Plain floats: a few µs.

    (A torque that is not finite at t0 ends the run at t0 with a PropagationError.)"""
    q0, q1, q2, q3, p0, p1, p2, p3 = problem.y0[:8].tolist()
    i1, i2, i3 = problem.params[:3].tolist()
    # g = ½ vec(q̃∘Q), ω = g / I, T = ½ g·ω (attitude._core.dynamics.diagnostics_row)
    g1 = 0.5 * (q0 * p1 - q1 * p0 - q2 * p3 + q3 * p2)
    g2 = 0.5 * (q0 * p2 + q1 * p3 - q2 * p0 - q3 * p1)
    g3 = 0.5 * (q0 * p3 - q1 * p2 + q2 * p1 - q3 * p0)
    w1, w2, w3 = g1 / i1, g2 / i2, g3 / i3
    if not math.isfinite(g1 * w1 + g2 * w2 + g3 * w3 + w1 * w1 + w2 * w2 + w3 * w3):
        raise AttitudeValueError(
            f"Q0: the body rates or kinetic energy of this initial state overflow double "
            f"precision (largest |Q0| component {max(abs(p0), abs(p1), abs(p2), abs(p3)):.3g}, "
            f"inertia {problem.body.inertia.tolist()}); no run can represent it"
        )

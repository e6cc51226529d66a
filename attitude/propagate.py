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
from collections.abc import Callable
from typing import Any

import xarray as xr

# The pipeline's names importable here, as before it was split out (attitude._run):
from ._methods import Problem, RunResult
from ._progress import ProgressBar as _ProgressBar  # noqa: F401
from ._run import results as _results
from ._run import runner as _runner
from ._run.plan import AUTO, METHODS, choose_method
from ._run.plan import EVENT_METHODS as EVENT_METHODS
from ._run.plan import lookup_method as _lookup_method  # noqa: F401
from ._run.results import _finite_prefix as _finite_prefix
from ._run.spec import MAX_UNSTREAMED_SAMPLES as MAX_UNSTREAMED_SAMPLES
from ._run.spec import PROGRESS_CHUNKS as PROGRESS_CHUNKS
from ._run.spec import PROJECTION_WARN as PROJECTION_WARN
from ._run.spec import RunSpec
from ._validation import ATOL_MIN as ATOL_MIN
from .body import RigidBody
from .potentials import Potential
from .results import Trajectory

__all__ = ["AUTO", "METHODS", "Problem", "RunResult", "choose_method", "propagate"]


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
        ``"nosquish"``, ``"splitting"``, ``"taylor"`` (built-in potentials). A spacecraft
        carrying its orbit (a mass on a ``NumericalOrbit``) without actuators, in its
        ``GravityGradient`` around a point-mass Earth, also runs ``"splitting"`` and
        ``"nosquish"`` (orbit and attitude split into exact Kepler and free flows and kicks:
        docs/integrators.md).
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
    spec = RunSpec.single(
        body, q0, Q0, t, potential, method, rtol, atol, dt, order, max_step=max_step,
        max_steps=max_steps, progress=progress, chunk=chunk, formulation=formulation,
        on_chunk=on_chunk, epoch=epoch, events=events, output=output, commands=commands,
        software=software, max_output_size=max_output_size,
    )  # fmt: skip
    return _results.build(spec, _runner.run(spec))

"""The run specification: every input of a run validated once, before any work.

:meth:`RunSpec.single` checks the arguments of :func:`attitude.propagate` in one place (the
errors name the argument; the same classes and messages as ever), asks the planner
(:mod:`attitude._run.plan`) for the method and the runner, prepares the model for the run's
span and lays the run out as the plain-float :class:`~attitude._methods.Problem` the runners
take. The checks an ensemble shares with a single run (the tolerances, the epoch, the model's
span, the initial state's projection) are the functions here that
:mod:`attitude.ensemble._spec` calls too.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._methods import Problem
from .._validation import as_atol, as_float_array, as_int, as_positive, as_rtol, as_times
from ..body import RigidBody
from ..canonical import _project
from ..errors import AttitudeTypeError, AttitudeValueError
from ..formulations import Formulation, get_formulation
from ..potentials import Potential, as_potential
from ..spacecraft import Spacecraft
from . import plan as _plan

__all__ = [
    "MAX_UNSTREAMED_SAMPLES",
    "PROGRESS_CHUNKS",
    "PROJECTION_WARN",
    "RunSpec",
    "check_steps",
    "epoch_attrs",
    "for_span",
]

#: Relative defect of the initial state above which a projection warns.
PROJECTION_WARN = 1e-12
#: Progress reports per run (the default chunk with ``progress``): the compiled loop returns
#: this often; results do not depend on it (dense output at the requested times).
PROGRESS_CHUNKS = 200
#: Largest number of output samples that is computed in memory before being handed to
#: ``on_chunk`` by the methods that do not stream (the non-canonical formulations): ~170 bytes
#: a sample, 0.34 GB at the limit.
MAX_UNSTREAMED_SAMPLES = 2_000_000
#: Output samples per ``on_chunk`` call unless ``chunk`` says otherwise.
STREAM_CHUNK = 4096


@dataclass
class RunSpec:
    """A validated single run: what the runner integrates and the results builder reports."""

    problem: Problem  # body, prepared potential, parameters, y0, t, entry points, events, craft
    plan: _plan.Plan  # method, runner, formulation, streaming
    options: dict[str, Any]  # the runner's options (tolerances, steps, progress, chunk)
    attrs: dict[str, Any]  # the run's attrs: epoch, orbit, events, spacecraft, software
    correction: float  # the initial state's projection
    formulation: Any = "canonical"  # as given (a name or a Formulation)
    on_chunk: Callable | None = None
    arrays: bool = False  # output="arrays": a Trajectory

    @classmethod
    def single(cls, body: Any, q0: Any, Q0: Any, t: Any, potential: Any, method: str,
               rtol: Any, atol: Any, dt: Any, order: Any, *, max_step: Any, max_steps: Any,
               progress: Any, chunk: Any, formulation: Any, on_chunk: Any, epoch: Any,
               events: Any, output: Any, commands: Any, software: Any,
               max_output_size: Any) -> RunSpec:  # fmt: skip
        """The run of :func:`attitude.propagate` with these arguments (its parameters),
        validated; AttitudeValueError/AttitudeTypeError naming the argument otherwise."""
        if not isinstance(output, str) or output not in ("dataset", "arrays"):
            raise AttitudeValueError(f"output: expected 'dataset' or 'arrays', got {output!r}")
        arrays = output == "arrays"
        if arrays and (events is not None or on_chunk is not None):
            raise AttitudeValueError(
                "output: 'arrays' returns the states only; events and on_chunk need the "
                "Dataset (output='dataset')"
            )
        craft = (
            body if isinstance(body, Spacecraft) and (body.has_actuators or body.coupled) else None
        )
        if software is not None and craft is None:
            craft = body if isinstance(body, Spacecraft) else Spacecraft(body)
        body = body.body if isinstance(body, Spacecraft) else body
        body = body if isinstance(body, RigidBody) else RigidBody(body)
        pot = as_potential(potential).bind(body)
        plan = _plan.pick(method, pot, craft, formulation, events, output, software)
        method = plan.method
        if craft is None and commands is not None:
            raise AttitudeValueError(
                "commands: a CommandSchedule drives the actuators of an attitude.Spacecraft; "
                "this body has none (give Spacecraft(body, wheels=..., magnetorquers=..., "
                "thrusters=...))"
            )
        if not isinstance(formulation, (str, Formulation)):
            raise AttitudeTypeError(
                f"formulation: expected a name such as 'canonical' or a Formulation, got "
                f"{type(formulation).__name__}"
            )
        if formulation != "canonical":
            plan.form = get_formulation(formulation, method)
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
        max_step, max_steps = check_steps(max_step, max_steps)
        if chunk is not None:
            chunk = as_int(chunk, "chunk")
        if progress is False:
            progress = None
        if progress is not None and progress is not True and not callable(progress):
            raise AttitudeTypeError(
                "progress: expected True (a progress bar) or a callable "
                "progress(n_done, n_total, t)"
            )
        if on_chunk is not None and not callable(on_chunk):
            raise AttitudeTypeError("on_chunk: expected a callable on_chunk(ds_chunk)")
        attrs = epoch_attrs(
            pot, epoch, craft.orbit if craft is not None and craft.coupled else None
        )
        if craft is not None and craft.coupled:
            # the NumericalOrbit's own integrator gives only the start and the environment
            # tables: the run integrates the orbit with the attitude, by its own method
            attrs["orbit"] = (
                f"numerical orbit: {craft.orbit._forces.describe()}, propagated with the "
                f"attitude by the run's method ({method})"
            )
            attrs["orbit_frame"] = "GCRS"  # (position and velocity's reference_frame)
            # what `attitude info` needs for the orbital energy of the samples (a semi-major
            # axis that J2's short-period terms do not move)
            field = craft.orbit.gravity
            attrs["orbit_gm"] = craft.orbit._forces.mu
            attrs["orbit_gm_units"] = "m3 s-2"
            attrs["orbit_j2"] = 0.0 if field is None else field.j2
            attrs["orbit_reference_radius"] = 0.0 if field is None else field.radius
            attrs["orbit_reference_radius_units"] = "m"
            if method == "dop853" and craft.orbit.perturbed and craft.orbit.field_step > 0.0:
                # (attitude._core.coupled: sampled where the steps are short, exact elsewhere)
                attrs["orbit"] += (
                    f", the field beyond the point mass sampled every "
                    f"{craft.orbit.field_step:g} s where the steps are shorter"
                )
        span = np.array([tt[0], tt[-1]], dtype=np.float64)  # only the ends matter to models
        pot = for_span(pot, span)
        evset = None
        if events is not None:
            tt = np.asarray(tt)  # events need the samples (no lazy grid)
            evset = _events(events, tt, method, formulation, attrs)
        can_stream = plan.form is None and evset is None and getattr(plan.runner, "streams", False)
        plan.streaming = on_chunk is not None and can_stream
        if on_chunk is not None and not plan.streaming and tt.shape[0] > MAX_UNSTREAMED_SAMPLES:
            raise AttitudeValueError(
                f"t: {tt.shape[0]} output samples with method {method!r} and formulation "
                f"{formulation!r}, which are computed in memory before they are handed out "
                f"(at most {MAX_UNSTREAMED_SAMPLES} samples); use formulation='canonical' "
                "without events (streamed), or fewer samples"
            )
        if not (plan.streaming or isinstance(tt, np.ndarray)):
            tt = np.asarray(tt)
        if progress is not None and chunk is None:  # report during the run, not at the end
            chunk = max(1, -(-tt.shape[0] // PROGRESS_CHUNKS))
        if on_chunk is not None and chunk is None:
            chunk = STREAM_CHUNK
        q0p, Q0p, correction = _project(q0a, Q0a)  # q0a, Q0a validated above
        if correction > PROJECTION_WARN:
            warnings.warn(
                f"initial state projected onto |q| = 1, q·Q = 0 (correction {correction:.2g})",
                stacklevel=3,
            )
        y0 = np.concatenate([q0p, Q0p])
        sc_run = None
        if craft is not None:
            from .. import _holds

            craft.check_orbit(getattr(pot, "orbit", None))
            # (the software's period, phase and ticks against the span: check_software_span)
            sc_run, y0 = _holds.prepare(
                craft, q0p, Q0p, span, commands, software, max_steps, samples=tt
            )
            attrs["spacecraft"] = craft.describe()
            if software is not None:
                attrs["software"] = software.describe()
        _plan.check_memory(max_output_size, tt.shape[0], sc_run, plan.streaming, can_stream)
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
        if sc_run is not None and sc_run.coupled:
            from .. import _coupling

            sc_run.sc = _coupling.follow_path(sc_run.sc, getattr(pot, "orbit", None))
            _coupling.attach(problem.params, sc_run.sc, craft, _coupling.orbit_tokens(craft, pot))
            if evset is not None:  # (built for this run: its data is its own)
                _coupling.attach_events(
                    evset.data, sc_run.sc, craft, _coupling.orbit_tokens(craft, pot)
                )
        _check_initial_state(problem)
        if method == "dop853" or method.startswith("scipy:"):
            # the fixed-step methods count their steps themselves; "exact" takes none
            span_len = abs(float(tt[tt.shape[0] - 1]) - float(tt[0]))
            if span_len > 0.0:
                _plan.check_max_step(span_len, max_step, max_steps)
        options = dict(
            rtol=rtol, atol=atol, dt=dt, order=int(order), max_step=max_step,
            max_steps=int(max_steps), progress=progress, chunk=chunk, **plan.extra,
        )  # fmt: skip
        return cls(problem, plan, options, attrs, float(correction), formulation, on_chunk, arrays)


def check_steps(max_step: Any, max_steps: Any) -> tuple[float, int]:
    """``max_step`` (positive, inf allowed) and ``max_steps`` (a positive integer)."""
    return as_positive(max_step, "max_step", allow_inf=True), as_int(max_steps, "max_steps")


def for_span(pot: Potential, span: np.ndarray) -> Potential:
    """The model checked against the run's times (e.g. an ephemeris orbit's table span) and
    prepared for them (environment tables along the orbit)."""
    try:
        pot.check_times(span, "t")
    except ValueError as exc:
        raise AttitudeValueError(str(exc)) from None
    return pot.prepare(span)


def epoch_attrs(pot: Potential, epoch: Any, carried: Any = None) -> dict[str, Any]:
    """Attrs ``epoch`` (UTC ISO 8601) and the orbit's description; checks the epochs agree
    (the model's orbit's, and ``carried``, the orbit a spacecraft propagates with its
    attitude: one run has one time origin)."""
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
    e = run_epoch if run_epoch is not None else orbit_epoch
    if carried is not None:
        if e is not None and not same_epoch(e, carried.epoch):
            which = "the run's epoch" if run_epoch is not None else "the potential's orbit's epoch"
            raise AttitudeValueError(
                f"epoch: {which} {format_epoch(e)} differs from the epoch "
                f"{format_epoch(carried.epoch)} of the orbit the spacecraft carries "
                "(spacecraft.orbit.epoch); one run has one time origin: leave epoch=None and "
                "build the orbits with the same epoch"
            )
        e = carried.epoch
    out: dict[str, Any] = {}
    if e is not None:
        out["epoch"] = format_epoch(e)
    if orbit is not None and hasattr(orbit, "describe"):
        out["orbit"] = orbit.describe()
        out["orbit_frame"] = str(getattr(orbit, "frame", ""))
    return out


def _entry_points(pot: Potential, evset: Any, sc_run: Any = None) -> Any:
    """The compiled entry points of the model, of the user's event functions and of the user's
    compiled flight-software step."""
    user_events = () if evset is None else tuple(evset.user_functions)
    step = None if sc_run is None or sc_run.program is None else sc_run.program.compiled_step
    if not user_events and step is None:
        generic = sc_run is not None and (sc_run.program is not None or sc_run.coupled)
        return pot._entry_points(closed_loop=generic)
    from .. import _user_kernels

    return _user_kernels.entry_points(pot._user_terms(), user_events, step=step, potential=pot)


def _events(events: Any, t: np.ndarray, method: str, formulation: str, run_attrs: dict) -> Any:
    """The validated events of the run (attitude.events.build); the run's epoch if they bring
    one."""
    from orbit.timescales import as_epoch, format_epoch

    from ..events import build

    if method not in _plan.EVENT_METHODS or formulation != "canonical":
        raise AttitudeValueError(
            f"events: located by the methods {', '.join(_plan.EVENT_METHODS)} on the canonical "
            f"equations; got method={method!r}, formulation={formulation!r}"
        )
    e = run_attrs.get("epoch")
    evset = build(events, t, as_epoch(e.rstrip("Z")) if e else None)
    if evset.epoch is not None and not e:
        run_attrs["epoch"] = format_epoch(evset.epoch)
    run_attrs["events"] = evset.describe()
    return evset


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

"""The planner: which method integrates a run and which driver runs it, and whether its result
fits in memory.

:data:`METHODS` maps each method name to its runner (:mod:`attitude._methods` says what a
runner is); :func:`choose_method` resolves ``"auto"`` for a single run, :func:`ensemble_method`
for the members of an ensemble (one method for all of them); :func:`pick` gives the runner of a
single run (the gyrostat drivers of :mod:`attitude._holds` for a spacecraft with actuators or
flight software); :func:`check_memory` and :func:`check_max_step` refuse, before any work, a run
that cannot fit or finish.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from .._methods import SCIPY_SOLVERS, RunResult, run_dop853, run_scipy
from ..errors import AttitudeTypeError, AttitudeValueError
from ..exact import run_exact
from ..splitting import run_nosquish, run_splitting
from ..taylor import run_taylor

__all__ = [
    "AUTO",
    "EVENT_METHODS",
    "METHODS",
    "Plan",
    "check_max_step",
    "check_memory",
    "choose_method",
    "ensemble_method",
    "lookup_method",
    "pick",
]

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

#: Methods that locate events (inside their compiled loops).
EVENT_METHODS = ("dop853", "nosquish", "splitting")


@dataclass
class Plan:
    """How a single run is integrated: the method (and the one asked for), its runner and the
    runner's extra options, the formulation object (None: canonical), whether the samples are
    streamed to ``on_chunk`` as they are computed."""

    requested: str
    method: str
    runner: Callable[..., RunResult]
    extra: dict[str, Any] = field(default_factory=dict)
    form: Any = None
    streaming: bool = False


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
            from .._holds import check_taylor

            check_taylor(spacecraft, potential)
        else:
            from ..taylor import check_potential

            check_potential(potential)
    except AttitudeValueError:
        return "dop853"
    return "taylor"


def ensemble_method(method: str, potentials: Any, *, crafts: Any = None, events: Any = None) -> str:
    """The one method of every member of an ensemble: ``"auto"`` is ``"taylor"`` when every
    member's single run would pick it (:func:`choose_method` with its potential and its
    spacecraft), else ``"dop853"``; a rigid-body ensemble's ``"taylor"`` is checked here
    (built-in potentials it expands, no events, as ``propagate``), a spacecraft's by the
    preparation of each member (:func:`attitude._holds.check_taylor`)."""
    if method == AUTO:
        for p in potentials:
            for c in crafts if crafts is not None else (None,):
                if choose_method(AUTO, p, spacecraft=c, events=events) != "taylor":
                    return "dop853"
        return "taylor"
    if method == "taylor" and events is not None:
        raise AttitudeValueError(
            "events: method='taylor' does not locate events (neither does "
            "propagate(method='taylor')); use method='dop853' for an ensemble with events"
        )
    if method != "taylor" or crafts is not None:
        return method
    from ..taylor import check_potential

    for p in potentials:
        check_potential(p)
    return method


def lookup_method(method: str) -> tuple[Callable[..., RunResult], dict[str, Any]]:
    """The runner of ``method`` and its extra options (the solver of ``"scipy:<name>"``)."""
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


def pick(
    method: str,
    potential: Any,
    craft: Any,
    formulation: Any,
    events: Any,
    output: str,
    software: Any = None,
) -> Plan:
    """The method and runner of a single run (``craft``: the spacecraft with actuators, flight
    software or its orbit in the state, else None); the formulation and streaming are filled
    in later."""
    requested = method
    method = choose_method(
        method, potential, spacecraft=craft, formulation=formulation, events=events
    )
    runner, extra = lookup_method(method)
    if craft is not None:
        runner = _spacecraft_runner(craft, method, formulation, events, output, potential, software)
    return Plan(requested, method, runner, extra)


def _spacecraft_runner(
    craft: Any, method: str, formulation: Any, events: Any, output: str, pot: Any, software: Any
) -> Callable[..., RunResult]:
    """The runner of a spacecraft with actuators (the methods that integrate the gyrostat), or
    carrying its orbit (those and, for a rigid body in its gravity gradient around a point
    mass, the splittings)."""
    from .. import _coupled_splitting, _holds

    if formulation != "canonical":
        raise AttitudeValueError(
            f"formulation: a spacecraft with actuators is integrated in canonical variables "
            f"(q, Q, h); got formulation={formulation!r}"
        )
    fixed_step = craft.coupled and method in _coupled_splitting.METHODS
    if method not in _holds.SPACECRAFT_METHODS and not fixed_step:
        methods = ", ".join(repr(m) for m in _holds.SPACECRAFT_METHODS)
        if craft.coupled and not craft.has_actuators:
            raise AttitudeValueError(
                f"method: a spacecraft carrying its orbit (mass= and a NumericalOrbit) is "
                f"integrated by {methods}, and for a rigid body in its gravity gradient around a "
                f"point-mass Earth also by 'splitting' and 'nosquish'; {method!r} does not "
                "carry the orbit"
            )
        also = ""
        if method in _coupled_splitting.METHODS:
            also = (
                " (a rigid body without actuators carrying its orbit, mass= and a "
                "NumericalOrbit, also by 'splitting' and 'nosquish')"
            )
        raise AttitudeValueError(
            f"method: a spacecraft with actuators (a gyrostat driven by held commands) is "
            f"integrated by {methods}{also}; "
            f"{method!r} does not model wheels, magnetorquers or thrusters"
        )
    if events is not None and method != "dop853":
        raise AttitudeValueError(
            f"events: a spacecraft with actuators or carrying its orbit has its events located "
            f"by method='dop853' (on the dense output of each step between command "
            f"boundaries); got method={method!r}"
        )
    if output != "dataset":
        raise AttitudeValueError(
            "output: a spacecraft with actuators returns the Dataset (its wheel states and "
            "commands are in it); use output='dataset'"
        )
    if fixed_step:
        _coupled_splitting.check_spacecraft(craft, pot, method, software)
        if method == "splitting":
            return _coupled_splitting.run_splitting
        return _coupled_splitting.run_nosquish
    if method == "taylor":
        _holds.check_taylor(craft, pot)
        if craft.coupled:
            from .._coupled_taylor import run_taylor

            return run_taylor
        return _holds.run_taylor
    return _holds.run_dop853


def check_max_step(span: float, max_step: float, max_steps: int) -> None:
    """Steps are at most ``max_step`` long: more than ``max_steps`` of them is certain failure."""
    if span / max_step > max_steps:
        raise AttitudeValueError(
            f"max_step: {max_step!r} over the time span {span:g} means at least "
            f"{span / max_step:.3g} steps, more than max_steps = {max_steps}: the run cannot "
            "finish; raise max_step (or max_steps)"
        )


def check_memory(limit: Any, n: int, sc_run: Any, streaming: bool, can_stream: bool) -> None:
    """Refuse a single run whose result in memory would exceed ``max_output_size`` (before any
    work): the samples unless streamed, the tick records unless streamed."""
    from .._memory import check_run_memory, default_memory_limit, parse_size

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

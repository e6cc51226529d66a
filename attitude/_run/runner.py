"""The runner: a validated run (:class:`~attitude._run.spec.RunSpec`) through its method.

It adds what a run needs around the method's runner: a progress bar (``progress=True``), the
notice of a first closed-loop run's compilation, the streaming of the samples (and the flight
software's tick records) to ``on_chunk`` as they are computed, and a formulation's own
variables; it returns the runner's :class:`~attitude._methods.RunResult`.
"""

from __future__ import annotations

import math

import numpy as np

from orbit import _rk

from .. import _compiling
from .._methods import RunResult
from .._progress import ProgressBar
from .._spacecraft_results import tick_dataset
from .results import _OVERFLOW_MESSAGE, _DiagnosticsOverflow, _finish, samples_kernels
from .spec import RunSpec

__all__ = ["run"]


def run(spec: RunSpec) -> RunResult:
    """Integrate ``spec``'s problem with its plan's runner (streamed to ``spec.on_chunk`` when
    the plan streams)."""
    problem, plan, options = spec.problem, spec.plan, dict(spec.options)
    n = problem.t.shape[0]
    bar = ProgressBar(n) if options["progress"] is True else None
    if bar is not None:
        options["progress"] = bar
    # the first closed-loop run compiles for most of a minute: said before, and how long after
    compiling = _compiling.watch(options["progress"], problem, plan.method)
    if compiling is not None:
        options["progress"] = compiling
    if problem.spacecraft is None:  # the diagnostics compile in a second process meanwhile
        _compiling.open_loop_helper(problem.entry.samples, lambda: samples_kernels(problem))
    try:
        if plan.streaming:
            result = _streamed(spec, options)
        elif plan.form is None:
            result = plan.runner(problem, **options)
        else:
            # The formulation converts the canonical initial state to its own variables,
            # integrates its equations with the same method, and converts the samples back.
            result = plan.form.run(problem, method=plan.method, runner=plan.runner, **options)
        if bar is not None:  # methods that do not report (scipy) complete the bar here
            bar(result.first + result.y.shape[0], n, math.nan)
    finally:
        if compiling is not None:
            compiling.close()
        if bar is not None:
            bar.close()
    return result


def chunk_attrs(spec: RunSpec) -> dict:
    """The attrs of a streamed chunk: the run's, the method and the formulation."""
    plan = spec.plan
    a = {"method": plan.method, "formulation": spec.formulation, **spec.attrs}
    if plan.requested != plan.method:
        a["method_requested"] = plan.requested
    return a


def _streamed(spec: RunSpec, options: dict) -> RunResult:
    """The run with its samples handed to ``on_chunk`` chunk by chunk as they are computed."""
    problem, on_chunk = spec.problem, spec.on_chunk
    attrs = chunk_attrs(spec)
    sc_run = problem.spacecraft
    if sc_run is not None and sc_run.program is not None:
        sc_run.tick_sink = lambda rec: on_chunk(tick_dataset(sc_run, rec, attrs))

    def emit(first: int, y: np.ndarray, t_last: float | None = None) -> None:
        part, n_ok = _finish(problem, y, attrs, first=first, t_last=t_last)
        if n_ok is not None:  # the diagnostics overflowed: hand out the rows before
            if n_ok:
                on_chunk(part.isel(time=slice(0, n_ok)))
            raise _DiagnosticsOverflow(first + n_ok, float(problem.t[first + n_ok]))
        on_chunk(part)

    try:
        return spec.plan.runner(problem, **options, on_chunk=emit)
    except _DiagnosticsOverflow as exc:
        return RunResult(
            np.empty((0, 8)), _rk.NONFINITE, _OVERFLOW_MESSAGE, first=exc.n, t_stop=exc.t
        )

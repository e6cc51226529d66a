"""The ensemble's run specification: every argument of :func:`propagate_ensemble` validated
once, before any work and before anything is written.

An ensemble is N runs that differ in a few fields (the initial state; the body or spacecraft;
the potential, commands or software). :meth:`EnsembleSpec.build` checks what every member
shares with the single-run checks of :mod:`attitude._run.spec` (the tolerances, the steps, the
epoch, the model's span), the output choice (:mod:`._plan`), then the members: rows of rigid
bodies (:class:`~._members._Members`) or spacecraft with actuators or flight software, each
prepared as its single run (:class:`~._members.CraftMembers`). The method of all members is the
planner's (:func:`attitude._run.plan.ensemble_method`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._run.plan import AUTO, check_max_step, ensemble_method
from .._run.spec import check_steps, epoch_attrs, for_span
from .._validation import as_atol, as_float_array, as_int, as_positive, as_rtol, as_times
from ..errors import AttitudeFileError, AttitudeTypeError, AttitudeValueError
from ..io import check_attrs
from ..potentials import Potential
from . import _dask, _plan
from ._chunks import _N_DIAG
from ._members import (
    CraftMembers,
    _body_units,
    _member_inertia,
    _member_potentials,
    _member_states,
    _Members,
    _one_or_list,
    as_crafts,
    check_states,
    is_spacecraft_ensemble,
)

__all__ = ["ENSEMBLE_METHODS", "EnsembleSpec"]

#: The methods of the compiled ensemble loops.
ENSEMBLE_METHODS = ("dop853", "taylor")

#: Arguments of propagate_ensemble the spacecraft ensembles do not take (yet), and why.
_NOT_FOR_SPACECRAFT = {
    "client": "Dask clusters run rigid-body ensembles only; run it locally (client=None)",
    "lazy": "a lazy Dask result is for rigid-body ensembles; run it eagerly (lazy=False)",
    "nominal": "the pointing error of a spacecraft ensemble is the flight software's "
    "(error_angle per tick, from its guidance); attitude.ensemble.error_angle_percentiles",
    "reference": "the pointing error of a spacecraft ensemble is the flight software's "
    "(error_angle per tick); attitude.ensemble.error_angle_percentiles",
    "boresight": "only with output='statistics' of rigid-body ensembles",
}


@dataclass
class EnsembleSpec:
    """A validated ensemble: what the runner (:mod:`._runner`) computes and assembles."""

    requested: str
    method: str
    t: np.ndarray  # the output times
    plan: _plan._Plan  # what is stored, the compiled loop's time grid, the size limit
    rtol: float
    atol: float
    max_step: float
    max_steps: int
    members: Any  # _Members or CraftMembers
    potential: Any  # the potential (member 0's when per member)
    chunk_size: int | None = None
    threads: int | None = None
    progress: Any = None
    on_estimate: Any = None
    attrs: dict[str, Any] | None = None  # the caller's extra attrs
    run_attrs: dict[str, Any] = field(default_factory=dict)  # epoch, spacecraft, software...
    path: Any = None  # as given
    out_path: Any = None  # the checked output file, or None
    t_start: float = 0.0
    # rigid bodies only
    potentials: list | None = None  # per member, or None
    unit: str | None = None
    events: Any = None  # attitude.events.EventSet, or None
    client: Any = None
    timeout: float = 10.0
    lazy: bool = False
    nominal: Any = None
    reference: Any = None
    boresight: np.ndarray | None = None

    @property
    def spacecraft(self) -> bool:
        """Whether the members are spacecraft with actuators or flight software."""
        return isinstance(self.members, CraftMembers)

    @classmethod
    def build(cls, body: Any, q0: Any, Q0: Any, t: Any, potential: Any, method: Any, rtol: Any,
              atol: Any, *, max_step: Any, max_steps: Any, chunk_size: Any, path: Any,
              client: Any, threads: Any, progress: Any, scheduler_timeout: Any, attrs: Any,
              lazy: Any, events: Any, epoch: Any, output: Any, every: Any, percentiles: Any,
              nominal: Any, reference: Any, boresight: Any, max_output_size: Any,
              on_estimate: Any, commands: Any, software: Any, seed: Any, _source: Any,
              _member_vars: Any) -> EnsembleSpec:  # fmt: skip
        """The ensemble of :func:`propagate_ensemble` with these arguments (its parameters),
        validated; AttitudeValueError/AttitudeTypeError naming the argument otherwise."""
        t_start = time.perf_counter()
        if not isinstance(method, str) or method not in (*ENSEMBLE_METHODS, AUTO):
            raise AttitudeValueError(
                f"method: propagate_ensemble runs {' or '.join(map(repr, ENSEMBLE_METHODS))} "
                f"(the compiled parallel loops; 'auto' picks one), got {method!r}; for other "
                f"methods loop over attitude.propagate"
            )
        tt = as_times(t, "t")
        rtol = as_rtol(rtol, "rtol")
        atol = as_atol(atol)
        max_step, max_steps = check_steps(max_step, max_steps)
        check_max_step(abs(float(tt[-1]) - float(tt[0])), max_step, max_steps)
        if chunk_size is not None:
            chunk_size = as_int(chunk_size, "chunk_size")
        if threads is not None:
            threads = _check_threads(threads)
        if progress is not None and not callable(progress):
            raise AttitudeTypeError(
                "progress: expected a callable progress(n_done, n_total, steps)"
            )
        if attrs is not None:
            if not isinstance(attrs, dict):
                raise AttitudeTypeError(f"attrs: expected a dict, got {type(attrs).__name__}")
            attrs = check_attrs(attrs, "attrs")  # what netCDF can store, before any work
        if scheduler_timeout is None:
            scheduler_timeout = _dask.SCHEDULER_TIMEOUT
        timeout = as_positive(scheduler_timeout, "scheduler_timeout")
        plan = _plan.make_plan(tt, output, every, percentiles, max_output_size)
        if on_estimate is not None and not callable(on_estimate):
            raise AttitudeTypeError("on_estimate: expected a callable on_estimate(nbytes)")
        spec = cls(
            method, method, tt, plan, rtol, atol, float(max_step), int(max_steps), None, None,
            chunk_size, threads, progress, on_estimate, attrs, path=path, t_start=t_start,
        )  # fmt: skip
        if _source is None and is_spacecraft_ensemble(body, commands, software):
            # spacecraft with actuators or flight software (docs/ensemble.md)
            refused = {"client": client, "lazy": lazy, "nominal": nominal,
                       "reference": reference, "boresight": boresight}  # fmt: skip
            for name, value in refused.items():
                if value is not None and value is not False:
                    raise AttitudeValueError(f"{name}: {_NOT_FOR_SPACECRAFT[name]}")
            spec._crafts(body, q0, Q0, potential, epoch, commands, software, seed, events)
            spec.members.extra_vars = _member_vars  # (start, stop) -> more per-member variables
            return spec
        if seed is not None:
            raise AttitudeValueError(
                "seed: the ensemble seed of noisy sensors, for members with flight software "
                "(software=); draw rigid-body members with attitude.ensemble.disperse(seed=...)"
            )
        spec.client, spec.timeout, spec.lazy = client, timeout, lazy
        spec.nominal, spec.reference = nominal, reference
        spec._reference(boresight)
        spec._bodies(body, q0, Q0, potential, events, epoch, _source)
        spec._output(path, client, lazy)
        return spec

    # -- rigid bodies ------------------------------------------------------------------------
    def _reference(self, boresight: Any) -> None:
        """The pointing reference and boresight of ``output="statistics"``."""
        nominal, reference = self.nominal, self.reference
        if nominal is not None and reference is not None:
            raise AttitudeValueError(
                "nominal, reference: give one of them (the pointing reference)"
            )
        if self.plan.output == "statistics":
            if nominal is None and reference is None:
                raise AttitudeValueError(
                    "nominal: output='statistics' measures the pointing error from one "
                    "reference for all members; give nominal=(q0, Q0) (the nominal initial "
                    "state, propagated once) or reference= (a propagate result on t, or "
                    "quaternions)"
                )
            if self.lazy:
                raise AttitudeValueError(
                    "lazy: output='statistics' is computed as the members finish; run it "
                    "eagerly (lazy=False)"
                )
        elif boresight is not None:
            raise AttitudeValueError("boresight: only with output='statistics'")
        if boresight is not None:
            bore = as_float_array(boresight, "boresight", trailing=3, ndim=1)
            if not float(np.linalg.norm(bore)) > 0:
                raise AttitudeValueError("boresight: the zero vector is not a direction")
            self.boresight = bore / float(np.linalg.norm(bore))

    def _bodies(self, body, q0, Q0, potential, events, epoch, source) -> None:
        """The rigid-body members (or a dispersion sampler's, already validated), the method
        and the events."""
        tt = self.t
        if source is None:
            q, Q, n = _member_states(q0, Q0, _body_units(body))
            inertia, unit = _member_inertia(body, n)
            if isinstance(potential, Potential):  # environment tables for this run's span
                potential = potential.prepare(tt)
            elif isinstance(potential, (list, tuple)):
                potential = [p.prepare(tt) if isinstance(p, Potential) else p for p in potential]
            pot, params, pots = _member_potentials(potential, n, inertia)
            members = _Members(q, Q, inertia, params, n)
            check_states(q, Q, n)
        else:  # a dispersion sampler (run_scenario): already validated
            members, unit, pot, pots = source
        self.members, self.unit, self.potential, self.potentials = members, unit, pot, pots
        every = pots if pots is not None else (pot,)
        self.method = ensemble_method(self.requested, every, events=events)
        # the epoch and the model's orbit with its frame, as a single run records them (an AEM
        # of a member is then labelled relative to the GCRS, not EME2000)
        self.run_attrs = epoch_attrs(pot, epoch)
        if events is not None:
            self.events = _events(events, tt, pot, epoch)

    def _output(self, path: Any, client: Any, lazy: Any) -> None:
        """The output file (checked: type, a directory or device, room on the disk) and the
        Dask options."""
        if path is not None:
            from .._files import OutputFile

            target = OutputFile(path, "path")
            if target.through:
                raise AttitudeFileError(
                    f"path: {target.path} is a pipe or a device; an ensemble's result is opened "
                    "from the file it was written to (members are read lazily from it), so it "
                    "needs a regular file: write there and copy it"
                )
            n, m = self.members.n, self.t.shape[0]
            target.check_space(float(n) * m * (8 + _N_DIAG) * 8, f"{n} members x {m} samples")
            self.out_path = target.path
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

    # -- spacecraft ----------------------------------------------------------------------------
    def _crafts(self, body, q0, Q0, potential, epoch, commands, software, seed, events) -> None:
        """The spacecraft members (each prepared as its single run), the method, the attrs."""
        from pathlib import Path

        from ..actuators.commands import CommandSchedule
        from ..potentials import as_potential
        from ..software import FlightSoftware

        tt, plan = self.t, self.plan
        if plan.output == "statistics":
            raise AttitudeValueError(
                "output: a spacecraft ensemble stores its members ('samples' or 'final'); take "
                "statistics afterwards (attitude.ensemble.error_angle_percentiles, "
                "settling_times)"
            )
        if tt.shape[0] > 1 and tt[-1] < tt[0]:
            raise AttitudeValueError(
                "t: a spacecraft with actuators is propagated forward in time (its commands "
                "are held from one time to the next); give increasing times"
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
                "commands: the flight software commands the actuators; give commands= (open "
                "loop) or software= (closed loop), not both"
            )
        if isinstance(potential, (list, tuple)):
            raise AttitudeValueError(
                "potential: a spacecraft ensemble runs one potential for all members (its "
                "environment tables are shared); disperse the spacecraft and software instead"
            )
        if potential is not None and not isinstance(potential, Potential):
            raise AttitudeTypeError(
                "potential: expected an attitude.potentials.Potential, got "
                f"{type(potential).__name__}"
            )
        check_states(q, Q, n)
        first = crafts[0] if isinstance(crafts, list) else crafts
        pot = as_potential(potential).bind(first.body)
        every = crafts if isinstance(crafts, list) else [crafts]
        self.method = method = ensemble_method(self.requested, (pot,), crafts=every, events=events)
        span = np.array([tt[0], tt[-1]], dtype=np.float64)
        run_attrs = epoch_attrs(pot, epoch, first.orbit if first.coupled else None)
        pot = for_span(pot, span)
        if events is not None:
            self.events = _events(events, tt, pot, epoch)
            run_attrs["events"] = self.events.describe()
            if self.events.epoch is not None and "epoch" not in run_attrs:
                from orbit.timescales import format_epoch

                run_attrs["epoch"] = format_epoch(self.events.epoch)
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
        members.events = self.events
        self.members, self.potential, self.run_attrs = members, pot, run_attrs
        self.out_path = None if self.path is None else Path(self.path)


def _max_threads() -> int:
    """The cores numba counts in this process (NUMBA_NUM_THREADS, fixed when numba starts)."""
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


def _check_threads(threads: Any) -> int:
    threads = as_int(threads, "threads")
    from orbit._shared_jit import JIT_DISABLED

    if not JIT_DISABLED and threads > _max_threads():
        raise AttitudeValueError(
            f"threads: at most {_max_threads()}, the cores of this process (NUMBA_NUM_THREADS): "
            f"members are compiled code, and more threads than cores only wait for each other; "
            f"got {threads}; give at most {_max_threads()}, or set NUMBA_NUM_THREADS in the "
            f"environment"
        )
    return threads


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


def _events(events: Any, t: np.ndarray, pot: Potential, epoch: Any) -> Any:
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

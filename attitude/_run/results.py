"""The results builder: a single run's :class:`~attitude._methods.RunResult` to what
:func:`attitude.propagate` returns (:func:`build`: the Dataset with its attrs, events and tick
records, or a :class:`~attitude.results.Trajectory`), or the
:class:`~attitude.errors.PropagationError` of a run that failed midway, whose ``partial`` holds
the samples computed.

A run's states become their Dataset (:func:`finish_dataset`, also each streamed chunk's) with
every per-sample variable (diagnostics, torques, the orbit) computed in one compiled pass
(:mod:`attitude._core.diagnostics`) or, for a spacecraft with actuators, by
:mod:`attitude._holds`; and the samples whose energy, rates or torques overflow are found (the
run then fails there).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from orbit import _rk
from orbit._state_kernels import TYPE_EPHEMERIS

from .. import _compiling
from .._core import diagnostics as _kd
from .._methods import SAMPLE_BUDGET, Problem, RunResult
from .._spacecraft_results import add_actuator_variables, add_tick_variables
from ..errors import PropagationError
from ..results import (
    Trajectory,
    _variable,
    add_event_variables,
    build_dataset,
    dataset_from_samples,
)
from .spec import RunSpec

__all__ = ["build", "finish_dataset"]


def build(spec: RunSpec, result: RunResult) -> xr.Dataset | Trajectory:
    """The run's result (raises PropagationError if it failed; ``partial``: the samples)."""
    problem, plan, tt = spec.problem, spec.plan, spec.problem.t
    attrs: dict[str, Any] = {
        **spec.attrs,
        "method": plan.method,
        **({"method_requested": plan.requested} if plan.requested != plan.method else {}),
        "formulation": spec.formulation,
        "initial_projection": spec.correction,
        **{k: (np.int64(v) if isinstance(v, int) else v) for k, v in result.stats.items()},
    }
    if spec.arrays:
        ds = Trajectory(tt[: result.y.shape[0]], result.y[:, :4], result.y[:, 4:8], attrs)
    elif plan.streaming and result.status == _rk.NONFINITE and result.message == _OVERFLOW_MESSAGE:
        ds = finish_dataset(problem, result.y, attrs, first=result.first)
    else:
        ds, n_ok = _finish(problem, result.y, attrs, first=result.first, t_last=result.t_event)
        if n_ok is not None:  # a finite state whose energy or rates overflow: fail there
            ds = ds.isel(time=slice(0, n_ok))
            result = RunResult(
                result.y[:n_ok], _rk.NONFINITE, _OVERFLOW_MESSAGE, result.stats,
                first=result.first, t_stop=float(tt[result.first + n_ok]), events=result.events,
            )  # fmt: skip
    if spec.on_chunk is not None and not plan.streaming:  # the finished samples, in chunks
        chunk = int(spec.options["chunk"])
        for i in range(0, ds.sizes["time"], chunk):
            spec.on_chunk(ds.isel(time=slice(i, i + chunk)))
    if problem.events is not None:
        omega = None
        if problem.spacecraft is not None:  # the gyrostat's rates; a coupled run's orbit
            from .._holds import event_state_variables

            omega, more = event_state_variables(problem, result.events)
            ds = ds.assign(more)
        ds = add_event_variables(
            ds, problem.events, result.events, problem.body, result.status, omega=omega
        )
    sc_run = problem.spacecraft
    if sc_run is not None and sc_run.program is not None:
        ds = add_tick_variables(ds, sc_run)  # (streamed: on the last sample's Dataset)
    if isinstance(ds, xr.Dataset) and result.status in (_rk.SUCCESS, _rk.EVENT):
        # how the run ended, on every run ("event": a terminal event, or the Earth's surface)
        ds.attrs.setdefault("status", "success" if result.status == _rk.SUCCESS else "event")
    if result.status not in (_rk.SUCCESS, _rk.EVENT):
        n = result.first + result.y.shape[0]
        t_fail = result.t_stop
        if t_fail is None:
            t_fail = float(tt[n - 1]) if n else float(tt[0])
        raise PropagationError(
            f"propagation stopped at t = {t_fail!r}: {result.message} "
            f"({n} of {tt.shape[0]} output samples computed"
            + (
                ", passed on chunk by chunk)"
                if plan.streaming
                else "; the error's partial holds them)"
            ),
            time=t_fail,
            partial=ds,
        )
    return ds


#: The failure of a run whose states are finite but whose energy, rates or torques overflow.
_OVERFLOW_MESSAGE = (
    "the energy, body rates or torque overflowed double precision (the state itself is finite)"
)


class _DiagnosticsOverflow(Exception):
    """Raised from a streamed run's chunk handler: the diagnostics of sample ``n`` (at ``t``)
    are not finite."""

    def __init__(self, n: int, t: float):
        super().__init__(n, t)
        self.n, self.t = n, t


def finish_dataset(
    problem: Problem,
    y: np.ndarray,
    attrs: dict[str, Any],
    first: int = 0,
    t_last: float | None = None,
) -> xr.Dataset:
    """Diagnostics and Dataset for the states ``y`` at ``problem.t[first : first + len(y)]``
    (the last one at ``t_last`` instead when given: the state at a terminal event)."""
    return _finish(problem, y, attrs, first, t_last)[0]


def _finish(
    problem: Problem,
    y: np.ndarray,
    attrs: dict[str, Any],
    first: int = 0,
    t_last: float | None = None,
) -> tuple[xr.Dataset, int | None]:
    """:func:`finish_dataset`, and the number of leading samples whose diagnostics and torques
    are finite when a later one's are not (None: all are)."""
    n = y.shape[0]
    t = problem.t[first : first + n]
    if t_last is not None and n:
        t = t.copy()
        t[-1] = t_last
    if problem.spacecraft is not None:
        from .. import _holds

        d = _holds.diagnostics(problem, t, y)
        if not problem.potential.has_potential:
            attrs = {**attrs, "energy_note": "potential unknown: energy is the kinetic energy only"}
        ds = build_dataset(
            t, y[:, :8], d["diag"], problem.body, problem.potential, attrs, torques=d["torques"],
            orbit=d["orbit"],
        )  # fmt: skip
        ds = add_actuator_variables(ds, problem.spacecraft, y, d)
        if problem.spacecraft.coupled:
            from .._coupling import orbit_variables, total_energy

            specs = orbit_variables(problem.spacecraft.spacecraft, y)
            ds = ds.assign({k: _variable(*v) for k, v in specs.items()})
            e = total_energy(problem.spacecraft, ds.energy.values, y)
            if e is not None and len(e[1]):
                ds = ds.assign(total_energy=_variable(*e))
                v = e[1]
                scale = max(abs(float(v[0])), 1e-300)
                ds.attrs["max_rel_total_energy_error"] = float(np.max(np.abs(v - v[0])) / scale)
        return ds, None
    # Every per-sample variable in one compiled pass (attitude._core.diagnostics), into one
    # buffer whose blocks become the Dataset's variables without copies.
    pot = problem.potential
    n_terms = len(pot.terms)
    orbit = getattr(pot, "orbit", None)
    od = orbit.kernel_data() if orbit is not None else _NO_ORBIT
    buf = np.empty(_kd.buffer_size(n, n_terms))
    y = np.ascontiguousarray(y, dtype=np.float64)
    for i in range(0, n, SAMPLE_BUDGET):  # bounded compiled calls: Ctrl-C acts in between
        j = min(n, i + SAMPLE_BUDGET)
        problem.entry.samples(t, y, problem.params, od, orbit is not None, buf, i, j)
    if orbit is not None and int(od[0]) == TYPE_EPHEMERIS and n:
        # the osculating true anomaly of a table: the orbit's own (numpy) formula, bit for bit
        buf[_kd.SAMPLE.F * n : (_kd.SAMPLE.F + 1) * n] = orbit.true_anomaly(t)
    n_ok = _finite_prefix(buf, n, n_terms)
    if not pot.has_potential:
        attrs = {**attrs, "energy_note": "potential unknown: energy is the kinetic energy only"}
    ds = dataset_from_samples(t, buf, n_terms, problem.body, pot, attrs, orbit is not None)
    return ds, n_ok


def samples_kernels(problem: Problem) -> list[tuple]:
    """What :func:`_finish` will compile for a run without a spacecraft, as items of
    :func:`attitude._compiling.helper` (the arguments' numba types); none for a user's module."""
    from numba import typeof
    from numba.core import types

    home = _compiling.where(problem.entry)
    if problem.spacecraft is not None or home is None:
        return []
    orbit = getattr(problem.potential, "orbit", None)
    od = orbit.kernel_data() if orbit is not None else _NO_ORBIT
    a1, a2 = types.Array(types.float64, 1, "C"), types.Array(types.float64, 2, "C")
    i = types.int64
    sig = (a1, a2, typeof(problem.params), typeof(od), types.boolean, a1, i, i)
    return [(home, "samples", sig, True)]


def _finite_prefix(buf: np.ndarray, n: int, n_terms: int) -> int | None:
    """The number of leading samples whose diagnostics (ω … q·Q) and torques in the buffer of
    :func:`attitude._core.diagnostics.samples_with` are finite, when a later one's are not
    (None: all are)."""
    diag = buf[_kd.SAMPLE.OMEGA * n : _kd.SAMPLE.R * n]
    torques = buf[_kd.SAMPLE.SIZE * n :]
    if np.isfinite(diag).all() and np.isfinite(torques).all():
        return None
    ok = np.isfinite(torques.reshape(n, -1)).all(axis=1)
    for _, off, w in _kd.BLOCKS:
        if _kd.SAMPLE.OMEGA <= off < _kd.SAMPLE.R:
            ok &= np.isfinite(buf[off * n : (off + w) * n].reshape(n, w)).all(axis=1)
    return int(np.argmin(ok))


_NO_ORBIT = np.zeros(1)

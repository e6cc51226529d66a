"""The result of a run: its states to the Dataset, with every per-sample variable (diagnostics,
torques, the orbit) computed in one compiled pass (:mod:`attitude._core.diagnostics`) or, for a
spacecraft with actuators, by :mod:`attitude._holds`; and the samples whose energy, rates or
torques overflow found (the run then fails there).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from orbit._state_kernels import TYPE_EPHEMERIS

from ._core import diagnostics as _kd
from ._methods import SAMPLE_BUDGET, Problem
from ._spacecraft_results import add_actuator_variables
from .results import build_dataset, dataset_from_samples

__all__ = ["finish_dataset"]


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
        from . import _holds

        d = _holds.diagnostics(problem, t, y)
        if not problem.potential.has_potential:
            attrs = {**attrs, "energy_note": "potential unknown: energy is the kinetic energy only"}
        ds = build_dataset(
            t, y[:, :8], d["diag"], problem.body, problem.potential, attrs, torques=d["torques"]
        )
        return add_actuator_variables(ds, problem.spacecraft, y, d), None
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

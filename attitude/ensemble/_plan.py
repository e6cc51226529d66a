"""What an ensemble stores: the output choice, the compiled loop's time grid, the size estimate.

Output choices (docs/ensemble.md, "Output choices"):

=================  =============================================================================
``"samples"``      every member at every output time (``every=k``: at ``t[::k]``)
``"final"``        every member at the final time only
``"statistics"``   no member trajectories: percentiles over members of the pointing error and
                   of the rate magnitude at every output time (``every=k``: at ``t[::k]``),
                   computed as the members finish (:mod:`._percentile_store`)
=================  =============================================================================

The compiled loop integrates every member from ``t[0]`` to ``t[-1]`` whatever is stored; it only
evaluates its dense output at the stored times (and at ``t[-1]``). DOP853's steps do not depend
on the output times (the step loop is driven by the error estimate and the end time ``t[-1]``
alone, :func:`orbit._rk.dop853_run`), so a stored sample is bit for bit the sample of a
run that stores everything (tests/test_ensemble.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from .._memory import format_size, parse_size
from ..errors import AttitudeTypeError, AttitudeValueError, OutputSizeError

#: The output choices of :func:`attitude.ensemble.propagate_ensemble`.
OUTPUTS = ("samples", "final", "statistics")
#: Percentiles of an ``output="statistics"`` run unless given (100: the maximum over members).
DEFAULT_PERCENTILES = (5.0, 50.0, 95.0, 100.0)
#: Default limit of the expected output size (bytes): larger outputs are refused before any work
#: unless ``max_output_size`` is raised (or None: no limit).
MAX_OUTPUT_SIZE = 1e9
#: Fixed netCDF4/HDF5 cost of a file: superblock, groups, dimension scales, global attrs (bytes).
FILE_OVERHEAD = 10_000
#: Per-variable netCDF4/HDF5 cost: object header, attributes, chunk index (bytes).
VARIABLE_OVERHEAD = 2_500


@dataclass
class _Plan:
    """The output choice of a run and the time grid it needs from the compiled loop."""

    output: str
    every: int
    t: np.ndarray  # the run's output times, as given
    kernel_t: np.ndarray  # what the compiled loop evaluates: t[0], the stored times, t[-1]
    keep: np.ndarray | None  # rows of kernel_t that are stored (None: all of them)
    percentiles: np.ndarray | None  # output="statistics" only
    limit: float  # bytes (inf: no limit)

    @property
    def stored_t(self) -> np.ndarray:
        return self.kernel_t if self.keep is None else self.kernel_t[self.keep]

    def attrs(self) -> dict[str, Any]:
        """Global attrs recording the choice and the integration span."""
        a: dict[str, Any] = {
            "ensemble_output": self.output,
            "integration_start": float(self.t[0]),
            "integration_stop": float(self.t[-1]),
            "integration_samples": np.int64(self.t.shape[0]),
        }
        if self.output != "final":
            a["output_every"] = np.int64(self.every)
        if self.percentiles is not None:
            a["statistics_percentiles"] = np.asarray(self.percentiles, dtype=np.float64)
        return a


def _positive_int(v: Any, name: str) -> int:
    if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1:
        raise AttitudeValueError(f"{name}: expected a positive integer, got {v!r}")
    return int(v)


def make_plan(
    t: np.ndarray,
    output: Any,
    every: Any,
    percentiles: Any,
    max_output_size: Any,
) -> _Plan:
    """Validate the output arguments of ``propagate_ensemble`` (errors name them)."""
    if not isinstance(output, str) or output not in OUTPUTS:
        raise AttitudeValueError(
            f"output: expected one of {', '.join(map(repr, OUTPUTS))}, got {output!r}"
        )
    k = _positive_int(every, "every")
    if output == "final" and k != 1:
        raise AttitudeValueError(
            "every: stores every k-th output time with output='samples' or 'statistics'; "
            "output='final' stores the final time only"
        )
    pct = None
    if output == "statistics":
        from .statistics import _percentiles

        pct = _percentiles(DEFAULT_PERCENTILES if percentiles is None else percentiles)
    elif percentiles is not None:
        raise AttitudeValueError(
            "percentiles: only with output='statistics' (the other outputs store the members; "
            "take percentiles with attitude.ensemble.pointing_error_percentiles afterwards)"
        )
    limit = parse_size(max_output_size)
    m = t.shape[0]
    if output == "final":
        rows = np.array([0, m - 1]) if m > 1 else np.array([0])
        keep = np.array([rows.shape[0] - 1])
    else:
        idx = np.arange(0, m, k)
        if idx[-1] == m - 1:
            rows, keep = idx, None
        else:  # the loop still runs to t[-1]: evaluate it, do not store it
            rows, keep = np.append(idx, m - 1), np.arange(idx.shape[0])
    kernel_t = np.ascontiguousarray(t[rows])
    return _Plan(output, k, t, kernel_t, keep, pct, limit)


# ------------------------------------------------------------------------------------------------
# size estimate
# ------------------------------------------------------------------------------------------------


def estimate_bytes(one: xr.Dataset, n: int, extra: xr.Dataset | None = None) -> int:
    """Expected size of the output of ``n`` members from the Dataset ``one`` of one member.

    Variables with a ``member`` dimension count ``n`` times, the others once; ``extra`` holds the
    variables written at the end (the percentiles of a statistics run). The data are counted
    uncompressed (float64 trajectories compress by only a few per cent), plus the netCDF4
    metadata: :data:`FILE_OVERHEAD` and :data:`VARIABLE_OVERHEAD` per variable and the
    attributes' text.
    """
    total = FILE_OVERHEAD + sum(len(str(v)) + len(k) for k, v in one.attrs.items())
    for ds in (one, extra) if extra is not None else (one,):
        for name, var in ds.variables.items():
            if ds is extra and name in one.variables:
                continue
            nbytes = int(var.dtype.itemsize * np.prod(var.shape, dtype=np.int64))
            if var.dtype.kind in "UO":  # a character array (attitude.io), and its dimension
                text = [len(str(x).encode("utf-8")) for x in np.asarray(var.values).ravel()]
                nbytes = max([1, *text]) * len(text) + VARIABLE_OVERHEAD
            total += VARIABLE_OVERHEAD + sum(len(str(v)) + len(k) for k, v in var.attrs.items())
            total += nbytes * n if "member" in var.dims else nbytes
    return int(total)


def check_size(
    expected: int,
    plan: _Plan,
    n: int,
    in_memory: bool,
    one: xr.Dataset | None = None,
    spacecraft: bool = False,
    tick_every: int | None = None,
) -> None:
    """Refuse an output above ``plan.limit`` (before any work), naming the remedies that work
    for this ensemble: ``one`` (one member's Dataset) tells how much of it the flight
    software's tick records are, ``tick_every`` whether they are every k-th tick (None: those
    at the stored times, which fewer stored times cut); a spacecraft ensemble stores its
    members (no statistics)."""
    if expected <= plan.limit:
        return
    where = "result in memory" if in_memory else "output file"
    m = plan.stored_t.shape[0]
    # what each remedy leaves, from one member's per-member bytes: samples S, ticks T (every
    # k-th tick, or those at the stored times, which fewer stored times cut too), the rest R
    S = T = 0
    if one is not None:
        for v in one.variables.values():
            if "member" in v.dims and "tick" in v.dims:
                T += int(v.nbytes)
            elif "member" in v.dims and "time" in v.dims:
                S += int(v.nbytes)
    S, T = S * n, T * n
    R = max(0, expected - S - T)
    k = one.sizes.get("tick", 0) if one is not None else 0
    at_samples = tick_every is None
    fixes = []
    if T and not at_samples and R + S + T * min(1.0, m / max(k, 1)) <= plan.limit:
        fixes.append(
            "record fewer ticks: FlightSoftware(record_every=None), the default, records the "
            "ticks in effect at the stored times"
        )

    def fewer(f: float) -> float:  # keep a fraction f of the stored times
        return R + S * f + (T * f if at_samples else T)

    if m > 1 and fewer(1.0 / m) <= plan.limit:
        lo, hi = 1, m  # the smallest every=k that fits (fewer(1/k) falls with k)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if fewer(1.0 / mid) <= plan.limit else (mid, hi)
        store = f"output='final', or every={hi} or more"
        if not spacecraft:
            store += ", or output='statistics'"
        fixes.append(f"store fewer times ({store})")
    elif not spacecraft and plan.output != "statistics":
        fixes.append("store statistics only (output='statistics')")
    fixes.append("raise the limit (max_output_size='10 GB', or None for no limit)")
    raise OutputSizeError(
        f"max_output_size: the {where} would take about {format_size(expected)} ({n} members, "
        f"{m} stored samples each"
        + (f", {k} tick records" if T else "")
        + f"), above the limit of {format_size(plan.limit)}; "
        + "; or ".join(fixes),
        expected=expected,
        limit=plan.limit,
    )


# ------------------------------------------------------------------------------------------------
# the reference attitude of the pointing error
# ------------------------------------------------------------------------------------------------


def stored_rows(plan: _Plan) -> np.ndarray:
    """Indices into ``plan.t`` of the stored times."""
    m = plan.t.shape[0]
    if plan.output == "final":
        return np.array([m - 1])
    return np.arange(0, m, plan.every)


def given_reference(reference: Any, plan: _Plan) -> np.ndarray:
    """The reference attitude (stored times, 4) from a propagate result or quaternions."""
    from .._validation import as_float_array

    rows = stored_rows(plan)
    m, ms = plan.t.shape[0], rows.shape[0]
    if isinstance(reference, xr.Dataset):
        if "q" not in reference or "member" in reference["q"].dims:
            raise AttitudeValueError(
                "reference: a Dataset must be one run with q (time, 4), e.g. attitude.propagate "
                "of the nominal case"
            )
        rt = np.asarray(reference["time"].values)
        q = np.asarray(reference["q"].transpose("time", "component").values, dtype=np.float64)
        if rt.shape == (m,) and np.array_equal(rt, plan.t):
            q = q[rows]
        elif not (rt.shape == (ms,) and np.array_equal(rt, plan.t[rows])):
            raise AttitudeValueError(
                "reference: the nominal run must have the ensemble's output times exactly "
                "(propagate it with the same t)"
            )
    else:
        q = as_float_array(reference, "reference", trailing=4)
        if q.shape == (4,):
            q = np.broadcast_to(q, (ms, 4))
        elif q.shape == (m, 4):
            q = q[rows]
        elif q.shape != (ms, 4):
            raise AttitudeValueError(
                f"reference: expected quaternions of shape (4,) or (time, 4) = ({m}, 4), got "
                f"{q.shape}"
            )
    nq = np.linalg.norm(q, axis=-1)
    if np.any(np.abs(nq - 1.0) > 1e-6):
        raise AttitudeValueError("reference: quaternions must be unit quaternions")
    return np.ascontiguousarray(q / nq[:, None])


def nominal_reference(setup: Any, params: np.ndarray, nominal: Any, plan: _Plan) -> np.ndarray:
    """The attitude (stored times, 4) of the nominal initial state, propagated once by the
    members' compiled loop (same body, potential, tolerances and time grid)."""
    from orbit import _rk

    from .._validation import as_float_array
    from ._chunks import _compute_chunk
    from ._members import _project

    if not isinstance(nominal, (tuple, list)) or len(nominal) not in (2, 3):
        raise AttitudeTypeError(
            "nominal: expected the nominal initial state as a pair (q0, Q0) of (4,) arrays, "
            "or (q0, Q0, body) when the members' bodies differ"
        )
    q0 = as_float_array(nominal[0], "nominal", trailing=4, ndim=1)
    Q0 = as_float_array(nominal[1], "nominal", trailing=4, ndim=1, unit=None)
    try:
        qp, Qp, _ = _project(q0[None, :], Q0[None, :], 0)
    except AttitudeValueError as exc:
        raise AttitudeValueError(f"nominal: {str(exc).split(': ', 2)[-1]}") from None
    y0 = np.ascontiguousarray(np.concatenate([qp, Qp], axis=1))
    out = _compute_chunk(setup, params[None, :], y0, parallel=False)
    if int(out["status"][0]) != _rk.SUCCESS:
        msg = _rk.STATUS_MESSAGES.get(int(out["status"][0]), "failed")
        raise AttitudeValueError(
            f"nominal: the nominal run stopped at t = {float(out['t_stop'][0]):g}: {msg}"
        )
    y = out["y"][0] if plan.keep is None else out["y"][0, plan.keep]
    return np.ascontiguousarray(y[:, :4])

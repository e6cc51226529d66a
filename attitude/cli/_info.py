"""``attitude info``: what was run, the invariants, events, wheels and torques."""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from ._common import (
    _READ_ERRORS,
    EXIT_OK,
    BadInput,
    _invariant_lines,
    _open,
    _span,
    _terminal_event,
    _unreadable,
)
from ._run import _numerics, _statistics


def cmd_info(args: argparse.Namespace) -> int:
    ds = _open(args.file)
    try:
        try:
            rows, inv = _info_rows(args, ds)
            budget = _torque_budget(ds)
            wheels = _wheel_lines(ds)
            orbit_lines = _orbit_lines(ds)
            from .._pointing_stats import pointing_lines
            from ..errors import AttitudeValueError

            try:
                pointing = pointing_lines(ds, args.settle)
            except AttitudeValueError as exc:
                raise BadInput(str(exc)) from None
            events = ds.attrs.get("events") or "detector" in ds.dims
            ev = _event_lines(ds) if events else []
        except BadInput:
            raise
        except _READ_ERRORS as exc:
            raise _unreadable(args.file, exc) from None
        for k, v in rows:
            print(f"{k:<11} {v}")
        print("invariants  " + ("\n            ".join(inv) if inv else "-"))
        print("torques     " + ("\n            ".join(budget) if budget else "-"))
        if pointing:
            print("pointing    " + "\n            ".join(pointing))
        if wheels:
            print("wheels      " + "\n            ".join(wheels))
        if orbit_lines:
            print("orbit       " + "\n            ".join(orbit_lines))
        if events:
            print("events      " + ("\n            ".join(ev) if ev else "-"))
    finally:
        ds.close()
    return EXIT_OK


def _info_rows(args: argparse.Namespace, ds: Any) -> tuple[list[tuple[str, Any]], list[str]]:
    a = dict(ds.attrs)
    n = ds.sizes["time"]
    t = ds["time"].values
    from ..results import time_unit

    unit = time_unit(ds["time"])
    if "max_abs_norm_error" not in a and "q" in ds.data_vars:  # (io.write: computed here)
        a.update(_invariants(ds, str(a.get("potential_name", ""))))
    inertia = a.get("inertia")
    rows = [
        ("file", args.file),
        ("scenario", f"{a.get('scenario', '-')}: {a.get('title', '')}"),
        ("status", a.get("run_status", "complete")),
        *([("ensemble", _ensemble_line(ds, a))] if "ensemble_size" in a else []),
        ("time span", _span(a, float(t[0]), float(t[-1]), n, str(unit))),
        (
            "body",
            f"inertia {np.asarray(inertia).tolist() if inertia is not None else '-'} "
            f"{a.get('inertia_units', '')}",
        ),
        ("potential", a.get("potential", "-")),
        *([("orbit", a["orbit"]), ("frame", a.get("orbit_frame", "-"))] if a.get("orbit") else []),
        ("epoch", a.get("epoch") or "- (times are relative)"),
        ("initial", a.get("initial_state_form", "-")),
        (
            "method",
            f"{a.get('method')} ({a.get('formulation', 'canonical')}), {_numerics(a)}",
        ),
        (
            "statistics",
            _statistics(a),
        ),
        (
            "variables",
            ", ".join(f"{v} [{_unit_label(ds[v])}]" for v in ds.data_vars),
        ),
        ("version", a.get("source", "-")),
        ("history", a.get("history", "-")),
    ]
    return rows, _invariant_lines(a)


def _invariants(ds: Any, potential_name: str) -> dict[str, Any]:
    """The invariant diagnostics of a file that does not store them (streamed over its time
    chunks; an ensemble's over blocks of members: the largest over the members that
    succeeded)."""
    from .._invariants import InvariantTracker

    counts = tuple(ds.sizes.get(d, 0) for d in ("wheel", "magnetorquer", "thruster"))
    if "member" in ds["q"].dims:
        from ..ensemble._output import member_invariant_attrs

        n = ds.sizes["member"]
        step = max(1, 2**24 // (8 * 16 * max(1, ds.sizes["time"])))
        out: dict[str, Any] = {}
        for i in range(0, n, step):
            part = ds.isel(member=slice(i, i + step))
            st = part["member_status"].values if "member_status" in part else None
            ok = np.ones(part.sizes["member"], bool) if st is None else np.isin(st, (0, 4))
            for k, v in member_invariant_attrs(part, ok, potential_name, counts).items():
                out[k] = max(out.get(k, 0.0), v)
        return out
    from ..io import iter_chunks

    tr = InvariantTracker()
    for c in iter_chunks(ds):
        tr.update(c)
    return tr.attrs(potential_name, counts)


def _event_lines(ds: Any, limit: int = 20) -> list[str]:
    """The event detectors of a run and what they found (single runs and ensembles)."""
    a = ds.attrs
    out = [str(x).strip() for x in str(a.get("events", "")).split(" | ") if str(x).strip()]
    if "detector_label" not in ds.variables:
        return out
    from ..results import time_unit, time_values

    labels = [str(x) for x in ds["detector_label"].values]
    unit = time_unit(ds["time"])
    unit = "" if unit in ("1", "") else unit
    if "event_first_time" in ds and "member" in ds["event_first_time"].dims:  # ensemble
        first = time_values(ds, "event_first_time")
        n = first.shape[0]
        for j, name in enumerate(labels):
            col = first[:, j]
            have = np.isfinite(col)
            if have.any():
                p5, p50, p95 = np.percentile(col[have], [5, 50, 95])
                out.append(
                    f"{name}: in {int(have.sum())} of {n} members; first at "
                    f"{p5:.6g} / {p50:.6g} / {p95:.6g} {unit} (5/50/95 %)"
                )
            else:
                out.append(f"{name}: in none of {n} members")
        return out
    if "detector_count" in ds:
        counts = np.asarray(ds["detector_count"].values)
        out.append(", ".join(f"{name}: {int(c)}" for name, c in zip(labels, counts, strict=True)))
    if "event_time" in ds:
        t = time_values(ds, "event_time")
        which = np.asarray(ds["event_detector"].values)
        sign = np.asarray(ds["event_direction"].values)
        for i in range(min(t.size, limit)):
            d = "rising" if sign[i] > 0 else "falling"
            out.append(f"t = {t[i]:.12g} {unit}  {labels[int(which[i])]} ({d})")
        if t.size > limit:
            out.append(f"... {t.size - limit} more (variables event_time, event_detector)")
    if a.get("terminal_event"):
        out.append(f"run ended by the terminal event {_terminal_event(a['terminal_event'])}")
    return out


def _ensemble_line(ds: Any, a: dict[str, Any]) -> str:
    """An ensemble's size, what it stored, its seed, and how many members failed or ended at a
    terminal event (``member_status``: 0 success, 4 terminal event, the others failures)."""
    parts = [f"{int(a['ensemble_size'])} members", f"output {a.get('ensemble_output', '-')}"]
    if "ensemble_seed" in a:
        parts.append(f"seed {a['ensemble_seed']}")
    if "member_status" in ds:
        status = np.asarray(ds["member_status"].values).astype(np.int64)
        parts.append(f"{int(np.count_nonzero((status != 0) & (status != 4)))} failed")
        if np.any(status == 4):
            parts.append(f"{int(np.count_nonzero(status == 4))} ended by a terminal event")
    return ", ".join(parts)


def _unit_label(da: Any) -> str:
    """A variable's unit in the ``variables`` line: CF flags have none (``flag``), the
    software's commands one per command (``command_units``)."""
    if "units" in da.attrs:
        return str(da.attrs["units"])
    if "flag_values" in da.attrs or "flag_masks" in da.attrs:
        return "flag"
    return "per command" if "command" in da.dims else "?"


def _samples(da: Any, *dims: str) -> np.ndarray:
    """A variable's values as (sample, *dims): an ensemble's (member, time) flattened (the
    NaN samples of failed members left out)."""
    lead = [d for d in da.dims if d not in dims]
    v = np.asarray(da.transpose(*lead, *dims).values)
    v = v.reshape(-1, *v.shape[len(lead) :])
    if v.dtype.kind == "f" and lead:  # the samples after a member's failure: left out
        v = v[np.isfinite(v).all(axis=tuple(range(1, v.ndim)))]
    return v


def _wheel_lines(ds: Any) -> list[str]:
    """Per reaction wheel: speed range (rpm), largest applied torque, and how often each limit
    acted (streamed over the file's chunks)."""
    if "wheel_speed" not in ds.data_vars:
        return []
    labels = [str(x) for x in ds["wheel_label"].values]
    n_w = len(labels)
    lo = np.full(n_w, np.inf)
    hi = np.full(n_w, -np.inf)
    umax = np.zeros(n_w)
    flags = np.zeros((n_w, 4), dtype=np.int64)
    n = 0
    step = 65536
    for i in range(0, ds.sizes["time"], step):
        sl = slice(i, i + step)
        # (an ensemble's members are more samples: (member, time, wheel) flattened)
        w = _samples(ds["wheel_speed"].isel(time=sl), "wheel").astype(np.float64)
        u = _samples(ds["wheel_torque"].isel(time=sl), "wheel").astype(np.float64)
        f = _samples(ds["wheel_limit"].isel(time=sl), "wheel").astype(np.int64)
        lo = np.minimum(lo, w.min(axis=0, initial=np.inf))
        hi = np.maximum(hi, w.max(axis=0, initial=-np.inf))
        umax = np.maximum(umax, np.abs(u).max(axis=0, initial=0.0))
        for b in range(4):
            flags[:, b] += ((f >> b) & 1).sum(axis=0)
        n += w.shape[0]
    rpm = 60.0 / (2.0 * np.pi)
    # round-off of a wheel that barely turns (-2e-18 rpm) printed as 0 at the wheels' scale
    tiny = 1e-12 * max(
        float(np.max(np.abs(lo), initial=0.0)), float(np.max(np.abs(hi), initial=0.0))
    )
    lo, hi = np.where(np.abs(lo) < tiny, 0.0, lo), np.where(np.abs(hi) < tiny, 0.0, hi)
    names = ("torque", "speed", "power", "dead band")
    width = max(len(x) for x in labels)
    unit = ds["wheel_torque"].attrs.get("units", "")
    out = [f"{'wheel':<{width}}  {'speed min .. max [rpm]':>24}  {'max |u| [' + unit + ']':>13}  "
           "limits (share of samples)"]  # fmt: skip
    for k in range(n_w):
        lim = ", ".join(
            f"{names[b]} {flags[k, b] / max(n, 1):.1%}" for b in range(4) if flags[k, b]
        )
        out.append(
            f"{labels[k]:<{width}}  {lo[k] * rpm:>11.6g} .. {hi[k] * rpm:<10.6g}  "
            f"{umax[k]:13.4g}  {lim or 'none'}"
        )
    return out


def _orbit_lines(ds: Any) -> list[str]:
    """A run that propagated its orbit with the attitude: its radius and semi-major axis at the
    start and the end, the mass used, and where it stopped at the surface."""
    if "position" not in ds or "velocity" not in ds or ds.sizes.get("time", 0) < 1:
        return []
    from orbit import earth_mu

    if "member" in ds.dims:
        return [f"propagated with the attitude, {ds.sizes['member']} members (position, "
                "velocity, mass per member)"]  # fmt: skip
    ends = [0, ds.sizes["time"] - 1]
    r = np.asarray(ds["position"].isel(time=ends).values, dtype=np.float64)
    v = np.asarray(ds["velocity"].isel(time=ends).values, dtype=np.float64)
    rn = np.linalg.norm(r, axis=1)
    out = ["propagated with the attitude (GCRS): radius "
           f"{rn[0] * 1e-3:.3f} -> {rn[-1] * 1e-3:.3f} km"]  # fmt: skip
    gm = ds.attrs.get("orbit_gm")
    a_osc = 1e-3 / (2.0 / rn - np.sum(v * v, axis=1) / (earth_mu() * 1e9 if gm is None else gm))
    osculating = f"two-body semi-major axis {a_osc[0]:.3f} -> {a_osc[-1]:.3f} km"
    from ..results import energy_semi_major_axis

    a = energy_semi_major_axis(ds.attrs, 1e-3 * r, 1e-3 * v)
    if a is None:  # (a file written before the field's constants were recorded)
        out[0] += ", " + osculating
    else:
        out.append(f"energy semi-major axis {a[0]:.3f} -> {a[-1]:.3f} km "
                   f"({a[-1] - a[0]:+.3f} km; {osculating})")  # fmt: skip
    m = np.asarray(ds["mass"].values, dtype=np.float64) if "mass" in ds else np.zeros(1)
    if m[0] != m[-1]:
        out.append(f"mass {m[0]:.6g} -> {m[-1]:.6g} kg ({m[0] - m[-1]:.6g} kg of propellant)")
    if ds.attrs.get("event") == "impact":
        out.append(f"reached the Earth's surface at t = {float(ds.attrs['impact_time']):.6g} s")
    return out


def _torque_budget(ds: Any) -> list[str]:
    """Max and RMS of the torque magnitude per model term (streamed over the file's chunks)."""
    if "torque" not in ds.data_vars or "model" not in ds.dims:
        return []
    labels = [str(x) for x in ds["model_label"].values] if "model_label" in ds else []
    n_model = ds.sizes["model"]
    peak = np.zeros(n_model)
    sq = np.zeros(n_model)
    n = 0
    step = 65536
    for i in range(0, ds.sizes["time"], step):
        tau = _samples(ds["torque"].isel(time=slice(i, i + step)), "model", "axis")
        mag = np.sqrt(np.sum(tau * tau, axis=-1))  # (time, model)
        peak = np.maximum(peak, np.max(mag, axis=0, initial=0.0))
        sq += np.sum(mag * mag, axis=0)
        n += mag.shape[0]
    unit = ds["torque"].attrs.get("units", "")
    # the torque-free model's own term is zero by definition: a row of zeros says nothing
    rows = [j for j in range(n_model) if not (j < len(labels) and labels[j] == "torque_free"
                                              and peak[j] == 0.0)]  # fmt: skip
    width = max((len(labels[j]) for j in rows if j < len(labels)), default=5)
    out = [f"{'model':<{width}}  {'max |tau|':>11}  {'rms |tau|':>11}  [{unit}]"]
    for j in rows:
        name = labels[j] if j < len(labels) else str(j)
        out.append(f"{name:<{width}}  {peak[j]:11.4g}  {np.sqrt(sq[j] / max(n, 1)):11.4g}")
    if "wheels" in labels and "total" in labels:
        out.append("(total: the external torque; the wheels' acts between wheels and body)")
    return out

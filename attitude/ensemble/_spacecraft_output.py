"""The Dataset of a chunk of spacecraft members: the single run's variables over ``member``.

The variables and their numbers are made by the single run's own builders
(:func:`attitude.results.build_dataset`,
:func:`~attitude._spacecraft_results.add_actuator_variables`,
:func:`~attitude._spacecraft_results.add_tick_variables`), called once per chunk on the
members' samples laid end to end (member after member along ``time``, and along ``tick``),
then cut back into (member, time) and (member, tick): so every member's values are, element
for element, the ones its single run would hold, without a Dataset per member. The actuators'
constants (axes, inertias, limits) are each member's own
(:func:`~attitude._spacecraft_results.actuator_constants`).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import xarray as xr

from .._spacecraft_results import actuator_constants, add_actuator_variables, add_tick_variables
from ..results import build_dataset, instant_attrs, time_unit
from ._chunks import STATUS_FLAGS
from ._members import initial_state_vars

__all__ = ["chunk_dataset"]

#: Global attrs of a single run that do not describe an ensemble (member 0's).
_SINGLE_ONLY = ("inertia", "sensor_seeds")


def _per_member(var: xr.Variable, dim: str, c: int) -> xr.Variable:
    """A variable laid end to end along ``dim`` (c × L rows), as (member, dim, ...)."""
    data = np.asarray(var.data)
    shape = (c, data.shape[0] // c, *data.shape[1:])
    return xr.Variable(("member", *var.dims), data.reshape(shape), var.attrs)


def chunk_dataset(
    members: Any,
    start: int,
    blk: dict[str, Any],
    out: dict[str, Any],
    t: np.ndarray,
    keep: np.ndarray | None,
    attrs: dict[str, Any],
) -> xr.Dataset:
    """The chunk's Dataset (members start..start + C − 1) from its arrays
    (:func:`~attitude.ensemble._spacecraft_chunks.compute_chunk`) at the output times ``t``
    (``keep``: the rows of the compiled loop's grid that are stored; None: all)."""
    runs = blk["runs"]
    run0 = runs[0]
    pot = members.potential
    c = len(runs)
    n = run0.n_state

    def rows_of(a):
        a = a if keep is None else a[:, keep]
        return np.ascontiguousarray(a).reshape(c * a.shape[1], *a.shape[2:])

    rows = rows_of(out["rows"])
    ms = rows.shape[0] // c
    d = {
        "diag": rows_of(out["diag"]),
        "torques": rows_of(out["torques"]),
        "actuators": rows_of(out["actuators"]),
        "wheels": rows_of(out["wheels"]),
        "records": rows[:, n:],
    }
    t_flat = np.tile(t, c)
    a = dict(attrs)
    if not pot.has_potential:
        a["energy_note"] = "potential unknown: energy is the kinetic energy only"
    body = run0.spacecraft.body
    flat = build_dataset(t_flat, rows[:, :8], d["diag"], body, pot, a, torques=d["torques"])
    flat = add_actuator_variables(flat, run0, rows, d)
    k_ticks = 0
    if "records" in out:
        k_ticks = members.tick_times().shape[0]
        rec = out["records"]
        flat_rec = np.empty((c * k_ticks, rec.shape[2]))
        for r in range(c):  # a member at a time: one copy of them all was seconds without Ctrl-C
            flat_rec[r * k_ticks : (r + 1) * k_ticks] = rec[r, :k_ticks]
        ticks = SimpleNamespace(program=run0.program, spacecraft=run0.spacecraft, ticks=flat_rec)
        flat = add_tick_variables(flat, ticks)
    # cut back into members
    consts: dict[int, dict[str, xr.Variable]] = {}
    for run in runs:
        if id(run.spacecraft) not in consts:
            consts[id(run.spacecraft)] = actuator_constants(run.spacecraft)
    data_vars: dict[str, xr.Variable] = {}
    for name, da in flat.data_vars.items():
        var = da.variable
        if name in consts[id(run0.spacecraft)]:
            each = [consts[id(run.spacecraft)][name] for run in runs]
            data_vars[name] = xr.Variable(
                ("member", *var.dims), np.stack([v.values for v in each]), var.attrs
            )
        elif var.dims and var.dims[0] == "time" and name in ("r", "f", "p"):
            data_vars[name] = xr.Variable(var.dims, np.asarray(var.data)[:ms], var.attrs)
        elif var.dims and var.dims[0] in ("time", "tick"):
            data_vars[name] = _per_member(var, var.dims[0], c)
        else:
            data_vars[name] = var
    if "mode" in data_vars and k_ticks:  # after a failed member's last tick: -1 (no mode)
        mode = data_vars["mode"].values
        after = np.arange(k_ticks)[None, :] >= out["n_records"][:, None]
        mode[after] = -1
    coords = {}
    for name, cv in flat.coords.items():
        if name == "time":
            coords[name] = ("time", np.asarray(t, dtype=np.float64), cv.attrs)
        elif name == "tick":
            coords[name] = ("tick", members.tick_times(), cv.attrs)
        else:
            coords[name] = cv.variable
    coords["member"] = (
        "member",
        np.arange(start, start + c, dtype=np.int64),
        {"long_name": "ensemble member index"},
    )
    if "seeds" in blk and members.sensor_kinds:
        kinds = members.sensor_kinds
        coords["sensor"] = (
            "sensor",
            np.arange(len(kinds), dtype=np.int32),
            {"long_name": "sensor index (kinds in sensor_label)", "units": "1"},
        )
        coords["sensor_label"] = ("sensor", np.array(kinds), {"long_name": "sensor kind"})
    data_vars.update(_member_variables(members, start, blk, out, flat))
    ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs = {k: v for k, v in flat.attrs.items() if k not in _SINGLE_ONLY}
    return ds


def _member_variables(members, start, blk, out, flat) -> dict[str, xr.Variable]:
    """Per-member inputs and statistics: what re-runs a member alone, and how it ended."""
    momentum = str(flat["Q"].attrs.get("units", "1"))
    inertia_units = str(flat.attrs.get("inertia_units", "1"))
    v: dict[str, xr.Variable] = {
        "inertia": xr.Variable(
            ("member", "axis"),
            np.ascontiguousarray(blk["inertia"]),
            {"units": inertia_units, "long_name": "principal moments of inertia (I1, I2, I3)"},
        )
    }
    for name, (dims, val, attrs) in initial_state_vars(blk["q"], blk["Q"]).items():
        attrs = dict(attrs)
        attrs["units"] = momentum if attrs["units"] == "momentum" else attrs["units"]
        v[name] = xr.Variable(dims, val, attrs)
    cnt = out["counters"]
    taylor = members.method == "taylor"
    stats = [
        ("member_n_steps", cnt[:, 0], "accepted integration steps"),
        (
            "member_n_rhs",
            np.zeros_like(cnt[:, 1]) if taylor else cnt[:, 1],
            "right-hand side evaluations",
        ),
        ("member_n_rejected", cnt[:, 2], "rejected integration steps"),
        ("member_status", out["status"], "integration status (0: success)"),
    ]
    if taylor:
        stats.append(("member_n_series_terms", cnt[:, 1], "Taylor series terms computed"))
    if "n_ticks" in out:
        stats.append(("member_n_ticks", out["n_ticks"], "flight-software ticks run"))
    for name, col, long in stats:
        attrs: dict[str, Any] = {"units": "1", "long_name": long}
        if name == "member_status":
            attrs["flag_values"] = np.array(list(STATUS_FLAGS), dtype=np.int64)
            attrs["flag_meanings"] = " ".join(STATUS_FLAGS.values())
        v[name] = xr.Variable(("member",), np.ascontiguousarray(col, dtype=np.int64), attrs)
    when = instant_attrs(time_unit(flat["time"]), flat.attrs.get("epoch"))
    v["member_t_stop"] = xr.Variable(
        ("member",), np.ascontiguousarray(out["t_stop"]), {**when, "long_name": "time reached"}
    )
    if members.extra_vars is not None:  # e.g. a scenario's dispersions
        rate = str(flat["omega"].attrs.get("units", "1"))
        for name, (dims, val, attrs) in members.extra_vars(start, start + len(blk["runs"])).items():
            attrs = {**attrs, "units": rate} if attrs.get("units") == "rate" else attrs
            v[name] = xr.Variable(dims, np.ascontiguousarray(val), attrs)
    if "seeds" in blk and members.sensor_kinds:
        v["sensor_seed"] = xr.Variable(
            ("member", "sensor"),
            np.ascontiguousarray(blk["seeds"]),
            {
                "units": "1",
                "long_name": "seed of each sensor's random stream: SeedSequence(ensemble_seed)"
                ".spawn(N)[member].generate_state(n_sensors, uint64) >> 1",
            },
        )
    return v


def member_invariant_attrs(
    ds: xr.Dataset, ok: np.ndarray, potential_name: str, counts: Any = None
) -> dict[str, float]:
    """The invariant diagnostics of :class:`attitude._invariants.InvariantTracker` (``attrs``:
    constraint errors, energy and momentum changes relative to the first stored sample), each
    member's over its stored samples, the largest over the members where ``ok`` (failed
    members are NaN after their failure). ``counts``: the (wheels, magnetorquers, thrusters)
    of a spacecraft."""
    from .._invariants import InvariantTracker

    def rows(name):
        return np.asarray(ds[name].transpose("member", "time", ...).values)[ok]

    def top(x):
        return float(np.max(x, initial=0.0)) if x.size else 0.0

    tr = InvariantTracker()
    if ok.any():
        qQ = np.abs(rows("qQ"))
        normQ = np.linalg.norm(rows("Q"), axis=-1)
        E, G = rows("energy"), rows("G")
        scale_e = np.maximum(np.abs(E[:, :1]), np.finfo(float).tiny)
        scale_g = np.maximum(np.linalg.norm(G[:, :1], axis=-1), 1e-300)
        tr.max_norm = top(np.abs(rows("norm_error")))
        tr.max_qQ = top(qQ)
        tr.max_rel_qQ = top(np.divide(qQ, normQ, out=np.zeros_like(qQ), where=normQ > 0))
        tr.max_dE = top(np.abs(E - E[:, :1]) / scale_e)
        tr.max_dG = top(np.linalg.norm(G - G[:, :1], axis=-1) / scale_g)
        tr.max_dGz = top(np.abs(G[..., 2] - G[:, :1, 2]) / scale_g)
    tr.E0, tr.G0 = 1.0, np.array([1.0, 0.0, 0.0])  # (the maxima above are relative already)
    return tr.attrs(potential_name, counts)

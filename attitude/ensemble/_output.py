"""Assembling chunks into Datasets (:class:`_Assembler` for rigid bodies,
:class:`_CraftAssembler` for spacecraft with actuators or flight software), and the result
opened from its netCDF file.

A spacecraft chunk's variables and their numbers are made by the single run's own builders
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

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import xarray as xr

from orbit import _rk

from .._spacecraft_results import actuator_constants, add_actuator_variables, add_tick_variables
from ..body import RigidBody
from ..results import _variable, build_dataset, instant_attrs, time_unit
from ._chunks import _N_DIAG, STATUS_FLAGS
from ._members import initial_state_vars

# ------------------------------------------------------------------------------------------------
# assembling chunks into Datasets
# ------------------------------------------------------------------------------------------------


class _Totals:
    """What an assembler keeps over the chunks (rigid bodies and spacecraft alike): the step
    totals, the largest initial projection, the invariant maxima, the members; the final
    attrs."""

    def __init__(self, attrs: dict[str, Any]):
        self.attrs = attrs
        self.totals = {"n_steps": 0, "n_rhs": 0, "n_rejected": 0}
        self.max_projection = 0.0
        self.inv: dict[str, float] = {}
        self.n_members = 0

    def _count(self, cnt: np.ndarray, rhs: bool, maxima: dict[str, Any] | None = None) -> None:
        """A chunk's counters (``rhs``: its right-hand sides and rejected steps too) and the
        invariant maxima of its successful members."""
        self.totals["n_steps"] += int(cnt[:, 0].sum())
        if rhs:
            self.totals["n_rhs"] += int(cnt[:, 1].sum())
            self.totals["n_rejected"] += int(cnt[:, 2].sum())
        self.n_members += cnt.shape[0]
        for k, v in (maxima or {}).items():
            self.inv[k] = max(self.inv.get(k, 0.0), float(v))

    def final_attrs(self, status: str) -> dict[str, Any]:
        a = dict(self.attrs)
        a.update({k: np.int64(v) for k, v in self.totals.items()})
        a.update(self.inv)
        a["initial_projection"] = float(self.max_projection)
        a["n_members_written"] = np.int64(self.n_members)
        a["run_status"] = status
        return a


class _Assembler(_Totals):
    """Turns the arrays of a chunk into a Dataset with a ``member`` dimension; keeps totals."""

    def __init__(self, t, unit, pot, pots, attrs, events=None):
        super().__init__({})
        self.t = t
        self.events = events
        self.pot = pot
        self.pots = pots
        body = RigidBody(np.ones(3), units=unit) if unit else RigidBody(np.ones(3))
        m = t.shape[0]
        # The single-run schema, for the variables' names, dims, units and long names.
        # (with the run's epoch, if any: the CF time units follow it)
        epoch = {k: v for k, v in (attrs or {}).items() if k == "epoch" and v}
        tmpl = build_dataset(t, np.zeros((m, 8)), np.zeros((m, _N_DIAG)), body, pot, epoch)
        self.template = tmpl
        self.per_member_orbit = pots is not None and getattr(pot, "orbit", None) is not None
        self.attrs = {k: v for k, v in tmpl.attrs.items() if k != "inertia"}
        self.attrs["history"] = str(tmpl.attrs["history"]).replace(
            ": propagate", ": propagate_ensemble"
        )
        self.attrs.update(attrs)
        # Output choice (_plan): rows of the compiled loop's time grid that are stored (None:
        # all); the member source, for its per-member inputs (initial states, dispersions); the
        # reference attitude (stored times, 4) of the pointing error, if any.
        self.keep: np.ndarray | None = None
        self.members: Any = None
        self.reference: np.ndarray | None = None
        # Views instead of contiguous copies of the (member, time) variables: for chunks whose
        # trajectories are reduced and dropped at once (output="statistics").
        self.views = False

    def dataset(self, start, out, inertia, lazy: bool = False) -> xr.Dataset:
        """The chunk's Dataset; ``lazy``: ``out`` holds dask arrays, kept as they are."""

        def arr(x, dtype=None):
            if lazy or (self.views and dtype is None):
                return x if dtype is None else x.astype(dtype)
            return np.ascontiguousarray(x, dtype=dtype)

        if "cols" in out:  # already split into the variables (_Direct)
            cols = out["cols"]
            c = cols["q"].shape[0]
        else:
            cols = self._columns(out, lazy)
            c = out["y"].shape[0]
        tm = self.template

        data_vars: dict[str, Any] = {}
        for name, da in tm.data_vars.items():
            if name in cols:
                data_vars[name] = xr.Variable(("member", *da.dims), arr(cols[name]), da.attrs)
            elif self.per_member_orbit:  # r, f, p of each member's own orbit
                vals = [self._orbit_var(p.orbit, name) for p in self.pots[start : start + c]]
                data_vars[name] = xr.Variable(("member", *da.dims), np.stack(vals), da.attrs)
            else:
                data_vars[name] = da.variable
        inputs: dict[str, tuple] = {}
        if self.members is not None:  # the inputs that re-run a member alone (replay.py)
            inputs = self.members.member_vars(start, start + c)
        data_vars.update(member_variables(tm, inertia, inputs, out, arr))
        if self.reference is not None:
            data_vars["reference_q"] = xr.Variable(
                ("time", "component"),
                self.reference,
                {
                    "units": "1",
                    "long_name": "reference attitude of the pointing error (body to space, "
                    "scalar first)",
                },
            )
        coords = {
            "member": (
                "member",
                np.arange(start, start + c, dtype=np.int64),
                {"long_name": "ensemble member index"},
            ),
            **{k: v.variable for k, v in tm.coords.items()},
        }
        if self.events is not None:
            more, more_coords = event_variables(self.events, out, tm["time"], self.attrs, arr)
            data_vars.update(more)
            coords.update(more_coords)
        return xr.Dataset(data_vars, coords=coords, attrs=dict(self.attrs))

    def _columns(self, out, lazy):
        """The variables' arrays (views) of a chunk's states and diagnostics."""
        y, d = out["y"], out["diag"]
        if self.keep is not None:  # every k-th or the final sample (_plan)
            y, d = y[:, self.keep], d[:, self.keep]
        if not (lazy or self.views) and isinstance(y, np.ndarray) and y.flags.c_contiguous:
            return _split(y, d)
        return {
            "q": y[:, :, :4],
            "Q": y[:, :, 4:],
            "omega": d[:, :, 0:3],
            "g": d[:, :, 3:6],
            "G": d[:, :, 6:9],
            "energy": d[:, :, 9],
            "potential_energy": d[:, :, 12],
            "norm_error": d[:, :, 10],
            "qQ": d[:, :, 11],
        }

    def _orbit_var(self, orbit, name):
        from ..results import _plain

        if name == "r":
            return _plain(orbit.radius(self.t), "km")
        if name == "f":
            return _plain(orbit.true_anomaly(self.t), "rad")
        return _plain(orbit.frame_quaternion(self.t), None)

    def account(self, out, ds: xr.Dataset | None = None) -> None:
        """Add a chunk to the totals, and its successful members to the invariant maxima."""
        st = np.asarray(out["status"])
        ok = (st == _rk.SUCCESS) | (st == _rk.EVENT)
        if not ok.any():
            return self._count(out["counters"], True)
        from .._core import ensemble as _ke

        # one compiled pass (numpy's nanmax, norms and quotients took 8 passes over the chunk)
        name = self.pot.name
        kind = {"torque_free": _ke.INVARIANTS_TORQUE_FREE, "heavy_top": _ke.INVARIANTS_HEAVY_TOP}
        kind = kind.get(name, _ke.INVARIANTS_NONE)
        d = out["diag"]
        if not (isinstance(d, np.ndarray) and d.flags.c_contiguous):
            d = np.ascontiguousarray(d)
        mx = np.zeros(5)
        _ke.invariant_maxima(d, ok, kind, mx)
        upd = {"max_abs_norm_error": mx[0], "max_abs_qQ": mx[1], "max_rel_qQ": mx[2]}
        # Conserved quantities per member (as scenario.InvariantTracker, maximised over members).
        if name in ("torque_free", "heavy_top"):
            upd["max_rel_energy_error"] = mx[3]
        else:
            upd["max_rel_energy_variation"] = mx[3]
        if name == "torque_free":
            upd["max_rel_G_error"] = mx[4]
        if name == "heavy_top":
            upd["max_rel_Gz_error"] = mx[4]
        self._count(out["counters"], True, upd)


def event_variables(events: Any, out: dict, time: Any, attrs: dict, arr: Any = np.asarray):
    """The per-member event variables (``event_count``, ``event_first_time`` on (member,
    detector)) and the detector coordinates, from a chunk's ``out``."""
    from ..results import instant_attrs, time_unit

    # an instant on the time axis, encoded as `time` (docs/results.md)
    when = instant_attrs(time_unit(time), attrs.get("epoch"))
    data_vars = {
        "event_count": xr.Variable(
            ("member", "detector"),
            arr(out["event_count"], np.int64),
            {"units": "1", "long_name": "occurrences of each event"},
        ),
        "event_first_time": xr.Variable(
            ("member", "detector"),
            arr(out["event_first"]),
            {**when, "long_name": "time of the first occurrence (NaN: none)"},
        ),
    }
    n = len(events.labels)
    coords = {
        "detector": (
            "detector",
            np.arange(n, dtype=np.int64),
            {"long_name": "index of the event detector (labels in detector_label)"},
        ),
        "detector_label": ("detector", np.array(events.labels), {"long_name": "event name"}),
    }
    return data_vars, coords


class _CraftAssembler(_Totals):
    """:class:`_Assembler` of spacecraft members: a chunk's Dataset by :func:`chunk_dataset`,
    the totals, the invariant maxima of :func:`member_invariant_attrs`."""

    def __init__(self, members: Any, plan: Any, attrs: dict[str, Any]):
        super().__init__(attrs)
        self.members, self.plan = members, plan

    def dataset(self, start: int, out: dict, blk: dict) -> xr.Dataset:
        plan = self.plan
        ds = chunk_dataset(self.members, start, blk, out, plan.stored_t, plan.keep, self.attrs)
        events = self.members.events
        if events is None:
            return ds
        more, coords = event_variables(events, out, ds["time"], self.attrs)
        return ds.assign_coords(coords).assign(more)

    def account(self, out: dict, ds: xr.Dataset) -> None:
        """Add a chunk to the totals (a Taylor run counts no right-hand sides), and its
        successful members to the invariant maxima."""
        ok = np.isin(out["status"], (_rk.SUCCESS, _rk.EVENT))
        name, counts = self.members.potential.name, self.members.structure.counts
        maxima = member_invariant_attrs(ds, ok, name, counts)
        self._count(out["counters"], self.members.method != "taylor", maxima)


#: The variables split from the states and diagnostics, with their trailing shapes (in the order
#: of attitude._core.ensemble.split_samples).
_COLS = {"q": (4,), "Q": (4,), "omega": (3,), "g": (3,), "G": (3,), "energy": (), "norm_error": (),
         "qQ": (), "potential_energy": ()}  # fmt: skip


def _columns_of_one_buffer(n: int, m: int) -> dict[str, np.ndarray]:
    """The result's per-variable arrays (n, m, ...), each C-contiguous, as consecutive parts of
    one allocation: numpy backs an allocation of 4 MB or more with huge pages (where the
    kernel allows), and first touching the memory of a 2 000-member result then costs a
    quarter of what nine separate arrays (half of them below 4 MB) cost in page faults."""
    width = sum(int(np.prod(shape)) for shape in _COLS.values())
    flat = np.empty(n * m * width)
    cols = {}
    o = 0
    for k, shape in _COLS.items():
        size = n * m * int(np.prod(shape))
        cols[k] = flat[o : o + size].reshape(n, m, *shape)
        o += size
    return cols


def _split(y: np.ndarray, d: np.ndarray, out: dict[str, np.ndarray] | None = None):
    """Contiguous per-variable arrays (or ``out``'s, written) from states (N, m, 8) and
    diagnostics (N, m, 13), in one compiled pass."""
    from orbit._shared_jit import JIT_DISABLED

    from .._core.ensemble import split_samples

    n, m = y.shape[:2]
    if out is None:
        out = _columns_of_one_buffer(n, m)
    if JIT_DISABLED or not d.flags.c_contiguous:
        for k, v in (("q", y[:, :, :4]), ("Q", y[:, :, 4:]), ("omega", d[:, :, 0:3]),
                     ("g", d[:, :, 3:6]), ("G", d[:, :, 6:9]), ("energy", d[:, :, 9]),
                     ("norm_error", d[:, :, 10]), ("qQ", d[:, :, 11]),
                     ("potential_energy", d[:, :, 12])):  # fmt: skip
            out[k][...] = v
        return out
    split_samples(y, d, *out.values())
    return out


class _Direct:
    """An in-memory result assembled as the chunks finish: each chunk's states and diagnostics
    (written into one reused buffer, so its memory is touched once) are split into the result's
    per-variable arrays at once, and the Dataset is built once at the end."""

    def __init__(self, n: int, m: int) -> None:
        self.m = m
        self.cols = _columns_of_one_buffer(n, m)
        self.buf: tuple[np.ndarray, np.ndarray] | None = None
        self.parts: list[tuple[dict, np.ndarray]] = []
        self.n = 0

    def buffers(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """``y_out``, ``diag`` of a chunk's :func:`_compute_chunk`."""
        c = stop - start
        if self.buf is None or self.buf[0].shape[0] < c:
            # one allocation (as the columns): large enough for numpy's huge pages
            flat = np.empty(c * self.m * (8 + _N_DIAG))
            cut = c * self.m * 8
            self.buf = (
                flat[:cut].reshape(c, self.m, 8),
                flat[cut:].reshape(c, self.m, _N_DIAG),
            )
        return {"y_out": self.buf[0][:c], "diag": self.buf[1][:c]}

    def add(self, out: dict, inertia: np.ndarray) -> None:
        """A chunk (the next members in order; failed members included, NaN after their end)."""
        c = out["y"].shape[0]
        _split(out["y"], out["diag"], {k: v[self.n : self.n + c] for k, v in self.cols.items()})
        keep = {k: v for k, v in out.items() if k not in ("y", "diag", "error")}
        self.parts.append((keep, inertia))
        self.n += c

    def dataset(self, asm: _Assembler) -> xr.Dataset:
        """The Dataset of the members added so far (members 0..n-1)."""
        out: dict[str, Any] = {"cols": {k: v[: self.n] for k, v in self.cols.items()}}
        for key in self.parts[0][0]:
            out[key] = np.concatenate([p[key] for p, _ in self.parts])
        return asm.dataset(0, out, np.concatenate([i for _, i in self.parts]))


def _concat(parts: list[xr.Dataset], attrs: dict[str, Any]) -> xr.Dataset:
    if len(parts) == 1:
        ds = parts[0]
    else:
        data_vars = {}
        first = parts[0]
        for name, da in first.data_vars.items():
            if "member" in da.dims:
                data_vars[name] = xr.Variable(
                    da.dims, np.concatenate([p[name].values for p in parts]), da.attrs
                )
            else:
                data_vars[name] = da.variable
        coords: dict[str, Any] = {
            k: v.variable for k, v in first.coords.items() if "member" not in v.dims
        }
        coords["member"] = (
            "member",
            np.concatenate([p["member"].values for p in parts]),
            first["member"].attrs,
        )
        ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs = dict(attrs)
    return ds


def _open_result(path: Path, chunk: int, dask: bool) -> xr.Dataset:
    from ..io import read

    ds = read(path, load=False)
    if dask:
        ds = ds.chunk({"member": chunk})
    return ds


# ------------------------------------------------------------------------------------------------
# a chunk of spacecraft members
# ------------------------------------------------------------------------------------------------

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
    (:func:`~attitude.ensemble._chunks.compute_craft_chunk`) at the output times ``t``
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
    per_member_orbit = {}
    if run0.coupled:  # each member carried its own orbit: its position, velocity, mass, r, f, p
        from .._coupling import orbit_variables, sample_orbit

        specs = orbit_variables(run0.spacecraft, rows)
        flat = flat.assign({k: _variable(*v) for k, v in specs.items()})
        rm = rows.reshape(c, ms, rows.shape[1])
        per_member_orbit = sample_orbit([run.spacecraft for run in runs], t, rm)
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
        elif name in per_member_orbit:
            data_vars[name] = xr.Variable(("member", *var.dims), per_member_orbit[name],
                                          var.attrs)  # fmt: skip
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


def member_variables(
    ds: xr.Dataset,
    inertia: np.ndarray,
    inputs: dict[str, tuple],
    out: dict[str, Any],
    arr: Any = np.ascontiguousarray,
    taylor: bool = False,
) -> dict[str, xr.Variable]:
    """The per-member variables of every ensemble: ``inertia``, the ``inputs`` that re-run a
    member alone (``name: (dims, values, attrs)``; units "rate" and "momentum" become ``ds``'s
    units of omega and Q), and how each member ended (``out``'s counters and status;
    ``taylor``: a Taylor spacecraft's series terms apart from its right-hand sides)."""
    units = {
        "rate": str(ds["omega"].attrs.get("units", "1")),
        "momentum": str(ds["Q"].attrs.get("units", "1")),
    }
    v: dict[str, xr.Variable] = {
        "inertia": xr.Variable(
            ("member", "axis"),
            np.ascontiguousarray(inertia),
            {
                "units": str(ds.attrs.get("inertia_units", "1")),
                "long_name": "principal moments of inertia (I1, I2, I3)",
            },
        )
    }
    for name, (dims, val, attrs) in inputs.items():
        attrs = dict(attrs)
        if attrs.get("units") in units:
            attrs["units"] = units[attrs["units"]]
        v[name] = xr.Variable(dims, val, attrs)
    cnt = out["counters"]
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
        attrs = {"units": "1", "long_name": long}
        if name == "member_status":  # the reason a member failed (CF flags)
            attrs["flag_values"] = np.array(list(STATUS_FLAGS), dtype=np.int64)
            attrs["flag_meanings"] = " ".join(STATUS_FLAGS.values())
        v[name] = xr.Variable(("member",), arr(col, np.int64), attrs)
    return v


def _member_variables(members, start, blk, out, flat) -> dict[str, xr.Variable]:
    """Per-member inputs and statistics: what re-runs a member alone, and how it ended."""
    inputs = initial_state_vars(blk["q"], blk["Q"])
    if members.extra_vars is not None:  # e.g. a scenario's dispersions
        inputs.update(members.extra_vars(start, start + len(blk["runs"])))
    taylor = members.method == "taylor"
    v = member_variables(flat, blk["inertia"], inputs, out, taylor=taylor)
    when = instant_attrs(time_unit(flat["time"]), flat.attrs.get("epoch"))
    v["member_t_stop"] = xr.Variable(
        ("member",), np.ascontiguousarray(out["t_stop"]), {**when, "long_name": "time reached"}
    )
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
    return tr.attrs(potential_name, counts, absolute=False)

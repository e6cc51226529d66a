"""The Dataset variables of a spacecraft and its flight software: wheels, magnetorquers and
thrusters at every sample, and per tick the software's modes, references, errors, commands,
sensors and estimator (docs/results.md, "Closed loop"). The schema of the attitude itself is
:mod:`attitude.results`; these add to a Dataset it built.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from .results import SI, UnitSystem, _variable, time_attrs

__all__ = ["WHEEL_LIMIT_FLAGS", "add_actuator_variables", "add_tick_variables", "tick_dataset"]


def _indexed(dim: str, labels: Any, name: str) -> dict[str, tuple]:
    """The numeric index coordinate of ``dim`` (0..n-1, CF: dimension coordinates are numeric)
    and its auxiliary label coordinate ``<dim>_label``."""
    return {
        dim: (
            dim,
            np.arange(len(labels), dtype=np.int32),
            {"long_name": f"{name} index", "units": "1"},
        ),
        f"{dim}_label": (dim, np.array(labels), {"long_name": name}),
    }


def _extended(ds: xr.Dataset, coords: dict, new: dict, drop: tuple = ()) -> xr.Dataset:
    """``ds`` without ``drop``, with the coordinates ``coords`` ((dims, data, attrs) each) and
    the variables ``new`` added after its own: ``ds.drop_vars(drop).assign_coords(coords)
    .assign(new)`` in one Dataset construction (their merges and alignments, ~4 ms a
    closed-loop run's results, were half of a short run's time)."""
    old = {k: v for k, v in ds.variables.items() if k not in drop}
    names = [k for k in ds.coords if k not in drop]
    c = {k: old[k] for k in names}
    c.update({k: _variable(d, np.asarray(v), dict(a)) for k, (d, v, a) in coords.items()})
    data = {k: v for k, v in old.items() if k not in c}
    data.update(new)
    return xr.Dataset(data, coords=c, attrs=dict(ds.attrs))


#: CF flag masks and meanings of ``wheel_limit`` (attitude._core.actuators FLAG_*).
WHEEL_LIMIT_FLAGS = (
    (1, "torque_limit"),
    (2, "speed_limit"),
    (4, "power_limit"),
    (8, "dead_band"),
)


def add_actuator_variables(ds: xr.Dataset, run: Any, rows: np.ndarray, d: dict) -> xr.Dataset:
    """The actuators of a spacecraft run as variables (docs/results.md, "Actuators").

    On the dimensions ``wheel``, ``magnetorquer``, ``thruster`` (labels in ``*_label``): the
    wheels' speed relative to the body, axial momentum, command, applied motor torque,
    friction torque and limit flags; the magnetorquers' commanded and applied dipoles; the
    thrusters' commands and forces; the actuators' constants. The torque budget gains the
    terms ``wheels`` (the torque of the wheels' motors and bearings on the body: internal,
    left out of ``total``), ``magnetorquers`` and ``thrusters``.
    """
    from ._core import holds as _kh

    craft = run.spacecraft
    u = UnitSystem(craft.body)
    nw, nm, nt = craft.counts
    rec = d["records"]  # per actuator its columns (attitude._core.holds *_REC), a row a sample
    wn, mn, tn = craft.names()

    def var(dims, data, units, long_name, **extra):
        attrs = {"long_name": long_name, **extra}
        if units is not None:
            attrs = {"units": units, **attrs}
        return _variable(dims, np.ascontiguousarray(data), attrs)

    new: dict[str, xr.Variable] = {}
    coords: dict[str, Any] = {}
    c = 0
    if nw:
        coords.update(_indexed("wheel", wn, "reaction wheel"))
        r = _kh.WHEEL_REC.read(
            rec[:, c : c + _kh.WHEEL_REC.SIZE * nw].reshape(-1, nw, _kh.WHEEL_REC.SIZE)
        )
        new["wheel_speed"] = var(
            ("time", "wheel"), d["wheels"][:, :, 0], u.rate, "wheel speed relative to the body"
        )
        new["wheel_momentum"] = var(
            ("time", "wheel"),
            rows[:, 8 : 8 + nw],
            u.momentum,
            "axial angular momentum of the wheel, J (a.omega + speed)",
        )
        new["wheel_torque_command"] = var(
            ("time", "wheel"), r["cmd"], u.torque, "commanded motor torque"
        )
        new["wheel_torque"] = var(
            ("time", "wheel"),
            r["torque"],
            u.torque,
            "applied motor torque (after the wheel's limits)",
        )
        new["wheel_friction"] = var(
            ("time", "wheel"),
            d["wheels"][:, :, 1],
            u.torque,
            "bearing friction torque on the wheel",
        )
        new["wheel_limit"] = var(
            ("time", "wheel"),
            # (0 on a member's rows after it ended, NaN elsewhere: no flag to cast)
            np.nan_to_num(r["flags"], nan=0.0).astype(np.int8),
            None,
            "limits acting on the wheel command",
            flag_masks=np.array([m for m, _ in WHEEL_LIMIT_FLAGS], dtype=np.int8),
            flag_meanings=" ".join(name for _, name in WHEEL_LIMIT_FLAGS),
        )
        new.update(_constants(craft, u, var, "wheel"))
        c += _kh.WHEEL_REC.SIZE * nw
    if nm:
        coords.update(_indexed("magnetorquer", mn, "magnetorquer"))
        r = _kh.MTQ_REC.read(
            rec[:, c : c + _kh.MTQ_REC.SIZE * nm].reshape(-1, nm, _kh.MTQ_REC.SIZE)
        )
        dip = "A m^2" if u.torque != "1" else "1"
        new["dipole_command"] = var(
            ("time", "magnetorquer"), r["cmd"], dip, "commanded magnetic dipole"
        )
        new["dipole"] = var(
            ("time", "magnetorquer"),
            r["applied"],
            dip,
            "applied magnetic dipole (clipped to the rod's limit)",
        )
        new.update(_constants(craft, u, var, "magnetorquer"))
        c += _kh.MTQ_REC.SIZE * nm
    if nt:
        coords.update(_indexed("thruster", tn, "thruster"))
        r = _kh.THR_REC.read(
            rec[:, c : c + _kh.THR_REC.SIZE * nt].reshape(-1, nt, _kh.THR_REC.SIZE)
        )
        fmax = np.array([x.max_thrust for x in craft.thrusters])
        force = u.torque.replace(" m", "") if u.torque != "1" else "1"
        new["thruster_command"] = var(
            ("time", "thruster"), r["cmd"], "1", "commanded on-time fraction of the hold"
        )
        new["thruster_force"] = var(
            ("time", "thruster"),
            r["firing"] * fmax,
            force,
            "thrust at the sample (0 when not firing)",
        )
        new.update(_constants(craft, u, var, "thruster"))
    # The torque budget with the actuators.
    terms = list(ds.model_label.values[:-1])
    tq = d["torques"]
    parts = [tq[:, :-1]]
    total = tq[:, -1].copy()
    names = list(terms)
    ideal = bool(getattr(run, "ideal_control", False))
    for j, (label, present) in enumerate(
        (("wheels", nw), ("magnetorquers", nm), ("thrusters", nt), ("control", ideal))
    ):
        if present:
            parts.append(d["actuators"][:, j : j + 1])
            names.append(label)
            if label != "wheels":
                total = total + d["actuators"][:, j]
    parts.append(total[:, None])
    names.append("total")
    drop = ("torque", "model", "model_label")
    coords["model"] = (
        "model",
        np.arange(len(names), dtype=np.int32),
        {"long_name": "torque model term index (labels in model_label)", "units": "1"},
    )
    coords["model_label"] = ("model", np.array(names), {"long_name": "torque model term"})
    new["torque"] = var(
        ("time", "model", "axis"),
        np.concatenate(parts, axis=1),
        u.torque,
        "body-frame torque of each model term and actuator, and the external total "
        "(model = total; the wheels' torque is internal and not in it)",
    )
    return _extended(ds, coords, new, drop)


def _constants(craft: Any, u: UnitSystem, var: Any, kind: str) -> dict[str, xr.Variable]:
    """The constants of a spacecraft's actuators of one kind (``"wheel"``, ``"magnetorquer"``,
    ``"thruster"``) as variables on that dimension."""
    if kind == "wheel":
        return {
            "wheel_axis": var(
                ("wheel", "axis"), craft.wheel_axes, "1", "wheel spin axis in body axes"
            ),
            "wheel_inertia": var(
                ("wheel",), craft.wheel_inertias, u.inertia, "wheel axial moment of inertia"
            ),
            "wheel_max_torque": var(
                ("wheel",),
                np.array([x.max_torque for x in craft.wheels]),
                u.torque,
                "motor torque limit (inf: none)",
            ),
            "wheel_max_speed": var(
                ("wheel",),
                np.array([x.max_speed for x in craft.wheels]),
                u.rate,
                "wheel speed limit (inf: none)",
            ),
        }
    if kind == "magnetorquer":
        return {
            "magnetorquer_axis": var(
                ("magnetorquer", "axis"),
                np.array([x.axis for x in craft.magnetorquers]),
                "1",
                "magnetorquer axis in body axes",
            ),
            "magnetorquer_max_dipole": var(
                ("magnetorquer",),
                np.array([x.max_dipole for x in craft.magnetorquers], dtype=np.float64),
                "A m^2" if u.torque != "1" else "1",
                "magnetorquer dipole limit (the command is clipped to +-it)",
            ),
        }
    return {
        "thruster_direction": var(
            ("thruster", "axis"),
            np.array([x.direction for x in craft.thrusters]),
            "1",
            "force direction in body axes",
        ),
        "thruster_position": var(
            ("thruster", "axis"),
            np.array([x.position for x in craft.thrusters]),
            SI["length"] if u.torque != "1" else "1",
            "point of application in body axes",
        ),
        "thruster_max_thrust": var(
            ("thruster",),
            np.array([x.max_thrust for x in craft.thrusters], dtype=np.float64),
            u.torque.replace(" m", "") if u.torque != "1" else "1",
            "thrust when firing",
        ),
    }


def actuator_constants(craft: Any) -> dict[str, xr.Variable]:
    """The variables of :func:`add_actuator_variables` that hold a spacecraft's constants (axes,
    inertias, limits; no ``time`` dimension): what differs between ensemble members."""
    u = UnitSystem(craft.body)

    def var(dims, data, units, long_name):
        return _variable(dims, np.ascontiguousarray(data), {"units": units, "long_name": long_name})

    nw, nm, nt = craft.counts
    out: dict[str, xr.Variable] = {}
    for kind, count in (("wheel", nw), ("magnetorquer", nm), ("thruster", nt)):
        if count:
            out.update(_constants(craft, u, var, kind))
    return out


def tick_dataset(run: Any, rec: np.ndarray, attrs: dict) -> xr.Dataset:
    """The tick variables of the records ``rec`` alone: a streamed chunk of ticks (``attrs``:
    the run's, whose ``epoch`` sets the ``tick`` coordinate's units)."""
    return add_tick_variables(xr.Dataset(attrs=dict(attrs)), run, rec)


def add_tick_variables(ds: xr.Dataset, run: Any, rec: np.ndarray | None = None) -> xr.Dataset:
    """The flight software's records on a ``tick`` dimension (docs/flight_software.md).

    ``tick`` is the time of each recorded tick (a CF time coordinate like ``time``);
    ``mode`` (CF flags naming the modes), ``reference_q``, ``sigma_error`` (σ_BR, MRP),
    ``error_angle``, ``rate_error`` (ω − ω_r, body axes), ``torque_request``,
    ``dipole_request``, and per command (dimension ``command``, labels in ``command_label``)
    ``command_sent`` (computed at the tick) and ``command_applied`` (in force from the tick:
    after the delay and, for wheels, their limits). ``rec``: the records (default the run's).
    """
    from ._core import fsw as _kf

    prog = run.program
    if rec is None:
        rec = run.ticks if run.ticks is not None else np.zeros((0, prog.rec_width))
    craft = run.spacecraft
    u = UnitSystem(craft.body)
    ncmd = prog.n_cmd
    wn, mn, tn = craft.names()

    def var(dims, data, units, long_name, **extra):
        attrs = {"long_name": long_name, **extra}
        if units is not None:
            attrs = {"units": units, **attrs}
        return _variable(dims, np.ascontiguousarray(data), attrs)

    n_modes = len(prog.mode_names)
    f = _kf.R.read(rec)  # the record's fields, a column or columns each
    new = {
        "mode": var(
            ("tick",),
            f["mode"].astype(np.int32),
            None,
            "active flight-software mode",
            flag_values=np.arange(n_modes, dtype=np.int32),
            flag_meanings=" ".join(prog.mode_names),
        ),
        "reference_q": var(
            ("tick", "component"),
            f["qref"],
            "1",
            "reference attitude quaternion (guidance), reference to space",
        ),
        "sigma_error": var(
            ("tick", "axis"),
            f["sigma"],
            "1",
            "attitude error sigma_BR (modified Rodrigues parameters)",
        ),
        "error_angle": var(("tick",), f["angle"], "rad", "attitude error angle from the reference"),
        "rate_error": var(
            ("tick", "axis"),
            f["domega"],
            u.rate,
            "angular velocity error omega - omega_r, body axes",
        ),
        "torque_request": var(
            ("tick", "axis"),
            f["torque"],
            u.torque,
            "control torque requested by the control law, body axes",
        ),
        "dipole_request": var(
            ("tick", "axis"),
            f["dipole"],
            "A m^2" if u.torque != "1" else "1",
            "magnetic dipole requested, body axes",
        ),
    }
    coords: dict[str, Any] = {}
    if ncmd:
        labels = [*wn, *mn, *tn]
        units = [u.torque] * len(wn) + ["A m^2"] * len(mn) + ["1"] * len(tn)
        c0 = _kf.R.CMD
        new["command_sent"] = var(
            ("tick", "command"),
            rec[:, c0 : c0 + ncmd],
            None,
            "actuator commands computed at the tick (units in command_units)",
        )
        new["command_applied"] = var(
            ("tick", "command"),
            rec[:, c0 + ncmd : c0 + 2 * ncmd],
            None,
            "actuator commands in force from the tick (after the delay and the wheels' limits)",
        )
        coords.update(_indexed("command", labels, "actuator command"))
        coords["command_units"] = (
            "command",
            np.array(units),
            {"long_name": "unit of each actuator command"},
        )
    if prog.sensors or prog.estimator is not None:
        new.update(_sensor_variables(rec[:, _kf.R.CMD + 2 * ncmd :], prog, u, var, coords))
    ta = time_attrs(u.time, ds.attrs.get("epoch"))
    ta = {**ta, "long_name": "time of the flight-software tick"}
    coords["tick"] = ("tick", f["t"].astype(np.float64), ta)
    out = _extended(ds, coords, new)
    if prog.sensors:
        out.attrs["sensor_seeds"] = ", ".join(f"{x.kind}={x.seed}" for x in prog.sensors)
    return out


def _sensor_variables(r: np.ndarray, prog: Any, u: UnitSystem, var: Any, coords: dict) -> dict:
    """The sensors' measurements and the estimator's estimate at the ticks."""
    from ._core import fsw as _kf
    from ._core import sensors as _ks

    kinds = {x.kind for x in prog.sensors}
    out: dict[str, Any] = {}
    z = _ks.Z.read(r)
    if "gyro" in kinds:
        out["gyro_rate"] = var(
            ("tick", "axis"),
            z["omega"],
            u.rate,
            "gyro measurement (body axes)",
        )
    if "star_tracker" in kinds:
        out["star_tracker_q"] = var(
            ("tick", "component"),
            z["q"],
            "1",
            "star tracker attitude quaternion, body to space",
        )
        out["star_tracker_status"] = var(
            ("tick",),
            z["st_flag"].astype(np.int8),
            None,
            "star tracker measurement status",
            flag_values=np.array([0, 1, 2, 3], dtype=np.int8),
            flag_meanings="valid no_update sun_exclusion earth_exclusion",
        )
    if "magnetometer" in kinds:
        out["magnetometer"] = var(
            ("tick", "axis"),
            z["b"],
            "T",
            "magnetometer measurement (body axes)",
        )
    if "sun_sensor" in kinds:
        out["sun_direction"] = var(
            ("tick", "axis"),
            z["sun"],
            "1",
            "Sun direction from the coarse Sun sensor (body axes; NaN: not enough heads lit)",
        )
    if kinds & {"sun_sensor", "star_tracker"}:
        out["sunlight"] = var(
            ("tick",), z["eclipse"], "1", "fraction of the solar disk visible (0: umbra)"
        )
    if prog.estimator is not None:
        est = _kf.RS.read(r, _ks.Z.SIZE)
        out["estimate_q"] = var(
            ("tick", "component"),
            est["q"],
            "1",
            "estimated attitude quaternion (MEKF), body to space",
        )
        out["bias_estimate"] = var(
            ("tick", "axis"),
            est["b"],
            u.rate,
            "estimated gyro bias (body axes)",
        )
        out["estimation_sigma"] = var(
            ("tick", "error_state"),
            est["sigma"],
            None,
            "1-sigma of the error states (sqrt of the MEKF covariance"
            " diagonal; units in error_state_units)",
        )
        out["estimation_error"] = var(
            ("tick", "error_state"),
            est["err"],
            None,
            "estimation error: the truth is the estimate "
            "rotated by the first three (rad, body axes); the "
            "true bias minus the estimate (last three)",
        )
        out["nees"] = var(
            ("tick",),
            est["nees"],
            "1",
            "normalised estimation error squared (6 degrees of freedom)",
        )
        coords["error_state"] = (
            "error_state",
            np.arange(6, dtype=np.int32),
            {"long_name": "MEKF error state index", "units": "1"},
        )
        coords["error_state_label"] = (
            "error_state",
            np.array(["attitude_x", "attitude_y", "attitude_z", "bias_x", "bias_y", "bias_z"]),
            {"long_name": "MEKF error state"},
        )
        coords["error_state_units"] = (
            "error_state",
            np.array(["rad"] * 3 + [u.rate] * 3),
            {"long_name": "unit of each error state"},
        )
    return out

"""The actuators of a scenario: ``[[spacecraft.wheels]]``, ``[[spacecraft.magnetorquers]]``,
``[[spacecraft.thrusters]]`` and the open-loop ``[commands]`` (inline or a CSV file)."""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import AttitudeError
from ._schema import ScenarioError, _fail, _is_number, _Reader

#: Keys of each actuator table: quantity kind of ``<key>_unit`` (None: plain, no unit).
WHEEL_KEYS: dict[str, str | None] = {
    "axis": None,
    "inertia": "inertia",
    "max_torque": "torque",
    "max_speed": "rate",
    "speed": "rate",
    "min_torque": "torque",
    "max_power": "power",
    "coulomb_friction": "torque",
    "static_friction": "torque",
    "viscous_friction": "viscous",
    "stribeck_speed": "rate",
    "limit_cycle_speed": "rate",
    "name": None,
}
MAGNETORQUER_KEYS: dict[str, str | None] = {"axis": None, "max_dipole": "dipole", "name": None}
THRUSTER_KEYS: dict[str, str | None] = {
    "position": "position",
    "direction": None,
    "max_thrust": "force",
    "min_impulse_bit": "impulse",
    "isp": "time",
    "name": None,
}
#: Keys of [spacecraft] that describe actuators (the rest serve the environment models).
ACTUATOR_KEYS = ("wheels", "magnetorquers", "thrusters", "center_of_mass", "mass")
_VECTORS = {"axis", "direction", "position"}


def _records(
    r: _Reader, sc: Mapping[str, Any], key: str, keys: dict[str, str | None], required: tuple
) -> list[dict[str, Any]]:
    """The array of tables ``[[spacecraft.<key>]]`` as keyword dicts in internal units."""
    spec = sc.get(key)
    if spec is None:
        return []
    if not isinstance(spec, list) or not all(isinstance(x, dict) for x in spec):
        raise _fail(f"spacecraft.{key}", f"expected an array of tables [[spacecraft.{key}]]")
    allowed = set(keys) | {f"{k}_unit" for k, kind in keys.items() if kind}
    out = []
    for i, t in enumerate(spec):
        where = f"spacecraft.{key}[{i}]"
        for k in t:
            if k not in allowed:
                close = difflib.get_close_matches(k, sorted(allowed), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise _fail(
                    f"{where}.{k}", f"unknown key{hint} (allowed: {', '.join(sorted(allowed))})"
                )
        for k in required:
            if k not in t:
                raise _fail(f"{where}.{k}", "missing")
        kw: dict[str, Any] = {}
        for k, kind in keys.items():
            if k not in t:
                if f"{k}_unit" in t:
                    raise _fail(f"{where}.{k}_unit", f"given without {where}.{k}")
                continue
            if k == "name":
                kw[k] = r.string(t, k, where)
            elif kind is None:
                kw[k] = r.array(t, k, where, 3)
            elif k in _VECTORS:
                kw[k] = r.value(t, k, where, kind, n=3)
            else:
                v = t[k]
                if v == "inf" or (_is_number(v) and v == math.inf):
                    kw[k] = math.inf
                else:
                    kw[k] = r.value(t, k, where, kind)
        out.append((where, kw))
    return out


def spacecraft(r: _Reader, sc: Mapping[str, Any], body: Any, orbit: Any, field: str) -> Any:
    """The :class:`attitude.Spacecraft` of the ``[spacecraft]`` actuator tables, or None."""
    from ..actuators import Magnetorquer, ReactionWheel, Thruster
    from ..spacecraft import Spacecraft

    built: list[list[Any]] = []
    for key, keys, cls, required in (
        ("wheels", WHEEL_KEYS, ReactionWheel, ("axis", "inertia")),
        ("magnetorquers", MAGNETORQUER_KEYS, Magnetorquer, ("axis", "max_dipole")),
        ("thrusters", THRUSTER_KEYS, Thruster, ("position", "direction", "max_thrust")),
    ):
        items = []
        for where, kw in _records(r, sc, key, keys, required):
            pos = [kw.pop(k) for k in required]
            try:
                items.append(cls(*pos, **kw))
            except AttitudeError as exc:
                raise ScenarioError(f"{where}.{exc}") from None
        built.append(items)
    if "center_of_mass" in sc and not built[2]:
        raise _fail(
            "spacecraft.center_of_mass", "given without thrusters (their lever arms use it)"
        )
    mass = r.value(sc, "mass", "spacecraft", "mass", default=None)
    if not any(built) and mass is None:
        return None
    cm = None
    if "center_of_mass" in sc:
        cm = r.value(sc, "center_of_mass", "spacecraft", "position", n=3)
    if built[1] and orbit is None:
        raise _fail(
            "spacecraft.magnetorquers",
            "magnetorquers act in the geomagnetic field along the orbit: add an [orbit] table",
        )
    try:
        return Spacecraft(body, built[0], built[1], built[2], orbit, center_of_mass=cm,
                          field=field, mass=mass)  # fmt: skip
    except AttitudeError as exc:
        raise ScenarioError(f"spacecraft.{exc}") from None


COMMAND_KEYS: dict[str, str | None] = {
    "times": "time",
    "wheel_torque": "torque",
    "dipole": "dipole",
    "thrust": None,
    "file": None,
}


def commands(r: _Reader, ct: Mapping[str, Any], craft: Any, path: Path | None) -> Any:
    """The ``[commands]`` table as a :class:`attitude.CommandSchedule` (or None)."""
    from ..actuators import CommandSchedule

    if not ct:
        return None
    if craft is None:
        raise _fail(
            "commands",
            "the schedule commands actuators, and the scenario has none: add "
            "[[spacecraft.wheels]], [[spacecraft.magnetorquers]] or [[spacecraft.thrusters]]",
        )
    if "file" in ct:
        for k in ct:
            if k != "file":
                raise _fail(f"commands.{k}", "not used with commands.file (the CSV holds them)")
        name = r.string(ct, "file", "commands")
        p = Path(name)
        if not p.is_absolute() and path is not None:
            p = path.parent / p
        try:
            sched = CommandSchedule.from_csv(p)
        except AttitudeError as exc:
            raise ScenarioError(f"commands.file: {exc}") from None
    else:
        if "times" not in ct:
            raise _fail("commands.times", "missing (the start times of the holds)")
        times = ct["times"]
        if not isinstance(times, list) or not times or not all(_is_number(x) for x in times):
            raise _fail("commands.times", f"expected an array of times, got {times!r}")
        unit = r.unit(ct, "times", "commands", "time")
        tv = np.array(times, dtype=np.float64)
        if unit is not None:
            tv = (tv * unit).to_value("s")
        cols: dict[str, Any] = {}
        for k in ("wheel_torque", "dipole", "thrust"):
            if k not in ct:
                if f"{k}_unit" in ct:
                    raise _fail(f"commands.{k}_unit", f"given without commands.{k}")
                continue
            v = ct[k]
            ok = (
                isinstance(v, list)
                and len(v) == len(times)
                and all(isinstance(row, list) and all(_is_number(x) for x in row) for row in v)
                and len({len(row) for row in v}) == 1
            )
            if not ok:
                raise _fail(
                    f"commands.{k}",
                    f"expected an array of {len(times)} rows (one per time), each with one "
                    "number per actuator",
                )
            arr = np.array(v, dtype=np.float64)
            kind = COMMAND_KEYS[k]
            if kind is not None:
                u = r.unit(ct, k, "commands", kind)
                if u is not None:
                    arr = (arr * u).to_value({"torque": "N m", "dipole": "A m2"}[kind])
            cols[k] = arr
        try:
            sched = CommandSchedule(tv, **cols)
        except AttitudeError as exc:
            raise ScenarioError(f"commands.{exc}") from None
    try:
        sched.arrays(*craft.counts)
    except AttitudeError as exc:
        raise ScenarioError(str(exc)) from None
    return sched

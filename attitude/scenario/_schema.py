"""Scenario files: their tables, keys and units, and a reader whose errors name the key."""

from __future__ import annotations

import difflib
import math
import sys
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import AttitudeValueError

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover - Python 3.10
    pass


class ScenarioError(AttitudeValueError):
    """A scenario file is invalid: the message names the key and what was expected."""


# Internal units of dimensional scenarios: the body in SI (kg m², N, m), the orbit in km and s.
# Any unit astropy converts to these is accepted (e.g. the paper's kg km²).
_INTERNAL = {
    "inertia": "kg m2",
    "momentum": "kg m2 s-1",
    "rate": "rad s-1",
    "time": "s",
    "length": "km",
    "position": "m",
    "angle": "rad",
    "force": "N",
    "mu": "km3 s-2",
    "area": "m2",
    "dipole": "A m2",
    "conductance": "S m4",
    "size": "byte",
    "torque": "N m",
    "power": "W",
    "viscous": "N m s",
    "impulse": "N s",
    "mass": "kg",
    "speed": "km s-1",
    "velocity": "m s-1",
}
_EXAMPLE = {
    "inertia": "'kg m2' or 'kg km2'",
    "momentum": "'kg m2 s-1' or 'N m s'",
    "rate": "'rad/s', 'deg/s' or 'rpm'",
    "time": "'s', 'min', 'h' or 'd'",
    "length": "'km' or 'm'",
    "position": "'m' or 'cm'",
    "angle": "'deg' or 'rad'",
    "force": "'N' (a weight M g)",
    "mu": "'km3 s-2'",
    "area": "'m2' or 'cm2'",
    "dipole": "'A m2'",
    "conductance": "'S m4' (A m2 per T per T/s)",
    "size": "'GB' or 'MB'",
    "torque": "'N m' or 'mN m'",
    "power": "'W'",
    "viscous": "'N m s'",
    "impulse": "'N s' or 'mN s'",
    "mass": "'kg' or 'g'",
    "speed": "'km/s' or 'm/s'",
    "velocity": "'m/s' or 'cm/s'",
}

_ALIASES: list[Any] = []


def parse_unit(s: str) -> Any:
    """The astropy unit of a scenario's unit string, with the spellings of rotation rates that
    astropy does not know: ``rpm`` (= astropy's ``cycle/min``) and ``rev`` (= ``cycle``), also
    inside compound units (``rpm/s``, ``rev/s``). Raises ValueError as ``astropy.units.Unit``."""
    from astropy import units as u

    if not _ALIASES:
        _ALIASES.append(u.def_unit(["rpm", "RPM"], u.cycle / u.min, doc="revolutions a minute"))
        _ALIASES.append(u.def_unit(["rev", "revolution"], u.cycle, doc="one revolution"))
    with u.add_enabled_units(_ALIASES):
        return u.Unit(s)


# Allowed keys per table (value: quantity kind for "<key>_unit", or None).
_TABLES: dict[str, dict[str, str | None]] = {
    "scenario": {
        "name": None,
        "title": None,
        "description": None,
        "epoch": None,
        "object_name": None,
        "object_id": None,
        "inertial_frame": None,
    },
    "body": {"inertia": "inertia"},
    "initial_state": {
        "form": None,
        "frame": None,
        "q": None,
        "Q": "momentum",
        "omega": "rate",
        "seq": None,
        "angles": "angle",
        "momenta": "momentum",
    },
    "potential": {
        "kind": None,
        "models": None,
        "weight": "force",
        "center_of_mass": "position",
        "field": None,
        "density": None,
        "f107": None,
        "f107a": None,
        "ap": None,
        "eclipse": None,
        "step": "time",
    },
    # what the environment models need to know about the spacecraft (docs/scenarios.md)
    # and its actuators (docs/actuators.md; keys of their tables in scenario/_actuators.py)
    "spacecraft": {
        "dipole": "dipole",
        "eddy_tensor": "conductance",
        "facets": None,
        "wheels": None,
        "magnetorquers": None,
        "thrusters": None,
        "center_of_mass": "position",
        "mass": "mass",
    },
    # the flight software (attitude.FlightSoftware; keys in scenario/_software.py)
    "software": {},
    # open-loop actuator commands held from each time to the next (attitude.CommandSchedule)
    "commands": {
        "times": "time",
        "wheel_torque": "torque",
        "dipole": "dipole",
        "thrust": None,
        "file": None,
    },
    "orbit": {
        "type": None,
        "epoch": None,
        "a": "length",
        "e": None,
        "inc": "angle",
        "raan": "angle",
        "argp": "angle",
        "f0": "angle",
        "mu": "mu",
        "j2": None,
        "radius": "length",
        "tle": None,
        "oem": None,
        "step": "time",
        "r0": "length",
        "v0": "speed",
        "degree": None,
        "order": None,
        "third_bodies": None,
        "earth_rotation": None,
        "rtol": None,
        "method": None,
        "field_step": "time",
    },
    "time": {"start": "time", "stop": "time", "step": "time", "count": None, "unit": None},
    "integrator": {
        "method": None,
        "rtol": None,
        "atol": None,
        "max_step": "time",
        "max_steps": None,
        "dt": "time",
        "order": None,
        "formulation": None,
    },
    "output": {"path": None, "plot_layout": None},
    # [events.<name>] subtables (attitude.events, docs/events.md; keys in _EVENT_KEYS)
    "events": {},
    # Monte Carlo dispersions (attitude.ensemble.Dispersions, docs/ensemble.md)
    "ensemble": {
        "size": None,
        "seed": None,
        "chunk": None,
        "attitude_error": "angle",
        "attitude_distribution": None,
        "rate_error": "rate",
        "rate_distribution": None,
        "inertia_error": None,
        "inertia_distribution": None,
        "position_error": "position",
        "velocity_error": "velocity",
        "mass_error": None,
        "output": None,
        "every": None,
        "percentiles": None,
        "max_output_size": "size",
    },
}
# Keys of each named subtable of [events] ([events.<name>], attitude.events, docs/events.md).
_EVENT_KEYS: dict[str, str | None] = {
    "type": None,
    "frame": None,
    "frame_q": None,
    "axis": None,
    "angle": "angle",
    "rate": "rate",
    "direction": None,
    "terminal": None,
    "samples": None,
    "shadow": None,
}
_EVENT_TYPES = ("pointing_exceeds", "rate_exceeds", "eclipse_entry", "eclipse_exit", "angle_to_sun")
#: The keys each event type reads (besides type, terminal and samples, which all read): any
#: other key of _EVENT_KEYS in its table is an error, not silently ignored.
_EVENT_TYPE_KEYS: dict[str, tuple[str, ...]] = {
    "pointing_exceeds": ("frame", "frame_q", "axis", "angle", "direction"),
    "rate_exceeds": ("rate", "direction"),
    "eclipse_entry": ("shadow",),
    "eclipse_exit": ("shadow",),
    "angle_to_sun": ("axis", "angle", "direction"),
}
#: Reference frames a scenario names (attitude.frames); "orbital" is the paper's p(t), rsw.
_FRAMES = ("inertial", "orbital", "lvlh", "rsw", "vnc", "nadir", "sun_pointing")
_REQUIRED_TABLES = ("body", "initial_state", "time")

_FORMS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    # form: (required keys, optional keys) besides "form" and "frame"
    "canonical": (("q", "Q"), ()),
    "body_rates": (("q", "omega"), ()),
    "euler_canonical": (("angles", "momenta"), ()),
    "euler_body_rates": (("seq", "angles", "omega"), ()),
}
_KINDS = {
    # model: (required keys, optional keys) of [potential]
    "torque_free": ((), ()),
    "heavy_top": (("weight", "center_of_mass"), ()),
    "gravity_gradient": ((), ()),
    "magnetic_dipole": ((), ("field", "step")),
    "eddy_current_damping": ((), ("field", "step")),
    "aerodynamic_drag": ((), ("density", "f107", "f107a", "ap", "step")),
    "solar_radiation": ((), ("eclipse", "step")),
}
#: Models that need an [orbit]; the environment models also an epoch and [spacecraft] keys.
_ORBIT_MODELS = (
    "gravity_gradient",
    "magnetic_dipole",
    "eddy_current_damping",
    "aerodynamic_drag",
    "solar_radiation",
)
_SPACECRAFT_KEYS = {
    "magnetic_dipole": "dipole",
    "eddy_current_damping": "eddy_tensor",
    "aerodynamic_drag": "facets",
    "solar_radiation": "facets",
}
_FACET_KEYS = ("area", "normal", "center", "cd", "specular", "diffuse")
# Quantities that carry units also in a dimensionless scenario.
_ALWAYS_UNIT = {"angle", "size"}


def _fail(key: str, msg: str) -> ScenarioError:
    return ScenarioError(f"{key}: {msg}")


def _unknown_choice(key: str, name: str, choices: tuple[str, ...], note: str = "") -> ScenarioError:
    """The error for a name that is not one of ``choices``: the name, the valid choices and
    the closest one (difflib) if any is close, e.g. 'intertial' → 'inertial'."""
    close = difflib.get_close_matches(name, choices, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return _fail(key, f"unknown name {name!r}: expected one of {', '.join(choices)}{note}{hint}")


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


class _Reader:
    """Typed access to the parsed TOML with errors naming the key."""

    def __init__(self, data: Mapping[str, Any]):
        self.data = data
        self.dimensionless = True

    def table(self, name: str, required: bool = False) -> dict[str, Any]:
        t = self.data.get(name)
        if t is None:
            if required:
                raise _fail(f"[{name}]", "missing table (see docs/scenarios.md)")
            return {}
        if not isinstance(t, dict):
            raise _fail(name, f"expected a table [{name}], got {type(t).__name__}")
        return t

    def check_keys(self, name: str, table: Mapping[str, Any]) -> None:
        allowed = _TABLES[name]
        names = set(allowed) | {f"{k}_unit" for k, kind in allowed.items() if kind}
        for k in table:
            if k not in names:
                close = difflib.get_close_matches(k, sorted(names), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise _fail(
                    f"{name}.{k}",
                    f"unknown key{hint} (allowed in [{name}]: {', '.join(sorted(names))})",
                )

    def string(self, t: Mapping[str, Any], key: str, where: str, default: Any = ...) -> Any:
        if key not in t:
            if default is ...:
                raise _fail(f"{where}.{key}", "missing (a string)")
            return default
        v = t[key]
        if not isinstance(v, str):
            raise _fail(f"{where}.{key}", f"expected a string, got {v!r}")
        return v

    def number(self, t, key, where, default: Any = ...) -> Any:
        if key not in t:
            if default is ...:
                raise _fail(f"{where}.{key}", "missing (a number)")
            return default
        v = t[key]
        if not _is_number(v):
            raise _fail(f"{where}.{key}", f"expected a number, got {v!r}")
        if not math.isfinite(v):
            raise _fail(f"{where}.{key}", f"must be finite, got {v!r}")
        return float(v)

    def array(self, t, key, where, n: int) -> np.ndarray:
        if key not in t:
            raise _fail(f"{where}.{key}", f"missing (an array of {n} numbers)")
        v = t[key]
        if (
            not isinstance(v, list)
            or len(v) != n
            or not all(_is_number(x) and math.isfinite(x) for x in v)
        ):
            raise _fail(f"{where}.{key}", f"expected an array of {n} finite numbers, got {v!r}")
        return np.array(v, dtype=np.float64)

    def unit(self, t, key, where, kind: str) -> Any:
        """The astropy unit of ``key`` from ``<key>_unit`` (None: plain internal number)."""
        from astropy import units as u

        ukey = f"{key}_unit"
        full = f"{where}.{ukey}"
        needs = kind in _ALWAYS_UNIT or not self.dimensionless
        if ukey not in t:
            if needs:
                raise _fail(
                    f"{where}.{key}",
                    f"needs a unit: add {ukey} = {_EXAMPLE[kind].split(' or ')[0]} "
                    f"(any {kind} unit, e.g. {_EXAMPLE[kind]})",
                )
            return None
        if not needs:
            raise _fail(
                full,
                "the body is dimensionless (no body.inertia_unit), so this quantity is a plain "
                "number in the same units; remove the unit or give body.inertia_unit",
            )
        s = t[ukey]
        if not isinstance(s, str):
            raise _fail(full, f"expected a unit string such as {_EXAMPLE[kind]}, got {s!r}")
        try:
            unit = parse_unit(s)
        except ValueError:
            raise _fail(
                full, f"{s!r} is not a unit astropy understands (e.g. {_EXAMPLE[kind]})"
            ) from None
        if not unit.is_equivalent(u.Unit(_INTERNAL[kind])):
            article = "an" if kind[0] in "aeiou" else "a"
            raise _fail(
                full, f"{s!r} is not {article} {kind} unit (expected e.g. {_EXAMPLE[kind]})"
            )
        return unit

    @staticmethod
    def given(t: Mapping[str, Any], key: str, default: Any = 0.0) -> str:
        """``key``'s value as the user wrote it, with its unit (for messages)."""
        unit = t.get(f"{key}_unit")
        return f"{t.get(key, default)!r}" + (f" {unit}" if isinstance(unit, str) else "")

    def value(self, t, key, where, kind: str, n: int | None = None, default: Any = ...) -> Any:
        """Number or array converted to internal units (float or ndarray)."""
        if key not in t and default is not ...:
            if f"{key}_unit" in t:
                raise _fail(f"{where}.{key}_unit", f"given without {where}.{key}")
            return default
        v = self.number(t, key, where) if n is None else self.array(t, key, where, n)
        unit = self.unit(t, key, where, kind)
        if unit is None:
            return v
        return (v * unit).to_value(_INTERNAL[kind])


def _only(t, where, what, required, always, selector):
    """Check that table ``t`` has exactly the keys of the selected form/kind."""
    base = {k for k in t if not k.endswith("_unit")}
    allowed = set(required) | set(always)
    for k in sorted(base - allowed):
        raise _fail(
            f"{where}.{k}",
            f"not used with {selector} = {what!r} (which takes: "
            f"{', '.join(required) or 'no other keys'})",
        )
    for k in t:
        if k.endswith("_unit") and k[:-5] not in t:
            raise _fail(f"{where}.{k}", f"given without {where}.{k[:-5]}")
    for k in required:
        if k not in t:
            raise _fail(f"{where}.{k}", f"missing (needed by {selector} = {what!r})")


def _epoch(s: str, key: str = "scenario.epoch") -> str:
    from orbit.errors import OrbitError
    from orbit.timescales import as_epoch, format_epoch

    try:
        return format_epoch(as_epoch(s, key, allow_none=False))
    except OrbitError:
        raise _fail(
            key,
            f"expected an ISO 8601 time like '2024-03-20T12:00:00' (UTC; or followed by a "
            f"scale: TAI, TT, TDB, GPS), got {s!r}",
        ) from None

"""The flight software of a scenario: ``[software]`` (its laws or ``[[software.modes]]``),
``[[software.sensors]]`` and ``[software.estimator]``."""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import AttitudeError
from ._schema import ScenarioError, _fail, _is_number, _Reader, parse_unit

#: Keys of [software] (and of each [[software.modes]] table): quantity kind of <key>_unit.
SOFTWARE_KEYS: dict[str, str | None] = {
    "period": "time",
    "delay": None,
    "phase": "time",
    "record_every": None,
    "modes": None,
    "sensors": None,
    "estimator": None,
    "burns": None,
}
MODE_KEYS: dict[str, str | None] = {
    "name": None,
    "condition": None,
    "threshold": None,  # a rate, an angle or a time: its unit says which
    "condition_frame": None,
    "condition_axis": None,
    "guidance": None,
    "guidance_q": None,
    "slew_rate": "rate",
    "slew_accel": None,
    "control": None,
    "K": "torque",
    "P": "momentum",
    "Ki": None,
    "integral_limit": "momentum",
    "C": "momentum",
    "gain": None,
    "normalized": None,
    "dumping_gain": None,
    "null_gain": None,
}
SENSOR_KEYS: dict[str, dict[str, str | None]] = {
    "gyro": {"arw": None, "rrw": None, "bias": "rate", "scale_factor": None, "seed": None,
             "quantization": "rate", "saturation": "rate"},
    "star_tracker": {"noise": "angle", "boresight": None, "rate": None, "sun_exclusion": "angle",
                     "earth_exclusion": "angle", "seed": None},
    "magnetometer": {"noise": None, "bias": None, "seed": None},
    "sun_sensor": {"noise": None, "normals": None, "seed": None},
}  # fmt: skip
#: The sensor keys that are quantities, each with an example unit: they need ``<key>_unit``.
_SENSOR_UNITS: dict[str, dict[str, str]] = {
    "gyro": {"arw": "deg/h(1/2)", "rrw": "rad/s(3/2)", "bias": "deg/h",
             "quantization": "rad/s", "saturation": "deg/s"},
    "star_tracker": {"noise": "arcsec", "rate": "Hz", "sun_exclusion": "deg",
                     "earth_exclusion": "deg"},
    "magnetometer": {"noise": "nT", "bias": "nT"},
    "sun_sensor": {},
}  # fmt: skip
ESTIMATOR_KEYS: dict[str, str | None] = {
    "type": None,
    "attitude_sigma": "angle",
    "bias_sigma": "rate",
    "use_magnetometer": None,
    "use_sun_sensor": None,
}
_CONTROLS = ("mrp_feedback", "quaternion_feedback", "rate_damping", "bdot", "none")
_CONDITIONS = ("rate_below", "rate_above", "pointing_within", "pointing_beyond", "after")


#: Keys that are not quantities: a ``<key>_unit`` beside them is an error, not ignored.
_UNITLESS = frozenset({
    "delay", "record_every", "modes", "sensors", "estimator", "name", "condition",
    "condition_frame", "condition_axis", "guidance", "guidance_q", "control", "normalized",
    "type", "seed", "boresight", "normals", "use_magnetometer", "use_sun_sensor",
})  # fmt: skip
#: The keys each control law reads (besides name, condition..., guidance, dumping, null_gain).
_CONTROL_KEYS: dict[str, tuple[str, ...]] = {
    "mrp_feedback": ("K", "P", "Ki", "integral_limit"),
    "quaternion_feedback": ("K", "C"),
    "rate_damping": ("C",),
    "bdot": ("gain", "normalized"),
    "none": (),
}
_GAIN_KEYS = frozenset(k for keys in _CONTROL_KEYS.values() for k in keys)


def _check(t: Mapping[str, Any], keys: Mapping[str, str | None], where: str) -> None:
    allowed = set(keys) | {f"{k}_unit" for k in keys if k not in _UNITLESS}
    for k in t:
        if k not in allowed:
            if k.endswith("_unit") and k[:-5] in _UNITLESS:
                raise _fail(f"{where}.{k}", f"{where}.{k[:-5]} takes no unit")
            close = difflib.get_close_matches(k, sorted(allowed), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise _fail(
                f"{where}.{k}", f"unknown key{hint} (allowed: {', '.join(sorted(allowed))})"
            )
    for k in t:
        if k.endswith("_unit") and k[:-5] not in t:
            raise _fail(f"{where}.{k}", f"given without {where}.{k[:-5]}")


def _unused(t: Mapping[str, Any], where: str, ctrl: str, cond: str | None) -> None:
    """Keys of a mode the chosen control law and condition do not read: errors (they would
    be ignored silently, e.g. ``K`` with ``control = "rate_damping"``)."""
    for k in sorted(_GAIN_KEYS - set(_CONTROL_KEYS[ctrl])):
        if k in t:
            takes = ", ".join(_CONTROL_KEYS[ctrl]) or "no gains"
            raise _fail(f"{where}.{k}", f"not used with control = {ctrl!r} (which takes: {takes})")
    if cond is None and "threshold" in t:
        raise _fail(f"{where}.threshold", "given without a condition")
    if cond not in ("pointing_within", "pointing_beyond"):
        for k in ("condition_frame", "condition_axis"):
            if k in t:
                raise _fail(f"{where}.{k}", "used only by the pointing_within and "
                            "pointing_beyond conditions")  # fmt: skip
    if "guidance" not in t:
        for k in ("guidance_q", "slew_rate"):
            if k in t:
                raise _fail(f"{where}.{k}", f"given without {where}.guidance")
    if "slew_accel" in t and "slew_rate" not in t:
        raise _fail(f"{where}.slew_accel", f"given without {where}.slew_rate")


def _quantity(r: _Reader, t: Mapping[str, Any], key: str, where: str, unit: str) -> Any:
    """A number (or array) with ``<key>_unit`` converted to ``unit`` (plain: SI)."""
    from astropy import units as u

    v = t[key]
    if isinstance(v, list):
        flat = v if not all(isinstance(x, list) for x in v) else [y for x in v for y in x]
        if not all(_is_number(x) and math.isfinite(x) for x in flat) or (
            flat is not v and len({len(x) for x in v}) != 1
        ):
            raise _fail(
                f"{where}.{key}",
                f"expected finite numbers (a number, an array or rows of equal length), got {v!r}",
            )
        val: Any = np.array(v, dtype=np.float64)
    elif _is_number(v) and math.isfinite(v):
        val = float(v)
    else:
        raise _fail(f"{where}.{key}", f"expected a finite number, got {v!r}")
    us = t.get(f"{key}_unit")
    if us is None:
        return val
    if not isinstance(us, str):
        raise _fail(f"{where}.{key}_unit", f"expected a unit string, got {us!r}")
    try:
        return (val * parse_unit(us)).to_value(u.Unit(unit), u.dimensionless_angles())
    except (ValueError, u.UnitConversionError):
        raise _fail(f"{where}.{key}_unit", f"{us!r} is not a unit of {unit}") from None


#: What a condition's threshold is, by an example unit (a plain number would be SI: radians).
_THRESHOLD_UNIT = {"rate_below": "deg/s", "rate_above": "deg/s", "after": "s",
                   "pointing_within": "deg", "pointing_beyond": "deg"}  # fmt: skip


def _needs_unit(t: Mapping[str, Any], key: str, where: str, example: str) -> None:
    """Angles and rates need their unit, as everywhere in a scenario (a condition's threshold
    too: a plain ``threshold = 0.5`` of ``rate_below`` was 0.5 rad/s, 28.6 deg/s)."""
    if f"{key}_unit" not in t:
        raise _fail(
            f"{where}.{key}",
            f"needs a unit: add {key}_unit = {example!r} (any unit of its kind; a plain number "
            "would be read in SI, an angle in radians)",
        )


def _mode(r: _Reader, t: Mapping[str, Any], where: str, orbit: Any, first: bool) -> tuple:
    """(condition, guidance, control, allocation, name) of a mode's table; an error of the laws
    it builds names its key under ``where`` (``software.K``, not ``K``)."""
    try:
        return _mode_table(r, t, where, orbit, first)
    except ScenarioError:
        raise
    except AttitudeError as exc:
        raise ScenarioError(f"{where}.{exc}") from None


def _mode_table(r: _Reader, t: Mapping[str, Any], where: str, orbit: Any, first: bool) -> tuple:
    from .. import control as K
    from ..software import (
        After,
        PointingBeyond,
        PointingWithin,
        RateAbove,
        RateBelow,
        Slew,
    )
    from ._models import _frame

    _check(t, MODE_KEYS, where)
    cond = None
    if "condition" in t:
        c = r.string(t, "condition", where)
        if c not in _CONDITIONS:
            raise _fail(
                f"{where}.condition", f"expected one of {', '.join(_CONDITIONS)}, got {c!r}"
            )
        if first:
            raise _fail(f"{where}.condition", "the first mode is where the software starts")
        if "threshold" not in t:
            raise _fail(f"{where}.threshold", f"missing (needed by condition = {c!r})")
        _needs_unit(t, "threshold", where, _THRESHOLD_UNIT[c])
        if c in ("rate_below", "rate_above"):
            x = _quantity(r, t, "threshold", where, "rad / s")
            cond = (RateBelow if c == "rate_below" else RateAbove)(x)
        elif c == "after":
            cond = After(_quantity(r, t, "threshold", where, "s"))
        else:
            x = _quantity(r, t, "threshold", where, "rad")
            fr = _frame(r.string(t, "condition_frame", where, "inertial"), orbit,
                        f"{where}.condition_frame")  # fmt: skip
            axis = r.array(t, "condition_axis", where, 3) if "condition_axis" in t else None
            cond = (PointingWithin if c == "pointing_within" else PointingBeyond)(fr, x, axis)
    elif not first:
        raise _fail(f"{where}.condition", "missing (when the software moves on to this mode)")
    guidance = None
    if "guidance" in t:
        g = r.string(t, "guidance", where)
        q = r.array(t, "guidance_q", where, 4) if "guidance_q" in t else None
        guidance = _frame(g, orbit, f"{where}.guidance", q)
        if "slew_rate" in t:
            _needs_unit(t, "slew_rate", where, "deg/s")
            rate = _quantity(r, t, "slew_rate", where, "rad / s")
            if "slew_accel" not in t:
                raise _fail(f"{where}.slew_accel", "missing (a slew has rate and acceleration)")
            _needs_unit(t, "slew_accel", where, "deg/s2")
            acc = _quantity(r, t, "slew_accel", where, "rad / s2")
            guidance = Slew(guidance, rate, acc)
    ctrl = r.string(t, "control", where, "none")
    if ctrl not in _CONTROLS:
        raise _fail(f"{where}.control", f"expected one of {', '.join(_CONTROLS)}, got {ctrl!r}")
    _unused(t, where, ctrl, t.get("condition"))

    def need(key, unit):
        if key not in t:
            raise _fail(f"{where}.{key}", f"missing (needed by control = {ctrl!r})")
        return _quantity(r, t, key, where, unit)

    law: Any = None
    if ctrl == "mrp_feedback":
        ki = _quantity(r, t, "Ki", where, "1 / s") if "Ki" in t else None
        lim = _quantity(r, t, "integral_limit", where, "N m s") if "integral_limit" in t else None
        law = K.MRPFeedback(need("K", "N m"), need("P", "N m s"), ki, lim)
    elif ctrl == "quaternion_feedback":
        law = K.QuaternionFeedback(need("K", "N m"), need("C", "N m s"))
    elif ctrl == "rate_damping":
        law = K.RateDamping(need("C", "N m s"))
    elif ctrl == "bdot":
        norm = t.get("normalized", False)
        if not isinstance(norm, bool):
            raise _fail(f"{where}.normalized", f"expected true or false, got {norm!r}")
        if t.get("gain") == "optimal":
            gain: Any = "optimal"
        else:
            gain = need("gain", "1")
        law = (K.BDot, gain, norm)
    control: Any = law
    if "dumping_gain" in t:
        dump = K.MomentumDumping(_quantity(r, t, "dumping_gain", where, "1 / s"))
        control = (law, dump) if law is not None else dump
    alloc = None
    if "null_gain" in t:
        alloc = K.WheelAllocation(_quantity(r, t, "null_gain", where, "1 / s"))
    name = r.string(t, "name", where, None) if "name" in t else None
    return cond, guidance, control, alloc, name


def software(r: _Reader, st: Mapping[str, Any], craft: Any, body: Any, orbit: Any) -> Any:
    """The :class:`attitude.FlightSoftware` of a ``[software]`` table (or None)."""
    from .. import control as K
    from ..software import FlightSoftware, Mode

    if not st:
        return None
    _check(st, {**SOFTWARE_KEYS, **{k: v for k, v in MODE_KEYS.items()}}, "software")
    if "period" not in st:
        raise _fail("software.period", "missing (the tick interval)")
    period = _quantity(r, st, "period", "software", "s")
    delay = st.get("delay", 0)
    every = st.get("record_every", "samples")
    if not isinstance(delay, int) or isinstance(delay, bool):
        raise _fail("software.delay", f"expected an integer, got {delay!r}")
    if every != "samples" and (not isinstance(every, int) or isinstance(every, bool)):
        raise _fail(
            "software.record_every",
            f'expected an integer k (every k-th tick) or "samples" (the ticks at the output '
            f"times, the default), got {every!r}",
        )
    phase = _quantity(r, st, "phase", "software", "s") if "phase" in st else 0.0
    specs = st.get("modes")
    mode_keys = [k for k in st if k in MODE_KEYS or k[:-5] in MODE_KEYS]
    if specs is not None:
        if mode_keys:
            raise _fail(f"software.{mode_keys[0]}", "give the laws per [[software.modes]]")
        if not isinstance(specs, list) or not specs or not all(isinstance(x, dict) for x in specs):
            raise _fail("software.modes", "expected an array of tables [[software.modes]]")
        raw = [_mode(r, m, f"software.modes[{i}]", orbit, i == 0) for i, m in enumerate(specs)]
    else:
        raw = [_mode(r, {k: st[k] for k in mode_keys}, "software", orbit, True)]

    def resolve(ctrl):
        if isinstance(ctrl, tuple) and ctrl and ctrl[0] is K.BDot:
            gain = ctrl[1]
            if gain == "optimal":
                if orbit is None:
                    raise _fail("software.gain", "'optimal' needs the [orbit]")
                gain = K.BDot.optimal_gain(orbit, body)
                return K.BDot(gain, normalized=True)
            return K.BDot(gain, normalized=ctrl[2])
        if isinstance(ctrl, tuple):
            return tuple(resolve(c) for c in ctrl)
        return ctrl

    modes = [
        (cond, Mode(guidance, resolve(control), alloc, name))
        for cond, guidance, control, alloc, name in raw
    ]
    sensors = _sensors(r, st.get("sensors"))
    estimator = _estimator(r, st.get("estimator"))
    burns = _burns(r, st.get("burns"))
    try:
        if len(modes) == 1:
            m = modes[0][1]
            return FlightSoftware(period, m.guidance, m.control, m.allocation, sensors=sensors,
                                  estimator=estimator, delay=delay, phase=phase,
                                  record_every=every, burns=burns)  # fmt: skip
        return FlightSoftware(period, sensors=sensors, estimator=estimator, modes=modes,
                              delay=delay, phase=phase, record_every=every,
                              burns=burns)  # fmt: skip
    except AttitudeError as exc:
        raise ScenarioError(f"software.{exc}") from None


def _sensors(r: _Reader, spec: Any) -> list:
    from .. import sensors as S

    if spec is None:
        return []
    if not isinstance(spec, list) or not all(isinstance(x, dict) for x in spec):
        raise _fail("software.sensors", "expected an array of tables [[software.sensors]]")
    out = []
    units = {
        "arw": "rad / s(1/2)",
        "rrw": "rad / s(3/2)",
        "bias": "rad / s",
        "quantization": "rad / s",
        "saturation": "rad / s",
        "noise": None,
        "sun_exclusion": "rad",
        "earth_exclusion": "rad",
        "rate": "Hz",
    }
    for i, t in enumerate(spec):
        where = f"software.sensors[{i}]"
        kind = r.string(t, "type", where)
        if kind not in SENSOR_KEYS:
            raise _fail(f"{where}.type", f"expected one of {', '.join(SENSOR_KEYS)}, got {kind!r}")
        keys = {"type": None, **SENSOR_KEYS[kind]}
        _check(t, keys, where)
        for k, example in _SENSOR_UNITS[kind].items():
            if k in t and f"{k}_unit" not in t:  # as the [[spacecraft.*]] tables' quantities
                raise _fail(
                    f"{where}.{k}",
                    f"needs a unit: add {k}_unit = {example!r} (any unit of its kind; a plain "
                    "number would be read in SI, 100 meaning 100 T for a magnetometer's noise)",
                )
        kw: dict[str, Any] = {}
        for k in SENSOR_KEYS[kind]:
            if k not in t:
                continue
            if k == "seed":
                kw[k] = t[k]
            elif k in ("boresight",):
                kw[k] = r.array(t, k, where, 3)
            elif k == "normals":
                kw[k] = t[k]  # checked by SunSensor (an array of (n, 3) finite numbers)
            elif k == "noise":
                unit = {"gyro": None, "star_tracker": "rad", "magnetometer": "T",
                        "sun_sensor": "1"}[kind]  # fmt: skip
                kw[k] = _quantity(r, t, k, where, unit)
            elif k == "bias" and kind == "magnetometer":
                kw[k] = _quantity(r, t, k, where, "T")
            elif k == "scale_factor":
                kw[k] = _quantity(r, t, k, where, "1")
            else:
                kw[k] = _quantity(r, t, k, where, units[k])
        cls = {"gyro": S.Gyro, "star_tracker": S.StarTracker, "magnetometer": S.Magnetometer,
               "sun_sensor": S.SunSensor}[kind]  # fmt: skip
        try:
            if kind == "gyro":
                if "arw" not in kw:
                    raise _fail(f"{where}.arw", "missing (the angle random walk)")
                out.append(cls(kw.pop("arw"), **kw))
            elif kind in ("star_tracker", "magnetometer"):
                if "noise" not in kw:
                    raise _fail(f"{where}.noise", "missing")
                out.append(cls(kw.pop("noise"), **kw))
            else:
                out.append(cls(**kw))
        except AttitudeError as exc:
            if isinstance(exc, ScenarioError):
                raise
            raise ScenarioError(f"{where}.{exc}") from None
    return out


def _estimator(r: _Reader, spec: Any) -> Any:
    from ..estimation import MEKF

    if spec is None:
        return None
    if not isinstance(spec, dict):
        raise _fail("software.estimator", "expected a table [software.estimator]")
    _check(spec, ESTIMATOR_KEYS, "software.estimator")
    kind = r.string(spec, "type", "software.estimator", "mekf")
    if kind != "mekf":
        raise _fail("software.estimator.type", f"expected 'mekf', got {kind!r}")
    kw: dict[str, Any] = {}
    for k in ("attitude_sigma", "bias_sigma"):
        if k in spec:
            kw[k] = _quantity(r, spec, k, "software.estimator",
                              "rad" if k == "attitude_sigma" else "rad / s")  # fmt: skip
    for k in ("use_magnetometer", "use_sun_sensor"):
        if k in spec:
            if not isinstance(spec[k], bool):
                raise _fail(f"software.estimator.{k}", "expected true or false")
            kw[k] = spec[k]
    try:
        return MEKF(**kw)
    except AttitudeError as exc:
        raise ScenarioError(f"software.estimator.{exc}") from None


def _burns(r: _Reader, spec: Any) -> tuple:
    """``[[software.burns]]``: start, duration (with their ``_unit``s) and thrusters."""
    from ..software import Burn

    if spec is None:
        return ()
    if not isinstance(spec, list) or not all(isinstance(x, dict) for x in spec):
        raise _fail("software.burns", "expected an array of tables [[software.burns]]")
    out = []
    for i, b in enumerate(spec):
        where = f"software.burns[{i}]"
        for k in b:
            if k not in ("start", "duration", "thrusters", "start_unit", "duration_unit"):
                raise _fail(f"{where}.{k}", "unknown key (start, duration, thrusters)")
        for k in ("start", "duration"):
            if k not in b:
                raise _fail(f"{where}.{k}", "missing")
        try:
            start = _quantity(r, b, "start", where, "s")
            duration = _quantity(r, b, "duration", where, "s")
            out.append(Burn(start, duration, b.get("thrusters", 0)))
        except (ValueError, TypeError) as exc:
            raise _fail(where, str(exc)) from None
    return tuple(out)

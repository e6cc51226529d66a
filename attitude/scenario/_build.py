"""Loading a scenario: TOML text to a validated :class:`Scenario`, one table builder at a time."""

from __future__ import annotations

import difflib
import math
import os
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._times import TimeGrid
from ..body import RigidBody
from ..ensemble.dispersions import DISTRIBUTIONS, OUTPUTS, Dispersions
from ..errors import AttitudeError, AttitudeValueError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib


from . import _actuators, _software
from ._models import _frame, _model_names, _orbit, _potential
from ._scenario import Scenario
from ._schema import (
    _EVENT_KEYS,
    _EVENT_TYPE_KEYS,
    _EVENT_TYPES,
    _EXAMPLE,
    _FORMS,
    _FRAMES,
    _TABLES,
    ScenarioError,
    _epoch,
    _fail,
    _is_number,
    _only,
    _Reader,
    _unknown_choice,
)

# ------------------------------------------------------------------------------------------------
# Loading
# ------------------------------------------------------------------------------------------------


def load(path: str | os.PathLike) -> Scenario:
    """Read and validate a scenario TOML file.

    Raises
    ------
    ScenarioError
        The file is missing, not TOML, or invalid; the message names the key.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{p}: no such scenario file") from None
    except OSError as exc:
        raise ScenarioError(f"{p}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ScenarioError(f"{p}: not a UTF-8 text file") from None
    return loads(text, name=p.stem, path=p)


def loads(text: str, *, name: str = "scenario", path: Path | None = None) -> Scenario:
    """Validate a scenario given as TOML text (see :func:`load`)."""
    where = str(path) if path else "scenario"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{where}: invalid TOML: {exc}") from None
    try:
        return _build(data, text, name, path)
    except ScenarioError:
        raise
    except AttitudeError as exc:  # a constructor rejected a value: still bad input
        raise ScenarioError(_scenario_key(str(exc))) from None


#: The scenario keys of the parameters the constructors name in their errors (``inertia: ...``
#: from RigidBody is ``body.inertia`` in a scenario).
_PARAMETER_KEYS = {
    "inertia": "body.inertia",
    "weight": "potential.weight",
    "center_of_mass": "potential.center_of_mass",
    "field": "potential.field",
    "density": "potential.density",
    "f107": "potential.f107",
    "f107a": "potential.f107a",
    "ap": "potential.ap",
    "eclipse": "potential.eclipse",
    "step": "potential.step",
    "dipole": "spacecraft.dipole",
    "tensor": "spacecraft.eddy_tensor",
}


def _scenario_key(message: str) -> str:
    """A constructor's error with the parameter it names replaced by the scenario's key."""
    name, sep, rest = message.partition(": ")
    return f"{_PARAMETER_KEYS[name]}: {rest}" if sep and name in _PARAMETER_KEYS else message


def _build(data: dict[str, Any], text: str, default_name: str, path: Path | None) -> Scenario:
    r = _Reader(data)
    for k in data:
        if k not in _TABLES:
            close = difflib.get_close_matches(k, list(_TABLES), n=1)
            hint = f"; did you mean [{close[0]}]?" if close else ""
            raise _fail(k, f"unknown table or key{hint} (tables: {', '.join(_TABLES)})")
    for name in _TABLES:
        if name not in ("events", "software"):
            r.check_keys(name, r.table(name))

    # [scenario]
    sc = r.table("scenario")
    name = r.string(sc, "name", "scenario", default_name)
    epoch = None
    if "epoch" in sc:
        epoch = _epoch(r.string(sc, "epoch", "scenario"))

    # [body]
    bt = r.table("body", required=True)
    inertia = r.array(bt, "inertia", "body", 3)
    r.dimensionless = "inertia_unit" not in bt
    if r.dimensionless:
        body = RigidBody(inertia)
    else:
        body = RigidBody(inertia * r.unit(bt, "inertia", "body", "inertia"))

    # [time]
    tt = r.table("time", required=True)
    t, time_unit, time_scale = _times(r, tt)

    # [orbit] and [potential]
    pt = r.table("potential")
    kind = _model_names(r, pt)
    orbit = None
    ot = r.table("orbit")
    if ot:
        if r.dimensionless:
            raise _fail(
                "orbit",
                "an orbit needs a body with units: give body.inertia_unit (e.g. 'kg m2')",
            )
        orbit, epoch = _orbit(r, ot, t, epoch, path)
    uses_orbit = (
        bool(r.table("events"))
        or bool(r.table("software"))
        or r.table("initial_state").get("frame", "inertial") not in ("inertial",)
    )
    sct = r.table("spacecraft")
    has_actuators = any(k in sct for k in ("wheels", "magnetorquers", "thrusters", "mass"))
    if has_actuators and "magnetorquers" in sct and orbit is None:
        raise _fail(
            "spacecraft.magnetorquers",
            "magnetorquers act in the geomagnetic field along the orbit: add an [orbit] table",
        )
    potential = _potential(
        r, pt, kind, orbit, sct, uses_orbit or (has_actuators and orbit is not None)
    )
    field = str(pt.get("field", "igrf")) if isinstance(pt.get("field", "igrf"), str) else "igrf"
    craft = _actuators.spacecraft(r, sct, body, orbit, field)
    schedule = _actuators.commands(r, r.table("commands"), craft, path)
    swt = r.table("software")
    if swt and craft is None:
        from ..spacecraft import Spacecraft

        craft = Spacecraft(body, orbit=orbit, field=field)
    fsw = _software.software(r, swt, craft, body, orbit)

    # [initial_state]
    it = r.table("initial_state", required=True)
    form = r.string(it, "form", "initial_state")
    if form not in _FORMS:
        raise _fail("initial_state.form", f"expected one of {', '.join(_FORMS)}, got {form!r}")
    _only(it, "initial_state", form, _FORMS[form][0], ("form", "frame"), "initial_state.form")
    frame = r.string(it, "frame", "initial_state", "inertial")
    if frame not in _FRAMES[:5]:
        raise _unknown_choice("initial_state.frame", frame, _FRAMES[:5], " ('orbital' is rsw)")
    q0, Q0 = _initial(r, it, form, frame, body if craft is None else craft, orbit, float(t[0]))

    # [integrator]
    nt = r.table("integrator")
    method = r.string(nt, "method", "integrator", "auto")
    rtol = r.number(nt, "rtol", "integrator", 1e-10)
    atol = r.number(nt, "atol", "integrator", 1e-12)
    for k, v in (("rtol", rtol), ("atol", atol)):
        if not v > 0:
            raise _fail(f"integrator.{k}", f"must be a positive number, got {v!r}")
    max_step = math.inf
    if "max_step" in nt:
        max_step = r.value(nt, "max_step", "integrator", "time")
        if not max_step > 0:
            raise _fail("integrator.max_step", f"must be positive, got {r.given(nt, 'max_step')}")
    max_steps = nt.get("max_steps", 100_000_000)
    if not isinstance(max_steps, int) or isinstance(max_steps, bool) or max_steps < 1:
        raise _fail("integrator.max_steps", f"expected a positive integer, got {max_steps!r}")
    from ..propagate import _lookup_method

    try:
        if method != "auto":  # (the run picks taylor or dop853: propagate.choose_method)
            _lookup_method(method)
    except AttitudeValueError as exc:
        raise _fail("integrator.method", str(exc).split(": ", 1)[-1]) from None
    dt = None
    if "dt" in nt:
        dt = r.value(nt, "dt", "integrator", "time")
        if not dt > 0:
            raise _fail("integrator.dt", f"must be a positive step, got {r.given(nt, 'dt')}")
    order = nt.get("order", 4)
    if not isinstance(order, int) or isinstance(order, bool) or order not in (2, 4, 6):
        raise _fail("integrator.order", f"expected 2, 4 or 6, got {order!r}")
    formulation = r.string(nt, "formulation", "integrator", "canonical")
    from ..formulations import get_formulation

    if formulation != "canonical":
        try:
            get_formulation(formulation, "dop853" if method == "auto" else method)
        except AttitudeValueError as exc:
            raise _fail("integrator.formulation", str(exc).split(": ", 1)[-1]) from None

    # [output]
    out = r.table("output")
    opath = Path(r.string(out, "path", "output", f"{name}.nc"))
    layout = r.string(out, "plot_layout", "output", None)
    if layout is not None and layout not in ("engineer", "paper"):
        raise _fail(
            "output.plot_layout", f"expected 'engineer' or 'paper' (attitude plot), got {layout!r}"
        )

    # [ensemble]
    ensemble = None
    if "ensemble" in data:
        ensemble = _dispersions(r, r.table("ensemble"), body)
        if craft is not None and ensemble.output == "statistics":
            raise _fail(
                "ensemble.output",
                "a scenario with actuators, [commands] or [software] stores its members "
                "('samples' or 'final'); take the statistics from the file afterwards "
                "(attitude.ensemble.error_angle_percentiles, settling_times)",
            )

    # [events]
    events = None
    if "events" in data:
        events = _events(r, r.table("events"), orbit, epoch)
        _check_event_method(method, craft is not None)

    return Scenario(
        name=name,
        title=r.string(sc, "title", "scenario", ""),
        description=r.string(sc, "description", "scenario", ""),
        body=body,
        q0=q0,
        Q0=Q0,
        potential=potential,
        t=t,
        time_unit=time_unit,
        time_scale=time_scale,
        method=method,
        rtol=rtol,
        atol=atol,
        max_step=max_step,
        max_steps=max_steps,
        dt=dt,
        order=order,
        formulation=formulation,
        output=opath,
        epoch=epoch,
        object_name=r.string(sc, "object_name", "scenario", "UNKNOWN"),
        object_id=r.string(sc, "object_id", "scenario", "UNKNOWN"),
        inertial_frame=r.string(sc, "inertial_frame", "scenario", None),
        source=text,
        path=path,
        initial_form=f"{form} ({frame} frame)",
        ensemble=ensemble,
        events=events,
        spacecraft=craft,
        commands=schedule,
        software=fsw,
        extra_attrs={"plot_layout": layout} if layout else {},
    )


def _dispersions(r: Any, table: dict[str, Any], body: RigidBody) -> Dispersions:
    """The ``[ensemble]`` table (scenario ``_Reader`` ``r``) as :class:`Dispersions`.

    Errors name the key (``ScenarioError`` is raised by the caller from AttitudeValueError).
    """

    def fail(key, msg):
        return ScenarioError(f"ensemble.{key}: {msg}")

    def integer(key, default, low):
        v = table.get(key, default)
        if v is None:
            return None
        if not isinstance(v, int) or isinstance(v, bool) or v < low:
            raise fail(key, f"expected an integer >= {low}, got {v!r}")
        return v

    if "size" not in table:
        raise fail("size", "missing: the number of members (an integer >= 1)")
    size = integer("size", None, 1)
    seed = integer("seed", 0, 0)
    chunk = integer("chunk", None, 1)
    values = {}
    for key, kind in (("attitude_error", "angle"), ("rate_error", "rate")):
        v = r.value(table, key, "ensemble", kind, default=0.0)
        if not v >= 0:
            raise fail(
                key, f"must be >= 0 (a standard deviation or half-width), got {r.given(table, key)}"
            )
        values[key] = float(v)
    ie = r.number(table, "inertia_error", "ensemble", 0.0)
    if not ie >= 0:
        raise fail("inertia_error", f"must be >= 0 (relative, e.g. 0.02 for 2 %), got {ie!r}")
    for key, kind in (("position_error", "position"), ("velocity_error", "velocity")):
        v = r.value(table, key, "ensemble", kind, default=0.0)
        if not v >= 0:
            raise fail(key, f"must be >= 0 (a standard deviation), got {r.given(table, key)}")
        values[key] = float(v)
    me = r.number(table, "mass_error", "ensemble", 0.0)
    if not 0 <= me < 1.0 / 3.0:
        raise fail("mass_error", f"relative, in [0, 1/3) (truncated at 3 sigma), got {me!r}")
    dists = {}
    for q in ("attitude", "rate", "inertia"):
        key = f"{q}_distribution"
        d = r.string(table, key, "ensemble", "normal")
        if d not in DISTRIBUTIONS:
            raise fail(key, f"expected one of {', '.join(map(repr, DISTRIBUTIONS))}, got {d!r}")
        dists[key] = d
    opts = _ensemble_output(r, table, fail)
    disp = Dispersions(
        size=size,
        seed=seed,
        chunk=chunk,
        attitude_error=values["attitude_error"],
        rate_error=values["rate_error"],
        inertia_error=ie,
        position_error=values["position_error"],
        velocity_error=values["velocity_error"],
        mass_error=me,
        **dists,
        **opts,
    )
    try:
        disp.check_body(body.inertia)
    except AttitudeValueError as exc:
        raise ScenarioError(str(exc)) from None
    return disp


def _ensemble_output(r: Any, table: dict[str, Any], fail: Callable) -> dict[str, Any]:
    """The output keys of the ``[ensemble]`` table (docs/ensemble.md, "Output choices")."""
    opts: dict[str, Any] = {}
    output = r.string(table, "output", "ensemble", "samples")
    if output not in OUTPUTS:
        raise fail("output", f"expected one of {', '.join(map(repr, OUTPUTS))}, got {output!r}")
    opts["output"] = output
    every = table.get("every", 1)
    if not isinstance(every, int) or isinstance(every, bool) or every < 1:
        raise fail("every", f"expected an integer >= 1 (store every k-th time), got {every!r}")
    if output == "final" and every != 1:
        raise fail("every", "stores every k-th time with output = 'samples' or 'statistics'")
    opts["every"] = every
    if "percentiles" in table:
        p = table["percentiles"]
        if output != "statistics":
            raise fail("percentiles", "only with output = 'statistics'")
        if not isinstance(p, list) or not p or not all(_is_number(x) and 0 <= x <= 100 for x in p):
            raise fail("percentiles", f"expected a list of numbers in [0, 100], got {p!r}")
        opts["percentiles"] = tuple(float(x) for x in p)
    if "max_output_size" in table:
        v = table["max_output_size"]
        if isinstance(v, str) and v.strip().lower() == "none":
            if "max_output_size_unit" in table:
                raise fail("max_output_size_unit", "given with max_output_size = 'none'")
            opts["max_output_size"] = math.inf
        else:
            size = r.value(table, "max_output_size", "ensemble", "size")
            if not size > 0:
                raise fail("max_output_size", f"must be a positive size, got {v!r}")
            opts["max_output_size"] = float(size)
    return opts


def _times(r: _Reader, tt: Mapping[str, Any]) -> tuple[TimeGrid, str, float]:
    for k in tt:
        if k not in ("start", "stop", "step", "count", "unit"):
            raise _fail(f"time.{k}", "unknown key (allowed: start, stop, step or count, unit)")
    if r.dimensionless:
        if "unit" in tt:
            raise _fail(
                "time.unit",
                "the body is dimensionless (no body.inertia_unit), so times are plain numbers; "
                "remove time.unit",
            )
        scale, tunit = 1.0, "1"
    else:
        if "unit" not in tt:
            raise _fail("time.unit", f"missing: the time unit, e.g. {_EXAMPLE['time']}")
        tt2 = {"x": 1.0, "x_unit": tt["unit"]}
        try:
            scale = float(r.value(tt2, "x", "time", "time"))  # plain floats: an overflow is
            # inf, checked below (numpy's scalars warned "overflow encountered")
        except ScenarioError as exc:
            raise ScenarioError(str(exc).replace("time.x_unit", "time.unit")) from None
        tunit = "s"
    start = r.number(tt, "start", "time", 0.0) * scale
    stop = r.number(tt, "stop", "time") * scale
    for key, v in (("start", start), ("stop", stop)):
        if not math.isfinite(v):
            raise _fail(f"time.{key}", f"{r.given(tt, key)} overflows in seconds")
    if not stop > start:
        raise _fail(
            "time.stop",
            f"must be after time.start ({r.given(tt, 'stop')} <= {r.given(tt, 'start')})",
        )
    span = stop - start
    if not math.isfinite(span):
        raise _fail(
            "time",
            f"the span time.stop - time.start = {r.given(tt, 'stop')} - {r.given(tt, 'start')} "
            "overflows double precision; give start and stop closer together",
        )
    if ("step" in tt) == ("count" in tt):
        raise _fail("time", "give exactly one of time.step (sample spacing) or time.count")
    if "count" in tt:
        n = tt["count"]
        if not isinstance(n, int) or isinstance(n, bool) or n < 2:
            raise _fail("time.count", f"expected an integer >= 2, got {n!r}")
    else:
        step = r.number(tt, "step", "time") * scale
        if not step > 0:
            raise _fail("time.step", f"must be positive, got {r.given(tt, 'step')}")
        if step > span * (1 + 1e-9):
            raise _fail(
                "time.step",
                f"{r.given(tt, 'step')} is longer than the time span (time.stop - time.start): "
                "the run would have one sample and propagate nothing; give a step of at most "
                "the span",
            )
        ratio = span / step
        if not ratio <= 10**9:
            raise _fail("time", f"about {ratio:.3g} output samples is too many (at most 1e9)")
        n = round(ratio) + 1
        if abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio):
            raise _fail(
                "time.step",
                f"must divide time.stop - time.start into whole steps ({ratio:.6g} steps); "
                "or give time.count",
            )
    if n > 10**9:
        raise _fail("time", f"{n} output samples is too many (at most 1e9)")
    try:
        t = TimeGrid(start, stop, int(n))  # generated a chunk at a time (bounded memory)
    except AttitudeValueError as exc:
        raise _fail("time", str(exc).split(": ", 1)[-1]) from None
    return t, tunit, scale


def _initial(r: _Reader, it, form, frame, body, orbit, t0) -> tuple[np.ndarray, np.ndarray]:
    from .. import canonical as C
    from ..quaternion import from_euler

    where = "initial_state"
    if frame != "inertial":
        if orbit is None:
            raise _fail(f"{where}.frame", f"{frame!r} needs an [orbit] table")
        if form in ("canonical", "euler_canonical"):
            raise _fail(
                f"{where}.frame",
                f"{frame!r} is for forms with body rates (body_rates, euler_body_rates); "
                f"form {form!r} gives inertial momenta",
            )
    if form == "euler_canonical":
        from ..errors import SingularityError

        angles = r.value(it, "angles", where, "angle", n=3)
        momenta = r.value(it, "momenta", where, "momentum", n=3)
        try:
            return C.from_euler_canonical(angles, momenta)
        except SingularityError:  # say it in the unit the file gives the angles in
            unit = str(it.get("angles_unit", "rad"))
            half = "180 deg" if unit == "deg" else "π rad" if unit == "rad" else f"π ({unit})"
            raise _fail(
                f"{where}.angles",
                f"the second angle ϑ = {it['angles'][1]!r} {unit} is 0 or {half} (modulo a full "
                "turn), where the 3-1-3 angles and their momenta are singular; give the state as "
                "(q, Q) (form = 'canonical') or with body rates instead",
            ) from None
    if form == "euler_body_rates":
        seq = r.string(it, "seq", where)
        from ..quaternion import EULER_SEQUENCES

        if seq not in EULER_SEQUENCES:
            raise _fail(
                f"{where}.seq", f"expected one of {', '.join(EULER_SEQUENCES)}, got {seq!r}"
            )
        q = from_euler(r.value(it, "angles", where, "angle", n=3), seq)
    else:
        q = r.array(it, "q", where, 4)
        nq = float(np.linalg.norm(q))
        if abs(nq - 1.0) > 1e-6:
            raise _fail(
                f"{where}.q",
                f"must be a unit quaternion (scalar first); |q| = {nq!r}. Write enough digits "
                "(e.g. 0.7071067811865476 for 1/sqrt(2))",
            )
    if form == "canonical":
        Q = r.value(it, "Q", where, "momentum", n=4)
        return q, Q
    omega = r.value(it, "omega", where, "rate", n=3)
    if frame != "inertial":
        # the attitude and rates are relative to the frame (attitude.frames.initial_state)
        from ..frames import initial_state

        ref = _frame(frame, orbit, f"{where}.frame")
        return initial_state(body, ref, t0, offset=q, rates=omega)
    return q, C.momenta_from_angular_velocity(q, omega, body)


def _check_event_method(method: str, spacecraft: bool) -> None:
    """The [integrator] method of a scenario with [events]: one that locates them."""
    from .._run.plan import EVENT_METHODS

    allowed = ("auto", "dop853") if spacecraft else ("auto", *EVENT_METHODS)
    if method not in allowed:
        what = "a spacecraft's events are" if spacecraft else "events are"
        raise _fail(
            "integrator.method",
            f"{what} located by {', '.join(repr(m) for m in allowed[1:])} ('auto' picks one); "
            f"got {method!r}: change the method or remove [events]",
        )


def _events(r: _Reader, table: dict[str, Any], orbit: Any, epoch: Any = None) -> list:
    """The ``[events.<name>]`` subtables as attitude.events objects (errors name the key)."""
    from .. import events as E

    out = []
    if not table:
        raise _fail("events", "empty table: add [events.<name>] subtables with a type")
    for name, et in table.items():
        where = f"events.{name}"
        if not isinstance(et, dict):
            raise _fail(where, f"expected a table [{where}] with a type, got {et!r}")
        if not name.isidentifier():
            raise _fail(where, "event names must be identifiers (letters, digits, _)")
        names = set(_EVENT_KEYS) | {f"{k}_unit" for k, kind in _EVENT_KEYS.items() if kind}
        for k in et:
            if k not in names:
                close = difflib.get_close_matches(k, sorted(names), n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise _fail(
                    f"{where}.{k}", f"unknown key{hint} (allowed: {', '.join(sorted(names))})"
                )
        typ = r.string(et, "type", where)
        if typ not in _EVENT_TYPES:
            raise _fail(f"{where}.type", f"expected one of {', '.join(_EVENT_TYPES)}, got {typ!r}")
        own = {"type", "terminal", "samples", *_EVENT_TYPE_KEYS[typ]}
        for k in et:
            if k.removesuffix("_unit") not in own:
                raise _fail(
                    f"{where}.{k}",
                    f"a {typ} event does not read {k!r} (its keys: {', '.join(sorted(own))})",
                )
        kw: dict[str, Any] = {"name": name}
        if "terminal" in et:
            if not isinstance(et["terminal"], bool):
                raise _fail(f"{where}.terminal", f"expected true or false, got {et['terminal']!r}")
            kw["terminal"] = et["terminal"]
        if "samples" in et:
            kw["samples"] = et["samples"]
        if "direction" in et and typ not in ("eclipse_entry", "eclipse_exit"):
            kw["direction"] = r.string(et, "direction", where)
        try:
            if typ == "pointing_exceeds":
                fq = r.array(et, "frame_q", where, 4) if "frame_q" in et else None
                fr = _frame(r.string(et, "frame", where), orbit, f"{where}.frame", fq)
                axis = et.get("axis")
                out.append(E.PointingExceeds(fr, axis, r.value(et, "angle", where, "angle"), **kw))
            elif typ == "rate_exceeds":
                out.append(E.RateExceeds(r.value(et, "rate", where, "rate"), **kw))
            elif typ in ("eclipse_entry", "eclipse_exit"):
                if orbit is None:
                    raise _fail(where, f"{typ} needs an [orbit] table (with an epoch)")
                cls = E.EclipseEntry if typ == "eclipse_entry" else E.EclipseExit
                out.append(cls(orbit, shadow=r.string(et, "shadow", where, "penumbra"), **kw))
            else:
                out.append(
                    E.AngleToSun(
                        et.get("axis", "+z"),
                        r.value(et, "angle", where, "angle"),
                        orbit=orbit,
                        **kw,
                    )
                )
        except ScenarioError:
            raise
        except (ValueError, TypeError) as exc:
            raise _fail(where, str(exc)) from None
        if out[-1].needs_epoch and epoch is None and getattr(orbit, "epoch", None) is None:
            raise _fail(
                where,
                f"{typ} needs a date (the Sun's position, the Earth's rotation): add epoch = "
                "'2024-03-20T12:00:00' to [scenario] (or give the [orbit] an epoch)",
            )
    return out

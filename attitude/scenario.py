"""Scenarios: a propagation described in a TOML file (docs/scenarios.md).

>>> from attitude import scenario                                   # doctest: +SKIP
>>> sc = scenario.load("scenarios/paper_keplerian.toml")
>>> ds = sc.run()                         # xarray Dataset (docs/results.md)
>>> sc.run_to_file("out.nc")              # streamed to netCDF, bounded memory

Quantities carry their unit in a sibling key ``<name>_unit`` (``a = 7000.0`` with
``a_unit = "km"``), parsed by astropy. A body without ``inertia_unit`` is dimensionless (the
paper's first two cases): then every quantity except angles is a plain number in the same
consistent units, and giving a unit is an error. Every error names the key and what was
expected, before any work (:class:`ScenarioError`).
"""

from __future__ import annotations

import difflib
import math
import os
import sys
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .body import RigidBody
from .ensemble.dispersions import DISTRIBUTIONS, OUTPUTS, Dispersions
from .errors import AttitudeError, AttitudeValueError, PropagationError
from .results import set_time_attrs

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["Scenario", "ScenarioError", "load", "loads"]


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
}
_EXAMPLE = {
    "inertia": "'kg m2' or 'kg km2'",
    "momentum": "'kg m2 s-1' or 'N m s'",
    "rate": "'rad/s' or 'deg/s'",
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
}

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
    "spacecraft": {"dipole": "dipole", "eddy_tensor": "conductance", "facets": None},
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
    "output": {"path": None},
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
            unit = u.Unit(s)
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


@dataclass
class Scenario:
    """A validated scenario: body, initial state, potential, output times and numerics.

    Build it with :func:`load` or :func:`loads`; :meth:`run` returns the result Dataset.
    """

    name: str
    title: str
    description: str
    body: RigidBody
    q0: np.ndarray
    Q0: np.ndarray
    potential: Any
    t: np.ndarray
    time_unit: str
    time_scale: float = 1.0  # internal time units per unit of the [time] table
    method: str = "dop853"
    rtol: float = 1e-10
    atol: float = 1e-12
    max_step: float = math.inf
    max_steps: int = 100_000_000
    dt: float | None = None  # step of the fixed-step methods (nosquish, splitting)
    order: int = 4
    formulation: str = "canonical"
    output: Path = Path("out.nc")
    epoch: str | None = None
    object_name: str = "UNKNOWN"
    object_id: str = "UNKNOWN"
    inertial_frame: str = "EME2000"
    source: str = ""
    path: Path | None = None
    initial_form: str = "canonical"
    extra_attrs: dict[str, Any] = field(default_factory=dict)
    ensemble: Dispersions | None = None  # from an [ensemble] table
    events: list | None = None  # from an [events] table (attitude.events)

    # -- running ----------------------------------------------------------------------------
    def _kwargs(self, overrides: Mapping[str, Any]) -> dict[str, Any]:
        kw = dict(
            method=self.method,
            rtol=self.rtol,
            atol=self.atol,
            max_step=self.max_step,
            max_steps=self.max_steps,
        )
        if self.dt is not None:
            kw.update(dt=self.dt, order=self.order)
        if self.formulation != "canonical":
            kw["formulation"] = self.formulation
        kw.update({k: v for k, v in overrides.items() if v is not None})
        return kw

    def attrs(self, kw: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Global attrs describing the scenario (added to the result's attrs)."""
        a: dict[str, Any] = {
            "title": self.title or self.name,
            "scenario": self.name,
            "scenario_description": self.description,
            "scenario_file": str(self.path) if self.path else "",
            "scenario_toml": self.source,
            "initial_state_form": self.initial_form,
            "object_name": self.object_name,
            "object_id": self.object_id,
            "inertial_frame": self.inertial_frame,
        }
        if self.epoch:
            a["epoch"] = self.epoch
        if kw and kw.get("max_step", math.inf) != math.inf:
            a["max_step"] = float(kw["max_step"])
        a.update(self.extra_attrs)
        return a

    def _history(self, ds_attrs: Mapping[str, Any]) -> str:
        where = f" {self.path}" if self.path else ""
        return f"{ds_attrs.get('history', '')}; scenario{where}".lstrip("; ")

    def run(self, *, progress: Callable | None = None, **overrides: Any) -> xr.Dataset:
        """Propagate and return the result Dataset (in memory).

        Parameters
        ----------
        progress : callable, optional
            ``progress(n_done, n_total, t)`` (see :func:`attitude.propagate.propagate`).
        **overrides
            ``method``, ``rtol``, ``atol``, ``max_step`` replacing the scenario's.

        Raises
        ------
        PropagationError
            The integration failed; ``.partial`` holds what was computed (with scenario attrs).
        """
        from .propagate import propagate

        kw = self._kwargs(overrides)
        try:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "initial state projected")
                ds = propagate(
                    self.body,
                    self.q0,
                    self.Q0,
                    self.t,
                    self.potential,
                    progress=progress,
                    epoch=self.epoch,
                    events=self.events,
                    **kw,
                )
        except PropagationError as exc:
            if exc.partial is not None:
                exc.partial.attrs.update(self.attrs(kw), run_status=f"failed: {exc}")
                set_time_attrs(exc.partial)
            raise
        status = "event" if ds.attrs.get("status") == "event" else "complete"
        ds.attrs.update(self.attrs(kw), run_status=status)
        set_time_attrs(ds)  # CF time units from the epoch
        ds.attrs["history"] = self._history(ds.attrs)
        return ds

    def run_to_file(
        self,
        path: str | os.PathLike | None = None,
        *,
        progress: Callable | None = None,
        chunk: int | None = None,
        **overrides: Any,
    ) -> dict[str, Any]:
        """Propagate streaming the samples to a netCDF4 file (bounded memory, atomic).

        A run that fails midway still commits the file with what was computed and
        ``run_status = "failed: ..."``, then raises the :class:`PropagationError`. An interrupt
        (KeyboardInterrupt) leaves no file under the final name.

        Returns
        -------
        dict
            ``path``, ``n_samples``, the run statistics and invariant diagnostics (the attrs).
        """
        from .io import TIME_CHUNK, StreamWriter
        from .propagate import propagate

        out = Path(path) if path is not None else self.output
        kw = self._kwargs(overrides)
        tracker = InvariantTracker()
        writer = StreamWriter(out)

        def sink(ds: xr.Dataset) -> None:
            tracker.update(ds)
            writer.append(ds)

        failure: PropagationError | None = None
        try:
            try:
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", "initial state projected")
                    last = propagate(
                        self.body,
                        self.q0,
                        self.Q0,
                        self.t,
                        self.potential,
                        progress=progress,
                        # ~200 chunks: a smooth progress bar, bounded memory
                        chunk=chunk or max(64, min(TIME_CHUNK, len(self.t) // 200)),
                        on_chunk=sink,
                        epoch=self.epoch,
                        events=self.events,
                        **kw,
                    )
                status = "event" if last.attrs.get("status") == "event" else "complete"
                if self.events is not None:
                    writer.add_static(last)
            except PropagationError as exc:
                failure = exc
                last = exc.partial
                status = f"failed: {exc}"
            if writer.n == 0:
                raise failure or AttitudeValueError("no samples computed")
            attrs = dict(last.attrs) if last is not None else dict(writer.attrs)
            attrs.update(self.attrs(kw), run_status=status, n_samples=np.int64(writer.n))
            attrs.update(tracker.attrs(attrs.get("potential_name", "")))
            attrs["history"] = self._history(attrs)
            writer.attrs = attrs
            writer.commit()
        except BaseException:
            writer.abort()
            raise
        if failure is not None:
            raise failure
        return {"path": out, **attrs}


class InvariantTracker:
    """Running maxima of the invariant errors over streamed chunks of a result."""

    def __init__(self):
        self.max_norm = 0.0
        self.max_qQ = 0.0
        self.E0: float | None = None
        self.G0: np.ndarray | None = None
        self.max_dE = 0.0
        self.max_dG = 0.0
        self.max_dGz = 0.0

    def update(self, ds: xr.Dataset) -> None:
        if ds.sizes["time"] == 0:
            return
        self.max_norm = max(self.max_norm, float(np.max(np.abs(ds["norm_error"].values))))
        self.max_qQ = max(self.max_qQ, float(np.max(np.abs(ds["qQ"].values))))
        E = ds["energy"].values
        G = ds["G"].values
        if self.E0 is None:
            self.E0 = float(E[0])
            self.G0 = G[0].copy()
        self.max_dE = max(self.max_dE, float(np.max(np.abs(E - self.E0))))
        dG = np.linalg.norm(G - self.G0, axis=-1)
        self.max_dG = max(self.max_dG, float(np.max(dG)))
        self.max_dGz = max(self.max_dGz, float(np.max(np.abs(G[:, 2] - self.G0[2]))))

    def attrs(self, potential_name: str) -> dict[str, Any]:
        """Diagnostic attrs: constraint errors always, conserved quantities where they are."""
        a: dict[str, Any] = {
            "max_abs_norm_error": self.max_norm,
            "max_abs_qQ": self.max_qQ,
        }
        scaleE = max(abs(self.E0 or 0.0), np.finfo(float).tiny)
        scaleG = max(float(np.linalg.norm(self.G0)) if self.G0 is not None else 0.0, 1e-300)
        if potential_name in ("torque_free", "heavy_top"):
            a["max_rel_energy_error"] = self.max_dE / scaleE
        if potential_name == "torque_free":
            a["max_rel_G_error"] = self.max_dG / scaleG
        if potential_name == "heavy_top":
            a["max_rel_Gz_error"] = self.max_dGz / scaleG
        if potential_name not in ("torque_free", "heavy_top"):
            a["max_rel_energy_variation"] = self.max_dE / scaleE
        return a


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
        raise ScenarioError(str(exc)) from None


def _build(data: dict[str, Any], text: str, default_name: str, path: Path | None) -> Scenario:
    r = _Reader(data)
    for k in data:
        if k not in _TABLES:
            close = difflib.get_close_matches(k, list(_TABLES), n=1)
            hint = f"; did you mean [{close[0]}]?" if close else ""
            raise _fail(k, f"unknown table or key{hint} (tables: {', '.join(_TABLES)})")
    for name in _TABLES:
        if name != "events":
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
    uses_orbit = bool(r.table("events")) or r.table("initial_state").get(
        "frame", "inertial"
    ) not in ("inertial",)
    potential = _potential(r, pt, kind, orbit, r.table("spacecraft"), uses_orbit)

    # [initial_state]
    it = r.table("initial_state", required=True)
    form = r.string(it, "form", "initial_state")
    if form not in _FORMS:
        raise _fail("initial_state.form", f"expected one of {', '.join(_FORMS)}, got {form!r}")
    _only(it, "initial_state", form, _FORMS[form][0], ("form", "frame"), "initial_state.form")
    frame = r.string(it, "frame", "initial_state", "inertial")
    if frame not in _FRAMES[:5]:
        raise _fail(
            "initial_state.frame",
            f"expected one of {', '.join(_FRAMES[:5])} ('orbital' is rsw), got {frame!r}",
        )
    q0, Q0 = _initial(r, it, form, frame, body, orbit, float(t[0]))

    # [integrator]
    nt = r.table("integrator")
    method = r.string(nt, "method", "integrator", "dop853")
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
    from .propagate import _lookup_method

    try:
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
    from .formulations import get_formulation

    if formulation != "canonical":
        try:
            get_formulation(formulation, method)
        except AttitudeValueError as exc:
            raise _fail("integrator.formulation", str(exc).split(": ", 1)[-1]) from None

    # [output]
    out = r.table("output")
    opath = Path(r.string(out, "path", "output", f"{name}.nc"))

    # [ensemble]
    ensemble = None
    if "ensemble" in data:
        ensemble = _dispersions(r, r.table("ensemble"), body)

    # [events]
    events = None
    if "events" in data:
        events = _events(r, r.table("events"), orbit)

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
        inertial_frame=r.string(sc, "inertial_frame", "scenario", "EME2000"),
        source=text,
        path=path,
        initial_form=f"{form} ({frame} frame)",
        ensemble=ensemble,
        events=events,
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


def _times(r: _Reader, tt: Mapping[str, Any]) -> tuple[np.ndarray, str, float]:
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
            scale = r.value(tt2, "x", "time", "time")
        except ScenarioError as exc:
            raise ScenarioError(str(exc).replace("time.x_unit", "time.unit")) from None
        tunit = "s"
    start = r.number(tt, "start", "time", 0.0) * scale
    stop = r.number(tt, "stop", "time") * scale
    if not stop > start:
        raise _fail(
            "time.stop",
            f"must be after time.start ({r.given(tt, 'stop')} <= {r.given(tt, 'start')})",
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
        ratio = (stop - start) / step
        n = round(ratio) + 1
        if abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio):
            raise _fail(
                "time.step",
                f"must divide time.stop - time.start into whole steps ({ratio:.6g} steps); "
                "or give time.count",
            )
    if n > 10**9:
        raise _fail("time", f"{n} output samples is too many (at most 1e9)")
    t = np.linspace(start, stop, int(n))
    return t, tunit, scale


_ORBIT_TYPES = ("kepler", "secular_j2", "tle", "oem")
_ELEMENT_KEYS = ("a", "e", "inc", "raan", "argp", "f0", "mu")


def _orbit(
    r: _Reader, ot: Mapping[str, Any], t: np.ndarray, epoch: str | None, path: Path | None
) -> tuple[Any, str | None]:
    """The orbit of an [orbit] table and the run's epoch (docs/scenarios.md)."""
    from astropy import units as u

    import orbit as O

    if "tle" in ot and "oem" in ot:
        raise _fail("orbit.oem", "give either orbit.tle or orbit.oem, not both")
    default = "tle" if "tle" in ot else "oem" if "oem" in ot else "kepler"
    kind = r.string(ot, "type", "orbit", default)
    if kind not in _ORBIT_TYPES:
        raise _fail("orbit.type", f"expected one of {', '.join(_ORBIT_TYPES)}, got {kind!r}")
    keys = {
        "kepler": ("a", "e", "inc", "raan", "argp", "f0", "mu"),
        "secular_j2": ("a", "e", "inc", "raan", "argp", "f0", "mu", "j2", "radius"),
        "tle": ("tle", "step", "mu"),
        "oem": ("oem", "mu"),
    }[kind]
    for k in ot:
        base = k[:-5] if k.endswith("_unit") else k
        if base not in (*keys, "type", "epoch"):
            raise _fail(
                f"orbit.{k}",
                f"not used with an orbit of type {kind!r} (which takes: {', '.join(keys)}, epoch)",
            )
    # One run, one epoch: [scenario] epoch and [orbit] epoch must agree.
    if "epoch" in ot:
        oe = _epoch(r.string(ot, "epoch", "orbit"), "orbit.epoch")
        if epoch is not None and oe != epoch:
            raise _fail(
                "orbit.epoch",
                f"{oe} differs from scenario.epoch {epoch}; a run has one time origin (give "
                "one of them, or the same instant in both)",
            )
        epoch = oe
    mu = r.value(ot, "mu", "orbit", "mu", default=None)
    mu_q = None if mu is None else mu * u.Unit("km3 s-2")
    t0 = float(t[0])
    try:
        if kind in ("kepler", "secular_j2"):
            for k in ("a", "e", "inc", "raan", "argp"):
                if k not in ot:
                    raise _fail(
                        f"orbit.{k}",
                        "missing (orbit needs a, e, inc, raan, argp; f0, mu optional)",
                    )
            a = r.value(ot, "a", "orbit", "length")
            e = r.number(ot, "e", "orbit")
            ang = {k: r.value(ot, k, "orbit", "angle") * u.rad for k in ("inc", "raan", "argp")}
            f0 = r.value(ot, "f0", "orbit", "angle", default=0.0) * u.rad
            _check_orbit_angles(r, ot, ang["inc"].value, e, f0.value)
            if kind == "kepler":
                orb = O.KeplerOrbit(
                    a * u.km,
                    e,
                    ang["inc"],
                    ang["raan"],
                    ang["argp"],
                    f0=f0,
                    mu=mu_q,
                    t0=t0 * u.s,
                    epoch=epoch,
                )
            else:
                j2 = r.number(ot, "j2", "orbit", None)
                rad = r.value(ot, "radius", "orbit", "length", default=None)
                orb = O.SecularJ2Orbit(
                    a * u.km,
                    e,
                    ang["inc"],
                    ang["raan"],
                    ang["argp"],
                    f0=f0,
                    epoch=epoch,
                    mu=mu_q,
                    j2=j2,
                    radius=None if rad is None else rad * u.km,
                    t0=t0 * u.s,
                )
            return orb, epoch
        if kind == "tle":
            lines = ot.get("tle")
            if (
                not isinstance(lines, list)
                or len(lines) != 2
                or not all(isinstance(x, str) for x in lines)
            ):
                raise _fail("orbit.tle", 'expected the two TLE lines: tle = ["1 ...", "2 ..."]')
            try:
                l1, l2 = O.ephemeris.check_tle(*lines)
            except O.OrbitError as exc:
                raise _fail("orbit.tle", str(exc)) from None
            step = r.value(ot, "step", "orbit", "time", default=60.0)
            if epoch is None:  # the element set's own epoch
                from astropy.time import Time
                from sgp4.api import Satrec

                from orbit.timescales import format_epoch

                sat = Satrec.twoline2rv(l1, l2)
                epoch = format_epoch(
                    Time(sat.jdsatepoch, sat.jdsatepochF, format="jd", scale="utc")
                )
            from astropy.time import Time, TimeDelta

            e0 = Time(epoch.rstrip("Z"), scale="utc")
            start = e0 + TimeDelta(float(t[0]), format="sec")
            stop = e0 + TimeDelta(float(t[-1]), format="sec")
            try:
                orb = O.EphemerisOrbit.from_tle(l1, l2, start, stop, step, epoch=e0, mu=mu_q)
            except O.OrbitError as exc:
                msg = str(exc)
                key = "time.stop" if msg.startswith("stop:") else "orbit.tle"
                raise _fail(key, msg) from None
            return orb, epoch
        # oem
        fname = r.string(ot, "oem", "orbit")
        fp = Path(fname)
        if not fp.is_absolute() and path is not None:
            fp = Path(path).parent / fp
        try:
            orb = O.EphemerisOrbit.from_oem(fp, epoch=epoch, mu=mu_q)
        except O.OrbitError as exc:
            raise _fail("orbit.oem", str(exc)) from None
        if epoch is None:
            from orbit.timescales import format_epoch

            epoch = format_epoch(orb.epoch)
        try:
            orb.check_times(t, "time")
        except O.OrbitError as exc:
            raise _fail("time", str(exc).split(": ", 1)[-1]) from None
        return orb, epoch
    except ScenarioError:
        raise
    except ValueError as exc:
        raise _fail("orbit", str(exc)) from None


def _model_names(r: _Reader, pt: Mapping[str, Any]) -> list[str]:
    """The models of [potential]: ``kind = "..."`` (one) or ``models = [...]`` (a sum), with
    their keys checked."""
    if "models" in pt:
        if "kind" in pt:
            raise _fail("potential.models", "give either potential.kind or potential.models")
        names = pt["models"]
        if not isinstance(names, list) or not names or not all(isinstance(x, str) for x in names):
            raise _fail(
                "potential.models",
                f'expected a list of model names such as ["gravity_gradient", '
                f'"magnetic_dipole"], got {names!r}',
            )
        selector, what = "potential.models", names
    else:
        names = [r.string(pt, "kind", "potential", "torque_free")]
        selector, what = "potential.kind", names[0]
    for name in names:
        if name not in _KINDS:
            raise _fail(selector, f"expected one of {', '.join(_KINDS)}, got {name!r}")
    if len(set(names)) != len(names):
        raise _fail("potential.models", f"a model is listed twice: {names}")
    required = [k for n in names for k in _KINDS[n][0]]
    optional = list(dict.fromkeys(k for n in names for k in _KINDS[n][1]))
    takes = [*required, *optional]
    for k in sorted({k for k in pt if not k.endswith("_unit")} - {"kind", "models", *takes}):
        raise _fail(
            f"potential.{k}",
            f"not used with {selector} = {what!r} (which take"
            f"{'s' if selector.endswith('kind') else ''}: {', '.join(takes) or 'no other keys'})",
        )
    _only(pt, "potential", what, required, ("kind", "models", *optional), selector)
    return names


def _facets(r: _Reader, spec: Any) -> list[Any]:
    """The ``[[spacecraft.facets]]`` array as :class:`attitude.Facet` objects."""
    from .facets import Facet

    if not isinstance(spec, list) or not spec or not all(isinstance(f, dict) for f in spec):
        raise _fail(
            "spacecraft.facets",
            "expected an array of tables [[spacecraft.facets]] with area, normal, center "
            "(and cd, specular, diffuse)",
        )
    out = []
    for i, f in enumerate(spec):
        where = f"spacecraft.facets[{i}]"
        allowed = (*_FACET_KEYS, "area_unit", "center_unit")
        for k in f:
            if k not in allowed:
                close = difflib.get_close_matches(k, allowed, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise _fail(f"{where}.{k}", f"unknown key{hint} (allowed: {', '.join(allowed)})")
        area = r.value(f, "area", where, "area")
        normal = r.array(f, "normal", where, 3)
        center = r.value(f, "center", where, "position", n=3)
        coef = {k: r.number(f, k, where, d) for k, d in (("cd", 2.2), ("specular", 0.0),
                                                          ("diffuse", 0.0))}  # fmt: skip
        try:
            out.append(Facet(area, normal, center, **coef))
        except AttitudeError as exc:
            raise ScenarioError(f"{where}.{exc}") from None
    return out


def _check_orbit_angles(r: _Reader, ot: Mapping[str, Any], inc: float, e: float, f0: float):
    """The orbit's angle ranges, reported in the unit the scenario gives them in."""
    from astropy import units as u

    def shown(key: str, rad: float) -> str:
        unit = str(ot.get(f"{key}_unit", "rad"))
        return f"{(rad * u.rad).to_value(u.Unit(unit)):.6g} {unit}"

    if not 0.0 <= inc <= math.pi:
        raise _fail(
            "orbit.inc",
            f"inclination must be in [0, {shown('inc', math.pi)}], got {r.given(ot, 'inc')} (a "
            f"retrograde orbit has inc > {shown('inc', math.pi / 2)}; instead of a negative "
            f"inclination shift raan by {shown('inc', math.pi)})",
        )
    if e > 1.0 and "f0" in ot and not abs(f0) < math.acos(-1.0 / e):
        lim = math.acos(-1.0 / e)
        raise _fail(
            "orbit.f0",
            f"a hyperbola with e = {e!r} only reaches |f| < acos(-1/e) = {shown('f0', lim)}, "
            f"got {r.given(ot, 'f0')}",
        )


def _potential(
    r: _Reader, pt, kind: list[str], orbit: Any, sc: Mapping[str, Any], uses_orbit: bool = False
) -> Any:
    from . import potentials as P

    names = kind
    label = repr(names[0]) if len(names) == 1 else repr(names)
    selector = "potential.kind" if len(names) == 1 and "models" not in pt else "potential.models"
    orbit_models = [n for n in names if n in _ORBIT_MODELS]
    if orbit_models and orbit is None:
        raise _fail("orbit", f"missing table: {selector} = {label} needs [orbit]")
    if orbit is not None and not orbit_models and not uses_orbit:
        raise _fail(
            "orbit",
            f"an orbit is only used by the models {', '.join(_ORBIT_MODELS)}, [events] and "
            f"initial_state.frame, not by {label} alone",
        )
    needed = {_SPACECRAFT_KEYS[n] for n in names if n in _SPACECRAFT_KEYS}
    for k in sc:
        base = k[:-5] if k.endswith("_unit") else k
        if base not in needed:
            users = [m for m, key in _SPACECRAFT_KEYS.items() if key == base]
            raise _fail(
                f"spacecraft.{k}",
                f"not used by {selector} = {label} (used by {' and '.join(users)})",
            )
    for n in names:
        key = _SPACECRAFT_KEYS.get(n)
        if key is not None and key not in sc:
            raise _fail(f"spacecraft.{key}", f"missing (needed by the model {n!r})")
    step = r.value(pt, "step", "potential", "time", default=None)
    terms = []
    for n in names:
        if n == "torque_free":
            terms.append(P.TorqueFree())
        elif n == "heavy_top":
            weight = r.value(pt, "weight", "potential", "force")
            com = r.value(pt, "center_of_mass", "potential", "position", n=3)
            terms.append(P.HeavyTop(weight, com))
        elif n == "gravity_gradient":
            terms.append(P.GravityGradient(orbit))
        elif n in ("magnetic_dipole", "eddy_current_damping"):
            field = r.string(pt, "field", "potential", "igrf")
            if field not in ("igrf", "dipole"):
                raise _fail("potential.field", f"expected 'igrf' or 'dipole', got {field!r}")
            if n == "magnetic_dipole":
                dip = r.value(sc, "dipole", "spacecraft", "dipole", n=3)
                terms.append(P.MagneticDipole(orbit, dip, field, step=step))
            else:
                terms.append(P.EddyCurrentDamping(orbit, _tensor(r, sc), field, step=step))
        elif n == "aerodynamic_drag":
            kw = {k: r.number(pt, k, "potential", 150.0 if k != "ap" else 4.0)
                  for k in ("f107", "f107a", "ap")}  # fmt: skip
            density = r.string(pt, "density", "potential", "msis")
            terms.append(
                P.AerodynamicDrag(orbit, _facets(r, sc["facets"]), density, **kw, step=step)
            )
        else:  # solar_radiation
            eclipse = r.string(pt, "eclipse", "potential", "conical")
            terms.append(P.SolarRadiation(orbit, _facets(r, sc["facets"]), eclipse, step=step))
    return P.Sum(*terms) if len(terms) > 1 else terms[0]


def _tensor(r: _Reader, sc: Mapping[str, Any]) -> np.ndarray:
    """``spacecraft.eddy_tensor``: one number, the 3 diagonal entries or 3 rows of 3."""
    v = sc["eddy_tensor"]
    where = "spacecraft"
    unit = r.unit(sc, "eddy_tensor", where, "conductance")
    scale = 1.0 if unit is None else float((1.0 * unit).to_value(_INTERNAL["conductance"]))
    if _is_number(v):
        m = r.number(sc, "eddy_tensor", where) * np.eye(3)
    elif isinstance(v, list) and len(v) == 3 and all(isinstance(x, list) for x in v):
        m = np.array([r.array({"eddy_tensor": x}, "eddy_tensor", where, 3) for x in v])
    else:
        m = np.diag(r.array(sc, "eddy_tensor", where, 3))
    return m * scale


def _initial(r: _Reader, it, form, frame, body, orbit, t0) -> tuple[np.ndarray, np.ndarray]:
    from . import canonical as C
    from .quaternion import from_euler

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
        from .errors import SingularityError

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
        from .quaternion import EULER_SEQUENCES

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
        from .frames import initial_state

        ref = _frame(frame, orbit, f"{where}.frame")
        return initial_state(body, ref, t0, offset=q, rates=omega)
    return q, C.momenta_from_angular_velocity(q, omega, body)


def _frame(name: str, orbit: Any, key: str, q: Any = None) -> Any:
    """A reference frame of attitude.frames named in a scenario."""
    from . import frames as F

    if name == "inertial":
        return F.inertial((1.0, 0.0, 0.0, 0.0) if q is None else q)
    if orbit is None:
        raise _fail(key, f"frame {name!r} needs an [orbit] table")
    makers = {
        "orbital": F.rsw,
        "rsw": F.rsw,
        "lvlh": F.lvlh,
        "vnc": F.vnc,
        "nadir": F.nadir,
        "sun_pointing": F.sun_pointing,
    }
    if name not in makers:
        raise _fail(key, f"expected one of {', '.join(_FRAMES)}, got {name!r}")
    try:
        return makers[name](orbit)
    except ValueError as exc:
        raise _fail(key, str(exc)) from None


def _events(r: _Reader, table: dict[str, Any], orbit: Any) -> list:
    """The ``[events.<name>]`` subtables as attitude.events objects (errors name the key)."""
    from . import events as E

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
    return out

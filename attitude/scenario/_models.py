"""The physics tables of a scenario: [orbit], [potential] (models that add up) and [spacecraft]."""

from __future__ import annotations

import difflib
import math
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import AttitudeError

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover - Python 3.10
    pass


from ._actuators import ACTUATOR_KEYS
from ._schema import (
    _FACET_KEYS,
    _FRAMES,
    _INTERNAL,
    _KINDS,
    _ORBIT_MODELS,
    _SPACECRAFT_KEYS,
    ScenarioError,
    _epoch,
    _fail,
    _is_number,
    _only,
    _Reader,
    _unknown_choice,
)

_ORBIT_TYPES = ("kepler", "secular_j2", "tle", "oem", "numerical")
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
        "numerical": (
            "a",
            "e",
            "inc",
            "raan",
            "argp",
            "f0",
            "r0",
            "v0",
            "mu",
            "degree",
            "order",
            "third_bodies",
            "earth_rotation",
            "rtol",
            "method",
            "field_step",
        ),
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
        if kind == "numerical":
            return _numerical(r, ot, epoch, mu_q), epoch
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

            from orbit.timescales import check_dates, quiet_erfa

            with quiet_erfa():  # the dates are checked here, before astropy's arithmetic
                e0 = Time(epoch.rstrip("Z"), scale="utc")
            try:  # (epoch + 1e308 s overflowed in astropy, 1e12 s warned "dubious year")
                check_dates(e0, [float(t[0]), float(t[-1])], "time")
            except O.OrbitError as exc:
                raise _fail("time", str(exc).removeprefix("time: ")) from None
            with quiet_erfa():
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
            orb.check_times(np.array([t[0], t[-1]]), "time")  # the ends (t may be lazy)
        except O.OrbitError as exc:
            raise _fail("time", str(exc).split(": ", 1)[-1]) from None
        return orb, epoch
    except ScenarioError:
        raise
    except ValueError as exc:
        raise _fail(*_orbit_key(str(exc))) from None


def _numerical(r: _Reader, ot: Mapping[str, Any], epoch: str | None, mu_q: Any) -> Any:
    """An ``[orbit] type = "numerical"``: its state at the epoch from elements (a, e, inc,
    raan, argp, f0: the osculating two-body state) or from r0 and v0 (GCRS), its field
    (``degree``, ``order``: EGM2008; none: a point mass) and ``third_bodies``."""
    from astropy import units as u

    import orbit as O

    if epoch is None:
        raise _fail("orbit.epoch", "a numerical orbit needs a date: give orbit.epoch (or "
                                   "scenario.epoch), e.g. '2026-03-20T00:00:00'")  # fmt: skip
    has_elements = any(k in ot for k in _ELEMENT_KEYS[:6])
    if has_elements and ("r0" in ot or "v0" in ot):
        raise _fail("orbit.r0", "give either the elements (a, e, inc, raan, argp, f0) or r0, v0")
    degree = ot.get("degree")
    order = ot.get("order")
    for k, v in (("degree", degree), ("order", order)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, int)):
            raise _fail(f"orbit.{k}", f"expected a whole number, got {v!r}")
    if order is not None and degree is None:
        raise _fail("orbit.order", "given without orbit.degree")
    if degree is not None and mu_q is not None:
        raise _fail("orbit.mu", "the field's own GM is used with orbit.degree; give one of them")
    bodies = ot.get("third_bodies", [])
    if not isinstance(bodies, list) or not all(isinstance(b, str) for b in bodies):
        raise _fail(
            "orbit.third_bodies", f'expected a list such as ["sun", "moon"], got {bodies!r}'
        )
    try:
        gravity = None if degree is None else O.SphericalHarmonics(degree, order)
        if has_elements:
            for k in ("a", "e", "inc", "raan", "argp"):
                if k not in ot:
                    raise _fail(f"orbit.{k}", "missing (the elements need a, e, inc, raan, argp)")
            ang = {k: r.value(ot, k, "orbit", "angle") * u.rad for k in ("inc", "raan", "argp")}
            f0 = r.value(ot, "f0", "orbit", "angle", default=0.0) * u.rad
            e = r.number(ot, "e", "orbit")
            _check_orbit_angles(r, ot, ang["inc"].value, e, f0.value)
            mu_el = mu_q if mu_q is not None else (
                None if gravity is None else gravity.mu * 1e-9 * u.Unit("km3 s-2"))  # fmt: skip
            kep = O.KeplerOrbit(r.value(ot, "a", "orbit", "length") * u.km, e, ang["inc"],
                                ang["raan"], ang["argp"], f0=f0, mu=mu_el)  # fmt: skip
            r0, v0 = kep.position(0.0), kep.velocity(0.0)
        else:
            for k in ("r0", "v0"):
                if k not in ot:
                    raise _fail(f"orbit.{k}", "missing (give r0 and v0, or the elements)")
            r0 = r.value(ot, "r0", "orbit", "length", n=3)
            v0 = r.value(ot, "v0", "orbit", "speed", n=3)
        return O.NumericalOrbit(
            r0, v0, epoch.rstrip("Z"), gravity=gravity, third_bodies=tuple(bodies), mu=mu_q,
            earth_rotation=r.string(ot, "earth_rotation", "orbit", "iers"),
            rtol=r.number(ot, "rtol", "orbit", 1e-12),
            method=r.string(ot, "method", "orbit", "dop853"),
            field_step=float(r.value(ot, "field_step", "orbit", "time", default=1.0)),
        )  # fmt: skip
    except O.OrbitError as exc:
        raise _fail(*_orbit_key(str(exc))) from None


def _orbit_key(msg: str) -> tuple[str, str]:
    """``orbit.<key>`` and the rest of an orbit error that starts with its parameter's name
    (``body`` is a ``third_bodies`` entry, ``gravity``/``degree``/``order`` the field)."""
    name, sep, rest = msg.partition(": ")
    keys = {"body": "third_bodies", "gravity": "degree", "r0": "r0", "v0": "v0", "mu": "mu",
            "degree": "degree", "order": "order", "rtol": "rtol", "method": "method",
            "field_step": "field_step", "earth_rotation": "earth_rotation",
            "epoch": "epoch", "a": "a", "e": "e", "inc": "inc", "raan": "raan", "argp": "argp",
            "f0": "f0", "M0": "M0", "t0": "t0", "j2": "j2", "radius": "radius"}  # fmt: skip
    if sep and name in keys:
        return f"orbit.{keys[name]}", rest
    return "orbit", msg


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
    from ..facets import Facet

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
    from .. import potentials as P

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
        if base in ACTUATOR_KEYS:
            continue
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


def _frame(name: str, orbit: Any, key: str, q: Any = None) -> Any:
    """A reference frame of attitude.frames named in a scenario (:func:`frames.by_name`)."""
    from .. import frames as F

    if name != "inertial" and name not in F.NAMED:  # before the [orbit] check: a misspelling
        raise _unknown_choice(key, name, _FRAMES)
    if name != "inertial" and orbit is None:
        raise _fail(key, f"frame {name!r} needs an [orbit] table")
    try:
        if q is not None and name != "inertial":  # the frame turned by q (inertial(q) is too)
            return F.by_name(name, orbit).offset(q)
        return F.by_name(name, orbit, q)
    except ValueError as exc:
        raise _fail(key, str(exc)) from None

"""What the 3D view and the 3D exports draw of a run: frames, shape, Sun, Earth, sensors.

:func:`scene` reads a run (a single run, or one member of an ensemble) into plain arrays at the
frames the page plays: the body quaternion, the reference (guidance) frame, the LVLH frame, the
spacecraft's position, the Sun direction and the shadow, thruster forces, and the time series
drawn beside the scene (pointing error, |ω|, wheel speeds with their limits, the mode).

Long runs are decimated (:func:`frame_indices`) to at most :data:`MAX_FRAMES` frames: evenly
spaced samples, plus in every stretch of the run the samples where the pointing error, |ω| and
each wheel's speed are largest and smallest, plus the samples at the events, the mode switches
and the shadow's edges, and the last sample.

The shape: the facets of the run's surface models (drag, solar radiation) when the scenario
has them, else a box with the proportions of a homogeneous box of the run's inertia.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from ..errors import AttitudeValueError

__all__ = ["MAX_FRAMES", "Scene", "box_from_inertia", "frame_indices", "scene"]

#: Frames a page plays at most (a day at 10 Hz, 864 001 samples, becomes this many).
MAX_FRAMES = 20_000
#: Members whose attitudes an ensemble's page carries (the cloud and the member chooser).
MAX_MEMBERS = 200
#: A limit the data stay below this fraction of is named, not drawn (as ``attitude plot``).
LIMIT_OFF_SCALE = 0.05
#: Mean Earth equatorial radius [km] (WGS-84), for the limb.
R_EARTH_KM = 6378.137


@dataclass
class Scene:
    """A run at the frames of its view (SI: seconds, metres for the shape, km for the orbit)."""

    title: str
    index: np.ndarray  # (n,) sample indices of the frames in the run
    t: np.ndarray  # (n,) seconds (or the run's unit when dimensionless)
    q: np.ndarray  # (n, 4) body -> space, scalar first
    time_unit: str = "s"
    epoch: str | None = None
    n_samples: int = 0
    ref_name: str | None = None
    ref_q: np.ndarray | None = None  # (n, 4) reference -> space
    lvlh_q: np.ndarray | None = None  # (n, 4) LVLH -> space
    position: np.ndarray | None = None  # (n, 3) km, inertial
    sun: np.ndarray | None = None  # (n, 3) unit vector spacecraft -> Sun, inertial
    shadow: np.ndarray | None = None  # (n,) visible fraction of the Sun (1 light, 0 umbra)
    no_orbit: str | None = None  # why no Earth/Sun is drawn
    facets: list[list[float]] = field(default_factory=list)  # [area, n(3), c(3)] body, m
    box: list[float] | None = None  # box sides, m (proportional when the mass is unknown)
    sensors: list[dict[str, Any]] = field(default_factory=list)
    thrusters: dict[str, Any] | None = None
    series: list[dict[str, Any]] = field(default_factory=list)
    modes: dict[str, Any] | None = None
    events: list[dict[str, Any]] = field(default_factory=list)
    ensemble: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)


def box_from_inertia(inertia: Any) -> list[float]:
    """Sides (a, b, c) of a homogeneous box with the principal moments' proportions.

    I₁ = m (b² + c²)/12 and cyclically, so a² ∝ I₂ + I₃ − I₁; the sides are scaled so the
    largest is 1 (the mass is not in the run). Moments that violate the triangle inequality
    (a thin rod, a plate at the limit) get a side of 5 % of the largest.

    Parameters
    ----------
    inertia : array_like, shape (3,)
        Principal moments I₁, I₂, I₃ (any unit).

    Returns
    -------
    list of float
        The sides along body x, y, z, the largest 1.
    """
    i = np.asarray(inertia, dtype=np.float64).reshape(3)
    sq = np.array([i[1] + i[2] - i[0], i[0] + i[2] - i[1], i[0] + i[1] - i[2]])
    sides = np.sqrt(np.clip(sq, 0.0, None))
    top = float(sides.max()) if np.isfinite(sides).all() and sides.max() > 0 else 1.0
    sides = np.maximum(sides / top, 0.05) if top > 0 else np.ones(3)
    return [float(x) for x in sides]


def frame_indices(
    n: int,
    limit: int = MAX_FRAMES,
    *,
    extremes: list[np.ndarray] | None = None,
    keep: Any = (),
) -> np.ndarray:
    """The sample indices a page plays.

    All of them up to ``limit``; else the first sample of each of equal stretches of the run
    and, in each stretch, the argmin and argmax of every series of ``extremes`` (NaN
    ignored), plus the indices ``keep`` and the last sample. The stretches are as many as
    keep the count at most ``limit`` (and, when the extremes coincide, above 90 % of it).

    Parameters
    ----------
    n : int
        Samples in the run.
    limit : int
        Frames at most, besides ``keep``.
    extremes : list of ndarray, optional
        Series of length ``n`` whose extremes are kept (others are ignored).
    keep : sequence of int
        Sample indices always kept (events, mode switches); those outside 0..n-1 ignored.

    Returns
    -------
    ndarray of int
        Sorted unique sample indices, the first and the last included.
    """
    if n <= limit:
        return np.arange(n)
    series = [np.asarray(s, dtype=np.float64) for s in (extremes or []) if np.size(s) == n]
    k = np.asarray(list(keep), dtype=np.int64).ravel()
    k = k[(k >= 0) & (k < n)]
    bins = max(1, (limit - 1) // (1 + 2 * len(series)))
    best = None
    for _ in range(4):  # extremes often coincide: more stretches while the budget allows
        idx = _pick(n, bins, series, k)
        if idx.size - k.size > limit:
            break
        best = idx
        if idx.size - k.size > 0.9 * limit or bins >= limit - 1:
            break
        bins = min(limit - 1, int(bins * 0.97 * limit / max(1, idx.size - k.size)))
    return best if best is not None else _pick(n, max(1, (limit - 1) // 2), [], k)


def _pick(n: int, bins: int, series: list[np.ndarray], keep: np.ndarray) -> np.ndarray:
    """Each stretch's first sample and its series' argmin and argmax, ``keep``, the last.

    The stretches are ``m = ceil(n / bins)`` samples long (the last one shorter).
    """
    m = -(-n // bins)
    starts = np.arange(0, n, m)
    picked = [starts, np.array([n - 1]), keep]
    for s in series:
        pad = np.full(starts.size * m, np.nan)
        pad[:n] = s
        w = pad.reshape(starts.size, m)
        ok = np.isfinite(w).any(axis=1)
        lo = np.argmin(np.where(np.isnan(w), np.inf, w), axis=1)
        hi = np.argmax(np.where(np.isnan(w), -np.inf, w), axis=1)
        picked += [(starts + lo)[ok], (starts + hi)[ok]]
    return np.unique(np.concatenate(picked))


# ------------------------------------------------------------------------------------------------
# reading a run
# ------------------------------------------------------------------------------------------------


def _member(ds: xr.Dataset, member: Any) -> tuple[xr.Dataset, dict[str, Any] | None]:
    """The run to draw and, for an ensemble, what the page needs of the other members."""
    if "member" not in ds.dims:
        if member is not None:
            raise AttitudeValueError(
                f"member: {member!r} given, but the run is a single run, not an ensemble"
            )
        return ds, None
    if "q" not in ds or "time" not in ds["q"].dims or ds.sizes.get("time", 0) < 2:
        raise AttitudeValueError(
            "the ensemble file holds no member attitude histories (statistics or final states "
            "only); run it storing the members' samples (--ensemble-output samples) to view it"
        )
    ids = np.asarray(ds["member"].values)
    k = int(ids[0]) if member is None else member
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)):
        raise AttitudeValueError(f"member: expected a member number, got {member!r}")
    if not np.any(ids == k):
        raise AttitudeValueError(
            f"member: no member {k} in this ensemble (members {int(ids.min())}..{int(ids.max())})"
        )
    return ds.sel(member=k), {"members": ids, "chosen": int(k)}


def _values(ds: xr.Dataset, name: str, idx: np.ndarray | None = None) -> np.ndarray:
    v = ds[name]
    if idx is not None and "time" in v.dims:
        v = v.isel(time=idx)
    return np.asarray(v.values, dtype=np.float64)


def _tick_at(ds: xr.Dataset, t: np.ndarray) -> np.ndarray | None:
    """Index of the tick in effect at each time (the last tick at or before it)."""
    if ds.sizes.get("tick", 0) == 0 or "tick" not in ds.variables:
        return None
    from ..results import time_values

    tick = time_values(ds, "tick")
    return np.clip(np.searchsorted(tick, t, side="right") - 1, 0, tick.size - 1)


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation angle of ã∘b (rad), both (n, 4); NaN where a row of ``a`` is NaN."""
    a0, av = a[:, 0], a[:, 1:]
    b0, bv = b[:, 0], b[:, 1:]
    e0 = a0 * b0 + np.sum(av * bv, axis=1)
    ev = a0[:, None] * bv - b0[:, None] * av - np.cross(av, bv)
    return 2.0 * np.arctan2(np.linalg.norm(ev, axis=1), np.abs(e0))


def _guidance(ds: xr.Dataset, t: np.ndarray) -> np.ndarray | None:
    """The flight software's reference attitude in effect at the times ``t`` (NaN in modes
    without a guidance)."""
    if "reference_q" not in ds:
        return None
    k = _tick_at(ds, t)
    if k is None:
        return None
    ref = np.asarray(ds["reference_q"].values, dtype=np.float64)[k]
    if "mode" in ds:
        from ._closed_loop import guided_modes

        guided = guided_modes(ds)
        mode = np.asarray(ds["mode"].values, dtype=np.int64)[k]
        ref = np.where(guided[np.clip(mode, 0, guided.size - 1)][:, None], ref, np.nan)
    return ref


def _shape(scene_: Scene, ds: xr.Dataset, sc: Any, given: Any = None) -> None:
    """The facets given, else the scenario's surface models', else the box of the inertia."""
    facets = []
    pot = getattr(sc, "potential", None) if sc is not None else None
    terms = [pot, *getattr(pot, "terms", ())] if pot is not None else []
    found = (
        list(given)
        if given is not None
        else [f for t in terms for f in getattr(t, "facets", None) or ()]
    )
    for f in found:
        if not all(hasattr(f, a) for a in ("area", "normal", "center")):
            raise AttitudeValueError(
                f"facets: expected attitude.Facet objects (area, normal, center), got {f!r}"
            )
        row = [float(f.area), *map(float, f.normal), *map(float, f.center)]
        if row not in facets:
            facets.append(row)
    scene_.facets = facets
    inertia = ds.attrs.get("inertia")
    if inertia is None and "inertia" in ds:
        inertia = np.asarray(ds["inertia"].values)
    if not facets:
        box = np.asarray(box_from_inertia(inertia if inertia is not None else [1.0, 1.0, 1.0]))
        size = "its largest side 1 m"
        if "thruster_position" in ds:  # large enough to hold the thrusters
            reach = float(np.abs(np.asarray(ds["thruster_position"].values)).max())
            if reach > 0:
                box, size = box * 2.0 * reach, "as wide as the thrusters' positions"
        scene_.box = [float(x) for x in box]
        scene_.notes.append(f"shape: a box with the proportions of the run's inertia ({size})")


def _sensors(scene_: Scene, sc: Any, given: Any = None) -> None:
    """The sensors given, else the scenario's flight software's."""
    sw = getattr(sc, "software", None) if sc is not None else None
    for s in given if given is not None else getattr(sw, "sensors", None) or ():
        kind = getattr(s, "kind", type(s).__name__)
        if hasattr(s, "boresight"):
            scene_.sensors.append({
                "kind": kind,
                "name": kind.replace("_", " "),
                "boresight": [float(x) for x in s.boresight],
                "sunExclusion": float(getattr(s, "sun_exclusion", 0.0)),
                "earthExclusion": float(getattr(s, "earth_exclusion", -1.0)),
            })  # fmt: skip
        elif hasattr(s, "normals"):
            scene_.sensors.append({
                "kind": kind,
                "name": kind.replace("_", " "),
                "normals": np.asarray(s.normals, dtype=np.float64).tolist(),
            })  # fmt: skip


def _orbit(scene_: Scene, ds: xr.Dataset, idx: np.ndarray, t: np.ndarray, o: Any) -> None:
    from ..quaternion import rotate

    pos = None
    if o is not None:
        try:
            pos = np.asarray(o.position(t), dtype=np.float64)
        except (ValueError, TypeError):
            pos = None
    if pos is None and "r" in ds and "p" in ds:
        pos = _values(ds, "r", idx)[:, None] * rotate(_values(ds, "p", idx), np.array([1.0, 0, 0]))
    if pos is None:
        scene_.no_orbit = "this run has no orbit: no Earth, Sun or LVLH frame to draw"
        return
    scene_.position = pos
    if "p" in ds:
        from ._reference import _from_p

        scene_.lvlh_q = _from_p(ds.isel(time=idx), "lvlh")
    elif o is not None:
        from .. import frames

        scene_.lvlh_q = frames.lvlh(o).quaternion(t)
    epoch = ds.attrs.get("epoch")
    if not epoch:
        scene_.no_orbit = "this run has no epoch: the Sun's direction is unknown"
        return
    from orbit.sun import shadow_function, sun_position

    try:
        sun = np.asarray(sun_position(str(epoch).rstrip("Z"), t), dtype=np.float64)
    except (ValueError, TypeError) as exc:
        scene_.no_orbit = f"the Sun's direction is unknown at these dates ({exc})"
        return
    d = sun - pos
    scene_.sun = d / np.linalg.norm(d, axis=1, keepdims=True)
    scene_.shadow = np.asarray(shadow_function(pos, sun), dtype=np.float64)


def _mode_names(ds: xr.Dataset) -> list[str]:
    meanings = str(ds["mode"].attrs.get("flag_meanings", "")).split()
    n = int(np.max(ds["mode"].values)) + 1 if ds["mode"].size else 0
    return [meanings[k] if k < len(meanings) else f"mode{k}" for k in range(max(n, len(meanings)))]


def _line(label: str, y: np.ndarray) -> dict[str, Any]:
    return {"label": label, "y": np.asarray(y, dtype=np.float64)}


def _series_and_extremes(
    ds: xr.Dataset, t_all: np.ndarray, ref_all: np.ndarray | None
) -> tuple[list[tuple[str, np.ndarray]], list[np.ndarray], list[int]]:
    """Full-resolution series that decide the frames: (name, values), extremes, kept indices."""
    full: list[tuple[str, np.ndarray]] = []
    q = _values(ds, "q")
    if ref_all is not None:
        full.append(("error", np.degrees(_angle_between(ref_all, q))))
    if "omega" in ds:
        full.append(("rate", np.degrees(np.linalg.norm(_values(ds, "omega"), axis=1))))
    if "wheel_speed" in ds:
        w = _values(ds, "wheel_speed") * 60.0 / (2.0 * np.pi)
        full += [(f"wheel{k}", w[:, k]) for k in range(w.shape[1])]
    keep: list[int] = []
    from ._common import run_events

    for e in run_events(ds):
        keep += [
            int(np.searchsorted(t_all, e.t, side="left")),
            int(np.searchsorted(t_all, e.t) - 1),
        ]
    if "mode" in ds and ds.sizes.get("tick", 0):
        from ..results import time_values

        mode = np.asarray(ds["mode"].values)
        tick = time_values(ds, "tick")
        for j in np.flatnonzero(np.diff(mode)) + 1:
            keep.append(int(np.searchsorted(t_all, tick[j], side="left")))
    return full, [v for _, v in full], keep


def scene(
    ds: xr.Dataset,
    *,
    member: Any = None,
    orbit: Any = None,
    facets: Any = None,
    sensors: Any = None,
    max_frames: int = MAX_FRAMES,
) -> Scene:
    """The frames of a run's view (see the module's docstring).

    Parameters
    ----------
    ds : xarray.Dataset
        A result (docs/results.md): a single run or an ensemble with the members' samples.
    member : int, optional
        An ensemble's member to draw (default: its first).
    orbit : orbit.Orbit, optional
        The run's orbit; default the one of the scenario the file holds, else the orbital
        frame and radius the run stored.
    facets : sequence of attitude.Facet, optional
        The spacecraft's surface; default the facets of the scenario's surface models (a run
        made in Python stores none: give them here), else a box of the inertia.
    sensors : sequence of sensors, optional
        Sensors to draw (boresights and exclusion cones, Sun-sensor heads); default the
        scenario's flight software's (a run made in Python stores none).
    max_frames : int
        At most this many frames (plus the events' and mode switches' samples).

    Returns
    -------
    Scene

    Raises
    ------
    AttitudeValueError
        Not a result (no ``q(time, component)``), an unknown member, an ensemble without
        member histories.
    """
    from ..results import time_unit, time_values
    from ._common import run_title
    from ._reference import orbit_of_run, reference, scenario_of

    if isinstance(ds, xr.Dataset) and "member" in ds.dims and "q" not in ds:
        _member(ds, member)  # an ensemble's statistics: says so
    if not isinstance(ds, xr.Dataset) or "q" not in ds or "time" not in ds.dims:
        raise AttitudeValueError(
            "ds: not an attitude result (expected a Dataset with q(time, component), as "
            "attitude.io.read returns)"
        )
    if not (isinstance(max_frames, (int, np.integer)) and max_frames >= 2):
        raise AttitudeValueError(f"max_frames: expected an integer >= 2, got {max_frames!r}")
    full_ds = ds
    ds, ens = _member(ds, member)
    if ds["q"].dims[-2:] != ("time", "component"):
        raise AttitudeValueError("ds: q must have the dimensions (time, component)")
    t_all = time_values(ds)
    n = t_all.size
    sc = scenario_of(full_ds)
    o = orbit if orbit is not None else orbit_of_run(ds, sc)
    ref_all = _guidance(ds, t_all)
    if ref_all is not None and not np.isfinite(ref_all).any():  # no guided mode (B-dot...)
        ref_all = None
    full, ext, keep = _series_and_extremes(ds, t_all, ref_all)
    # the shadow's edges, on the run's own orbit variables (cheap: r and p at every sample)
    idx = frame_indices(n, max_frames, extremes=ext, keep=keep)
    t = t_all[idx]
    q = _values(ds, "q", idx)
    unit = str(time_unit(ds["time"]))
    s = Scene(
        title=run_title(full_ds),
        index=idx,
        t=t,
        q=q,
        time_unit="s" if unit.startswith("s") else unit,
        epoch=str(ds.attrs["epoch"]) if ds.attrs.get("epoch") else None,
        n_samples=n,
    )
    if ref_all is not None:
        s.ref_name, s.ref_q = "guidance reference", ref_all[idx]
    elif "reference_q" not in ds:  # (flight software without a guided mode: no reference)
        try:
            r = reference(ds.isel(time=idx), t, None, o)
        except AttitudeValueError:
            r = None
        if r is not None:
            s.ref_name, s.ref_q = r.name, np.asarray(r.q, dtype=np.float64)
    _orbit(s, ds, idx, t, o)
    _shape(s, ds, sc, facets)
    _sensors(s, sc, sensors)
    if "thruster_force" in ds:
        s.thrusters = {
            "position": _values(ds, "thruster_position").tolist(),
            "direction": _values(ds, "thruster_direction").tolist(),
            "maxThrust": _values(ds, "thruster_max_thrust").tolist(),
            "force": _values(ds, "thruster_force", idx),
        }
    _add_series(s, ds, full, idx)
    from ._common import run_events

    s.events = [{"t": e.t, "name": e.name, "dir": e.direction} for e in run_events(ds)]
    if ens is not None:
        ids = ens["members"][:MAX_MEMBERS]
        qm = np.asarray(full_ds["q"].sel(member=ids).isel(time=idx).values, dtype=np.float64)
        boresight = s.sensors[0]["boresight"] if s.sensors and "boresight" in s.sensors[0] else None
        s.ensemble = {
            "members": [int(x) for x in ids],
            "total": int(ens["members"].size),
            "chosen": ens["chosen"],
            "q": qm,  # (member, frame, 4)
            "boresight": boresight or [0.0, 0.0, 1.0],
        }
        if ens["members"].size > MAX_MEMBERS:
            s.notes.append(f"ensemble: the first {MAX_MEMBERS} of {ens['members'].size} members")
    if n > idx.size:
        s.notes.append(
            f"{idx.size} of {n} samples shown (evenly spaced, with each stretch's extremes, "
            "the events and the mode switches)"
        )
    return s


def _add_series(
    s: Scene, ds: xr.Dataset, full: list[tuple[str, np.ndarray]], idx: np.ndarray
) -> None:
    named = dict(full)
    if "error" in named:
        s.series.append({
            "name": f"pointing error from the {s.ref_name}", "unit": "deg", "log": True,
            "lines": [_line("error", named["error"][idx])], "limits": [],
        })  # fmt: skip
    elif s.ref_q is not None:
        err = np.degrees(_angle_between(s.ref_q, s.q))
        s.series.append({
            "name": f"pointing error from {s.ref_name}", "unit": "deg", "log": False,
            "lines": [_line("error", err)], "limits": [],
        })  # fmt: skip
    if "rate" in named:
        s.series.append({"name": "|ω|", "unit": "deg/s", "log": False,
                         "lines": [_line("|ω|", named["rate"][idx])], "limits": []})  # fmt: skip
    if "wheel_speed" in ds:
        labels = [str(x) for x in ds["wheel_label"].values] if "wheel_label" in ds else []
        nw = ds.sizes["wheel"]
        lines = [_line(labels[k] if k < len(labels) else f"wheel {k + 1}", named[f"wheel{k}"][idx])
                 for k in range(nw)]  # fmt: skip
        lim = _values(ds, "wheel_max_speed") * 60.0 / (2.0 * np.pi)
        lims = sorted({float(x) for x in np.abs(lim) if np.isfinite(x)})
        peak = max(float(np.nanmax(np.abs(named[f"wheel{k}"]))) for k in range(nw))
        name = "wheel speeds"
        if lims and peak < LIMIT_OFF_SCALE * lims[0]:  # as attitude plot: it would flatten them
            name += f" (limit ±{lims[0]:.4g} rpm, off scale)"
            lims = []
        s.series.append({"name": name, "unit": "rpm", "log": False, "lines": lines,
                         "limits": [v for x in lims for v in (x, -x)]})  # fmt: skip
    if s.thrusters is not None:
        f = s.thrusters["force"]
        s.series.append(
            {
                "name": "thrust",
                "unit": "N",
                "log": False,
                "limits": [],
                "lines": [_line(f"thruster {k + 1}", f[:, k]) for k in range(f.shape[1])],
            }
        )
    if "mode" in ds and ds.sizes.get("tick", 0):
        k = _tick_at(ds, s.t)
        if k is not None:
            mode = np.asarray(ds["mode"].values, dtype=np.int64)[k]
            s.modes = {"names": _mode_names(ds), "value": mode}
    if s.shadow is not None and np.nanmin(s.shadow) < 1.0:
        s.notes.append("the satellite enters the Earth's shadow: the scene dims there")

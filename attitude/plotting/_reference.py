"""The reference frame a figure measures the attitude against (pointing error, roll/pitch/yaw).

The frame is a name (``"lvlh"``, ``"orbital"``, ``"nadir"``... :data:`attitude.frames.NAMED`,
``"inertial"``) or an :class:`attitude.frames.Frame`. A name needs the run's orbit: the one
given, else the orbit of the scenario the file holds (``scenario_toml``, rebuilt), else, for
the orbital frames (``orbital``/``rsw``, ``lvlh``), the orbital frame ``p`` the run stored.
By default it is the scenario's: the frame of its initial state, else of its first pointing
event, else LVLH for a run with an orbit.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..errors import AttitudeValueError

#: Frame names a figure accepts (besides a Frame object).
FRAME_NAMES = ("inertial", "orbital", "rsw", "lvlh", "vnc", "nadir", "sun_pointing", "none")


@dataclass
class Reference:
    """A reference attitude sampled at a figure's times."""

    name: str  # for titles: "LVLH", "orbital (RSW)", ...
    q: np.ndarray  # (n, 4): reference -> space


def scenario_of(ds: xr.Dataset) -> Any:
    """The scenario a result file holds (``scenario_toml``), rebuilt, or None.

    Relative paths in it (an OEM file) are taken from the scenario file's directory when it is
    still there. Nothing is run; an orbit from a TLE is sampled again (SGP4).
    """
    text = ds.attrs.get("scenario_toml")
    if not text:
        return None
    from .. import scenario

    where = ds.attrs.get("scenario_file") or None
    try:
        with warnings.catch_warnings():  # already said when the run was made
            warnings.simplefilter("ignore")
            return scenario.loads(str(text), path=Path(where) if where else None)
    except (ValueError, TypeError, OSError):
        return None


def orbit_of(scenario: Any) -> Any:
    """The orbit of a scenario's potential, or None."""
    if scenario is None:
        return None
    pot = scenario.potential
    o = getattr(pot, "orbit", None)
    if o is None:
        for term in getattr(pot, "terms", ()):
            o = getattr(term, "orbit", None)
            if o is not None:
                break
    return o


def run_orbit(ds: xr.Dataset) -> Any:
    """The orbit a run propagated with its attitude (its ``position`` and ``velocity``
    samples, GCRS), as an :class:`orbit.EphemerisOrbit`; None for a run on a given orbit."""
    if "position" not in ds or "velocity" not in ds or ds.sizes.get("time", 0) < 2:
        return None
    from orbit import EphemerisOrbit

    from ..results import time_values

    t = time_values(ds)
    return EphemerisOrbit(t, ds["position"].values * 1e-3, ds["velocity"].values * 1e-3,
                          epoch=ds.attrs.get("epoch", "").rstrip("Z") or None,
                          source="the run's own orbit")  # fmt: skip


def orbit_of_run(ds: xr.Dataset, scenario: Any = None) -> Any:
    """The run's orbit: the one it propagated (its samples), else its scenario's."""
    o = run_orbit(ds)
    return o if o is not None else orbit_of(scenario_of(ds) if scenario is None else scenario)


def default_frame(ds: xr.Dataset) -> str | None:
    """The scenario's frame: of the initial state, else of the first pointing event, else
    ``lvlh`` when the run has an orbit; None without one."""
    text = ds.attrs.get("scenario_toml")
    if text:
        from ..scenario import tomllib

        try:
            toml = tomllib.loads(str(text))
        except ValueError:
            toml = {}
        frame = toml.get("initial_state", {}).get("frame", "inertial")
        if frame != "inertial":
            return str(frame)
        for ev in toml.get("events", {}).values():
            if isinstance(ev, dict) and ev.get("type") == "pointing_exceeds":
                f = ev.get("frame", "inertial")
                if f != "inertial":
                    return str(f)
    return "lvlh" if "p" in ds or ds.attrs.get("orbit") else None


_TITLES = {
    "lvlh": "LVLH",
    "orbital": "the orbital frame (RSW)",
    "rsw": "RSW",
    "vnc": "VNC",
    "nadir": "the nadir frame",
    "sun_pointing": "the Sun-pointing frame",
    "inertial": "the inertial axes",
}


def _from_p(ds: xr.Dataset, name: str) -> np.ndarray | None:
    """The orbital frames from the run's stored p (RSW): LVLH = RSW∘o, o the fixed rotation
    with (x, y, z)_LVLH = (ŝ, −ĥ, −r̂) (docs/conventions.md sect. 8)."""
    if "p" not in ds or name not in ("orbital", "rsw", "lvlh"):
        return None
    from ..quaternion import from_matrix, multiply

    p = np.asarray(ds["p"].values, dtype=np.float64)
    if name != "lvlh":
        return p
    # columns: the LVLH axes in RSW components
    o = from_matrix(np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))
    return multiply(p, o)


def reference(
    ds: xr.Dataset, t_seconds: np.ndarray, frame: Any = None, orbit: Any = None
) -> Reference | None:
    """The reference attitude at the figure's times (``ds`` already decimated to them).

    ``frame``: None (the scenario's, :func:`default_frame`), ``"none"`` (no reference), a name
    of :data:`FRAME_NAMES`, or an :class:`attitude.frames.Frame`.
    """
    from .. import frames as F

    if isinstance(frame, F.Frame):
        name = getattr(frame, "name", None) or type(frame).__name__
        return Reference(_TITLES.get(str(name), str(name)), frame.quaternion(t_seconds))
    if frame is not None and not isinstance(frame, str):
        raise AttitudeValueError(
            f"frame: a frame name ({', '.join(FRAME_NAMES)}) or an attitude.frames.Frame, "
            f"got {type(frame).__name__}"
        )
    name = default_frame(ds) if frame is None else frame
    if name is None or name == "none":
        return None
    if name not in FRAME_NAMES:
        raise AttitudeValueError(
            f"frame: {name!r}; expected one of {', '.join(FRAME_NAMES)} or a Frame"
        )
    title = _TITLES.get(name, name)
    if name == "inertial":
        return Reference(title, np.tile([1.0, 0.0, 0.0, 0.0], (t_seconds.size, 1)))
    if orbit is None:
        orbit = orbit_of_run(ds)
    if orbit is None:
        q = _from_p(ds, name)
        if q is None:
            raise AttitudeValueError(
                f"frame: {name!r} needs the run's orbit: this result holds no scenario to "
                "rebuild it from; pass orbit= (plot_result), or use a frame the run stored "
                "(orbital, lvlh)"
            )
        return Reference(title, q)
    return Reference(title, F.by_name(name, orbit).quaternion(t_seconds))

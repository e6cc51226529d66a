"""An offline 3D view of a run in the browser: one self-contained HTML file (``attitude view``).

:func:`view` writes a page that animates the run (:mod:`._scene` says what is drawn): the
spacecraft's shape, its body axes, the reference (guidance) frame and LVLH, the Earth at the
angular size it has from the spacecraft with the nadir arrow and the limb, the Sun's direction
(the light dims in the Earth's shadow), sensor boresights with their exclusion cones, thruster
plumes when they fire, and beside it the pointing error, |ω|, the wheel speeds with their
limits and the modes, with a cursor; a time slider, play/pause and speed; the camera fixed to
inertial space, to LVLH or to the body. An ensemble's page chooses a member and shows the
members' boresights as a cloud.

Every script is in the file: three.js r170 (package data ``view/``, MIT licence beside it)
through an import map of ``data:`` URLs, the scene's code, and the run's frames as base64
arrays (float64 for times, quaternions and the Sun; float32 for the plotted series). The page
makes no network request. ``window.attitudeView`` exposes what is drawn (``state()``) and
``setFrame(i)``, for tests and scripts.
"""

from __future__ import annotations

import base64
import json
import os
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._scene import MAX_FRAMES, R_EARTH_KM, Scene, scene

__all__ = ["view", "view_html"]

#: Package data of the page.
_ASSETS = "view"


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath(_ASSETS, name).read_text(encoding="utf-8")


def _data_url(text: str) -> str:
    return "data:text/javascript;base64," + base64.b64encode(text.encode("utf-8")).decode("ascii")


def _array(a: Any, dtype: str = "f64") -> dict[str, Any] | None:
    if a is None:
        return None
    np_type = {"f64": "<f8", "f32": "<f4", "i32": "<i4"}[dtype]
    arr = np.ascontiguousarray(np.asarray(a), dtype=np_type)
    return {"dtype": dtype, "shape": list(arr.shape), "b64": base64.b64encode(arr).decode("ascii")}


def _size(s: Scene) -> float:
    """The body's size [m] (the scene's length unit): its largest extent from the centre."""
    if s.facets:
        f = np.asarray(s.facets)
        reach = np.linalg.norm(f[:, 4:7], axis=1) + 0.5 * np.sqrt(f[:, 0])
        return float(max(reach.max(), 1e-3))
    return float(0.5 * np.linalg.norm(s.box)) if s.box else 1.0


def _payload(s: Scene) -> dict[str, Any]:
    return {
        "title": s.title,
        "epoch": s.epoch,
        "timeUnit": s.time_unit,
        "nSamples": s.n_samples,
        "t": _array(s.t),
        "q": _array(s.q),
        "refName": s.ref_name,
        "refQ": _array(s.ref_q),
        "lvlhQ": _array(s.lvlh_q),
        "position": _array(s.position, "f32"),
        "sun": _array(s.sun),
        "shadow": _array(s.shadow, "f32"),
        "noOrbit": s.no_orbit,
        "earthRadiusKm": R_EARTH_KM,
        "facets": s.facets,
        "box": s.box,
        "size": _size(s),
        "sensors": s.sensors,
        "thrusters": None
        if s.thrusters is None
        else {**s.thrusters, "force": _array(s.thrusters["force"], "f32")},
        "series": [
            {
                **x,
                "lines": [{"label": ln["label"], "y": _array(ln["y"], "f32")} for ln in x["lines"]],
            }
            for x in s.series
        ],
        "mode": None if s.modes is None else _array(s.modes["value"], "i32"),
        "modeNames": [] if s.modes is None else s.modes["names"],
        "events": s.events,
        "ensemble": None
        if s.ensemble is None
        else {**s.ensemble, "q": _array(s.ensemble["q"], "f32")},
        "notes": s.notes,
    }


def _json_for_script(obj: Any) -> str:
    """JSON that can sit inside a ``<script>`` element (no ``</`` to close it early)."""
    text = json.dumps(obj, ensure_ascii=True, allow_nan=False, separators=(",", ":"))
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def _clean(obj: Any) -> Any:
    """NaN/inf (not JSON) in the small lists of the payload as None."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_clean(v) for v in obj]
    return obj


def view_html(
    ds: xr.Dataset,
    *,
    member: int | None = None,
    orbit: Any = None,
    facets: Any = None,
    sensors: Any = None,
    max_frames: int = MAX_FRAMES,
) -> str:
    """The page of :func:`view`, as a string.

    Parameters
    ----------
    ds, member, orbit, facets, sensors, max_frames
        As :func:`view`.

    Returns
    -------
    str
        A complete HTML document.
    """
    from .._version import __version__

    s = scene(ds, member=member, orbit=orbit, facets=facets, sensors=sensors, max_frames=max_frames)
    imports = {
        "imports": {
            "three": _data_url(_asset("three.module.min.js")),
            "three/addons/controls/OrbitControls.js": _data_url(_asset("OrbitControls.js")),
        }
    }
    title = s.title.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    page = _asset("view.html")
    parts = {
        "@@GENERATOR@@": f"attitude {__version__} (three.js r170, MIT licence)",
        "@@TITLE@@": title,
        "@@CSS@@": _asset("view.css"),
        "@@IMPORTMAP@@": json.dumps(imports),
        "@@APP@@": _asset("view.js"),
        "@@DATA@@": _json_for_script(_clean(_payload(s))),
    }
    for key in ("@@GENERATOR@@", "@@TITLE@@", "@@CSS@@", "@@IMPORTMAP@@", "@@APP@@"):
        page = page.replace(key, parts[key])
    return page.replace("@@DATA@@", parts["@@DATA@@"])  # last: the data holds any text


def view(
    ds: xr.Dataset,
    path: str | os.PathLike | None = None,
    *,
    member: int | None = None,
    orbit: Any = None,
    facets: Any = None,
    sensors: Any = None,
    max_frames: int = MAX_FRAMES,
) -> str | Path:
    """A self-contained HTML page that animates the run in 3D (see the module's docstring).

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result (docs/results.md), a single run or an ensemble with its
        members' samples; an open lazy file is read in full once for the frames' variables.
    path : str or Path, optional
        Write the page there (atomically: a temporary file beside it, renamed into place;
        nothing is left under the name if anything fails). Default: return the HTML.
    member : int, optional
        An ensemble's member to draw first (default its first); the page carries up to 200
        members (the member chooser and the boresight cloud).
    orbit : orbit.Orbit, optional
        The run's orbit, if the file cannot rebuild it (default: the scenario's).
    facets : sequence of attitude.Facet, optional
        The spacecraft's surface, for a run made in Python (a scenario's file has them).
    sensors : sequence of sensors, optional
        Sensors to draw (star trackers' boresights and exclusion cones, Sun-sensor heads), for
        a run made in Python (default: the scenario's flight software's).
    max_frames : int
        Frames at most (default :data:`MAX_FRAMES` = 20 000, which a browser loads in about
        a second and plays smoothly): evenly spaced, plus each stretch's extremes, the events
        and the mode switches.

    Returns
    -------
    str or Path
        The HTML text, or ``path`` once written.

    Raises
    ------
    AttitudeValueError
        Not a run (no attitude ``q(time, component)``), an unknown ensemble member.
    AttitudeFileError
        ``path`` cannot be written (a directory, no permission, a full disk...).
    """
    from .._files import OutputFile

    target = OutputFile(path, "path") if path is not None else None  # checked before the work
    html = view_html(
        ds, member=member, orbit=orbit, facets=facets, sensors=sensors, max_frames=max_frames
    )
    if target is None:
        return html
    with target.writing() as tmp:
        Path(tmp).write_text(html, encoding="utf-8")
        return target.commit()

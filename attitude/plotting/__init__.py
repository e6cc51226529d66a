"""Figures of propagation results (matplotlib, imported only here): ``attitude plot``; the 3D
view in the browser (``attitude view``) and the glTF and CZML exports (``attitude export``).

==============================  ==============================================================
:func:`plot_result`             a single run: the engineer's figure (pointing error and
                                roll/pitch/yaw against a reference frame, body rates in deg/s,
                                eclipse bars, event markers; panels chosen by name) or the
                                paper's layout (q, Q, ω, energy: Arribas et al. Figs. 1–3)
:func:`plot_torque_budget`      |τ| of every model term against time, max and RMS
:func:`plot_ensemble`           percentile bands over the members of an ensemble
:func:`register_panel`          add a panel to the engineer's figure
:func:`view`                    a self-contained HTML page animating the run in 3D (three.js)
:func:`write_gltf`              the spacecraft with its attitude keyframes as binary glTF 2.0
:func:`write_czml`              the orbit and the orientation as CZML for Cesium
==============================  ==============================================================

Modules: ``_common`` (time axis in s/min/h/days, decimation, events, eclipses), ``_reference``
(the reference frame of a run: by name on its orbit, rebuilt from the file's scenario, or the
stored orbital frame), ``_panels`` (the panel functions and their registry), ``_paper``,
``_torques``, ``_ensemble``, ``_closed_loop`` (the attitude error of the flight
software, the actuators with their limits, the estimator in its 3σ bounds), ``_scene`` (what
the 3D view and exports draw, at decimated frames), ``_view`` (the page; its files in
``view/``), ``_export`` (glTF and CZML).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import xarray as xr

from ._closed_loop import CLOSED_LOOP_PANELS, closed_loop_defaults, is_closed_loop, mark_modes
from ._common import (
    MAX_POINTS,
    TimeAxis,
    decimate,
    mark_events,
    pyplot,
    run_events,
    run_title,
    save,
    shade_eclipses,
    shadow_along,
)
from ._ensemble import MAX_ENSEMBLE_TIMES, plot_ensemble
from ._export import write_czml, write_gltf
from ._panels import DEFAULT_PANELS, PANELS, PlotContext, available, default_panels, register_panel
from ._paper import draw_paper
from ._reference import FRAME_NAMES, default_frame, reference
from ._torques import plot_torque_budget
from ._view import view, view_html

__all__ = [
    "CLOSED_LOOP_PANELS",
    "DEFAULT_PANELS",
    "FRAME_NAMES",
    "LAYOUTS",
    "MAX_ENSEMBLE_TIMES",
    "MAX_POINTS",
    "PANELS",
    "PlotContext",
    "default_frame",
    "plot_ensemble",
    "plot_result",
    "plot_torque_budget",
    "register_panel",
    "view",
    "view_html",
    "write_czml",
    "write_gltf",
]

#: Layouts of :func:`plot_result`.
LAYOUTS = ("auto", "engineer", "paper")


def _layout(ds: xr.Dataset, layout: str, frame: Any, orbit: Any) -> str:
    if layout not in LAYOUTS:
        from ..errors import AttitudeValueError

        raise AttitudeValueError(f"layout: one of {', '.join(LAYOUTS)}, got {layout!r}")
    if layout != "auto":
        return layout
    if ds.attrs.get("plot_layout") in ("paper", "engineer"):  # the scenario's choice
        return str(ds.attrs["plot_layout"])
    if frame is not None or orbit is not None or is_closed_loop(ds):
        return "engineer"
    return "engineer" if default_frame(ds) is not None else "paper"


def plot_result(
    ds: xr.Dataset,
    path: str | os.PathLike | None = None,
    *,
    layout: str = "auto",
    frame: Any = None,
    orbit: Any = None,
    panels: Any = None,
    dpi: int = 110,
) -> Any:
    """Figure of a single run.

    ``layout="engineer"``: panels on one time axis (hours or days on long runs, with the
    epoch), grey bars where the satellite is in the Earth's shadow (darker in the umbra) and
    dotted lines at the run's events (named at the top). The default panels are ``pointing``
    (the angle from the reference frame to the body), ``angles`` (roll, pitch, yaw: 3-2-1
    about body x, y, z, relative to the frame) and ``rates`` (ω in body axes and |ω|, deg/s);
    also ``rates_relative``, ``energy`` (H solid, T dashed over it, U on its own axis when
    small) and ``torque`` (|τ| per model, log). A tumbling body's angles are drawn as points.

    ``layout="paper"``: q (left) and Q (right) against time as in Arribas et al. Figs. 1–3,
    with the body angular velocity and the energy below (the relative energy error of
    conservative problems; H, T, U of time-dependent potentials).

    ``layout="auto"``: the scenario's choice (its ``[output] plot_layout``, as the paper's
    three scenarios ask for the paper's), else the engineer's for a run with an orbit or a
    reference frame, else the paper's.

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result (docs/results.md); may be lazily loaded (it is decimated to at
        most :data:`MAX_POINTS` samples before reading).
    path : str or Path, optional
        Save the figure there (PNG, PDF, SVG... by extension).
    layout : {"auto", "engineer", "paper"}
    frame : str or attitude.frames.Frame, optional
        The reference frame: a name of :data:`FRAME_NAMES` (``"lvlh"``, ``"orbital"``,
        ``"nadir"``..., ``"inertial"``: the space axes; ``"none"``: no reference) or a Frame.
        Default: the scenario's (:func:`default_frame`: its initial state's frame, else its
        first pointing event's, else LVLH on an orbit).
    orbit : orbit.Orbit, optional
        The run's orbit, for frames by name and the shadow; default the one of the scenario
        the file holds (rebuilt), else the orbital frame and radius the run stored.
    panels : sequence of str, optional
        Engineer's panels by name (:data:`PANELS`; :func:`register_panel` adds more).
    dpi : int
        Resolution of a saved raster figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..errors import AttitudeValueError
    from ..results import time_values

    chosen = _layout(ds, layout, frame, orbit)
    d = decimate(ds)
    t = time_values(d)
    axis = TimeAxis.of(ds, t)
    plt = pyplot(path)
    title = run_title(ds)
    if chosen == "paper":
        ctx = PlotContext(d, t, axis)
        fig = plt.figure(figsize=(11, 7), constrained_layout=True)
        draw_paper(fig, ctx)
        fig.suptitle(title, fontsize=11)
        return save(fig, path, dpi)

    names = list(panels) if panels is not None else None
    for name in names or ():
        if name not in PANELS:
            raise AttitudeValueError(f"panels: {name!r}; available: {', '.join(PANELS)}")
    ref = reference(d, t, frame, orbit)
    ctx = PlotContext(d, t, axis, ref, run_events(ds))
    if names is None:
        names = closed_loop_defaults(ctx) if is_closed_loop(d) else default_panels(ctx)
    missing = [p for p in names if not available(ctx, p)]
    if missing:
        raise AttitudeValueError(
            f"panels: {', '.join(missing)} cannot be drawn for this run (they need a reference "
            "frame or variables it does not have)"
        )
    if axis.unit and ("p" in d or orbit is not None):
        from ._reference import orbit_of_run

        o = orbit if orbit is not None else orbit_of_run(ds)
        ctx.shadow = shadow_along(d, t, o)
    fig, axes = plt.subplots(len(names), 1, figsize=(11, 1.2 + 2.35 * len(names)), sharex=True,
                             constrained_layout=True, squeeze=False)  # fmt: skip
    axes = list(axes[:, 0])
    for ax, name in zip(axes, names, strict=True):
        PANELS[name](ax, ctx)
        ax.grid(alpha=0.3)
    tv = ctx.t
    axes[-1].set_xlim(float(np.nanmin(tv)), float(np.nanmax(tv)))
    shaded = shade_eclipses(axes, ctx.shadow, axis)
    mark_events(axes, ctx.events, axis)
    moded = mark_modes(axes, d, axis)
    axes[-1].set_xlabel(axis.text)
    notes = []
    if shaded:
        notes.append("grey: the Earth's shadow (light: penumbra, dark: umbra)")
    if ctx.events:
        notes.append("dotted: events")
    if moded:
        notes.append("coloured bands and dashed lines: flight-software modes")
    sub = f"\n{'; '.join(notes)}" if notes else ""
    fig.suptitle(f"{title}{sub}", fontsize=11)
    return save(fig, path, dpi)

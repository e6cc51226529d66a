"""The panels of the engineer's figure: one function per panel, drawn on a shared time axis.

A panel function takes ``(ax, ctx)`` — a matplotlib Axes and the :class:`PlotContext` of the
figure (the run decimated to the plotted times, the time axis, the reference frame's attitude,
the events, the shadow) — draws, and returns nothing. :data:`PANELS` maps names to them;
:func:`register_panel` adds one (a closed-loop quantity, say wheel speeds, once a run stores
them), and ``plot_result(ds, panels=[...])`` / ``attitude plot --panels`` choose them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import xarray as xr

from ._common import Event, TimeAxis, break_at_wraps, label, series, window_text, windows
from ._reference import Reference

_AXIS_COLORS = ("tab:blue", "tab:orange", "tab:green")


@dataclass
class PlotContext:
    """What the panels of one figure share.

    Attributes
    ----------
    ds : xarray.Dataset
        The run at the plotted times (decimated to at most ``MAX_POINTS``).
    t_seconds : ndarray
        Those times, seconds since the epoch (or the run's own unit, dimensionless).
    axis : TimeAxis
        The time axis (unit and label).
    reference : Reference or None
        The reference frame's attitude at those times.
    events : list of Event
        The run's events (seconds).
    shadow : (ndarray, ndarray) or None
        Times [s] and the visible fraction of the Sun there (None: no orbit or no epoch).
    """

    ds: xr.Dataset
    t_seconds: np.ndarray
    axis: TimeAxis
    reference: Reference | None = None
    events: list[Event] = field(default_factory=list)
    shadow: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def t(self) -> np.ndarray:
        """The plotted times in the axis unit."""
        return self.axis.values(self.t_seconds)

    @cached_property
    def tick_index(self) -> np.ndarray:
        """The flight-software ticks drawn: every one, or a stride of them (the last kept) on a
        run with more than ``MAX_POINTS``."""
        from ._common import MAX_POINTS

        n = self.ds.sizes.get("tick", 0)
        idx = np.arange(0, n, max(1, -(-n // MAX_POINTS)))
        if n and idx[-1] != n - 1:
            idx = np.append(idx, n - 1)
        return idx

    @cached_property
    def tick_seconds(self) -> np.ndarray:
        """The times of those ticks, seconds since the epoch (as ``t_seconds``)."""
        from ..results import time_values

        if "tick" not in self.ds.variables:
            return np.zeros(0)
        return time_values(self.ds, "tick")[self.tick_index]

    @cached_property
    def q(self) -> np.ndarray:
        return np.asarray(self.ds["q"].values, dtype=np.float64)

    @cached_property
    def error_quaternion(self) -> np.ndarray | None:
        """q_BR = q̃_R∘q (body → reference), None without a reference."""
        if self.reference is None:
            return None
        from ..quaternion import conjugate, multiply

        return multiply(conjugate(self.reference.q), self.q)

    @cached_property
    def error_angle_deg(self) -> np.ndarray | None:
        """The pointing error: the rotation angle of q_BR, degrees in [0, 180]."""
        e = self.error_quaternion
        if e is None:
            return None
        return np.degrees(2.0 * np.arctan2(np.linalg.norm(e[:, 1:], axis=1), np.abs(e[:, 0])))

    @cached_property
    def roll_pitch_yaw_deg(self) -> np.ndarray | None:
        """Roll, pitch, yaw (intrinsic 3-2-1 of q_BR: about body x, y, z), degrees, (n, 3)."""
        e = self.error_quaternion
        if e is None:
            return None
        from ..quaternion import to_euler

        yaw, pitch, roll = np.degrees(to_euler(e, "321")).T
        return np.stack([roll, pitch, yaw], axis=1)

    @cached_property
    def rate_scale(self) -> tuple[float, str]:
        """(factor, unit) turning ``omega`` into deg/s (deg per time unit, dimensionless)."""
        units = str(self.ds["omega"].attrs.get("units", "1"))
        if units in ("1", ""):
            return float(np.degrees(1.0)), "deg per time unit"
        from astropy import units as u

        f = u.Unit(units).to("deg/s", equivalencies=u.dimensionless_angles())
        return float(f), "deg/s"

    @cached_property
    def tumbling(self) -> bool:
        """Whether the body turns relative to the reference instead of holding an attitude
        in it (even one far from it): a tenth of the samples more than 90° from the first
        attitude relative to the frame, or more than 30° turned between plotted samples
        (lines through those are meaningless). The angle panels then draw points, and the
        default panels leave roll/pitch/yaw out for the energy and the torques."""
        if self.t_seconds.size < 3 or self.error_quaternion is None:
            return False
        from ..quaternion import angle_between

        e = self.error_quaternion
        steps = np.degrees(angle_between(e[1:], e[:-1]))
        spread = np.degrees(angle_between(e, e[0]))
        return bool(np.median(steps) > 30.0 or np.percentile(spread, 90) > 90.0)


#: A panel function draws on ``ax`` from the figure's context.
Panel = Callable[[Any, PlotContext], None]

#: The panels by name (in the order of the figure when asked for together).
PANELS: dict[str, Panel] = {}
#: What each panel needs: a reference frame ("reference"), or variables of the run.
NEEDS: dict[str, tuple[str, ...]] = {}


def register_panel(name: str, needs: tuple[str, ...] = ()) -> Callable[[Panel], Panel]:
    """Add a panel function under ``name`` (a decorator).

    Parameters
    ----------
    name : str
        The panel's name (``plot_result(panels=[...])``, ``attitude plot --panels``).
    needs : tuple of str
        Variables the run must hold, or ``"reference"`` (a reference frame), for the panel
        to be drawn in the automatic choice.
    """

    def add(fn: Panel) -> Panel:
        PANELS[name] = fn
        NEEDS[name] = tuple(needs)
        return fn

    return add


def available(ctx: PlotContext, name: str) -> bool:
    """Whether the run has what panel ``name`` needs."""
    for need in NEEDS.get(name, ()):
        if need == "reference":
            if ctx.reference is None:
                return False
        elif need not in ctx.ds.variables:
            return False
    return True


def _legend(ax: Any, ncol: int = 1, loc: str = "upper left") -> None:
    """The legend outside the panel, at its right: it never hides a curve."""
    ax.legend(loc=loc, bbox_to_anchor=(1.005, 1.0), fontsize=8, ncol=ncol, framealpha=0.9,
              handlelength=1.6, borderaxespad=0.0)  # fmt: skip


@register_panel("pointing", needs=("reference",))
def pointing(ax: Any, ctx: PlotContext) -> None:
    """The pointing error: the angle of the rotation from the reference frame to the body."""
    err = ctx.error_angle_deg
    style = {"marker": ".", "ms": 1.5, "ls": "none"} if ctx.tumbling else {"lw": 1.3}
    ax.plot(ctx.t, err, color="k", label="error angle", **style)
    ax.set_ylabel("pointing error [deg]")
    note = " (not held: tumbling)" if ctx.tumbling else ""
    ax.set_title(f"attitude relative to {ctx.reference.name}{note}", fontsize=10, loc="left")
    top = float(np.nanmax(err)) if err.size else 1.0
    ax.set_ylim(0.0, min(180.0, top * 1.1 + 1e-9) if top < 170 else 180.0)
    if top >= 170:
        ax.set_yticks([0, 45, 90, 135, 180])


@register_panel("angles", needs=("reference",))
def angles(ax: Any, ctx: PlotContext) -> None:
    """Roll, pitch, yaw of the body in the reference frame (3-2-1, about body x, y, z)."""
    rpy = ctx.roll_pitch_yaw_deg
    names = ("roll (x)", "pitch (y)", "yaw (z)")
    for k, (name, color) in enumerate(zip(names, _AXIS_COLORS, strict=True)):
        if ctx.tumbling:
            ax.plot(ctx.t, rpy[:, k], ".", ms=1.2, color=color, label=name)
        else:
            tt, a = break_at_wraps(ctx.t, rpy[:, k])
            ax.plot(tt, a, lw=1.2, color=color, label=name)
    ax.set_ylabel("3-2-1 angles [deg]")
    span = float(np.nanmax(np.abs(rpy))) if rpy.size else 1.0
    if span > 100:
        ax.set_ylim(-180, 180)
        ax.set_yticks([-180, -90, 0, 90, 180])
    ax.axhline(0.0, color="0.5", lw=0.6)
    _legend(ax)


@register_panel("rates", needs=("omega",))
def rates(ax: Any, ctx: PlotContext) -> None:
    """Body angular velocity components and |ω| (inertial rate in body axes, what gyros
    measure)."""
    f, unit = ctx.rate_scale
    w = np.asarray(ctx.ds["omega"].values, dtype=np.float64) * f
    # |ω| wide and light under the components: a component that is |ω| shows on it
    norm = np.linalg.norm(w, axis=1)
    drawn = set()
    drawn.add(series(ax, ctx.t, norm, "band", lw=4.5, color="0.6", alpha=0.55, label="|ω|",
                     solid_capstyle="butt", zorder=1.8))  # fmt: skip
    fast = any(windows(ctx.t, w[:, k]) is not None for k in range(3))
    for k, c in enumerate("xyz"):  # a fast tumble: each axis's amplitude per window
        name = f"|ω{c}|" if fast else f"ω{c}"
        drawn.add(series(ax, ctx.t, w[:, k], "amplitude", fast, lw=1.1, color=_AXIS_COLORS[k],
                         label=name, zorder=2))  # fmt: skip
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_ylabel(f"ω, body axes [{unit}]")
    _legend(ax)
    if "amplitude" in drawn:
        ax.get_legend().set_title(f"per {window_text(ctx.t_seconds, ctx.axis)}", prop={"size": 8})


@register_panel("rates_relative", needs=("omega", "reference"))
def rates_relative(ax: Any, ctx: PlotContext) -> None:
    """Body rates relative to the reference frame, from the error quaternion's derivative
    (centred differences at the plotted times): ω_BR = 2 vec(q̃_BR∘q̇_BR)."""
    from ..quaternion import conjugate, multiply

    e = ctx.error_quaternion.copy()
    flips = np.concatenate([[1.0], np.sign(np.sum(e[1:] * e[:-1], axis=1))])
    e *= np.cumprod(np.where(flips == 0, 1.0, flips))[:, None]  # a sign-continuous q_BR
    de = np.gradient(e, ctx.t_seconds, axis=0)
    w = 2.0 * multiply(conjugate(e), de)[:, 1:]
    f, unit = ctx.rate_scale
    w = w * f
    for k, c in enumerate("xyz"):
        ax.plot(ctx.t, w[:, k], lw=1.0, color=_AXIS_COLORS[k], label=f"ω_BR {c}")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_ylabel(f"ω rel. frame [{unit}]")
    _legend(ax)


@register_panel("energy", needs=("energy",))
def energy(ax: Any, ctx: PlotContext) -> None:
    """Energies: H = T + U and T on the left axis (H solid, T dashed over it, so both show
    where U is small), U on its own axis at the right when it is below 5 % of T."""
    ds = ctx.ds
    H = np.asarray(ds["energy"].values, dtype=np.float64)
    U = np.asarray(ds["potential_energy"].values, dtype=np.float64)
    T = H - U
    unit = label(str(ds["energy"].attrs.get("units", "")))
    series(ax, ctx.t, H, "band", color="k", lw=2.2, label="H = T + U")
    series(ax, ctx.t, T, "mean", color="tab:purple", lw=1.1, ls=(0, (4, 2)), label="T (kinetic)")
    small = np.nanmax(np.abs(U)) < 0.05 * max(np.nanmax(np.abs(T)), np.finfo(float).tiny)
    if small and np.any(U != 0):
        bx = ax.twinx()
        series(bx, ctx.t, U, "band", color="tab:gray", lw=1.0, label="U (right axis)")
        bx.set_ylabel(f"U{unit}", color="tab:gray")
        bx.tick_params(axis="y", colors="tab:gray", labelsize=8)
        bx.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        lines = ax.get_lines() + bx.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], loc="upper left",
                  bbox_to_anchor=(1.07, 1.0), fontsize=8, framealpha=0.9,
                  borderaxespad=0.0)  # fmt: skip
    else:
        if np.any(U != 0):
            series(ax, ctx.t, U, "band", color="tab:gray", lw=1.0, label="U")
        _legend(ax)
    ax.set_ylabel(f"energy{unit}")
    ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))


@register_panel("torque", needs=("torque",))
def torque(ax: Any, ctx: PlotContext) -> None:
    """|τ| of every model term, log scale (the total drawn wide and light, under the terms)."""
    from ._torques import MODEL_COLORS, model_labels

    ds = ctx.ds
    mag = np.sqrt(np.sum(np.asarray(ds["torque"].values, dtype=np.float64) ** 2, axis=-1))
    names = model_labels(ds)
    cycle = iter(("tab:cyan", "tab:olive", "tab:pink", "tab:brown"))
    positive = mag[mag > 0]
    floor = float(positive.min()) if positive.size else 1e-30
    for j, name in enumerate(names):
        y = np.maximum(mag[:, j], floor)
        if name == "total":
            if len(names) > 2:
                series(ax, ctx.t, y, "rms", color="0.6", lw=4.0, alpha=0.45, label="total",
                       zorder=1)  # fmt: skip
            continue
        c = MODEL_COLORS.get(name) or next(cycle, "k")
        series(ax, ctx.t, y, "rms", color=c, lw=1.0, label=name, zorder=2)
    ax.set_yscale("log")
    ax.set_ylabel(f"|τ|{label(str(ds['torque'].attrs.get('units', '')))}")
    _legend(ax)


@register_panel("orbit", needs=("position",))
def orbit(ax: Any, ctx: PlotContext) -> None:
    """A run that propagated its orbit: the height above the WGS 84 ellipsoid (thin) and, thick,
    the energy semi-major axis above the equator (:func:`orbit.j2.energy_semi_major_axis`: the
    decay or the raise at every sample; files without the field's constants: the height's mean
    over each orbital period), the mass on the right when it changes."""
    from orbit import earth_mu
    from orbit.frames import gcrs_to_itrs, geodetic_from_itrs

    ds = ctx.ds
    r = np.asarray(ds["position"].values, dtype=np.float64) * 1e-3
    epoch = ds.attrs.get("epoch")
    if epoch:
        from astropy.time import Time, TimeDelta

        times = Time(str(epoch).rstrip("Z"), scale="utc") + TimeDelta(ctx.t_seconds, format="sec")
        h = geodetic_from_itrs(gcrs_to_itrs(times, r))[2]
    else:
        h = np.linalg.norm(r, axis=1) - 6378.137
    series(ax, ctx.t, h, "band", color="tab:blue", lw=0.6, alpha=0.6, label="height")
    v = np.asarray(ds["velocity"].values, dtype=np.float64) * 1e-3
    rn = np.linalg.norm(r, axis=1)
    mu = earth_mu()
    a = 1.0 / (2.0 / rn - np.sum(v * v, axis=1) / mu)  # km: two-body osculating
    period = 2.0 * np.pi * np.sqrt(np.abs(a) ** 3 / mu)
    ts = ctx.t_seconds
    from ..results import energy_semi_major_axis

    # the energy semi-major axis above the equator: constant in the field's point mass and J2,
    # it moves with thrust and drag alone, at every sample (docs/cli.md, info)
    a_e = energy_semi_major_axis(ds.attrs, r, v)
    if a_e is not None:
        ax.plot(ctx.t, a_e - 6378.137, color="tab:blue", lw=2.0,
                label="energy semi-major axis - 6378 km")  # fmt: skip
    elif ts.size > 2 and ts[-1] - ts[0] > float(np.median(period)):
        half = 0.5 * float(np.median(period))
        lo = np.searchsorted(ts, ts - half)
        hi = np.searchsorted(ts, ts + half)
        csum = np.concatenate([[0.0], np.cumsum(h)])
        mean = (csum[hi] - csum[lo]) / np.maximum(hi - lo, 1)
        inside = (ts - half >= ts[0]) & (ts + half <= ts[-1])
        ax.plot(ctx.t[inside], mean[inside], color="tab:blue", lw=2.0, label="mean over an orbit")
    ax.set_ylabel("height [km]")
    if "mass" in ds and float(np.ptp(ds["mass"].values)) > 0.0:
        bx = ax.twinx()
        bx.plot(ctx.t, ds["mass"].values, color="tab:red", lw=1.2, label="mass")
        bx.set_ylabel("mass [kg]", color="tab:red")
        lines = ax.get_lines() + bx.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], loc="upper left",
                  bbox_to_anchor=(1.07, 1.0), fontsize=8, framealpha=0.9,
                  borderaxespad=0.0)  # fmt: skip
    else:
        _legend(ax)


#: The panels of the engineer's figure when none are asked for, in order: those the run has
#: what they need for.
DEFAULT_PANELS = ("pointing", "angles", "rates")
#: ... and for a body that does not hold the reference (:attr:`PlotContext.tumbling`): its
#: roll/pitch/yaw are noise; its energy and torques say what happens to the tumble.
TUMBLING_PANELS = ("pointing", "rates", "energy", "torque")


def default_panels(ctx: PlotContext) -> list[str]:
    """The panels drawn when none are asked for (a run with actuators or flight software
    gets the closed-loop ones instead: ``_closed_loop.closed_loop_defaults``)."""
    names = TUMBLING_PANELS if ctx.tumbling else DEFAULT_PANELS
    out = [p for p in names if available(ctx, p)]
    if "torque" in out and ctx.ds.sizes.get("model", 0) < 3:  # one term and its total
        out.remove("torque")
    if available(ctx, "orbit"):  # the run propagated its orbit
        out.append("orbit")
    return out

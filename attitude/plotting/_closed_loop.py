"""The closed-loop panels of the engineer's figure: the flight software's attitude error, the
actuators (wheel speeds in rpm with their limits and saturation, motor torques, dipoles,
thrust, each with its limit) and the estimator (estimation error inside its ±3σ bounds, the
gyro bias estimate against the truth).

They are registered like the others (:func:`attitude.plotting.register_panel`) and chosen by
:func:`closed_loop_defaults` when the run holds their variables (docs/results.md,
docs/actuators.md, docs/flight_software.md, docs/sensors.md). Variables on ``time`` are read
at the figure's (decimated) samples, those on ``tick`` at every tick (a stride of them on very
long runs, :data:`attitude.plotting.MAX_POINTS` at most).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from .._pointing_stats import guided_modes
from ._common import series
from ._panels import _AXIS_COLORS, PlotContext, _legend, available, register_panel

#: Colours of the actuators of one kind (wheel 1, 2, ...; cycled).
ACTUATOR_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:cyan")
#: Colour of limit lines.
LIMIT_COLOR = "tab:red"
#: Background colours of the flight-software modes (cycled).
MODE_COLORS = ("tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:olive", "tab:cyan")
MODE_ALPHA = 0.10
#: Data staying below this fraction of their limit leave the limit off the scale (said in the
#: panel's title instead: the data would be a flat line at the limits' scale).
LIMIT_OFF_SCALE = 0.05
#: A positive series spanning more than this ratio is drawn on a log scale.
LOG_SPAN = 30.0
#: The most decades a log axis shows below its top: a run starting exactly on its reference
#: has an error of 1e-17 at t = 0, which would stretch the axis over 15 decades of nothing.
MAX_DECADES = 8

#: The closed-loop panels, in the figure's order.
CLOSED_LOOP_PANELS = (
    "control_error",
    "rate_norm",
    "wheel_speeds",
    "wheel_torque",
    "dipoles",
    "thrust",
    "estimation",
    "gyro_bias",
)


# ------------------------------------------------------------------------------------------------
# What the panels share


def is_closed_loop(ds: xr.Dataset) -> bool:
    """Whether the run has actuators or flight software (its figure is the engineer's)."""
    return any(d in ds.dims for d in ("tick", "wheel", "magnetorquer", "thruster"))


def _factor(units: str, target: str) -> float | None:
    """The factor from ``units`` to ``target`` (angles as dimensionless), None for ``"1"``."""
    if units in ("", "1"):
        return None
    from astropy import units as u

    return float(u.Unit(units).to(target, equivalencies=u.dimensionless_angles()))


def _units(ds: xr.Dataset, name: str) -> str:
    return str(ds[name].attrs.get("units", "1"))


def _scaled(peak: float, base: str) -> tuple[float, str]:
    """(factor, unit) showing SI values of ``base`` (``"N m"``, ``"N"``) with a prefix that puts
    ``peak`` between 0.1 and 100: N m, mN m or µN m."""
    if not np.isfinite(peak) or peak >= 0.1:
        return 1.0, base
    if peak >= 1e-4:
        return 1e3, f"m{base}"
    return 1e6, f"µ{base}"


def _scale_of(values: Any, limits: np.ndarray, si: float | None, base: str) -> tuple[float, str]:
    """(factor, unit) of a panel of SI ``base`` values with their limits: the prefix that suits
    the limits when they are in view, else the data (:func:`_limit_lines`)."""
    if si is None:
        return 1.0, f"{base} (run units)".replace("N m", "torque").replace("N (", "force (")
    peak = _robust_peak(np.asarray(values, dtype=np.float64)) * si
    fin = limits[np.isfinite(limits) & (limits > 0)] * si
    if fin.size and peak >= LIMIT_OFF_SCALE * float(fin.min()):
        peak = max(peak, float(fin.max()))
    f, unit = _scaled(peak, base)
    return f * si, unit


def tick_values(ctx: PlotContext, name: str) -> np.ndarray:
    """A ``tick`` variable at the plotted ticks (:attr:`PlotContext.tick_index`), float64."""
    return np.asarray(ctx.ds[name].values[ctx.tick_index], dtype=np.float64)


def _labels(ds: xr.Dataset, dim: str, prefix: str) -> list[str]:
    name = f"{dim}_label"
    if name in ds.variables:
        return [str(x) for x in ds[name].values]
    return [f"{prefix}{k + 1}" for k in range(ds.sizes[dim])]


def mode_spans(ds: xr.Dataset) -> list[tuple[float, float, int]]:
    """The intervals of the software's modes: (start [s], end [s], mode), from every recorded
    tick (the mode switches where the tick after the last of a mode starts)."""
    if "mode" not in ds or ds.sizes.get("tick", 0) == 0:
        return []
    from ..results import time_values

    t = time_values(ds, "tick")
    mode = np.asarray(ds["mode"].values, dtype=np.int64)
    cut = np.flatnonzero(np.diff(mode)) + 1
    starts = np.concatenate([[0], cut])
    ends = np.concatenate([cut, [mode.size]])
    t_end = max(float(t[-1]), float(time_values(ds)[-1]))
    return [
        (float(t[a]), float(t[b]) if b < mode.size else t_end, int(mode[a]))
        for a, b in zip(starts, ends, strict=True)
    ]


def mark_modes(axes: list, ds: xr.Dataset, axis: Any) -> bool:
    """The flight-software modes, when the run switched between some: coloured bands named at
    their start on the top panel, dashed lines at the switches on every panel. True when
    drawn."""
    spans = mode_spans(ds)
    if len({m for _, _, m in spans}) < 2:
        return False
    names = str(ds["mode"].attrs.get("flag_meanings", "")).split()
    top = axes[0]
    for i, (a, b, m) in enumerate(spans):
        color = MODE_COLORS[m % len(MODE_COLORS)]
        top.axvspan(a / axis.scale, b / axis.scale, color=color, alpha=MODE_ALPHA, lw=0, zorder=0)
        name = names[m] if m < len(names) else f"mode{m}"
        top.annotate(name, (a / axis.scale, 0.0), xycoords=("data", "axes fraction"),
                     xytext=(3, 3 + 11 * (i % 2)), textcoords="offset points", fontsize=8,
                     color=color, fontweight="bold")  # fmt: skip
    for ax in axes:
        for a, _, _ in spans[1:]:
            ax.axvline(a / axis.scale, color="0.3", lw=0.9, ls="--", zorder=1.5)
    return True


def _log_if_spanning(ax: Any, y: np.ndarray) -> bool:
    """A log y scale when the positive values span more than :data:`LOG_SPAN`."""
    pos = y[np.isfinite(y) & (y > 0)]
    if pos.size and float(pos.max()) > LOG_SPAN * float(pos.min()):
        ax.set_yscale("log")
        lo, hi = np.floor(np.log10(pos.min())), np.ceil(np.log10(pos.max()))
        lo = max(lo, hi - MAX_DECADES)  # (values below: off the bottom edge)
        ax.set_ylim(10.0**lo, 10.0**hi)  # whole decades: both ends labelled
        return True
    return False


def _nice(x: float, unit: str, digits: int = 4) -> str:
    """``x`` in ``unit`` as text, a prefix up where it reaches 1000 (5000 µN m: 5 mN m)."""
    for small, big in (("µN", "mN"), ("mN", "N")):
        if unit.startswith(small) and abs(x) >= 1000.0:
            x, unit = x / 1000.0, big + unit[len(small) :]
    return f"{x:.{digits}g} {unit}"


def _robust_peak(y: np.ndarray) -> float:
    """The 99.5th percentile of |y|: the level most of a run stays within (a short initial
    transient above it)."""
    a = np.abs(y[np.isfinite(y)])
    return float(np.percentile(a, 99.5)) if a.size else 0.0


def _limit_lines(ax: Any, y: np.ndarray, limits: np.ndarray, unit: str, what: str) -> str:
    """Dashed lines at ±limit (each distinct finite limit), in view unless the data stay
    (:func:`_robust_peak`) below :data:`LIMIT_OFF_SCALE` of it: then the limit is said in the
    title and the scale is the data's (a transient above it too). Returns the title note."""
    lim = np.unique(np.abs(limits[np.isfinite(limits) & (limits > 0)]))
    if lim.size == 0:
        return ""
    peak = _robust_peak(y)
    if peak < LIMIT_OFF_SCALE * float(lim.min()):
        vals = ", ".join(_nice(x, unit) for x in lim)
        top = float(np.nanmax(np.abs(y))) if y.size else 0.0
        note = f"{what} ±{vals} off scale: max {_nice(top, unit, 3)} = {top / lim.max():.1%}"
        if top > 1.5 * peak and peak > 0:
            ax.set_ylim(-1.3 * peak, 1.3 * peak)
            note += "; start off scale"
        return note
    for j, x in enumerate(lim):
        lab = f"{what} ±{x:.4g} {unit}" if j == 0 else None
        ax.axhline(x, color=LIMIT_COLOR, lw=1.1, ls="--", label=lab, zorder=1.8)
        ax.axhline(-x, color=LIMIT_COLOR, lw=1.1, ls="--", zorder=1.8)
    return ""


def _ticks_said(ds: xr.Dataset) -> str:
    """ "every tick", or how many of the run's ticks were recorded (the default: those in
    effect at the output samples)."""
    n, total = ds.sizes.get("tick", 0), ds.attrs.get("n_ticks")
    if total is None or n >= int(total):
        return "every tick"
    return f"at {n} of its {int(total)} ticks"


def _title(ax: Any, text: str, note: str = "") -> None:
    ax.set_title(f"{text}{f'   [{note}]' if note else ''}", fontsize=10, loc="left")


def _per_actuator(
    ax: Any,
    ctx: PlotContext,
    applied: str,
    command: str | None,
    dim: str,
    prefix: str,
    factor: float,
) -> np.ndarray:
    """Applied values per actuator (solid), the command (dotted, same colour) where it differs
    (a limit cut it); returns the applied values as drawn."""
    ds = ctx.ds
    y = np.asarray(ds[applied].values, dtype=np.float64) * factor
    c = None
    if command is not None and command in ds:
        c = np.asarray(ds[command].values, dtype=np.float64) * factor
    for k, name in enumerate(_labels(ds, dim, prefix)):
        color = ACTUATOR_COLORS[k % len(ACTUATOR_COLORS)]
        series(ax, ctx.t, y[:, k], "band", color=color, lw=1.2, label=name, zorder=2)
        if c is not None and not np.allclose(c[:, k], y[:, k], rtol=1e-12, atol=0.0):
            ax.plot(ctx.t, c[:, k], color=color, lw=0.9, ls=":", zorder=2.1)
    ax.axhline(0.0, color="0.5", lw=0.6)
    return y


# ------------------------------------------------------------------------------------------------
# The panels


def _error_deg(ctx: PlotContext) -> np.ndarray:
    """The software's attitude error angle at the plotted ticks, deg; NaN in modes without a
    guidance."""
    f = _factor(_units(ctx.ds, "error_angle"), "deg") or float(np.degrees(1.0))
    err = tick_values(ctx, "error_angle") * f
    guided = guided_modes(ctx.ds)
    if "mode" in ctx.ds and not guided.all():
        mode = np.asarray(ctx.ds["mode"].values[ctx.tick_index], dtype=np.int64)
        ok = guided[np.clip(mode, 0, guided.size - 1)]
        err = np.where(ok, err, np.nan)
    return err


def _true_error_deg(ctx: PlotContext) -> np.ndarray | None:
    """With an estimator, the true attitude error at the ticks: the reference against the
    truth, which is the estimate rotated by the estimation error's first three (body axes)."""
    ds = ctx.ds
    if not {"estimate_q", "estimation_error", "reference_q"} <= set(ds.variables):
        return None
    from ..quaternion import conjugate, from_rotation_vector, multiply

    qe = tick_values(ctx, "estimate_q")
    dth = tick_values(ctx, "estimation_error")[:, :3]
    qt = multiply(qe, from_rotation_vector(dth))
    e = multiply(conjugate(tick_values(ctx, "reference_q")), qt)
    ang = np.degrees(2.0 * np.arctan2(np.linalg.norm(e[:, 1:], axis=1), np.abs(e[:, 0])))
    return np.where(np.isnan(_error_deg(ctx)), np.nan, ang)


@register_panel("control_error", needs=("error_angle", "tick"))
def control_error(ax: Any, ctx: PlotContext) -> None:
    """The attitude error the flight software controls (the angle of σ_BR's rotation, every
    tick), log scale when it spans decades; with an estimator the true error beside the one
    the software sees."""
    t = ctx.axis.values(ctx.tick_seconds)
    err = _error_deg(ctx)
    true = _true_error_deg(ctx)
    seen = "as the software sees it (estimate)" if true is not None else "error angle"
    series(ax, t, err, "band", color="k", lw=1.3, label=seen, zorder=2)
    if true is not None:
        series(ax, t, true, "band", color="tab:red", lw=1.0, label="true", zorder=2.2)
    logged = _log_if_spanning(ax, err if true is None else np.concatenate([err, true]))
    if not logged:
        ax.set_ylim(bottom=0.0)
    ax.set_ylabel("attitude error [deg]")
    guided = guided_modes(ctx.ds)
    note = "" if guided.all() else "modes without guidance left out"
    _title(ax, f"attitude error from the guidance's reference, {_ticks_said(ctx.ds)}"
           f"{' (log scale)' if logged else ''}", note)  # fmt: skip
    _legend(ax)


@register_panel("rate_norm", needs=("omega",))
def rate_norm(ax: Any, ctx: PlotContext) -> None:
    """|ω| in deg/s (log scale when it spans decades), with the orbital rate n for reference
    on a run with an orbit (B-dot leaves the body near 2n)."""
    f, unit = ctx.rate_scale
    w = np.linalg.norm(np.asarray(ctx.ds["omega"].values, dtype=np.float64), axis=1) * f
    series(ax, ctx.t, w, "band", color="k", lw=1.3, label="|ω|", zorder=2)
    refs = []
    if "r" in ctx.ds and unit == "deg/s" and _units(ctx.ds, "r") == "km":
        from orbit.keplerorbit import EARTH_MU

        r = float(np.nanmean(ctx.ds["r"].values))
        n = float(np.degrees(np.sqrt(EARTH_MU / r**3)))
        ax.axhline(n, color="tab:blue", lw=1.0, ls=":", label=f"orbital rate n = {n:.3g} deg/s")
        ax.axhline(2 * n, color="tab:blue", lw=1.0, ls="--", label="2n")
        refs = [n, 2 * n]
    logged = _log_if_spanning(ax, np.concatenate([w, refs]))  # n in view
    if not logged:
        ax.set_ylim(bottom=0.0)
    ax.set_ylabel(f"|ω| [{unit}]")
    _title(ax, f"body rate magnitude{' (log scale)' if logged else ''}")
    _legend(ax)


def _per_axis_ticks(ax: Any, ctx: PlotContext, name: str, f: float, label: str) -> np.ndarray:
    """A (tick, axis) variable times ``f``, one line per body axis."""
    y = tick_values(ctx, name) * f
    t = ctx.axis.values(ctx.tick_seconds)
    for k, c in enumerate("xyz"):
        series(ax, t, y[:, k], "band", color=_AXIS_COLORS[k], lw=1.1, label=f"{label} {c}")
    ax.axhline(0.0, color="0.5", lw=0.6)
    return y


@register_panel("rate_error", needs=("rate_error", "tick"))
def rate_error(ax: Any, ctx: PlotContext) -> None:
    """The rate error ω − ω_r the software sees (body axes, every tick), deg/s."""
    f = _factor(_units(ctx.ds, "rate_error"), "deg/s")
    _per_axis_ticks(ax, ctx, "rate_error", 1.0 if f is None else f, "δω")
    ax.set_ylabel(f"rate error [{'deg/s' if f is not None else 'rad per time unit'}]")
    _title(ax, f"rate error ω − ω_r, body axes, {_ticks_said(ctx.ds)}")
    _legend(ax)


@register_panel("torque_request", needs=("torque_request", "tick"))
def torque_request(ax: Any, ctx: PlotContext) -> None:
    """The control law's torque request (body axes, every tick), N m, mN m or µN m."""
    si = _factor(_units(ctx.ds, "torque_request"), "N m")
    f, unit = _scale_of(ctx.ds["torque_request"].values, np.array([np.inf]), si, "N m")
    _per_axis_ticks(ax, ctx, "torque_request", f, "L")
    ax.set_ylabel(f"torque request [{unit}]")
    _title(ax, f"control torque requested by the law, body axes, {_ticks_said(ctx.ds)}")
    _legend(ax)


@register_panel("wheel_speeds", needs=("wheel_speed",))
def wheel_speeds(ax: Any, ctx: PlotContext) -> None:
    """Wheel speeds relative to the body in rpm, the speed limits (dashed red) and bars at the
    top where a wheel is at a limit (light: torque, dark: speed)."""
    ds = ctx.ds
    f = _factor(_units(ds, "wheel_speed"), "cycle/min")
    unit = "rpm" if f is not None else "rad per time unit"
    f = 1.0 if f is None else f
    y = np.asarray(ds["wheel_speed"].values, dtype=np.float64) * f
    names = _labels(ds, "wheel", "wheel")
    for k, name in enumerate(names):
        color = ACTUATOR_COLORS[k % len(ACTUATOR_COLORS)]
        series(ax, ctx.t, y[:, k], "band", color=color, lw=1.2, label=name, zorder=2)
    ax.axhline(0.0, color="0.5", lw=0.6)
    note = ""
    if "wheel_max_speed" in ds:
        lim = np.asarray(ds["wheel_max_speed"].values, dtype=np.float64) * f
        note = _limit_lines(ax, y, lim, unit, "speed limit")
    marked = _saturation_bars(ax, ctx, names)
    ax.set_ylabel(f"wheel speed [{unit}]")
    if marked:
        note = "; ".join(x for x in (note, "bars: " + marked) if x)
    _title(ax, "reaction wheel speeds", note)
    _legend(ax)


def _saturation_bars(ax: Any, ctx: PlotContext, names: list[str]) -> str:
    """Bars along the top of the panel, one row per wheel, over the samples where it is at a
    limit (``wheel_limit`` flags: torque light, speed and others dark); edges half-way between
    samples. Returns what was marked, for the title."""
    if "wheel_limit" not in ctx.ds:
        return ""
    import matplotlib.transforms as mtransforms

    flags = np.asarray(ctx.ds["wheel_limit"].values, dtype=np.int64)
    t = ctx.t
    if t.size < 2 or not flags.any():
        return ""
    mid = np.concatenate([[t[0]], 0.5 * (t[1:] + t[:-1]), [t[-1]]])
    trans = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    h = min(0.05, 0.25 / max(1, len(names)))
    kinds = set()
    for k, _name in enumerate(names):
        color = ACTUATOR_COLORS[k % len(ACTUATOR_COLORS)]
        for bit, alpha in ((1, 0.45), (~1, 1.0)):
            on = (flags[:, k] & bit) != 0
            if not on.any():
                continue
            kinds.add("torque" if bit == 1 else "speed")
            change = np.flatnonzero(np.diff(on.astype(np.int8))) + 1
            starts = np.concatenate([[0], change])
            stops = np.concatenate([change, [on.size]])
            spans = [(mid[a], mid[b] - mid[a]) for a, b in zip(starts, stops, strict=True) if on[a]]
            ax.broken_barh(spans, (1.0 - (k + 1) * h, h * 0.85), transform=trans, color=color,
                           alpha=alpha, lw=0, zorder=3)  # fmt: skip
    return " and ".join(f"at the {x} limit" for x in sorted(kinds, reverse=True))


@register_panel("wheel_torque", needs=("wheel_torque",))
def wheel_torque(ax: Any, ctx: PlotContext) -> None:
    """Applied motor torque per wheel (solid; the command dotted where a limit cut it) and the
    torque limits (dashed red), in N m, mN m or µN m."""
    ds = ctx.ds
    si = _factor(_units(ds, "wheel_torque"), "N m")
    lim = np.asarray(ds["wheel_max_torque"].values, dtype=np.float64) if "wheel_max_torque" in ds \
        else np.array([np.inf])  # fmt: skip
    f, unit = _scale_of(ds["wheel_torque"].values, lim, si, "N m")
    y = _per_actuator(ax, ctx, "wheel_torque", "wheel_torque_command", "wheel", "wheel", f)
    note = _limit_lines(ax, y, lim * f, unit, "torque limit")
    ax.set_ylabel(f"motor torque [{unit}]")
    _title(ax, "wheel motor torque (applied; dotted: commanded)", note)
    _legend(ax)


@register_panel("dipoles", needs=("dipole",))
def dipoles(ax: Any, ctx: PlotContext) -> None:
    """Applied magnetorquer dipoles (solid; the command dotted where the limit cut it) and the
    limits ±max (dashed red), A m²."""
    ds = ctx.ds
    unit = _units(ds, "dipole")
    y = _per_actuator(ax, ctx, "dipole", "dipole_command", "magnetorquer", "rod", 1.0)
    note = ""
    if "magnetorquer_max_dipole" in ds:
        lim = np.asarray(ds["magnetorquer_max_dipole"].values, dtype=np.float64)
        note = _limit_lines(ax, y, lim, unit.replace("^2", "²"), "dipole limit")
    ax.set_ylabel(f"dipole [{unit.replace('^2', '²')}]")
    _title(ax, "magnetorquer dipoles (applied; dotted: commanded)", note)
    _legend(ax)


@register_panel("thrust", needs=("thruster_force",))
def thrust(ax: Any, ctx: PlotContext) -> None:
    """Thrust per thruster at the samples (0 when not firing) and each one's thrust when
    firing (dashed red), in N, mN or µN."""
    ds = ctx.ds
    si = _factor(_units(ds, "thruster_force"), "N")
    lim = np.asarray(ds["thruster_max_thrust"].values, dtype=np.float64) \
        if "thruster_max_thrust" in ds else np.array([np.inf])  # fmt: skip
    f, unit = _scale_of(ds["thruster_force"].values, lim, si, "N")
    ds_y = np.asarray(ds["thruster_force"].values, dtype=np.float64) * f
    for k, name in enumerate(_labels(ds, "thruster", "thruster")):
        color = ACTUATOR_COLORS[k % len(ACTUATOR_COLORS)]
        ax.plot(ctx.t, ds_y[:, k], color=color, lw=1.1, drawstyle="steps-post", label=name)
    lims = np.unique(lim[np.isfinite(lim)] * f)
    for j, x in enumerate(lims):
        ax.axhline(x, color=LIMIT_COLOR, lw=1.1, ls="--", zorder=1.8,
                   label=f"max thrust {x:.4g} {unit}" if j == 0 else None)  # fmt: skip
    ax.set_ylim(bottom=0.0)
    ax.set_ylabel(f"thrust [{unit}]")
    _title(ax, "thruster forces at the samples")
    _legend(ax)


def _angle_unit(sig3_rad: np.ndarray) -> tuple[float, str]:
    """arcsec when the converged 3σ is below 0.1 deg, else deg."""
    med = float(np.nanmedian(sig3_rad)) if np.isfinite(sig3_rad).any() else 1.0
    if np.degrees(med) < 0.1:
        return float(np.degrees(1.0) * 3600.0), "arcsec"
    return float(np.degrees(1.0)), "deg"


def _focus(ax: Any, values: np.ndarray, bounds: np.ndarray) -> bool:
    """Symmetric y limits on the converged bounds (their 90th percentile) and most errors, so a
    large initial transient does not flatten the rest; True when something is off scale."""
    b = bounds[np.isfinite(bounds)]
    v = np.abs(values[np.isfinite(values)])
    if not b.size:
        return False
    lim = 1.3 * max(float(np.percentile(b, 90)), float(np.percentile(v, 99)) if v.size else 0.0)
    if not lim > 0:
        return False
    ax.set_ylim(-lim, lim)
    return bool(b.max() > lim or (v.size and v.max() > lim))


def _percent_floor(p: float) -> str:
    """A fraction as a percentage with one decimal, rounded *down*: 0.9997 is "99.9%", never
    "100%" (which only 1 is: every tick inside); NaN is "n/a"."""
    if not math.isfinite(p):
        return "n/a"
    if p >= 1.0:
        return "100%"
    tenths = min(math.floor(p * 1000.0 * (1.0 + 1e-12)), 999)  # (1e-12: 0.997 is 99.7)
    return f"{tenths / 10:.1f}%"


@register_panel("estimation", needs=("estimation_error", "estimation_sigma"))
def estimation(ax: Any, ctx: PlotContext) -> None:
    """The estimator's attitude error (truth against estimate, body axes) per axis, inside its
    ±3σ bounds (3 sqrt(diag P), dashed, same colour), in arcsec or deg; the title says which
    fraction of the ticks lies inside (≈ 99 % for a consistent filter)."""
    units = (
        [str(x) for x in ctx.ds["error_state_units"].values]
        if "error_state_units" in ctx.ds.variables
        else ["rad"] * 3
    )
    to_rad = np.array([_factor(u, "rad") or 1.0 for u in units[:3]])
    err = tick_values(ctx, "estimation_error")[:, :3] * to_rad
    sig3 = 3.0 * tick_values(ctx, "estimation_sigma")[:, :3] * to_rad
    f, unit = _angle_unit(sig3)
    err, sig3 = err * f, sig3 * f
    t = ctx.axis.values(ctx.tick_seconds)
    inside = []
    for k, c in enumerate("xyz"):
        color = _AXIS_COLORS[k]
        series(ax, t, err[:, k], "band", color=color, lw=1.0, label=f"δθ {c}", zorder=2)
        ax.plot(t, sig3[:, k], color=color, lw=0.9, ls="--", zorder=2.1,
                label="±3σ (dashed)" if k == 2 else None)  # fmt: skip
        ax.plot(t, -sig3[:, k], color=color, lw=0.9, ls="--", zorder=2.1)
        ok = np.isfinite(err[:, k]) & np.isfinite(sig3[:, k])
        inside.append(float(np.mean(np.abs(err[ok, k]) <= sig3[ok, k])) if ok.any() else np.nan)
    ax.axhline(0.0, color="0.5", lw=0.6)
    off = _focus(ax, err, sig3)
    out = _tracker_outages(ax, ctx)
    ax.set_ylabel(f"estimation error [{unit}]")
    frac = ", ".join(f"{c} {_percent_floor(p)}" for c, p in zip("xyz", inside, strict=True))
    notes = [n for n in ("start off scale" if off else "", out) if n]
    _title(ax, f"attitude estimation error in ±3σ (inside: {frac})", "; ".join(notes))
    _legend(ax)


#: ``star_tracker_status`` values of an outage (no measurement although one was due): the Sun
#: or the Earth in the exclusion cone. ``no_update`` (1) is a tracker slower than the ticks.
TRACKER_OUT = (2, 3)
#: Colour of the star tracker's outages on the estimation panel.
OUTAGE_COLOR = "tab:orange"


def outage_spans(ds: xr.Dataset) -> list[tuple[float, float]]:
    """The star tracker's outages: (start, end) in s of each run of recorded ticks whose
    ``star_tracker_status`` is an exclusion (:data:`TRACKER_OUT`), to the next recorded tick."""
    if "star_tracker_status" not in ds.variables or ds.sizes.get("tick", 0) == 0:
        return []
    from ..results import time_values

    t = time_values(ds, "tick")
    out = np.isin(np.asarray(ds["star_tracker_status"].values), TRACKER_OUT)
    edges = np.diff(np.concatenate([[0], out.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    return [
        (float(t[a]), float(t[b]) if b < t.size else float(t[-1]) + step)
        for a, b in zip(starts, ends, strict=True)
    ]


def _tracker_outages(ax: Any, ctx: PlotContext) -> str:
    """Bands where the star tracker gave no measurement (Sun or Earth exclusion); the title's
    note (share of the ticks), or "" when it never was out."""
    spans = outage_spans(ctx.ds)
    if not spans:
        return ""
    s = ctx.axis.scale
    for i, (a, b) in enumerate(spans):
        ax.axvspan(a / s, b / s, color=OUTAGE_COLOR, alpha=0.18, lw=0, zorder=0.5,
                   label="star tracker out" if i == 0 else None)  # fmt: skip
    status = np.asarray(ctx.ds["star_tracker_status"].values)
    share = float(np.mean(np.isin(status, TRACKER_OUT)))
    return f"orange: star tracker out, {share:.0%} of the ticks"


@register_panel("gyro_bias", needs=("bias_estimate",))
def gyro_bias(ax: Any, ctx: PlotContext) -> None:
    """The gyro bias estimate per axis (solid, ±3σ band) and the true bias (dashed: the
    estimate plus the estimation error's last three), deg/h."""
    ds = ctx.ds
    f = _factor(_units(ds, "bias_estimate"), "deg/h")
    unit = "deg/h" if f is not None else "rad per time unit"
    f = 1.0 if f is None else f
    est = tick_values(ctx, "bias_estimate") * f
    true = None
    if "estimation_error" in ds:
        true = est + tick_values(ctx, "estimation_error")[:, 3:] * f
    sig3 = 3.0 * tick_values(ctx, "estimation_sigma")[:, 3:] * f if "estimation_sigma" in ds \
        else None  # fmt: skip
    t = ctx.axis.values(ctx.tick_seconds)
    for k, c in enumerate("xyz"):
        color = _AXIS_COLORS[k]
        ax.plot(t, est[:, k], color=color, lw=1.2, label=f"estimate {c}", zorder=2)
        if sig3 is not None:
            ax.fill_between(t, est[:, k] - sig3[:, k], est[:, k] + sig3[:, k], color=color,
                            alpha=0.15, lw=0, zorder=1)  # fmt: skip
        if true is not None:
            ax.plot(t, true[:, k], color=color, lw=1.0, ls="--", zorder=2.1,
                    label="true (dashed)" if k == 2 else None)  # fmt: skip
    if sig3 is not None:  # limits on the converged band
        vals = np.concatenate([est, true if true is not None else est])
        b = np.nanpercentile(sig3, 90)
        lo, hi = float(np.nanmin(vals)) - 1.3 * b, float(np.nanmax(vals)) + 1.3 * b
        if hi > lo:
            ax.set_ylim(lo, hi)
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_ylabel(f"gyro bias [{unit}]")
    _title(ax, "gyro bias: estimate (band ±3σ) and truth")
    _legend(ax)


def closed_loop_defaults(ctx: PlotContext) -> list[str]:
    """The panels of a closed-loop run when none are asked for: the attitude error (a run
    whose software points at something) and |ω| when a mode only damps rates (a detumbling
    mode before the pointing), or |ω| and the rates (software that only damps rates: B-dot),
    then the actuators it has, then the estimator."""
    ds = ctx.ds
    out = []
    guided = guided_modes(ds)
    pointing = available(ctx, "control_error") and bool(guided.any())
    if pointing:
        out.append("control_error")
        if not guided.all():  # what the other modes do: their rates
            out.append("rate_norm")
    else:
        out += ["rate_norm", "rates"]
    out += [p for p in CLOSED_LOOP_PANELS[2:] if available(ctx, p)]
    out.append("orbit")  # a run that propagated its orbit (drawn when it has one)
    return [p for p in out if available(ctx, p)]

"""What every figure shares: the time axis, decimation, saving, event markers, eclipse bars."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

#: Largest number of points drawn per curve (longer runs are decimated by a stride).
MAX_POINTS = 20_000

#: Time units of the axes: (name, seconds, longest span shown in it [s]).
TIME_UNITS = (("s", 1.0, 600.0), ("min", 60.0, 3 * 3600.0), ("h", 3600.0, 3 * 86400.0),
              ("d", 86400.0, np.inf))  # fmt: skip


def pyplot(path: Any) -> Any:
    """matplotlib.pyplot, on the Agg backend when the figure goes to a file."""
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save(fig: Any, path: str | os.PathLike | None, dpi: int) -> Any:
    """Save (creating the directory) and close the figure when a path is given."""
    if path is not None:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=dpi)
        pyplot(path).close(fig)
    return fig


def decimate(ds: xr.Dataset, limit: int = MAX_POINTS) -> xr.Dataset:
    """Every k-th sample, at most ``limit`` of them, the last sample kept (a terminal event)."""
    n = ds.sizes["time"]
    stride = max(1, -(-n // limit))
    if stride == 1:
        return ds
    idx = np.arange(0, n, stride)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return ds.isel(time=idx)


def label(units: str) -> str:
    """`` [units]`` for an axis label, nothing for dimensionless."""
    return "" if units in ("1", "") else f" [{units}]"


@dataclass(frozen=True)
class TimeAxis:
    """The time axis of a figure: seconds since the epoch shown in s, min, h or days."""

    scale: float  # seconds per axis unit
    unit: str  # "s", "min", "h", "d", or "" (dimensionless)
    epoch: str | None

    @classmethod
    def of(cls, ds: xr.Dataset, t_seconds: np.ndarray) -> TimeAxis:
        from ..results import time_unit

        epoch = ds.attrs.get("epoch") or None
        if time_unit(ds["time"]) in ("1", ""):
            return cls(1.0, "", None)
        span = float(t_seconds[-1] - t_seconds[0]) if t_seconds.size else 0.0
        for name, sec, longest in TIME_UNITS:
            if span <= longest:
                return cls(sec, name, epoch)
        return cls(86400.0, "d", epoch)  # pragma: no cover - the last unit has no limit

    def values(self, t_seconds: np.ndarray) -> np.ndarray:
        return np.asarray(t_seconds, dtype=np.float64) / self.scale

    @property
    def text(self) -> str:
        """The axis label: ``t [h] since 2020-02-22 02:00:00 UTC``."""
        if not self.unit:
            return "t (dimensionless)"
        if not self.epoch:
            return f"t [{self.unit}]"
        e = str(self.epoch).rstrip("Z").replace("T", " ")
        if "." in e:
            e = e.rstrip("0").rstrip(".")
        return f"t [{self.unit}] since {e} UTC"


# ------------------------------------------------------------------------------------------------
# Events


@dataclass(frozen=True)
class Event:
    """One occurrence of an event of the run: time [s], name, +1 rising / -1 falling."""

    t: float
    name: str
    direction: int


def run_events(ds: xr.Dataset) -> list[Event]:
    """The events a single run recorded (``event_time`` ...), in time order."""
    if "event_time" not in ds or "detector_label" not in ds.variables:
        return []
    from ..results import time_values

    t = time_values(ds, "event_time")
    which = np.asarray(ds["event_detector"].values, dtype=np.int64)
    sign = np.asarray(ds["event_direction"].values, dtype=np.int64)
    labels = [str(x) for x in ds["detector_label"].values]
    return [Event(float(t[i]), labels[which[i]], int(sign[i])) for i in range(t.size)]


#: Colours of event markers, by detector (cycled).
EVENT_COLORS = ("tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")


def mark_events(axes: list, events: list[Event], axis: TimeAxis, *, names: bool = True) -> None:
    """Vertical lines at the events on every panel; the top panel names them (once per
    detector when they repeat)."""
    if not events:
        return
    colors: dict[str, str] = {}
    for e in events:
        colors.setdefault(e.name, EVENT_COLORS[len(colors) % len(EVENT_COLORS)])
    for ax in axes:
        for e in events:
            ax.axvline(e.t / axis.scale, color=colors[e.name], lw=0.9, ls=":", zorder=1.5)
    if not names:
        return
    top = axes[0]
    lo, hi = top.get_xlim()
    seen: set[str] = set()
    for e in events:
        if e.name in seen and len(events) > 6:
            continue
        seen.add(e.name)
        arrow = "↑" if e.direction > 0 else "↓"
        x = e.t / axis.scale
        # beside the line, inside the panel (a terminal event is the run's last instant)
        right = x > lo + 0.97 * (hi - lo)
        top.annotate(
            f"{e.name} {arrow}", (x, 1.0), xycoords=("data", "axes fraction"),
            xytext=(-2 if right else 2, -2), textcoords="offset points", rotation=90, va="top",
            ha="right" if right else "left", fontsize=7, color=colors[e.name],
        )  # fmt: skip


# ------------------------------------------------------------------------------------------------
# Eclipses


#: Most points at which the shadow is evaluated (a dense grid when the orbit is at hand).
SHADOW_POINTS = 20_000
#: Finest spacing of that grid [s].
SHADOW_STEP = 2.0


def shadow_along(
    ds: xr.Dataset, t_seconds: np.ndarray, orbit: Any = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """The visible fraction of the Sun ν (1 light, 0 umbra) along the run: (times [s], ν), or
    None.

    With ``orbit`` the satellite's position is evaluated on a grid of up to
    :data:`SHADOW_POINTS` times (every :data:`SHADOW_STEP` s at most), so the shadow's edges
    are where they are, not at the output samples; without, from the run's own orbit
    variables at its samples (``r`` and the orbital frame ``p``: r̂ is p's x axis). The Sun
    comes from astropy (:mod:`orbit.sun`) and needs the run's epoch. NaN inside the Earth.
    """
    epoch = ds.attrs.get("epoch")
    if not epoch or t_seconds.size < 2:
        return None
    from orbit.sun import shadow_function, sun_position

    try:
        if orbit is not None:
            span = float(t_seconds[-1] - t_seconds[0])
            n = int(min(SHADOW_POINTS, max(t_seconds.size, span / SHADOW_STEP + 1)))
            tt = np.linspace(float(t_seconds[0]), float(t_seconds[-1]), n)
            r = np.asarray(orbit.position(tt), dtype=np.float64)
        elif "r" in ds and "p" in ds:
            from ..quaternion import rotate

            tt = np.asarray(t_seconds, dtype=np.float64)
            p = np.asarray(ds["p"].values, dtype=np.float64)
            radius = np.asarray(ds["r"].values, dtype=np.float64)
            r = radius[:, None] * rotate(p, np.array([1.0, 0.0, 0.0]))
        else:
            return None
        step = 600.0  # the Sun moves 0.25 deg in 10 min: interpolated between those
        grid = np.arange(tt[0], tt[-1] + step, step)
        sun = sun_position(str(epoch).rstrip("Z"), grid)
        s = np.stack([np.interp(tt, grid, sun[:, k]) for k in range(3)], axis=-1)
        nu = np.asarray(shadow_function(r, s), dtype=np.float64)
    except (ValueError, TypeError):  # no date astropy can use, positions outside a table
        return None
    return tt, np.where(np.linalg.norm(r, axis=-1) < 6378.137, np.nan, nu)


#: Shading of the penumbra and the umbra (grey level alphas).
PENUMBRA_ALPHA, UMBRA_ALPHA = 0.10, 0.22


def shade_eclipses(axes: list, shadow: Any, axis: TimeAxis) -> bool:
    """Grey bars where the satellite is in the Earth's shadow (penumbra light, umbra darker)
    on every panel, edges half-way between the grid points; True when there is some."""
    if shadow is None:
        return False
    tt, nu = shadow
    state = np.where(nu >= 1.0, 0, np.where(nu > 0.0, 1, 2))
    state = np.where(np.isnan(nu), 0, state)
    if not np.any(state):
        return False
    t = axis.values(tt)
    mid = np.concatenate([[t[0]], 0.5 * (t[1:] + t[:-1]), [t[-1]]])
    change = np.flatnonzero(np.diff(state)) + 1
    starts = np.concatenate([[0], change])
    stops = np.concatenate([change, [state.size]])
    for a, b in zip(starts, stops, strict=True):
        if state[a] == 0:
            continue
        alpha = PENUMBRA_ALPHA if state[a] == 1 else UMBRA_ALPHA
        for ax in axes:
            ax.axvspan(mid[a], mid[b], color="0.15", alpha=alpha, lw=0, zorder=0)
    return True


def break_at_wraps(t: np.ndarray, angle_deg: np.ndarray, jump: float = 180.0):
    """(t, angles) with a NaN point inserted where the angles wrap (a jump above ``jump``), so
    a line stops at ±180° instead of crossing the panel."""
    a = np.asarray(angle_deg, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    if a.size < 2:
        return t, a
    cut = np.flatnonzero(np.abs(np.diff(a)) > jump) + 1
    return np.insert(t, cut, np.nan), np.insert(a, cut, np.nan)


#: Above this many plotted samples a fast-oscillating series is drawn by windows.
ENVELOPE_SAMPLES = 2000
#: Windows of a long run (about one per pixel column of a README-sized figure).
ENVELOPE_WINDOWS = 600


def windows(
    t: np.ndarray, y: np.ndarray, force: bool = False
) -> tuple[np.ndarray, np.ndarray] | None:
    """(window times, values (windows, w)) of a long run that oscillates faster than a window
    (a pixel column) shows: a median of two or more turning points per window (a nutation over
    a day), else None. ``force``: the windows of any long run."""
    n = y.size
    if n <= ENVELOPE_SAMPLES:
        return None
    w = n // ENVELOPE_WINDOWS
    m = (n // w) * w
    blocks = y[:m].reshape(-1, w)
    if not force:
        d = np.diff(y[:m])
        turns = np.zeros(m)
        turns[1:-1] = (d[1:] * d[:-1]) < 0
        if float(np.median(turns.reshape(-1, w).sum(axis=1))) < 2:
            return None
    return t[:m].reshape(-1, w).mean(axis=1), blocks


def series(
    ax: Any, t: np.ndarray, y: np.ndarray, style: str = "band", force: bool = False, **kw: Any
) -> str:
    """A line; for a long run that oscillates faster than a pixel column (:func:`windows`), per
    window: ``"band"`` the range (light) and the mean, ``"amplitude"`` the largest |y|,
    ``"mean"`` the mean, ``"rms"`` the RMS. Returns what was drawn (``"line"`` or the style)."""
    win = windows(t, y, force)
    if win is None:
        ax.plot(t, y, **kw)
        return "line"
    tb, blocks = win
    lab = kw.pop("label", None)
    if style == "band":
        ax.fill_between(tb, np.nanmin(blocks, axis=1), np.nanmax(blocks, axis=1),
                        color=kw.get("color"), alpha=0.2, lw=0)  # fmt: skip
        ax.plot(tb, np.nanmean(blocks, axis=1), label=lab, **kw)
    elif style == "amplitude":
        ax.plot(tb, np.nanmax(np.abs(blocks), axis=1), label=f"max {lab}", **kw)
    elif style == "rms":
        ax.plot(tb, np.sqrt(np.nanmean(blocks**2, axis=1)), label=f"RMS {lab}", **kw)
    else:
        ax.plot(tb, np.nanmean(blocks, axis=1), label=f"mean {lab}", **kw)
    return style


def window_text(t_seconds: np.ndarray, axis: TimeAxis) -> str:
    """The length of the windows :func:`series` uses on this run, for a legend title."""
    n = t_seconds.size
    w = max(1, n // ENVELOPE_WINDOWS)
    span = float(t_seconds[min(w, n - 1)] - t_seconds[0])
    if not axis.unit:
        return f"{w} samples"
    return f"{span / 60:.2g} min" if span >= 60 else f"{span:.2g} s"


#: The title :func:`attitude.propagate` gives every run: a figure says what the run is instead.
GENERIC_TITLE = "attitude propagation"
_SENSOR_VARIABLES = (("gyro_rate", "gyro"), ("star_tracker_q", "star tracker"),
                     ("magnetometer", "magnetometer"), ("sun_sensor", "Sun sensor"))  # fmt: skip


def _count(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


def run_title(ds: xr.Dataset) -> str:
    """The figure's title: the run's own (a scenario's), else what the run is, from its
    attrs and variables: the scenario's name, the spacecraft (inertia, actuators), the flight
    software's laws by mode with their guidance, the sensors and the estimator, or the torque
    model of a run without software."""
    a = ds.attrs
    title = str(a.get("title", "") or "")
    if title and title != GENERIC_TITLE:
        return title
    inertia = a.get("inertia")
    body = ""
    if inertia is not None:
        moments = "/".join(f"{float(x):g}" for x in np.atleast_1d(inertia))
        units = str(a.get("inertia_units", "")).replace("^2", "²").replace("kg m2", "kg m²")
        body = f"{moments} {'' if units == '1' else units}".strip()
    actuators = (
        ("wheel", "reaction wheel", "reaction wheels"),
        ("magnetorquer", "magnetorquer", "magnetorquers"),
        ("thruster", "thruster", "thrusters"),
    )
    kinds = [_count(ds.sizes[d], one, many) for d, one, many in actuators if ds.sizes.get(d, 0)]
    software = str(a.get("software", "") or "")
    craft = kinds or software or a.get("spacecraft")
    what = f"{'spacecraft' if craft else 'rigid body'} {body}".strip()
    what += f" with {', '.join(kinds)}" if kinds else ""
    parts = []
    if software:
        import re

        laws = []
        for m in re.finditer(r"(?:^|; )[\w-]+(?: when \w+)?: guidance (.+?), control (\w+)",
                             software):  # fmt: skip
            guidance, law = m.group(1), m.group(2)
            slew = guidance.startswith("slew onto ")
            target = re.match(r"[\w-]*", guidance[10:] if slew else guidance).group(0)
            target = f"slew onto {target}" if slew else target
            laws.append(law if guidance == "none" else f"{law} to {target}")
        if laws:
            parts.append(", then ".join(laws))
        sensors = [name for v, name in _SENSOR_VARIABLES if v in ds.variables]
        if "estimate_q" in ds.variables:
            sensors.append("MEKF")
        if sensors:
            parts.append(", ".join(sensors))
    else:
        model = str(a.get("potential_name", "") or "").replace("_", " ")
        if model:
            parts.append(model)
    name = str(a.get("scenario", "") or "")
    head = f"{name}: {what}" if name else what
    return head + (f" — {'; '.join(parts)}" if parts else "")

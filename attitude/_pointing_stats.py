"""The pointing error of a closed-loop result: which ticks count, and its statistics.

``attitude info`` prints them for a run with flight software (docs/cli.md); ``attitude plot``
leaves the same ticks out of its attitude-error panel (modes without guidance).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from .errors import AttitudeValueError

__all__ = ["DEFAULT_SETTLE", "PERCENTILES", "guided_modes", "pointing_summary", "settle_time"]

#: ``--settle`` by default: the first tenth of the run is the transient, left out.
DEFAULT_SETTLE = "10%"
#: The percentiles of the summary.
PERCENTILES = (50.0, 95.0, 99.0)


def guided_modes(ds: Any) -> np.ndarray:
    """Per mode of the software, whether it has a guidance (a reference to point at): the
    attitude error of a mode without one (B-dot, rate damping) is measured from the inertial
    identity and means nothing. From the ``software`` attr (``mode0: guidance none, ...``);
    all guided when it does not say."""
    names = str(ds["mode"].attrs.get("flag_meanings", "")).split() if "mode" in ds else []
    text = str(ds.attrs.get("software", ""))
    out = []
    for name in names:
        m = re.search(rf"(?:^|; ){re.escape(name)}(?: when \w+)?: guidance (\S+)", text)
        out.append(not (m is not None and m.group(1).rstrip(",") == "none"))
    return np.array(out or [True], dtype=bool)


def settle_time(spec: Any, t0: float, t1: float) -> tuple[float, str]:
    """The settling time from ``--settle``: ``"P%"`` of the run's span, or seconds (a number,
    or a string with a time unit: ``"2 min"``), counted from the run's first time ``t0``.
    Returns the time (s, the file's time axis) and how it was chosen, for the summary."""
    if spec is None:
        spec = DEFAULT_SETTLE
    s = str(spec).strip()
    if s.endswith("%"):
        try:
            p = float(s[:-1])
        except ValueError:
            p = math.nan
        if not 0.0 <= p < 100.0:
            raise AttitudeValueError(
                f"--settle: expected a percentage of the run in [0, 100) such as 10%, got {s!r}"
            )
        return t0 + p / 100.0 * (t1 - t0), f"the first {p:g} % of the run"
    from ._times import seconds_of

    try:
        sec = float(spec if isinstance(spec, (int, float)) else s)  # a number: seconds
    except ValueError:
        sec = seconds_of(s)
    if not 0.0 <= sec < math.inf:
        raise AttitudeValueError(
            f"--settle: expected a time after the start (e.g. 60, 60s or 2min) or a percentage "
            f"of the run (e.g. 10%), got {s!r}"
        )
    if t1 > t0 and sec >= t1 - t0:
        raise AttitudeValueError(
            f"--settle: {sec:g} s is not before the end of the run, which spans {t1 - t0:g} s; "
            "give a shorter time or a percentage (e.g. 10%)"
        )
    return t0 + sec, f"{sec:g} s after the start"


def _to_rad(ds: Any, name: str) -> float:
    units = str(ds[name].attrs.get("units", "rad")).strip() or "rad"
    from astropy import units as u

    try:
        return float(u.Unit(units).to(u.rad))
    except (ValueError, u.UnitsError):
        return 1.0


def pointing_summary(ds: Any, settle: Any = None) -> dict[str, Any] | None:
    """The statistics of the software's attitude error angle (``error_angle``, every recorded
    tick) after the settling time (:func:`settle_time`), on the ticks of modes with a guidance;
    None for a result without flight software.

    Returns a dict: ``t_settle`` (s), ``how`` (the settling rule), ``n`` (ticks counted),
    ``n_total`` (ticks recorded), and in rad ``rms``, ``max``, ``p50``, ``p95``, ``p99``
    (numpy's linear percentiles; NaN when no tick counts). None also for an ensemble's
    (member, tick) error angle: ``attitude info`` gives the ensemble's statistics apart.
    """
    if "error_angle" not in ds.variables or ds["error_angle"].dims != ("tick",):
        return None
    from .results import time_values

    t = time_values(ds, "tick")
    err = np.asarray(ds["error_angle"].values, dtype=np.float64) * _to_rad(ds, "error_angle")
    run_t = time_values(ds)
    t0 = float(run_t[0]) if run_t.size else (float(t[0]) if t.size else 0.0)
    t1 = float(run_t[-1]) if run_t.size else t0
    ts, how = settle_time(settle, t0, t1)
    keep = (t >= ts) & np.isfinite(err)
    if "mode" in ds.variables:
        guided = guided_modes(ds)
        mode = np.asarray(ds["mode"].values, dtype=np.int64)
        keep &= guided[np.clip(mode, 0, guided.size - 1)]
    e = err[keep]
    out: dict[str, Any] = {"t_settle": ts, "how": how, "n": int(e.size), "n_total": int(t.size)}
    if e.size:
        out["rms"] = float(np.sqrt(np.mean(e * e)))
        out["max"] = float(np.max(e))
        for p, v in zip(PERCENTILES, np.percentile(e, PERCENTILES), strict=True):
            out[f"p{p:g}"] = float(v)
    else:
        for k in ("rms", "max", *(f"p{p:g}" for p in PERCENTILES)):
            out[k] = math.nan
    return out


def pointing_lines(ds: Any, settle: Any = None) -> list[str]:
    """``attitude info``'s lines for :func:`pointing_summary` (none without flight software)."""
    s = pointing_summary(ds, settle)
    if s is None:
        return []
    head = (
        f"attitude error (error_angle) after t = {s['t_settle']:.6g} s ({s['how']}; --settle): "
        f"{s['n']} of {s['n_total']} recorded ticks"
    )
    run = ds.attrs.get("n_ticks")
    if run is not None and int(run) > s["n_total"] and "member" not in ds.dims:
        head += f" (of {int(run)} ticks run: record_every=1 would record every one)"
    if not s["n"]:
        return [head, "no guided tick after the settling time"]
    big = max(s["max"], s["rms"])
    f, unit = (3600.0 * 180.0 / math.pi, "arcsec") if big < math.radians(0.1) else (
        180.0 / math.pi, "deg"
    )  # fmt: skip
    pct = " / ".join(f"{s[f'p{p:g}'] * f:.4g}" for p in PERCENTILES)
    names = "/".join(f"{p:g}" for p in PERCENTILES)
    return [
        head,
        f"RMS {s['rms'] * f:.4g} {unit}, max {s['max'] * f:.4g} {unit}, "
        f"percentiles {names} %: {pct} {unit}",
    ]

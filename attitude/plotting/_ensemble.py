"""The ensemble figure: percentile bands over the members (``attitude plot`` on an ensemble)."""

from __future__ import annotations

import os
from typing import Any

import xarray as xr

from ._common import TimeAxis, pyplot, save

#: Most output times at which an ensemble's percentiles are drawn (the members are read in
#: blocks of times; longer runs are decimated by a stride).
MAX_ENSEMBLE_TIMES = 2000
#: Bytes of members' attitudes read at a time when computing an ensemble's percentiles.
_BLOCK_BYTES = 64 * 2**20
_BANDS = (5.0, 50.0, 95.0, 100.0)


def _ensemble_percentiles(ds: xr.Dataset) -> tuple[Any, Any, str]:
    """(pointing error [deg], |ω| [deg/s or deg per time unit], reference) percentiles
    (percentile, time): stored ones, or computed over the members in blocks of times."""
    import numpy as np

    from ..ensemble import pointing_error_percentiles, rate_percentiles
    from ..ensemble.statistics import has_nominal

    ref = "nominal" if has_nominal(ds) else "mean"
    if _software_error(ds):  # closed loop: the flight software's own pointing error per tick
        ref = "software"
    if "q" not in ds:  # statistics only
        have = [p for p in _BANDS if np.any(np.isclose(ds["percentile"].values, p))]
        pe = pointing_error_percentiles(ds, None, have, degrees=True)
        w = rate_percentiles(ds, have, degrees=True)
        return pe, w, ref
    n_time = ds.sizes["time"]
    stride = max(1, -(-n_time // MAX_ENSEMBLE_TIMES))
    d = ds.isel(time=slice(None, None, stride))
    block = max(1, _BLOCK_BYTES // (56 * max(1, ds.sizes["member"])))
    pes, ws = [], []
    for i in range(0, d.sizes["time"], block):
        part = d.isel(time=slice(i, i + block)).load()
        if ref != "software":
            pes.append(pointing_error_percentiles(part, None, _BANDS, degrees=True))
        ws.append(rate_percentiles(part, _BANDS, degrees=True))
    if ref == "software":
        from ..ensemble import error_angle_percentiles

        n_tick = ds.sizes["tick"]
        stride = max(1, -(-n_tick // MAX_ENSEMBLE_TIMES))
        ticks = ds[["error_angle", "member_status"]].isel(tick=slice(None, None, stride))
        pe = error_angle_percentiles(ticks.load(), _BANDS, degrees=True)
        return pe.rename(tick="time"), xr.concat(ws, "time"), ref
    return xr.concat(pes, "time"), xr.concat(ws, "time"), ref


def _software_error(ds: xr.Dataset) -> bool:
    """Whether ``ds`` is a closed-loop ensemble with the software's error angle at 2+ ticks."""
    return (
        "error_angle" in ds
        and ds["error_angle"].dims == ("member", "tick")
        and ds.sizes["tick"] >= 2
    )


def _bands(ax, t, da, color: str) -> None:
    import numpy as np

    p = np.asarray(da["percentile"].values)
    v = np.asarray(da.transpose("percentile", "time").values)

    def row(x):
        hit = np.flatnonzero(np.isclose(p, x))
        return v[hit[0]] if hit.size else None

    inner = [x for x in p if x < 100]
    lo, hi = (row(min(inner)), row(max(inner))) if len(inner) >= 2 else (None, None)
    if lo is not None:
        ax.fill_between(
            t, lo, hi, color=color, alpha=0.25, lw=0,
            label=f"{min(inner):g}–{max(inner):g} %",
        )  # fmt: skip
    if row(50) is not None:
        ax.plot(t, row(50), color=color, lw=1.3, label="median")
    if row(100) is not None:
        ax.plot(t, row(100), color="k", lw=0.9, ls="--", label="max")
    ax.legend(loc="upper left", fontsize=8, framealpha=0.8)
    ax.grid(alpha=0.3)


def plot_ensemble(ds: xr.Dataset, path: str | os.PathLike | None = None, *, dpi: int = 110) -> Any:
    """Figure of an ensemble result: percentile bands over members of the pointing error and
    of |ω| against time (5–95 % shaded, median, maximum dashed).

    The pointing error is measured from the stored reference (``reference_q``: the nominal
    state propagated once, as in a scenario run), else from the members' mean attitude; for a
    closed-loop ensemble it is the flight software's own (``error_angle``, at its ticks). A
    result with the final state only gives histograms over members instead.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result (any output choice; may be lazily loaded: members are read in
        blocks of output times, at most :data:`MAX_ENSEMBLE_TIMES` times).
    path : str or Path, optional
        Save the figure there.
    dpi : int
        Resolution of a saved raster figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    plt = pyplot(path)
    from ..results import time_unit, time_values

    pe, w, ref = _ensemble_percentiles(ds)
    n = int(ds.sizes.get("member", 0))
    ref_text = {"nominal": "the nominal attitude", "mean": "the members' mean attitude",
                "software": "the flight software's reference"}[ref]  # fmt: skip
    wu = str(w.attrs.get("units", ""))
    wlabel = "deg per time unit" if w.attrs.get("comment") else wu.replace(" s^-1", "/s")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    if ref == "software" and w.sizes["time"] < 2:  # closed loop, final states stored
        _software_final(ds, axes, pe, w, wlabel, n)
    elif w.sizes["time"] == 1 and "q" in ds:  # final state only: distributions over members
        from ..ensemble.statistics import _error_angles, _mean_attitude

        last = ds.isel(time=slice(-1, None)).load()
        q = np.asarray(last["q"].isel(time=0).values)
        if ref == "nominal":
            r = np.asarray(last["reference_q"].isel(time=0).values)
        else:
            r = _mean_attitude(last["q"])[0]
        r = r / np.linalg.norm(r)
        err = np.degrees(_error_angles(q, r, None))
        wn = np.degrees(np.linalg.norm(np.asarray(ds["omega"].isel(time=-1).values), axis=-1))
        for ax, x, stats, label in (
            (axes[0], err, pe, "pointing error [deg]"),
            (axes[1], wn, w, f"|ω| [{wlabel}]"),
        ):
            ax.hist(x, bins=min(60, max(10, n // 20)), color="tab:blue", alpha=0.7)
            for p, val in zip(stats["percentile"].values, stats.values[:, 0], strict=True):
                ax.axvline(val, color="k", lw=0.9, ls="--" if p == 100 else "-")
                ax.annotate(f"{p:g} %", (val, 1), xycoords=("data", "axes fraction"),
                            rotation=90, va="top", ha="right", fontsize=7)  # fmt: skip
            ax.set_xlabel(label)
            ax.set_ylabel("members")
            ax.grid(alpha=0.3)
        t_end = float(np.asarray(ds["time"].values)[-1]) if ds["time"].dtype.kind == "f" else None
        tu_end = str(time_unit(ds["time"]))
        tu_end = "" if tu_end in ("1", "") else f" {tu_end}"
        when = f" at t = {t_end:g}{tu_end}" if t_end is not None else ""
        axes[0].set_title(f"pointing error from {ref_text}{when}")
        axes[1].set_title(f"angular velocity magnitude{when}")
    else:
        ts = time_values(xr.Dataset(coords={"time": pe["time"]}))
        axis = TimeAxis.of(ds, ts)
        t = axis.values(ts)
        _bands(axes[0], t, pe, "tab:blue")
        axes[0].set_ylabel("pointing error [deg]")
        axes[0].set_title(f"pointing error from {ref_text}")
        if ref == "software":  # (its ticks are not the output times)
            t = axis.values(time_values(xr.Dataset(coords={"time": w["time"]})))
        _bands(axes[1], t, w, "tab:orange")
        axes[1].set_ylabel(f"|ω| [{wlabel}]")
        axes[1].set_title("angular velocity magnitude")
        for ax in axes:
            ax.set_xlabel(axis.text)
    title = str(ds.attrs.get("title", "attitude ensemble"))
    fig.suptitle(f"{title} ({n} members)", fontsize=11)
    return save(fig, path, dpi)


def _software_final(ds, axes, pe, w, wlabel: str, n: int) -> None:
    """A closed-loop ensemble storing final states: the software's pointing error in bands over
    its ticks, a histogram of |ω| at the end."""
    import numpy as np

    from ..results import time_values

    ts = time_values(xr.Dataset(coords={"time": pe["time"]}))
    axis = TimeAxis.of(ds, ts)
    _bands(axes[0], axis.values(ts), pe, "tab:blue")
    axes[0].set_ylabel("pointing error [deg]")
    axes[0].set_xlabel(axis.text)
    axes[0].set_title("pointing error from the flight software's reference")
    wn = np.degrees(np.linalg.norm(np.asarray(ds["omega"].isel(time=-1).values), axis=-1))
    ax = axes[1]
    ax.hist(wn[np.isfinite(wn)], bins=min(60, max(10, n // 20)), color="tab:orange", alpha=0.7)
    for p, val in zip(w["percentile"].values, w.values[:, 0], strict=True):
        ax.axvline(val, color="k", lw=0.9, ls="--" if p == 100 else "-")
    ax.set_xlabel(f"|ω| [{wlabel}]")
    ax.set_ylabel("members")
    ax.set_title("angular velocity magnitude at the end")
    ax.grid(alpha=0.3)

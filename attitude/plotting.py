"""Figures of propagation results (matplotlib, imported only here)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import xarray as xr

__all__ = ["plot_result", "plot_torque_budget"]

#: Largest number of points drawn per curve (longer runs are decimated by a stride).
MAX_POINTS = 20_000

_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red")


def _label(units: str) -> str:
    return "" if units in ("1", "") else f" [{units}]"


def plot_result(ds: xr.Dataset, path: str | os.PathLike | None = None, *, dpi: int = 110) -> Any:
    """Figure of a result: q (left) and Q (right) against time as in Arribas et al. Figs. 1–3,
    with the body angular velocity and the energy below.

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result (docs/results.md); may be lazily loaded (it is decimated to at
        most :data:`MAX_POINTS` samples before reading).
    path : str or Path, optional
        Save the figure there (PNG, PDF, SVG... by extension).
    dpi : int
        Resolution of a saved raster figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    n = ds.sizes["time"]
    stride = max(1, -(-n // MAX_POINTS))
    d = ds.isel(time=slice(None, None, stride))
    t = d["time"].values
    from .results import time_unit

    tu = _label(time_unit(ds["time"]))

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True, constrained_layout=True)
    comp = ["q0", "q1", "q2", "q3"]
    for ax, var, sym in ((axes[0, 0], "q", "q"), (axes[0, 1], "Q", "Q")):
        vals = d[var].values
        for i in range(4):
            ax.plot(t, vals[:, i], color=_COLORS[i], lw=1.1, label=f"{sym}{comp[i][1]}")
        ax.set_ylabel(f"{sym}{_label(str(ds[var].attrs.get('units', '')))}")
        ax.legend(loc="upper right", fontsize=8, ncol=4, framealpha=0.8)
        ax.grid(alpha=0.3)
    axes[0, 0].set_title("Euler parameters q (body to space)")
    axes[0, 1].set_title("conjugate momenta Q")

    ax = axes[1, 0]
    w = d["omega"].values
    for i, c in enumerate("123"):
        ax.plot(t, w[:, i], color=_COLORS[i], lw=1.1, label=f"ω{c}")
    ax.set_ylabel(f"ω (body axes){_label(str(ds['omega'].attrs.get('units', '')))}")
    ax.set_title("angular velocity")
    ax.legend(loc="upper right", fontsize=8, ncol=3, framealpha=0.8)
    ax.grid(alpha=0.3)

    ax = axes[1, 1]
    E = d["energy"].values
    eu = _label(str(ds["energy"].attrs.get("units", "")))
    pot = str(ds.attrs.get("potential_name", ""))
    if pot in ("torque_free", "heavy_top") and E.size:
        scale = abs(E[0]) if E[0] != 0 else 1.0
        ax.plot(t, (E - E[0]) / scale, color="k", lw=1.0)
        ax.set_ylabel("(H − H₀) / |H₀|")
        ax.set_title(f"energy error (H₀ = {E[0]:.6g}{eu})")
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    else:
        U = d["potential_energy"].values
        ax.plot(t, E, color="k", lw=1.1, label="H = T + U")
        ax.plot(t, E - U, color="tab:purple", lw=1.0, label="T")
        ax.plot(t, U, color="tab:gray", lw=1.0, label="U")
        ax.set_ylabel(f"energy{eu}")
        ax.set_title("energy (time-dependent potential)")
        ax.legend(loc="upper right", fontsize=8, ncol=3, framealpha=0.8)
    ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel(f"t{tu}")
    title = str(ds.attrs.get("title", "attitude propagation"))
    fig.suptitle(title, fontsize=11)
    if path is not None:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=dpi)
        plt.close(fig)
    return fig


#: Colours of the torque models in :func:`plot_torque_budget` (by term name; others cycle).
_MODEL_COLORS = {
    "gravity_gradient": "tab:blue",
    "magnetic_dipole": "tab:red",
    "aerodynamic_drag": "tab:green",
    "solar_radiation": "tab:orange",
    "eddy_current_damping": "tab:purple",
    "heavy_top": "tab:brown",
    "total": "black",
}


def plot_torque_budget(
    ds: xr.Dataset, path: str | os.PathLike | None = None, *, windows: int = 288, dpi: int = 110
) -> Any:
    """Figure of the torque budget: |τ| of every model term against time, and their max / RMS.

    Left: for each term the range of |τ| (band between the smallest and largest value in each
    of ``windows`` consecutive windows of the run) and its RMS per window (line), log scale.
    Right: max and RMS of |τ| over the run per term (what ``attitude info`` prints).

    Parameters
    ----------
    ds : xarray.Dataset
        A result with the per-model ``torque (time, model, axis)`` (docs/results.md).
    path : str or Path, optional
        Save the figure there.
    windows : int
        Number of time windows of the left panel (default 288: 5 min in a day).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    import numpy as np

    from .errors import AttitudeValueError
    from .results import time_unit

    if "torque" not in ds.data_vars or "model" not in ds["torque"].dims:
        raise AttitudeValueError(
            "ds: no per-model torque variable (torque (time, model, axis)) in this result"
        )
    labels = [str(x) for x in ds["model_label"].values] if "model_label" in ds else []
    labels += [str(j) for j in range(len(labels), ds.sizes["model"])]
    t = np.asarray(ds["time"].values, dtype=np.float64)
    tu = time_unit(ds["time"])
    scale, tlabel = 1.0, f"t [{tu}]"
    if tu == "s" and t.size and t[-1] - t[0] > 3 * 3600:
        scale, tlabel = 3600.0, "t [h]"
    mag = np.sqrt(np.sum(np.asarray(ds["torque"].values, dtype=np.float64) ** 2, axis=-1))
    n = mag.shape[0]
    w = max(1, n // max(1, windows))
    m = (n // w) * w
    blocks = mag[:m].reshape(-1, w, mag.shape[1])
    tb = t[:m].reshape(-1, w).mean(axis=1) / scale
    lo, hi = blocks.min(axis=1), blocks.max(axis=1)
    rms_w = np.sqrt((blocks**2).mean(axis=1))
    peak = mag.max(axis=0)
    rms = np.sqrt((mag**2).mean(axis=0))
    positive = rms[rms > 0]
    floor = 1e-3 * positive.min() if positive.size else 1e-30
    unit = str(ds["torque"].attrs.get("units", ""))

    fig, (ax, bx) = plt.subplots(
        1, 2, figsize=(13, 5.2), gridspec_kw={"width_ratios": [2.3, 1]}, constrained_layout=True
    )
    cycle = iter(plt.rcParams["axes.prop_cycle"].by_key()["color"])
    colors = [_MODEL_COLORS.get(name) or next(cycle) for name in labels]
    for j, name in enumerate(labels):
        c = colors[j]
        if name != "total":
            ax.fill_between(tb, np.maximum(lo[:, j], floor), np.maximum(hi[:, j], floor),
                            color=c, alpha=0.18, lw=0)  # fmt: skip
        ax.plot(tb, np.maximum(rms_w[:, j], floor), color=c, lw=1.3 if name == "total" else 1.1,
                ls="--" if name == "total" else "-", label=name)  # fmt: skip
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor * 10)
    ax.set_xlabel(tlabel)
    ax.set_ylabel(f"|τ| (body frame) [{unit}]")
    span = (t[w] - t[0]) if n > w else 0.0
    win = f"{span / 60:.3g} min" if tu == "s" and span >= 60 else f"{w} samples"
    ax.set_title(f"torque per model: RMS over {win} windows (line) and range (band)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="lower right", fontsize=8, ncol=2, framealpha=0.85)

    y = np.arange(len(labels))[::-1]
    bx.barh(y + 0.18, peak, height=0.36, color=colors, alpha=0.45, label="max |τ|")
    bx.barh(y - 0.18, rms, height=0.36, color=colors, label="RMS |τ|")
    for yy, p, r in zip(y, peak, rms, strict=True):
        bx.text(p, yy + 0.18, f" {p:.2g}", va="center", fontsize=7)
        bx.text(r, yy - 0.18, f" {r:.2g}", va="center", fontsize=7)
    bx.set_yticks(y, labels, fontsize=8)
    bx.set_xscale("log")
    bx.set_xlim(left=floor * 10, right=peak.max() * 3e3 if peak.size else 1.0)
    bx.set_xlabel(f"|τ| [{unit}]")
    bx.set_title("budget over the run")
    bx.grid(alpha=0.3, axis="x", which="both")
    bx.legend(loc="upper right", fontsize=8)
    fig.suptitle(str(ds.attrs.get("title", "torque budget")), fontsize=11)
    if path is not None:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=dpi)
        plt.close(fig)
    return fig


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

    from .ensemble import pointing_error_percentiles, rate_percentiles

    ref = "nominal" if "reference_q" in ds else "mean"
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
        pes.append(pointing_error_percentiles(part, None, _BANDS, degrees=True))
        ws.append(rate_percentiles(part, _BANDS, degrees=True))
    return xr.concat(pes, "time"), xr.concat(ws, "time"), ref


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
    state propagated once, as in a scenario run), else from the members' mean attitude. A
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
    import matplotlib
    import numpy as np

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    from .results import time_unit

    pe, w, ref = _ensemble_percentiles(ds)
    n = int(ds.sizes.get("member", 0))
    ref_text = "the nominal attitude" if ref == "nominal" else "the members' mean attitude"
    wu = str(w.attrs.get("units", ""))
    wlabel = "deg per time unit" if w.attrs.get("comment") else wu.replace(" s^-1", "/s")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    if pe.sizes["time"] == 1 and "q" in ds:  # final state only: distributions over members
        from .ensemble.statistics import _error_angles, _mean_attitude

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
        t = np.asarray(pe["time"].values)
        tu = _label(time_unit(ds["time"]))
        _bands(axes[0], t, pe, "tab:blue")
        axes[0].set_ylabel("pointing error [deg]")
        axes[0].set_title(f"pointing error from {ref_text}")
        _bands(axes[1], t, w, "tab:orange")
        axes[1].set_ylabel(f"|ω| [{wlabel}]")
        axes[1].set_title("angular velocity magnitude")
        for ax in axes:
            ax.set_xlabel(f"t{tu}")
    title = str(ds.attrs.get("title", "attitude ensemble"))
    fig.suptitle(f"{title} ({n} members)", fontsize=11)
    if path is not None:
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=dpi)
        plt.close(fig)
    return fig

"""The torque budget figure (``attitude plot --torques``)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import xarray as xr

from ._common import TimeAxis, pyplot, save

#: Colours of the torque models (by term name; others cycle).
MODEL_COLORS = {
    "gravity_gradient": "tab:blue",
    "magnetic_dipole": "tab:red",
    "aerodynamic_drag": "tab:green",
    "solar_radiation": "tab:orange",
    "eddy_current_damping": "tab:purple",
    "heavy_top": "tab:brown",
    "total": "black",
}


def model_labels(ds: xr.Dataset) -> list[str]:
    """The names of the ``model`` dimension (``model_label``; indices when absent)."""
    labels = [str(x) for x in ds["model_label"].values] if "model_label" in ds else []
    return labels + [str(j) for j in range(len(labels), ds.sizes["model"])]


def plot_torque_budget(
    ds: xr.Dataset, path: str | os.PathLike | None = None, *, windows: int = 288, dpi: int = 110
) -> Any:
    """Figure of the torque budget: |τ| of every model term against time, and their max / RMS.

    Left: for each term the range of |τ| (band between the smallest and largest value in each
    of ``windows`` consecutive windows of the run) and its RMS per window (line), log scale;
    the total is a wide light line under the terms, so the dominant term stays visible where
    it is the total. Right: max and RMS of |τ| over the run per term (what ``attitude info``
    prints).

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
    from ..errors import AttitudeValueError
    from ..results import time_values

    if "torque" not in ds.data_vars or "model" not in ds["torque"].dims:
        raise AttitudeValueError(
            "ds: no per-model torque variable (torque (time, model, axis)) in this result"
        )
    plt = pyplot(path)
    labels = model_labels(ds)
    t = time_values(ds)
    axis = TimeAxis.of(ds, t)
    mag = np.sqrt(np.sum(np.asarray(ds["torque"].values, dtype=np.float64) ** 2, axis=-1))
    n = mag.shape[0]
    w = max(1, n // max(1, windows))
    m = (n // w) * w
    blocks = mag[:m].reshape(-1, w, mag.shape[1])
    tb = axis.values(t[:m].reshape(-1, w).mean(axis=1))
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
    colors = [MODEL_COLORS.get(name) or next(cycle) for name in labels]
    for j, name in enumerate(labels):
        c = colors[j]
        if name == "total":  # wide and light, under the terms: the dominant one shows on it
            ax.plot(tb, np.maximum(rms_w[:, j], floor), color="0.55", lw=5.0, alpha=0.5,
                    label="total", zorder=1, solid_capstyle="butt")  # fmt: skip
            continue
        ax.fill_between(tb, np.maximum(lo[:, j], floor), np.maximum(hi[:, j], floor),
                        color=c, alpha=0.18, lw=0, zorder=0.5)  # fmt: skip
        ax.plot(tb, np.maximum(rms_w[:, j], floor), color=c, lw=1.2, label=name, zorder=2)
    ax.set_yscale("log")
    ax.set_ylim(bottom=floor * 10)
    ax.set_xlabel(axis.text)
    ax.set_ylabel(f"|τ| (body frame) [{unit}]")
    span = (t[w] - t[0]) if n > w else 0.0
    win = f"{span / 60:.3g} min" if axis.unit and span >= 60 else f"{w} samples"
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
    return save(fig, path, dpi)

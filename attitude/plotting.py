"""Figures of propagation results (matplotlib, imported only here)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import xarray as xr

__all__ = ["plot_result"]

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

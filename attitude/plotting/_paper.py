"""The paper's layout: q (left) and Q (right) as in Arribas et al. Figs. 1–3, ω and energy below."""

from __future__ import annotations

from typing import Any

import numpy as np

from ._common import label
from ._panels import PlotContext, energy

_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red")


def draw_paper(fig: Any, ctx: PlotContext) -> list:
    """Draw the four panels on ``fig``; returns the axes."""
    ds = ctx.ds
    t = ctx.t
    axes = fig.subplots(2, 2, sharex=True)
    for ax, var in ((axes[0, 0], "q"), (axes[0, 1], "Q")):
        vals = np.asarray(ds[var].values, dtype=np.float64)
        for i in range(4):
            ax.plot(t, vals[:, i], color=_COLORS[i], lw=1.1, label=f"{var}{i}")
        ax.set_ylabel(f"{var}{label(str(ds[var].attrs.get('units', '')))}")
        ax.legend(loc="best", fontsize=8, ncol=4, framealpha=0.8)
    axes[0, 0].set_title("Euler parameters q (body to space)")
    axes[0, 1].set_title("conjugate momenta Q")

    ax = axes[1, 0]
    w = np.asarray(ds["omega"].values, dtype=np.float64)
    for i, c in enumerate("123"):
        ax.plot(t, w[:, i], color=_COLORS[i], lw=1.1, label=f"ω{c}")
    ax.set_ylabel(f"ω (body axes){label(str(ds['omega'].attrs.get('units', '')))}")
    ax.set_title("angular velocity")
    ax.legend(loc="best", fontsize=8, ncol=3, framealpha=0.8)

    ax = axes[1, 1]
    E = np.asarray(ds["energy"].values, dtype=np.float64)
    eu = label(str(ds["energy"].attrs.get("units", "")))
    pot = str(ds.attrs.get("potential_name", ""))
    if pot in ("torque_free", "heavy_top") and E.size:
        scale = abs(E[0]) if E[0] != 0 else 1.0
        ax.plot(t, (E - E[0]) / scale, color="k", lw=1.0)
        ax.set_ylabel("(H − H₀) / |H₀|")
        ax.set_title(f"energy error (H₀ = {E[0]:.6g}{eu})")
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    else:
        energy(ax, ctx)
        ax.set_title("energy (time-dependent potential)")
    for a in axes.ravel():
        a.grid(alpha=0.3)
    for a in axes[1]:
        a.set_xlabel(ctx.axis.text)
    return list(axes.ravel())

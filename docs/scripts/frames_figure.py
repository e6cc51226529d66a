"""docs/figures/frames.png: the local orbital frames of attitude.frames on an elliptic orbit.

Run from the repository root: ``python docs/scripts/frames_figure.py``. The axes are computed
by attitude.frames itself (the columns of to_matrix(q_R)), drawn in the orbit plane seen from
the orbit normal ĥ (out of the page).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import orbit
from attitude import frames
from attitude import quaternion as aq

o = orbit.KeplerOrbit(10000.0, 0.35, 0.0, 0.0, 0.0)  # equatorial: the plane is the page
tt = np.linspace(0.0, o.period, 400)
path = o.position(tt)
t0 = 0.18 * o.period
r0, v0 = o.to_state(t0)
L = 3000.0

fig, axes = plt.subplots(1, 3, figsize=(12.5, 4.6))
names = ("rsw", "lvlh", "vnc")
titles = {
    "rsw": "RSW  (the paper's orbital frame p)\nx radial, y along-track, z orbit normal ĥ",
    "lvlh": "LVLH  (CCSDS / Vallado)\nz nadir, y = −ĥ, x = y × z (along-track)",
    "vnc": "VNC\nx velocity, y = ĥ, z = x × y (co-normal)",
}
colors = ("tab:red", "tab:green", "tab:blue")
for ax, name in zip(axes, names, strict=True):
    fr = getattr(frames, name)(o)
    R = aq.to_matrix(fr.quaternion(np.array([t0]))[0])
    ax.plot(path[:, 0], path[:, 1], color="0.6", lw=1)
    ax.plot([0], [0], "o", color="tab:cyan", ms=14)
    ax.plot([r0[0], 0.45 * r0[0]], [r0[1], 0.45 * r0[1]], ":", color="tab:cyan")
    ax.annotate("to the Earth's centre", (0.5 * r0[0], 0.5 * r0[1]), fontsize=8, color="0.3")
    ax.plot(*r0[:2], "k.", ms=8)
    ax.annotate(
        "v",
        xy=(
            r0[0] + 0.75 * L * v0[0] / np.linalg.norm(v0),
            r0[1] + 0.75 * L * v0[1] / np.linalg.norm(v0),
        ),
        xytext=(r0[0], r0[1]),
        arrowprops={"arrowstyle": "->", "color": "0.3", "ls": "--"},
        fontsize=8,
        color="0.3",
    )
    for k, (lab, c) in enumerate(zip("xyz", colors, strict=True)):
        axis = R[:, k]
        if abs(axis[2]) > 0.99:  # out of / into the page
            sym = "$\\odot$" if axis[2] > 0 else "$\\otimes$"
            ax.plot(r0[0] + 0.3 * L, r0[1] - 0.35 * L, marker=sym, ms=16, color=c, ls="none")
            ax.annotate(lab, (r0[0] + 0.3 * L, r0[1] - 0.35 * L), textcoords="offset points",
                        xytext=(9, 6), color=c, fontsize=11)  # fmt: skip
        else:
            ax.arrow(r0[0], r0[1], L * axis[0], L * axis[1], color=c, width=60,
                     length_includes_head=True)  # fmt: skip
            ax.annotate(lab, (r0[0] + 1.08 * L * axis[0], r0[1] + 1.08 * L * axis[1]),
                        color=c, fontsize=11)  # fmt: skip
    ax.set_title(titles[name], fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlim(r0[0] - 6000, r0[0] + 4500)
    ax.set_ylim(r0[1] - 5500, r0[1] + 4500)
    ax.set_xticks([])
    ax.set_yticks([])
fig.suptitle(
    "Local orbital frames of attitude.frames on an e = 0.35 orbit (orbit normal ĥ out of the "
    "page; ⊙ out, ⊗ in)",
    fontsize=10,
)
fig.tight_layout()
out = Path(__file__).resolve().parent.parent / "figures" / "frames.png"
fig.savefig(out, dpi=110)
print(out)

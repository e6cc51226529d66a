"""The cost of events: the paper's Sect. 6.2 case (gravity gradient, 10 orbits, rtol 1e-12) with
and without events located inside the compiled loop, as ratios measured in this process.

Events: the attitude error from the RSW frame (the orbital frame p(t), a Kepler orbit read
through the frame dispatcher at every sample), |ω|, and the eclipse entry and exit (orbit and
Sun table). Run: ``python benchmarks/events.py``
"""

from __future__ import annotations

import time

import numpy as np

import orbit
from attitude import events, frames
from attitude.canonical import project_state
from attitude.potentials import GravityGradient
from attitude.propagate import propagate

INERTIA = np.array([400.0, 500.0, 600.0])  # kg km²


def best_of(fn, n=5):
    best = np.inf
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    o = orbit.KeplerOrbit(
        7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12, epoch="2024-03-20T12:00:00"
    )
    pot = GravityGradient(o)
    q0, Q0, _ = project_state([0.5, -(0.5**0.5), 0, 0.5], [0.3, -0.848528, 0.141421, -1.5])
    t = np.linspace(0.0, 10 * o.period, 10 * 360 + 1)
    sets = {
        "none": None,
        "pointing (rsw)": [events.PointingExceeds(frames.rsw(o), None, 1.0, direction="both")],
        "rate": [events.RateExceeds(1e-3, direction="both")],
        "eclipse in/out": [events.EclipseEntry(o), events.EclipseExit(o)],
    }
    sets["all four"] = [e for v in list(sets.values())[1:] for e in v]
    base = None
    print(f"paper Sect. 6.2, 10 orbits ({t[-1]:.0f} s), rtol 1e-12, best of 5")
    for name, evs in sets.items():
        propagate(INERTIA, q0, Q0, t[:3], potential=pot, events=evs)  # load/compile

        def run(evs=evs):
            return propagate(INERTIA, q0, Q0, t, potential=pot, events=evs, rtol=1e-12, atol=1e-14)

        dt, ds = best_of(run)
        base = dt if base is None else base
        n_ev = int(ds.sizes.get("event", 0))
        print(
            f"  {name:<16} {1e3 * dt:7.2f} ms  x{dt / base:5.2f}  {ds.attrs['n_steps']} steps, "
            f"{n_ev} events"
        )


if __name__ == "__main__":
    main()

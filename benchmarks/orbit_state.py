"""Cost of an orbit state inside compiled code, per orbit source, as a right-hand side pays it.

Usage::

    python benchmarks/orbit_state.py [--n 1000000] [--repeat 5]

Prints ns per call of the radial kernel the gravity gradient uses (``orbit_radial``: r and r̂)
for each orbit type of the dispatcher (orbit/_state_kernels.py), against the 9-element Kepler
kernel ``orbit._kernels.radius_and_radial_unit`` that recomputes cos/sin of Ω, i, ω per call
(the baseline, same process, same times), and the full state ``orbit_state``. Then the paper's
Sect. 6.2 gravity-gradient run over 10 orbits on a Kepler orbit and on the same orbit sampled
every 60 s into a Hermite table. Best of ``--repeat`` after a warm-up (compilation excluded).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from orbit import EphemerisOrbit, KeplerOrbit, SecularJ2Orbit
from orbit import _kernels as K
from orbit import _state_kernels as SK
from orbit._shared_jit import jit


@jit
def _legacy(el, t):
    acc = 0.0
    for i in range(t.size):
        r, x, y, z = K.radius_and_radial_unit(el, t[i])
        acc += r + x + y + z
    return acc


@jit
def _radial(d, t):
    acc = 0.0
    for i in range(t.size):
        r, x, y, z = SK.orbit_radial(d, t[i])
        acc += r + x + y + z
    return acc


@jit
def _state(d, t):
    acc = 0.0
    for i in range(t.size):
        s = SK.orbit_state(d, t[i])
        acc += s[0] + s[1] + s[2] + s[3] + s[4] + s[5]
    return acc


def best_of(fn, repeat):
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    kep = KeplerOrbit(7000.0, 0.2, math.pi / 6, math.pi / 4, math.pi / 12)
    span = 10 * kep.period
    t = np.sort(np.random.default_rng(0).uniform(0.0, span, a.n))
    sources = {
        "Kepler": kep,
        "secular J2": SecularJ2Orbit(7000.0, 0.2, math.pi / 6, math.pi / 4, math.pi / 12),
        "Hermite table (60 s)": EphemerisOrbit.from_orbit(kep, 0.0, span, 60.0),
    }
    el = kep.kernel_elements()
    _legacy(el, t[:10])
    base = best_of(lambda: _legacy(el, t), a.repeat) / a.n * 1e9
    print(f"baseline radius_and_radial_unit (9-element Kepler, trig per call): {base:6.1f} ns")
    for name, o in sources.items():
        d = o.kernel_data()
        _radial(d, t[:10])
        _state(d, t[:10])
        r = best_of(lambda d=d: _radial(d, t), a.repeat) / a.n * 1e9
        s = best_of(lambda d=d: _state(d, t), a.repeat) / a.n * 1e9
        print(
            f"{name:>22}: orbit_radial {r:6.1f} ns ({base / r:4.2f}x baseline), "
            f"orbit_state {s:6.1f} ns"
        )

    import attitude

    body = attitude.RigidBody([400.0, 500.0, 600.0], units="kg km2")
    q0 = [0.5, -0.7071067811865476, 0.0, 0.5]
    Q0 = [0.3, -0.848528, 0.141421, -1.5]
    tt = np.linspace(0.0, span, 1001)
    for name in ("Kepler", "Hermite table (60 s)"):
        pot = attitude.GravityGradient(sources[name])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")

            def go(pot=pot):
                return attitude.propagate(body, q0, Q0, tt, potential=pot, rtol=1e-12)

            ds = go()
            w = best_of(go, a.repeat)
        print(
            f"GG paper case, 10 orbits, rtol 1e-12, {name:>20}: {w * 1e3:6.1f} ms, "
            f"{int(ds.attrs['n_rhs'])} right-hand sides"
        )


if __name__ == "__main__":
    main()

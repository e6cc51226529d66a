"""``orbit.NumericalOrbit`` (DOP853 and ``method="taylor"``) against heyoka's Taylor integrator:
one day under EGM2008 20×20, time to 1e-9 relative accuracy, in one process.

Run (heyoka is an optional peer, never a dependency: a scratch environment with heyoka and this
package installed, ``pip install -e .``)::

    python benchmarks/numerical_orbit.py [--repeat 20] [--full] [--heyoka-cache DIR]

The case is tests/test_numerical_heyoka.py's: epoch 2026-03-20T00:00:00 UTC, r0 = (6878.137, 0,
0) km, v0 = 7.6127 (0, cos 51.6°, sin 51.6°) km/s, the Earth turning uniformly (θ = θ0 + ω t,
``earth_rotation="uniform"``), 1441 samples every 60 s over one day.

Accuracy: error = max over the samples of |Δr| / |r0| against a reference, heyoka's Taylor
integrator at tol 1e-15 with high accuracy (its own tol 1e-13 run is 3e-5 m from it, 4e-12
relative; without heyoka: DOP853 at rtol 1e-15, flagged). For each method the cheapest setting
with error ≤ 1e-9 (6.9 mm) is reported. Our Taylor method's ``rtol`` sets its order as heyoka's
tolerance does (p = ⌈−½ ln rtol + 1⌉) and its step from the series (Jorba & Zou), so its error
moves in jumps too. DOP853 runs with atol = rtol (m, m/s: rtol governs both
positions and velocities). heyoka's tolerance only sets its order (its step size follows from
the Taylor coefficients), so its error moves in jumps; it runs in SI units and in units of
(|r0|, the period / 2π) (its norm then weighs positions and velocities alike), in compact mode
(``--full`` adds the non-compact mode of the chosen orders: faster code, minutes to compile).

Times: wall time, best of ``--repeat`` after a warm-up (the machine may be shared: see the load
printed). "core": the integrator alone on a prepared problem (heyoka: ``propagate_grid`` on a
reset integrator; ours: the compiled driver ``orbit._force_kernels.run`` or
``orbit._taylor.run`` from a fresh state, the force tables built); "public":
``NumericalOrbit(...)`` then ``.propagate(t)`` (tables, the ERA of the epoch, the Dataset).
Compilation apart: heyoka's ``taylor_adaptive`` construction (JIT of the expression; from a
fresh cache directory unless ``--heyoka-cache``), and our first
call in the process (numba: loaded from its disk cache, ``ATTITUDE_CACHE_DIR``, or compiled
when that is empty: the script says which).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

EPOCH = "2026-03-20T00:00:00"
R0_KM = np.array([6878.137, 0.0, 0.0])
INC = math.radians(51.6)
V0_KM_S = 7.6127 * np.array([0.0, math.cos(INC), math.sin(INC)])
DEGREE = 20
DAY = 86_400.0
TARGET = 1e-9
OMEGA = 2.0 * math.pi * 1.00273781191135448 / 86400.0


def best_time(fn, repeat):
    fn()  # warm-up
    best = math.inf
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _heyoka(cache):
    if cache is None:
        cache = tempfile.mkdtemp(prefix="heyoka-cache-")
    os.environ["XDG_CACHE_HOME"] = cache  # heyoka's on-disk cache of compiled code
    try:
        import heyoka
    except ImportError:
        return None
    return heyoka


def heyoka_system(hy, theta0, length, time_unit):
    """r̈ = R3(θ)ᵀ g(R3(θ) r), positions in ``length`` m, time in ``time_unit`` s."""
    mu = hy.model.get_egm2008_mu() * time_unit**2 / length**3
    a = hy.model.get_egm2008_a() / length
    x, y, z, vx, vy, vz = hy.make_vars("x", "y", "z", "vx", "vy", "vz")
    th = theta0 + (OMEGA * time_unit) * hy.time
    c, s = hy.cos(th), hy.sin(th)
    gx, gy, gz = hy.model.egm2008_acc([c * x + s * y, c * y - s * x, z], DEGREE, DEGREE,
                                      mu=mu, a=a)  # fmt: skip
    return [(x, vx), (y, vy), (z, vz), (vx, c * gx - s * gy), (vy, s * gx + c * gy), (vz, gz)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--full", action="store_true", help="heyoka's non-compact mode too")
    ap.add_argument("--heyoka-cache", default=None, help="heyoka's cache dir (default: fresh)")
    args = ap.parse_args(argv)

    hy = _heyoka(args.heyoka_cache)
    cache_dir = os.environ.get("ATTITUDE_CACHE_DIR")
    cold = cache_dir is not None and (
        not Path(cache_dir).exists() or not any(Path(cache_dir).iterdir())
    )

    t_first0 = time.perf_counter()
    import orbit
    from orbit import _force_kernels as _fk

    t_import = time.perf_counter() - t_first0
    field = orbit.SphericalHarmonics(DEGREE)
    t = np.arange(0.0, DAY + 30.0, 60.0)

    def make(rtol, method="dop853"):
        return orbit.NumericalOrbit(R0_KM, V0_KM_S, EPOCH, gravity=field, method=method,
                                    earth_rotation="uniform", rtol=rtol, atol=rtol)  # fmt: skip

    t0 = time.perf_counter()
    make(1e-11).propagate(t)
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    make(1e-11).propagate(t)
    t_second = time.perf_counter() - t0

    o_ref = make(1e-15)
    theta0 = o_ref._forces._theta0
    y0 = o_ref.initial_state
    r0 = float(np.linalg.norm(y0[:3]))
    if hy is not None:
        ta = hy.taylor_adaptive(heyoka_system(hy, theta0, 1.0, 1.0), y0, tol=1e-15,
                                high_accuracy=True, compact_mode=True)  # fmt: skip
        ref = np.asarray(ta.propagate_grid(t)[-1])[:, :3]
        ref_note = f"heyoka {hy.__version__} tol 1e-15, order {ta.order}, high accuracy"
    else:
        ref = o_ref.propagate(t).position.values
        ref_note = "DOP853 rtol 1e-15 (install heyoka for an independent reference)"

    def error(r):
        return float(np.max(np.linalg.norm(r - ref, axis=1)) / r0)

    rows = []  # method, setting, error, steps, rhs, compile s, core s, public s
    ours = [("DOP853 (ours)", "dop853", r) for r in (1e-10, 5e-11, 3e-11, 2e-11, 1.5e-11, 1e-11,
                                                     5e-12)]  # fmt: skip
    ours += [("Taylor (ours)", "taylor", r) for r in (1e-8, 3e-9, 1e-9, 3e-10, 1e-10)]
    for label, method, rtol in ours:
        o = make(rtol, method)
        o._forces.cover(0.0, DAY)

        def core(o=o):
            it = o._integrator(1.0)
            y, _, _ = o._advance(it, t)
            return y, it.counters, it.tstate

        tc, (y, counters, tstate) = best_time(core, args.repeat)
        tp, _ = best_time(lambda r=rtol, m=method: make(r, m).propagate(t),
                          max(3, args.repeat // 4))  # fmt: skip
        setting = f"rtol={rtol:.1e}" + (f" (order {tstate[3]:.0f})" if method == "taylor" else "")
        # (Taylor: the "RHS evals" column counts the orders expanded, p per step)
        rows.append((label, setting, error(y[:, :3]), int(counters[0]), int(counters[1]), None,
                     tc, tp))  # fmt: skip
    n_acc = 20000
    rng = np.random.default_rng(1)
    u = rng.normal(size=(n_acc, 3))
    pts = u / np.linalg.norm(u, axis=1)[:, None] * r0
    ts = np.linspace(0.0, DAY, n_acc)
    acc = np.empty_like(pts)
    d = o_ref._forces.cover(0.0, DAY)
    t_acc, _ = best_time(lambda: _fk.acceleration_loop(d, ts, pts, acc), args.repeat)
    t_acc /= n_acc

    if hy is not None:
        T = math.sqrt(r0**3 / hy.model.get_egm2008_mu())
        variants = [("heyoka SI", 1.0, 1.0, True), ("heyoka (|r0|, T)", r0, T, True)]
        tols = {"heyoka SI": (1e-9, 1e-10, 1e-11, 1e-12), "heyoka (|r0|, T)": (1e-8, 1e-9, 1e-10)}
        for label, length, tu, compact in variants:
            sys_ = heyoka_system(hy, theta0, length, tu)
            ys = np.concatenate([y0[:3] / length, y0[3:] * tu / length])
            for tol in tols[label]:
                c0 = time.perf_counter()
                ta = hy.taylor_adaptive(sys_, ys, tol=tol, compact_mode=compact)
                tcomp = time.perf_counter() - c0

                def core(ta=ta, ys=ys, tu=tu):
                    ta.time = 0.0
                    ta.state[:] = ys
                    return ta.propagate_grid(t / tu)

                tc, out = best_time(core, args.repeat)
                e = error(np.asarray(out[-1])[:, :3] * length)
                rows.append((label + " compact", f"tol={tol:.0e} (order {ta.order})", e,
                             int(out[3]), None, tcomp, tc, None))  # fmt: skip
        if args.full:
            for label, length, tu, _ in variants:
                ok = [r for r in rows if r[0] == label + " compact" and r[2] <= TARGET]
                if not ok:
                    continue
                tol = float(min(ok, key=lambda r: r[6])[1].split()[0][4:])
                sys_ = heyoka_system(hy, theta0, length, tu)
                ys = np.concatenate([y0[:3] / length, y0[3:] * tu / length])
                c0 = time.perf_counter()
                ta = hy.taylor_adaptive(sys_, ys, tol=tol, compact_mode=False)
                tcomp = time.perf_counter() - c0

                def core(ta=ta, ys=ys, tu=tu):
                    ta.time = 0.0
                    ta.state[:] = ys
                    return ta.propagate_grid(t / tu)

                tc, out = best_time(core, args.repeat)
                e = error(np.asarray(out[-1])[:, :3] * length)
                rows.append((label + " full", f"tol={tol:.0e} (order {ta.order})", e,
                             int(out[3]), None, tcomp, tc, None))  # fmt: skip

    print(f"One day, EGM2008 {DEGREE}x{DEGREE}, uniform Earth rotation, {t.size} samples; "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")  # fmt: skip
    print(f"reference: {ref_note}; error = max |dr| / |r0| over the samples\n")
    print("| method | setting | error | steps | RHS evals | compile [s] | core [ms] "
          "| public call [ms] |")  # fmt: skip
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for m, s, e, ns, nr, tcomp, tc, tp in rows:
        nrs = str(nr) if nr is not None else "–"
        tcs = f"{tcomp:.2f}" if tcomp is not None else "–"
        tps = f"{1e3 * tp:.2f}" if tp is not None else "–"
        print(f"| {m} | {s} | {e:.2e} | {ns} | {nrs} | {tcs} | {1e3 * tc:.2f} | {tps} |")
    best = {}
    for row in rows:
        if row[2] <= TARGET and (row[0] not in best or row[6] < best[row[0]][6]):
            best[row[0]] = row
    hy_best = min((r[6] for m, r in best.items() if m.startswith("heyoka")), default=None)
    print(f"\nCheapest setting with error <= {TARGET:g} ({TARGET * r0 * 1e3:.1f} mm):\n")
    print("| method | setting | error | core [ms] | / best heyoka |")
    print("| --- | --- | ---: | ---: | ---: |")
    for m, r in sorted(best.items(), key=lambda kv: kv[1][6]):
        ratio = f"{r[6] / hy_best:.2f}" if hy_best else "–"
        print(f"| {m} | {r[1]} | {r[2]:.2e} | {1e3 * r[6]:.2f} | {ratio} |")
    dop = best.get("DOP853 (ours)")
    if dop is not None:
        print(
            f"\nours: {dop[4]} RHS evaluations x {1e9 * t_acc:.0f} ns per acceleration "
            f"(20x20, measured alone) = {1e3 * dop[4] * t_acc:.2f} ms of {1e3 * dop[6]:.2f} ms"
        )
    tay = best.get("Taylor (ours)")
    if tay is not None and dop is not None:
        print(
            f"Taylor (ours): {tay[3]} steps, {1e6 * tay[6] / tay[3]:.1f} us a step; "
            f"{tay[6] / dop[6]:.2f}x DOP853's time"
        )
    state = "empty: compiled" if cold else "filled: loaded" if cache_dir else "default dir"
    print(
        f"ours, first call in the process (numba cache {state}): {t_first:.2f} s; "
        f"second call {t_second * 1e3:.1f} ms; import orbit {t_import:.2f} s"
    )
    if hy is None:
        print("\n(heyoka not installed: its rows are skipped)")


if __name__ == "__main__":
    main()

"""The CubeSat day (scenarios/cubesat_environment.toml): wall time and the cost of each torque.

1. ``attitude run``'s work, step by step: loading the scenario (SGP4 table), preparing the
   environment tables (astropy frames, IGRF, NRLMSIS, the Sun), integrating one day with all
   five models (dop853, rtol 1e-10), and the per-model torque output.
2. The cost of one torque evaluation of each model in a compiled loop over the day (monotonic
   times, random attitudes and rates), against the gravity gradient's: the performance goal is
   that each environment model costs less than one gravity-gradient evaluation.
3. The same day integrated with each model alone: time per right-hand side, stepping included.

Run: ``python benchmarks/environment.py`` (times are best of 9 or 3 in this process; the machine is
shared, so ratios matter more than absolute times).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from attitude import scenario
from attitude._core.potentials import builtin_torque
from attitude.propagate import propagate
from orbit._shared_jit import jit

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "cubesat_environment.toml"


# Compiled as the built-in integrators are (attitude._core.entry_points: no reference counting),
# so the row views q[k] cost what they cost inside a right-hand side.
@jit(cache=False, _nrt=False)
def torque_loop(q, w, t, params):
    s = 0.0
    for k in range(t.shape[0]):
        tau = builtin_torque(q[k], (w[k, 0], w[k, 1], w[k, 2]), t[k], params)
        s += tau[0] + tau[1] + tau[2]
    return s


def best_of(f, n=5):
    best = np.inf
    out = None
    for _ in range(n):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    t0 = time.perf_counter()
    sc = scenario.load(SCENARIO)
    t_load = time.perf_counter() - t0
    model = sc.potential
    t0 = time.perf_counter()
    model.prepare(sc.t)
    t_prep = time.perf_counter() - t0
    inertia = sc.body.inertia
    # warm up (cached kernels load from disk; a cold cache compiles here)
    propagate(sc.body, sc.q0, sc.Q0, sc.t[:3], model, rtol=sc.rtol, atol=sc.atol)

    def run():
        return propagate(sc.body, sc.q0, sc.Q0, sc.t, model, rtol=sc.rtol, atol=sc.atol)

    t_run, ds = best_of(run, 3)
    print(f"CubeSat day ({SCENARIO.name}): {sc.t.size} samples, rtol {sc.rtol:g}")
    print(f"  load scenario (SGP4 table)          {t_load:7.3f} s")
    print(f"  environment tables (all models)     {t_prep:7.3f} s")
    print(
        f"  propagate, 5 models (best of 3)     {t_run:7.3f} s  ({ds.attrs['n_steps']} steps, "
        f"{ds.attrs['n_rhs']} RHS, {1e6 * t_run / ds.attrs['n_rhs']:.2f} us per RHS incl. "
        "stepping and output)"
    )

    # 2. one torque evaluation per model, compiled loop
    n = 1_000_000
    rng = np.random.default_rng(1)
    t = np.linspace(sc.t[0], sc.t[-1], n)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = rng.normal(scale=0.1, size=(n, 3))
    rows = []
    from attitude.potentials import TorqueFree

    base = TorqueFree()._params(inertia)
    torque_loop(q[:10], w[:10], t[:10], base)
    dt0, _ = best_of(lambda: torque_loop(q, w, t, base), 9)
    for term in model.terms:
        params = term._params(inertia)
        torque_loop(q[:10], w[:10], t[:10], params)  # compile once per process
        dt, _ = best_of(lambda p=params: torque_loop(q, w, t, p), 9)
        rows.append((term.name, 1e9 * dt / n))
    params = model._params(inertia)
    dt, _ = best_of(lambda: torque_loop(q, w, t, params))
    rows.append(("sum of the five", 1e9 * dt / n))
    loop = 1e9 * dt0 / n
    gg = rows[0][1] - loop
    print(f"  one torque evaluation, compiled loop over {n} samples of the day (best of 9);")
    print(f"  the loop itself (torque-free model) costs {loop:.1f} ns and is subtracted:")
    for name, ns in rows:
        print(f"    {name:<22} {ns - loop:7.1f} ns   {(ns - loop) / gg:5.2f} x gravity gradient")

    # 3. the day with each model alone: time per right-hand side
    print("  the day with one model (dop853, best of 5): time per RHS incl. stepping and output;")
    print(
        "  the model's share: minus the torque-free run's time per RHS (the gravity gradient runs"
    )
    print("  on its own specialised entry points, the environment models on the generic ones)")
    per = {}
    for term in (TorqueFree(), *model.terms):

        def one(term=term):
            return propagate(sc.body, sc.q0, sc.Q0, sc.t, term, rtol=sc.rtol, atol=sc.atol)

        one()
        dt, d = best_of(one, 5)
        per[term.name] = 1e9 * dt / d.attrs["n_rhs"]
        share = per[term.name] - per["torque_free"]
        ratio = share / (per.get("gravity_gradient", np.nan) - per["torque_free"])
        print(
            f"    {term.name:<22} {dt:7.4f} s  {d.attrs['n_rhs']:8d} RHS  "
            f"{per[term.name]:6.1f} ns per RHS, the model's share {share:5.1f} ns"
            + (f"  {ratio:5.2f} x gravity gradient" if term.name != "torque_free" else "")
        )


if __name__ == "__main__":
    main()

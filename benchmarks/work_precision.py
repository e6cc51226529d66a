"""Work–precision of the formulations of rigid-body rotation, side by side.

Run: ``python benchmarks/work_precision.py`` (``--quick`` for fewer tolerances). Writes
``docs/figures/work_precision.png`` (error at the final time against wall time, one panel per
scenario) and ``docs/figures/work_precision_drift.png`` (long-run drift of |q| and of the
energy), and prints the tables behind them, including the number of right-hand-side
evaluations.

Scenarios (Arribas, Elipe & Palacios 2006, Sect. 6, with the paper's initial state
q0 = (0.5, −1/√2, 0, 0.5), Q0 = (0.3, −0.848528, 0.141421, −1.5) projected onto the manifold):

* ``torque_free``: I = (1.25, 1, 0.75), t ∈ [0, 100]. Reference: the exact solution
  (:func:`attitude.exact.torque_free`).
* ``heavy_top``: the same body, weight 0.5 at (1, 0, 0), t ∈ [0, 100]. Reference: canonical
  DOP853 at rtol 1e-15 (its distance to Euler's equations at rtol 1e-15 is printed as the floor).
* ``keplerian``: I = (400, 500, 600) kg km², gravity gradient on the orbit a = 7000 km,
  e = 0.2, i = π/6, Ω = π/4, ω = π/12, f0 = 0, over one orbital period (≈ 5829 s). Reference as
  for the heavy top.

Error: rotation angle (rad) between the attitude at the final time and the reference, and the
relative error of the body angular momentum g there; the figure plots the larger of the two.
Work: wall time of the formulation's ``run`` on a prepared problem (validation and Dataset
building excluded; conversions to and from the formulation's variables included), best of
several repetitions after a warm-up call (compilation excluded), in this process.

Methods: the compiled ``"dop853"`` and scipy's ``"scipy:DOP853"`` and ``"scipy:RK45"`` for all
formulations (``"scipy:Radau"`` too unless ``--quick``), and the canonical-only symplectic
fixed-step ``"splitting"`` and ``"nosquish"`` (order 4, step sweep).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from attitude import canonical as C  # noqa: E402
from attitude import quaternion as qt  # noqa: E402
from attitude.body import RigidBody  # noqa: E402
from attitude.formulations import FORMULATIONS  # noqa: E402
from attitude.potentials import GravityGradient, HeavyTop, as_potential  # noqa: E402
from attitude.propagate import Problem, _lookup_method, propagate  # noqa: E402

FIG_DIR = ROOT / "docs" / "figures"
NAMES = ("canonical", "euler_angles", "schwab", "euler_equations")
COLORS = {
    "canonical": "tab:blue",
    "euler_angles": "tab:orange",
    "schwab": "tab:green",
    "euler_equations": "tab:red",
}
STYLES = {
    "dop853": ("-", "o"),
    "scipy:DOP853": ("--", "s"),
    "scipy:RK45": (":", "^"),
    "scipy:Radau": ("-.", "v"),
    "splitting": ("-", "D"),
    "nosquish": ("--", "P"),
}


def paper_state():
    q0 = np.array([0.5, -1 / math.sqrt(2), 0.0, 0.5])
    Q0 = np.array([0.3, -0.848528, 0.141421, -1.5])
    q, Q, _ = C.project_state(q0, Q0)
    return q, Q


def scenarios():
    import orbit

    out = {
        "torque_free": (np.array([1.25, 1.0, 0.75]), None, 100.0),
        "heavy_top": (np.array([1.25, 1.0, 0.75]), HeavyTop(0.5, [1.0, 0.0, 0.0]), 100.0),
    }
    if hasattr(orbit, "KeplerOrbit"):
        orb = orbit.KeplerOrbit(7000.0, 0.2, math.pi / 6, math.pi / 4, math.pi / 12, f0=0.0)
        out["keplerian"] = (np.array([400.0, 500.0, 600.0]), GravityGradient(orb), orb.period)
    else:
        print("keplerian: skipped (orbit.KeplerOrbit not available)")
    return out


def make_problem(inertia, potential, q0, Q0, t):
    body = RigidBody(inertia)
    pot = as_potential(potential).bind(body)
    return Problem(
        body=body,
        potential=pot,
        params=pot._params(body.inertia),
        y0=np.concatenate([q0, Q0]),
        t=np.asarray(t, dtype=np.float64),
        entry=pot._entry_points(),
    )


def run_once(problem, name, method, tol_or_dt):
    runner, extra = _lookup_method(method)
    opts = dict(extra, max_steps=100_000_000)
    if method in ("splitting", "nosquish"):
        opts.update(dt=tol_or_dt, order=4)
    else:
        opts.update(rtol=tol_or_dt, atol=1e-2 * tol_or_dt)
    return FORMULATIONS[name].run(problem, method=method, runner=runner, **opts)


def timed(problem, name, method, tol_or_dt, budget):
    result = run_once(problem, name, method, tol_or_dt)  # warm-up (compilation)
    best = math.inf
    spent = 0.0
    reps = 0
    while reps < 3 or (spent < budget and reps < 50):
        t0 = time.perf_counter()
        result = run_once(problem, name, method, tol_or_dt)
        dt = time.perf_counter() - t0
        best = min(best, dt)
        spent += dt
        reps += 1
        if dt > budget:
            break
    return result, best


def error_of(y, ref):
    q, Q = y[:4], y[4:]
    qn = q / np.linalg.norm(q)
    ang = float(qt.angle_between(qn, ref[:4]))
    g = 0.5 * qt.multiply(qt.conjugate(qn), Q)[1:]
    g_ref = 0.5 * qt.multiply(qt.conjugate(ref[:4]), ref[4:])[1:]
    return ang, float(np.linalg.norm(g - g_ref) / np.linalg.norm(g_ref))


def reference(name, inertia, pot, q0, Q0, t_end):
    if pot is None:
        from attitude.exact import torque_free

        q, Q = torque_free(inertia, q0, Q0, [t_end])
        return np.concatenate([q[0], Q[0]]), 0.0
    kw = dict(potential=pot, rtol=1e-15, atol=1e-17)
    a = propagate(inertia, q0, Q0, [0.0, t_end], **kw)
    b = propagate(inertia, q0, Q0, [0.0, t_end], formulation="euler_equations", **kw)
    ref = np.concatenate([a.q.values[-1], a.Q.values[-1]])
    floor = max(error_of(np.concatenate([b.q.values[-1], b.Q.values[-1]]), ref))
    return ref, floor


def work_precision(quick):
    q0, Q0 = paper_state()
    tols = [1e-5, 1e-7, 1e-9, 1e-11, 1e-13] if quick else [10.0**-k for k in range(4, 15)]
    scipy_tols = [1e-5, 1e-8, 1e-11] if quick else [1e-5, 1e-7, 1e-9, 1e-11, 1e-13]
    methods = ["dop853", "scipy:DOP853", "scipy:RK45"] + ([] if quick else ["scipy:Radau"])
    rows = []
    for scen, (inertia, pot, t_end) in scenarios().items():
        ref, floor = reference(scen, inertia, pot, q0, Q0, t_end)
        print(f"\n== {scen}: t_end = {t_end:.6g}, reference floor {floor:.1e}")
        print(
            f"{'formulation':16s} {'method':13s} {'tol/dt':>8s} {'angle err':>10s} "
            f"{'g rel err':>10s} {'time [s]':>10s} {'n_rhs':>9s}"
        )
        problem = make_problem(inertia, pot, q0, Q0, [0.0, t_end])
        budget = 0.3 if quick else 1.0
        for name in NAMES:
            plan = [(m, tols if m == "dop853" else scipy_tols) for m in methods]
            if name == "canonical":
                scale = t_end / 100.0
                dts = [0.2, 0.1, 0.05, 0.025] if quick else [0.4, 0.2, 0.1, 0.05, 0.025, 0.0125]
                plan += [(m, [d * scale for d in dts]) for m in ("splitting", "nosquish")]
            for method, values in plan:
                if method == "scipy:Radau":
                    values = [v for v in values if v >= 1e-10]
                for v in values:
                    try:
                        result, wall = timed(problem, name, method, v, budget)
                    except Exception as exc:  # a method that cannot run this case
                        print(f"{name:16s} {method:13s} {v:8.1e} failed: {exc}")
                        continue
                    if result.status != 0 or result.y.shape[0] < 2:
                        print(f"{name:16s} {method:13s} {v:8.1e} failed: {result.message}")
                        continue
                    ang, grel = error_of(result.y[-1], ref)
                    n_rhs = int(result.stats.get("n_rhs", -1))
                    rows.append((scen, name, method, v, ang, grel, wall, n_rhs))
                    print(
                        f"{name:16s} {method:13s} {v:8.1e} {ang:10.2e} {grel:10.2e} "
                        f"{wall:10.2e} {n_rhs if n_rhs >= 0 else '—':>9}"
                    )
    return rows


def drift(quick):
    """Long runs: |q| − 1, energy error, and Schwab's q·q̇ at fixed tolerance."""
    q0, Q0 = paper_state()
    t_end = 2000.0 if quick else 10000.0
    t = np.linspace(0.0, t_end, 401)
    out = {}
    cases = {
        "torque_free": (np.array([1.25, 1.0, 0.75]), None),
        "heavy_top": (np.array([1.25, 1.0, 0.75]), HeavyTop(0.5, [1.0, 0.0, 0.0])),
    }
    print(f"\n== long runs, t ∈ [0, {t_end:g}], rtol 1e-10 (splitting: order 4, dt 0.05)")
    print(
        f"{'case':12s} {'formulation':16s} {'max||q|-1|':>11s} {'max|ΔE|/|E|':>12s} "
        f"{'max|q.qdot|':>11s} {'n_rhs':>10s} {'time [s]':>9s}"
    )
    for case, (inertia, pot) in cases.items():
        runs = [(n, "dop853", {}) for n in NAMES] + [("canonical", "splitting", {"dt": 0.05})]
        for name, method, extra in runs:
            kw = dict(potential=pot, formulation=name, method=method, **extra)
            if method == "dop853":
                kw.update(rtol=1e-10, atol=1e-12)
            t0 = time.perf_counter()
            try:
                ds = propagate(inertia, q0, Q0, t, **kw)
            except Exception as exc:
                print(f"{case:12s} {name:16s} failed: {exc}")
                continue
            wall = time.perf_counter() - t0
            E = ds.energy.values
            dE = np.abs(E - E[0]) / abs(E[0])
            ne = np.abs(ds.norm_error.values)
            qqd = ds.attrs.get("max_abs_qdot_q", float("nan"))
            label = name if method == "dop853" else f"{name}/{method}"
            out[(case, label)] = (t, ne, dE)
            print(
                f"{case:12s} {label:16s} {ne.max():11.2e} {dE.max():12.2e} {qqd:11.2e} "
                f"{int(ds.attrs['n_rhs']) if 'n_rhs' in ds.attrs else '—':>10} {wall:9.2f}"
            )
    return out


def plot_work_precision(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scens = list(dict.fromkeys(r[0] for r in rows))
    fig, axes = plt.subplots(1, len(scens), figsize=(5.2 * len(scens), 4.6), squeeze=False)
    for ax, scen in zip(axes[0], scens, strict=True):
        keys = list(dict.fromkeys((r[1], r[2]) for r in rows if r[0] == scen))
        for name, method in keys:
            pts = sorted(
                (r[6], max(r[4], r[5], 1e-17))
                for r in rows
                if r[0] == scen and r[1] == name and r[2] == method
            )
            ls, mk = STYLES[method]
            ax.loglog(
                [p[0] for p in pts],
                [p[1] for p in pts],
                ls=ls,
                marker=mk,
                ms=4,
                color=COLORS[name],
                label=f"{name} · {method}",
            )
        ax.set_title(scen.replace("_", " "))
        ax.set_xlabel("wall time of the run [s]")
        ax.grid(True, which="major", alpha=0.3)
    axes[0][0].set_ylabel("error at the final time (max of angle [rad], |Δg|/|g|)")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, 0.16, 1, 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


def plot_drift(data, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(k[0] for k in data))
    fig, axes = plt.subplots(2, len(cases), figsize=(5.5 * len(cases), 6.5), squeeze=False)
    for j, case in enumerate(cases):
        for (c, label), (t, ne, dE) in data.items():
            if c != case:
                continue
            name = label.split("/")[0]
            ls = "-" if "/" not in label else "--"
            axes[0][j].semilogy(
                t[1:], np.maximum(ne[1:], 1e-17), ls, color=COLORS[name], label=label
            )
            axes[1][j].semilogy(
                t[1:], np.maximum(dE[1:], 1e-17), ls, color=COLORS[name], label=label
            )
        axes[0][j].set_title(f"{case.replace('_', ' ')}: | |q| − 1 |")
        axes[1][j].set_title(f"{case.replace('_', ' ')}: |E − E0| / |E0|")
        axes[1][j].set_xlabel("t")
        for i in range(2):
            axes[i][j].grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer tolerances, shorter runs")
    parser.add_argument("--no-plot", action="store_true", help="print the tables only")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore", UserWarning)  # the paper's Q0 is projected (6 digits)
    t0 = time.perf_counter()
    rows = work_precision(args.quick)
    data = drift(args.quick)
    if not args.no_plot:
        FIG_DIR.mkdir(parents=True, exist_ok=True)
        plot_work_precision(rows, FIG_DIR / "work_precision.png")
        plot_drift(data, FIG_DIR / "work_precision_drift.png")
        print(
            f"\nfigures: {FIG_DIR / 'work_precision.png'}, {FIG_DIR / 'work_precision_drift.png'}"
        )
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()

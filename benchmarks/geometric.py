"""Work–precision of the symplectic methods against DOP853, the exact solution and heyoka.

Run: ``python benchmarks/geometric.py`` (``--quick`` for fewer settings). heyoka is an optional
peer: when it is importable, its Taylor integrator runs on the same eight equations (eq. 7 in
(q, Q)); otherwise its rows are skipped. It is never a dependency of the package; to compare,
install it in a scratch environment with this package on PYTHONPATH.

Case 1 — torque-free body of Arribas, Elipe & Palacios (2006) Sect. 6.1 (I = 1.25, 1, 0.75),
t ∈ [0, 1000] with 101 output samples: attitude error (rotation angle, rad) at t = 1000 against
the exact solution (:func:`attitude.exact.torque_free`), and wall time of the run.

Case 2 — a weak heavy top (weight 0.01 instead of the paper's 0.5; a near-integrable system like
a spacecraft under environmental torques), t ∈ [0, 1000]: error against DOP853 at rtol 1e-14.

Times are the best of several repetitions after a warm-up call (compilation excluded), measured
in this process. "core" is the integrator alone (the method runner on a prepared problem, or
heyoka's ``propagate_grid``); "propagate" is the whole public call, including validation and
building the xarray Dataset with its diagnostics.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from attitude import canonical as C
from attitude import quaternion as qt
from attitude._methods import run_dop853
from attitude.body import RigidBody
from attitude.potentials import HeavyTop, as_potential
from attitude.propagate import METHODS, Problem, propagate

I_PAPER = np.array([1.25, 1.0, 0.75])
T_END = 1000.0
N_OUT = 101


def paper_state():
    q0 = np.array([0.5, -1 / math.sqrt(2), 0.0, 0.5])
    Q0 = np.array([0.3, -0.848528, 0.141421, -1.5])
    q, Q, _ = C.project_state(q0, Q0)
    return q, Q


def make_problem(q0, Q0, t, potential):
    body = RigidBody(I_PAPER)
    pot = as_potential(potential).bind(body)
    return Problem(
        body=body,
        potential=pot,
        params=pot._params(body.inertia),
        y0=np.concatenate([q0, Q0]),
        t=t,
        entry=pot._entry_points(),
    )


def best_time(fn, repeat):
    fn()  # warm-up (compilation, caches)
    best = math.inf
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def repeats_for(seconds):
    return max(2, min(20, int(0.5 / max(seconds, 1e-6))))


# --------------------------------------------------------------------------------------------
# heyoka (optional)
# --------------------------------------------------------------------------------------------


def heyoka_integrator(q0, Q0, potential, tol):
    """heyoka's Taylor integrator on eq. 7 (or None when heyoka is not installed)."""
    try:
        import heyoka as hy
    except ImportError:
        return None
    q = hy.make_vars("q0", "q1", "q2", "q3")
    Q = hy.make_vars("p0", "p1", "p2", "p3")
    I1, I2, I3 = (float(x) for x in I_PAPER)
    # w = q̃∘Q (vector part); ω = ½ w / I
    w1 = q[0] * Q[1] - q[1] * Q[0] - q[2] * Q[3] + q[3] * Q[2]
    w2 = q[0] * Q[2] + q[1] * Q[3] - q[2] * Q[0] - q[3] * Q[1]
    w3 = q[0] * Q[3] - q[1] * Q[2] + q[2] * Q[1] - q[3] * Q[0]
    om = (0.5 * w1 / I1, 0.5 * w2 / I2, 0.5 * w3 / I3)

    def mul_vec(a, v):
        return (
            -a[1] * v[0] - a[2] * v[1] - a[3] * v[2],
            a[0] * v[0] + a[2] * v[2] - a[3] * v[1],
            a[0] * v[1] - a[1] * v[2] + a[3] * v[0],
            a[0] * v[2] + a[1] * v[1] - a[2] * v[0],
        )

    dq = [0.5 * x for x in mul_vec(q, om)]
    dQ = [0.5 * x for x in mul_vec(Q, om)]
    if isinstance(potential, HeavyTop):
        W = potential.weight
        c = potential.center_of_mass
        # F_B = q̃∘(−W s3)∘q; τ_B = c × F_B
        fb = (
            -W * 2.0 * (q[1] * q[3] - q[0] * q[2]),
            -W * 2.0 * (q[2] * q[3] + q[0] * q[1]),
            -W * (q[0] * q[0] - q[1] * q[1] - q[2] * q[2] + q[3] * q[3]),
        )
        tau = (
            c[1] * fb[2] - c[2] * fb[1],
            c[2] * fb[0] - c[0] * fb[2],
            c[0] * fb[1] - c[1] * fb[0],
        )
        f = mul_vec(q, tau)
        dQ = [dQ[i] + 2.0 * f[i] for i in range(4)]
    sys_ = [(q[i], dq[i]) for i in range(4)] + [(Q[i], dQ[i]) for i in range(4)]
    y0 = np.concatenate([q0, Q0])
    return hy.taylor_adaptive(sys_, y0, tol=tol), y0


# --------------------------------------------------------------------------------------------
# The table
# --------------------------------------------------------------------------------------------


def run_case(title, q0, Q0, potential, truth_q, settings, heyoka_tols, target):
    t = np.linspace(0.0, T_END, N_OUT)
    problem = make_problem(q0, Q0, t, potential)
    rows = []

    def add(name, setting, core_fn, prop_fn):
        tc, y = best_time(core_fn, 3)
        tc, y = best_time(core_fn, repeats_for(tc))
        err = float(qt.angle_between(y[-1, :4], truth_q[-1]))
        tp = None
        if prop_fn is not None:
            tp, _ = best_time(prop_fn, repeats_for(tc))
        rows.append((name, setting, err, tc, tp))

    for rtol in settings["dop853"]:
        add(
            "dop853",
            f"rtol={rtol:.0e}",
            lambda rtol=rtol: run_dop853(problem, rtol=rtol, atol=rtol * 1e-2).y,
            lambda rtol=rtol: propagate(
                I_PAPER, q0, Q0, t, potential=potential, rtol=rtol, atol=rtol * 1e-2
            ),
        )
    for method in ("nosquish", "splitting"):
        for order, dts in settings[method].items():
            for dt in dts:
                add(
                    f"{method}-{order}",
                    f"dt={dt:g}",
                    lambda m=method, o=order, dt=dt: METHODS[m](problem, dt=dt, order=o).y,
                    lambda m=method, o=order, dt=dt: propagate(
                        I_PAPER, q0, Q0, t, potential=potential, method=m, dt=dt, order=o
                    ),
                )
    if potential is None:
        from attitude.exact import torque_free

        add(
            "exact",
            "closed form",
            lambda: np.concatenate(torque_free(I_PAPER, q0, Q0, t), axis=1),
            (lambda: propagate(I_PAPER, q0, Q0, t, method="exact")) if "exact" in METHODS else None,
        )
    have_heyoka = False
    for tol in heyoka_tols:
        made = heyoka_integrator(q0, Q0, potential, tol)
        if made is None:
            break
        have_heyoka = True
        ta, y0 = made

        def core(ta=ta, y0=y0):
            ta.time = 0.0
            ta.state[:] = y0
            return ta.propagate_grid(t)[-1]

        add("heyoka", f"tol={tol:.0e}", core, None)

    print(f"\n## {title}\n")
    print("| method | setting | attitude error at t=1000 [rad] | core [ms] | propagate() [ms] |")
    print("| --- | --- | ---: | ---: | ---: |")
    for name, setting, err, tc, tp in rows:
        tps = f"{1e3 * tp:.2f}" if tp is not None else "–"
        print(f"| {name} | {setting} | {err:.1e} | {1e3 * tc:.3f} | {tps} |")
    if not have_heyoka:
        print("\n(heyoka not installed: its rows are skipped)")

    # Cheapest setting reaching the target error, per method family, and ratios.
    best = {}
    for name, setting, err, tc, _ in rows:
        fam = name.split("-")[0] if name.startswith(("nosquish", "splitting")) else name
        if err <= target and (fam not in best or tc < best[fam][1]):
            best[fam] = (f"{name} {setting}", tc, err)
    print(f"\nFastest setting with attitude error <= {target:g} at t = 1000 (core time):\n")
    ref = best.get("heyoka") or best.get("dop853")
    ref_name = "heyoka" if "heyoka" in best else "dop853"
    print(f"| family | setting | error | core [ms] | time / {ref_name} |")
    print("| --- | --- | ---: | ---: | ---: |")
    for fam, (setting, tc, err) in sorted(best.items(), key=lambda kv: kv[1][1]):
        ratio = f"{tc / ref[1]:.3f}" if ref else "–"
        print(f"| {fam} | {setting} | {err:.1e} | {1e3 * tc:.3f} | {ratio} |")
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer settings")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    q0, Q0 = paper_state()
    t = np.linspace(0.0, T_END, N_OUT)

    if args.quick:
        free_settings = {
            "dop853": [1e-10, 1e-13],
            "nosquish": {4: [0.01], 6: [0.05]},
            "splitting": {2: [10.0], 6: [10.0]},
        }
        heyoka_tols = [1e-12, 1e-15]
    else:
        free_settings = {
            "dop853": [1e-8, 1e-10, 1e-12, 1e-13, 1e-14],
            "nosquish": {2: [0.01, 0.001], 4: [0.05, 0.02, 0.01], 6: [0.1, 0.05, 0.025]},
            "splitting": {2: [10.0, 1.0], 4: [10.0], 6: [10.0]},
        }
        heyoka_tols = [1e-9, 1e-11, 1e-12, 1e-13, 1e-15]

    from attitude.exact import torque_free

    truth_q, _ = torque_free(I_PAPER, q0, Q0, t)
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}")
    try:
        import heyoka

        print(f"heyoka {heyoka.__version__}")
    except ImportError:
        pass
    run_case(
        "Torque-free body (Arribas et al. Sect. 6.1), t = 0..1000, 101 outputs",
        q0,
        Q0,
        None,
        truth_q,
        free_settings,
        heyoka_tols,
        1e-11,
    )

    weak = HeavyTop(0.01, [1.0, 0.0, 0.0])
    ref = propagate(I_PAPER, q0, Q0, t, potential=weak, rtol=1e-14, atol=1e-16)
    if args.quick:
        weak_settings = {
            "dop853": [1e-10],
            "nosquish": {4: [0.02]},
            "splitting": {4: [0.1], 6: [0.2]},
        }
    else:
        weak_settings = {
            "dop853": [1e-8, 1e-10, 1e-12],
            "nosquish": {2: [0.01], 4: [0.05, 0.02], 6: [0.1, 0.05]},
            "splitting": {2: [0.05, 0.01], 4: [0.2, 0.1], 6: [0.4, 0.2]},
        }
    run_case(
        "Weak heavy top (weight 0.01, c = e1), t = 0..1000; truth: DOP853 rtol 1e-14",
        q0,
        Q0,
        weak,
        ref.q.values,
        weak_settings,
        [1e-10, 1e-12],
        1e-9,
    )


if __name__ == "__main__":
    main()

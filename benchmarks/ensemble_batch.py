"""Ensembles per core against heyoka's batch mode, at the same accuracy (issue 17).

The case of the issue: the paper's Sect. 6.2 (Arribas, Elipe & Palacios 2006: gravity gradient
in the Kepler orbit a = 7000 km, e = 0.2; I = 400, 500, 600 kg km², the printed (q, Q), in the
paper's units kg km², km, s), 2000 members dispersed by 1 % (every component of q, Q and the
three moments multiplied by 1 + 0.01 N(0, 1), seed 2006, states projected onto |q| = 1,
q·Q = 0), one orbit, 101 output times shared by all members.

Ours: :func:`attitude.ensemble.propagate_ensemble` (the whole public call: validation,
compiled loop, diagnostics, the Dataset) on 1 and 2 numba threads, and the compiled loop alone
("core", the chunk driver with the diagnostics). heyoka (optional peer, never a dependency):
``taylor_adaptive_batch`` with batch size 4 (its recommended SIMD width here), the inertia as
``par[0..2]``, ONE integrator reused over the 500 batches (state, pars and time reset, then
``propagate_grid``), on one core; also its orbit in units of a (its error norm mixes all
variables; see benchmarks/taylor.py).

Same accuracy: the error of every setting is measured on the first ``--n-err`` members
against a reference (heyoka's scalar integrator in long double, tol 1e-19, when heyoka is
available; else our ``taylor`` at rtol 1e-15 in double, flagged): the maximum over members and
samples of max(|Δq|∞, |ΔQ|∞ / max|Q|). For each integrator the cheapest setting with error
≤ 1e-9 is compared. Times are the best of ``--repeat`` runs after a warm-up (compilation
excluded), as wall time and as this process's CPU time: on one thread the CPU time is the cost
per core, and unlike the wall time it does not grow when other jobs share the machine (the
ratios to heyoka use it; the two-thread rows use wall time).

heyoka runs in this process when importable, else in a subprocess of ``--heyoka-python``
(an interpreter with heyoka and numpy; the members go through a temporary .npz file), else its
rows are skipped.

Run: ``python benchmarks/ensemble_batch.py [--quick] [--heyoka-python /path/to/python]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1e-9
A, E = 7000.0, 0.2
ELEMENTS = (A, E, math.pi / 6, math.pi / 4, math.pi / 12)  # a, e, i, Ω, ω; f0 = 0
INERTIA = np.array([400.0, 500.0, 600.0])
Q_PAPER = np.array([0.5, -1 / math.sqrt(2), 0.0, 0.5])
P_PAPER = np.array([0.3, -0.848528, 0.141421, -1.5])


def best_time(fn, repeat):
    """(best wall time, best CPU time of this process, last result) over ``repeat`` runs after
    a warm-up. The CPU time is what one core spends (the machine may be shared: a run that
    waits for the CPU costs wall time, not CPU time); for one thread it is the per-core cost."""
    fn()  # warm-up (and compilation)
    wall = cpu = math.inf
    out = None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - t0)
    return wall, cpu, out


BUSY = (
    "import time\nt0 = time.perf_counter()\ns = 0\nfor i in range(5_000_000):\n    s += i\n"
    "print(time.perf_counter() - t0)"
)


def free_cores() -> float:
    """Cores' worth of CPU two independent processes get at once (2.0 on an idle 2-core box):
    what a second thread can add (benchmarks/ensemble.py measures it the same way)."""
    one = float(subprocess.run([sys.executable, "-c", BUSY], capture_output=True).stdout)
    procs = [subprocess.Popen([sys.executable, "-c", BUSY], stdout=subprocess.PIPE)
             for _ in range(2)]  # fmt: skip
    return sum(one / float(p.communicate()[0]) for p in procs)


def error(y, ref):
    """max over members and samples of max(|Δq|∞, |ΔQ|∞ / max|Q|); y, ref (n, m, ≥8)."""
    q = np.max(np.abs(y[..., :4] - ref[..., :4]))
    Q = np.max(np.abs(y[..., 4:8] - ref[..., 4:8])) / np.max(np.abs(ref[..., 4:8]))
    return float(max(q, Q))


# --------------------------------------------------------------------------------------------
# heyoka (this process or a subprocess of another interpreter)
# --------------------------------------------------------------------------------------------
def _heyoka_system(hy, length, mu_km):
    """Eq. 7 with the gravity gradient and the two-body equations (r in units of ``length``
    km), the moments of inertia as par[0], par[1], par[2]."""
    q = hy.make_vars("q0", "q1", "q2", "q3")
    Q = hy.make_vars("p0", "p1", "p2", "p3")
    x, y, z, vx, vy, vz = hy.make_vars("x", "y", "z", "vx", "vy", "vz")
    inertia = (hy.par[0], hy.par[1], hy.par[2])

    # the package's quaternion kernels as plain Python: they build heyoka expressions too
    from attitude._core import quat
    from orbit._shared_jit import interpreted

    qk = interpreted(quat)
    mul_vec, rotate_inverse, cross = qk.mul_vec, qk.rotate_inverse, qk.cross

    w1 = q[0] * Q[1] - q[1] * Q[0] - q[2] * Q[3] + q[3] * Q[2]
    w2 = q[0] * Q[2] + q[1] * Q[3] - q[2] * Q[0] - q[3] * Q[1]
    w3 = q[0] * Q[3] - q[1] * Q[2] + q[2] * Q[1] - q[3] * Q[0]
    om = (0.5 * w1 / inertia[0], 0.5 * w2 / inertia[1], 0.5 * w3 / inertia[2])
    dq = [0.5 * c for c in mul_vec(q, om)]
    dQ = [0.5 * c for c in mul_vec(Q, om)]
    mu = mu_km / length**3
    r2 = x * x + y * y + z * z
    ir3 = r2**-1.5
    xb = rotate_inverse(q, (x, y, z))
    ixb = tuple(inertia[i] * xb[i] for i in range(3))
    k = 3.0 * mu * r2**-2.5
    tau = tuple(k * c for c in cross(xb, ixb))
    f = mul_vec(q, tau)
    dQ = [dQ[i] + 2.0 * f[i] for i in range(4)]
    orbit_eqs = [(x, vx), (y, vy), (z, vz), (vx, -mu * x * ir3), (vy, -mu * y * ir3),
                 (vz, -mu * z * ir3)]  # fmt: skip
    return [(q[i], dq[i]) for i in range(4)] + [(Q[i], dQ[i]) for i in range(4)] + orbit_eqs


def heyoka_side(hy, data, tols, repeat, n_err, reference):
    """Times and errors of heyoka's batch mode (and the long-double reference if asked)."""
    y0, inertia, rv0, t = data["y0"], data["inertia"], data["rv0"], data["t"]
    mu = float(data["mu"])
    n = y0.shape[0]
    res = {"version": hy.__version__, "simd": int(hy.recommended_simd_size()), "rows": []}
    if reference:
        sys_ = _heyoka_system(hy, 1.0, mu)
        ld = np.longdouble
        ta = hy.taylor_adaptive(sys_, np.zeros(14, dtype=ld), tol=ld(1e-19), fp_type=ld,
                                pars=np.zeros(3, dtype=ld))  # fmt: skip
        ref = np.empty((n_err, t.size, 8))
        for i in range(n_err):
            ta.time = ld(0.0)
            ta.state[:] = np.concatenate([y0[i], rv0]).astype(ld)
            ta.pars[:] = inertia[i].astype(ld)
            ref[i] = np.asarray(ta.propagate_grid(t.astype(ld))[-1][:, :8], dtype=float)
        res["reference"] = ref
        res["reference_note"] = f"heyoka long double, tol 1e-19, order {ta.order}"
    for B, label, length in ((b, lab, ln) for b in (4, 8)
                             for lab, ln in ((f"heyoka batch {b}", 1.0),
                                             (f"heyoka batch {b} (r/a)", A))):  # fmt: skip
        nb = -(-n // B)
        sys_ = _heyoka_system(hy, length, mu)
        s0 = np.concatenate([y0, np.tile(rv0 / length, (n, 1))], axis=1)
        s0 = np.concatenate([s0, np.tile(s0[-1:], (nb * B - n, 1))])  # pad the last batch
        pars = np.concatenate([inertia, np.tile(inertia[-1:], (nb * B - n, 1))])
        grid = np.repeat(t[:, None], B, axis=1)
        for tol in tols:
            ta = hy.taylor_adaptive_batch(sys_, s0[:B].T.copy(), tol=tol, pars=pars[:B].T.copy())
            ys = np.empty((nb * B, t.size, 8))

            def run(ta=ta, s0=s0, pars=pars, grid=grid, ys=ys, B=B, nb=nb):
                for b in range(nb):
                    ta.set_time(0.0)
                    ta.state[:] = s0[b * B : (b + 1) * B].T
                    ta.pars[:] = pars[b * B : (b + 1) * B].T
                    out = ta.propagate_grid(grid)
                    ys[b * B : (b + 1) * B] = out[1][:, :8, :].transpose(2, 0, 1)
                return ys

            wall, cpu, ys = best_time(run, repeat)
            row = {"method": label, "setting": f"tol={tol:.0e}", "wall": wall, "cpu": cpu,
                   "y": ys[:n_err]}  # fmt: skip
            res["rows"].append(row)
    return res


def heyoka_in_subprocess(python, data, tols, repeat, n_err, reference):
    with tempfile.TemporaryDirectory() as tmp:
        inp = os.path.join(tmp, "in.npz")
        out = os.path.join(tmp, "out.npz")
        np.savez(inp, **data)
        args = json.dumps({"tols": tols, "repeat": repeat, "n_err": n_err, "ref": reference})
        env = {**os.environ, "PYTHONPATH": ""}
        cmd = [python, __file__, "--heyoka-worker", inp, out, args]
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
        if p.returncode:
            sys.stderr.write(p.stderr)
            return None
        with np.load(out, allow_pickle=True) as f:
            return f["res"].item()


def _worker(inp, out, args):
    import heyoka as hy

    sys.path.insert(0, str(ROOT))  # the package's quaternion kernels build the system

    a = json.loads(args)
    with np.load(inp) as f:
        data = {k: f[k] for k in f.files}
    res = heyoka_side(hy, data, a["tols"], a["repeat"], a["n_err"], a["ref"])
    np.savez(out, res=np.array(res, dtype=object))


# --------------------------------------------------------------------------------------------
# ours
# --------------------------------------------------------------------------------------------
def members(n, seed=2006, spread=0.01):
    rng = np.random.default_rng(seed)
    q = Q_PAPER * (1.0 + spread * rng.standard_normal((n, 4)))
    Q = P_PAPER * (1.0 + spread * rng.standard_normal((n, 4)))
    inertia = INERTIA * (1.0 + spread * rng.standard_normal((n, 3)))
    q /= np.linalg.norm(q, axis=1, keepdims=True)  # onto |q| = 1, q·Q = 0
    Q -= np.sum(q * Q, axis=1, keepdims=True) * q
    return np.concatenate([q, Q], axis=1), inertia


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer tolerances, fewer repeats")
    ap.add_argument("-n", type=int, default=2000, help="members (default 2000)")
    ap.add_argument("--n-err", type=int, default=40, help="members whose error is measured")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--heyoka-python", default=os.environ.get("HEYOKA_PYTHON"),
                    help="interpreter with heyoka (if it is not importable here)")  # fmt: skip
    ap.add_argument("--methods", default="dop853,taylor", help="our methods to run")
    ap.add_argument("--heyoka-worker", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.heyoka_worker:
        _worker(*args.heyoka_worker)
        return
    sys.path.insert(0, str(ROOT))
    warnings.simplefilter("ignore")
    import numba

    import orbit
    from attitude.ensemble import propagate_ensemble
    from attitude.ensemble._chunks import _compute_chunk, _Setup
    from attitude.potentials import GravityGradient

    repeat = 2 if args.quick else args.repeat
    n, n_err = args.n, min(args.n_err, args.n)
    o = orbit.KeplerOrbit(*ELEMENTS, f0=0.0)
    t = np.linspace(0.0, o.period, 101)
    y0, inertia = members(n)
    r0, v0 = o.to_state(0.0)
    data = {"y0": y0, "inertia": inertia, "rv0": np.concatenate([np.ravel(r0), np.ravel(v0)]),
            "t": t, "mu": np.float64(o.mu)}  # fmt: skip
    pot = GravityGradient(o)
    methods = args.methods.split(",")
    if args.quick:
        settings = {"dop853": [1e-10, 1e-11], "taylor": [2e-8, 1e-8, 1e-10],
                    "heyoka": [2e-8, 1e-8, 1e-12, 1e-13]}  # fmt: skip
    else:
        settings = {"dop853": [1e-10, 1e-11, 1e-12, 1e-13],
                    "taylor": [2e-8, 1e-8, 1e-9, 1e-10, 1e-12],
                    "heyoka": [2e-8, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-15]}  # fmt: skip

    hy_res = None
    hy_note = "heyoka not available (pass --heyoka-python): its rows are skipped"
    try:
        import heyoka as hy
    except ImportError:
        hy = None
    if hy is not None:
        hy_res = heyoka_side(hy, data, settings["heyoka"], repeat, n_err, True)
    elif args.heyoka_python:
        hy_res = heyoka_in_subprocess(args.heyoka_python, data, settings["heyoka"], repeat,
                                      n_err, True)  # fmt: skip
    if hy_res is not None:
        hy_note = f"heyoka {hy_res['version']} (recommended SIMD size {hy_res['simd']})"
        ref, ref_note = hy_res["reference"], hy_res["reference_note"]
    else:
        ds = propagate_ensemble(inertia[:n_err], y0[:n_err, :4], y0[:n_err, 4:], t, pot,
                                method="taylor" if "taylor" in methods else "dop853",
                                rtol=1e-15, atol=1e-15)  # fmt: skip
        ref = np.concatenate([ds["q"].values, ds["Q"].values], axis=-1)
        ref_note = "ours at rtol 1e-15 in double (no heyoka: install it for long double)"

    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, numba {numba.__version__}; "
          f"{hy_note}; load average {os.getloadavg()[0]:.2f}; two processes got "
          f"{free_cores():.2f} cores")  # fmt: skip
    print(f"\nSect. 6.2 gravity gradient, e = 0.2, {n} members dispersed by 1 %, one orbit "
          f"({o.period:.1f} s), {t.size} outputs")  # fmt: skip
    print(f"reference: {ref_note}; error over the first {n_err} members\n")

    rows = []  # (method, setting, threads, error, wall, cpu, steps/member)
    from attitude._core.lanes import WIDTHS, simd_lanes
    from attitude.ensemble._members import _member_potentials, _Members

    host = simd_lanes()
    runs = [(m, None) for m in methods if m != "taylor"]
    if "taylor" in methods:  # the CPU's width (the default) and the other one
        runs += [("taylor", host)] + [("taylor", w) for w in WIDTHS if w != host]
    for method, lanes in runs:
        if lanes is not None:
            os.environ["ATTITUDE_SIMD_LANES"] = str(lanes)
        name = method if lanes is None else f"{method} ({lanes} lanes)"
        for rtol in settings[method]:
            kw = {"method": method, "rtol": rtol, "atol": rtol}
            ds = propagate_ensemble(inertia[:n_err], y0[:n_err, :4], y0[:n_err, 4:], t, pot, **kw)
            y = np.concatenate([ds["q"].values, ds["Q"].values], axis=-1)
            err = error(y, ref)
            for threads in (1, 2):
                wall, cpu, ds = best_time(
                    lambda kw=kw, th=threads: propagate_ensemble(
                        inertia, y0[:, :4], y0[:, 4:], t, pot, threads=th, **kw
                    ),
                    repeat,
                )
                steps = float(ds.attrs["n_steps"]) / n
                cpu = cpu if threads == 1 else math.nan  # (summed over threads)
                rows.append((name, f"rtol={rtol:.0e}", threads, err, wall, cpu, steps))
            # the compiled loop alone (one chunk, one thread, diagnostics included)
            _, params1, _ = _member_potentials(pot, n, inertia)
            params, _, _, _ = _Members(y0[:, :4], y0[:, 4:], inertia, params1, n).block(0, n)
            setup = _Setup(t, rtol, rtol, math.inf, 100_000_000, method=method)
            wall, cpu, _ = best_time(lambda setup=setup, params=params: _compute_chunk(
                setup, params, y0, parallel=False), repeat)  # fmt: skip
            rows.append((name + " core", f"rtol={rtol:.0e}", 1, err, wall, cpu, steps))
        os.environ.pop("ATTITUDE_SIMD_LANES", None)
    if hy_res is not None:
        for r in hy_res["rows"]:
            e = error(r["y"], ref)
            rows.append((r["method"], r["setting"], 1, e, r["wall"], r["cpu"], math.nan))

    print("| method | setting | threads | error | steps/member | wall [s] | CPU [s] |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for m, s, th, e, w, c, st in rows:
        print(f"| {m} | {s} | {th} | {e:.1e} | {st:.1f} | {w:.4f} | {c:.4f} |")
    best = {}
    for m, s, th, e, w, c, _ in rows:
        key = (m.replace(" (r/a)", ""), th)
        cost = c if th == 1 else w
        if e <= TARGET and (key not in best or cost < best[key][2]):
            best[key] = (m, s, cost, e)
    print(f"\nCheapest setting with error <= {TARGET:g} (one thread: CPU time, i.e. per core; "
          "two threads: wall time):\n")  # fmt: skip
    hy1 = [v for (m, th), v in best.items() if m.startswith("heyoka batch") and th == 1]
    hyb = min(hy1, key=lambda v: v[2]) if hy1 else None  # heyoka's best batch size
    best_mode = hyb[0] if hyb else "–"
    print(f"(this CPU: {host} lanes by default; heyoka's best batch mode: {best_mode})\n")
    print("| method | threads | setting | error | time [s] | µs / member | time / heyoka's best |")
    print("| --- | ---: | --- | ---: | ---: | ---: | ---: |")
    for (_, th), (m, s, tc, e) in sorted(best.items(), key=lambda kv: kv[1][2]):
        ratio = f"{tc / hyb[2]:.2f}" if hyb else "–"
        print(f"| {m} | {th} | {s} | {e:.1e} | {tc:.4f} | {1e6 * tc / n:.1f} | {ratio} |")
    print(f"\nload average at end {os.getloadavg()[0]:.2f}; two processes got {free_cores():.2f} "
          "cores")  # fmt: skip


if __name__ == "__main__":
    main()

"""Benchmark of ensemble propagation (issue: ensembles at scale).

The paper's Sect. 6.2 case (Arribas, Elipe & Palacios 2006: gravity gradient in a Keplerian
orbit, a = 7000 km, e = 0.2) over one orbit (5828.5 s) at rtol 1e-10, atol 1e-12, with the
dispersions of scenarios/ensemble_paper_keplerian.toml (1 deg attitude, 2e-3 deg/s rate, 2 %
inertia errors, 1 sigma). Output: the final state of every member, streamed to a temporary
netCDF file chunk by chunk (the members are sampled chunk by chunk too).

Printed, for N = 1e3, 1e4, 1e5 members, each N in a fresh process (so peak memory is per N):
wall time, member-steps per second (accepted DOP853 steps of all members per wall second),
the peak resident memory (ru_maxrss) and the peak Python/numpy heap of the run (tracemalloc).
Then, in one process at N = 1e4: the speed-up from 1 to 2 numba threads, and the ratio against
a plain loop of single ``attitude.propagate`` calls, timed on 200 members and extrapolated per
member (the loop would take hours at 1e5; its per-member cost is constant).

Run: ``python benchmarks/ensemble.py`` (the first run compiles the kernels, ~1 min; the numbers
are from the second, warm-cache phase of each process).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

CHILD = r"""
import json, os, resource, sys, tempfile, time, tracemalloc, warnings
import numpy as np
warnings.simplefilter("ignore")
from attitude.scenario import load
from attitude import ensemble as E

n = int(sys.argv[1])
threads = int(sys.argv[2])
sc = load(os.path.join(sys.argv[3], "scenarios", "ensemble_paper_keplerian.toml"))
period = sc.potential.orbit.period
sc.t = np.array([0.0, period])
sc.rtol, sc.atol = 1e-10, 1e-12
sc.events = None  # the dynamics only, as measured (the scenario's [events] table came later)
with tempfile.TemporaryDirectory() as tmp:
    sc.ensemble.size = 64                       # warm-up: load the compiled kernels
    E.run_scenario(sc, os.path.join(tmp, "w.nc"))
    sc.ensemble.size = n
    sc.ensemble.chunk = 4096                    # the largest default chunk, for every N
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    tracemalloc.start()
    import numba
    numba.set_num_threads(threads)
    t0 = time.perf_counter()
    info = E.run_scenario(sc, os.path.join(tmp, "e.nc"))
    wall = time.perf_counter() - t0
    heap = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    size = os.path.getsize(os.path.join(tmp, "e.nc"))
print(json.dumps({"n": n, "threads": threads, "wall": wall, "steps": int(info["n_steps"]),
                  "chunk": int(info["chunk_size"]), "rss0_kb": rss0, "rss_kb": rss,
                  "heap": heap, "file": size}))
"""

SPEEDUP = r"""
import json, sys, time, warnings
import numpy as np
warnings.simplefilter("ignore")
from attitude.scenario import load
from attitude.canonical import project_state
from attitude import ensemble as E
from attitude.propagate import propagate
from attitude.body import RigidBody
from astropy import units as u

sc = load(sys.argv[2] + "/scenarios/ensemble_paper_keplerian.toml")
t = np.array([0.0, sc.potential.orbit.period])
n = int(sys.argv[1])
q0, Q0, _ = project_state(sc.q0, sc.Q0)
q, Q, inertia = sc.ensemble.sample(q0, Q0, sc.body.inertia, 0, n)
pot = sc.potential
kw = dict(rtol=1e-10, atol=1e-12, method=sc.method)  # the scenario's dop853, as above
body_q = inertia * u.Unit("kg km2")
E.propagate_ensemble(body_q[:64], q[:64], Q[:64], t, pot, **kw)       # warm-up
res = {}
for threads in (1, 2, 1, 2, 1, 2):
    t0 = time.perf_counter()
    ds = E.propagate_ensemble(body_q, q, Q, t, pot, threads=threads, **kw)
    wall = time.perf_counter() - t0
    res[threads] = min(res.get(threads, np.inf), wall)
    steps = int(ds.attrs["n_steps"])
m = 200
propagate(RigidBody(body_q[0]), q[0], Q[0], t, pot, **kw)              # warm-up
t0 = time.perf_counter()
for i in range(m):
    propagate(RigidBody(body_q[i]), q[i], Q[i], t, pot, **kw)
loop = (time.perf_counter() - t0) / m
print(json.dumps({"n": n, "t1": res[1], "t2": res[2], "steps": steps, "loop_per_member": loop}))
"""


BUSY = r"""
import sys, time
t0 = time.perf_counter()
s = 0
for i in range(10_000_000):
    s += i
print(time.perf_counter() - t0)
"""


def free_cores() -> float:
    """How many cores' worth of CPU two independent processes got (2.0 on an idle 2-core box)."""
    one = float(subprocess.run([sys.executable, "-c", BUSY], capture_output=True).stdout)
    procs = [
        subprocess.Popen([sys.executable, "-c", BUSY], stdout=subprocess.PIPE) for _ in range(2)
    ]
    two = [float(p.communicate()[0]) for p in procs]
    return sum(one / x for x in two)


def run(code: str, *args: str) -> dict:
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, check=False
    )
    if out.returncode:
        sys.stderr.write(out.stderr)
        raise SystemExit(out.returncode)
    return json.loads(out.stdout.strip().splitlines()[-1])


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main() -> None:
    import numba

    print(
        f"paper Sect. 6.2 over one orbit, rtol 1e-10, atol 1e-12; final state per member; "
        f"{os.cpu_count()} CPUs, numba threading layer default, load average "
        f"{os.getloadavg()[0]:.2f} at start"
    )
    print(
        f"{'N':>8s} {'threads':>7s} {'chunk':>6s} {'wall [s]':>9s} {'steps/member':>12s} "
        f"{'member-steps/s':>15s} {'peak RSS [MB]':>14s} {'(+ over start)':>14s} "
        f"{'peak heap [MB]':>14s} {'file [MB]':>9s}"
    )
    threads = numba.config.NUMBA_NUM_THREADS
    for n in (1_000, 10_000, 100_000):
        r = run(CHILD, str(n), str(threads), ROOT)
        print(
            f"{n:8d} {threads:7d} {r['chunk']:6d} {r['wall']:9.2f} {r['steps'] / n:12.1f} "
            f"{r['steps'] / r['wall']:15.4g} {r['rss_kb'] / 1024:14.1f} "
            f"{(r['rss_kb'] - r['rss0_kb']) / 1024:14.1f} {r['heap'] / 2**20:14.1f} "
            f"{r['file'] / 1e6:9.2f}"
        )
    cores0 = free_cores()
    s = run(SPEEDUP, "10000", ROOT)
    cores1 = free_cores()
    per = s["steps"] / s["n"]
    print()
    print(f"N = {s['n']} (arrays in memory, best of 3):")
    print(f"  1 thread : {s['t1']:.2f} s  {s['steps'] / s['t1']:.4g} member-steps/s")
    print(f"  2 threads: {s['t2']:.2f} s  {s['steps'] / s['t2']:.4g} member-steps/s")
    print(
        f"  speed-up 1 -> 2 threads: {s['t1'] / s['t2']:.2f}x (CPU available to two "
        f"independent processes before/after: {cores0:.2f}/{cores1:.2f} cores)"
    )
    loop_n = s["loop_per_member"] * s["n"]
    print(
        f"  plain loop of attitude.propagate: {1e3 * s['loop_per_member']:.2f} ms per member "
        f"(timed on 200 members, extrapolated: {loop_n:.1f} s for {s['n']}, "
        f"{per / s['loop_per_member']:.4g} member-steps/s)"
    )
    print(
        f"  ensemble vs loop: {loop_n / s['t2']:.1f}x faster with 2 threads, "
        f"{loop_n / s['t1']:.1f}x with 1 thread"
    )
    print(f"load average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

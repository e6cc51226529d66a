"""The first ``attitude run`` of a fresh install: the README's main job with empty caches.

``attitude run scenarios/paper_keplerian.toml`` (the paper's Sect. 6.2 case: gravity gradient on
the e = 0.2 Kepler orbit, DOP853 at rtol 1e-12, diagnostics, netCDF output) in a new process
whose numba caches are empty directories (``NUMBA_CACHE_DIR`` and ``ATTITUDE_CACHE_DIR``, so
nothing compiled before is found), several times, then the same job again in processes that
find the cache the first one wrote. For each run:

* **first step**: seconds from launching the process until the integrator takes its first step
  (the end of the compilation of the DOP853 entry point, or with a warm cache the moment the
  run starts integrating: the step itself follows within microseconds);
* **total**: seconds until the process has written the file and exited;
* the number of functions numba compiled.

Times are wall-clock seconds on this machine, min and median of the runs, with the load
average (the cold runs compile on one core: other work on the machine slows them). The goal of
issue 17 is a first step within 5 s. Run: ``python benchmarks/cold_start.py [--runs N]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENARIO = ROOT / "scenarios" / "paper_keplerian.toml"

#: Runs ``attitude run`` in the child and reports when the integrator could first step.
DRIVER = """
import json, sys, time
t_launch = float(sys.argv[1])
from numba.core import event
marks = {"compiles": 0}
depth = [0]
class Listener(event.Listener):
    def on_start(self, ev):
        depth[0] += 1
    def on_end(self, ev):
        depth[0] -= 1
        marks["compiles"] += 1
        f = getattr(ev.data.get("dispatcher"), "py_func", None)
        if depth[0] == 0 and f is not None and f.__name__.startswith("dop853"):
            marks.setdefault("compiled", time.time())  # the integrator entry point is ready
event.register("numba:compile", Listener())
import attitude
P = sys.modules["attitude.propagate"]  # (attitude.propagate is the function)
runner = P.METHODS["dop853"]
def timed(problem, **options):
    marks.setdefault("run", time.time())  # the runner starts: it loads or compiles, then steps
    return runner(problem, **options)
timed.streams = runner.streams
P.METHODS["dop853"] = timed
marks["imported"] = time.time()
from attitude.cli import main
main(["run", sys.argv[2], "-o", sys.argv[3], "-q"])
marks["done"] = time.time()
first = max(marks["run"], marks.get("compiled", 0.0))
print(json.dumps({"import": marks["imported"] - t_launch, "first_step": first - t_launch,
                  "compiles": marks["compiles"]}))
"""


def run_once(numba_dir: str, attitude_dir: str, out: Path) -> dict:
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": numba_dir,
        "ATTITUDE_CACHE_DIR": attitude_dir,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        "PYTHONWARNINGS": "ignore",
    }
    t0 = time.time()
    res = subprocess.run(
        [sys.executable, "-c", DRIVER, repr(t0), str(SCENARIO), str(out)],
        env=env,
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    total = time.time() - t0
    if res.returncode:
        raise RuntimeError(f"attitude run failed:\n{res.stderr}")
    info = json.loads(res.stdout.strip().splitlines()[-1])
    info["total"] = total
    return info


def summary(name: str, runs: list[dict]) -> str:
    def stat(key: str) -> str:
        v = [r[key] for r in runs]
        return f"{min(v):5.2f} / {statistics.median(v):5.2f}"

    n = sorted({r["compiles"] for r in runs})
    return (
        f"  {name:5s} first step {stat('first_step')} s   total {stat('total')} s   "
        f"(import {stat('import')} s; {'/'.join(map(str, n))} functions compiled)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3, help="runs of each kind (default 3)")
    args = ap.parse_args()
    load0 = os.getloadavg()
    cold, warm = [], []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "paper_keplerian.nc"
        keep = None
        for _ in range(args.runs):
            nd, ad = tempfile.mkdtemp(dir=tmp), tempfile.mkdtemp(dir=tmp)
            cold.append(run_once(nd, ad, out))
            keep = keep or (nd, ad)
        for _ in range(args.runs):
            warm.append(run_once(*keep, out))
    load1 = os.getloadavg()
    print(f"attitude run {SCENARIO.relative_to(ROOT)}: min / median of {args.runs} runs")
    print(summary("cold", cold))
    print(summary("warm", warm))
    print(f"  load average {load0[0]:.2f} before, {load1[0]:.2f} after ({os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

"""What the flight software's recording costs: time, memory, file (issue 39).

The case is Basilisk's ``scenarioAttitudeFeedbackRW`` (benchmarks/software.py, the hr16
spacecraft of tests/test_software.py: three wheels, MRP feedback at 10 Hz), run as a user
writes it: 101 output samples over the span, the software recorded by default. Printed:

1. one day: the default recording (the ticks in effect at the 101 samples) against
   ``record_every=600`` (the benchmark's once a minute) and against every tick: CPU time (best
   of ``REPEAT``, interleaved) and the Dataset's size;
2. each in a process of its own, its peak resident memory (VmHWM, the whole process:
   Python, numba and the loaded kernels are ~260 MB of it):
   7 days with the default recording; 7 days with every tick in memory; 30 days with every
   tick in memory (refused before any work: the estimate and the remedies); 30 days with
   every tick streamed to a netCDF file (``propagate(..., on_chunk=StreamWriter.append)``),
   with the file's size.

Run: ``python benchmarks/recording.py`` (``--quick``: 1 and 3 days instead of 7 and 30).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "tests"))

import numpy as np

REPEAT = 5
DAY = 86400.0


def setup():
    from test_software import hr16_spacecraft

    from attitude import canonical as C
    from attitude import quaternion as qt

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    return craft, q0, Q0


def software(record_every):
    from attitude import frames
    from attitude.control import MRPFeedback
    from attitude.software import FlightSoftware

    return FlightSoftware(0.1, frames.inertial(), MRPFeedback(3.5, 30.0), record_every=record_every)


def one_day() -> None:
    import attitude

    craft, q0, Q0 = setup()
    t = np.linspace(0.0, DAY, 101)
    cases = {"default (at the samples)": None, "record_every=600": 600, "every tick": 1}
    times: dict[str, list[float]] = {k: [] for k in cases}
    size = {}
    for k, every in cases.items():  # warm-up (compiled and cached)
        size[k] = attitude.propagate(craft, q0, Q0, t, software=software(every)).nbytes
    # the two small results interleaved; every tick apart (freeing its 169 MB between the
    # others' runs made them 30-40 % slower under load: page faults, not the recording)
    for group in (list(cases)[:2], list(cases)[2:]):
        for _ in range(REPEAT):
            for k in group:
                fsw = software(cases[k])
                t0 = time.process_time()
                attitude.propagate(craft, q0, Q0, t, software=fsw)
                times[k].append(time.process_time() - t0)
    base = min(times["record_every=600"])
    print(f"one day at 10 Hz, 101 output samples (CPU, best of {REPEAT}):")
    for k in cases:
        dt = min(times[k])
        print(f"  {k:26s} {dt:.3f} s ({dt / base:.2f}x record_every=600), {size[k] / 1e6:.3f} MB")


def child(case: str, days: float, path: str | None) -> None:
    """One measured run (in its own process)."""
    import attitude
    from attitude import io
    from attitude.errors import OutputSizeError

    craft, q0, Q0 = setup()
    t = np.linspace(0.0, days * DAY, 101)
    t0 = time.time()
    if case == "default":
        ds = attitude.propagate(craft, q0, Q0, t, software=software(None))
        print(f"Dataset {ds.nbytes / 1e6:.3f} MB, {ds.sizes['tick']} ticks recorded", end="")
    elif case == "memory":
        try:
            ds = attitude.propagate(craft, q0, Q0, t, software=software(1))
            print(f"Dataset {ds.nbytes / 1e6:.1f} MB, {ds.sizes['tick']} ticks", end="")
        except OutputSizeError as exc:
            print(f"refused after {time.time() - t0:.2f} s: {exc}", end="")
    else:
        with io.StreamWriter(path) as w:
            last = attitude.propagate(craft, q0, Q0, t, software=software(1), on_chunk=w.append)
            w.attrs.update(last.attrs)
        print(f"file {os.path.getsize(path) / 1e6:.0f} MB, {w.n_ticks} ticks", end="")
    print(f", {time.time() - t0:.1f} s wall, peak RSS {_hwm_mb():.0f} MB")


def _hwm_mb() -> float:
    """This process's peak resident memory (MB): VmHWM of /proc/self/status, which starts
    afresh at exec (wait4's ru_maxrss would count the parent's forked image)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def measured(case: str, days: float, what: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "run.nc")
        args = [sys.executable, __file__, "--child", case, str(days), path]
        p = subprocess.run(args, stdout=subprocess.PIPE, text=True, check=False)
        print(f"  {what}: {p.stdout.strip()}")
        if p.returncode:
            print(f"    (exit status {p.returncode})")


def main() -> None:
    if sys.argv[1:2] == ["--child"]:
        child(sys.argv[2], float(sys.argv[3]), sys.argv[4])
        return
    quick = "--quick" in sys.argv
    week, month = (1, 3) if quick else (7, 30)
    one_day()
    print("long runs, 101 samples, each in its own process:")
    measured("default", week, f"{week} days, default recording")
    measured("memory", week, f"{week} days, every tick in memory")
    measured("memory", month, f"{month} days, every tick in memory")
    measured("stream", month, f"{month} days, every tick streamed to a file")


if __name__ == "__main__":
    main()

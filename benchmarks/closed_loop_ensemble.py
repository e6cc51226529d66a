"""A 1 000-member closed-loop ensemble: dispersed inertia, initial rates and gains (issue 25),
and the pointing budget through sensors and the MEKF against the linear covariance analysis
(issue 26, docs/closed_loop_covariance.md).

Printed:

1. the slew-free settling ensemble: scenarioAttitudeFeedbackRW's spacecraft (900/800/600
   kg m², three HR16 wheels, 0.2 N m) under MRP feedback (K = 100 N m, P = 300 N m s) at
   1 Hz from a 0.5° (1σ per axis) attitude error and 0.01 °/s rates, inertia ±5 % (1σ), gains
   ±10 % (1σ), truth sensors, 300 s: percentiles of the pointing error at a few ticks and of
   the settling time to 0.01°, for ``dop853`` and ``taylor`` (SIMD lanes of gyrostats);
2. the same spacecraft pointing with a gyro (ARW 1.45e-5 rad/√s, RRW 3e-7 rad/s^1.5, bias) and a
   star tracker (10″ across, 30″ about its boresight) through the MEKF, 200 s: the pointing
   error's standard deviation per axis over the members against the linear covariance
   analysis (tests/closed_loop_covariance.py), with the 99 % sampling interval.

Times are CPU seconds (time.process_time: the machine is shared, wall time is noise), the best
of ``REPEAT`` runs after a warm-up (the kernels compile and are cached by the warm-up).

Run: ``python benchmarks/closed_loop_ensemble.py [N]`` (default N = 1000)
"""

from __future__ import annotations

import math
import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "tests"))

import numpy as np

REPEAT = 3


def best(fn, repeat=REPEAT):
    fn()
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return min(times), out


def main(n: int) -> None:
    import closed_loop_covariance as lc
    from scipy import stats
    from test_ensemble_closed_loop import ARCSEC, JS, SPEEDS, craft, software

    from attitude import canonical as C
    from attitude import frames
    from attitude.control import MRPFeedback
    from attitude.ensemble import (
        disperse_spacecraft,
        error_angle_percentiles,
        propagate_ensemble,
        settling_times,
    )
    from attitude.software import FlightSoftware

    print(f"1. settling: {n} members, dispersed inertia (5 %), rates, gains (10 %); 300 s at 1 Hz")
    fs = FlightSoftware(
        1.0, guidance=frames.inertial(), control=MRPFeedback(100.0, 300.0), record_every=1
    )  # every tick: the pointing error and the settling time at 1 Hz
    d = disperse_spacecraft(
        craft(), [1.0, 0, 0, 0], [0.0, 0.0, 0.0], n, software=fs, seed=1,
        attitude_error=math.radians(0.5), rate_error=math.radians(0.01), inertia_error=0.05,
        gain_error=0.1,
    )  # fmt: skip
    for method in ("dop853", "taylor"):
        cpu, ds = best(
            lambda m=method: propagate_ensemble(
                d.spacecraft,
                d.q,
                d.Q,
                [0.0, 300.0],
                software=d.software,
                method=m,
                rtol=1e-10,
            )
        )
        ticks = n * ds.sizes["tick"]
        print(f"   {method:7s} CPU {cpu:6.2f} s  ({1e6 * cpu / ticks:5.1f} µs per member-tick)")
    p = error_angle_percentiles(ds, [5, 50, 95], degrees=True)
    for t in (0.0, 10.0, 30.0, 60.0, 120.0):
        v = p.sel(tick=t).values
        print(f"   pointing error at {t:5.0f} s (5/50/95 %): " + " ".join(f"{x:.2e}°" for x in v))
    st = settling_times(ds, math.radians(0.01)).values
    q5, q50, q95 = np.nanpercentile(st, [5, 50, 95])
    print(f"   settling time to 0.01° (5/50/95 %): {q5:.0f} {q50:.0f} {q95:.0f} s; "
          f"not settled: {int(np.isnan(st).sum())}")  # fmt: skip
    sat = float((ds.wheel_limit.values != 0).any(axis=(1, 2)).mean())
    print(f"   members that touched a wheel limit: {100 * sat:.0f} %")

    print(f"2. pointing budget: {n} members, gyro + star tracker + MEKF, 200 s at 1 Hz")
    c = craft()
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    Q0 = np.tile(C.momenta_from_angular_velocity(q0[0], [0.0, 0.0, 0.0], c), (n, 1))
    sw = software(record_every=100)
    cpu, ds = best(lambda: propagate_ensemble(c, q0, Q0, [0.0, 200.0], software=sw, seed=1))
    print(f"   dop853 CPU {cpu:6.2f} s  ({1e6 * cpu / (n * 200):5.1f} µs per member-tick)")
    q = ds.q.isel(time=-1).values
    theta = 2.0 * q[:, 1:] * np.sign(q[:, :1])
    R = np.diag([(10 * ARCSEC) ** 2, (10 * ARCSEC) ** 2, (30 * ARCSEC) ** 2])
    P0 = np.diag([(30 * ARCSEC) ** 2] * 3 + [1e-10] * 3)
    Xss, _X = lc.pointing_covariance(c.locked_less_wheels(), JS * SPEEDS, 1.0, 100.0, 300.0,
                                    1.45e-5, 3e-7, R, P0, 200)  # fmt: skip
    lo, hi = np.sqrt(stats.chi2.ppf([0.005, 0.995], n - 1) / (n - 1))
    s = theta.std(axis=0, ddof=1) / ARCSEC
    pred = np.sqrt(np.diag(Xss)[:3]) / ARCSEC
    for k, ax in enumerate("xyz"):
        print(f"   {ax}: sample σ {s[k]:6.3f}″  linear covariance σ {pred[k]:6.3f}″  ratio "
              f"{s[k] / pred[k]:.3f} (99 % sampling interval {lo:.3f}..{hi:.3f})")  # fmt: skip


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)

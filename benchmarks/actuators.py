"""Reaction wheels: the cost of the gyrostat's right-hand side, and a day of open-loop holds.

1. The right-hand side of eq. 7 with three wheels (the gyrostat: ω = Ĩ⁻¹(g − ℓ), ḣ = u − f,
   the held commands and Basilisk's friction law) against the rigid body's, both torque-free,
   each called 10⁶ times from a compiled loop (issue: ≤ 1.3×).
2. One day of the scenarioAttitudeFeedbackRW spacecraft (three HR16 wheels, 900/800/600 kg m²)
   under a 10 Hz open-loop schedule of random motor torques within ±0.1 N m (864 000 holds),
   ``taylor`` and ``dop853`` at rtol 1e-12, recorded once a minute; and, if ``bsk`` is
   installed (a scratch environment, never a dependency), Basilisk's reaction-wheel effector
   under the same schedule at its RK4 step of 0.1 s, with the largest difference of the wheel
   speeds at the recorded times.

Times are CPU seconds of this process (``time.process_time``: what the run costs, whatever
else the machine is doing), the best of three after a warm-up.

Run: ``python benchmarks/actuators.py`` (``--quick``: a tenth of a day)
"""

from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "tests"))

import numpy as np

DAY = 86400.0


def best(fn, repeat=3):
    fn()
    out, times = None, []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return min(times), out


def rhs_ratio() -> None:
    import numba
    from test_software import hr16_spacecraft

    import attitude
    from attitude import _holds
    from attitude import canonical as C
    from attitude import quaternion as qt
    from attitude.potentials import TorqueFree

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    pot = TorqueFree()
    entry = pot._entry_points()
    params = pot._params(craft.body.inertia)
    run, y_sc = _holds.prepare(craft, q0, Q0, np.array([0.0, 1.0]), None)
    P = (params, run.fresh_block())
    y_rb = y_sc[:8].copy()
    rigid, gyro = entry.canonical_rhs, entry.spacecraft_rhs

    @numba.njit
    def loop_rigid(n, y, params, out):
        s = 0.0
        for i in range(n):
            y[0] += 1e-17
            rigid(0.1 * i, y, params, out)
            s += out[4]
        return s

    @numba.njit
    def loop_gyro(n, y, P, out):
        s = 0.0
        for i in range(n):
            y[0] += 1e-17
            gyro(0.1 * i, y, P, out)
            s += out[4]
        return s

    n = 1_000_000
    a, _ = best(lambda: loop_rigid(n, y_rb.copy(), params, np.empty(8)))
    b, _ = best(lambda: loop_gyro(n, y_sc.copy(), P, np.empty(11)))
    print(f"right-hand side: rigid {a / n * 1e9:.1f} ns, three wheels {b / n * 1e9:.1f} ns "
          f"({b / a:.2f}x)")  # fmt: skip
    del attitude


def day(duration: float) -> None:
    from test_software import hr16_spacecraft

    import attitude
    from attitude import CommandSchedule
    from attitude import canonical as C
    from attitude import quaternion as qt

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    k = round(duration / 0.1)
    u = np.random.default_rng(1).uniform(-0.1, 0.1, (k, 3))
    sched = CommandSchedule(np.arange(k) * 0.1, u)
    t = np.arange(0.0, duration + 1e-9, 60.0)
    runs = {}
    for method in ("taylor", "dop853"):
        dt, ds = best(
            lambda method=method: attitude.propagate(
                craft, q0, Q0, t, commands=sched, method=method, rtol=1e-12
            )
        )
        runs[method] = (dt, ds)
        print(f"{duration:g} s of 10 Hz holds ({k} holds), {method:7s}: {dt:.3f} s")
    try:
        import Basilisk  # noqa: F401
        import basilisk_reference as br
    except ImportError:
        print("Basilisk is not installed (pip install bsk in a scratch environment): skipped")
        return
    wheels = [
        {"axis": w.axis, "Js": w.inertia, "Omega": w.speed, "u_max": w.max_torque,
         "Omega_max": w.max_speed}
        for w in craft.wheels
    ]  # fmt: skip
    t0 = time.process_time()
    ref = br.rw_open_loop(
        np.diag([900.0, 800.0, 600.0]), wheels, [0.1, 0.2, -0.3], [0.001, -0.01, 0.03], 0.1,
        u, 0.1, record_every=600,
    )  # fmt: skip
    t_bsk = time.process_time() - t0
    print(f"Basilisk, the same schedule at its RK4 step of 0.1 s: {t_bsk:.2f} s")
    for method, (dt, ds) in runs.items():
        m = min(len(ref["t"]), ds.sizes["time"])
        dw = np.abs(ds.wheel_speed.values[:m] - ref["Omega"][:m]).max()
        print(f"  {method:7s}: {t_bsk / dt:.0f}x faster; wheel speeds differ by {dw:.1e} rad/s")


def main() -> None:
    rhs_ratio()
    day(DAY / 10 if "--quick" in sys.argv else DAY)


if __name__ == "__main__":
    main()

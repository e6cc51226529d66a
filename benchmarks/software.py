"""Closed-loop attitude control against Basilisk (issues: flight software, sensors and MEKF).

The case is Basilisk's ``scenarioAttitudeFeedbackRW`` (tests/basilisk_reference.py): a
900/800/600 kg m² hub, three HR16 wheels on the body axes, inertial pointing with
``mrpFeedback`` (K = 3.5, P = 30) and ``rwMotorTorque`` at 10 Hz, extended to one day
(864 000 ticks), recorded once a minute. Printed, all in one process:

1. Basilisk's run of the day (RK4 at the 0.1 s tick: its scenario as published), when
   ``bsk`` is installed (a scratch environment; never a dependency), else skipped;
2. ours, the built-in law, ``taylor`` and ``dop853`` (rtol 1e-12), with the ratio to Basilisk
   and the largest difference of the MRP and wheel-speed histories from Basilisk's
   (and, for scale, how much halving Basilisk's RK4 step changes its MRP: 2.5e-14 measured);
3. the same day with a gyro, a star tracker and the MEKF in the loop (``taylor`` and
   ``dop853``), against Basilisk's day with its own attitude filter in the loop, like for like:
   its gyro (``imuSensor``, at the tick), its star tracker (``starTracker``, 2 Hz, our noise and
   boresight) and its ``inertialUKF`` (``stComm`` + the UKF in the 2 Hz task, the control on
   its estimate; settings from Basilisk's own test of the filter: tests/basilisk_reference.py
   says exactly what that loop does, and why nothing feeds the gyro to Basilisk's filter).
   Also printed: Basilisk with the sensors but its loop on the truth (``simpleNav``), and the
   pointing error after the first hour of both filtered loops (each converges to what its
   sensors allow: ours is dominated by the gyro's noise through the rate term, Basilisk's
   filter uses no gyro);
4. the cost per tick of the flight software: the built-in law, your own compiled step
   (tests/compiled_steps.py), your own Python step, and sensors + MEKF (each over 600 s at
   10 Hz; the per-tick cost is the run's time less that of the same run open loop with the
   same holds, divided by the ticks).

Every time is the best of ``REPEAT`` runs after a warm-up run (the kernels are compiled and
cached on disk by the warm-up); Basilisk's, the best of two runs. (Basilisk's C code prints
"unwritten message" errors while its filter has no output yet, the first half second: those
lines are held back, any other line of its output is printed.)

Run: ``python benchmarks/software.py`` (``--quick``: a tenth of a day, no Basilisk refinement)
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "tests"))

import numpy as np

REPEAT = 3
BSK_REPEAT = 2  # Basilisk's day takes ~15 s a run
DAY = 86400.0


def best(fn, repeat=REPEAT):
    fn()
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return min(times), out


def setup():
    from test_software import hr16_spacecraft

    import attitude
    from attitude import canonical as C
    from attitude import quaternion as qt

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    return attitude, craft, q0, Q0


def software(control, sensors=False, record_every=600):
    import astropy.units as u

    from attitude import frames
    from attitude.estimation import MEKF
    from attitude.sensors import Gyro, StarTracker
    from attitude.software import FlightSoftware

    kw = {}
    if sensors:
        kw["sensors"] = [
            Gyro(0.05 * u.deg / u.hour**0.5, 2e-9 * u.rad / u.s**1.5, seed=1),
            StarTracker([6 * u.arcsec, 45 * u.arcsec], [0.0, 0.6, 0.8], rate=2.0, seed=2),
        ]
        kw["estimator"] = MEKF()
    return FlightSoftware(0.1, frames.inertial(), control, record_every=record_every, **kw)


#: Basilisk's prints (C printf) while its filter has not written its output yet.
BSK_EXPECTED = ("unwritten message", "[FILE : ", "not properly initialized or written")


@contextlib.contextmanager
def basilisk_output():
    """Hold back the lines of Basilisk's C output listed in BSK_EXPECTED; print the rest."""
    sys.stdout.flush()
    libc = ctypes.CDLL(None)
    saved = os.dup(1)
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 1)
        try:
            yield
        finally:
            libc.fflush(None)
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)
            f.seek(0)
            for line in f.read().decode(errors="replace").splitlines():
                if not any(e in line for e in BSK_EXPECTED):
                    print(line)


def basilisk_day(duration: float, sensors: bool = False, estimator: bool = False):
    """(best CPU time of BSK_REPEAT runs, the run) of Basilisk's scenario, or (None, None)."""
    try:
        import Basilisk  # noqa: F401
        import basilisk_reference as br
    except ImportError:
        return None, None
    times = []
    for _ in range(BSK_REPEAT):
        with basilisk_output():
            t0 = time.process_time()
            run = br.rw_feedback_scenario(
                dt=0.1, duration=duration, record_every=600, sensors=sensors, estimator=estimator
            )
            times.append(time.process_time() - t0)
    return min(times), run


def pointing_rms(t, q, after=3600.0):
    """RMS (arcsec) of the angle of q from the inertial reference (identity) at t >= after."""
    from attitude import quaternion as qt

    late = np.asarray(t) >= after
    angle = qt.angle_between(np.asarray(q)[late], np.array([1.0, 0.0, 0.0, 0.0]))
    return math.degrees(math.sqrt(np.mean(angle**2))) * 3600.0


def day_runs(duration: float, quick: bool) -> None:
    from attitude.control import MRPFeedback

    attitude, craft, q0, Q0 = setup()
    t = np.arange(0.0, duration + 1e-9, 60.0)
    t_bsk, bsk = basilisk_day(duration)
    if bsk is None:
        print("Basilisk is not installed (pip install bsk in a scratch environment): skipped")
    else:
        import basilisk_reference as br

        print(f"Basilisk scenarioAttitudeFeedbackRW, {duration:g} s at 10 Hz: {t_bsk:.2f} s")
        if not quick:
            half = br.rw_feedback_scenario(dt=0.1, duration=duration, record_every=600, dyn_dt=0.05)
            d = np.abs(half["sigma"] - bsk["sigma"]).max()
            print(f"  Basilisk's own step halving changes the MRP by {d:.1e}")
        t = bsk["t"]
    t_bsk_s, t_bsk_f, bsk_f = None, None, None
    if bsk is not None:
        t_bsk_s, _ = basilisk_day(duration, sensors=True)
        print(f"Basilisk with imuSensor and starTracker, its loop on the truth: {t_bsk_s:.2f} s")
        t_bsk_f, bsk_f = basilisk_day(duration, sensors=True, estimator=True)
        print(f"Basilisk with imuSensor, starTracker and inertialUKF in the loop: {t_bsk_f:.2f} s")
    for sensors in (False, True):
        fsw = software(MRPFeedback(3.5, 30.0), sensors=sensors)
        for method in ("taylor", "dop853"):
            dt, ds = best(
                lambda method=method, fsw=fsw: attitude.propagate(
                    craft, q0, Q0, t, software=fsw, method=method, rtol=1e-12
                )
            )
            what = "with gyro + star tracker + MEKF" if sensors else "built-in law"
            line = f"ours, {method:7s} {what}: {dt:.3f} s"
            if sensors and t_bsk_f is not None:
                r_f, r_s, r = t_bsk_f / dt, t_bsk_s / dt, t_bsk / dt
                line += (
                    f"  ({r_f:.0f}x Basilisk with its filter in the loop; {r_s:.0f}x with its"
                    f" sensors on the truth, {r:.0f}x without)"
                )
                if method == "taylor":
                    p_ours, p_bsk = (
                        pointing_rms(t, ds.q.values),
                        pointing_rms(bsk_f["t"], br.mrp_to_quaternion(bsk_f["sigma"])),
                    )
                    line += (
                        f"\n  pointing error RMS after the first hour: ours {p_ours:.1f} arcsec,"
                        f" Basilisk's filtered loop {p_bsk:.1f} arcsec"
                    )
            elif t_bsk is not None:
                from attitude import quaternion as qt

                line += f"  ({t_bsk / dt:.0f}x Basilisk)"
                att = qt.angle_between(ds.q.values, br.mrp_to_quaternion(bsk["sigma"])).max()
                rpm = 60.0 / (2.0 * math.pi)
                dw = np.abs(ds.wheel_speed.values - bsk["Omega"]).max()
                line += f"; vs Basilisk: attitude {att:.1e} rad, wheel speed {dw * rpm:.1e} rpm"
            print(line)


def per_tick() -> None:
    import compiled_steps as cs

    from attitude import CommandSchedule
    from attitude.control import MRPFeedback

    attitude, craft, q0, Q0 = setup()
    duration = 600.0
    n_ticks = round(duration / 0.1)
    t = np.array([0.0, duration])
    I = np.diag([900.0, 800.0, 600.0])
    js = craft.wheel_inertias

    def py_step(tt, m):
        w = m.omega
        h = js * (w + m.wheel_speeds)
        lr = 3.5 * m.sigma_error + 30.0 * m.omega_error
        return lr - np.cross(m.omega_ref, I @ w + h) + I @ np.cross(w, m.omega_ref)

    closed = attitude.propagate(
        craft, q0, Q0, t, software=software(MRPFeedback(3.5, 30.0), record_every=1),
        method="taylor", rtol=1e-12,
    )  # fmt: skip
    sched = CommandSchedule(np.arange(n_ticks) * 0.1, closed.command_applied.values[:n_ticks])
    base, _ = best(
        lambda: attitude.propagate(craft, q0, Q0, t, commands=sched, method="taylor", rtol=1e-12)
    )
    print(f"open loop, the same {n_ticks} holds: {base * 1e3:.1f} ms")
    cases = [
        ("built-in MRP feedback", software(MRPFeedback(3.5, 30.0))),
        ("your compiled step", software(cs.mrp_feedback)),
        ("your Python step", software(py_step)),
        ("built-in law + gyro, star tracker, MEKF", software(MRPFeedback(3.5, 30.0), True)),
    ]
    for name, fsw in cases:
        dt, _ = best(
            lambda fsw=fsw: attitude.propagate(
                craft, q0, Q0, t, software=fsw, method="taylor", rtol=1e-12
            )
        )
        print(f"{name:42s} {dt * 1e3:8.1f} ms  per tick {(dt - base) / n_ticks * 1e6:7.2f} us")


def main() -> None:
    quick = "--quick" in sys.argv
    day_runs(DAY / 10 if quick else DAY, quick)
    per_tick()


if __name__ == "__main__":
    main()

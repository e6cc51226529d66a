"""The closed-loop day with the orbit propagated in the loop (issue 41), against the same day on
a given orbit.

The case is the closed-loop day of ``benchmarks/software.py`` (Basilisk's
``scenarioAttitudeFeedbackRW``: a 900/800/600 kg m² hub, three HR16 wheels, inertial pointing
with ``mrpFeedback`` at 10 Hz, recorded once a minute), put on a 500 km orbit with its
gravity-gradient torque, ``dop853`` at rtol 1e-12:

1. on a given orbit: an :class:`orbit.NumericalOrbit` (EGM2008 to the degree below, the Sun
   and the Moon) handed to the run as a table, as any orbit source is;
2. the orbit propagated with the attitude: the same spacecraft with a mass (750 kg), its state
   (q, Q, h, r, v, m), the gravity gradient's back-reaction on the orbit, the field beyond
   the point mass and the third bodies sampled every second (``NumericalOrbit.field_step``,
   attitude/_core/coupled.py).

Printed: both times (best of ``REPEAT`` after a warm-up run, CPU time), their ratio (target
<= 1.5), how far the coupled orbit is from the given one at the end of the day, and, for the
20 x 20 field, how far the sampled field's run is from one evaluating it at every stage (one
run, not timed against the others).

Run: ``python benchmarks/coupled.py`` (``--quick``: a tenth of a day)
"""

from __future__ import annotations

import os
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "tests"))

import numpy as np

REPEAT = 3
DAY = 86400.0
EPOCH = "2026-03-20T00:00:00"


def best(fn, repeat=REPEAT):
    fn()
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return min(times), out


def main(quick: bool) -> None:
    from test_software import hr16_spacecraft

    import attitude
    import orbit
    from attitude import canonical as C
    from attitude import frames
    from attitude import quaternion as qt
    from attitude.control import MRPFeedback
    from attitude.software import FlightSoftware

    duration = DAY / 10 if quick else DAY
    t = np.arange(0.0, duration + 1e-9, 60.0)
    base = hr16_spacecraft()
    q0 = qt.from_mrp([0.1, 0.2, -0.3])
    fsw = FlightSoftware(0.1, frames.inertial(), MRPFeedback(3.5, 30.0), record_every=600)
    print(f"closed-loop day ({duration:g} s at 10 Hz), dop853 rtol 1e-12, CPU time:")
    for degree, bodies in ((None, ()), (8, ("sun", "moon")), (20, ("sun", "moon"))):
        field = None if degree is None else orbit.SphericalHarmonics(degree)
        o = orbit.NumericalOrbit([6878.137, 0.0, 0.0], [0.0, 4.7329, 5.9744], EPOCH,
                                 gravity=field, third_bodies=bodies)  # fmt: skip
        given = attitude.Spacecraft(base.body, base.wheels, orbit=o)
        coupled = attitude.Spacecraft(base.body, base.wheels, orbit=o, mass=750.0)
        Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], given)
        gg = attitude.GravityGradient(o)

        def run(craft, gg=gg, Q0=Q0):
            return attitude.propagate(craft, q0, Q0, t, gg, software=fsw, method="dop853",
                                      rtol=1e-12)  # fmt: skip

        t_given, _ = best(lambda given=given: run(given))
        t_coupled, ds_coupled = best(lambda coupled=coupled: run(coupled))
        gap = np.linalg.norm(ds_coupled.position.values[-1] - o.position(t[-1]) * 1e3)
        name = "point-mass Earth" if degree is None else f"EGM2008 {degree}x{degree} + Sun, Moon"
        print(
            f"  {name:32s} given orbit {t_given:7.3f} s   propagated with the attitude "
            f"{t_coupled:7.3f} s   ratio {t_coupled / t_given:.2f}   "
            f"(orbits {gap:.3g} m apart at the end: the gravity gradient's back-reaction)"
        )
    exact = orbit.NumericalOrbit([6878.137, 0.0, 0.0], [0.0, 4.7329, 5.9744], EPOCH,
                                 gravity=field, third_bodies=bodies, field_step=0.0)  # fmt: skip
    t0 = time.process_time()
    ds_exact = run(
        attitude.Spacecraft(base.body, base.wheels, orbit=exact, mass=750.0),
        gg=attitude.GravityGradient(exact),
    )
    t_exact = time.process_time() - t0
    dr = np.linalg.norm(ds_exact.position.values - ds_coupled.position.values, axis=1).max()
    print(
        f"  the field at every stage instead (field_step=0): {t_exact:.3f} s; the sampled "
        f"run's orbit within {dr:.3g} m of it"
    )


if __name__ == "__main__":
    main("--quick" in sys.argv)

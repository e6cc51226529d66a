"""Reaction wheels against Basilisk: the limit and friction cases of tests/test_actuators.py.

Basilisk (``pip install bsk``, in a scratch environment; never a dependency) runs its hub with
the reaction-wheel state effector (balanced wheels) under the same open-loop schedule (0.1 s
holds, 100 s), at its dynamics step equal to the hold and refined 2, 4, ... 32 times; the
table gives the largest difference of the wheel speeds (rad/s) from our run (``dop853`` and
``taylor`` at rtol 1e-13) at each refinement: Basilisk converging towards our run shows that
the difference is its own discretisation error. Without Basilisk the script says so and stops.

Run: ``python benchmarks/basilisk_wheels.py``
"""

from __future__ import annotations

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(__file__), os.pardir, "tests"))


def main() -> None:
    try:
        import Basilisk  # noqa: F401
    except ImportError:
        print("Basilisk is not installed (pip install bsk in a scratch environment): skipped")
        return
    import numpy as np
    import test_actuators as ta

    refine = (1, 2, 4, 8, 16, 32)
    print(f"{'case':22s} " + " ".join(f"{'h/' + str(k):>9s}" for k in refine) + "  flags")
    for name in ta.BASILISK_CASES:
        ds, refs = ta.basilisk_case(name, refine=refine)
        errs = [np.abs(ds.wheel_speed.values - refs[k]["Omega"]).max() for k in refine]
        flags = sorted(set(np.unique(ds.wheel_limit.values).tolist()) - {0})
        print(f"{name:22s} " + " ".join(f"{e:9.1e}" for e in errs) + f"  {flags}")


if __name__ == "__main__":
    main()

"""Write the KVN source files of the CCSDS test data with this package (step 1 of 2).

Run from the repository root with the project's environment::

    python tests/data/ccsds/make_sources.py

It writes ``attitude_q.aem`` and ``attitude_angvel.aem`` (AEM 2.0 KVN, UTC: 41 samples of
``scenarios/tumbling_upper_stage.toml``, a 0.5-2 deg/s tumble, with the inertial frame labelled
GCRF) and ``orbit.oem`` (OEM 2.0 KVN, UTC, GCRF: the FLOCK 1C-1 TLE of
``scenarios/cubesat_environment.toml`` through SGP4, 31 states 60 s apart). Step 2,
It also writes ``estimate.acm`` (ACM 2.0 KVN, UTC): the MEKF's estimate with its covariance
over 60 s of tests/test_sensors.py's closed loop (three wheels, a gyro with bias, a 2 Hz star
tracker, the filter started 10 degrees off), with the truth block. ``make_sources.py acm``
writes only that file, ``make_sources.py aem`` only the others. Step 2,
``orekit_convert.py``, has Orekit (``orekit_jpype``, a scratch environment, never a
dependency) read these files and write them again as XML and in other time systems: the
tests read Orekit's files and compare them with these (tests/test_aem.py,
tests/test_ephemeris.py).
"""

from __future__ import annotations

import sys
from pathlib import Path

import orbit
from attitude import acm, aem, scenario

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]


def aem_and_oem() -> None:
    sc = scenario.load(ROOT / "scenarios/tumbling_upper_stage.toml")
    sc.t = sc.t[:41]
    ds = sc.run()
    for kind, name in (
        ("QUATERNION", "attitude_q.aem"),
        ("QUATERNION/ANGVEL", "attitude_angvel.aem"),
    ):
        aem.write_aem(
            ds, HERE / name, attitude_type=kind, ref_frame_a="GCRF", originator="attitude"
        )

    tle = (
        "1 40027U PLANET   20053.08335648  .00000000  00000+0  34079-4 0    09",
        "2 40027 097.9376 341.9424 0011991 325.7224 261.4362 14.90036668    06",
    )
    o = orbit.EphemerisOrbit.from_tle(
        *tle, start="2020-02-22T02:00:00", stop="2020-02-22T02:30:00", step=60.0
    )
    o.to_oem(HERE / "orbit.oem", object_name="FLOCK 1C-1", object_id="2014-033R")
    print("written:", *sorted(p.name for p in HERE.glob("*.[ao]em")))


def acm_source() -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    from test_sensors import _mekf_run

    _, run = _mekf_run(60.0, seed=5)
    acm.write_acm(run, HERE / "estimate.acm", epoch="2024-06-01T00:00:00",
                  object_name="MEKF TEST", originator="attitude")  # fmt: skip
    print("written: estimate.acm")


if __name__ == "__main__":
    which = sys.argv[1:] or ["aem", "acm"]
    if "aem" in which:
        aem_and_oem()
    if "acm" in which:
        acm_source()

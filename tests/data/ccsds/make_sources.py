"""Write the KVN source files of the CCSDS test data with this package (step 1 of 2).

Run from the repository root with the project's environment::

    python tests/data/ccsds/make_sources.py

It writes ``attitude_q.aem`` and ``attitude_angvel.aem`` (AEM 2.0 KVN, UTC: 41 samples of
``scenarios/tumbling_upper_stage.toml``, a 0.5-2 deg/s tumble, with the inertial frame labelled
GCRF) and ``orbit.oem`` (OEM 2.0 KVN, UTC, GCRF: the FLOCK 1C-1 TLE of
``scenarios/cubesat_environment.toml`` through SGP4, 31 states 60 s apart). Step 2,
``orekit_convert.py``, has Orekit (``orekit_jpype``, a scratch environment, never a
dependency) read these files and write them again as XML and in other time systems: the
tests read Orekit's files and compare them with these (tests/test_aem.py,
tests/test_ephemeris.py).
"""

from __future__ import annotations

from pathlib import Path

import orbit
from attitude import aem, scenario

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]

sc = scenario.load(ROOT / "scenarios/tumbling_upper_stage.toml")
sc.t = sc.t[:41]
ds = sc.run()
for kind, name in (("QUATERNION", "attitude_q.aem"), ("QUATERNION/ANGVEL", "attitude_angvel.aem")):
    aem.write_aem(ds, HERE / name, attitude_type=kind, ref_frame_a="GCRF", originator="attitude")

tle = (
    "1 40027U PLANET   20053.08335648  .00000000  00000+0  34079-4 0    09",
    "2 40027 097.9376 341.9424 0011991 325.7224 261.4362 14.90036668    06",
)
o = orbit.EphemerisOrbit.from_tle(
    *tle, start="2020-02-22T02:00:00", stop="2020-02-22T02:30:00", step=60.0
)
o.to_oem(HERE / "orbit.oem", object_name="FLOCK 1C-1", object_id="2014-033R")
print("written:", *sorted(p.name for p in HERE.glob("*.[ao]em")))

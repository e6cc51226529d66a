"""Every orbit source drives the gravity gradient; epochs flow orbit -> Dataset -> AEM.

GG runs on a secular-J2 orbit with J2 = 0, on the Kepler orbit sampled into a Hermite table and
on that table written to an OEM file and read back must agree with the Kepler run: the orbits
coincide (to the interpolation error), so the attitudes must too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import attitude
from attitude import scenario
from attitude.errors import AttitudeValueError
from attitude.scenario import ScenarioError
from orbit import EphemerisOrbit, KeplerOrbit, SecularJ2Orbit

# CBERS-2 (NORAD 28057), as in tests/test_ephemeris.py and the shipped SSO scenario
L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"

pytestmark = pytest.mark.filterwarnings("ignore:initial state projected")

EPOCH = "2024-03-20T12:00:00"
ELEMENTS = (7000.0, 0.2, math.pi / 6, math.pi / 4, math.pi / 12)  # Arribas et al. Sect. 6.2
Q0 = np.array([0.5, -0.7071067811865476, 0.0, 0.5])
P0 = np.array([0.3, -0.848528, 0.141421, -1.5])


def run(orb, t, **kw):
    body = attitude.RigidBody([400.0, 500.0, 600.0], units="kg km2")
    return attitude.propagate(
        body, Q0, P0, t, potential=attitude.GravityGradient(orb), rtol=1e-12, atol=1e-14, **kw
    )


@pytest.fixture(scope="module")
def kepler_and_sources(tmp_path_factory):
    kep = KeplerOrbit(*ELEMENTS, epoch=EPOCH)
    T = kep.period
    eph = EphemerisOrbit.from_orbit(kep, 0.0, T, 60.0)
    path = eph.to_oem(tmp_path_factory.mktemp("oem") / "kepler.oem")
    return kep, {
        "secular_j2 (J2 = 0)": SecularJ2Orbit(*ELEMENTS, j2=0.0, epoch=EPOCH),
        "from_orbit": eph,
        "from_oem": EphemerisOrbit.from_oem(path),
    }


def test_gravity_gradient_on_every_source_agrees_with_kepler(kepler_and_sources):
    kep, sources = kepler_and_sources
    t = np.linspace(0.0, kep.period, 101)
    ref = run(kep, t)
    assert ref.attrs["epoch"] == "2024-03-20T12:00:00.000000Z"
    for name, orb in sources.items():
        ds = run(orb, t)
        ang = float(np.max(ds.attitude.angle_between(ref).values))
        dE = float(np.max(np.abs(ds["energy"].values - ref["energy"].values)))
        assert ang < 1e-9, (name, ang)  # measured 1e-12 .. 3e-11 rad
        assert dE < 1e-9 * abs(float(ref["energy"].values[0])), (name, dE)
        assert ds.attrs["epoch"] == ref.attrs["epoch"], name
        assert ds.attrs["orbit_frame"] == "GCRS"
        np.testing.assert_allclose(ds["r"].values, ref["r"].values, rtol=1e-11)


def test_epoch_flows_to_the_dataset_and_the_aem_across_a_leap_second(tmp_path):
    import ccsds_ndm

    from attitude.aem import write_aem

    kep = KeplerOrbit(*ELEMENTS, epoch="2016-12-31T23:59:58")
    ds = run(kep, np.arange(0.0, 5.0))
    assert ds.attrs["epoch"] == "2016-12-31T23:59:58.000000Z"
    stamps = [s[:19] for s in ds.attitude.times().isot]
    assert stamps == [
        "2016-12-31T23:59:58",
        "2016-12-31T23:59:59",
        "2016-12-31T23:59:60",
        "2017-01-01T00:00:00",
        "2017-01-01T00:00:01",
    ]
    path = write_aem(ds, tmp_path / "leap.aem")  # no epoch given: it comes from the orbit
    aem = ccsds_ndm.from_file(str(path))
    text = path.read_text()
    assert "2016-12-31T23:59:60.000000" in text
    q = ds["q"].values
    seg = aem.segments[0]
    assert len(text.splitlines()) > 5 and seg is not None
    # the data line of the leap second carries the attitude at t = 2 s (scalar last)
    line = next(ln for ln in text.splitlines() if ln.startswith("2016-12-31T23:59:60"))
    vals = np.array([float(x) for x in line.split()[1:5]])
    np.testing.assert_allclose(vals, [*q[2, 1:], q[2, 0]], rtol=0, atol=1e-15)
    # the same epoch in another time scale is the same run; another instant is an error
    same = run(kep, np.arange(0.0, 2.0), epoch="2017-01-01T00:00:34 TAI")  # TAI − UTC = 36 s before
    assert same.attrs["epoch"] == "2016-12-31T23:59:58.000000Z"
    with pytest.raises(AttitudeValueError) as err:
        run(kep, np.arange(0.0, 2.0), epoch="2016-12-31T23:59:59")
    msg = str(err.value)
    assert msg.startswith("epoch: the run's epoch 2016-12-31T23:59:59.000000Z differs")
    assert "2016-12-31T23:59:58.000000Z" in msg
    # an orbit without epoch takes the run's
    free = run(KeplerOrbit(*ELEMENTS), np.arange(0.0, 2.0), epoch="2020-01-01T00:00:00")
    assert free.attrs["epoch"] == "2020-01-01T00:00:00.000000Z"
    with pytest.raises(AttitudeValueError, match=r"^epoch: astropy cannot read"):
        run(kep, np.arange(0.0, 2.0), epoch="2016-13-01T00:00:00")


def test_times_outside_an_ephemeris_are_rejected_before_any_work():
    kep = KeplerOrbit(*ELEMENTS, epoch=EPOCH)
    eph = EphemerisOrbit.from_orbit(kep, 0.0, 600.0, 60.0)
    with pytest.raises(
        AttitudeValueError, match=r"^t: times from 0.0 s to 700.0 s since the epoch"
    ):
        run(eph, np.linspace(0.0, 700.0, 8))
    with pytest.raises(ValueError, match=r"^t: times from"):
        attitude.GravityGradient(eph, inertia=[1.0, 2.0, 3.0]).value([1.0, 0, 0, 0], 601.0)


# ---------------------------------------------------------------------------------------------
# Scenarios and the command line.
ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]

BASE = """
[scenario]
{scenario}
[body]
inertia = [120.0, 150.0, 180.0]
inertia_unit = "kg m2"
[initial_state]
form = "body_rates"
frame = "orbital"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.0, 0.0, 0.0]
omega_unit = "rad/s"
[potential]
kind = "gravity_gradient"
[orbit]
{orbit}
[time]
stop = {stop}
step = 10.0
unit = "s"
"""


def load(orbit, scenario_table="", stop=100.0, path=None):
    text = BASE.format(orbit=orbit, scenario=scenario_table, stop=stop)
    return scenario.loads(text, path=path)


TLE = f'tle = ["{L1}", "{L2}"]'


def test_tle_scenario_defaults_to_the_element_set_epoch():
    sc = load(TLE)
    assert sc.epoch == "2006-06-26T18:52:04.079712Z"  # day 177.78615833 of 2006
    orb = sc.potential.orbit
    assert isinstance(orb, EphemerisOrbit) and orb.time_span[1] == pytest.approx(100.0)
    ds = sc.run()
    assert ds.attrs["epoch"] == sc.epoch and "TLE 28057" in ds.attrs["orbit"]
    # the body starts aligned with the orbital frame: p(0) = q(0)
    p0 = orb.frame_quaternion(0.0)
    assert (
        min(np.linalg.norm(ds["q"].values[0] - p0), np.linalg.norm(ds["q"].values[0] + p0)) < 1e-12
    )


def test_shipped_tle_scenario_loads():
    sc = scenario.load(ROOT / "scenarios/sso_tle_gravity_gradient.toml")
    orb = sc.potential.orbit
    assert sc.epoch == "2006-06-27T00:00:00.000000Z" and orb.time_span == (0.0, 86400.0)
    assert sc.t[-1] == 86400.0


def test_secular_j2_and_oem_scenarios(tmp_path):
    els = 'a = 7078.137\na_unit = "km"\ne = 0.001\ninc = 98.19\ninc_unit = "deg"\n' + (
        'raan = 10.0\nraan_unit = "deg"\nargp = 0.0\nargp_unit = "deg"\n'
    )
    sc = load('type = "secular_j2"\nepoch = "2024-03-20T12:00:00"\n' + els)
    orb = sc.potential.orbit
    assert isinstance(orb, SecularJ2Orbit) and orb.j2 == 1.08263e-3
    assert sc.epoch == "2024-03-20T12:00:00.000000Z"
    kep = KeplerOrbit(7000.0, 0.001, 1.0, 0.3, 0.2, epoch="2024-03-20T12:00:00")
    EphemerisOrbit.from_orbit(kep, 0.0, 600.0, 60.0).to_oem(tmp_path / "eph.oem")
    sc = load('oem = "eph.oem"', path=tmp_path / "s.toml")
    assert isinstance(sc.potential.orbit, EphemerisOrbit)
    assert sc.epoch == "2024-03-20T12:00:00.000000Z"
    ds = sc.run()
    assert ds.attrs["orbit_frame"] == "GCRS" and "OEM eph.oem" in ds.attrs["orbit"]
    with pytest.raises(ScenarioError, match=r"^time: times from"):
        load('oem = "eph.oem"', path=tmp_path / "s.toml", stop=700.0)


@pytest.mark.parametrize(
    "orbit,scen,key,what",
    [
        (TLE.replace("1836", "1837"), "", "orbit.tle", "checksum"),
        ('tle = ["1 2", "3"]', "", "orbit.tle", "line1"),
        ('tle = "one line"', "", "orbit.tle", "two TLE lines"),
        (TLE + '\na = 7000.0\na_unit = "km"', "", "orbit.a", "not used with an orbit of type"),
        (TLE + '\ntype = "kepler_j4"', "", "orbit.type", "expected one of"),
        ('oem = "missing.oem"', "", "orbit.oem", "no such OEM file"),
        (TLE + '\noem = "x.oem"', "", "orbit.oem", "either"),
        (
            TLE + '\nepoch = "2006-06-27T00:00:00"',
            'epoch = "2006-06-27T00:00:01"',
            "orbit.epoch",
            "differs from scenario.epoch",
        ),
        (TLE + '\nepoch = "June 27"', "", "orbit.epoch", "ISO 8601"),
    ],
)
def test_orbit_table_errors_name_the_key(orbit, scen, key, what):
    with pytest.raises(ScenarioError) as err:
        load(orbit, scen)
    msg = str(err.value)
    assert msg.startswith(key + ":"), msg
    assert what in msg, msg


def test_cli_info_prints_orbit_source_epoch_and_frame(tmp_path, capsys):
    from attitude.cli import main

    out = tmp_path / "sso.nc"
    src = ROOT / "scenarios/sso_tle_gravity_gradient.toml"
    assert main(["run", str(src), "-o", str(out), "--stop", "0.05", "-q"]) == 0
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    lines = {ln.split(None, 1)[0]: ln.split(None, 1)[1] for ln in text.splitlines() if ln.strip()}
    assert lines["orbit"].startswith("TLE 28057")
    assert lines["frame"] == "GCRS"
    assert lines["epoch"] == "2006-06-27T00:00:00.000000Z"

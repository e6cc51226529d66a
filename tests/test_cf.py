"""CF-1.11 files that CF tools accept, and SI units that every unit library reads alike.

Truth: the IOOS compliance checker (``compliance-checker --test=cf:1.11``, called as a library)
on the output of every shipped scenario and on every kind of ensemble file: no errors, and no
warning but the two docs/results.md documents; xarray's and netCDF4's CF time
decoding against astropy's ``epoch + time``; the unit attrs against dimensions derived
independently (astropy, from the physics: g = I ω, T = ½ I ω², τ = r × F), parsed by astropy,
UDUNITS (cf_units) and pint's default registry; the same physics from km-based and SI input.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr
from astropy import units as u
from astropy.time import Time

import attitude.accessor  # noqa: F401 - registers ds.attitude
from attitude import canonical as C
from attitude import io, scenario
from attitude.body import RigidBody
from attitude.potentials import GravityGradient, HeavyTop
from attitude.propagate import propagate

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"
# Short spans (in each scenario's time unit): the checker looks at the file's structure.
SHORT = {
    "paper_torque_free": 1.0,
    "paper_heavy_top": 1.0,
    "paper_keplerian": 60.0,
    "gg_stabilised_leo": 2.0,
    "tumbling_upper_stage": 60.0,
    "sso_tle_gravity_gradient": 0.02,  # hours
    "cubesat_environment": 0.01,  # hours
    "lvlh_pointing_events": 6000.0,  # its events occur (the last one ends the run)
    "rw_inertial_pointing": 5.0,
    "cubesat_bdot": 0.01,  # hours
    "nadir_wheels_dumping": 0.01,  # hours
    "orbit_raising_burn": 0.2,  # hours: the burn starts at 0.167 h
    "cubesat_drag_decay": 0.02,  # hours
}


#: The checker's warnings that docs/results.md documents (and why they stay): variable names
#: that differ only by case (§2.3: the paper's q/Q and the body/space g/G), and, in ensemble
#: files, dimensions right of T (§2.4: (member, time, component): quaternion and vector
#: components last, as everywhere in the package; `member`, not `time`, is the unlimited one).
CASE_PAIRS = {"q", "g", "initial_q", "event_q"}
ORDER_VARIABLES = {"q", "Q", "omega", "g", "G", "p", "reference_q"}


def cf_report(path: Path, tmp_path: Path) -> tuple[list[str], list[str]]:
    """The errors (high-priority failures) and the warnings (medium and low) of
    ``compliance-checker --test=cf:1.11``, each as 'section: message'."""
    pytest.importorskip("compliance_checker")
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    with warnings.catch_warnings():  # its deprecated ioos_sos plugin warns on loading
        warnings.simplefilter("ignore", DeprecationWarning)
        CheckSuite.load_all_available_checkers()
    out = tmp_path / f"{path.stem}.cf.json"
    ComplianceChecker.run_checker(
        str(path), ["cf:1.11"], 0, "strict", output_filename=str(out), output_format="json"
    )
    report = json.loads(out.read_text())["cf:1.11"]
    assert report["possible_points"] > 50  # the checker really ran its checks

    def failed(level):
        return [
            f"{r['name']}: {m}" for r in report[level] if r["value"][0] < r["value"][1]
            for m in r["msgs"]
        ]  # fmt: skip

    return failed("high_priorities"), failed("medium_priorities") + failed("low_priorities")


def undocumented(warns: list[str], ensemble: bool) -> list[str]:
    """The warnings that are not the documented ones."""
    out = []
    for w in warns:
        if w.startswith("§2.3 ") and "Duplicate variables named: " in w:
            if w.rsplit(": ", 1)[1].strip() in CASE_PAIRS:
                continue
        if ensemble and w.startswith("§2.4 ") and "spatio-temporal dimensions" in w:
            if w.split(": ", 1)[1].split("'s ")[0] in ORDER_VARIABLES:
                continue
        out.append(w)
    return out


def cf_errors(path: Path, tmp_path: Path) -> list[str]:
    """The checker's errors, and its warnings other than the documented ones."""
    errors, warns = cf_report(path, tmp_path)
    with netCDF4.Dataset(path) as nc:
        ensemble = "member" in nc.dimensions
    return errors + undocumented(warns, ensemble)


def run_short(name: str, tmp_path: Path) -> Path:
    sc = scenario.load(SCEN / f"{name}.toml")
    sc.t = sc.t[sc.t <= SHORT[name] * sc.time_scale]
    return Path(sc.run_to_file(tmp_path / f"{name}.nc")["path"])


def test_every_shipped_scenario_is_listed():
    single = {p.stem for p in SCEN.glob("*.toml") if not p.stem.startswith("ensemble_")}
    assert single == set(SHORT)


#: Scenarios whose files hold no variable, dimension or attribute (global or a variable's) that
#: the others' do not: slow, their closed-loop driver compiled for them alone (nadir_wheels_
#: dumping: four wheels with friction, momentum dumping through magnetorquers, the five
#: environment torques; the same schema as rw_inertial_pointing, cubesat_bdot and
#: cubesat_environment together, ~15 s of a fresh cache).
SLOW = ("nadir_wheels_dumping",)


@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in sorted(SHORT)]
)
def test_compliance_checker_no_errors_on_shipped_scenarios(name, tmp_path):
    path = run_short(name, tmp_path)
    assert cf_errors(path, tmp_path) == []


def test_compliance_checker_no_errors_on_ensemble_file(tmp_path):
    from attitude.ensemble import run_scenario

    sc = scenario.load(SCEN / "ensemble_paper_keplerian.toml")
    sc.t = sc.t[:3]
    sc.ensemble.size = 8
    path = tmp_path / "ens.nc"
    run_scenario(sc, path)
    assert cf_errors(path, tmp_path) == []
    with netCDF4.Dataset(path) as nc:  # the ensemble file carries the run's epoch as CF time
        assert nc.variables["time"].units == "seconds since 2000-05-15 12:00:00.000000"
        assert nc.variables["inertia"].coordinates == "axis_label"
    back = xr.open_dataset(path)  # CF decoding: datetimes, label coordinates
    assert np.issubdtype(back.time.dtype, np.datetime64)
    assert "component_label" in back.coords and "axis_label" in back.coords
    back.close()


@pytest.mark.parametrize("output", ["statistics", "final"])
def test_compliance_checker_no_errors_on_ensemble_output_choices(output, tmp_path):
    """Statistics-only files (a percentile coordinate) and final-state files are CF too."""
    from attitude.ensemble import run_scenario

    sc = scenario.load(SCEN / "ensemble_paper_keplerian.toml")
    sc.t = sc.t[:4]
    sc.ensemble.size = 8
    path = tmp_path / f"{output}.nc"
    run_scenario(sc, path, output=output)
    assert cf_errors(path, tmp_path) == []
    back = xr.open_dataset(path)
    assert np.issubdtype(back.time.dtype, np.datetime64)
    if output == "statistics":
        assert back.percentile.attrs["units"] == "percent"
        assert back.pointing_error_percentiles.dims == ("percentile", "time")
    back.close()


def test_compliance_checker_no_errors_on_lazy_ensemble_file(tmp_path):
    """The Dask-graph writer (``lazy=True``, xarray's to_netcdf) writes CF files as well."""
    pytest.importorskip("dask")
    from attitude.ensemble import propagate_ensemble

    sc = scenario.load(SCEN / "paper_keplerian.toml")
    q0, Q0, _ = C.project_state(sc.q0, sc.Q0)
    rng = np.random.default_rng(5)
    from attitude import quaternion as qt

    q = qt.multiply(q0, qt.from_rotation_vector(0.05 * rng.normal(size=(6, 3))))
    Q = C.momenta_from_body_angular_momentum(q, C.body_angular_momentum(q0, Q0))
    path = tmp_path / "lazy.nc"
    ds = propagate_ensemble(sc.body, q, Q, np.linspace(0.0, 600.0, 5), sc.potential,
                            path=path, lazy=True, attrs={"epoch": sc.epoch})  # fmt: skip
    ds.close()
    assert cf_errors(path, tmp_path) == []


def test_event_times_are_encoded_as_time_in_single_runs_and_ensembles(tmp_path):
    """One convention: event_time, detector_first_time (single runs) and event_first_time
    (ensembles) carry the encoding of `time` (seconds since the epoch): io.read gives the
    numbers, CF tools decode datetimes, for both kinds of file."""
    from attitude.ensemble import run_scenario

    path = run_short("lvlh_pointing_events", tmp_path)
    exact = io.read(path)
    assert exact.sizes["event"] >= 2
    keys = ("units", "calendar", "units_metadata", "elapsed_time_units")
    for name in ("event_time", "detector_first_time"):
        assert {k: exact[name].attrs[k] for k in keys} == {k: exact.time.attrs[k] for k in keys}
    assert exact.time.attrs["units_metadata"] == "leap_seconds: utc"
    # the terminal event is the last sample, bit for bit
    assert exact.event_time.values[-1] == exact.time.values[-1]
    dec = xr.open_dataset(path)
    for name in ("time", "event_time", "detector_first_time"):
        assert np.issubdtype(dec[name].dtype, np.datetime64), name
    t_ref = exact.attitude.epoch + exact.attitude.quantity("event_time")
    got = Time(dec.event_time.values.astype("datetime64[ns]"), scale="utc")
    assert np.max(np.abs((got - t_ref).to_value("s"))) < 1e-6
    np.testing.assert_allclose(
        dec.attitude.quantity("event_time").to_value("s"), exact.event_time.values, atol=1e-9
    )
    dec.close()
    sc = scenario.load(SCEN / "ensemble_paper_keplerian.toml")
    sc.t = sc.t[:4]
    sc.ensemble.size = 8
    ens_path = tmp_path / "ens.nc"
    run_scenario(sc, ens_path)
    ens = io.read(ens_path)
    first = ens.event_first_time
    assert {k: first.attrs[k] for k in keys} == {k: ens.time.attrs[k] for k in keys}
    dec = xr.open_dataset(ens_path)
    assert np.issubdtype(dec.event_first_time.dtype, np.datetime64)
    dec.close()


def test_dataset_in_memory_is_the_file(tmp_path):
    sc = scenario.load(SCEN / "gg_stabilised_leo.toml")
    sc.t = sc.t[:5]
    ds = sc.run()
    assert ds.time.attrs["units"] == "seconds since 2024-03-20 12:00:00.000000"
    assert ds.attrs["epoch"] == "2024-03-20T12:00:00.000000Z"  # the exact epoch, as before
    back = io.read(io.write(ds, tmp_path / "g.nc"))
    xr.testing.assert_identical(ds, back)
    for name in ds.variables:
        assert ds[name].values.tobytes() == back[name].values.tobytes(), name
    # a file streamed by the scenario runner holds the same time attrs as the in-memory run
    streamed = io.read(sc.run_to_file(tmp_path / "s.nc")["path"])
    assert streamed.time.attrs == ds.time.attrs


def test_cf_time_decodes_to_the_astropy_times(tmp_path):
    sc = scenario.load(SCEN / "tumbling_upper_stage.toml")
    sc.t = sc.t[:31]
    path = Path(sc.run_to_file(tmp_path / "t.nc")["path"])
    exact = io.read(path)
    t_ref = exact.attitude.times()  # astropy: epoch + TimeDelta
    # netCDF4.num2date reads the CF units
    with netCDF4.Dataset(path) as nc:
        tv = nc.variables["time"]
        assert (tv.standard_name, tv.axis, tv.calendar) == ("time", "T", "standard")
        dates = netCDF4.num2date(tv[:], tv.units, tv.calendar, only_use_cftime_datetimes=False)
    assert str(dates[-1]) == "2024-06-01 00:05:00"
    # xarray decodes datetimes; no leap second between the epoch and the samples here
    dec = xr.open_dataset(path)
    assert np.issubdtype(dec.time.dtype, np.datetime64)
    decoded = Time(dec.time.values.astype("datetime64[ns]"), scale="utc")
    assert np.max(np.abs((decoded - t_ref).to_value("s"))) < 1e-6
    # the accessor works on the decoded Dataset: the same relative times and absolute times
    np.testing.assert_allclose(
        dec.attitude.quantity("time").to_value("s"), exact.time.values, rtol=0, atol=1e-9
    )
    assert np.max(np.abs((dec.attitude.times() - t_ref).to_value("s"))) < 1e-9
    dec.close()


def test_leap_second_caveat_is_real_and_documented(tmp_path):
    # 2016-12-31T23:59:60 was a leap second: 10 s after 23:59:55 is 00:00:04 (astropy, UTC),
    # while a CF "standard" calendar (no leap seconds) decodes 00:00:05.
    body = RigidBody([1.0, 2.0, 2.5], units="kg m2")
    ds = propagate(body, [1, 0, 0, 0], [0, 0.2, 0.1, 0.0], [0.0, 10.0])
    ds.attrs["epoch"] = "2016-12-31T23:59:55.000000Z"
    path = io.write(ds, tmp_path / "leap.nc")
    back = io.read(path)
    assert "leap seconds" in back.time.attrs["comment"]
    assert "seconds since 2016-12-31 23:59:55" in back.time.attrs["units"]
    exact = back.attitude.times()
    assert exact[-1].isot == "2017-01-01T00:00:04.000"
    cf = xr.open_dataset(path)
    assert str(cf.time.values[-1])[:19] == "2017-01-01T00:00:05"
    assert np.array_equal(cf.attitude.times().isot, exact.isot)  # the accessor stays exact
    cf.close()


def test_runs_without_epoch_say_so(tmp_path):
    tf = scenario.load(SCEN / "paper_torque_free.toml")
    tf.t = tf.t[:5]
    ds = tf.run()
    a = ds.time.attrs
    assert a["elapsed_time_units"] == "1" and "dimensionless" in a["comment"]
    assert "placeholder" in a["comment"] and "no epoch" in a["long_name"]
    assert ds.attitude.quantity("time").unit == u.dimensionless_unscaled
    with pytest.raises(ValueError, match="no epoch"):
        ds.attitude.times()
    # decoded by xarray, the accessor still gives the dimensionless numbers
    dec = xr.open_dataset(io.write(ds, tmp_path / "tf.nc"))
    t = dec.attitude.quantity("time")
    assert t.unit == u.dimensionless_unscaled
    np.testing.assert_allclose(t.value, ds.time.values, rtol=0, atol=1e-9)
    dec.close()


# ------------------------------------------------------------------------------------------------
# units
# ------------------------------------------------------------------------------------------------


def expected_units():
    """Units of every variable of a body with units, derived from the physics with astropy."""
    inertia = u.kg * u.m**2  # SI body
    rate = u.rad / u.s
    g = inertia * rate  # g = I ω
    energy = inertia * rate**2  # T = ½ I ω²
    return {
        "q": u.one,
        "Q": g,  # Q = 2 q∘(0, g)
        "omega": rate,
        "g": g,
        "G": g,
        "energy": energy,
        "potential_energy": u.N * u.m,  # U = weight × height
        "norm_error": u.one,
        "qQ": g,
        "r": u.km,  # the orbit stays in km
        "f": u.rad,
        "p": u.one,
        "torque": g * rate,  # dg/dt = τ − ω × g: the torque has the units of g/s
    }


def _same(unit_str: str, expected) -> float:
    """Conversion factor of ``unit_str`` to ``expected`` in astropy (radians dimensionless)."""
    return float(u.Unit(unit_str).to(expected, equivalencies=u.dimensionless_angles()))


@pytest.fixture(scope="module")
def gg_run(tmp_path_factory):
    sc = scenario.load(SCEN / "gg_stabilised_leo.toml")
    sc.t = sc.t[:4]
    path = tmp_path_factory.mktemp("units") / "gg.nc"
    sc.run_to_file(path)
    return io.read(path)


def test_unit_attrs_are_si_and_exact(gg_run):
    exp = expected_units()
    assert set(gg_run.data_vars) == set(exp)
    for name, unit in exp.items():
        s = gg_run[name].attrs["units"]
        assert _same(s, unit) == 1.0, (name, s)  # SI itself, not a multiple
    assert gg_run.attrs["inertia_units"] == "kg m^2"
    assert _same(gg_run.attrs["inertia_units"], u.kg * u.m**2) == 1.0


def test_unit_strings_parse_alike_in_pint_udunits_and_astropy(gg_run):
    pint = pytest.importorskip("pint")
    cf_units = pytest.importorskip("cf_units")
    ureg = pint.UnitRegistry()
    si = {  # the same expected unit, written for each library from the SI base units
        "q": "1",
        "Q": "kg m^2 s^-1",
        "omega": "rad s^-1",
        "g": "kg m^2 s^-1",
        "G": "kg m^2 s^-1",
        "energy": "kg m^2 s^-2",
        "potential_energy": "kg m^2 s^-2",
        "norm_error": "1",
        "qQ": "kg m^2 s^-1",
        "r": "km",
        "f": "rad",
        "p": "1",
        "torque": "kg m^2 s^-2",
    }
    names = [*gg_run.data_vars, "inertia_units"]
    for name in names:
        s = gg_run.attrs[name] if name == "inertia_units" else gg_run[name].attrs["units"]
        ref = "kg m^2" if name == "inertia_units" else si[name]
        # pint's default registry
        assert float(ureg.Quantity(1.0, s).to(ref).magnitude) == pytest.approx(1.0, rel=1e-15)
        # UDUNITS-2 through cf_units
        assert cf_units.Unit(s).convert(1.0, cf_units.Unit(ref)) == pytest.approx(1.0, rel=1e-15)
        # astropy
        assert u.Unit(s).to(u.Unit(ref)) == pytest.approx(1.0, rel=1e-15)


def test_pint_xarray_quantifies_a_decoded_file(tmp_path):
    pytest.importorskip("pint_xarray")
    sc = scenario.load(SCEN / "paper_keplerian.toml")
    sc.t = sc.t[:3]
    path = Path(sc.run_to_file(tmp_path / "k.nc")["path"])
    ds = xr.open_dataset(path)  # CF-decoded: time is datetime64, its units in the encoding
    q = ds.pint.quantify()
    assert str(q.G.pint.units) == "kilogram * meter ** 2 / second"
    E = q.energy.pint.to("kJ")
    np.testing.assert_allclose(E.pint.magnitude, ds.energy.values / 1e3, rtol=1e-15)
    assert str(q.r.pint.units) == "kilometer"
    ds.close()


# ------------------------------------------------------------------------------------------------
# SI results and the same physics from km-based input
# ------------------------------------------------------------------------------------------------


def test_500_kg_satellite_prints_in_si(tmp_path, capsys):
    from attitude.cli import main

    path = tmp_path / "sat.nc"
    assert main(["run", str(SCEN / "gg_stabilised_leo.toml"), "-o", str(path), "--stop", "1"]) == 0
    capsys.readouterr()
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "inertia [60.0, 950.0, 1000.0] kg m^2" in out
    assert "energy [J]" in out and "G [kg m^2 s^-1]" in out and "time span   0 .. 60 s" in out
    ds = io.read(path)
    # |G| = I ω with ω ~ the orbital rate 1e-3 rad/s: O(1) N m s, not O(1e-6)
    assert 0.1 < float(np.linalg.norm(ds.G.values[0])) < 10.0


def test_km_based_input_gives_the_same_physics_as_si(tmp_path):
    """The Sect. 6.2 satellite given in kg km² (the paper) and in kg m² (SI): same motion."""
    km = scenario.load(SCEN / "paper_keplerian.toml")
    si_text = (
        km.source.replace("inertia = [400.0, 500.0, 600.0]", "inertia = [4e8, 5e8, 6e8]")
        .replace('inertia_unit = "kg km2"', 'inertia_unit = "kg m2"')
        .replace("Q = [0.3, -0.848528, 0.141421, -1.5]", "Q = [3e5, -848528.0, 141421.0, -1.5e6]")
        .replace('Q_unit = "kg km2 s-1"', 'Q_unit = "N m s"')
    )
    si = scenario.loads(si_text)
    for sc in (km, si):
        sc.t = sc.t[sc.t <= 600.0]
    a, b = km.run(), si.run()
    np.testing.assert_allclose(a.q.values, b.q.values, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.energy.values, b.energy.values, rtol=1e-12)
    assert a.energy.attrs["units"] == b.energy.attrs["units"] == "J"


def test_si_body_scales_like_the_old_km_system():
    """The gravity gradient 3μ/r³ is in s⁻² whatever the length unit: a body in kg m² gets
    torques in N m and energies in J, 1e6 times the numbers of the same body in kg km²."""
    from orbit.keplerorbit import KeplerOrbit

    o = KeplerOrbit(7000.0, 0.2, 0.5, 0.7, 0.3)
    q0 = np.array([0.5, -0.7071067811865476, 0.0, 0.5])
    w0 = np.array([1e-3, -2e-3, 1.5e-3])
    t = np.linspace(0.0, 2000.0, 11)
    I_km = np.array([400.0, 500.0, 600.0])  # plain numbers: the old km-based system
    old = propagate(I_km, q0, C.momenta_from_angular_velocity(q0, w0, I_km), t,
                    GravityGradient(o), rtol=1e-12, atol=1e-20)  # fmt: skip
    body = RigidBody(I_km * u.Unit("kg km2"))
    new = propagate(body, q0, C.momenta_from_angular_velocity(q0, w0, body), t,
                    GravityGradient(o), rtol=1e-12, atol=1e-14)  # fmt: skip
    np.testing.assert_allclose(new.q.values, old.q.values, rtol=0, atol=1e-10)
    np.testing.assert_allclose(new.G.values, old.G.values * 1e6, rtol=1e-9)
    np.testing.assert_allclose(new.energy.values, old.energy.values * 1e6, rtol=1e-9)
    np.testing.assert_allclose(new.omega.values, old.omega.values, rtol=1e-9)
    # the torque in N m: τ = 3μ/r³ x̂_B × I x̂_B, μ in km³ s⁻², r in km, I in kg m²
    from attitude.quaternion import rotate, rotate_inverse

    tau = GravityGradient(o, inertia=body).torque(q0, 0.0)
    r = float(np.asarray(o.radius(0.0)))
    p = np.asarray(o.frame_quaternion(0.0), dtype=float).reshape(4)
    x = rotate_inverse(q0, rotate(p, [1.0, 0.0, 0.0]))  # radial direction in body axes
    tau_ref = 3 * o.mu / r**3 * np.cross(x, body.inertia * x)
    np.testing.assert_allclose(tau, tau_ref, rtol=1e-12, atol=1e-14 * np.max(np.abs(tau_ref)))


def test_heavy_top_in_si_and_km_units_is_one_physics():
    q0 = np.array([0.5, -0.7071067811865476, 0.0, 0.5])
    w0 = np.array([0.3, -0.2, 0.4])  # rad/s
    t = np.linspace(0.0, 5.0, 11)
    body_si = RigidBody([2.0, 2.5, 3.0], units="kg m2")
    top_si = HeavyTop(9.80665 * 1.5 * u.N, [0.1, 0.0, 0.2] * u.m)
    body_km = RigidBody([2.0e-6, 2.5e-6, 3.0e-6] * u.Unit("kg km2"))
    top_km = HeavyTop(9.80665 * 1.5e-3 * u.Unit("kg km / s2"), [1e-4, 0.0, 2e-4] * u.km)
    assert body_km == body_si or np.allclose(body_km.inertia, body_si.inertia, rtol=1e-15)
    assert top_km.weight == pytest.approx(top_si.weight, rel=1e-15)
    a = propagate(body_si, q0, C.momenta_from_angular_velocity(q0, w0, body_si), t, top_si)
    b = propagate(body_km, q0, C.momenta_from_angular_velocity(q0, w0, body_km), t, top_km)
    np.testing.assert_allclose(a.q.values, b.q.values, rtol=0, atol=1e-12)
    assert a.potential_energy.attrs["units"] == "J"
    # U = weight × height of the centre of mass: at t = 0, weight (R(q) c)·s3, in J
    from attitude.quaternion import rotate

    U0 = top_si.weight * rotate(q0, top_si.center_of_mass)[2]
    assert a.potential_energy.values[0] == pytest.approx(U0, rel=1e-14)


def test_heavy_top_scenario_units_convert_to_si():
    text = """
    [body]
    inertia = [2.0e4, 2.5e4, 3.0e4]
    inertia_unit = "kg cm2"
    [initial_state]
    form = "body_rates"
    q = [1.0, 0.0, 0.0, 0.0]
    omega = [10.0, 0.0, 5.0]
    omega_unit = "deg/s"
    [potential]
    kind = "heavy_top"
    weight = 1.5e5
    weight_unit = "dyn"
    center_of_mass = [10.0, 0.0, 20.0]
    center_of_mass_unit = "cm"
    [time]
    stop = 1.0
    step = 0.5
    unit = "s"
    """
    sc = scenario.loads(text)
    np.testing.assert_allclose(sc.body.inertia, [2.0, 2.5, 3.0], rtol=1e-15)  # kg m²
    assert sc.potential.weight == pytest.approx(1.5, rel=1e-15)  # N (1 dyn = 1e-5 N)
    np.testing.assert_allclose(sc.potential.center_of_mass, [0.1, 0.0, 0.2], rtol=1e-15)  # m
    ds = sc.run()
    assert ds.potential_energy.attrs["units"] == "J"
    with pytest.raises(scenario.ScenarioError, match=r"center_of_mass_unit.*position"):
        scenario.loads(text.replace('center_of_mass_unit = "cm"', 'center_of_mass_unit = "s"'))

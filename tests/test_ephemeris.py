"""EphemerisOrbit: Hermite tables from arrays, TLEs (sgp4 + astropy) and OEM files.

References are computed independently: sgp4's ``Satrec.sgp4_array`` and astropy's TEME -> GCRS
called directly at off-grid times, KeplerOrbit's closed form, the Hermite remainder bound, the
convergence order under step halving, and files read back by ccsds-ndm-py itself; XML OEMs
written by Orekit (tests/data/ccsds, tests/data/ccsds/orekit_convert.py); an OEM holding SGP4's
own velocities (not dr/dt of its positions).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import orbit
from orbit import EphemerisOrbit, KeplerOrbit, OrbitTypeError, OrbitValueError
from orbit import _state_kernels as SK

# CBERS-2 (NORAD 28057), a sun-synchronous LEO; element set of the SGP4 verification set
# (Vallado et al. 2006, AIAA 2006-6753), as in scenarios/sso_tle_gravity_gradient.toml.
L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"
START, STOP = "2006-06-27T00:00:00", "2006-06-28T00:00:00"
DATA = __import__("pathlib").Path(__file__).resolve().parent / "data/ccsds"


def tle_checksum(line68: str) -> str:
    s = 0
    for c in line68:
        s += int(c) if c.isdigit() else (1 if c == "-" else 0)
    return line68 + str(s % 10)


@pytest.fixture(scope="module")
def tle_orbit():
    return EphemerisOrbit.from_tle(L1, L2, START, STOP)


def sgp4_gcrs_direct(times):
    """sgp4's array API at UTC Julian dates, then astropy TEME -> GCRS: the reference."""
    from astropy import units as u
    from astropy.coordinates import GCRS, TEME, CartesianDifferential, CartesianRepresentation
    from sgp4.api import Satrec

    sat = Satrec.twoline2rv(L1, L2)
    err, r, v = sat.sgp4_array(times.utc.jd1, times.utc.jd2)
    assert np.all(err == 0)
    rep = CartesianRepresentation(r.T * u.km, differentials=CartesianDifferential(v.T * u.km / u.s))
    g = TEME(rep, obstime=times).transform_to(GCRS(obstime=times))
    return g.cartesian.xyz.to_value(u.km).T, g.cartesian.differentials["s"].d_xyz.to_value(
        u.km / u.s
    ).T


def test_from_tle_matches_sgp4_and_astropy_off_grid(tle_orbit):
    from astropy.time import Time, TimeDelta

    rng = np.random.default_rng(13)
    t = np.sort(rng.uniform(0.0, 86400.0, 300))
    t = t[np.abs(t / 60.0 - np.round(t / 60.0)) > 0.05]  # off the 60 s grid
    times = Time(START, scale="utc") + TimeDelta(t, format="sec")
    r_ref, v_ref = sgp4_gcrs_direct(times)
    dr = np.max(np.linalg.norm(tle_orbit.position(t) - r_ref, axis=-1))
    dv = np.max(np.linalg.norm(tle_orbit.velocity(t) - v_ref, axis=-1))
    assert dr <= 1e-6  # km: the bound (measured 7.5e-9 km)
    # the table's velocity is dr/dt of SGP4's position; SGP4's velocity output is not quite
    # that (short-period rates partly left out): they differ by mm/s
    assert 1e-7 < dv <= 5e-5  # km/s (measured 2.0e-5)
    assert tle_orbit.epoch == Time(START, scale="utc")
    assert tle_orbit.frame == "GCRS"
    assert "28057" in tle_orbit.source
    # the nodes themselves are the reference states
    rn, _ = sgp4_gcrs_direct(tle_orbit.absolute_times(tle_orbit.node_times))
    assert np.max(np.abs(tle_orbit.node_states[:, :3] - rn)) < 1e-9


def test_sgp4_velocity_is_not_the_derivative_of_its_position():
    """Why from_tle differentiates positions: SGP4's v differs from dr/dt by mm/s."""
    from sgp4.api import Satrec

    sat = Satrec.twoline2rv(L1, L2)
    tm = np.linspace(300.0, 1300.0, 11)

    def pos(x):
        return sat.sgp4_array(np.full(x.size, sat.jdsatepoch), sat.jdsatepochF + x / 1440)

    d = 1.0 / 60.0
    fd = (-pos(tm + 2 * d)[1] + 8 * pos(tm + d)[1] - 8 * pos(tm - d)[1] + pos(tm - 2 * d)[1]) / 12
    gap = np.max(np.abs(fd - pos(tm)[2]))
    assert 1e-6 < gap < 5e-5  # km/s, far above the difference's own error (~1e-11 km/s)


def test_tle_epoch_option_shifts_the_time_origin(tle_orbit):
    e2 = EphemerisOrbit.from_tle(L1, L2, START, "2006-06-27T03:00:00", epoch="2006-06-26T23:00:00")
    np.testing.assert_allclose(e2.time_span, (3600.0, 14400.0), rtol=0, atol=1e-9)
    t = np.array([3700.0, 9000.0])
    np.testing.assert_allclose(e2.position(t), tle_orbit.position(t - 3600.0), atol=1e-9)


def test_oem_round_trip_reproduces_the_states(tle_orbit, tmp_path):
    import ccsds_ndm

    for frame in ("GCRF", "EME2000"):
        path = tle_orbit.to_oem(tmp_path / f"cbers_{frame}.oem", frame=frame, object_name="CBERS-2")
        back = EphemerisOrbit.from_oem(path)
        assert back.epoch == tle_orbit.epoch
        # UTC stamps written to the ns and read back: the times agree to astropy's rounding
        np.testing.assert_allclose(back.node_times, tle_orbit.node_times, rtol=0, atol=1e-9)
        tol = 0.0 if frame == "GCRF" else 1e-12  # EME2000: frame bias applied and undone
        np.testing.assert_allclose(
            back.node_states, tle_orbit.node_states, rtol=0, atol=tol * 1e4 + 0.0
        )
        t = np.linspace(0.0, 86400.0, 777)
        assert np.max(np.abs(back.position(t) - tle_orbit.position(t))) <= 1e-8
        # the file, read by the reader itself
        msg = ccsds_ndm.Oem.from_file(str(path))
        seg = msg.segments[0]
        assert seg.metadata.ref_frame == frame and seg.metadata.time_system == "UTC"
        raw = np.asarray(seg.data.state_vector_numpy)
        if frame == "GCRF":
            np.testing.assert_array_equal(raw, tle_orbit.node_states)
        else:  # EME2000 differs from GCRS by the ~23 mas frame bias: ~0.8 m at 7000 km
            d = np.linalg.norm(raw[:, :3] - tle_orbit.node_states[:, :3], axis=1)
            assert 0.5e-3 < np.max(d) < 1.0e-3


OEM_TEXT = """CCSDS_OEM_VERS = 2.0
CREATION_DATE = 2017-01-01T00:00:00
ORIGINATOR = TEST

META_START
OBJECT_NAME = SAT
OBJECT_ID = 2017-000A
CENTER_NAME = {center}
REF_FRAME = {frame}
TIME_SYSTEM = {system}
START_TIME = 2016-12-31T23:59:00.000
STOP_TIME = 2017-01-01T00:01:00.000
META_STOP

{lines}
"""


def _oem(tmp_path, epochs, states, frame="GCRF", system="UTC", center="EARTH", name="x.oem"):
    lines = "\n".join(
        e + " " + " ".join(repr(float(x)) for x in s) for e, s in zip(epochs, states, strict=True)
    )
    p = tmp_path / name
    p.write_text(OEM_TEXT.format(frame=frame, system=system, center=center, lines=lines))
    return p


def test_oem_times_across_a_leap_second_and_time_systems(tmp_path):
    kep = KeplerOrbit(7000.0, 0.001, 1.0, 0.5, 0.2)
    t = np.arange(0.0, 121.0, 10.0)
    st = np.concatenate(kep.to_state(t), axis=1)
    from astropy.time import Time, TimeDelta

    t0 = Time("2016-12-31T23:59:00", scale="utc")
    stamps = (t0 + TimeDelta(t, format="sec")).isot
    assert "2016-12-31T23:59:60.000" in stamps  # 61 s after 23:59:00 UTC that night
    e = EphemerisOrbit.from_oem(_oem(tmp_path, stamps, st))
    np.testing.assert_allclose(e.node_times, t, atol=1e-9)  # elapsed SI seconds, leap included
    # TAI and GPS stamps of the same instants give the same table
    for system, offset in (("TAI", 36.0), ("GPS", 17.0)):
        s2 = (Time(t0.tai.mjd, format="mjd", scale="tai") + TimeDelta(t, format="sec")).isot
        if system == "GPS":
            s2 = (t0.tai + TimeDelta(t - 19.0, format="sec")).isot
        e2 = EphemerisOrbit.from_oem(_oem(tmp_path, s2, st, system=system, name=f"{system}.oem"))
        assert abs((e2.epoch - t0).sec) < 1e-6, (system, offset)
        np.testing.assert_allclose(e2.node_times, t, atol=1e-6)


@pytest.mark.parametrize(
    "kw,key",
    [
        ({"frame": "ITRF2000"}, "REF_FRAME"),
        ({"frame": "TEME"}, "REF_FRAME"),
        ({"system": "UT1"}, "TIME_SYSTEM"),
        ({"system": "MET"}, "TIME_SYSTEM"),
        ({"center": "MARS"}, "CENTER_NAME"),
    ],
)
def test_oem_unsupported_frame_time_system_center(tmp_path, kw, key):
    st = np.tile([7000.0, 0.0, 0.0, 0.0, 7.5, 0.0], (3, 1))
    stamps = ["2016-12-31T23:59:00.000", "2016-12-31T23:59:30.000", "2017-01-01T00:00:00.000"]
    with pytest.raises(OrbitValueError) as err:
        EphemerisOrbit.from_oem(_oem(tmp_path, stamps, st, **kw))
    assert str(err.value).startswith(key + ":"), str(err.value)


def test_oem_bad_files(tmp_path):
    with pytest.raises(OrbitValueError, match=r"^path: no such OEM file"):
        EphemerisOrbit.from_oem(tmp_path / "missing.oem")
    p = tmp_path / "junk.oem"
    p.write_text("this is not an OEM\n")
    with pytest.raises(OrbitValueError, match=r"^path: .* not a readable CCSDS OEM"):
        EphemerisOrbit.from_oem(p)
    st = np.tile([7000.0, 0.0, 0.0, 0.0, 7.5, 0.0], (3, 1))
    stamps = ["2017-01-01T00:00:00.000", "2016-12-31T23:59:30.000", "2017-01-01T00:00:30.000"]
    with pytest.raises(OrbitValueError, match=r"strictly increasing"):
        EphemerisOrbit.from_oem(_oem(tmp_path, stamps, st))


@pytest.mark.parametrize("name", ["orekit_orbit.xml.oem", "orekit_orbit_stream.xml.oem"])
def test_xml_oem_written_by_orekit(name):
    """Orekit's XML of our KVN OEM reads to the same table; its streaming writer
    (EphemerisOemWriter) leaves out <segment>, which ccsds-ndm-py refuses and we read."""
    text = (DATA / name).read_text()
    assert text.lstrip().startswith("<?xml") and "<stateVector>" in text
    assert ("<segment>" in text) == (name == "orekit_orbit.xml.oem")
    kvn = EphemerisOrbit.from_oem(DATA / "orbit.oem")
    xml = EphemerisOrbit.from_oem(DATA / name)
    assert xml.epoch == kvn.epoch and xml.node_times.size == 31
    np.testing.assert_array_equal(xml.node_times, kvn.node_times)
    # Orekit prints some doubles one unit in the last place off (its own formatter)
    np.testing.assert_allclose(xml.node_states, kvn.node_states, rtol=2e-16, atol=0)
    assert "FLOCK 1C-1; GCRF; UTC; 31 states" in xml.source
    if name != "orekit_orbit.xml.oem":
        ndm = pytest.importorskip("ccsds_ndm")
        with pytest.raises(Exception, match="segment"):
            ndm.Oem.from_file(str(DATA / name))


def test_xml_oem_errors(tmp_path):
    with pytest.raises(OrbitValueError, match="XML AEM message, not an OEM"):
        EphemerisOrbit.from_oem(DATA / "orekit_attitude_q.xml.aem")
    text = (DATA / "orekit_orbit.xml.oem").read_text()
    p = tmp_path / "m.oem"
    p.write_text(text.replace("<X>", '<X units="m">', 1))
    with pytest.raises(OrbitValueError, match=r"state 1: X in 'm'; an OEM gives km"):
        EphemerisOrbit.from_oem(p)
    p.write_text(text.replace("<REF_FRAME>GCRF</REF_FRAME>", "<REF_FRAME>ITRF</REF_FRAME>"))
    with pytest.raises(OrbitValueError, match=r"^REF_FRAME:"):
        EphemerisOrbit.from_oem(p)
    p.write_text(text[: len(text) // 2])
    with pytest.raises(OrbitValueError, match="not well-formed XML"):
        EphemerisOrbit.from_oem(p)
    with pytest.raises(OrbitValueError, match="velocities: 'file' or 'positions'"):
        EphemerisOrbit.from_oem(DATA / "orbit.oem", velocities="dr/dt")


def test_position_derivative_against_the_closed_form():
    from orbit.ephemeris import position_derivative

    kep = KeplerOrbit(7000.0, 0.01, 0.5, 0.1, 0.2)
    t = np.arange(0.0, 6000.0, 60.0)
    err = np.linalg.norm(position_derivative(t, kep.position(t)) - kep.velocity(t), axis=1)
    assert err[6:-6].max() < 3e-11  # km/s, degree 8 centred (1.6e-11)
    assert err.max() < 3e-9  # the first and last nodes: one-sided windows (1.1e-9)
    rng = np.random.default_rng(3)  # irregular nodes
    t = np.concatenate([[0.0], np.sort(rng.uniform(0.0, 6000.0, 150)), [6000.0]])
    err = np.linalg.norm(position_derivative(t, kep.position(t)) - kep.velocity(t), axis=1)
    assert err.max() < 1e-8  # gaps up to 2x the mean; worst at the last node (3.2e-9)
    # exact for a polynomial of degree 8
    t = np.linspace(-1.0, 2.0, 12)
    c = rng.normal(size=(9, 3))
    r = sum(c[k] * t[:, None] ** k for k in range(9))
    v = sum(k * c[k] * t[:, None] ** (k - 1) for k in range(1, 9))
    np.testing.assert_allclose(position_derivative(t, r), v, rtol=0, atol=1e-11)


def test_oem_with_sgp4_velocities_warns_and_interpolates_positions_only(tmp_path):
    """SGP4's velocity output is not dr/dt of its positions (docs/orbit.md): an OEM of SGP4
    states interpolated with its velocities is 0.1-0.4 m off between states; from the
    positions alone, micrometres (both against sgp4 + astropy called directly)."""
    import warnings

    from astropy.time import Time, TimeDelta

    from orbit.errors import OemVelocityWarning

    t0 = Time(START, scale="utc")
    t = np.arange(0.0, 3 * 3600.0 + 1.0, 60.0)
    times = t0 + TimeDelta(t, format="sec")
    r, v = sgp4_gcrs_direct(times)
    times.precision = 9
    path = _oem(tmp_path, times.isot, np.hstack([r, v]), name="sgp4.oem")
    with pytest.warns(OemVelocityWarning, match=r"moves the positions by up to (\S+) m") as rec:
        e_file = EphemerisOrbit.from_oem(path)
    moved = float(str(rec[0].message).split("by up to ")[1].split(" m")[0])
    assert 0.05 < moved < 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        e_pos = EphemerisOrbit.from_oem(path, velocities="positions")
    assert "velocities from the positions" in e_pos.source
    tm = np.linspace(300.0, t[-1] - 300.0, 2001)  # away from the one-sided ends
    ref = sgp4_gcrs_direct(t0 + TimeDelta(tm, format="sec"))[0]
    err_file = np.linalg.norm(e_file.position(tm) - ref, axis=1).max()
    err_pos = np.linalg.norm(e_pos.position(tm) - ref, axis=1).max()
    assert 0.05e-3 < err_file < 1e-3  # km: 5 cm - 1 m
    assert err_pos < 1e-7  # km: 0.1 mm
    np.testing.assert_array_equal(e_pos.node_states[:, :3], e_file.node_states[:, :3])


def test_oem_with_exact_velocities_on_a_coarse_table_does_not_warn(tmp_path):
    """A 60 s table of an e = 0.2 orbit: dr/dt of the positions is the less accurate near
    periapsis; the file's exact velocities are not blamed (no OemVelocityWarning)."""
    import warnings

    kep = KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12, epoch="2024-03-20T12:00:00")
    path = EphemerisOrbit.from_orbit(kep, 0.0, kep.period, 60.0).to_oem(tmp_path / "k.oem")
    with warnings.catch_warnings():
        warnings.simplefilter("error", orbit.errors.OemVelocityWarning)
        EphemerisOrbit.from_oem(path)


# ---------------------------------------------------------------------------------------------
# Interpolation accuracy and order.
def hermite_bound(n_rate, radius, h):
    """Hermite remainder bound of the docs, end intervals included: 2.5e-5 h⁸ max|r⁽⁸⁾| per
    component (max over [0, h] of Π(x − jh)²/8!, j = 0..3), |r⁽⁸⁾| = n⁸ r on a circle; √3 for
    the vector norm."""
    return math.sqrt(3.0) * 2.5e-5 * h**8 * n_rate**8 * radius


@pytest.mark.parametrize("step", [60.0, 300.0])
def test_from_orbit_kepler_within_the_documented_error(step):
    kep = KeplerOrbit(7000.0, 0.0, 1.2, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    eph = EphemerisOrbit.from_orbit(kep, 0.0, 2 * kep.period, step)
    assert eph.epoch == kep.epoch and eph.mu == kep.mu and eph.step > 0
    t = np.linspace(0.0, 2 * kep.period, 4001)
    err = np.max(np.linalg.norm(eph.position(t) - kep.position(t), axis=-1))
    bound = hermite_bound(kep.mean_motion, 7000.0, step)
    assert err <= max(bound, 1e-9), (err, bound)
    if step == 60.0:
        assert err <= 1e-6  # the 1 mm in LEO at 60 s (bound 2e-11 km)
    verr = np.max(np.linalg.norm(eph.velocity(t) - kep.velocity(t), axis=-1))
    assert verr <= 8 * bound / step + 1e-12
    # the orbital frame is the Kepler one (up to the sign of p)
    p1, p2 = eph.frame_quaternion(t), kep.frame_quaternion(t)
    d = np.minimum(np.linalg.norm(p1 - p2, axis=-1), np.linalg.norm(p1 + p2, axis=-1))
    assert np.max(d) < 1e-9
    assert np.all(np.einsum("ij,ij->i", p1[1:], p1[:-1]) > 0)  # continuous along t


def test_interpolation_converges_at_order_8():
    kep = KeplerOrbit(7000.0, 0.3, 1.0, 0.3, 0.5)
    t = np.linspace(100.0, 5000.0, 2001)
    errs = []
    for h in (240.0, 120.0):
        e = EphemerisOrbit.from_orbit(kep, 0.0, 6000.0, h)
        errs.append(np.max(np.linalg.norm(e.position(t) - kep.position(t), axis=-1)))
    ratio = errs[0] / errs[1]
    assert 2**7 < ratio < 2**9, (errs, ratio)


def test_small_tables_and_irregular_times():
    kep = KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5)
    for n, tol in ((2, 1e-4), (3, 1e-7)):  # cubic and quintic Hermite through all nodes
        t = np.linspace(0.0, 30.0, n)
        e = EphemerisOrbit(t, kep.position(t), kep.velocity(t))
        np.testing.assert_allclose(e.position(t), kep.position(t), atol=1e-12)
        np.testing.assert_allclose(e.velocity(t), kep.velocity(t), atol=1e-14)
        # cubic: h⁴/384 |r⁽⁴⁾| ~ 2e-5 km at h = 30 s near periapsis
        assert np.max(np.abs(e.position(13.7) - kep.position(13.7))) < tol
    rng = np.random.default_rng(1)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(20.0, 60.0, 200))])
    e = EphemerisOrbit(t, kep.position(t), kep.velocity(t))
    assert e.step == 0.0  # irregular: bisection
    tt = np.linspace(0.0, t[-1], 3001)
    assert np.max(np.abs(e.position(tt) - kep.position(tt))) < 1e-8


def test_kernel_dispatch_and_out_of_table_nan():
    kep = KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5)
    e = EphemerisOrbit.from_orbit(kep, 0.0, 600.0, 60.0)
    d = e.kernel_data()
    assert d[SK.TYPE] == SK.TYPE_EPHEMERIS and d[SK.E_N] == 11 and d[SK.MU] == kep.mu
    assert d.size == SK.E_TIMES + 7 * 11
    s = SK.orbit_state(d, 123.0)
    np.testing.assert_allclose(s[:3], kep.position(123.0), atol=1e-9)
    r, *_ = SK.orbit_radial(d, 123.0)
    assert r == pytest.approx(np.linalg.norm(s[:3]), rel=1e-15)
    assert all(math.isnan(x) for x in SK.orbit_state(d, 601.0))
    assert all(math.isnan(x) for x in SK.orbit_state(d, -1.0))
    with pytest.raises(OrbitValueError, match=r"^t: times from .* leave"):
        e.position([10.0, 700.0])


# ---------------------------------------------------------------------------------------------
# Bad input.
def test_constructor_errors():
    t = np.array([0.0, 60.0, 120.0])
    r = np.array([[7000.0, 0, 0], [6999.0, 400.0, 0], [6990.0, 800.0, 0]])
    v = np.tile([0.0, 7.5, 0.0], (3, 1))
    with pytest.raises(OrbitValueError, match=r"^t: times must be strictly increasing; t\[2\]"):
        EphemerisOrbit([0.0, 60.0, 60.0], r, v)
    with pytest.raises(OrbitValueError, match=r"^t: times must be strictly increasing"):
        EphemerisOrbit([0.0, 60.0, 30.0], r, v)
    with pytest.raises(OrbitValueError, match=r"^r: expected shape \(3, 3\)"):
        EphemerisOrbit(t, r[:2], v)
    with pytest.raises(OrbitValueError, match=r"^v: must be finite .* index \(1, 1\)"):
        EphemerisOrbit(t, r, np.where(np.arange(9).reshape(3, 3) == 4, np.nan, v))
    with pytest.raises(OrbitValueError, match=r"^t: expected a 1-D array of >= 2"):
        EphemerisOrbit([0.0], r[:1], v[:1])
    with pytest.raises(OrbitValueError, match=r"^epoch: astropy cannot read"):
        EphemerisOrbit(t, r, v, epoch="2024-13-45")
    with pytest.raises(OrbitTypeError, match=r"^epoch:"):
        EphemerisOrbit(t, r, v, epoch=12.0)
    with pytest.raises(OrbitValueError, match=r"^mu:"):
        EphemerisOrbit(t, r, v, mu=-1.0)
    with pytest.raises(OrbitTypeError, match=r"^orbit:"):
        EphemerisOrbit.from_orbit("kepler", 0.0, 10.0)
    kep = KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5)
    with pytest.raises(OrbitValueError, match=r"^stop: must be after start"):
        EphemerisOrbit.from_orbit(kep, 10.0, 0.0)
    with pytest.raises(OrbitValueError, match=r"^start: an absolute time needs an orbit with an"):
        EphemerisOrbit.from_orbit(kep, "2024-01-01T00:00:00", 10.0)
    with pytest.raises(OrbitValueError, match=r"^step:"):
        EphemerisOrbit.from_orbit(kep, 0.0, 10.0, -1.0)
    short = EphemerisOrbit.from_orbit(kep, 0.0, 600.0, 60.0)
    with pytest.raises(OrbitValueError, match=r"^start, stop: times from"):
        EphemerisOrbit.from_orbit(short, 0.0, 700.0, 60.0)


@pytest.mark.parametrize(
    "l1,l2,match",
    [
        (L1[:-1] + "7", L2, r"^line1: checksum error"),
        (L1, L2[:-1] + "1", r"^line2: checksum error"),
        (L2, L1, r"^line1: a TLE line 1 starts with '1 '.*swapped"),
        (L1[:60], L2, r"^line1: a TLE line has 69 characters"),
        (L1, tle_checksum("2 28058" + L2[7:68]), r"^line2: catalogue number"),
        (L1, 42, r"^line2: expected the TLE line as a string"),
    ],
)
def test_bad_tle_lines(l1, l2, match):
    with pytest.raises((OrbitValueError, OrbitTypeError), match=match):
        EphemerisOrbit.from_tle(l1, l2, START, STOP)


def test_tle_decaying_inside_the_span_names_the_time():
    # A 200 km orbit with an enormous drag term: SGP4 reports decay (error 6) within a day.
    l1 = tle_checksum("1 99999U 24001A   24001.00000000  .50000000  00000-0  50000-0 0  999")
    l2 = tle_checksum("2 99999  51.6000 100.0000 0005000  90.0000 270.0000 16.40000000    1")
    from sgp4.api import Satrec

    sat = Satrec.twoline2rv(l1, l2)
    assert sat.error == 0
    with pytest.raises(OrbitValueError) as err:
        EphemerisOrbit.from_tle(l1, l2, "2024-01-01T00:00:00", "2024-01-05T00:00:00", 600.0)
    msg = str(err.value)
    assert msg.startswith("stop: SGP4 fails at 2024-01-0"), msg
    assert "error 6" in msg or "error 1" in msg, msg
    with pytest.raises(OrbitValueError, match=r"^stop: must be after start"):
        EphemerisOrbit.from_tle(L1, L2, STOP, START)
    with pytest.raises(OrbitValueError, match=r"^start: 'last tuesday' is not an ISO 8601"):
        EphemerisOrbit.from_tle(L1, L2, "last tuesday", STOP)


def test_orbit_protocol_members():
    kep = KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5, epoch="2024-03-20T12:00:00")
    j2 = orbit.SecularJ2Orbit(7000.0, 0.1, 1.0, 0.3, 0.5, epoch="2024-03-20T12:00:00")
    eph = EphemerisOrbit.from_orbit(kep, 0.0, 600.0)
    for o in (kep, j2, eph):
        assert isinstance(o, orbit.Orbit)
        assert o.frame == "GCRS" and o.mu == kep.mu
        assert o.radius(np.array([1.0, 2.0])).shape == (2,)
        assert o.radial_direction([[1.0, 2.0]]).shape == (1, 2, 3)
        assert o.frame_quaternion(5.0).shape == (4,)
        assert o.kernel_data()[SK.TYPE] in (0, 1, 2)
    assert KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5).frame == "inertial"


def test_generic_hermite_table_kernel():
    """hermite4 on a two-component table (values then derivatives per row), as environment
    tables will use it: sin and cos sampled every 0.1 rad, value and derivative at 1e-10."""
    x = np.linspace(0.0, 3.0, 31)
    rows = np.stack([np.sin(x), np.cos(x), np.cos(x), -np.sin(x)], axis=1)
    d = np.concatenate([[0.0, 0.0], x, rows.ravel()])
    for t in (0.0, 0.05, 1.2345, 2.99, 3.0):
        for c, (f, fp) in enumerate(((np.sin, np.cos), (np.cos, lambda s: -np.sin(s)))):
            v, dv = SK.hermite4(d, 2, 2 + 31, 2, 31, 0.1, t, c)
            assert v == pytest.approx(f(t), abs=1e-12)
            assert dv == pytest.approx(fp(t), abs=1e-10)


def test_dispatcher_runs_as_plain_python():
    import os
    import subprocess
    import sys

    code = (
        "import numpy as np, orbit\n"
        "from orbit import _state_kernels as SK\n"
        "assert not hasattr(SK.orbit_state, 'py_func')\n"
        "k = orbit.KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5)\n"
        "j = orbit.SecularJ2Orbit(7000.0, 0.1, 1.0, 0.3, 0.5)\n"
        "e = orbit.EphemerisOrbit.from_orbit(k, 0.0, 600.0, 60.0)\n"
        "print(repr([list(SK.orbit_state(o.kernel_data(), 123.0)) + "
        "list(SK.orbit_frame(o.kernel_data(), 123.0)) for o in (k, j, e)]))\n"
    )
    env = dict(os.environ, NUMBA_DISABLE_JIT="1", ATTITUDE_DISABLE_JIT="1")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = root + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    ).stdout
    got = np.array(eval(out))
    k = KeplerOrbit(7000.0, 0.1, 1.0, 0.3, 0.5)
    j = orbit.SecularJ2Orbit(7000.0, 0.1, 1.0, 0.3, 0.5)
    e = EphemerisOrbit.from_orbit(k, 0.0, 600.0, 60.0)
    want = np.array(
        [
            list(SK.orbit_state(o.kernel_data(), 123.0))
            + list(SK.orbit_frame(o.kernel_data(), 123.0))
            for o in (k, j, e)
        ]
    )
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=1e-12)

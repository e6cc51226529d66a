"""Epochs, time scales, the offline IERS policy, frame bias, ITRS and geodetic coordinates.

The UT1 − UTC our conversions really use is compared with the bundled IERS table read
directly from its fixed-width text (not through astropy's IERS classes).
"""

from __future__ import annotations

import datetime
import math
import warnings

import numpy as np
import pytest
from astropy.time import Time
from astropy.utils import iers

import orbit
from orbit import IERSRangeWarning, KeplerOrbit, OrbitTypeError, OrbitValueError
from orbit import timescales as ts
from orbit.frames import _frame_bias, eme2000_to_gcrs, gcrs_to_eme2000

MAS = math.pi / 180 / 3600e3


def raw_finals(path=iers.IERS_A_FILE):
    """{MJD: UT1−UTC} from finals2000A.all columns (IERS readme): MJD 8-15, UT1−UTC Bulletin A
    59-68, Bulletin B 155-165 (used where present, as the final values)."""
    out = {}
    with open(path) as f:
        for line in f:
            if len(line) < 68 or not line[58:68].strip():
                continue
            b = line[154:165].strip() if len(line) >= 165 else ""
            out[float(line[7:15])] = float(b) if b else float(line[58:68])
    return out


def test_ut1_minus_utc_is_the_bundled_table_value():
    table = raw_finals()
    for mjd in (52000.0, 57754.0, 60000.0):  # 2001, the day after the 2016 leap second, 2023
        got = float(ts.ut1_minus_utc(Time(mjd, format="mjd", scale="utc")))
        assert got == pytest.approx(table[mjd], abs=1e-9), mjd
    # between rows: linear interpolation of the tabulated values
    got = float(ts.ut1_minus_utc(Time(60000.25, format="mjd", scale="utc")))
    assert got == pytest.approx(0.75 * table[60000.0] + 0.25 * table[60001.0], abs=1e-9)
    # the IERS-B (EOP C04) series agrees to its own difference from the finals (~50 µs)
    b = iers.IERS_B.open(iers.IERS_B_FILE)
    i = int(np.searchsorted(b["MJD"].value, 60000.0))
    assert float(b["UT1_UTC"][i].value) == pytest.approx(table[60000.0], abs=2e-4)


def _same_table(a, b):
    assert a.colnames == b.colnames and a.meta == b.meta and len(a) == len(b)
    for k in a.colnames:
        x, y = np.ma.getdata(a[k]), np.ma.getdata(b[k])
        xv, yv = np.asarray(getattr(x, "value", x)), np.asarray(getattr(y, "value", y))
        assert np.array_equal(xv, yv, equal_nan=xv.dtype.kind == "f"), k
        assert np.array_equal(np.ma.getmaskarray(a[k]), np.ma.getmaskarray(b[k])), k
        assert getattr(a[k], "unit", None) == getattr(b[k], "unit", None), k


def test_the_bundled_table_is_parsed_once_and_kept(tmp_path, monkeypatch):
    """The parsed IERS-A table is kept in the cache: a later process loads it instead of
    parsing the file again, and gets the same table; a corrupt copy is parsed again."""
    monkeypatch.setenv("ATTITUDE_CACHE_DIR", str(tmp_path))
    parsed = iers.IERS_A.open(iers.IERS_A_FILE)  # astropy's own reading of the file
    first = ts._bundled_table()
    (kept,) = (tmp_path / "data").glob("iers-a-*.pickle")
    _same_table(first, parsed)

    def no_parse(*a, **k):
        raise AssertionError("parsed the file again")

    with monkeypatch.context() as m:
        m.setattr(iers.IERS_A, "open", no_parse)
        again = ts._bundled_table()
    _same_table(again, parsed)
    t = Time([52000.0, 60000.25, float(parsed["MJD"][-1].value) - 3.5], format="mjd")
    assert np.array_equal(again.ut1_utc(t).value, parsed.ut1_utc(t).value)
    assert np.array_equal(np.stack(again.pm_xy(t)), np.stack(parsed.pm_xy(t)))

    kept.write_bytes(b"not a pickle")
    _same_table(ts._bundled_table(), parsed)  # parsed again, and kept again
    with monkeypatch.context() as m:
        m.setattr(iers.IERS_A, "open", no_parse)
        _same_table(ts._bundled_table(), parsed)


def test_prediction_range_works_offline_without_the_30_day_error(monkeypatch):
    """Dates in the table's prediction span: no download, no astropy 30-day ValueError."""
    tab = ts.iers_table()
    pred, end = float(tab.meta["predictive_mjd"]), float(tab["MJD"][-1].value)
    t = Time(0.5 * (pred + end), format="mjd", scale="utc")

    def no_network(*a, **k):  # pragma: no cover - would be a failure
        raise AssertionError("attempted a download")

    monkeypatch.setattr(iers.iers, "download_file", no_network, raising=False)
    kep = KeplerOrbit(7000.0, 0.001, 1.0, 0.3, 0.2, epoch=t)
    with warnings.catch_warnings():
        warnings.simplefilter("error", IERSRangeWarning)
        lat, _, h = kep.geodetic(np.array([0.0, 60.0]))
    assert np.all(np.isfinite(lat)) and np.all(np.abs(h - 621.9) < 30.0)
    # astropy's default table would raise here once the bundled predictions are 30 days old
    if Time.now().mjd - pred > 30:
        with iers.conf.set_temp("auto_download", False), pytest.raises(ValueError, match=r"30"):
            iers.IERS_Auto.open().ut1_utc(t)


def test_beyond_the_table_warns_and_holds_the_last_values():
    t = Time("2045-01-01T00:00:00", scale="utc")
    kep = KeplerOrbit(7000.0, 0.001, 1.0, 0.3, 0.2, epoch=t)
    with pytest.warns(IERSRangeWarning, match=r"outside the IERS Earth-orientation table"):
        lat, lon, _ = kep.geodetic(0.0)
    assert math.isfinite(lat) and math.isfinite(lon)
    tab = ts.iers_table()
    with pytest.warns(IERSRangeWarning):
        assert float(ts.ut1_minus_utc(t)) == pytest.approx(float(tab["UT1_UTC"][-1].value))


def test_time_scales_and_leap_seconds():
    t = ts.as_epoch("2024-03-20T12:00:00")
    assert t.scale == "utc"
    # published offsets: TAI − UTC = 37 s since 2017, TT − TAI = 32.184 s, GPS − UTC = 18 s
    assert float((ts.as_epoch("2024-03-20T12:00:37 TAI") - t).sec) == pytest.approx(0, abs=1e-9)
    assert float((ts.as_epoch("2024-03-20T12:01:09.184 TT") - t).sec) == pytest.approx(0, abs=1e-9)
    assert float((ts.as_epoch("2024-03-20T12:00:18 GPS") - t).sec) == pytest.approx(0, abs=1e-9)
    assert ts.as_epoch("2024-03-20T12:00:00Z") == t
    assert ts.as_epoch(datetime.datetime(2024, 3, 20, 12)) == t
    # the 2016 leap second: 23:59:60 exists, and two seconds of UTC clock are three elapsed
    leap = ts.as_epoch("2016-12-31T23:59:60")
    assert float((ts.as_epoch("2017-01-01T00:00:01") - ts.as_epoch("2016-12-31T23:59:59")).sec) == (
        pytest.approx(3.0, abs=1e-9)
    )
    assert ts.format_epoch(leap) == "2016-12-31T23:59:60.000000Z"
    assert ts.format_epoch(ts.as_epoch("2000-01-01T12:00:00 TT")) == "2000-01-01T11:58:55.816000Z"
    assert ts.format_epoch(Time("2024-01-01T00:00:00.000000001", scale="utc")).endswith(
        "00.000000001Z"
    )


@pytest.mark.parametrize(
    "value,exc,match",
    [
        ("2024-02-30T00:00:00", OrbitValueError, r"^epoch: astropy cannot read"),
        ("yesterday noon", OrbitValueError, r"^epoch: 'yesterday noon' is not an ISO 8601"),
        ("2024-01-01T00:00:00Z TT", OrbitValueError, r"^epoch:"),
        (12345.0, OrbitTypeError, r"^epoch: expected an astropy Time"),
        (Time(["2024-01-01", "2024-01-02"]), OrbitValueError, r"^epoch: expected a single time"),
    ],
)
def test_unreadable_epochs_name_the_parameter(value, exc, match):
    with pytest.raises(exc, match=match):
        KeplerOrbit(7000.0, 0.0, 0.0, 0.0, 0.0, epoch=value)


def test_eme2000_frame_bias_is_the_published_one():
    """IERS Conventions 2010 Sect. 5.5.1: dα0 = −14.6 mas, ξ0 = −16.617 mas, η0 = −6.819 mas."""
    B = _frame_bias()
    assert B[0, 1] / MAS == pytest.approx(-14.6, abs=0.01)
    assert B[0, 2] / MAS == pytest.approx(16.617, abs=0.01)
    assert B[1, 2] / MAS == pytest.approx(6.819, abs=0.01)
    np.testing.assert_allclose(B @ B.T, np.eye(3), atol=1e-15)
    x = np.array([[7000.0, 100.0, -300.0]])
    np.testing.assert_allclose(gcrs_to_eme2000(eme2000_to_gcrs(x)), x, rtol=0, atol=1e-12)
    ang = math.acos(np.clip((np.trace(B) - 1) / 2, -1, 1)) / MAS
    assert 20.0 < ang < 25.0  # "~20 mas"


def wgs84_to_ecef(lat, lon, h):
    a, f = 6378.137, 1 / 298.257223563
    e2 = f * (2 - f)
    N = a / np.sqrt(1 - e2 * np.sin(lat) ** 2)
    return np.stack(
        [
            (N + h) * np.cos(lat) * np.cos(lon),
            (N + h) * np.cos(lat) * np.sin(lon),
            (N * (1 - e2) + h) * np.sin(lat),
        ],
        axis=-1,
    )


def test_itrs_and_geodetic():
    kep = KeplerOrbit(7000.0, 0.01, 1.7, 0.3, 0.2, epoch="2023-02-25T00:00:00")
    t = np.linspace(0.0, 6000.0, 31)
    ri = kep.itrs_position(t)
    np.testing.assert_allclose(
        np.linalg.norm(ri, axis=-1), np.linalg.norm(kep.position(t), axis=-1), rtol=1e-14
    )
    lat, lon, h = kep.geodetic(t)
    np.testing.assert_allclose(wgs84_to_ecef(lat, lon, h), ri, rtol=0, atol=1e-8)  # 10 µm
    # |geocentric latitude| <= 180° − i; geodetic adds <= 0.19° (3.4e-3), precession <= 3e-3
    assert np.all(np.abs(lat) <= math.pi - 1.7 + 0.01)
    # a direction fixed in GCRS turns in the ITRS at the Earth's rate (IERS: 7.292115e-5 rad/s)
    fixed = orbit.EphemerisOrbit(
        [0.0, 3600.0],
        [[7000.0, 0, 0], [7000.0, 0, 0]],
        [[0.0, 0, 0], [0.0, 0, 0]],
        epoch="2023-02-25T00:00:00",
    )
    r2 = fixed.itrs_position(np.array([0.0, 3600.0]))
    dlon = math.atan2(r2[1, 1], r2[1, 0]) - math.atan2(r2[0, 1], r2[0, 0])
    assert -dlon == pytest.approx(7.292115e-5 * 3600.0, rel=1e-6)


def test_earth_fixed_needs_an_epoch():
    kep = KeplerOrbit(7000.0, 0.01, 1.7, 0.3, 0.2)
    with pytest.raises(OrbitValueError, match=r"^epoch: this orbit has no epoch"):
        kep.geodetic(0.0)
    with pytest.raises(OrbitValueError, match=r"^t: this orbit has no epoch"):
        kep.position(Time("2024-01-01T00:00:00"))
    with_epoch = KeplerOrbit(7000.0, 0.01, 1.7, 0.3, 0.2, epoch="2024-01-01T00:00:00")
    np.testing.assert_allclose(
        with_epoch.position(Time("2024-01-01T00:01:40", scale="utc")),
        with_epoch.position(100.0),
        atol=1e-9,
    )
    assert with_epoch.frame == "GCRS" and "2024-01-01T00:00:00" in with_epoch.describe()


def test_teme_to_gcrs_rotation_interpolated_is_astropys():
    """A day's TEME → GCRS of TLE-table times (five per minute) by astropy's rotation every
    hour, interpolated: astropy's own transformation of every position to 1.1e-13 rad."""
    from astropy.time import TimeDelta

    from orbit.frames import teme_to_gcrs_matrix, teme_to_gcrs_positions

    sec = (np.arange(0.0, 86401.0, 60.0)[:, None] + 2.0 * np.arange(-2.0, 3.0)).ravel()
    times = Time("2026-03-20T00:00:00", scale="utc") + TimeDelta(sec, format="sec")
    r = np.random.default_rng(5).normal(size=(sec.size, 3)) * 7000.0
    want = teme_to_gcrs_positions(times, r)  # astropy, position by position
    for step in (600.0, 3600.0):
        got = teme_to_gcrs_positions(times, r, step=step)
        err = np.linalg.norm(got - want, axis=1) / np.linalg.norm(want, axis=1)
        assert np.max(err) < 2e-13, step
    m = teme_to_gcrs_matrix(times[:50])  # astropy at every time: a rotation
    assert np.max(np.abs(np.einsum("nij,nkj->nik", m, m) - np.eye(3))) < 4e-15
    assert np.allclose(np.linalg.det(m), 1.0, atol=4e-15)
    # not the identity: precession since J2000 turns TEME by ~0.37° about the pole in 2026
    angle = np.degrees(np.arccos((np.trace(m[0]) - 1.0) / 2.0))
    assert 0.3 < angle < 0.45

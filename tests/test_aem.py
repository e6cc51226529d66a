"""CCSDS AEM: QUATERNION/ANGVEL export (v2) checked by ccsds-ndm-py, and reading AEM v1/v2 back.

Also: XML AEMs and the TAI/GPS labels of the same instants, as Orekit writes them (files in
tests/data/ccsds, written by Orekit from our KVN files: tests/data/ccsds/orekit_convert.py);
epochs that give the float64 times back bit for bit; the EME2000 label of a GCRS run (the
frame bias, ERFA directly).

Truth: an independent reader (ccsds-ndm-py) of the files we write; the round trip result →
AEM → Dataset (quaternions bit for bit, 17 significant digits); the same attitude history
written by hand in every other layout the standard allows (scalar first, B2A, the body as
frame A, rates in inertial axes, quaternion derivatives, day-of-year epochs, TAI, two segments)
reads back to the same q and ω; ω_B = 2 q̃∘q̇ (docs/conventions.md sect. 5).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from astropy.time import Time

import attitude.accessor  # noqa: F401 - registers ds.attitude
from attitude import aem, scenario
from attitude import quaternion as qt
from attitude.errors import AttitudeValueError

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests/data/ccsds"


@pytest.fixture(scope="module")
def tumbling():
    sc = scenario.load(ROOT / "scenarios/tumbling_upper_stage.toml")
    sc.t = sc.t[:41]  # 400 s at 10 s: a fast tumble, 0.5-2 deg/s
    return sc.run()


def _ndm():
    ndm = pytest.importorskip("ccsds_ndm")
    if not hasattr(ndm, "Aem") or not hasattr(ndm.Aem, "from_file"):
        pytest.skip("ccsds_ndm here is not ccsds-ndm-py")
    return ndm


def test_quaternion_angvel_v2_read_by_ccsds_ndm(tumbling, tmp_path):
    ndm = _ndm()
    path = aem.write_aem(tumbling, tmp_path / "a.aem", attitude_type="QUATERNION/ANGVEL")
    msg = ndm.Aem.from_file(str(path))
    assert msg.version == "2.0"
    seg = msg.segments[0]
    assert seg.metadata.attitude_type == "QUATERNION/ANGVEL"
    assert seg.metadata.angvel_frame == "SC_BODY_1" == seg.metadata.ref_frame_b
    got = np.asarray(seg.data.attitude_states_numpy)
    q, w = tumbling.q.values, tumbling.omega.values
    np.testing.assert_array_equal(got[:, :4], q[:, [1, 2, 3, 0]])  # Q1 Q2 Q3 QC, exact digits
    np.testing.assert_allclose(got[:, 4:], np.degrees(w), rtol=1e-15)  # deg/s
    assert len(seg.data.attitude_states_epochs) == tumbling.sizes["time"]


def test_round_trip_v2_angvel_and_quaternion(tumbling, tmp_path):
    for kind in aem.ATTITUDE_TYPES:
        path = aem.write_aem(tumbling, tmp_path / "r.aem", attitude_type=kind)
        back = aem.read(path)
        assert back.attrs["epoch"] == tumbling.attrs["epoch"]
        np.testing.assert_array_equal(back.time.values, tumbling.time.values)
        assert back.time.attrs == tumbling.time.attrs  # the same CF time coordinate
        assert back.q.dims == tumbling.q.dims and back.q.attrs == tumbling.q.attrs
        np.testing.assert_array_equal(back.q.values, tumbling.q.values)  # bit for bit
        np.testing.assert_array_equal(back.component_label, tumbling.component_label)
        assert back.attrs["object_name"] == "UPPER_STAGE_RB"
        assert back.attrs["inertial_frame"] == "GCRF"  # the run's orbit is in the GCRS
        assert float(back.attitude.angle_between(tumbling).max()) == 0.0
        if kind == "QUATERNION":
            assert "omega" not in back
        else:
            assert back.omega.attrs["units"] == tumbling.omega.attrs["units"] == "rad s^-1"
            np.testing.assert_allclose(back.omega.values, tumbling.omega.values, rtol=2e-16)


def test_round_trip_v1(tumbling, tmp_path):
    path = aem.write_aem(tumbling, tmp_path / "v1.aem", version=1)
    back = aem.read(path)
    assert back.attrs["aem_version"] == "1.0"
    np.testing.assert_array_equal(back.q.values, tumbling.q.values)
    with pytest.raises(AttitudeValueError, match="version 2"):
        aem.write_aem(tumbling, tmp_path / "x.aem", version=1, attitude_type="QUATERNION/ANGVEL")


HEAD = """CCSDS_AEM_VERS = {vers}
CREATION_DATE = 2024-01-01T00:00:00
ORIGINATOR = OTHER_TOOL
"""


def _segment(meta: dict[str, str], lines: list[str]) -> str:
    if meta.get("START_TIME") == "x" and lines:  # the span of the segment's data lines
        meta = {**meta, "START_TIME": lines[0].split()[0], "STOP_TIME": lines[-1].split()[0]}
    m = "\n".join(f"{k} = {v}" for k, v in meta.items())
    return f"META_START\nOBJECT_NAME = X\nOBJECT_ID = 2024-001A\n{m}\nMETA_STOP\n" + (
        "DATA_START\n" + "\n".join(lines) + "\nDATA_STOP\n"
    )


def _fmt(rows) -> list[list[str]]:
    return [[f"{x:.17e}" for x in r] for r in rows]


def _stamps(ds, scale="utc", yday=False):
    t = ds.attitude.times()
    t = getattr(t, scale)
    t.precision = 6
    s = t.yday if yday else t.isot
    if yday:  # CCSDS day-of-year form YYYY-DDDThh:mm:ss
        s = [f"{x[:4]}-{x[5:8]}T{x[9:]}" for x in s]
    return list(s)


def _meta(a="EME2000", b="SC_BODY_1", **kw):
    base = {"REF_FRAME_A": a, "REF_FRAME_B": b, "TIME_SYSTEM": "UTC",
            "START_TIME": "x", "STOP_TIME": "y"}  # fmt: skip
    base.update(kw)
    return base


@pytest.mark.parametrize(
    "layout",
    [
        "v1_first_a2b",
        "v1_last_b2a",
        "v1_body_is_frame_a",
        "v1_rate_in_inertial_axes",
        "v2_derivative",
        "v2_angvel_tai_day_of_year_two_segments",
    ],
)
def test_other_tools_layouts_read_to_the_same_attitude(tumbling, tmp_path, layout):
    ds = tumbling
    q, w = ds.q.values, ds.omega.values
    stamps = _stamps(ds)
    vec, sc = q[:, 1:], q[:, :1]
    conj = np.concatenate([sc, -vec], axis=1)
    rates = False
    if layout == "v1_first_a2b":
        text = HEAD.format(vers="1.0") + _segment(
            _meta(ATTITUDE_DIR="A2B", ATTITUDE_TYPE="QUATERNION", QUATERNION_TYPE="FIRST"),
            [" ".join([e, *r]) for e, r in zip(stamps, _fmt(q), strict=True)],
        )
    elif layout == "v1_last_b2a":  # the file's quaternion rotates the body onto the inertial
        text = HEAD.format(vers="1.0") + _segment(
            _meta(ATTITUDE_DIR="B2A", ATTITUDE_TYPE="QUATERNION", QUATERNION_TYPE="LAST"),
            [" ".join([e, *r]) for e, r in zip(stamps, _fmt(conj[:, [1, 2, 3, 0]]), strict=True)],
        )
    elif layout == "v1_body_is_frame_a":  # A2B from the body to the inertial frame
        text = HEAD.format(vers="1.0") + _segment(
            _meta(
                a="SC_BODY_1",
                b="EME2000",
                ATTITUDE_DIR="A2B",
                ATTITUDE_TYPE="QUATERNION",
                QUATERNION_TYPE="LAST",
            ),
            [" ".join([e, *r]) for e, r in zip(stamps, _fmt(conj[:, [1, 2, 3, 0]]), strict=True)],
        )
    elif layout == "v1_rate_in_inertial_axes":  # ω in space axes, deg/s (RATE_FRAME = A)
        rates = True
        ws = np.degrees(qt.rotate(q, w))
        rows = np.concatenate([q[:, [1, 2, 3, 0]], ws], axis=1)
        text = HEAD.format(vers="1.0") + _segment(
            _meta(
                ATTITUDE_DIR="A2B",
                ATTITUDE_TYPE="QUATERNION/RATE",
                QUATERNION_TYPE="LAST",
                RATE_FRAME="REF_FRAME_A",
            ),
            [" ".join([e, *r]) for e, r in zip(stamps, _fmt(rows), strict=True)],
        )
    elif layout == "v2_derivative":  # q̇ = ½ q∘(0, ω_B) in 1/s
        rates = True
        qd = 0.5 * qt.multiply(q, np.concatenate([np.zeros((len(q), 1)), w], axis=1))
        rows = np.concatenate([q[:, [1, 2, 3, 0]], qd[:, [1, 2, 3, 0]]], axis=1)
        text = HEAD.format(vers="2.0") + _segment(
            _meta(ATTITUDE_TYPE="QUATERNION/DERIVATIVE"),
            [" ".join([e, *r]) for e, r in zip(stamps, _fmt(rows), strict=True)],
        )
    else:  # TAI day-of-year epochs; two segments sharing the boundary sample
        rates = True
        tai = _stamps(ds, "tai", yday=True)
        rows = np.concatenate([q[:, [1, 2, 3, 0]], np.degrees(w)], axis=1)
        lines = [" ".join([e, *r]) for e, r in zip(tai, _fmt(rows), strict=True)]
        meta = _meta(TIME_SYSTEM="TAI", ATTITUDE_TYPE="QUATERNION/ANGVEL", ANGVEL_FRAME="SC_BODY_1")
        text = (
            HEAD.format(vers="2.0")
            + _segment(meta, lines[:21])
            + "\nCOMMENT second segment\n"
            + _segment(meta, lines[20:])
        )
    path = tmp_path / f"{layout}.aem"
    path.write_text(text)
    back = aem.read(path)
    assert back.sizes["time"] == ds.sizes["time"]
    np.testing.assert_allclose(back.time.values, ds.time.values, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.attitude.angle_between(ds.q.values).values, 0.0, atol=1e-15)
    np.testing.assert_allclose(qt.canonical(back.q.values), qt.canonical(q), rtol=0, atol=1e-16)
    assert back.attrs["inertial_frame"] == "EME2000" and back.attrs["body_frame"] == "SC_BODY_1"
    assert (
        abs((Time(back.attrs["epoch"].rstrip("Z")) - Time(ds.attrs["epoch"].rstrip("Z"))).sec)
        < 1e-9
    )
    if rates:
        # rotating with, or differentiating, a q with |q| = 1 + ε scales ω by 1 + O(ε)
        eps = 4 * float(np.max(np.abs(ds.norm_error.values))) + 1e-15
        np.testing.assert_allclose(back.omega.values, w, rtol=0, atol=eps * np.abs(w).max())
    else:
        assert "omega" not in back


def test_read_errors(tmp_path):
    p = tmp_path / "e.aem"
    p.write_text("hello\n")
    with pytest.raises(AttitudeValueError, match=r"expected KEYWORD = value|not a CCSDS AEM"):
        aem.read(p)
    p.write_text(HEAD.format(vers="2.0") + _segment(
        _meta(ATTITUDE_TYPE="EULER_ANGLE", EULER_ROT_SEQ="ZXZ"), ["2024-01-01T00:00:00 1 2 3"]
    ))  # fmt: skip
    with pytest.raises(AttitudeValueError, match="EULER_ANGLE is not read"):
        aem.read(p)
    p.write_text(HEAD.format(vers="2.0") + _segment(
        _meta(ATTITUDE_TYPE="QUATERNION"), ["2024-01-01T00:00:00 0 0 0"]
    ))  # fmt: skip
    with pytest.raises(AttitudeValueError, match="has 4 fields"):
        aem.read(p)
    with pytest.raises(AttitudeValueError, match="no such file"):
        aem.read(tmp_path / "missing.aem")


def test_cli_export_angvel(tmp_path, capsys):
    from attitude import io
    from attitude.cli import main

    nc = tmp_path / "g.nc"
    assert main(["run", str(ROOT / "scenarios/gg_stabilised_leo.toml"), "-o", str(nc),
                 "--stop", "2", "-q"]) == 0  # fmt: skip
    out = tmp_path / "g.aem"
    args = ["export", str(nc), "--ccsds-aem", str(out), "--aem-type", "QUATERNION/ANGVEL"]
    assert main(args) == 0  # the scenario's inertial_frame, GCRF: the run's own axes
    back, ds = aem.read(out), io.read(nc)
    np.testing.assert_array_equal(back.q.values, ds.q.values)
    np.testing.assert_allclose(back.omega.values, ds.omega.values, rtol=2e-16)
    assert main([*args, "--ref-frame-a", "EME2000"]) == 0  # rotated by the frame bias
    angle = np.degrees(aem.read(out).attitude.angle_between(ds).values) * 3.6e6
    np.testing.assert_allclose(angle, 23.1, atol=0.1)  # mas
    assert main([*args, "--aem-version", "1"]) == 2
    assert "version 2" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------------
# Files written by Orekit (an independent CCSDS implementation): XML, and TAI/GPS labels.
@pytest.mark.parametrize("kind", ["q", "angvel"])
def test_xml_aem_written_by_orekit(kind):
    ours = aem.read(DATA / f"attitude_{kind}.aem")  # KVN, written by write_aem
    xml = aem.read(DATA / f"orekit_attitude_{kind}.xml.aem")
    assert (DATA / f"orekit_attitude_{kind}.xml.aem").read_text().lstrip().startswith("<?xml")
    assert xml.attrs["aem_version"] == "2.0" and xml.attrs["epoch"] == ours.attrs["epoch"]
    assert xml.attrs["inertial_frame"] == "GCRF" and xml.attrs["body_frame"] == "SC_BODY_1"
    np.testing.assert_array_equal(xml.time.values, ours.time.values)
    # Orekit keeps a read quaternion as a rotation, normalised: ours had |q| - 1 ~ 3e-12
    q = ours.q.values / np.linalg.norm(ours.q.values, axis=1, keepdims=True)
    assert np.max(np.abs(np.linalg.norm(ours.q.values, axis=1) - 1)) > 1e-13
    np.testing.assert_allclose(xml.q.values, q, rtol=0, atol=3e-16)
    if kind == "angvel":
        np.testing.assert_allclose(xml.omega.values, ours.omega.values, rtol=1e-15, atol=0)
    else:
        assert "omega" not in xml


def test_tai_and_gps_labels_of_the_same_instants():
    """Orekit wrote the same attitude history with TIME_SYSTEM = TAI and = GPS: its epochs
    are 37 s (TAI - UTC in 2024) and 18 s (GPS = TAI - 19 s) after the UTC ones; read, all
    three are the same instants."""
    utc = aem.read(DATA / "attitude_q.aem")
    first = {}
    for system in ("tai", "gps"):
        text = (DATA / f"orekit_attitude_q_{system}.aem").read_text()
        assert f"TIME_SYSTEM               = {system.upper()}" in text
        first[system] = next(ln.split()[0] for ln in text.splitlines() if ln.startswith("2024"))
        back = aem.read(DATA / f"orekit_attitude_q_{system}.aem")
        assert back.attrs["aem_time_system"] == system.upper()
        assert back.attrs["epoch"] == utc.attrs["epoch"] == "2024-06-01T00:00:00.000000Z"
        np.testing.assert_array_equal(back.time.values, utc.time.values)
        np.testing.assert_allclose(back.q.values, utc.q.values, rtol=0, atol=1e-11)
    t_utc = Time(utc.attrs["epoch"].rstrip("Z"), scale="utc")
    assert first["tai"] == "2024-06-01T00:00:37.000" == (t_utc.tai.isot)
    assert first["gps"] == "2024-06-01T00:00:18.000"  # TAI - 19 s


def test_xml_read_errors(tmp_path):
    with pytest.raises(AttitudeValueError, match="XML OEM message, not an AEM"):
        aem.read(DATA / "orekit_orbit.xml.oem")
    p = tmp_path / "bad.aem"
    p.write_text('<?xml version="1.0"?>\n<aem version="2.0"><header></header><body>')
    with pytest.raises(AttitudeValueError, match="not well-formed XML"):
        aem.read(p)
    text = (DATA / "orekit_attitude_q.xml.aem").read_text()
    p.write_text(text.replace("<Q3>", "<Q9>", 1).replace("</Q3>", "</Q9>", 1))
    with pytest.raises(AttitudeValueError, match="attitude state 1 has no Q3"):
        aem.read(p)


# ------------------------------------------------------------------------------------------------
# Epochs and frames of the export.
def test_epochs_give_the_float64_times_back_bit_for_bit(tmp_path):
    """A run ended by a terminal event has a last sample at an arbitrary time (3666.38... s):
    its epoch is written with the decimals that read back to the same double (not to the
    microsecond, 0.23 us off), the regular samples with 6."""
    from decimal import Decimal

    sc = scenario.load(ROOT / "scenarios/lvlh_pointing_events.toml")
    ds = sc.run()
    assert ds.attrs["run_status"] == "event"
    t_end = float(ds.time.values[-1])
    assert t_end != round(t_end, 6)
    path = aem.write_aem(ds, tmp_path / "ev.aem")
    back = aem.read(path)
    np.testing.assert_array_equal(back.time.values, ds.time.values)
    assert back.attrs["epoch"] == ds.attrs["epoch"]
    lines = [ln for ln in path.read_text().splitlines() if ln.startswith("2024-")]
    assert all(len(ln.split()[0].split(".")[1]) == 6 for ln in lines[:-1])
    stamp = lines[-1].split()[0]
    frac = stamp.split(".")[1]
    assert 6 < len(frac) <= 17
    # the decimal time of the stamp (epoch 12:00:00 UTC, no leap second) rounds to t_end
    h, m, sec = stamp.split("T")[1].split(":")
    elapsed = (int(h) - 12) * 3600 + int(m) * 60 + Decimal(sec)
    assert float(elapsed) == t_end
    # and fewer digits would not do
    assert float(elapsed.quantize(Decimal(1).scaleb(-(len(frac) - 1)))) != t_end


def test_gcrs_run_labelled_eme2000_is_rotated_by_the_frame_bias(tumbling, tmp_path):
    import erfa

    assert tumbling.attrs["orbit_frame"] == "GCRS"
    path = aem.write_aem(tumbling, tmp_path / "e.aem", ref_frame_a="EME2000")
    assert "REF_FRAME_A          = EME2000" in path.read_text()
    back = aem.read(path)
    rb, _, _ = erfa.bp06(2451545.0, 0.0)  # x_EME2000 = B x_GCRS
    # attitude matrices: R_EME2000(q') = B R_GCRS(q)
    np.testing.assert_allclose(
        qt.to_matrix(back.q.values), rb @ qt.to_matrix(tumbling.q.values), rtol=0, atol=4e-16
    )
    angle = np.degrees(back.attitude.angle_between(tumbling).values) * 3.6e6  # mas
    np.testing.assert_allclose(angle, 23.1, atol=0.1)  # the frame bias's angle
    with pytest.raises(AttitudeValueError, match="relative to the GCRS"):
        aem.write_aem(tumbling, tmp_path / "x.aem", ref_frame_a="TOD")
    # a run without an orbit has an abstract inertial frame: the label is the user's
    free = tumbling.drop_vars(["r", "f", "p"]).assign_attrs(orbit_frame="inertial")
    path = aem.write_aem(free, tmp_path / "f.aem", ref_frame_a="TOD")
    np.testing.assert_array_equal(aem.read(path).q.values, tumbling.q.values)


def test_a_run_carrying_its_orbit_is_labelled_gcrf(tmp_path):
    """A spacecraft carrying a NumericalOrbit integrates its attitude in the GCRS (the orbit's
    position and velocity are GCRS): its AEM is labelled GCRF, and EME2000 only rotated by the
    frame bias. (It had no orbit_frame, so the label was EME2000 without the rotation: 23 mas
    off.)"""
    import orbit
    from attitude import RigidBody, Spacecraft, propagate

    o = orbit.NumericalOrbit([6778.137, 0.0, 0.0], [0.0, 7.6686, 0.0], "2026-03-20T00:00:00")
    sc = Spacecraft(RigidBody([1.0, 1.2, 1.4], units="kg m2"), orbit=o, mass=10.0)
    ds = propagate(sc, [1.0, 0, 0, 0], [0.0, 0.0, 0.0, 0.02], np.linspace(0.0, 60.0, 7))
    assert ds.attrs["orbit_frame"] == ds["position"].attrs["reference_frame"] == "GCRS"
    path = aem.write_aem(ds, tmp_path / "c.aem")
    assert "REF_FRAME_A          = GCRF" in path.read_text()
    np.testing.assert_array_equal(aem.read(path).q.values, ds.q.values)
    back = aem.read(aem.write_aem(ds, tmp_path / "e.aem", ref_frame_a="EME2000"))
    angle = np.degrees(back.attitude.angle_between(ds).values) * 3.6e6  # mas
    np.testing.assert_allclose(angle, 23.1, atol=0.1)  # the frame bias's angle


def test_an_ensemble_member_is_labelled_as_its_single_run(tmp_path):
    """A rigid-body ensemble on a dated orbit records the epoch, the orbit and its frame as a
    single run does, so a member's AEM is labelled GCRF like the single run's. (It recorded
    no orbit_frame: the member's GCRS attitude was labelled EME2000 without the frame bias.)"""
    import orbit
    from attitude import GravityGradient, RigidBody, propagate, propagate_ensemble

    o = orbit.KeplerOrbit(7000.0, 0.01, 0.5, 0.7, 0.2, epoch="2024-03-20T12:00:00")
    body = RigidBody([4e8, 5e8, 6e8], units="kg m2")
    q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    Q = np.array([[0.0, 0.0, 0.0, 1e5], [0.0, 1e5, 0.0, 0.0], [0.0, 0.0, 2e5, 0.0]])
    t = np.linspace(0.0, 600.0, 7)
    ens = propagate_ensemble(body, q, Q, t, potential=GravityGradient(o))
    one = propagate(body, q[1], Q[1], t, potential=GravityGradient(o), method=ens.attrs["method"])
    for k in ("epoch", "orbit", "orbit_frame"):
        assert ens.attrs[k] == one.attrs[k], k
    head = [
        [x for x in aem.write_aem(ds, tmp_path / f"{i}.aem").read_text().splitlines()
         if "REF_FRAME_A" in x]
        for i, ds in enumerate((ens.isel(member=1), one))
    ]  # fmt: skip
    assert head[0] == head[1] == ["REF_FRAME_A          = GCRF"]

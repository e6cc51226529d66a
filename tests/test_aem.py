"""CCSDS AEM: QUATERNION/ANGVEL export (v2) checked by ccsds-ndm-py, and reading AEM v1/v2 back.

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
        assert back.attrs["inertial_frame"] == "EME2000"
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
    assert main(args) == 0
    back, ds = aem.read(out), io.read(nc)
    np.testing.assert_array_equal(back.q.values, ds.q.values)
    np.testing.assert_allclose(back.omega.values, ds.omega.values, rtol=2e-16)
    assert main([*args, "--aem-version", "1"]) == 2
    assert "version 2" in capsys.readouterr().err

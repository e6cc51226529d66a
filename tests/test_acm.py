"""CCSDS ACM (Attitude Comprehensive Message, 504.0-B-2 sect. 5): the MEKF's estimate with its
covariance, exported and read back, and checked by Orekit's AcmParser.

Truth: Orekit (an independent implementation of the ACM) parsed ``tests/data/ccsds/
estimate.acm``, written by :func:`attitude.acm.write_acm`; the values it read, in SI units, are
``orekit_estimate_acm.txt`` and its own re-write of the message ``orekit_estimate.acm``
(``tests/data/ccsds/orekit_convert.py``). With Orekit at hand (``ATTITUDE_OREKIT_PYTHON`` names
an interpreter with ``orekit_jpype``, or it imports here) a fresh export of a run is parsed by
Orekit directly. The round trip run -> ACM -> Dataset gives the quaternions and tick times
bit for bit, the rest to the 17 printed digits; the covariance lines are the squares of
``estimation_sigma`` in deg² and (deg/s)².
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from attitude import acm
from attitude.errors import AttitudeTypeError, AttitudeValueError

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests/data/ccsds"
EPOCH = "2024-06-01T00:00:00"


@pytest.fixture(scope="module")
def mekf_run():
    """test_sensors' closed loop (three wheels, a gyro with bias, a 2 Hz star tracker, the
    MEKF started 10° off), 20 s at 0.5 s ticks."""
    sys.path.insert(0, str(ROOT / "tests"))
    from test_sensors import _mekf_run

    return _mekf_run(20.0, seed=3)[1]


def _valid(ds):
    return np.isfinite(ds.estimate_q.values[:, 0])


def test_round_trip(mekf_run, tmp_path):
    ds = mekf_run
    path = acm.write_acm(ds, tmp_path / "e.acm", epoch=EPOCH, object_name="SAT")
    back = acm.read(path)
    ok = _valid(ds)
    assert ok.sum() == back.sizes["tick"] > 30
    np.testing.assert_array_equal(back.tick.values, ds.tick.values[ok])  # bit for bit
    np.testing.assert_array_equal(back.estimate_q.values, ds.estimate_q.values[ok])
    # deg/s and deg² written with 17 digits: back to rad within one rounding of each step
    np.testing.assert_allclose(
        back.bias_estimate.values, ds.bias_estimate.values[ok], rtol=4e-16, atol=1e-300
    )
    np.testing.assert_allclose(
        back.estimation_sigma.values, ds.estimation_sigma.values[ok], rtol=4e-16, atol=0
    )
    np.testing.assert_array_equal(back.q.values, ds.q.values)  # the truth block
    np.testing.assert_array_equal(back.time.values, ds.time.values)
    assert back.attrs["epoch"] == EPOCH + ".000000Z" and back.attrs["object_name"] == "SAT"
    assert back.attrs["inertial_frame"] == "EME2000" and back.attrs["body_frame"] == "SC_BODY_1"


def test_covariance_lines_are_the_variances_in_degrees(mekf_run, tmp_path):
    """The COV lines: EPOCH then the diagonal of P in deg² and (deg/s)², positive, a
    symmetric positive definite (diagonal) 6×6 matrix at every tick; the ANGLE type keeps the
    first three."""
    ds = mekf_run
    ok = _valid(ds)
    s = ds.estimation_sigma.values[ok]
    for cov_type, n in (("ANGLE_GYROBIAS", 6), ("ANGLE", 3)):
        path = acm.write_acm(ds, tmp_path / "c.acm", epoch=EPOCH, cov_type=cov_type)
        lines = path.read_text().splitlines()
        i, j = lines.index("COV_START"), lines.index("COV_STOP")
        assert f"COV_TYPE             = {cov_type}" in lines[i:j]
        assert "COV_REF_FRAME        = SC_BODY_1" in lines[i:j]
        rows = np.array([[float(x) for x in ln.split()] for ln in lines[i:j] if ln[0].isdigit()])
        assert rows.shape == (ok.sum(), 1 + n)
        np.testing.assert_array_equal(rows[:, 0], ds.tick.values[ok])
        var = rows[:, 1:]
        np.testing.assert_allclose(var[:, :3], np.degrees(s[:, :3]) ** 2, rtol=1e-15)
        if n == 6:
            np.testing.assert_allclose(var[:, 3:], np.degrees(s[:, 3:]) ** 2, rtol=1e-15)
        for row in var:
            P = np.diag(row)
            np.testing.assert_array_equal(P, P.T)
            assert np.all(np.linalg.eigvalsh(P) > 0)
        back = acm.read(path)
        assert np.all(np.isnan(back.estimation_sigma.values[:, n:]))


def test_sections_keywords_and_order(mekf_run, tmp_path):
    text = acm.write_acm(mekf_run, tmp_path / "k.acm", epoch=EPOCH, truth=False).read_text()
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("COMMENT")]
    assert lines[0] == "CCSDS_ACM_VERS       = 2.0"
    keys = [ln.split("=")[0].strip() for ln in lines if "=" in ln]
    meta = keys[keys.index("OBJECT_NAME") : keys.index("STOP_TIME") + 1]
    assert meta == [
        "OBJECT_NAME",
        "TIME_SYSTEM",
        "EPOCH_TZERO",
        "ACM_DATA_ELEMENTS",
        "START_TIME",
        "STOP_TIME",
    ]  # fmt: skip  (table 5-3 order)
    assert "ACM_DATA_ELEMENTS    = ATT, COV, AD" in text
    starts = [ln for ln in lines if ln.endswith("_START")]
    assert starts == ["META_START", "ATT_START", "COV_START", "AD_START"]  # table 5-1 order
    assert "NUMBER_STATES        = 7" in text and "RATE_TYPE            = GYRO_BIAS" in text
    assert "AD_METHOD            = EKF" in text


def test_bad_input(mekf_run, tmp_path):
    import attitude
    from attitude import canonical as C
    from attitude.body import RigidBody

    body = RigidBody([1.0, 2.0, 3.0])
    Q0 = C.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.1, 0.0, 0.0], body)
    plain = attitude.propagate(body, [1.0, 0, 0, 0], Q0, [0.0, 1.0])  # no flight software
    with pytest.raises(AttitudeValueError, match=r"^ds: no attitude estimate \(estimate_q.*MEKF"):
        acm.write_acm(plain, tmp_path / "x.acm", epoch=EPOCH)
    assert not (tmp_path / "x.acm").exists()
    with pytest.raises(AttitudeTypeError, match=r"^ds: expected an xarray\.Dataset"):
        acm.write_acm({"q": 1}, tmp_path / "x.acm")
    with pytest.raises(AttitudeValueError, match="cov_type: one of"):
        acm.write_acm(mekf_run, tmp_path / "x.acm", epoch=EPOCH, cov_type="QUATERNION")
    with pytest.raises(AttitudeValueError, match="epoch: this run has no epoch"):
        acm.write_acm(mekf_run, tmp_path / "x.acm")
    bad = mekf_run.copy(deep=True)
    bad["estimation_sigma"][5, 1] = 0.0
    with pytest.raises(AttitudeValueError, match=r"^estimation_sigma: .* not positive"):
        acm.write_acm(bad, tmp_path / "x.acm", epoch=EPOCH)
    never = mekf_run.copy(deep=True)
    never["estimate_q"][:] = np.nan
    with pytest.raises(AttitudeValueError, match="no estimate at any tick"):
        acm.write_acm(never, tmp_path / "x.acm", epoch=EPOCH)
    with pytest.raises(AttitudeValueError, match=r"^object_name: .* control character"):
        acm.write_acm(mekf_run, tmp_path / "x.acm", epoch=EPOCH, object_name="A\nB")
    assert not (tmp_path / "x.acm").exists()
    p = tmp_path / "t.acm"
    p.write_text("CCSDS_AEM_VERS = 2.0\n")
    with pytest.raises(AttitudeValueError, match="not a CCSDS ACM"):
        acm.read(p)
    good = acm.write_acm(mekf_run, tmp_path / "g.acm", epoch=EPOCH).read_text()
    p.write_text(good.replace("NUMBER_STATES        = 7", "NUMBER_STATES        = 4"))
    with pytest.raises(AttitudeValueError, match="NUMBER_STATES = 4, but QUATERNION and GYRO"):
        acm.read(p)
    p.write_text(good[: good.index("COV_STOP")])
    with pytest.raises(AttitudeValueError, match="COV_STOP missing"):
        acm.read(p)


def test_cli_export_acm(tmp_path, capsys, mekf_run):
    from attitude import io
    from attitude.cli import main

    nc = tmp_path / "m.nc"
    io.write(mekf_run, nc)
    out = tmp_path / "m.acm"
    args = ["export", str(nc), "--ccsds-acm", str(out), "--epoch", EPOCH]
    assert main(args) == 0
    assert f"CCSDS ACM   {out}" in capsys.readouterr().out
    back = acm.read(out)
    ok = _valid(mekf_run)
    np.testing.assert_array_equal(back.estimate_q.values, mekf_run.estimate_q.values[ok])
    assert main([*args, "--acm-cov-type", "ANGLE"]) == 0
    assert "COV_TYPE             = ANGLE\n" in out.read_text()
    plain = tmp_path / "g.nc"
    assert main(["run", str(ROOT / "scenarios/gg_stabilised_leo.toml"), "-o", str(plain),
                 "--stop", "2", "-q"]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["export", str(plain), "--ccsds-acm", str(tmp_path / "g.acm")]) == 2
    assert "no attitude estimate" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------------
# Orekit (an independent ACM implementation)


def _orekit_table(text: str) -> dict[str, np.ndarray]:
    rows: dict[str, list] = {}
    for ln in text.splitlines():
        if ln.startswith("#") or not ln.strip():
            continue
        kind, ident, *vals = ln.split()
        rows.setdefault(f"{kind} {ident}", []).append([float(v) for v in vals])
    return {k: np.array(v) for k, v in rows.items()}


def _compare_with_orekit(ours, table: dict[str, np.ndarray]) -> None:
    """Orekit's values (SI) against ours: quaternions and times exactly, the bias (deg/s ->
    rad/s) and the variances (deg² -> rad²) to a rounding."""
    est, cov = table["ATT ESTIMATE"], table["COV ESTIMATE_COVARIANCE"]
    np.testing.assert_array_equal(est[:, 0], ours.tick.values)
    np.testing.assert_array_equal(est[:, 1:5], ours.estimate_q.values[:, [1, 2, 3, 0]])
    np.testing.assert_allclose(est[:, 5:8], ours.bias_estimate.values, rtol=3e-16, atol=1e-300)
    np.testing.assert_array_equal(cov[:, 0], ours.tick.values)
    np.testing.assert_allclose(cov[:, 1:], ours.estimation_sigma.values**2, rtol=8e-16)
    if "q" in ours:
        truth = table["ATT TRUTH"]
        np.testing.assert_array_equal(truth[:, 0], ours.time.values)
        np.testing.assert_array_equal(truth[:, 1:5], ours.q.values[:, [1, 2, 3, 0]])


def test_orekit_read_our_acm():
    """Orekit's AcmParser read tests/data/ccsds/estimate.acm to the values in
    orekit_estimate_acm.txt: the same quaternions, times, bias and variances as ours; its own
    re-write of the message reads back to the same estimate."""
    text = (DATA / "orekit_estimate_acm.txt").read_text()
    assert "# COV ESTIMATE_COVARIANCE ANGLE_GYROBIAS SC_BODY_1" in text
    assert "# ATT ESTIMATE EME2000 -> SC_BODY_1 QUATERNION GYRO_BIAS" in text
    assert "# AD EKF QUATERNION ANGLE_GYROBIAS GYRO_BIAS" in text
    ours = acm.read(DATA / "estimate.acm")
    assert ours.sizes["tick"] == 120
    _compare_with_orekit(ours, _orekit_table(text))
    again = acm.read(DATA / "orekit_estimate.acm")
    np.testing.assert_array_equal(again.estimate_q.values, ours.estimate_q.values)
    np.testing.assert_array_equal(again.tick.values, ours.tick.values)
    np.testing.assert_allclose(again.estimation_sigma.values, ours.estimation_sigma.values,
                               rtol=4e-16)  # fmt: skip
    np.testing.assert_array_equal(again.q.values, ours.q.values)


def _orekit_python() -> str | None:
    exe = os.environ.get("ATTITUDE_OREKIT_PYTHON")
    if exe:
        return exe
    return sys.executable if importlib.util.find_spec("orekit_jpype") else None


def test_orekit_parses_a_fresh_export(mekf_run, tmp_path):
    """Live: Orekit's AcmParser on an ACM written now (skipped without Orekit)."""
    exe = _orekit_python()
    if exe is None:
        pytest.skip(
            "Orekit not available (set ATTITUDE_OREKIT_PYTHON to a Python with orekit_jpype)"
        )
    path = acm.write_acm(mekf_run, tmp_path / "fresh.acm", epoch=EPOCH)
    out = subprocess.run(
        [exe, str(DATA / "orekit_convert.py"), "--acm", str(path)],
        capture_output=True, text=True, timeout=300, check=True,
    )  # fmt: skip
    _compare_with_orekit(acm.read(path), _orekit_table(out.stdout))

"""`attitude info` on a closed-loop result: the pointing error's statistics after the settling
time, checked against numpy on the file's own variable; scenarios may write rpm (issue 43)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from attitude import scenario
from attitude._pointing_stats import pointing_summary, settle_time
from attitude.cli import main
from attitude.errors import AttitudeValueError
from attitude.results import time_values

SCEN = Path(__file__).resolve().parent.parent / "scenarios"


@pytest.fixture(scope="module")
def closed_loop_file(tmp_path_factory):
    """Basilisk's reaction-wheel scenario for 30 s (300 ticks at 10 Hz; recorded: the 61 in
    effect at the samples, 0.5 s apart)."""
    out = tmp_path_factory.mktemp("info") / "rw.nc"
    assert main(["run", str(SCEN / "rw_inertial_pointing.toml"), "--stop", "30", "-o", str(out),
                 "-q"]) == 0  # fmt: skip
    return out


def _numpy_stats(path: Path, t_settle: float) -> dict[str, float]:
    with xr.open_dataset(path, decode_times=False) as ds:
        t = time_values(ds, "tick")
        assert ds["error_angle"].attrs["units"] == "rad"
        e = np.asarray(ds["error_angle"].values)[t >= t_settle]
    return {
        "n": e.size,
        "rms": math.sqrt(np.mean(e**2)),
        "max": e.max(),
        **{f"p{p}": np.percentile(e, p) for p in (50, 95, 99)},
    }


@pytest.mark.parametrize(("settle", "t_settle"), [(None, 3.0), ("20%", 6.0), ("12", 12.0)])
def test_summary_against_numpy(closed_loop_file, settle, t_settle):
    want = _numpy_stats(closed_loop_file, t_settle)
    with xr.open_dataset(closed_loop_file, decode_times=False) as ds:
        got = pointing_summary(ds, settle)
    assert got["t_settle"] == pytest.approx(t_settle)
    assert got["n"] == want["n"] and 0 < got["n"] < got["n_total"] == 61
    for k in ("rms", "max", "p50", "p95", "p99"):
        assert got[k] == pytest.approx(want[k], rel=1e-12), k
    assert got["p50"] < got["p95"] < got["p99"] <= got["max"]


def test_info_prints_the_pointing_error(closed_loop_file, capsys):
    assert main(["info", str(closed_loop_file), "--settle", "2min"]) == 2  # beyond the run
    assert "--settle: 120 s is not before the end of the run, which spans 30 s" in (
        capsys.readouterr().err
    )
    assert main(["info", str(closed_loop_file), "--settle", "12"]) == 0
    out = capsys.readouterr().out
    i = out.index("pointing    attitude error (error_angle) after t = 12 s")
    head, stats = out[i:].splitlines()[:2]
    want = _numpy_stats(closed_loop_file, 12.0)
    assert f"{want['n']} of 61 recorded ticks (of 300 ticks run:" in head
    unit = stats.split()[2].rstrip(",")
    f = {"deg": 180 / math.pi, "arcsec": 3600 * 180 / math.pi}[unit]
    numbers = [float(x) for x in re.findall(r"(?<![\w/])\d[\d.e+-]*(?= |$)", stats)]
    expected = [want["rms"], want["max"], want["p50"], want["p95"], want["p99"]]
    assert numbers == [float(f"{v * f:.4g}") for v in expected]


def test_info_without_software_has_no_pointing_line(tmp_path, capsys):
    nc = tmp_path / "tf.nc"
    assert main(["run", str(SCEN / "paper_torque_free.toml"), "--stop", "1", "-o", str(nc),
                 "-q"]) == 0  # fmt: skip
    assert main(["info", str(nc)]) == 0
    assert "pointing" not in capsys.readouterr().out


def test_no_summary_for_an_ensembles_error_angle():
    """A (member, tick) error angle is an ensemble's: not this summary's."""
    ds = xr.Dataset(
        {"error_angle": (("member", "tick"), np.ones((2, 3)), {"units": "rad"})},
        coords={"tick": [0.0, 1.0, 2.0]},
    )
    assert pointing_summary(ds) is None
    ds1 = ds.isel(member=0)
    ds1 = ds1.assign_coords(time=("time", [0.0, 2.0]))
    assert pointing_summary(ds1, "0")["rms"] == 1.0


def test_settle_spec():
    assert settle_time("10%", 100.0, 700.0) == (160.0, "the first 10 % of the run")
    assert settle_time("1.5 min", 100.0, 700.0)[0] == 190.0
    assert settle_time(0, 100.0, 700.0)[0] == 100.0
    for bad in ("100%", "-5", "soon", "3 m"):
        with pytest.raises(AttitudeValueError, match="--settle: expected"):
            settle_time(bad, 0.0, 10.0)
    with pytest.raises(AttitudeValueError, match="not before the end of the run"):
        settle_time("10 s", 0.0, 10.0)


def test_scenario_wheel_speed_in_rpm():
    """astropy spells rpm 'cycle/min'; a scenario may write 'rpm' (and 'rev/min', 'rpm/s')."""
    text = (SCEN / "rw_inertial_pointing.toml").read_text()
    base = scenario.loads(text).spacecraft
    for spelling in ("rpm", "rev/min", "RPM"):
        sc = scenario.loads(text.replace('"cycle/min"', f'"{spelling}"')).spacecraft
        for w, w0 in zip(sc.wheels, base.wheels, strict=True):
            assert w.speed == w0.speed and w.max_speed == w0.max_speed
    assert base.wheels[2].speed == pytest.approx(300 * 2 * math.pi / 60, rel=1e-15)
    bad = text.replace('speed_unit = "cycle/min"', 'speed_unit = "rotations"', 1)
    with pytest.raises(scenario.ScenarioError, match=r"e\.g\. 'rad/s', 'deg/s' or 'rpm'"):
        scenario.loads(bad)

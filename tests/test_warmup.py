"""attitude/_warmup.py and the closed loop that compiles once (issue 40, point 4).

Every closed-loop run of the built-in models shares one driver per method
(attitude._core.models): a second configuration with another control law, other actuators,
other sensors, the MEKF and a larger time-dependent model compiles no function in a fresh
process (numba's compile events, counted there). ``attitude warmup`` runs scenarios for three
samples in worker processes; a second warmup compiles nothing (the cache index says so).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from attitude import _warmup
from attitude.cli import main
from attitude.errors import AttitudeValueError
from orbit._shared_jit import JIT_DISABLED

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"

jitted = pytest.mark.skipif(JIT_DISABLED, reason="kernels not compiled")

# The B-dot CubeSat of scenarios/cubesat_bdot.toml (three rods, one magnetometer, gravity
# gradient on its TLE orbit), then the same CubeSat with three wheels added under MRP feedback
# with momentum dumping through the rods, a gyro, a star tracker and the MEKF.
_A = (
    (SCEN / "cubesat_bdot.toml")
    .read_text()
    .replace("stop = 3.0", "stop = 0.01")
    .replace("count = 1081 ", "count = 7 ")
)
_B = _A.replace(
    'control = "bdot"\ngain = "optimal"               # Avanzini & Giulietti\'s, for the '
    "normalized law",
    textwrap.dedent(
        """\
        control = "mrp_feedback"
        K = 1e-4
        K_unit = "N m"
        P = 2e-3
        P_unit = "N m s"
        dumping_gain = 1e-3
        dumping_gain_unit = "1/s"
        """
    ),
).replace(
    "[[software.sensors]]",
    textwrap.dedent(
        """\
        [[software.sensors]]
        type = "gyro"
        arw = 0.05
        arw_unit = "deg/h(1/2)"
        seed = 1

        [[software.sensors]]
        type = "star_tracker"
        noise = [6.0, 45.0]
        noise_unit = "arcsec"
        seed = 2

        [software.estimator]
        type = "mekf"

        [[software.sensors]]"""
    ),
    1,
) + "".join(
    textwrap.dedent(
        f"""
        [[spacecraft.wheels]]
        axis = {axis}
        inertia = 1e-5
        inertia_unit = "kg m2"
        max_torque = 1.0
        max_torque_unit = "mN m"
        """
    )
    for axis in ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
)

_PROBE = textwrap.dedent(
    """
    import json, sys
    from numba.core import event
    from attitude import scenario
    names = []
    class L(event.Listener):
        def on_start(self, ev):
            d = ev.data["dispatcher"]
            names.append(d.py_func.__module__ + ":" + d.py_func.__qualname__)
        def on_end(self, ev):
            pass
    event.register("numba:compile", L())
    sc = scenario.loads(open(sys.argv[1]).read())
    if sc.ensemble is None:
        ds = sc.run()
    else:
        from attitude import io
        from attitude.ensemble import run_scenario
        run_scenario(sc, "ensemble.nc")
        ds = io.read("ensemble.nc")
    print(json.dumps({"compiled": names, "n": int(ds.sizes["time"]),
                      "wheels": int(ds.sizes.get("wheel", 0)),
                      "members": int(ds.sizes.get("member", 0))}))
    """
)


def _probe(toml: str, tmp: Path, name: str) -> dict:
    path = tmp / f"{name}.toml"
    path.write_text(toml)
    env = dict(os.environ)
    r = subprocess.run(
        [sys.executable, "-c", _PROBE, str(path)], env=env, capture_output=True, text=True,
        timeout=900, cwd=tmp,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@jitted
def test_a_second_closed_loop_configuration_compiles_nothing(tmp_path):
    a = _probe(_A, tmp_path, "a")  # compiles the closed-loop driver if no test did before
    assert a["wheels"] == 0
    b = _probe(_B, tmp_path, "b")
    assert b["wheels"] == 3 and b["n"] == a["n"]  # it ran, with its wheels
    assert b["compiled"] == []
    # and an ensemble of it (DOP853 members run the single run's compiled driver)
    ens = _B + '\n[ensemble]\nsize = 3\nseed = 7\nrate_error = 0.01\nrate_error_unit = "deg/s"\n'
    e = _probe(ens, tmp_path, "e")
    assert e["wheels"] == 3 and e["n"] == a["n"] and e["members"] == 3
    assert e["compiled"] == []


def test_order_compiles_each_kind_first():
    paths = [SCEN / f"{n}.toml" for n in ("cubesat_bdot", "nadir_wheels_dumping",
                                          "paper_keplerian", "rw_inertial_pointing",
                                          "ensemble_rw_inertial_pointing")]  # fmt: skip
    first, rest = _warmup._order(paths)
    assert [p.stem for p in first] == ["cubesat_bdot", "paper_keplerian",
                                       "ensemble_rw_inertial_pointing"]  # fmt: skip
    assert {p.stem for p in rest} == {"nadir_wheels_dumping", "rw_inertial_pointing"}
    assert _warmup._kind(SCEN / "rw_inertial_pointing.toml") == (True, "dop853", False)


def test_default_scenarios_are_the_shipped_ones():
    assert _warmup.default_scenarios() == sorted(SCEN.glob("*.toml"))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"scenarios": []}, "scenarios: none given"),
        ({"scenarios": ["no_such.toml"]}, "is not a file"),
        ({"scenarios": [SCEN / "cubesat_bdot.toml"], "jobs": 0}, "jobs: a positive number"),
    ],
)
def test_bad_input(kwargs, match):
    with pytest.raises(AttitudeValueError, match=match):
        _warmup.warmup(**kwargs)


@jitted
def test_warmup_command_is_idempotent(tmp_path, capsys):
    scen = tmp_path / "a.toml"
    scen.write_text(_A)
    assert main(["warmup", "-q", "-j", "1", str(scen)]) == 0  # compiles or loads
    capsys.readouterr()
    assert main(["warmup", "-q", "-j", "1", str(scen)]) == 0
    out = capsys.readouterr().out
    assert "warmup: nothing to compile (all cached) for 1 scenarios" in out


def test_warmup_command_bad_file(tmp_path, capsys):
    assert main(["warmup", "-q", str(tmp_path / "missing.toml")]) == 2
    assert "is not a file" in capsys.readouterr().err

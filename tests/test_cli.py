"""The ``attitude`` command, run as a subprocess; files checked with netCDF4 directly."""

from __future__ import annotations

import itertools
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import netCDF4
import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time, TimeDelta

import orbit
from attitude import __version__
from attitude.cli import Progress, main

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
# The subprocesses run the kernels as plain Python (short spans: a few seconds, no compilation
# in every fresh process); the compiled path of the same commands is exercised in-process
# below through attitude.cli.main. ATTITUDE_TEST_CLI_JIT=1 compiles in the subprocesses too.
if os.environ.get("ATTITUDE_TEST_CLI_JIT", "0") in ("", "0"):
    ENV["ATTITUDE_DISABLE_JIT"] = "1"

# Short spans (in each scenario's time unit) that keep the subprocess runs quick.
SHORT = {
    "paper_torque_free": 2.0,
    "paper_heavy_top": 2.0,
    "paper_keplerian": 300.0,
    "gg_stabilised_leo": 10.0,
    "tumbling_upper_stage": 300.0,
    "sso_tle_gravity_gradient": 0.05,
    "lvlh_pointing_events": 1800.0,
    "cubesat_environment": 0.01,
    "rw_inertial_pointing": 30.0,
    "cubesat_bdot": 0.02,
    "nadir_wheels_dumping": 0.02,
    "orbit_raising_burn": 0.01,
    "cubesat_drag_decay": 0.02,
}
NO_ORBIT = ("paper_torque_free", "paper_heavy_top", "rw_inertial_pointing")  # no epoch, no r


def cli(*args, cwd, check=None, timeout=300):
    r = subprocess.run(
        [sys.executable, "-m", "attitude", *map(str, args)],
        cwd=cwd,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    if check is not None:
        assert r.returncode == check, r.stderr + r.stdout
    return r


def test_run_summary_of_a_terminal_event_run_and_its_timing(tmp_path):
    """The span printed is the one computed (a terminal event ends the run between grid
    times, as `info` says); "in X s" counts from the process's start, start-up included."""
    out = tmp_path / "ev.nc"
    t_launch = time.monotonic()
    r = cli("run", SCEN / "lvlh_pointing_events.toml", "-o", out, cwd=tmp_path, check=0)
    t_process = time.monotonic() - t_launch
    with netCDF4.Dataset(out) as nc:
        t_end = float(nc.variables["time"][-1])
        assert nc.getncattr("run_status") == "event"
    assert t_end != 3660.0 and t_end % 60.0 != 0.0  # between two output times
    assert f"time span   0 .. {t_end:g} s (" in r.stdout
    info = cli("info", out, cwd=tmp_path, check=0).stdout
    assert f"time span   0 .. {t_end:g} s (" in info
    # the terminal event's time as the events are listed (12 digits; the file keeps every bit)
    assert f"run ended by shadow_out at t = {t_end:.12g}\n" in r.stdout
    assert f"run ended by the terminal event shadow_out at t = {t_end:.12g}\n" in info
    m = re.search(r"MB\) in ([0-9.]+) s \(([0-9.]+) s of it start-up", r.stdout)
    assert m, r.stdout
    total, startup = float(m.group(1)), float(m.group(2))
    assert 0.0 < startup < total <= t_process + 0.05  # within the process's lifetime


def test_every_shipped_scenario_is_listed():
    single = {p.stem for p in SCEN.glob("*.toml") if not p.stem.startswith("ensemble_")}
    assert single == set(SHORT)  # ensemble scenarios: tests/test_ensemble.py


@pytest.mark.parametrize("name", sorted(SHORT))
def test_run_shipped_scenario(name, tmp_path):
    out = tmp_path / f"{name}.nc"
    r = cli("run", SCEN / f"{name}.toml", "-o", out, "--stop", SHORT[name], cwd=tmp_path, check=0)
    assert "time span" in r.stdout and str(out) in r.stdout and "invariants" in r.stdout
    assert "max | |q| - 1 |" in r.stdout
    if name == "paper_keplerian":  # the paper's a = 7000 km, e = 0.2: perigee 5600 km
        want = "attitude: warning: perigee altitude -778.1 km: this Earth orbit's perigee radius"
        assert r.stderr.startswith(want) and r.stderr.count("\n") == 1
    else:
        assert r.stderr == ""
    with netCDF4.Dataset(out) as nc:
        g = {k: nc.getncattr(k) for k in nc.ncattrs()}
        assert g["Conventions"] == "CF-1.11"
        for k in ("title", "history", "source", "scenario", "method", "potential", "run_status"):
            assert isinstance(g[k], str) and g[k], k
        assert g["scenario"] == name and g["run_status"] == "complete"
        assert g["package_version"] == __version__
        assert g["rtol"] > 0 and g["atol"] > 0
        assert len(g["inertia"]) == 3
        assert "epoch" in g or name in NO_ORBIT
        # q.Q has the unit of Q: relative to |Q| (Q ~ 1e6 kg m² s⁻¹ for the paper's satellite)
        Qmax = float(np.max(np.linalg.norm(nc.variables["Q"][:], axis=1)))
        assert g["max_abs_norm_error"] < 1e-9 and g["max_abs_qQ"] < 1e-9 * max(1.0, Qmax)
        rel = np.abs(nc.variables["qQ"][:]) / np.linalg.norm(nc.variables["Q"][:], axis=1)
        assert g["max_rel_qQ"] == pytest.approx(float(np.max(rel)), rel=1e-12)
        assert f"max |q.Q| / |Q| = {g['max_rel_qQ']:.3g}" in r.stdout
        expected = ["q", "Q", "omega", "g", "G", "energy", "potential_energy", "norm_error", "qQ"]
        orbit = name not in NO_ORBIT
        if orbit:
            expected += ["r", "f", "p"]
        assert set(expected) <= set(nc.variables)
        for v in expected:
            var = nc.variables[v]
            unit = u.Unit(var.getncattr("units"))
            assert var.getncattr("long_name")
            if orbit and v == "r":
                assert unit == u.km
        tv = nc.variables["time"]
        assert tv.standard_name == "time" and tv.axis == "T" and tv.calendar == "standard"
        if orbit:  # bodies with units: SI (kg km² based before issue 16), CF time
            assert tv.units.startswith("seconds since ") and tv.elapsed_time_units == "s"
            assert u.Unit(nc.variables["Q"].units) == u.Unit("kg m2 / s")
        t = nc.variables["time"][:]
        scale = {
            "gg_stabilised_leo": 60.0,
            "sso_tle_gravity_gradient": 3600.0,
            "cubesat_environment": 3600.0,
            "cubesat_bdot": 3600.0,
            "nadir_wheels_dumping": 3600.0,
            "orbit_raising_burn": 3600.0,
            "cubesat_drag_decay": 3600.0,
        }.get(name, 1.0)
        assert t[0] == 0.0 and t[-1] <= SHORT[name] * scale
        q = nc.variables["q"][:]
        assert np.max(np.abs(np.linalg.norm(q, axis=1) - 1)) < 1e-9


def test_version_help_and_module(tmp_path, capsys):
    r = cli("--version", cwd=tmp_path, check=0)  # python -m attitude
    assert r.stdout.strip() == f"attitude {__version__}"
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    for cmd in ("run", "plot", "info", "export"):
        assert cmd in out
    assert main(["run", "--help"]) == 0
    out = capsys.readouterr().out
    assert "--rtol" in out and "--method" in out and "--stop" in out
    assert main([]) == 2  # no command: help, bad input


def test_malformed_scenario_exit_2_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    text = (SCEN / "paper_keplerian.toml").read_text().replace('Q_unit = "kg km2 s-1"\n', "")
    text = text.replace("a = 7000.0", "a = 8000.0")  # perigee above the ground: no warning
    bad.write_text(text)
    r = cli("run", bad, cwd=tmp_path, check=2)
    assert r.stderr.startswith("attitude: error: initial_state.Q: needs a unit")
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert not list(tmp_path.glob("*.nc"))
    with pytest.raises(ValueError, match=r"initial_state\.Q"):  # --debug: the exception itself
        main(["--debug", "run", str(bad)])


@pytest.mark.parametrize(
    "text,key",
    [
        ("[body]\ninertia = [1, 2]\n", "body.inertia"),
        ("[body]\ninertia = [1.0, 1.0, 1.0]\ncolour = 3\n", "body.colour"),
        ("[bodyy]\n", "bodyy"),
        ("this is not toml", "invalid TOML"),
    ],
)
def test_malformed_in_process(text, key, tmp_path, capsys):
    p = tmp_path / "s.toml"
    p.write_text(text)
    assert main(["run", str(p)]) == 2
    err = capsys.readouterr().err
    assert key in err and err.count("\n") == 1


def test_bad_arguments_exit_2(tmp_path, capsys):
    assert main(["run", str(SCEN / "paper_torque_free.toml"), "--rtol", "-1"]) == 2
    assert "--rtol" in capsys.readouterr().err
    assert main(["run", str(SCEN / "paper_torque_free.toml"), "--method", "rk99"]) == 2
    assert "--method" in capsys.readouterr().err
    assert main(["frobnicate"]) == 2
    assert main(["info", str(tmp_path / "missing.nc")]) == 2
    assert "no such file" in capsys.readouterr().err


def test_failed_run_exit_1_keeps_samples(tmp_path, capsys):
    text = (SCEN / "paper_torque_free.toml").read_text()
    text = text.replace("atol = 1e-14", "atol = 1e-14\nmax_steps = 50")
    (tmp_path / "f.toml").write_text(text)
    assert main(["run", str(tmp_path / "f.toml"), "-o", str(tmp_path / "f.nc")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("attitude: failed: propagation stopped") and err.count("\n") == 1
    with netCDF4.Dataset(tmp_path / "f.nc") as nc:
        assert nc.getncattr("run_status").startswith("failed:")
        assert 0 < len(nc.dimensions["time"]) < 2001


def _long_scenario(tmp_path):
    text = (SCEN / "paper_torque_free.toml").read_text().replace("stop = 20.0", "stop = 100000.0")
    p = tmp_path / "long.toml"
    p.write_text(text)  # 1e7 output samples: far longer than the test waits
    return p


@pytest.mark.parametrize(
    "sig",
    [pytest.param(signal.SIGINT, marks=pytest.mark.slow), signal.SIGTERM, signal.SIGKILL],
)
def test_interrupted_run_leaves_old_file_or_none(sig, tmp_path):
    out = tmp_path / "out.nc"
    if sig != signal.SIGKILL:  # a previous complete result must survive the interrupted run
        args = ["run", str(SCEN / "paper_torque_free.toml"), "-o", str(out), "--stop", "1", "-q"]
        assert main(args) == 0
        before = out.read_bytes()
    proc = subprocess.Popen(
        [sys.executable, "-m", "attitude", "run", str(_long_scenario(tmp_path)), "-o", str(out),
         "--progress", "always"],
        cwd=tmp_path,
        env=ENV,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )  # fmt: skip
    # Events, not a clock: stderr is drained by a thread (the progress line must not block on
    # a full pipe), and the test waits, with a deadline, for the condition it checks: the
    # progress line reports n > 0 samples (may come before the first chunk reaches the disk),
    # then the temporary file exists (on a loaded machine, some time after).
    chunks: list[bytes] = []
    reader = threading.Thread(
        target=lambda: chunks.extend(iter(lambda: os.read(proc.stderr.fileno(), 4096), b"")),
        daemon=True,
    )
    reader.start()
    deadline = time.monotonic() + 300.0

    def wait_for(condition, what):
        while not condition():
            assert proc.poll() is None, (what, proc.returncode, b"".join(chunks)[-2000:])
            assert time.monotonic() < deadline, (f"no {what} after 300 s", b"".join(chunks))
            time.sleep(0.01)

    wait_for(
        lambda: any(int(n) > 0 for n in re.findall(rb"(\d+)/\d+ samples", b"".join(chunks))),
        "progress",
    )
    wait_for(lambda: list(tmp_path.glob(".out.nc.*.tmp")), "temporary file")
    proc.send_signal(sig)
    proc.wait(timeout=300)  # a guard against a hang only
    reader.join(timeout=60)  # the rest of stderr, to its end
    err = b"".join(chunks).decode()
    if sig == signal.SIGKILL:
        assert not out.exists()  # a temporary file may remain, never a partial final file
    else:
        assert proc.returncode == 130, err
        assert "interrupted" in err and "Traceback" not in err
        assert out.read_bytes() == before
        assert not list(tmp_path.glob(".out.nc.*.tmp"))
        with netCDF4.Dataset(out) as nc:
            assert nc.getncattr("run_status") == "complete"


def test_stop_takes_a_unit(tmp_path, capsys, monkeypatch):
    """--stop 10min is 600 s on the run's axis, as 600 in a scenario counting seconds (the
    paper's Keplerian case); a unit that is not a time, or a unit on a dimensionless
    scenario's plain numbers, is refused naming --stop."""
    monkeypatch.chdir(tmp_path)
    for stop, name in (("10min", "a.nc"), ("600", "b.nc")):
        assert main(["run", str(SCEN / "paper_keplerian.toml"), "-o", name, "--stop", stop,
                     "-q"]) == 0  # fmt: skip
    with netCDF4.Dataset("a.nc") as a, netCDF4.Dataset("b.nc") as b:
        ta, tb = a.variables["time"][:].data, b.variables["time"][:].data
        assert ta[-1] == 600.0 and np.array_equal(ta, tb)
        assert np.array_equal(a.variables["q"][:].data, b.variables["q"][:].data)
    capsys.readouterr()
    assert main(["run", str(SCEN / "paper_keplerian.toml"), "-o", "c.nc", "--stop", "3 kg"]) == 2
    assert "--stop 3 kg: expected a time" in capsys.readouterr().err
    assert main(["run", str(SCEN / "paper_torque_free.toml"), "-o", "c.nc", "--stop", "1min"]) == 2
    assert "--stop 1min: this scenario's times are plain numbers" in capsys.readouterr().err
    assert not (tmp_path / "c.nc").exists()


def test_info_plot_export(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(SCEN / "paper_keplerian.toml"), "-o", "k.nc", "--stop", "600"]) == 0
    assert main(["info", "k.nc"]) == 0
    out = capsys.readouterr().out
    assert "paper_keplerian" in out and "GravityGradient" in out
    assert "max | |q| - 1 |" in out and "not conserved" in out
    assert main(["plot", "k.nc", "-o", "k.png"]) == 0
    import matplotlib.image as mpimg

    img = mpimg.imread(tmp_path / "k.png")
    assert img.shape[0] > 500 and img.shape[1] > 800
    assert img[..., :3].std() > 0.05  # not blank
    assert main(["export", "k.nc", "--ccsds-aem", "k.aem"]) == 0
    lines = (tmp_path / "k.aem").read_text(encoding="latin-1").splitlines()
    _, meta, data = check_aem_v2(lines)
    assert meta["REF_FRAME_A"] == "GCRF" and meta["REF_FRAME_B"] == "SC_BODY_1"
    assert meta["CENTER_NAME"] == "EARTH" and meta["TIME_SYSTEM"] == "UTC"
    with netCDF4.Dataset(tmp_path / "k.nc") as nc:
        t = nc.variables["time"][:].data
        q = nc.variables["q"][:].data
        epoch = Time(nc.getncattr("epoch").rstrip("Z"), scale="utc")
    assert len(data) == len(t)
    stamps = [Time(d[0], scale="utc") for d in (data[0], data[-1])]
    for s, tt in zip(stamps, (t[0], t[-1]), strict=True):
        assert abs((s - (epoch + TimeDelta(tt, format="sec"))).to_value("s")) < 1e-6
    vals = np.array([[float(x) for x in d[1:]] for d in data])
    np.testing.assert_array_equal(vals, q[:, [1, 2, 3, 0]])  # Q1 Q2 Q3 QC, exact digits
    # an independent reader (test extra): ccsds-ndm-py
    import ccsds_ndm as ndm

    aem = ndm.Aem.from_file(str(tmp_path / "k.aem"))
    assert aem.version == "2.0"
    seg = aem.segments[0]
    assert seg.metadata.ref_frame_a == "GCRF" and seg.metadata.attitude_type == "QUATERNION"
    np.testing.assert_array_equal(np.asarray(seg.data.attitude_states_numpy), vals)


# CCSDS 504.0-B-2, table 4-2 (AEM header) and table 4-3 (AEM metadata): the keywords in their
# mandatory order (M) or optional (O), transcribed from the standard for this test.
AEM2_HEADER = [("CCSDS_AEM_VERS", "M"), ("COMMENT", "O"), ("CLASSIFICATION", "O"),
               ("CREATION_DATE", "M"), ("ORIGINATOR", "M"), ("MESSAGE_ID", "O")]  # fmt: skip
AEM2_META = [("COMMENT", "O"), ("OBJECT_NAME", "M"), ("OBJECT_ID", "M"), ("CENTER_NAME", "O"),
             ("REF_FRAME_A", "M"), ("REF_FRAME_B", "M"), ("TIME_SYSTEM", "M"),
             ("START_TIME", "M"), ("USEABLE_START_TIME", "O"), ("USEABLE_STOP_TIME", "O"),
             ("STOP_TIME", "M"), ("ATTITUDE_TYPE", "M"), ("EULER_ROT_SEQ", "O"),
             ("ANGVEL_FRAME", "O"), ("INTERPOLATION_METHOD", "O"),
             ("INTERPOLATION_DEGREE", "O")]  # fmt: skip
EPOCH_RE = re.compile(r"^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d+)?$")


def _ordered(items, table):
    """Keywords appear in table order, each non-COMMENT at most once, all mandatory present."""
    pos = {k: i for i, (k, _) in enumerate(table)}
    last = -1
    seen = []
    for k, _ in items:
        assert k in pos, f"keyword {k} not allowed here"
        assert pos[k] >= last, f"keyword {k} out of order"
        assert k == "COMMENT" or k not in seen, f"{k} repeated"
        last = pos[k]
        seen.append(k)
    for k, m in table:
        assert m == "O" or k in seen, f"mandatory {k} missing"


def check_aem_v2(lines):
    body = [ln for ln in lines if ln.strip()]
    assert body[0].split("=")[0].strip() == "CCSDS_AEM_VERS"  # first non-blank line
    i = body.index("META_START")
    kv = [(ln.split(None, 1)[0], ln) if ln.startswith("COMMENT") else
          tuple(s.strip() for s in ln.split("=", 1)) for ln in body[:i]]  # fmt: skip
    _ordered(kv, AEM2_HEADER)
    j = body.index("META_STOP")
    meta_kv = [(ln.split(None, 1)[0], ln) if ln.startswith("COMMENT") else
               tuple(s.strip() for s in ln.split("=", 1)) for ln in body[i + 1 : j]]  # fmt: skip
    _ordered(meta_kv, AEM2_META)
    meta = dict(meta_kv)
    assert meta["ATTITUDE_TYPE"] == "QUATERNION"
    assert "QUATERNION_TYPE" not in meta and "ATTITUDE_DIR" not in meta  # removed in v2
    if "INTERPOLATION_METHOD" in meta:
        assert "INTERPOLATION_DEGREE" in meta
    assert body[j + 1] == "DATA_START" and body[-1] == "DATA_STOP"
    data = [ln.split() for ln in body[j + 2 : -1] if not ln.startswith("COMMENT")]
    for d in data:
        assert len(d) == 5 and EPOCH_RE.match(d[0])
    epochs = [Time(d[0], scale="utc") for d in data]
    assert all((b - a).to_value("s") > 0 for a, b in itertools.pairwise(epochs))
    assert data[0][0] == meta["START_TIME"] and data[-1][0] == meta["STOP_TIME"]
    return dict(kv), meta, data


def test_aem_quaternion_convention_matches_ccsds_annex_f(tmp_path):
    # CCSDS 504.0-B-2 annex F5.4: Z-X-Z rotations (α0 + 90°, 90° − δ0, σ0) = (90°, 10°, 45°)
    # from frame A give the quaternion A→B: Q1 = 0.0805, Q2 = 0.0334, Q3 = 0.9204, QC = 0.3812.
    text = """
    [scenario]
    epoch = "2020-01-01T00:00:00"
    [body]
    inertia = [100.0, 200.0, 250.0]
    inertia_unit = "kg m2"
    [initial_state]
    form = "euler_body_rates"
    seq = "313"
    angles = [90.0, 10.0, 45.0]
    angles_unit = "deg"
    omega = [0.0, 0.0, 0.0]
    omega_unit = "rad/s"
    [time]
    stop = 2.0
    step = 1.0
    unit = "s"
    """
    (tmp_path / "f5.toml").write_text(text)
    assert main(["run", str(tmp_path / "f5.toml"), "-o", str(tmp_path / "f5.nc"), "-q"]) == 0
    out = tmp_path / "f5.aem"
    assert main(["export", str(tmp_path / "f5.nc"), "--ccsds-aem", str(out)]) == 0
    data = check_aem_v2(out.read_text().splitlines())[2]
    assert data[0][0] == "2020-01-01T00:00:00.000000"
    np.testing.assert_allclose([float(x) for x in data[0][1:]], [0.0805, 0.0334, 0.9204, 0.3812],
                               atol=5e-5)  # fmt: skip
    # version 1 (504.0-B-1) for older readers: ATTITUDE_DIR and QUATERNION_TYPE, read back by
    # an independent parse that honours both keywords
    assert (
        main(["export", str(tmp_path / "f5.nc"), "--ccsds-aem", str(out), "--aem-version", "1"])
        == 0
    )
    _, _, (_, v1) = read_aem_v1(out.read_text().splitlines())
    np.testing.assert_allclose(v1[0], [0.0805, 0.0334, 0.9204, 0.3812], atol=5e-5)


# CCSDS 504.0-B-1 (2008), tables 4-2 and 4-3: the version-1 header and metadata keywords in
# their order; version 1 has ATTITUDE_DIR (mandatory) and QUATERNION_TYPE (mandatory for
# quaternion attitude types), RATE_FRAME instead of ANGVEL_FRAME, and no MESSAGE_ID.
AEM1_HEADER = [("CCSDS_AEM_VERS", "M"), ("COMMENT", "O"), ("CREATION_DATE", "M"),
               ("ORIGINATOR", "M")]  # fmt: skip
AEM1_META = [("COMMENT", "O"), ("OBJECT_NAME", "M"), ("OBJECT_ID", "M"), ("CENTER_NAME", "O"),
             ("REF_FRAME_A", "M"), ("REF_FRAME_B", "M"), ("ATTITUDE_DIR", "M"),
             ("TIME_SYSTEM", "M"), ("START_TIME", "M"), ("USEABLE_START_TIME", "O"),
             ("USEABLE_STOP_TIME", "O"), ("STOP_TIME", "M"), ("ATTITUDE_TYPE", "M"),
             ("QUATERNION_TYPE", "M"), ("EULER_ROT_SEQ", "O"), ("RATE_FRAME", "O"),
             ("INTERPOLATION_METHOD", "O"), ("INTERPOLATION_DEGREE", "O")]  # fmt: skip


def read_aem_v1(lines):
    """Independent reader of a version-1 quaternion AEM (504.0-B-1 sect. 4.2.4 and 4.2.5).

    Returns (header, metadata, quaternions) with the quaternions as (Q1, Q2, Q3, QC) *from
    REF_FRAME_A to REF_FRAME_B*, whatever the file declares: the data-line order follows
    QUATERNION_TYPE (FIRST: EPOCH QC Q1 Q2 Q3; LAST: EPOCH Q1 Q2 Q3 QC) and a B2A quaternion is
    inverted (the rotation from B to A is the conjugate of the one from A to B).
    """
    body = [ln for ln in lines if ln.strip()]
    i = body.index("META_START")
    kv = [(ln.split(None, 1)[0], ln) if ln.startswith("COMMENT") else
          tuple(s.strip() for s in ln.split("=", 1)) for ln in body[:i]]  # fmt: skip
    _ordered(kv, AEM1_HEADER)
    assert dict(kv)["CCSDS_AEM_VERS"] == "1.0"
    j = body.index("META_STOP")
    meta_kv = [(ln.split(None, 1)[0], ln) if ln.startswith("COMMENT") else
               tuple(s.strip() for s in ln.split("=", 1)) for ln in body[i + 1 : j]]  # fmt: skip
    _ordered(meta_kv, AEM1_META)
    meta = dict(meta_kv)
    assert meta["ATTITUDE_TYPE"] == "QUATERNION"
    assert meta["QUATERNION_TYPE"] in ("FIRST", "LAST")
    assert meta["ATTITUDE_DIR"] in ("A2B", "B2A")
    assert body[j + 1] == "DATA_START" and body[-1] == "DATA_STOP"
    data = [ln.split() for ln in body[j + 2 : -1] if not ln.startswith("COMMENT")]
    for d in data:
        assert len(d) == 5 and EPOCH_RE.match(d[0])
    assert data[0][0] == meta["START_TIME"] and data[-1][0] == meta["STOP_TIME"]
    vals = np.array([[float(x) for x in d[1:]] for d in data])
    if meta["QUATERNION_TYPE"] == "FIRST":
        vals = vals[:, [1, 2, 3, 0]]
    if meta["ATTITUDE_DIR"] == "B2A":
        vals[:, :3] *= -1.0
    return dict(kv), meta, ([d[0] for d in data], vals)


def test_aem_v1_data_lines_follow_its_keywords(tmp_path):
    """A rotating body exported as version 1 and version 2: the v1 data lines, read as the v1
    keywords (QUATERNION_TYPE, ATTITUDE_DIR) say, are the run's quaternions (exact digits) and
    the v2 values that the independent reader ccsds-ndm-py reads."""
    text = """
    [scenario]
    epoch = "2020-01-01T00:00:00"
    [body]
    inertia = [100.0, 200.0, 250.0]
    inertia_unit = "kg m2"
    [initial_state]
    form = "euler_body_rates"
    seq = "313"
    angles = [90.0, 10.0, 45.0]
    angles_unit = "deg"
    omega = [0.05, -0.02, 0.03]
    omega_unit = "rad/s"
    [time]
    stop = 60.0
    step = 5.0
    unit = "s"
    """
    (tmp_path / "rot.toml").write_text(text)
    nc_path = tmp_path / "rot.nc"
    assert main(["run", str(tmp_path / "rot.toml"), "-o", str(nc_path), "-q"]) == 0
    with netCDF4.Dataset(nc_path) as nc:
        q = nc.variables["q"][:].data
    v1_path, v2_path = tmp_path / "rot1.aem", tmp_path / "rot2.aem"
    assert main(["export", str(nc_path), "--ccsds-aem", str(v1_path), "--aem-version", "1"]) == 0
    assert main(["export", str(nc_path), "--ccsds-aem", str(v2_path)]) == 0
    _, meta, (epochs, v1) = read_aem_v1(v1_path.read_text(encoding="latin-1").splitlines())
    assert meta["REF_FRAME_A"] == "EME2000" and meta["REF_FRAME_B"] == "SC_BODY_1"
    assert len(epochs) == 13 and epochs[-1] == "2020-01-01T00:01:00.000000"
    assert np.ptp(q, axis=0).min() > 0.05  # every component moves: the order is observable
    np.testing.assert_array_equal(v1, q[:, [1, 2, 3, 0]])
    _, _, data2 = check_aem_v2(v2_path.read_text(encoding="latin-1").splitlines())
    assert [d[0] for d in data2] == epochs
    import ccsds_ndm

    aem2 = ccsds_ndm.Aem.from_file(str(v2_path))
    np.testing.assert_array_equal(np.asarray(aem2.segments[0].data.attitude_states_numpy), v1)
    # ccsds-ndm-py 0.0.9 reads version 2 only (it rejects ATTITUDE_DIR); use it on version 1
    # too once it can.
    try:
        aem1 = ccsds_ndm.Aem.from_file(str(v1_path))
    except ValueError as exc:
        assert "parsing error" in str(exc)
    else:
        np.testing.assert_array_equal(np.asarray(aem1.segments[0].data.attitude_states_numpy), v1)


def test_export_needs_an_epoch_and_seconds(tmp_path, capsys):
    nc = tmp_path / "tf.nc"
    assert (
        main(["run", str(SCEN / "paper_torque_free.toml"), "-o", str(nc), "--stop", "1", "-q"]) == 0
    )
    assert main(["export", str(nc), "--ccsds-aem", str(tmp_path / "a.aem")]) == 2
    assert "time-unit-seconds" in capsys.readouterr().err
    assert main(["export", str(nc), "--ccsds-aem", str(tmp_path / "a.aem"),
                 "--time-unit-seconds", "1"]) == 2  # fmt: skip
    assert "--epoch" in capsys.readouterr().err
    assert not (tmp_path / "a.aem").exists()


def test_progress_line_after_one_second():
    import io as _io

    clock = iter([0.0, 0.5, 1.5, 1.7, 3.0])
    s = _io.StringIO()
    p = Progress("always", stream=s, clock=lambda: next(clock))
    p(10, 100, 1.0)  # at 0.5 s: nothing yet
    assert s.getvalue() == ""
    p(50, 100, 5.0)  # at 1.5 s
    assert "50.0%" in s.getvalue() and "50/100" in s.getvalue()
    p(100, 100, 10.0)
    p.close()
    assert s.getvalue().endswith("\n") and "100.0%" in s.getvalue()
    q = Progress("auto", stream=_io.StringIO())  # not a terminal: silent
    assert not q.enabled


def test_run_fixed_step_method_options(tmp_path):
    """--method splitting needs --dt (exit 2 naming it); with it the file records dt and order."""
    scen = SCEN / "paper_torque_free.toml"
    r = cli(
        "run", scen, "--method", "splitting", "--stop", "1", "-o", "a.nc", cwd=tmp_path, check=2
    )
    assert "dt" in r.stderr and "Traceback" not in r.stderr
    cli(
        "run", scen, "--method", "splitting", "--dt", "0.01", "--order", "6", "--stop", "1",
        "-o", "b.nc", "-q", cwd=tmp_path, check=0,
    )  # fmt: skip
    with netCDF4.Dataset(tmp_path / "b.nc") as nc:
        assert nc.getncattr("method") == "splitting"
        assert float(nc.getncattr("dt")) == 0.01 and int(nc.getncattr("order")) == 6
    r = cli("run", scen, "--formulation", "euler_angle", "-o", "c.nc", cwd=tmp_path, check=2)
    assert "formulation" in r.stderr


# Each reader of a corrupt file runs in a process of its own (HDF5 reading corrupted metadata
# can leave the library's state broken for the rest of a process): forked, one per job, from
# a process that imported the package once and opened no file (a second apiece, not 1.3 s).
_FORKED_READERS = """
import json, os, sys
import matplotlib.figure  # the plot command's, imported once
from attitude import io
from attitude.cli import main
from attitude.errors import AttitudeFileError
codes = []
for job in json.loads(sys.argv[1]):
    pid = os.fork()
    if pid == 0:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.dup2(null, 2)
        code = 1
        try:
            if job[0] == "read":
                try:
                    io.read(job[1])
                    code = 0
                except AttitudeFileError:
                    code = 2
            else:
                code = main(job)
        except SystemExit as e:
            code = e.code if isinstance(e.code, int) else 1
        finally:
            os._exit(code or 0)
    codes.append(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))
print(json.dumps(codes))
"""


def _exit_codes_in_fresh_processes(jobs):
    """The exit code of each job (a command line of `attitude`, or ``["read", path]`` for
    :func:`attitude.io.read`: 2 on AttitudeFileError), each in a process of its own."""
    jobs = [[str(a) for a in job] for job in jobs]
    if not hasattr(os, "fork"):
        read = (
            "from attitude import io; from attitude.errors import AttitudeFileError\n"
            "try:\n    io.read(r'%s')\nexcept AttitudeFileError:\n    raise SystemExit(2)"
        )
        cmds = [
            [sys.executable, "-c", read % job[1]] if job[0] == "read"
            else [sys.executable, "-m", "attitude", *job]
            for job in jobs
        ]  # fmt: skip
        return [
            subprocess.run(c, env=ENV, capture_output=True, timeout=300).returncode for c in cmds
        ]
    r = subprocess.run(
        [sys.executable, "-c", _FORKED_READERS, json.dumps(jobs)],
        env=ENV, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.splitlines()[-1])


def test_every_reader_agrees_on_what_is_corrupt(tmp_path, capsys):
    """A closed-loop result with 4 KiB zeroed at offsets through the file: `attitude info`,
    `attitude plot`, `attitude export --ccsds-aem` and `io.read` all accept it or all refuse it
    (exit 2; AttitudeFileError), never one of them writing output from a corrupt file. The
    writers checksum every chunk (Fletcher-32) and the commands read the whole file first."""
    import shutil

    text = (ROOT / "scenarios/rw_inertial_pointing.toml").read_text()
    toml = tmp_path / "rw.toml"
    toml.write_text(text.replace("stop = 600.0", "stop = 20.0"))
    good = tmp_path / "good.nc"
    assert main(["run", str(toml), "-o", str(good)]) == 0
    size = good.stat().st_size
    refused = 0
    jobs = []
    for frac in (0.2, 0.5, 0.8, 0.95):
        bad = tmp_path / f"bad{frac}.nc"
        shutil.copy(good, bad)
        with open(bad, "r+b") as f:
            f.seek(int(frac * size) // 4096 * 4096)
            f.write(bytes(4096))
        jobs += [
            ["info", bad],
            ["plot", bad, "-o", tmp_path / f"p{frac}.png"],
            ["export", bad, "--ccsds-aem", tmp_path / f"e{frac}.aem"],
            ["read", bad],
        ]
    codes = _exit_codes_in_fresh_processes(jobs)
    for frac, row in zip((0.2, 0.5, 0.8, 0.95), np.reshape(codes, (4, 4)).tolist(), strict=True):
        assert row in ([0] * 4, [2] * 4), (frac, row)
        refused += row[0] == 2
        if row[0] == 2:  # a refused file wrote nothing
            assert not (tmp_path / f"p{frac}.png").exists()
            assert not (tmp_path / f"e{frac}.aem").exists()
    assert refused >= 2  # most of the file is checksummed data


def test_info_summarises_a_propagated_orbit(tmp_path, capsys):
    # in-process (compiled): the whole 4 h at 10 Hz
    out = tmp_path / "burn.nc"
    assert main(["run", str(SCEN / "orbit_raising_burn.toml"), "-o", str(out), "-q"]) == 0
    capsys.readouterr()
    r = cli("info", out, cwd=tmp_path)
    lines = r.stdout.splitlines()
    assert "propagated with the attitude" in next(x for x in lines if x.startswith("orbit"))
    # 40 min at 1 N, isp 220 s: 2400 / (220 g0) = 1.11242 kg
    dm = 2400.0 / (220.0 * 9.80665)
    assert re.search(rf"\({dm:.6g} kg of propellant\)", r.stdout)
    # Gauss: a tangential Delta v = isp g0 ln(m0/m1) on a circular orbit, with
    # da/dv = 2 a^(3/2)/sqrt(mu),
    # so a1^(-1/2) = a0^(-1/2) - Delta v/sqrt(mu). The energy semi-major axis shows it to
    # 0.1 % (J3 and beyond, the tesseral terms, the Sun and the Moon move it by ~0.2 km); the
    # osculating two-body a misses it by 2.4 km (J2 swings it by ~10 km over an orbit, and the
    # run ends at one phase of the swing).
    got = re.search(r"energy semi-major axis (\S+) -> (\S+) km \((\S+) km; two-body semi-major "
                    r"axis (\S+) -> (\S+) km\)", r.stdout)  # fmt: skip
    a0, a1, da = (float(got[k]) * 1e3 for k in (1, 2, 3))
    mu = orbit.SphericalHarmonics(8).mu
    dv = 220.0 * 9.80665 * np.log(150.0 / (150.0 - dm))
    gauss = (a0**-0.5 - dv / np.sqrt(mu)) ** -2 - a0
    assert da == pytest.approx(a1 - a0, abs=2.0)  # (m: three decimals of km)
    assert da == pytest.approx(gauss, rel=0.01)
    # the torque budget: the total is the external torque, the thruster's 1 N at 0.1 mm of
    # lever arm (1e-4 N m); the wheels' is internal, and the torque-free model's zero row is left
    rows = {
        x.split()[-3]: float(x.split()[-2]) for x in lines if re.match(r"^\s+\w+\s+\S+\s+\S+$", x)
    }
    assert rows["total"] == pytest.approx(1e-4, rel=1e-3) and rows["thrusters"] == rows["total"]
    assert rows["wheels"] > rows["total"] and "torque_free" not in r.stdout.split("torques")[1]
    assert "(total: the external torque; the wheels' acts between wheels and body)" in r.stdout
    # every variable's unit: CF flags have none, the commands theirs per command
    variables = next(x for x in lines if x.startswith("variables"))
    assert "[?]" not in variables and "mode [flag]" in variables
    assert "wheel_limit [flag]" in variables and "command_sent [per command]" in variables
    # the y wheel barely turns: its round-off minimum (~1e-18 rpm) is printed as 0
    import xarray as xr

    with xr.open_dataset(out) as ds:
        w = ds.wheel_speed.values
    assert abs(w[:, 1].min()) < 1e-12 * np.abs(w).max()
    assert next(x for x in lines if x.split()[:1] == ["wheel2"]).split()[1] == "0"
    # the attitude's energy is not conserved (the wheels and the thruster do work): its change
    # and H0 are printed beside their ratio, which a body starting near rest makes large
    line = next(x for x in lines if "actuators do work" in x)
    got = re.search(r"^\s*max \|H - H0\| = (\S+) J \(actuators do work: not conserved; H0 = "
                    r"(\S+) J, relative (\S+)\)$", line)  # fmt: skip
    import xarray as xr

    with xr.open_dataset(out) as ds:
        E = ds.energy.values
    assert float(got[1]) == pytest.approx(np.abs(E - E[0]).max(), rel=1e-2)
    assert float(got[2]) == pytest.approx(E[0], rel=1e-2)
    assert float(got[3]) == pytest.approx(np.abs(E - E[0]).max() / E[0], rel=1e-2)


def test_a_reader_that_goes_away_ends_the_command_quietly(monkeypatch, capsys):
    # `attitude info out.nc | head`: writing to the closed pipe raises BrokenPipeError, which
    # ends the command with the shell's SIGPIPE status and no "failed" message.
    import attitude.cli as cli

    def closed(args):
        print("file        out.nc")
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(cli, "cmd_info", closed)
    assert main(["info", "out.nc"]) == 141
    assert capsys.readouterr().err == ""

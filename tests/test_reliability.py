"""Regression tests of the reliability defects of issue 12 (fuzzing, interrupts, full disks).

One test (or parametrized case) per defect; each failed before its fix. The hypothesis-driven
fuzz suites of the same campaign are in tests/test_fuzz.py (``pytest -m slow``).
"""

from __future__ import annotations

import gc
import json
import os
import shutil
import signal
import stat
import subprocess
import sys
import textwrap
import threading
import time
import tracemalloc
import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest

import attitude
from attitude import _methods, io, scenario
from attitude import canonical as C
from attitude.cli import main
from attitude.errors import (
    AttitudeError,
    AttitudeFileError,
    AttitudeTypeError,
    AttitudeValueError,
    PropagationError,
)
from attitude.potentials import HeavyTop
from attitude.propagate import propagate
from orbit import KeplerOrbit
from orbit.errors import OrbitTypeError, OrbitValueError

ROOT = Path(__file__).resolve().parent.parent
SCEN = ROOT / "scenarios"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
I_PAPER = [1.25, 1.0, 0.75]
Q_UNIT = [1.0, 0.0, 0.0, 0.0]


def _Q(omega, q=Q_UNIT):
    return C.momenta_from_angular_velocity(q, omega, I_PAPER)


def _temps(d: Path) -> list[Path]:
    return sorted(p for p in d.rglob(".*") if p.name.endswith(".tmp"))


def _scenario_text(**time_table) -> str:
    t = {"stop": 2.0, "step": 0.5, **time_table}
    rows = "\n".join(f"{k} = {v!r}" for k, v in t.items())
    return (
        textwrap.dedent(
            """
        [body]
        inertia = [1.25, 1.0, 0.75]
        [initial_state]
        form = "body_rates"
        q = [1.0, 0.0, 0.0, 0.0]
        omega = [0.3, 0.2, 0.1]
        [time]
        """
        )
        + rows
    )


@pytest.fixture(scope="module")
def small_ds():
    return propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 1.0, 11))


# ------------------------------------------------------------------------------------------------
# runs that did nothing, or should have been refused before any work
# ------------------------------------------------------------------------------------------------


def test_time_step_longer_than_the_span_is_refused(tmp_path):
    # was: exit 0, "time span 0 .. 0 (1 samples)", nothing propagated
    with pytest.raises(scenario.ScenarioError, match=r"time\.step"):
        scenario.loads(_scenario_text(stop=2.0, step=1e7))
    (tmp_path / "s.toml").write_text(_scenario_text(stop=2.0, step=1e7))
    assert main(["run", str(tmp_path / "s.toml"), "-o", str(tmp_path / "s.nc"), "-q"]) == 2
    assert not (tmp_path / "s.nc").exists()


def test_fast_rotation_is_refused_after_a_probe():
    # was: 1e6 steps (minutes at the default max_steps), then a PropagationError
    with pytest.raises(AttitudeValueError, match=r"max_steps.*cannot finish"):
        propagate(I_PAPER, Q_UNIT, _Q([1e12, 0.0, 1e11]), [0.0, 1000.0], max_steps=10**6)


def test_long_span_is_refused_after_a_probe():
    # was: t = [0, 1e12] ran max_steps steps (100-215 s at the default) before failing
    with pytest.raises(AttitudeValueError, match="max_steps"):
        propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), [0.0, 1e12], max_steps=10**5)


def test_scipy_methods_estimate_their_work_too():
    # ~2e4 RK45 steps for max_steps = 100: refused after the probe (was: no step limit at all)
    with pytest.raises(AttitudeValueError, match="max_steps"):
        propagate(
            I_PAPER, Q_UNIT, _Q([1e4, 0.0, 1e3]), [0.0, 0.05], method="scipy:RK45",
            max_steps=100,
        )  # fmt: skip


def test_probe_estimate_warns_and_keeps_the_partial_run():
    # A run that needs a few times max_steps: a warning before, the partial samples after.
    t = np.linspace(0.0, 100.0, 11)
    with pytest.warns(RuntimeWarning, match="more than max_steps = 100"):
        with pytest.raises(PropagationError, match="maximum number of steps") as info:
            propagate(I_PAPER, Q_UNIT, _Q([0.3, 2.0, 0.1]), t, max_steps=100)
    assert 0 < info.value.partial.sizes["time"] < 11


def test_the_probe_estimate_is_close_to_the_steps_taken():
    # the estimate made after PROBE_STEPS steps against the steps of the whole run
    I = attitude.RigidBody([400.0, 500.0, 600.0], units="kg km2")
    o = KeplerOrbit(7000.0 / 0.3, 0.7, 0.5, 0.7, 0.1)
    q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = C.momenta_from_angular_velocity(q0, [1e-3, 0.0, 2e-3], I)
    pot = attitude.GravityGradient(o)
    t = [0.0, 5 * o.period]
    full = propagate(I, q0, Q0, t, potential=pot)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the estimate must not warn: max_steps is enough
        propagate(I, q0, Q0, t, potential=pot, max_steps=int(2 * full.attrs["n_steps"]))
    few = max(1, int(full.attrs["n_steps"]) // 1000)  # 1/1000 of it: refused after the probe
    with pytest.raises(AttitudeValueError, match="max_steps"):
        propagate(I, q0, Q0, t, potential=pot, max_steps=few)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"max_step": 1e-300, "max_steps": 10**5}, "max_step"),
        ({"atol": 1e-200}, "atol"),
        ({"atol": 1e-300}, "atol"),
    ],
)
def test_what_cannot_work_is_refused_up_front(kwargs, match):
    # was: max_step=1e-300 ran until max_steps; atol <= 1e-200 "state became non-finite" at t0
    with pytest.raises(AttitudeValueError, match=match):
        propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), [0.0, 10.0], **kwargs)


def test_ensemble_threads_beyond_numba_are_refused():
    import numba

    # was: PropagationError at run time ("chunk of members ... failed: ValueError")
    q0 = np.tile(Q_UNIT, (4, 1))
    with pytest.raises(AttitudeValueError, match="threads"):
        attitude.propagate_ensemble(
            I_PAPER, q0, _Q([0.3, 0.2, 0.1]), [0.0, 1.0],
            threads=numba.config.NUMBA_NUM_THREADS + 1,
        )  # fmt: skip


def test_huge_Q0_is_checked_without_overflow():
    # was: |Q| = inf, so q.Q looked relatively 0: another Q came back with correction 0.0
    with pytest.raises(AttitudeValueError, match="Q0"):
        C.project_state([1.0, 0.0, 0.0, 0.0], [1e155, 1e155, 0.0, 0.0])
    with pytest.raises(AttitudeValueError, match="Q0"):
        attitude.propagate_ensemble(
            I_PAPER, np.tile(Q_UNIT, (3, 1)), [1e155, 1e155, 0.0, 0.0], [0.0, 1.0], max_steps=1000
        )
    _, Q, corr = C.project_state([1.0, 0.0, 0.0, 0.0], [0.0, 1e300, -1e300, 1e300])
    assert corr == 0.0 and np.array_equal(Q, [0.0, 1e300, -1e300, 1e300])


def test_scaled_projection_is_the_unscaled_one_bit_for_bit():
    rng = np.random.default_rng(5)
    for _ in range(200):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q *= 1.0 + rng.uniform(-5e-7, 5e-7)
        Q = rng.normal(size=4) * 10.0 ** rng.uniform(-8, 8)
        Q -= np.dot(q, Q) / np.dot(q, q) * q * (1.0 - rng.uniform(0, 1e-8))
        qn = q / np.linalg.norm(q)
        qQ = float(np.dot(qn, Q))
        ref = Q - qQ * qn
        got = C.project_state(q, Q)
        assert np.array_equal(got[0], qn) and np.array_equal(got[1], ref)


# ------------------------------------------------------------------------------------------------
# errors that were not the package's
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"rtol": np.array([1e-8, 1e-9])}, AttitudeTypeError, "rtol"),
        ({"atol": np.array([1e-8, 1e-9])}, AttitudeTypeError, "atol"),
        ({"max_step": np.array([1.0, 2.0])}, AttitudeTypeError, "max_step"),
        ({"method": "splitting", "dt": np.array([0.1, 0.2])}, AttitudeTypeError, "dt"),
        ({"rtol": "1e-8"}, AttitudeTypeError, "rtol"),
        ({"atol": b"1e-8"}, AttitudeTypeError, "atol"),
        ({"rtol": np.complex128(1e-8)}, AttitudeTypeError, "rtol"),
        ({"rtol": True}, AttitudeTypeError, "rtol"),
        ({"max_steps": True}, AttitudeTypeError, "max_steps"),
        ({"max_steps": 1e5}, AttitudeTypeError, "max_steps"),
        ({"chunk": "a"}, AttitudeTypeError, "chunk"),
        ({"chunk": 0}, AttitudeValueError, "chunk"),
        ({"chunk": -5}, AttitudeValueError, "chunk"),
        ({"q0": np.array([1.0 + 0.5j, 0.0, 0.0, 0.0])}, AttitudeTypeError, "q0"),
        ({"q0": ["1", "0", "0", "0"]}, AttitudeTypeError, "q0"),
        ({"t": np.array([0.0, 1.0 + 1j])}, AttitudeTypeError, "t"),
    ],
)
def test_bad_scalars_and_arrays_name_the_parameter(kwargs, exc, match):
    args = {"q0": Q_UNIT, "t": [0.0, 1.0], **kwargs}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's ComplexWarning is not an answer
        with pytest.raises(exc, match=match):
            propagate(I_PAPER, args.pop("q0"), _Q([0.3, 0.2, 0.1]), args.pop("t"), **args)


def test_heavy_top_weight_array_is_named():
    with pytest.raises(AttitudeTypeError, match="weight"):
        HeavyTop(np.array([1.0, 2.0]), [1.0, 0.0, 0.0])
    with pytest.raises(AttitudeTypeError, match="weight"):
        HeavyTop("2", [1.0, 0.0, 0.0])


@pytest.mark.parametrize("a", [1e300, 1e-300, -1e300])
def test_extreme_semi_major_axes_are_orbit_errors(a):
    # was: OverflowError / ZeroDivisionError
    e = 1.5 if a < 0 else 0.1
    with pytest.raises(OrbitValueError, match="a"):
        KeplerOrbit(a, e, 0.5, 0.1, 0.2)


@pytest.mark.parametrize(
    "kwargs", [{"a": True}, {"e": np.complex128(0.1 + 0.2j)}, {"inc": np.array([True])}]
)
def test_keplerorbit_refuses_non_real_elements(kwargs):
    # was: True taken as 1 km, complex elements truncated with only numpy's ComplexWarning
    args = {"a": 7000.0, "e": 0.1, "inc": 0.5, "raan": 0.1, "argp": 0.2, **kwargs}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(OrbitTypeError):
            KeplerOrbit(**args)
    orb = KeplerOrbit(7000.0, 0.1, 0.5, 0.1, 0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(OrbitTypeError, match="t"):
            orb.radius(np.complex128(1j))


@pytest.mark.parametrize("path", [None, 3, 3.5, "a\x00b.nc", b"a\x00b.nc", ""])
def test_io_bad_paths_are_package_errors_and_leave_nothing(path, small_ds, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(AttitudeError):
        io.write(small_ds, path)
    with pytest.raises(AttitudeError):
        io.read(path)
    assert list(tmp_path.iterdir()) == []  # was: a stray ".a" (the name cut at the NUL)


def test_long_file_names(small_ds, tmp_path):
    # 250 characters: a valid name, whose ".NAME.<pid>.tmp" was not
    name = "y" * 247 + ".nc"
    io.write(small_ds, tmp_path / name)
    assert io.read(tmp_path / name).sizes["time"] == 11
    with pytest.raises(AttitudeFileError, match="too long"):
        io.write(small_ds, tmp_path / ("x" * 300 + ".nc"))
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_scenario_start_overflow_is_a_scenario_error():
    # was: OverflowError (round(inf))
    with pytest.raises(scenario.ScenarioError, match="time"):
        scenario.loads(_scenario_text(start=-1e308, stop=1e308, step=1.0))
    with pytest.raises(scenario.ScenarioError, match="time"):
        scenario.loads(_scenario_text(stop=1e300, step=1e-300))


def test_cli_bad_output_paths_exit_2_without_stray_files(tmp_path, capsys):
    text = _scenario_text() + '\n[output]\npath = "a\\u0000b.nc"\n'
    (tmp_path / "s.toml").write_text(text)
    os.chdir(tmp_path)
    try:
        assert main(["run", "s.toml", "-q"]) == 2
        assert "NUL" in capsys.readouterr().err
        assert main(["run", "s.toml", "-o", "x" * 300 + ".nc", "-q"]) == 2
        assert "too long" in capsys.readouterr().err
    finally:
        os.chdir(ROOT)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def _mount_tmpfs(where: Path, opts: str) -> bool:
    if os.geteuid() != 0 or not shutil.which("mount"):
        return False
    where.mkdir(exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(where)],
                       capture_output=True)  # fmt: skip
    return r.returncode == 0


@pytest.fixture
def full_disk(tmp_path):
    """A 256 kB file system (root can mount one; skipped otherwise)."""
    mnt = tmp_path / "full"
    if not _mount_tmpfs(mnt, "size=256k"):
        pytest.skip("needs root and tmpfs to make a small file system")
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.fixture
def read_only_dir(tmp_path):
    mnt = tmp_path / "ro"
    if _mount_tmpfs(mnt, "ro,size=64k"):
        yield mnt
        subprocess.run(["umount", "-l", str(mnt)], check=False)
        return
    if os.geteuid() == 0:
        pytest.skip("root ignores permissions and cannot mount here")
    mnt.mkdir()
    mnt.chmod(0o555)
    yield mnt
    mnt.chmod(0o755)


def test_full_disk_says_so_and_leaves_nothing(full_disk, tmp_path, capsys):
    # 4001 samples (896 kB in memory, 469 kB written): small enough for the up-front size
    # check (a quarter of the raw size, 224 kB), too large for 256 kB
    ds = propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 50.0, 4001))
    for _ in range(2):
        with pytest.raises(AttitudeFileError, match="disk is full"):
            io.write(ds, full_disk / "x.nc")  # was: RuntimeError: NetCDF: HDF error
        assert list(full_disk.iterdir()) == []
        # the space is given back (HDF5 could not close the file and kept it open), also once
        # the failed handle is garbage-collected (HDF5 flushed into the deleted file then)
        assert shutil.disk_usage(full_disk).free > 200_000
        gc.collect()
        assert shutil.disk_usage(full_disk).free > 200_000
    (tmp_path / "s.toml").write_text(_scenario_text(stop=50.0, step=0.01))
    assert main(["run", str(tmp_path / "s.toml"), "-o", str(full_disk / "s.nc"), "-q"]) == 2
    assert "disk is full" in capsys.readouterr().err
    assert list(full_disk.iterdir()) == []


def test_outputs_that_cannot_fit_are_refused_before_any_work(full_disk, tmp_path):
    # was: a 1e9-member ensemble ran (for days) until the disk was full
    sc = scenario.loads(_scenario_text(stop=1000.0, step=0.01))  # 1e5 samples, ~17 MB
    with pytest.raises(AttitudeFileError, match="needs about"):
        sc.run_to_file(full_disk / "s.nc")
    with pytest.raises(AttitudeFileError, match="needs about"):
        attitude.propagate_ensemble(
            I_PAPER, np.tile(Q_UNIT, (100_000, 1)), _Q([0.3, 0.2, 0.1]),
            np.linspace(0.0, 1.0, 101), path=full_disk / "e.nc",
        )  # fmt: skip
    assert list(full_disk.iterdir()) == []


def test_read_only_directory_exit_2(read_only_dir, tmp_path, small_ds, capsys):
    with pytest.raises(AttitudeFileError, match=r"read-only|permission"):
        io.write(small_ds, read_only_dir / "x.nc")
    (tmp_path / "s.toml").write_text(_scenario_text())
    assert main(["run", str(tmp_path / "s.toml"), "-o", str(read_only_dir / "s.nc")]) == 2
    err = capsys.readouterr().err
    assert "read-only" in err or "permission" in err


def test_info_on_foreign_and_truncated_files_exit_2(tmp_path, small_ds, capsys):
    with netCDF4.Dataset(tmp_path / "foreign.nc", "w") as nc:
        nc.createDimension("x", 3)
        nc.createVariable("v", "f8", ("x",))[:] = [1.0, 2.0, 3.0]
    assert main(["info", str(tmp_path / "foreign.nc")]) == 2  # was: exit 1, KeyError
    assert "not an attitude result file" in capsys.readouterr().err
    big = propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 100.0, 50001))
    io.write(big, tmp_path / "full.nc")
    data = (tmp_path / "full.nc").read_bytes()
    (tmp_path / "cut.nc").write_bytes(data[: len(data) // 2])
    for cmd in (["info"], ["plot"], ["export", "--ccsds-aem", str(tmp_path / "c.aem")]):
        assert main([cmd[0], str(tmp_path / "cut.nc"), *cmd[1:]]) == 2, cmd
        err = capsys.readouterr().err
        assert err.startswith("attitude: error:") and err.count("\n") == 1, err
    with pytest.raises(AttitudeFileError):
        io.read(tmp_path / "cut.nc")
    assert not (tmp_path / "c.aem").exists() and not _temps(tmp_path)


# ------------------------------------------------------------------------------------------------
# files
# ------------------------------------------------------------------------------------------------


def test_write_to_a_directory_leaves_no_temporary(small_ds, tmp_path):
    (tmp_path / "adir").mkdir()
    with pytest.raises(AttitudeFileError, match="directory"):
        io.write(small_ds, tmp_path / "adir")  # was: IsADirectoryError after the data
    assert not _temps(tmp_path)


@pytest.mark.parametrize(
    "attrs", [{"bad/name": 1.0}, {"big": 2**70}, {"s": "a\udcffb"}, {"nul": "a\x00b"}, {3: 1.0}]
)
def test_attrs_are_checked_before_anything_is_written(attrs, small_ds, tmp_path):
    path = tmp_path / "x.nc"
    path.write_bytes(b"previous")
    ds = small_ds.copy()
    ds.attrs.update(attrs)
    with pytest.raises(AttitudeError, match="attr"):
        io.write(ds, path)  # was: the data written first, then a raw error, temp left
    assert path.read_bytes() == b"previous" and not _temps(tmp_path)
    w = io.StreamWriter(path)
    w.append(small_ds)
    w.attrs.update(attrs)
    with pytest.raises(AttitudeError, match="attr"):
        w.commit()
    assert path.read_bytes() == b"previous" and not _temps(tmp_path)


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_stale_temporaries_of_dead_processes_are_removed(small_ds, tmp_path):
    dead = _dead_pid()
    stale = [tmp_path / f".out.nc.attitude-{dead}.tmp", tmp_path / f".out.nc.{dead}.tmp"]
    alive = tmp_path / ".out.nc.attitude-1.tmp"  # pid 1 runs, and started before the file
    other = tmp_path / f".other.nc.attitude-{dead}.tmp"  # another target: not ours to remove
    for p in [*stale, alive, other]:
        p.write_bytes(b"x" * 1000)
    io.write(small_ds, tmp_path / "out.nc")
    assert not any(p.exists() for p in stale)
    assert alive.exists() and other.exists()


def test_a_killed_run_is_cleaned_up_by_the_next(tmp_path):
    out = tmp_path / "out.nc"
    text = (SCEN / "paper_torque_free.toml").read_text().replace("stop = 20.0", "stop = 1e5")
    (tmp_path / "long.toml").write_text(text)
    proc = subprocess.Popen(
        [sys.executable, "-m", "attitude", "run", str(tmp_path / "long.toml"), "-o", str(out)],
        env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while not _temps(tmp_path):
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    proc.kill()
    proc.wait()
    assert _temps(tmp_path) and not out.exists()
    assert (
        main(["run", str(SCEN / "paper_torque_free.toml"), "-o", str(out), "--stop", "1", "-q"])
        == 0
    )
    assert not _temps(tmp_path)  # was: 117 MB temporaries that nothing removed


def test_symlink_target_is_written_through_the_link(small_ds, tmp_path):
    real = tmp_path / "real.nc"
    real.write_bytes(b"old")
    link = tmp_path / "link.nc"
    link.symlink_to(real)
    io.write(small_ds, link)
    assert link.is_symlink() and os.readlink(link) == str(real)  # was: the link replaced
    assert io.read(real).sizes["time"] == 11


def test_fifo_is_written_through(small_ds, tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    io.write(small_ds, fifo)
    reader.join(30)
    assert stat.S_ISFIFO(fifo.lstat().st_mode)  # was: replaced by a regular file
    (tmp_path / "copy.nc").write_bytes(got[0])
    back = io.read(tmp_path / "copy.nc")
    np.testing.assert_array_equal(back.q.values, small_ds.q.values)


def test_character_device_is_never_replaced(small_ds, tmp_path):
    if os.geteuid() != 0:
        pytest.skip("mknod of a character device needs root")
    null = tmp_path / "null"
    try:
        os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a private /dev/null
    except OSError:
        pytest.skip("cannot create device nodes here")
    io.write(small_ds, null)
    assert stat.S_ISCHR(null.lstat().st_mode)  # was: renamed over: a regular file
    (tmp_path / "s.toml").write_text(_scenario_text())
    assert main(["run", str(tmp_path / "s.toml"), "-o", str(null), "-q"]) == 0
    assert stat.S_ISCHR(null.lstat().st_mode)
    assert not _temps(tmp_path)


def test_block_devices_and_sockets_are_refused(small_ds, tmp_path):
    import socket

    sock = tmp_path / "s.sock"
    s = socket.socket(socket.AF_UNIX)
    try:
        s.bind(str(sock))
        with pytest.raises(AttitudeFileError, match="socket"):
            io.write(small_ds, sock)
    finally:
        s.close()


def test_output_to_stdout_is_the_netcdf_and_the_summary_goes_to_stderr(tmp_path):
    (tmp_path / "s.toml").write_text(_scenario_text())
    r = subprocess.run(
        [sys.executable, "-m", "attitude", "run", "s.toml", "-o", "/dev/stdout"],
        cwd=tmp_path, env=ENV, capture_output=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout[:4] == b"\x89HDF"
    assert b"scenario" in r.stderr
    (tmp_path / "o.nc").write_bytes(r.stdout)
    assert io.read(tmp_path / "o.nc").sizes["time"] == 5


def test_output_directory_naming(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.toml").write_text(_scenario_text())
    # was: "-o newdir/" wrote a file named "newdir"
    assert main(["run", "s.toml", "-o", "newdir/", "-q"]) == 0
    assert (tmp_path / "newdir" / "s.nc").is_file()
    assert main(["run", "s.toml", "-o", "newdir", "-q"]) == 0  # an existing directory too
    (tmp_path / "adir").mkdir()
    # was: "plot -o adir" wrote adir.png but printed "adir"
    assert main(["plot", "newdir/s.nc", "-o", "fig"]) == 0
    assert capsys.readouterr().out.strip().endswith("fig.png") and (tmp_path / "fig.png").is_file()
    assert main(["plot", "newdir/s.nc", "-o", "adir"]) == 0
    assert capsys.readouterr().out.strip().endswith("adir/s.png")
    assert (tmp_path / "adir" / "s.png").is_file()
    assert main(["plot", "newdir/s.nc", "-o", "f.xyz"]) == 2
    assert "format" in capsys.readouterr().err and not _temps(tmp_path)


# ------------------------------------------------------------------------------------------------
# interruption
# ------------------------------------------------------------------------------------------------


def test_results_do_not_depend_on_the_step_budget(monkeypatch):
    from attitude._core import splitting as _ks
    from attitude.ensemble import _chunks

    t = np.linspace(0.0, 60.0, 4)
    Q0 = _Q([0.3, 2.0, 0.1])
    pot = HeavyTop(0.5, [0.0, 0.0, 1.0])
    runs = [
        dict(potential=pot),
        dict(potential=pot, formulation="euler_equations"),
        dict(potential=pot, method="splitting", dt=0.01),
    ]
    ref = [propagate(I_PAPER, Q_UNIT, Q0, t, **kw) for kw in runs]
    ens = attitude.propagate_ensemble(I_PAPER, np.tile(Q_UNIT, (5, 1)), Q0, t, pot)
    monkeypatch.setattr(_methods, "STEP_BUDGET", 7)
    monkeypatch.setattr(_chunks, "ENSEMBLE_STEP_BUDGET", 1)
    monkeypatch.setattr(_chunks, "MIN_MEMBER_BUDGET", 3)
    assert _ks.N_COUNTERS == 5
    calls = []
    for kw, r in zip(runs, ref, strict=True):
        got = propagate(I_PAPER, Q_UNIT, Q0, t, progress=lambda *a: calls.append(a), **kw)
        assert np.array_equal(got.q.values, r.q.values), kw
        assert np.array_equal(got.Q.values, r.Q.values), kw
    assert len(calls) > 100  # the compiled calls returned every few steps
    ens2 = attitude.propagate_ensemble(I_PAPER, np.tile(Q_UNIT, (5, 1)), Q0, t, pot)
    assert np.array_equal(ens.q.values, ens2.q.values)
    assert np.array_equal(ens.member_n_steps.values, ens2.member_n_steps.values)


def test_taylor_and_event_runs_do_not_depend_on_the_step_budget(monkeypatch):
    # The runners added with the Taylor method and the events (single runs and ensembles)
    # return to Python every STEP_BUDGET steps too (Ctrl-C acts), bit for bit.
    from attitude.ensemble import _chunks
    from attitude.events import RateExceeds

    t = np.linspace(0.0, 60.0, 4)
    Q0 = _Q([0.3, 2.0, 0.1])
    pot = HeavyTop(0.5, [0.0, 0.0, 1.0])
    dense = propagate(I_PAPER, Q_UNIT, Q0, np.linspace(0.0, 60.0, 601), potential=pot)
    w = np.linalg.norm(dense.omega.values, axis=-1)
    ev = RateExceeds(0.5 * (w.min() + w.max()), direction="both")
    stop = RateExceeds(0.5 * (w.min() + w.max()), terminal=True)
    runs = [
        dict(method="taylor", rtol=1e-12),
        dict(events=[ev]),
        dict(events=[ev, stop]),
    ]
    ref = [propagate(I_PAPER, Q_UNIT, Q0, t, potential=pot, **kw) for kw in runs]
    q0s = np.tile(Q_UNIT, (5, 1))
    ens = attitude.propagate_ensemble(I_PAPER, q0s, Q0, t, pot, events=[ev, stop])
    monkeypatch.setattr(_methods, "STEP_BUDGET", 7)
    monkeypatch.setattr(_chunks, "ENSEMBLE_STEP_BUDGET", 1)
    monkeypatch.setattr(_chunks, "MIN_MEMBER_BUDGET", 3)
    for kw, r in zip(runs, ref, strict=True):
        calls = []
        report = lambda *a, calls=calls: calls.append(a)  # noqa: E731
        got = propagate(I_PAPER, Q_UNIT, Q0, t, potential=pot, progress=report, **kw)
        assert np.array_equal(got.q.values, r.q.values), kw
        assert np.array_equal(got.Q.values, r.Q.values), kw
        assert got.attrs["n_steps"] == r.attrs["n_steps"]
        # a return every 7 steps after the 64-step probe
        assert (got.attrs["n_steps"] - _methods.PROBE_STEPS) / 7 - 2 <= len(calls), kw
        if "events" in kw:
            assert np.array_equal(got.event_time.values, r.event_time.values)
            assert got.event_time.size >= 2
    assert ref[2].attrs.get("terminal_event")
    ens2 = attitude.propagate_ensemble(I_PAPER, q0s, Q0, t, pot, events=[ev, stop])
    for v in ("q", "member_n_steps", "member_status", "event_first_time", "event_count"):
        assert np.array_equal(ens[v].values, ens2[v].values, equal_nan=True), v


def test_ctrl_c_acts_inside_a_long_compiled_run():
    # One output interval of ~3e7 steps: a single compiled call before the fix (tens of s).
    Q0 = _Q([3000.0, 0.0, 500.0])
    calls = []

    def alarm(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, 0.5)
    try:
        with pytest.raises(KeyboardInterrupt):
            propagate(I_PAPER, Q_UNIT, Q0, [0.0, 1e4], progress=lambda *a: calls.append(a))
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert calls and calls[-1][2] < 1e4  # interrupted midway, not after the run


def _runner(tmp_path: Path, body: str) -> Path:
    """A package ``runner`` whose __main__ patches the CLI, then runs it (python -m runner)."""
    pkg = tmp_path / "runner"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "__main__.py").write_text(
        "import os, signal, sys\nimport attitude.cli as cli\n"
        + textwrap.dedent(body)
        + "\nraise SystemExit(cli.main(sys.argv[1:]))\n"
    )
    return pkg


def test_a_swallowed_interrupt_is_not_lost(tmp_path):
    # Third-party code swallows a KeyboardInterrupt (here: a bare except around a SIGINT);
    # was: the run went on and exited 0 with the file written (2 of 89 Ctrl-C).
    _runner(
        tmp_path,
        """
        _orig = cli.Progress.__call__
        def _call(self, *a):
            if not getattr(cli, "_sent", False):
                cli._sent = True
                try:
                    os.kill(os.getpid(), signal.SIGINT)
                    for _ in range(1000):
                        pass
                except KeyboardInterrupt:
                    pass
            return _orig(self, *a)
        cli.Progress.__call__ = _call
        """,
    )
    (tmp_path / "s.toml").write_text(_scenario_text(stop=200.0, step=0.001))
    r = subprocess.run(
        [sys.executable, "-m", "runner", "run", "s.toml", "-o", "s.nc"],
        cwd=tmp_path, env={**ENV, "PYTHONPATH": f"{ROOT}{os.pathsep}{tmp_path}"},
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 130, r.stderr
    assert "interrupted" in r.stderr and not (tmp_path / "s.nc").exists()
    assert not _temps(tmp_path)


def test_interrupt_exit_status_is_130_not_a_signal(tmp_path):
    # A KeyboardInterrupt that escapes an exec() of a string (numba does those) made CPython
    # kill the process with SIGINT at exit: status -2 instead of 130 (15 of 40 Ctrl-C).
    _runner(
        tmp_path,
        """
        _orig = cli.Progress.__call__
        def _call(self, *a):
            exec("raise KeyboardInterrupt")
        cli.Progress.__call__ = _call
        """,
    )
    (tmp_path / "s.toml").write_text(_scenario_text())
    r = subprocess.run(
        [sys.executable, "-m", "runner", "run", "s.toml", "-o", "s.nc"],
        cwd=tmp_path, env={**ENV, "PYTHONPATH": f"{ROOT}{os.pathsep}{tmp_path}"},
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert r.returncode == 130, (r.returncode, r.stderr)
    assert not (tmp_path / "s.nc").exists()


def test_ctrl_c_stops_a_fast_spinning_cli_run(tmp_path):
    # Two output samples, ~4e7 steps between them: before, Ctrl-C waited for the whole
    # compiled call (minutes on this machine; 96 s in the campaign).
    text = _scenario_text(stop=1e4, step=1e4).replace("[0.3, 0.2, 0.1]", "[3000.0, 0.0, 500.0]")
    (tmp_path / "s.toml").write_text(text)
    proc = subprocess.Popen(
        [sys.executable, "-m", "attitude", "run", "s.toml", "-o", "s.nc", "--progress", "always"],
        cwd=tmp_path, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    seen = threading.Event()

    def watch():
        while proc.stderr.read(1):  # the progress bar: the integration is under way
            seen.set()

    threading.Thread(target=watch, daemon=True).start()
    assert seen.wait(120), "no progress bar"
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130
    assert not (tmp_path / "s.nc").exists() and not _temps(tmp_path)


# ------------------------------------------------------------------------------------------------
# ensembles
# ------------------------------------------------------------------------------------------------


def test_failing_members_do_not_discard_the_others(tmp_path):
    n = 200
    q0 = np.tile(Q_UNIT, (n, 1))
    w = np.tile([0.0, 0.0, 0.1], (n, 1))
    w[[30, 170], 2] = 30.0  # these two need far more steps than max_steps
    Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
    t = np.linspace(0.0, 10.0, 3)
    path = tmp_path / "e.nc"
    with pytest.raises(PropagationError, match=r"member\(s\) 30, 170 failed") as info:
        attitude.propagate_ensemble(I_PAPER, q0, Q0, t, max_steps=100, chunk_size=50, path=path)
    info.value.partial.close()
    back = io.read(path)  # was: no file (both failures in chunks that were discarded)
    assert back.sizes["member"] == n
    status = back.member_status.values
    assert set(np.flatnonzero(status)) == {30, 170} and status[30] == 3
    meanings = back.member_status.attrs["flag_meanings"].split()
    assert meanings[list(back.member_status.attrs["flag_values"]).index(3)] == "max_steps_reached"
    assert back.attrs["run_status"].startswith("failed: member(s) 30, 170")
    assert back.attrs["n_members_failed"] == 2
    assert np.all(np.isnan(back.q.values[30, -1])) and np.all(np.isfinite(back.q.values[31]))
    single = propagate(I_PAPER, q0[171], Q0[171], t)
    np.testing.assert_array_equal(back.q.values[171], single.q.values)
    # the statistics leave the failed members out (their NaN would spread)
    ok = back.isel(member=np.flatnonzero(status == 0))
    np.testing.assert_array_equal(
        attitude.rate_percentiles(back).values, attitude.rate_percentiles(ok).values
    )
    assert np.all(np.isfinite(attitude.pointing_error_percentiles(back).values))
    # in memory too: every member in .partial
    with pytest.raises(PropagationError, match="30, 170") as info:
        attitude.propagate_ensemble(I_PAPER, q0, Q0, t, max_steps=100, chunk_size=64)
    assert info.value.partial.sizes["member"] == n
    assert not _temps(tmp_path)


# ------------------------------------------------------------------------------------------------
# memory
# ------------------------------------------------------------------------------------------------


def test_cli_streaming_does_not_hold_the_time_grid(tmp_path):
    # 1e6 samples: the grid alone is 8 MB; a run streams chunks of 4096.
    text = _scenario_text(stop=1000.0, step=0.001)
    # compile first (three chunks take the same paths), so that only the run is traced
    scenario.loads(_scenario_text(stop=10.0, step=0.001)).run_to_file(tmp_path / "w.nc", rtol=1e-6)
    tracemalloc.start()
    try:
        sc = scenario.loads(text)
        sc.run_to_file(tmp_path / "m.nc", rtol=1e-6)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4e6, f"peak {peak / 1e6:.1f} MB"  # was: > 8 MB of times (1 GB at 3e7)
    assert io.read(tmp_path / "m.nc", load=False).sizes["time"] == 1_000_001
    # the times are generated a chunk at a time, bit for bit those of numpy.linspace
    assert len(sc.t) == 1_000_001 and sc.t.nbytes == 8_000_008
    np.testing.assert_array_equal(sc.t[999_990:], np.linspace(0.0, 1000.0, 1_000_001)[999_990:])


def test_streamed_chunks_reach_the_disk_as_they_are_written(tmp_path):
    # netCDF's default chunk cache (64 MiB a variable) kept up to ~0.7 GB of a streamed run in
    # memory (359 MB measured at 2e6 samples) and made closing or aborting take seconds.
    w = io.StreamWriter(tmp_path / "s.nc")
    t = np.linspace(0.0, 5000.0, 500_001)
    propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), t, rtol=1e-6, on_chunk=w.append, chunk=4096)
    assert w.tmp.stat().st_size > 20e6  # was: 16 kB until close (all of it in the cache)
    w.abort()
    assert not _temps(tmp_path)


def test_scipy_methods_stream(tmp_path):
    n = 200_001
    sc = scenario.loads(_scenario_text(stop=200.0, step=0.001))
    warm = scenario.loads(_scenario_text(stop=10.0, step=0.001))  # imports and compiles first
    warm.run_to_file(tmp_path / "w.nc", method="scipy:RK45", rtol=1e-6)
    tracemalloc.start()
    try:
        sc.run_to_file(tmp_path / "s.nc", method="scipy:RK45", rtol=1e-6)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # in memory the samples alone take 200 001 x 8 x 8 B = 12.8 MB (was 677 MB at 1e6)
    assert peak < 6e6, f"peak {peak / 1e6:.1f} MB"
    back = io.read(tmp_path / "s.nc")
    assert back.sizes["time"] == n
    ref = sc.run(method="scipy:RK45", rtol=1e-6)
    np.testing.assert_array_equal(back.q.values, ref.q.values)


def test_non_streamed_formulations_refuse_huge_outputs():
    # the Euler-equation formulation is computed in memory, then handed out in chunks
    with pytest.raises(AttitudeValueError, match="formulation"):
        propagate(
            I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 1e3, 3_000_001),
            formulation="euler_equations", on_chunk=lambda ds: None,
        )  # fmt: skip


def test_ensemble_accepts_the_Q0_quantity_that_propagate_accepts():
    # was: propagate_ensemble refused Q0 in kg m2/s that propagate takes (an AttitudeTypeError)
    from astropy import units as u

    body = attitude.RigidBody([0.02, 0.03, 0.04], units="kg m2")
    Q0 = np.array([0.0, 2e-3, 1e-3, 3e-3])
    t = [0.0, 5.0, 10.0]
    plain = attitude.propagate_ensemble(body, np.tile(Q_UNIT, (2, 1)), Q0, t)
    qty = attitude.propagate_ensemble(body, np.tile(Q_UNIT, (2, 1)), Q0 * u.Unit("kg m2 / s"), t)
    g_cm = attitude.propagate_ensemble(
        body, np.tile(Q_UNIT, (2, 1)), Q0 * 1e7 * u.Unit("g cm2 / s"), t
    )
    assert np.array_equal(plain.q.values, qty.q.values)
    np.testing.assert_allclose(g_cm.q.values, plain.q.values, rtol=0, atol=1e-14)
    single = propagate(body, Q_UNIT, Q0 * u.Unit("kg m2 / s"), t)
    assert np.array_equal(single.q.values, qty.q.values[0])
    with pytest.raises(AttitudeTypeError, match="Q0"):  # a dimensionless body: no units
        attitude.propagate_ensemble(I_PAPER, np.tile(Q_UNIT, (2, 1)), Q0 * u.Unit("kg m2 / s"), t)


def test_an_error_after_a_swallowed_interrupt_is_reported_as_the_interrupt(monkeypatch, capsys):
    # was (interruption fuzzing, Ctrl-C while numba compiled): "Exception ignored on calling
    # ctypes callback function" with a KeyboardInterrupt traceback, then "attitude: failed:
    # RuntimeError: no compiled object yet for <Library 'frame_loop'>", then the interrupt
    import attitude.cli as cli
    from attitude import _interrupt

    class Unraisable:  # what Python hands sys.unraisablehook for a swallowed exception
        exc_type = KeyboardInterrupt
        exc_value = KeyboardInterrupt()
        exc_traceback = None
        err_msg = "Exception ignored on calling ctypes callback function"
        object = None

    def compiling(args):
        _interrupt.request()  # the handler records the signal, then raises in the callback
        sys.unraisablehook(Unraisable)
        raise RuntimeError("no compiled object yet for <Library 'frame_loop'>")

    monkeypatch.setattr(cli, "cmd_info", compiling)
    hook = sys.unraisablehook
    assert main(["info", "whatever.nc"]) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err
    assert "RuntimeError" not in err and "Traceback" not in err and "ignored" not in err
    assert sys.unraisablehook is hook  # restored after the command


# ------------------------------------------------------------------------------------------------
# issue 23: runs that can never hang
# ------------------------------------------------------------------------------------------------

_NONFINITE = ROOT / "tests" / "_nonfinite.py"
#: Seconds a child may take (an integrator's cases take 1-3 s with the numba cache warm;
#: compiling its entry points in a cold cache up to a minute).
HANG_DEADLINE = 600.0


def _run_cases(integrators: tuple[str, ...]) -> dict[str, dict[str, str]]:
    """The outcomes of ``tests/_nonfinite.py integrator...`` by integrator and case, killed at
    HANG_DEADLINE: a case that does not return fails the test, naming the integrator and the
    case (it does not hang the suite)."""
    proc = subprocess.Popen(
        [sys.executable, str(_NONFINITE), *integrators], env=ENV, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        out, err = proc.communicate(timeout=HANG_DEADLINE)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        started = [json.loads(ln) for ln in out.splitlines() if ln.startswith("{")]
        last = [(d["integrator"], d["start"]) for d in started if "start" in d][-1:]
        pytest.fail(f"{last or '(setup)'}: still running after {HANG_DEADLINE:g} s")
    assert proc.returncode == 0, err[-2000:]
    rows = [json.loads(ln) for ln in out.splitlines() if ln.startswith("{")]
    outcomes: dict[str, dict[str, str]] = {}
    for d in rows:
        if "case" in d:
            outcomes.setdefault(d["integrator"], {})[d["case"]] = d["outcome"]
    return outcomes


# The integrators in three child processes (an import each, not one per integrator).
_NONFINITE_GROUPS = {
    "compiled": ("dop853", "taylor", "exact", "splitting", "nosquish", "euler_angles", "schwab",
                 "euler_equations", "dop853 events", "splitting events"),
    "scipy": ("scipy:DOP853", "scipy:RK23", "scipy:Radau", "scipy:BDF", "scipy:LSODA"),
    "ensemble": ("ensemble dop853", "ensemble taylor", "ensemble events"),
}  # fmt: skip


@pytest.mark.parametrize("group", sorted(_NONFINITE_GROUPS))
def test_nonfinite_inputs_end_cleanly(group):
    # was: the DOP853 rejection loop spun forever on the NaN step size of a non-finite first
    # derivative (|Q0| = 1e160, drag below the surface; ensembles too), ignoring Ctrl-C and
    # SIGTERM; scipy's RK loops likewise, LSODA repeated steps of size 0, Radau raised a raw
    # ValueError; the splittings ran on a NaN state to the next output time.
    integrators = _NONFINITE_GROUPS[group]
    results = _run_cases(integrators)
    assert set(results) == set(integrators), "an integrator ran no case"
    for integrator, outcomes in results.items():
        for case, outcome in outcomes.items():
            if case.startswith("kernel:"):
                # the compiled loop called directly: NONFINITE (1) on a NaN or inf anywhere; a
                # finite state of 1e160 may also run (propagate refuses it before any work)
                allowed = {"status 1"} | ({"status 0"} if "overflows" in case else set())
            elif case in ("nan momenta", "inf attitude", "energy overflows"):
                allowed = {"refused"}
            elif integrator.startswith("ensemble"):
                allowed = {"failed"}  # the bad members fail, the others finish
            else:
                allowed = {"refused", "failed", "ok"}  # never NaN results, never a raw error
            assert outcome in allowed, (integrator, case, outcome)


def test_drag_below_the_surface_is_refused_before_any_work():
    # was: the paper's orbit (perigee 778 km inside the Earth) with drag: NRLMSIS gives 0
    # there, log(0) a raw numpy warning, NaN tables, and the run never returned
    o = KeplerOrbit(7000.0, 0.2, 0.5236, 0.7854, 0.2618, epoch="2000-01-01T11:58:55.816")
    body = attitude.RigidBody([4e8, 5e8, 6e8], units="kg m2")
    drag = attitude.AerodynamicDrag(o, attitude.box_wing([1.0, 1.0, 2.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(AttitudeValueError, match=r"orbit: .*below the Earth's surface"):
            propagate(body, Q_UNIT, [0, 8e5, 0, 0], [0.0, 600.0], potential=drag)
        with pytest.raises(AttitudeValueError, match="below the Earth's surface"):
            attitude.propagate_ensemble(
                body, np.tile(Q_UNIT, (2, 1)), [0, 8e5, 0, 0], [0.0, 600.0], potential=drag
            )


def test_drag_scenario_below_the_surface_exits_2(tmp_path, capsys):
    # the case: the shipped scenario with drag added, one facet
    text = (SCEN / "paper_keplerian.toml").read_text()
    old = 'kind = "gravity_gradient"'
    assert old in text
    text = text.replace(old, 'models = ["gravity_gradient", "aerodynamic_drag"]')
    text += (
        '\n[[spacecraft.facets]]\narea = 1.0\narea_unit = "m2"\nnormal = [1.0, 0.0, 0.0]\n'
        'center = [0.1, 0.0, 0.0]\ncenter_unit = "m"\n'
    )
    p = tmp_path / "s.toml"
    p.write_text(text)
    assert main(["run", str(p), "-o", str(tmp_path / "s.nc"), "-q"]) == 2
    assert "below the Earth's surface" in capsys.readouterr().err


def test_splitting_events_and_taylor_ensembles_return_at_their_step_budget(monkeypatch):
    # was: the splittings with events ran their whole span in one compiled call, the Taylor
    # ensemble a chunk's members to their ends (58 s uninterruptible for 2 fast members)
    from attitude import splitting as _sp
    from attitude.ensemble import _chunks
    from attitude.events import RateExceeds

    t = np.linspace(0.0, 20.0, 3)
    Q0 = _Q([0.3, 2.0, 0.1])
    pot = HeavyTop(0.5, [0.0, 0.0, 1.0])
    dense = propagate(I_PAPER, Q_UNIT, Q0, np.linspace(0.0, 20.0, 401), potential=pot)
    w = np.linalg.norm(dense.omega.values, axis=-1)
    ev = RateExceeds(0.5 * (w.min() + w.max()), direction="both")
    kw = dict(potential=pot, method="splitting", dt=0.01, events=[ev])
    ref = propagate(I_PAPER, Q_UNIT, Q0, t, **kw)
    q0s = np.tile(Q_UNIT, (9, 1))
    Q0s = Q0 * np.linspace(1.0, 1.5, 9)[:, None]
    ens = attitude.propagate_ensemble(I_PAPER, q0s, Q0s, t, pot, method="taylor")
    checks = []
    assert _sp._interrupt is _chunks._interrupt  # (Ctrl-C is checked between compiled calls)
    monkeypatch.setattr(_sp._interrupt, "check", lambda: checks.append(1))
    monkeypatch.setattr(_methods, "STEP_BUDGET", 50)
    monkeypatch.setattr(_chunks, "ENSEMBLE_STEP_BUDGET", 8)
    monkeypatch.setattr(_chunks, "MIN_MEMBER_BUDGET", 2)
    got = propagate(I_PAPER, Q_UNIT, Q0, t, **kw)
    assert len(checks) >= 2000 // 50  # 2000 steps
    assert np.array_equal(got.q.values, ref.q.values)
    assert np.array_equal(got.event_time.values, ref.event_time.values)
    assert got.event_time.size >= 2
    checks.clear()
    ens2 = attitude.propagate_ensemble(I_PAPER, q0s, Q0s, t, pot, method="taylor")
    # ~1000 member steps in batches of 4 lanes, a few batch steps a call
    assert int(ens.member_n_steps.values.sum()) > 1000
    assert len(checks) >= 1000 // (4 * 8)
    for v in ("q", "Q", "member_n_steps", "member_status"):
        assert np.array_equal(ens[v].values, ens2[v].values), v


def _mapped(pid: int, name: str) -> bool:
    try:
        return name in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc")
@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("form", ["python -m attitude", "console script"])
def test_a_signal_while_the_command_imports_exits_130(tmp_path, sig, form):
    # was: 21 of 120 signals sent in the first seconds of `attitude run` arrived during the
    # package's imports (~0.7 s): a KeyboardInterrupt traceback and death by the signal
    script = Path(sys.executable).parent / "attitude"
    if form == "console script" and not script.exists():
        pytest.skip("the console script is not installed beside this interpreter")
    cmd = [sys.executable, "-m", "attitude"] if form != "console script" else [str(script)]
    proc = subprocess.Popen(
        [*cmd, "run", str(SCEN / "paper_torque_free.toml"), "-o", str(tmp_path / "o.nc"), "-q"],
        env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    deadline = time.monotonic() + 60.0
    # numpy is first loaded by the package's imports, after the command's early handlers
    while not _mapped(proc.pid, "_multiarray_umath") and proc.poll() is None:
        assert time.monotonic() < deadline, "the command did not start importing"
        time.sleep(0.001)
    proc.send_signal(getattr(signal, sig))
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, err[-1000:])
    assert "Traceback" not in err
    assert "interrupted" in err
    assert not (tmp_path / "o.nc").exists() and not _temps(tmp_path)


# ------------------------------------------------------------------------------------------------
# issue 23: raw exceptions and warnings, silent NaN, nonsense accepted, unclear errors
# ------------------------------------------------------------------------------------------------

EPOCH_2024 = "2024-03-01T00:00:00"
TLE_L1 = "1 28057U 03049A   06177.78615833  .00000060  00000-0  35940-4 0  1836"
TLE_L2 = "2 28057  98.4283 247.6961 0000884  88.1964 271.9322 14.35478080140550"


def _leo():
    from orbit import SecularJ2Orbit

    return SecularJ2Orbit(7000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch=EPOCH_2024)


def _paper_orbit(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # its perigee is inside the Earth (the paper's case)
        return KeplerOrbit(7000.0, 0.2, 0.5236, 0.7854, 0.2618, **kw)


def _raw_cases():
    from astropy import units as u

    from attitude import events, frames
    from orbit import EphemerisOrbit

    sbody = attitude.RigidBody([0.02, 0.03, 0.04], units="kg m2")
    return {
        "from_oem(5)": (lambda: EphemerisOrbit.from_oem(5), OrbitTypeError, "path"),
        "from_oem(bytes)": (lambda: EphemerisOrbit.from_oem(b"x.oem"), OrbitValueError, "path"),
        "from_oem(300 chars)": (
            lambda: EphemerisOrbit.from_oem("x" * 300),
            OrbitValueError,
            "path: cannot read",
        ),
        "environment table over 1e12 s": (
            lambda: propagate(
                sbody,
                Q_UNIT,
                [0.0] * 4,
                [0.0, 1e12],
                potential=attitude.MagneticDipole(_leo(), [0.0, 0.0, 0.05], field="dipole"),
            ),
            AttitudeValueError,
            r"^t: .* every 30 s",
        ),
        "target at 2**63 s": (
            lambda: frames.target(_paper_orbit(epoch=EPOCH_2024), 0.7, 0.2).quaternion(
                [2**63 - 1] * 3
            ),
            AttitudeValueError,
            "^t:",
        ),
        "target over 9.2e18 s": (
            lambda: frames.target(_leo(), 0.7, 0.2).quaternion([0.0, 9.2e18]),
            AttitudeValueError,
            "^t:",
        ),
        "sun frame over 1e10 s": (
            lambda: (
                frames.sun_pointing(_paper_orbit(epoch=EPOCH_2024, e=0.01)).quaternion([0.0, 1e10])
                if False
                else frames.sun_pointing(_leo()).quaternion([0.0, 1e10])
            ),
            (AttitudeValueError, OrbitValueError),
            "^t: .*dates are accepted from 1900",
        ),
        "AngleToSun on an orbit without epoch": (
            lambda: events.AngleToSun("+z", 0.5, orbit=_paper_orbit()),
            AttitudeValueError,
            "orbit: .*epoch",
        ),
        "box_wing(wing_back=3 kg)": (
            lambda: attitude.box_wing([1.0, 1.0, 2.0], wing_back=3 * u.kg),
            AttitudeTypeError,
            "wing_back",
        ),
    }


@pytest.mark.parametrize(
    "case",
    [
        "from_oem(5)", "from_oem(bytes)", "from_oem(300 chars)", "environment table over 1e12 s",
        "target at 2**63 s", "target over 9.2e18 s", "sun frame over 1e10 s",
        "AngleToSun on an orbit without epoch", "box_wing(wing_back=3 kg)",
    ],
)  # fmt: skip
def test_raw_exceptions_are_the_package_errors(case):
    # was: TypeError/OSError (pathlib), MemoryError (248 GiB, 109 PiB), ErfaError,
    # AttributeError (sun_table), astropy TypeError
    f, exc, match = _raw_cases()[case]
    with pytest.raises(exc, match=match):
        f()


def test_ensemble_paths_as_bytes_and_devices(tmp_path, monkeypatch):
    from attitude.ensemble import _chunks

    q0s, Q0 = np.tile(Q_UNIT, (3, 1)), _Q([0.3, 0.2, 0.1])
    # bytes, as io.write takes them (was: a raw TypeError from pathlib)
    ds = attitude.propagate_ensemble(
        I_PAPER, q0s, Q0, [0.0, 1.0], path=os.fsencode(tmp_path / "e.nc")
    )
    assert ds.sizes["member"] == 3 and (tmp_path / "e.nc").exists()
    ds.close()

    def no_work(*a, **k):
        raise AssertionError("the ensemble ran")

    monkeypatch.setattr(_chunks, "_compute_chunk", no_work)
    # was: the whole ensemble ran, then reading /dev/null back failed
    with pytest.raises(AttitudeFileError, match=r"pipe or a device"):
        attitude.propagate_ensemble(I_PAPER, q0s, Q0, [0.0, 1.0], path="/dev/null")


def test_corrupt_hdf5_attribute_exits_2(tmp_path, small_ds, capsys):
    # was: "attitude: failed: AttributeError: NetCDF: Can't open HDF5 attribute", exit 1
    p = tmp_path / "c.nc"
    io.write(small_ds, p)
    raw = bytearray(p.read_bytes())
    i = raw.find(b"n_steps\x00")  # an attribute of every method's run (taylor has no n_rejected)
    assert i > 0
    raw[i : i + 8] = b"\xff" * 8
    p.write_bytes(bytes(raw))
    with pytest.raises(AttitudeFileError):
        io.read(p)
    for cmd in (
        ["info", str(p)],
        ["plot", str(p), "-o", str(tmp_path / "c.png")],
        ["export", str(p), "--ccsds-aem", str(tmp_path / "c.aem"), "--epoch", EPOCH_2024,
         "--time-unit-seconds", "1"],
    ):  # fmt: skip
        assert main(cmd) == 2, cmd
        err = capsys.readouterr().err
        assert err.startswith("attitude: error:") and "AttributeError" not in err, err
    assert not (tmp_path / "c.aem").exists() and not (tmp_path / "c.png").exists()


@pytest.mark.parametrize("year", [1950, 2040])
def test_no_raw_erfa_or_astropy_warnings(year, tmp_path):
    # was: "ERFA function ... dubious year", "Tried to get polar motions for times after IERS
    # data is valid" (astropy) reached the user; the package's IERSRangeWarning says it once
    from astropy.utils.exceptions import AstropyWarning
    from erfa import ErfaWarning

    from attitude import aem, frames
    from orbit import SecularJ2Orbit

    o = SecularJ2Orbit(7000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch=f"{year}-03-01T00:00:00")
    body = attitude.RigidBody([0.02, 0.03, 0.04], units="kg m2")
    box = attitude.box_wing([0.1, 0.1, 0.3])
    t = np.linspace(0.0, 600.0, 11)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ErfaWarning)
        warnings.simplefilter("error", AstropyWarning)
        warnings.simplefilter("error", RuntimeWarning)
        warnings.simplefilter("ignore", UserWarning)  # IERSRangeWarning: the package's own
        frames.target(o, 0.7, 0.2).quaternion(t)
        frames.sun_pointing(o).quaternion(t)
        pot = attitude.GravityGradient(o) + attitude.SolarRadiation(o, box)
        ds = propagate(body, Q_UNIT, [0.0, 1e-4, 0.0, 0.0], t, potential=pot)
        aem.read(aem.write_aem(ds, tmp_path / "a.aem"))
        io.read(io.write(ds, tmp_path / "a.nc"))


def test_invalid_leap_seconds_and_dates_are_refused():
    from orbit.timescales import as_epoch

    with pytest.raises(OrbitValueError, match=r"no leap second|this day had none"):
        as_epoch("2017-06-30T23:59:60")  # was: accepted, with ERFA's "time is after end of day"
    assert as_epoch("2016-12-31T23:59:60").utc.isot.startswith("2016-12-31T23:59:60")
    with pytest.raises(OrbitValueError, match=r"1900-01-01 to 2200-01-01"):
        as_epoch("2300-01-01T00:00:00")


def test_silent_nan_results_are_refused(tmp_path):
    from attitude import aem, frames
    from orbit import SecularJ2Orbit

    # was: NaN positions for j2 = 2**63 - 1
    with pytest.raises(OrbitValueError, match=r"^j2:"):
        SecularJ2Orbit(7078.0, 0.001, 1.7, 0.5, 0.0, j2=2**63 - 1)
    # was: a NaN row at t = -1e308
    with pytest.raises(AttitudeValueError, match=r"^t: the mean anomaly"):
        frames.nadir(_paper_orbit()).quaternion([-1e308, 0.0])
    # was: energy inf at every sample of method="exact"
    with pytest.raises(AttitudeValueError, match=r"^Q0: .*overflow"):
        propagate(I_PAPER, Q_UNIT, [0.0, 1e200, 0.0, 0.0], [0.0, 1.0], method="exact")
    # was: aem.read returned nan, inf, 1e999 from the data lines
    ds = propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 1.0, 5))
    good = aem.write_aem(ds, tmp_path / "g.aem", epoch=EPOCH_2024, time_unit_seconds=1.0)
    text = good.read_text()
    row = next(ln for ln in text.splitlines() if ln.startswith("2024-03-01T00:00:00.500"))
    for bad in ("nan", "inf", "-inf", "1e999"):
        p = tmp_path / f"{bad}.aem"
        fields = row.split()
        p.write_text(text.replace(row, " ".join([fields[0], bad, *fields[2:]])))
        with pytest.raises(AttitudeValueError, match=r"data line 3, value 1 is not a finite"):
            aem.read(p)


def test_splitting_energy_overflow_is_a_failure_not_inf():
    # a finite state whose energy overflows (a 1e300 heavy top drives |Q| past 1e154)
    with pytest.raises(PropagationError, match=r"overflowed double precision") as err:
        propagate(
            I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), [0.0, 0.5, 1.0],
            potential=HeavyTop(1e300, [1.0, 0.0, 1.0]), method="splitting", dt=0.01,
        )  # fmt: skip
    part = err.value.partial
    assert np.isfinite(part.energy.values).all() and part.sizes["time"] >= 1


def _aem_text(tmp_path) -> str:
    from attitude import aem

    ds = propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 1.0, 5))
    return aem.write_aem(
        ds, tmp_path / "g.aem", epoch=EPOCH_2024, time_unit_seconds=1.0
    ).read_text()


@pytest.mark.parametrize(
    "old, new, match",
    [
        ("START_TIME           = 2024-03-01T00:00:00.000000", "START_TIME = garbage",
         "START_TIME = 'garbage' is not a CCSDS epoch"),
        ("START_TIME           = 2024-03-01T00:00:00.000000", "START_TIME = 1800-01-01T00:00:00",
         "START_TIME = 1800-01-01T00:00:00 is .* s from the first data epoch"),
        ("STOP_TIME            = 2024-03-01T00:00:01.000000", "STOP_TIME = 2024-03-01T09:00:00",
         "STOP_TIME .* from the last data epoch"),
        ("ATTITUDE_TYPE        = QUATERNION", "ATTITUDE_TYPE = QUATERNION\nQUATERNION_TYPE = FIRST",
         "QUATERNION_TYPE is a version 1 keyword"),
    ],
)  # fmt: skip
def test_aem_read_refuses_inconsistent_metadata(tmp_path, old, new, match):
    from attitude import aem

    text = _aem_text(tmp_path)
    assert old in text
    p = tmp_path / "b.aem"
    p.write_text(text.replace(old, new))
    with pytest.raises(AttitudeValueError, match=match):
        aem.read(p)  # was: read without a word


@pytest.mark.parametrize("key", ["object_name", "object_id", "originator", "ref_frame_b"])
def test_write_aem_refuses_control_characters(tmp_path, small_ds, key):
    from attitude import aem

    # was: a malformed file (its own reader then refused it)
    with pytest.raises(AttitudeValueError, match=rf"^{key}: .*control character"):
        aem.write_aem(
            small_ds, tmp_path / "c.aem", epoch=EPOCH_2024, time_unit_seconds=1.0,
            **{key: "SAT\nMETA_STOP\nX = 1"},
        )  # fmt: skip
    assert not list(tmp_path.iterdir())


def test_nonsense_arguments_are_refused(tmp_path, small_ds):
    from astropy import units as u

    from attitude import frames
    from orbit import SecularJ2Orbit

    with pytest.raises(AttitudeValueError, match=r"^rtol: 10 is not a relative tolerance"):
        propagate(I_PAPER, Q_UNIT, _Q([0.3, 0.2, 0.1]), [0.0, 1.0], rtol=10)
    with pytest.raises(AttitudeValueError, match=r"^rtol:"):
        attitude.propagate_ensemble(
            I_PAPER, np.tile(Q_UNIT, (2, 1)), _Q([0.3, 0.2, 0.1]), [0.0, 1.0], rtol=10
        )
    with pytest.raises(OrbitTypeError, match=r"^radius: expected real numbers"):
        SecularJ2Orbit(7078.0, 0.001, 1.7, 0.5, 0.0, radius=np.datetime64("2020-01-01"))
    p = io.write(small_ds, tmp_path / "s.nc")
    with pytest.raises(AttitudeTypeError, match=r"^load: expected True or False"):
        io.read(p, load="no")
    with pytest.raises(AttitudeValueError, match=r"^height:"):
        frames.target(_leo(), 0.7, 0.2, height=-7000 * u.km)


def test_tle_age_warns_and_absurd_spans_are_refused():
    from orbit import EphemerisOrbit
    from orbit.errors import TLEAgeWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        EphemerisOrbit.from_tle(TLE_L1, TLE_L2, "2006-06-27T00:00:00", "2006-06-27T01:00:00")
    # was: exit 0 and no word, decades from the element set's epoch
    with pytest.warns(TLEAgeWarning, match=r"365.3 days from the element set's epoch"):
        EphemerisOrbit.from_tle(TLE_L1, TLE_L2, "2007-06-27T00:00:00", "2007-06-27T01:00:00")
    with pytest.raises(OrbitValueError, match=r"^start: .*before 1957-10-04"):
        EphemerisOrbit.from_tle(TLE_L1, TLE_L2, "1950-01-01T00:00:00", "1950-01-01T01:00:00")


def test_a_shifted_tle_field_is_named():
    from orbit import EphemerisOrbit

    # one blank added before the inclination, one taken out after it: the checksum holds
    shifted = TLE_L2[:8] + " " + TLE_L2[8:16] + TLE_L2[17:]
    assert len(shifted) == 69 and shifted != TLE_L2
    # was: "orbit.tle: r: must be finite" (SGP4's output)
    with pytest.raises(OrbitValueError, match=r"^line2: the inclination \(columns 9-16\)"):
        EphemerisOrbit.from_tle(TLE_L1, shifted, "2006-06-27T00:00:00", "2006-06-27T01:00:00")


def test_scenario_event_keys_of_another_type_are_errors():
    text = _scenario_text() + (
        '\n[events.e1]\ntype = "rate_exceeds"\nrate = 0.5\nshadow = "umbra"\n'
    )
    # was: ignored (docs/scenarios.md says they are errors); eclipse_entry with direction too
    with pytest.raises(scenario.ScenarioError, match=r"^events\.e1\.shadow: a rate_exceeds"):
        scenario.loads(text)


def test_scenario_errors_name_the_table():
    text = _scenario_text().replace("inertia = [1.25, 1.0, 0.75]", "inertia = [1.0, 1.0, 5.0]")
    # was: "inertia: violates the triangle inequality"
    with pytest.raises(scenario.ScenarioError, match=r"^body\.inertia: violates"):
        scenario.loads(text)
    text = (
        _scenario_text()
        + '\n[potential]\nkind = "heavy_top"\nweight = -1.0\ncenter_of_mass = [0.0, 0.0, 1.0]\n'
    )
    with pytest.raises(scenario.ScenarioError, match=r"^potential\.weight:"):
        scenario.loads(text)


def test_disk_filling_during_a_streamed_write_says_so(tmp_path, capsys):
    # 50001 samples: 8.8 MB raw, 5.1 MB written; a 3 MB file system passes the up-front check
    # (a quarter of the raw size) and fills during the write
    mnt = tmp_path / "fill"
    if not _mount_tmpfs(mnt, "size=3m"):
        pytest.skip("needs root and tmpfs to make a small file system")
    try:
        (tmp_path / "s.toml").write_text(_scenario_text(stop=500.0, step=0.01))
        assert main(["run", str(tmp_path / "s.toml"), "-o", str(mnt / "s.nc"), "-q"]) == 2
        err = capsys.readouterr().err
        # was: "writing failed: RuntimeError: NetCDF: HDF error" (the free space was measured
        # after the temporary file had been removed)
        assert "the disk is full" in err, err
        assert list(mnt.iterdir()) == []
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


def test_ensemble_to_a_read_only_file_system_says_so(read_only_dir):
    # was: "has 1.05 MB free; needs about 6.79 MB"
    with pytest.raises(AttitudeFileError, match=r"read-only|permission"):
        attitude.propagate_ensemble(
            I_PAPER, np.tile(Q_UNIT, (2000, 1)), _Q([0.3, 0.2, 0.1]), np.linspace(0.0, 1.0, 101),
            path=read_only_dir / "e.nc",
        )  # fmt: skip

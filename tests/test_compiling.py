"""attitude/_compiling.py: the compile helper of a first closed-loop run.

While a closed-loop driver compiles, a second process compiles the flight software's kernels
and the diagnostics into the disk cache; the run waits for what it has not finished and loads
it. Truth: numba's compile events in fresh processes (what each one compiled), the types numba
compiled the driver for (what the helper must compile for), and the process table (a helper
never outlives its run).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from compile_events import LISTEN
from numba.core import types

import attitude
from attitude import _compiling, scenario
from orbit._shared_jit import JIT_DISABLED

ROOT = Path(__file__).resolve().parent.parent

pytestmark = pytest.mark.skipif(JIT_DISABLED, reason="kernels not compiled")

_LISTEN = LISTEN + textwrap.dedent(
    """
    import sys
    from numba.core import types
    from attitude import _compiling
    from orbit import _kepler_equation as ke
    from orbit._shared_jit import will_compile
    """
)
# Two kernels of orbit._kepler_equation: one as Python calls it, one as kernels call it.
_ITEMS = """[("orbit._kepler_equation", "reduce_angle", (types.float64,), True),
           ("orbit._kepler_equation", "_two_sum", (types.float64, types.float64), False)]"""


def _env(tmp: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT), ATTITUDE_CACHE_DIR=str(tmp / "cache"))
    env.pop(_compiling.HELPER_ENV, None)
    return env


def test_what_the_helper_compiled_is_loaded_not_compiled(tmp_path):
    script = _LISTEN + textwrap.dedent(
        f"""
        proc = _compiling.helper({_ITEMS})
        assert proc.wait(timeout=300) == 0
        print(will_compile(ke.reduce_angle), will_compile(ke._two_sum.dispatcher))
        ke.reduce_angle(7.0)
        print(sorted(compiled))
        """
    )
    r = subprocess.run([sys.executable, "-c", script], env=_env(tmp_path), capture_output=True,
                       text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert r.stdout.split("\n")[:2] == ["False False", "[]"]


def test_a_helper_ends_with_its_run_even_killed(tmp_path):
    """A run killed while its helper works: the helper ends too (it reads the pipe the run held
    open). Here the helper is held on a kernel's lock by a third process, which keeps it until
    the test ends: only the pipe can end the helper in time (else it would wait up to 900 s)."""
    locker = textwrap.dedent(
        """
        import sys
        from orbit import _kepler_equation as ke
        from orbit._shared_jit import _compile_lock
        with _compile_lock(ke.reduce_angle):
            print("locked", flush=True)
            sys.stdin.readline()
        """
    )
    script = _LISTEN + textwrap.dedent(
        """
        import time
        proc = _compiling.helper([("orbit._kepler_equation", "reduce_angle", (types.float64,),
                                   True)])
        print(proc.pid, flush=True)
        time.sleep(600)
        """
    )
    kw = dict(env=_env(tmp_path), stdout=subprocess.PIPE, text=True)
    hold = subprocess.Popen([sys.executable, "-c", locker], stdin=subprocess.PIPE, **kw)
    run = None
    try:
        assert hold.stdout.readline().strip() == "locked"
        run = subprocess.Popen([sys.executable, "-c", script], **kw)
        pid = int(run.stdout.readline())
        time.sleep(2.0)  # (the helper imports the package and waits for the lock)
        assert _alive(pid)
        run.send_signal(signal.SIGKILL)
        run.wait()
        deadline = time.monotonic() + 10.0
        while _alive(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(pid)
    finally:
        for p in (run, hold):
            if p is not None and p.poll() is None:
                p.kill()


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")  # (a zombie has ended; init reaps it)


def test_off_by_the_environment_on_one_cpu_without_locks_or_a_disk_cache(monkeypatch):
    import numba

    import orbit._shared_jit as sj

    items = [("orbit._kepler_equation", "reduce_angle", (types.float64,), True)]
    monkeypatch.setenv(_compiling.HELPER_ENV, "0")
    assert _compiling.helper(items) is None
    monkeypatch.delenv(_compiling.HELPER_ENV)
    with monkeypatch.context() as m:
        m.setattr(_compiling, "_cpus", lambda: 1)
        assert _compiling.helper(items) is None
    with monkeypatch.context() as m:  # (Windows: the two processes could not wait for each other)
        m.setattr(sj, "fcntl", None)
        assert _compiling.helper(items) is None
    # a kernel without a disk cache will compile, but what a helper compiled would not reach it
    uncached = numba.njit(lambda x: x)
    items = [("m", "f", (types.float64,), True)]
    assert _compiling.open_loop_helper(uncached, lambda: items) is None


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_the_helper_compiles_for_the_types_the_run_compiles_for(monkeypatch, method):
    """The helper's items of a closed-loop run are the types numba compiled (or loaded) the
    run's driver and diagnostics for: the boundary's P and ctl are the driver's arguments, its
    state a row of the driver's C-ordered work array; the diagnostics' signatures are theirs."""
    seen = []

    def record(driver, P, ctl, after=list, software=True):
        assert software == (method == "dop853")  # (the Taylor driver: the diagnostics alone)
        seen.append((driver, _compiling.closed_loop_items(P, ctl, after())))

    monkeypatch.setattr(_compiling, "closed_loop_helper", record)
    sc = scenario.load(ROOT / "scenarios" / "rw_inertial_pointing.toml")
    attitude.propagate(sc.spacecraft, sc.q0, sc.Q0, np.linspace(0.0, 0.5, 6),
                       software=sc.software, method=method)  # fmt: skip
    ((driver, items),) = seen
    (module, name, sig, from_python), *after = items
    assert (module, name, from_python) == ("attitude._core.fsw", "fsw_boundary", False)
    (args,) = driver.signatures
    assert sig[0] == args[0] and sig[4] == args[13]  # P, ctl
    assert args[5] == types.Array(types.float64, 2, "C")  # work: its rows are sig[1]
    assert sig[1] == types.Array(types.float64, 1, "C") and sig[2:4] == (types.float64,) * 2
    assert [n for _, n, _, _ in after] == [
        "spacecraft_diagnostics",
        "term_torques_at_rates",
        "actuator_diagnostics",
    ]
    for module, name, s, from_python in after:
        kernel = getattr(sys.modules[module], name)
        assert from_python and tuple(s) in kernel.signatures, (name, kernel.signatures)


# The README's main job with empty caches, its diagnostics compiled by its helper, then a second
# process that compiles nothing and writes the same file: tests/test_user_kernels.py
# (test_main_job_compiles_nothing_in_a_second_process).


def test_the_open_loop_helper_compiles_for_the_types_the_run_compiles_for(monkeypatch):
    """The main job's item is the signature numba compiled (or loaded) its diagnostics pass
    for, in the module the helper makes again from the arguments that made the run's."""
    seen = []
    monkeypatch.setattr(
        _compiling, "open_loop_helper", lambda kernel, items: seen.append((kernel, items()))
    )
    sc = scenario.load(ROOT / "scenarios" / "paper_keplerian.toml")
    with pytest.warns(UserWarning, match="initial state projected"):  # (as the command says)
        attitude.propagate(sc.body, sc.q0, sc.Q0, np.linspace(0.0, 60.0, 7),
                           potential=sc.potential)  # fmt: skip
    ((kernel, items),) = seen
    ((home, name, sig, from_python),) = items
    assert name == "samples" and from_python
    assert tuple(sig) in kernel.signatures, kernel.signatures
    assert _compiling._kernel(items[0]) is kernel  # (the helper makes its module again)
    assert home[:2] == ("attitude._core.models", "entry_points")


@pytest.mark.slow
def test_a_first_closed_loop_run_leaves_the_software_to_its_helper(tmp_path):
    """Empty caches: the run itself compiles neither the tick's sensors and estimator nor the
    diagnostics (the helper did), and writes the file a run without the helper writes."""
    script = _LISTEN + textwrap.dedent(
        """
        from attitude import cli
        assert cli.main(["run", sys.argv[1], "--stop", "0.5", "-o", sys.argv[2], "-q"]) == 0
        print(sorted(set(compiled)))
        """
    )
    scen = str(ROOT / "scenarios" / "rw_inertial_pointing.toml")
    outs = []
    for helper in ("1", "0"):
        env = dict(_env(tmp_path / helper), **{_compiling.HELPER_ENV: helper})
        out = tmp_path / f"{helper}.nc"
        r = subprocess.run([sys.executable, "-c", script, scen, str(out)], env=env,
                           capture_output=True, text=True, timeout=900)  # fmt: skip
        assert r.returncode == 0, r.stderr
        outs.append((out, r.stdout))
    with_helper, alone = (o for _, o in outs)
    for name in ("sense_and_estimate__kernel", "spacecraft_diagnostics"):
        assert name not in with_helper and name in alone, name
    import xarray as xr

    with xr.open_dataset(outs[0][0]) as a, xr.open_dataset(outs[1][0]) as b:
        xr.testing.assert_identical(a.drop_attrs(), b.drop_attrs())


def test_the_helper_of_a_closed_loop_run_builds_a_numerical_orbit(monkeypatch):
    """An item of a first closed-loop run's helper builds a scenario on a numerical
    orbit with environment models and a seeded sensor (attitude._warmup): what such runs
    compile from Python before their driver (the orbit's own integrator, its tables and frames,
    the environment tables, a sensor's stream; 5.4 s of a first orbit_raising_burn after
    rw_inertial_pointing) is compiled meanwhile."""
    from attitude import _warmup

    _warm = _compiling.NUMERICAL_ORBIT_ITEM[1]
    started = []
    monkeypatch.setattr(_compiling, "helper", lambda items: started.append(list(items)))
    monkeypatch.setattr(_compiling, "helper_on", lambda: True)
    monkeypatch.setattr(_compiling, "will_compile", lambda kernel: True)
    monkeypatch.setattr(_compiling, "_on_disk", lambda kernel: True)
    diagnostics = [("orbit._kepler_equation", "reduce_angle", (types.float64,), True)]
    for software in (True, False):
        _compiling.closed_loop_helper(None, (), (), lambda: diagnostics, software)
    with_software, taylor = started  # (the numerical orbit before the diagnostics if it can)
    assert [x[1] for x in with_software] == ["fsw_boundary", _warm, "reduce_angle"]
    assert taylor == [*diagnostics, _compiling.NUMERICAL_ORBIT_ITEM]
    assert _compiling._kernel(_compiling.NUMERICAL_ORBIT_ITEM) is (
        _warmup.build_numerical_orbit_scenario
    )


@pytest.mark.slow
def test_after_one_closed_loop_run_the_others_compile_nothing(tmp_path):
    """Empty caches, one closed-loop run with its helper; then each other shipped closed-loop
    scenario, a numerical orbit's included, compiles nothing (numba's compile events)."""
    script = _LISTEN + textwrap.dedent(
        """
        from attitude import cli
        assert cli.main(["run", sys.argv[1], "--stop", sys.argv[3], "-o", sys.argv[2], "-q"]) == 0
        print(sorted(set(compiled)))
        """
    )
    env = dict(_env(tmp_path), **{_compiling.HELPER_ENV: "1"})
    runs = [("rw_inertial_pointing", "60s"), ("orbit_raising_burn", "600s"),
            ("cubesat_bdot", "600s"), ("nadir_wheels_dumping", "600s")]  # fmt: skip
    for k, (name, stop) in enumerate(runs):
        scen = str(ROOT / "scenarios" / f"{name}.toml")
        r = subprocess.run([sys.executable, "-c", script, scen, str(tmp_path / f"{name}.nc"), stop],
                           env=env, capture_output=True, text=True, timeout=900)  # fmt: skip
        assert r.returncode == 0, r.stderr
        if k:
            assert r.stdout.strip().splitlines()[-1] == "[]", (name, r.stdout)

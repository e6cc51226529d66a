"""The first closed-loop run says that it compiles, and for how long (issue 43); the progress
bar's time left counts from the first chunk of real work, not from before the compilation."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest

from attitude import _compiling
from attitude._compiling import CompileWatch
from attitude.cli import Progress
from attitude.propagate import _ProgressBar

ROOT = Path(__file__).resolve().parent.parent
SCEN = ROOT / "scenarios" / "rw_inertial_pointing.toml"
NOTICE = "attitude: compiling the closed-loop kernels, once (cached afterwards): ~"
DONE = re.compile(r"attitude: compiled the closed-loop kernels in \d+\.\d s")
# (another test worker compiled them meanwhile: this process waited and loaded them)
LOADED = re.compile(
    r"attitude: loaded the closed-loop kernels, compiled by another process meanwhile, "
    r"in \d+\.\d s"
)

_SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    import attitude
    from attitude import cli, scenario

    scen, out, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
    for k in range(runs):  # the command, twice in one process
        assert cli.main(["run", scen, "--stop", "0.5", "-o", f"{out}/r{k}.nc", "-q"]) == 0
        print(f"-- run {k} done", file=sys.stderr, flush=True)
    sc = scenario.load(scen)  # the library with progress=True
    attitude.propagate(
        sc.spacecraft, sc.q0, sc.Q0, np.linspace(0.0, 0.5, 6), software=sc.software,
        method=sc.method, progress=True,
    )
    print("-- library done", file=sys.stderr, flush=True)
    """
)


def _env(cache: Path | None) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if cache is not None:
        env["ATTITUDE_CACHE_DIR"] = str(cache)
    return env


def _run(tmp_path: Path, cache: Path | None, runs: int) -> str:
    r = subprocess.run(
        [sys.executable, "-c", _SCRIPT, str(SCEN), str(tmp_path), str(runs)],
        env=_env(cache), capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return r.stderr


def test_a_fresh_cache_says_it_compiles_before_compiling(tmp_path):
    """An empty cache: the notice comes first, before numba has finished anything (the
    process is stopped there: the whole compilation is the slow test below)."""
    p = subprocess.Popen(
        [sys.executable, "-c", _SCRIPT, str(SCEN), str(tmp_path), "1"],
        env=_env(tmp_path / "cache"), stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        lines = []
        for line in p.stderr:
            lines.append(line)
            if NOTICE in line or len(lines) > 50:
                break
        assert p.poll() is None  # still compiling
    finally:
        p.kill()
        p.wait()
    text = "".join(lines)
    assert text.count(NOTICE) == 1, text
    assert not DONE.search(text) and "-- run 0 done" not in text


def test_a_cached_closed_loop_says_nothing(tmp_path):
    """With the kernels in the cache (compiled by this test's first run if no test did
    before): the second run of the command and the library's run say nothing, nor does a new
    process."""
    err = _run(tmp_path, None, 2)
    first, rest = err.split("-- run 0 done", 1)
    if NOTICE in first:  # a cold cache: compiled here (or loaded), and said how long it took
        assert len(DONE.findall(first)) + len(LOADED.findall(first)) == 1, first
    assert "compil" not in rest, rest
    assert "-- library done" in rest
    err = _run(tmp_path, None, 0)
    assert "compil" not in err and "-- library done" in err, err


@pytest.mark.slow
def test_first_closed_loop_run_says_it_compiles(tmp_path):
    """A fresh cache: the notice once, before the first run's compilation, and the time it
    took; the second run of the command and the library's run in the same process compile
    nothing and say nothing. A new process with the cache on disk says nothing either."""
    cache = tmp_path / "cache"
    err = _run(tmp_path, cache, 2)
    first, rest = err.split("-- run 0 done", 1)
    assert first.count(NOTICE) == 1
    assert len(DONE.findall(first)) == 1
    assert first.index(NOTICE) < DONE.search(first).start()
    assert "compil" not in rest, rest
    assert "-- library done" in rest
    err = _run(tmp_path, cache, 0)  # the cache on disk: loaded, not compiled
    assert "compil" not in err and "-- library done" in err, err


def test_will_compile_reads_the_disk_cache(tmp_path):
    """orbit._shared_jit.will_compile: True before the first call, False after it, and False
    in a new process that finds the function in numba's cache index."""
    (tmp_path / "kern.py").write_text(
        "from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return x + 1.0\n"
    )
    script = textwrap.dedent(
        """
        import sys
        sys.path.insert(0, sys.argv[1])
        from orbit._shared_jit import will_compile
        import kern
        before = will_compile(kern.f)
        kern.f(1.0)
        print(before, will_compile(kern.f))
        """
    )
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(ROOT)
    outs = [
        subprocess.run(
            [sys.executable, "-c", script, str(tmp_path)], env=env, capture_output=True,
            text=True, timeout=300, check=True,
        ).stdout.split()
        for _ in range(2)
    ]  # fmt: skip
    assert outs == [["True", "False"], ["False", "False"]]


def test_estimate_stretches_with_the_load(monkeypatch):
    """numba compiles on one core: 40 s of CPU take 40 s on an idle machine, the load per core
    times longer on a busy one (2 cores at load 5.5: 110 s; measured 122 s)."""
    monkeypatch.setattr(_compiling.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(_compiling.os, "getloadavg", lambda: (5.5, 4.0, 3.0))
    assert _compiling.compile_estimate(40.0) == 110.0
    monkeypatch.setattr(_compiling.os, "getloadavg", lambda: (0.3, 0.2, 0.1))
    assert _compiling.compile_estimate(40.0) == 40.0


class _Report:
    def __init__(self):
        self.calls, self.notes, self.restarts = [], [], 0

    def __call__(self, done, total, t):
        self.calls.append(done)

    def note(self, text):
        self.notes.append(text)

    def restart(self):
        self.restarts += 1


def test_compile_watch_says_how_long_after_the_compilation():
    report = _Report()
    w = CompileWatch(report, "the kernels", 7)
    assert report.notes == ["compiling the kernels, once (cached afterwards): ~7 s"]
    numba.njit(lambda x: x + 1)(1)  # a compilation during the run's first chunk
    w(3, 10, 0.0)  # the report after it: the pace starts again, the time is said later
    assert report.restarts == 1 and len(report.notes) == 1
    w(5, 10, 0.0)  # no compilation since: it is over
    assert re.fullmatch(r"compiled the kernels in \d+\.\d s", report.notes[1])
    w(10, 10, 0.0)
    w.close()
    assert len(report.notes) == 2 and report.restarts == 1 and report.calls == [3, 5, 10]


def test_compile_watch_says_when_another_process_compiled_it():
    """Nothing compiled in this process (it waited for another one's lock files and loaded
    what that one saved): said once, at the first report after what was announced is there,
    and the pace starts again; a run stopped before that (an error, Ctrl-C while waiting)
    says nothing of a load."""
    ready = [False]
    report = _Report()
    w = CompileWatch(report, "the kernels", 7, lambda: ready[0])
    w(1, 10, 0.0)  # (not there yet)
    assert len(report.notes) == 1 and report.restarts == 0
    ready[0] = True
    w(3, 10, 0.0)
    assert re.fullmatch(
        r"loaded the kernels, compiled by another process meanwhile, in \d+\.\d s",
        report.notes[1],
    )
    assert report.restarts == 1
    w(10, 10, 0.0)
    w.close()
    assert len(report.notes) == 2 and report.restarts == 1
    stopped = _Report()
    CompileWatch(stopped, "the kernels", 7, lambda: False).close()
    assert len(stopped.notes) == 1


def test_command_progress_time_left_from_the_first_report():
    """40 s compiling, then 5 samples a second: 18 s left at 10 of 100, not 40 s x 9."""
    clock = iter([0.0, 40.0, 41.0, 42.0, 50.0, 51.0])
    s = io.StringIO()
    p = Progress("always", stream=s, clock=lambda: next(clock))
    p(5, 100, 0.0)  # at 40 s: the first chunk done, no estimate yet
    assert "left" not in s.getvalue()
    p(10, 100, 0.0)  # at 41 s
    assert s.getvalue().endswith("   18 s left")
    p.note("compiling more")
    assert s.getvalue().endswith("\r\x1b[Kattitude: compiling more\n")
    p.restart()
    p(12, 100, 0.0)  # at 42 s: counts again from here
    p(20, 100, 0.0)  # at 50 s: 1 sample a second
    assert s.getvalue().endswith("   80 s left")
    quiet = io.StringIO()
    Progress("never", stream=quiet).note("compiling")
    assert quiet.getvalue() == ""


def test_library_bar_rate_from_the_first_report(monkeypatch):
    now = [100.0]
    bar = _ProgressBar(100)
    monkeypatch.setattr(bar.bar, "_time", lambda: now[0], raising=False)
    bar(5, 100, 0.0)  # at 100 s (after a long compilation): the clock starts here
    assert bar.bar.n == 5 and bar.bar.start_t == 100.0
    now[0] = 110.0
    bar(55, 100, 0.0)  # 5 samples a second since
    assert bar.bar.format_dict["rate"] == pytest.approx(5.0)
    assert "00:09" in str(bar.bar)  # (100 - 55) / 5 s left
    bar.close()

"""The fuzzing campaign of issue 12, kept as hypothesis-driven suites (``pytest -m slow``).

Three suites, each printing its counts (tried / ok / clean error / other) and failing on any
raw exception (anything that is not an ``attitude``/``orbit`` error class, or a CLI exit that is
not a clean one-line error), any silent no-op (exit 0 or a normal return without the result
asked for), and any temporary file left behind:

* :func:`test_fuzz_scenario_files_through_the_cli`: mutated scenario files (and options) run by
  ``attitude run``, the results read back by ``info``/``plot``/``export``;
* :func:`test_fuzz_public_api`: bad arguments to ``propagate``, ``propagate_ensemble``,
  ``RigidBody``, the potentials, ``KeplerOrbit``, ``io.write``/``io.read`` and the AEM export;
* :func:`test_fuzz_interruptions`: ``attitude run`` interrupted by SIGINT, SIGTERM or SIGKILL
  at random moments (exit 130 and no output file, or the previous one untouched; the next run
  removes a killed run's temporary file).

Sizes (the issue's campaign by default) can be set with ``ATTITUDE_FUZZ_SCENARIOS``,
``ATTITUDE_FUZZ_API`` and ``ATTITUDE_FUZZ_INTERRUPTS``; ``ATTITUDE_FUZZ_SEED`` changes the
examples (hypothesis is derandomised otherwise, so a run is reproducible).
"""

from __future__ import annotations

import contextlib
import io as _stdio
import json
import math
import os
import re
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import attitude  # noqa: E402
from attitude import io  # noqa: E402
from attitude.cli import main  # noqa: E402
from attitude.errors import AttitudeError  # noqa: E402
from orbit.errors import OrbitError  # noqa: E402

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
SCEN = ROOT / "scenarios"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
N_SCENARIOS = int(os.environ.get("ATTITUDE_FUZZ_SCENARIOS", "600"))
N_API = int(os.environ.get("ATTITUDE_FUZZ_API", "960"))
N_INTERRUPTS = int(os.environ.get("ATTITUDE_FUZZ_INTERRUPTS", "120"))
N_CLOSED_LOOP_API = int(os.environ.get("ATTITUDE_FUZZ_CLOSED_LOOP_API", "900"))
N_CLOSED_LOOP_SCENARIOS = int(os.environ.get("ATTITUDE_FUZZ_CLOSED_LOOP_SCENARIOS", "400"))
#: A regular expression: only the API targets whose names it finds are fuzzed (all: empty).
ONLY = os.environ.get("ATTITUDE_FUZZ_ONLY", "")
SEED = int(os.environ.get("ATTITUDE_FUZZ_SEED", "0"))
#: Seconds a single fuzzed call may take before it is interrupted (counted as "slow").
TIME_LIMIT = 20.0
_RAW_CLI = re.compile(r"attitude: failed: [A-Za-z_.]*(Error|Exception|Warning|Interrupt)\b")
#: Warnings of the libraries the package calls, printed by the command as they came.
_RAW_WARNING = re.compile(r"ERFA function|Tried to get polar motions|encountered in")


def _settings(n: int):
    conf = settings(
        max_examples=n,
        deadline=None,
        database=None,
        derandomize=SEED == 0,
        suppress_health_check=list(HealthCheck),
        phases=[hypothesis.Phase.generate],  # no shrinking: every example is counted once
    )

    def decorate(f):
        f = conf(f)
        return hypothesis.seed(SEED)(f) if SEED else f

    return decorate


def _temps(*dirs: Path) -> list[Path]:
    out = []
    for d in dirs:
        out += [p for p in Path(d).rglob(".*") if p.name.endswith(".tmp")]
    return out


def _own_temps() -> list[Path]:
    """This process's temporary files in the temp directory (pipes and devices written through)."""
    return list(Path(tempfile.gettempdir()).glob(f".*.attitude-{os.getpid()}.tmp"))


#: Seconds after which a call that has not returned counts as a hang (the calls' own limit,
#: TIME_LIMIT, acts only when the compiled code returns to Python).
HANG_LIMIT = float(os.environ.get("ATTITUDE_FUZZ_HANG_LIMIT", "180"))

_WATCHDOG = """
import os, signal, sys, time
pid, path, limit = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
while True:
    time.sleep(1.0)
    try:
        os.kill(pid, 0)
        t0, _, case = open(path).read().partition("\\n")
        late = bool(case) and time.time() - float(t0) > limit
    except ValueError:
        continue
    except OSError:
        break
    if late:
        sys.stderr.write(f"\\n[fuzz] HANG: still running after {limit:g} s: {case}\\n")
        sys.stderr.flush()
        os.kill(pid, signal.SIGABRT)  # pytest's faulthandler prints where it hangs
        break
"""


class _Watchdog:
    """A child process that ends this one when a call runs past HANG_LIMIT, after printing the
    case (SIGABRT: pytest's faulthandler prints the tracebacks): a hang fails the suite
    instead of stalling it. A Python thread could not: a compiled loop that spins holds the
    GIL, and SIGALRM's handler runs only when it returns."""

    def __init__(self, d: Path):
        self.file = d / "watchdog_case"
        self.file.write_text("")
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _WATCHDOG, str(os.getpid()), str(self.file), str(HANG_LIMIT)]
        )

    @contextlib.contextmanager
    def __call__(self, case: str):
        self.file.write_text(f"{time.time()}\n{case}")
        try:
            yield
        finally:
            self.file.write_text("")

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait()


@contextlib.contextmanager
def _time_limit(seconds: float):
    """Raise KeyboardInterrupt in this thread after ``seconds`` (SIGALRM)."""

    def alarm(signum, frame):
        from attitude import _interrupt

        _interrupt.request(signum)  # as Ctrl-C in the command: not lost if swallowed
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _figures(counts: Counter) -> str:
    """The figures issue 23 asks for (a hang ends the run: reaching here means none)."""
    return (
        f"; raw exceptions {counts['raw exceptions']}, raw warnings {counts['raw warnings']}, "
        f"silent NaN/inf {counts['silent NaN/inf']}, silent no-ops {counts['silent no-ops']}, "
        f"hangs 0 (a call running past {HANG_LIMIT:g} s ends the suite)"
    )


def _report(capsys, title: str, counts: Counter, extra: str = "") -> None:
    with capsys.disabled():
        keys = ", ".join(f"{k} {v}" for k, v in sorted(counts.items()))
        print(f"\n[fuzz] {title}: {keys}{extra}")


# ------------------------------------------------------------------------------------------------
# TOML
# ------------------------------------------------------------------------------------------------


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def _toml(data: dict[str, Any]) -> str:
    top = [
        f"{json.dumps(k)} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)
    ]
    tables = [
        f"[{json.dumps(k)}]\n"
        + "\n".join(f"{json.dumps(kk)} = {_toml_value(vv)}" for kk, vv in v.items())
        for k, v in data.items()
        if isinstance(v, dict)
    ]
    return "\n".join(top) + "\n\n" + "\n\n".join(tables) + "\n"


def _base_scenarios() -> list[dict[str, Any]]:
    """The repository's scenarios, shortened to a few dozen samples (mutations lengthen them)."""
    out = []
    for p in sorted(SCEN.glob("*.toml")):
        d = tomllib.loads(p.read_text())
        t = d["time"]
        start = float(t.get("start", 0.0))
        span = float(t["stop"]) - start
        t.pop("step", None)
        t["count"] = 41
        t["stop"] = start + span / 20.0
        if "ensemble" in d:
            d["ensemble"]["size"] = 24
        d.get("output", {}).pop("path", None)
        out.append(d)
    return out


BASES = _base_scenarios()
#: Tables of the closed-loop scenarios (issues 24-26).
_CLOSED_LOOP_TABLES = ("commands", "software")


def _is_closed_loop(d: dict[str, Any]) -> bool:
    sc = d.get("spacecraft", {})
    return any(k in d for k in _CLOSED_LOOP_TABLES) or any(
        k in sc for k in ("wheels", "magnetorquers", "thrusters")
    )


def _closed_loop_bases() -> list[dict[str, Any]]:
    """The repository's closed-loop scenarios, and variations of the reaction-wheel one that
    use every closed-loop table: thrusters with an inline [commands] schedule and one from a
    CSV file, sensors with the MEKF, [[software.modes]] with a slew."""
    out = [json.loads(json.dumps(d)) for d in BASES if _is_closed_loop(d)]
    rw = next(d for d in out if d.get("scenario", {}).get("name") == "rw_inertial_pointing")

    def variant(**changes):
        d = json.loads(json.dumps(rw))
        d.update(changes)
        return d

    wheels = rw["spacecraft"]["wheels"]
    thrusters = [
        {"position": [1.0, 0.0, 0.0], "position_unit": "m", "direction": [0.0, 1.0, 0.0],
         "max_thrust": 1.0, "max_thrust_unit": "N", "min_impulse_bit": 0.02,
         "min_impulse_bit_unit": "N s", "name": "jet"},
        {"position": [-1.0, 0.0, 0.0], "position_unit": "m", "direction": [0.0, -1.0, 0.0],
         "max_thrust": 1.0, "max_thrust_unit": "N"},
    ]  # fmt: skip
    commands = {
        "times": [0.0, 5.0, 10.0], "times_unit": "s",
        "wheel_torque": [[0.1, -0.1, 0.05], [0.0, 0.0, 0.0], [-0.05, 0.1, 0.0]],
        "wheel_torque_unit": "N m", "thrust": [[0.5, 0.0], [0.0, 0.25], [0.0, 0.0]],
    }  # fmt: skip
    software = rw["software"]
    out.append(variant(
        spacecraft={"wheels": wheels, "thrusters": thrusters,
                    "center_of_mass": [0.0, 0.01, 0.0], "center_of_mass_unit": "m"},
        commands=commands, software=None))  # fmt: skip
    out.append(variant(
        spacecraft={"wheels": wheels, "thrusters": thrusters[:1]}, software=None,
        commands={"file": "commands.csv"},
        __files__={"commands.csv": "time,wheel_torque_1,wheel_torque_2,wheel_torque_3,thrust_1\n"
                   "0,0.1,0,-0.1,0.5\n5,0,0,0.05,0\n# a comment\n10,-0.1,0.02,0,1\n"}))  # fmt: skip
    out.append(variant(software={
        **software, "period": 0.5,
        "sensors": [
            {"type": "gyro", "arw": 1e-6, "arw_unit": "rad/s(1/2)", "rrw": 1e-9,
             "rrw_unit": "rad/s(3/2)", "bias": [1e-5, -1e-5, 0.0], "bias_unit": "rad/s",
             "seed": 1},
            {"type": "star_tracker", "noise": [5.0, 40.0], "noise_unit": "arcsec",
             "boresight": [0.0, 0.6, 0.8], "rate": 2.0, "rate_unit": "Hz", "seed": 2},
        ],
        "estimator": {"type": "mekf", "attitude_sigma": 0.01, "attitude_sigma_unit": "rad",
                      "bias_sigma": 1e-4, "bias_sigma_unit": "rad/s"},
    }))  # fmt: skip
    out.append(variant(software={
        "period": 0.2, "period_unit": "s", "delay": 1, "record_every": 2,
        "modes": [
            {"name": "damp", "control": "rate_damping", "C": 30.0, "C_unit": "N m s"},
            {"name": "slew", "condition": "rate_below", "threshold": 1.5,
             "threshold_unit": "deg/s", "guidance": "inertial",
             "guidance_q": [0.9, 0.1, 0.0, 0.4242640687119285],
             "slew_rate": 1.0, "slew_rate_unit": "deg/s",
             "slew_accel": 0.1, "slew_accel_unit": "deg/s2", "control": "quaternion_feedback",
             "K": 3.5, "K_unit": "N m", "C": 30.0, "C_unit": "N m s", "null_gain": 0.1},
            {"name": "hold", "condition": "after", "threshold": 20.0, "threshold_unit": "s",
             "guidance": "inertial", "control": "mrp_feedback", "K": 3.5, "K_unit": "N m",
             "P": 30.0, "P_unit": "N m s", "Ki": 0.001, "integral_limit": 1.0,
             "integral_limit_unit": "N m s"},
        ],
    }))  # fmt: skip
    for d in out:
        for k in [k for k, v in d.items() if v is None]:
            del d[k]
    return out


CLOSED_LOOP_BASES = _closed_loop_bases()

_WEIRD_SCALARS = [
    None, "", "abc", "1e-8", "nan", "\x00", "x" * 300, "é", True, False, 0, -1, 1, 2**62,
    -(2**62), 0.0, -0.0, 5e-324, 1e-308, 1e-300, 1e300, 1e308, -1e308, math.inf, -math.inf,
    math.nan, 1e-15, 1e15, [], [1.0], [1.0, 2.0], [[1.0, 2.0]], ["a", "b", "c"],
    [math.nan, 0.0, 0.0], [1e308, 1e308, 1e308], {}, {"a": 1},
]  # fmt: skip
_UNITS = ["s", "min", "d", "km", "m", "deg", "rad", "kg m2", "kg km2", "N", "rad/s", "deg/s",
          "km3 s-2", "kg m2 s-1", "N m s", "furlong", "", "1", "s-1", "m/s", "K"]  # fmt: skip


def _numbers():
    return st.one_of(
        st.sampled_from([0.0, -1.0, 1e-300, 1e300, -1e300, 1e-12, 1e12, 1e-6, 1e6, math.pi]),
        st.floats(allow_nan=False, allow_infinity=False, width=64),
        st.integers(min_value=-(2**63), max_value=2**63 - 1),
    )


def _is_num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _mutate_key(draw, table: dict[str, Any], op: str) -> None:
    """One mutation of one key of ``table`` (a table, or one of an array of tables)."""
    if not table:
        return
    key = draw(st.sampled_from(sorted(table)))
    if op == "delete":
        del table[key]
    elif op == "weird":
        v = draw(st.sampled_from(_WEIRD_SCALARS))
        if v is None:
            del table[key]
        else:
            table[key] = v
    elif op == "scale" and _is_num(table[key]):
        k = draw(st.sampled_from([-300, -100, -20, -6, -1, 1, 6, 20, 100, 300]))
        with contextlib.suppress(OverflowError):
            table[key] = float(table[key]) * 10.0**k * draw(st.sampled_from([1, -1]))
    elif op == "scale" and isinstance(table[key], list) and table[key]:
        i = draw(st.integers(0, len(table[key]) - 1))
        if isinstance(table[key][i], list) and table[key][i]:  # a row of a command table
            table[key][i][draw(st.integers(0, len(table[key][i]) - 1))] = draw(_numbers())
        else:
            table[key][i] = draw(_numbers())
    elif op == "number":
        table[key] = draw(_numbers())
    elif op == "unit":
        table[f"{key.removesuffix('_unit')}_unit"] = draw(st.sampled_from(_UNITS))
    elif op == "unknown":
        table[draw(st.sampled_from(["stpe", "rtol2", "x", "unit_unit", "", "seed_unit",
                                    "delay_unit", "axis_unit"]))] = 1.0  # fmt: skip


def _nested(base: dict[str, Any]) -> list[tuple[str, Any]]:
    """(path, table) of every array-of-tables element and sub-table of the scenario's tables
    (``[[spacecraft.wheels]]``, ``[[software.sensors]]``, ``[software.estimator]``...)."""
    out: list[tuple[str, Any]] = []
    for tname, table in sorted(base.items()):
        if not isinstance(table, dict):
            continue
        for k, v in sorted(table.items()):
            if isinstance(v, dict):
                out.append((f"{tname}.{k}", v))
            elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                out += [(f"{tname}.{k}[{i}]", x) for i, x in enumerate(v)]
    return out


def _arrays_of_tables(base: dict[str, Any]) -> list[list[Any]]:
    return [
        v
        for table in base.values()
        if isinstance(table, dict)
        for v in table.values()
        if isinstance(v, list) and v and all(isinstance(x, dict) for x in v)
    ]


@st.composite
def mutated_scenario(draw, bases=None) -> tuple[str, list[str], dict[str, str]]:
    """(TOML text, extra CLI options, other files of the case) of a mutated repository
    scenario (one of ``bases``, default every repository scenario)."""
    base = json.loads(json.dumps(draw(st.sampled_from(bases or BASES))))
    files = base.pop("__files__", {})
    if draw(st.integers(0, 3)) == 0:  # a valid variation: the runs that should succeed
        it = base.setdefault("integrator", {})
        it["rtol"] = draw(st.sampled_from([1e-13, 1e-10, 1e-8, 1e-6, 1e-3]))
        it["atol"] = draw(st.sampled_from([1e-16, 1e-12, 1e-9]))
        m = draw(st.sampled_from(
            ["dop853", "taylor"] if _is_closed_loop(base)  # what a spacecraft runs with
            else ["dop853", "scipy:DOP853", "splitting", "nosquish", "taylor"]))  # fmt: skip
        if "ensemble" not in base:
            it["method"] = m
            if m in ("splitting", "nosquish"):
                it["dt"] = draw(st.sampled_from([0.01, 0.1, 1.0]))
                if not r_dimless(base):
                    it["dt_unit"] = "s"
        t = base["time"]
        t["count"] = draw(st.sampled_from([2, 3, 41, 500]))
        return _toml(base), [], files
    n_ops = draw(st.integers(1, 4))
    closed = _is_closed_loop(base)
    for _ in range(n_ops):
        op = draw(st.sampled_from(
            ["delete", "weird", "scale", "number", "unit", "unknown", "time", "integrator",
             "form", "output", "ensemble", "table", "drag"]
            + ["nested"] * 6 * closed + ["count", "csv"] * closed
        ))  # fmt: skip
        if op == "nested":  # issues 24-26: one key of one actuator, sensor, mode, estimator
            subs = _nested(base)
            if subs:
                _, sub = draw(st.sampled_from(subs))
                _mutate_key(draw, sub, draw(st.sampled_from(
                    ["delete", "weird", "scale", "number", "unit", "unknown"])))  # fmt: skip
            continue
        if op == "count":  # an actuator or sensor more or fewer (the commands' columns...)
            arrays = _arrays_of_tables(base)
            if arrays:
                arr = draw(st.sampled_from(arrays))
                if draw(st.booleans()):
                    arr.append(json.loads(json.dumps(draw(st.sampled_from(arr)))))
                else:
                    del arr[draw(st.integers(0, len(arr) - 1))]
            continue
        if op == "csv":  # a command file mutated, missing or replaced by a directory
            if files:
                name = sorted(files)[0]
                lines = files[name].splitlines()
                i = draw(st.integers(0, len(lines) - 1))
                line = draw(
                    st.sampled_from(
                        [
                            "",
                            "nan,0,0,0",
                            "1e308,1,1,1",
                            "time",
                            "x,y",
                            "0,0,0,0,0",
                            "-1,0,0,0",
                            "5,inf,0,0",
                            "5,0,0,2",
                            "time,dipole_9",
                            "\x00",
                            "time,dipole_99999999999",
                        ]
                    )
                )
                files[name] = "\n".join([*lines[:i], line, *lines[i + 1 :]])  # fmt: skip
                if draw(st.integers(0, 5)) == 0:
                    files = {}
            else:
                base["commands"] = {
                    "file": draw(
                        st.sampled_from(
                            ["missing.csv", ".", "/proc/version", "a\x00b.csv", "x" * 300 + ".csv"]
                        )
                    )
                }
            continue
        if op == "drag" and "orbit" in base:  # issue 23: drag added (paper orbit: underground)
            base["potential"] = {"models": ["gravity_gradient", "aerodynamic_drag"]}
            base.setdefault("spacecraft", {})["facets"] = [
                {"area": draw(st.sampled_from([1.0, 0.0, 1e30])), "area_unit": "m2",
                 "normal": [1.0, 0.0, 0.0], "center": [0.1, 0.0, 0.0], "center_unit": "m"}
            ]  # fmt: skip
            continue
        tables = [k for k, v in base.items() if isinstance(v, dict) and v]
        if not tables:
            break
        tname = draw(st.sampled_from(sorted(tables)))
        table = base[tname]
        if op in ("delete", "weird", "scale", "number", "unit", "unknown"):
            _mutate_key(draw, table, op)
        elif op == "time":
            t = base.setdefault("time", {})
            t.pop("count", None)
            t.pop("step", None)
            t["start"] = draw(st.sampled_from([0.0, -1.0, 1e9, -1e308, 1e-300, 5.0]))
            t["stop"] = draw(st.sampled_from([2.0, 1e-9, 1e6, 1e308, -3.0, 0.0, 1e12]))
            if draw(st.booleans()):
                t["step"] = draw(st.sampled_from([1e7, 1e-3, 0.5, 1e-300, -1.0, 2.0, 1e308]))
            else:
                t["count"] = draw(st.sampled_from([1, 2, 10, 10**9, 10**10, 0, -5, 3]))
        elif op == "integrator":
            it = base.setdefault("integrator", {})
            k = draw(st.sampled_from(["method", "rtol", "atol", "max_step", "max_steps", "dt",
                                      "order", "formulation"]))  # fmt: skip
            it[k] = draw(st.one_of(
                st.sampled_from(["dop853", "scipy:RK45", "scipy:LSODA", "exact", "splitting",
                                 "nosquish", "rk99", "scipy:Euler", "euler_angles", "schwab"]),
                st.sampled_from([1e-300, 1e-200, 1e-16, 1e-3, 0.5, 2, 6, 10**12, True, -1]),
            ))  # fmt: skip
            if k in ("max_step", "dt") and not r_dimless(base):
                it[f"{k}_unit"] = "s"
        elif op == "form":
            ist = base.setdefault("initial_state", {})
            ist["form"] = draw(st.sampled_from(
                ["canonical", "body_rates", "euler_canonical", "euler_body_rates", "quux"]
            ))  # fmt: skip
        elif op == "output":
            base.setdefault("output", {})["path"] = draw(st.sampled_from(
                ["a\x00b.nc", "x" * 300 + ".nc", "newdir/", "deep/er/o.nc", "o.nc", ".", "",
                 "/proc/version", "link.nc", "dev_null"]
            ))  # fmt: skip
        elif op == "ensemble" and "ensemble" not in base:
            base["ensemble"] = {
                "size": draw(st.sampled_from([1, 3, 0, -2, 10**9, 2.5])),
                "seed": draw(st.sampled_from([0, 1, -1])),
            }
        elif op == "table":
            base[draw(st.sampled_from(
                ["time", "body", "potential", "orbit", "quux"]
                + ["spacecraft", "software", "commands"] * closed
            ))] = draw(st.sampled_from([{}, 1.0, "x", {"a": {}}, [{}], [{"a": 1}]]))  # fmt: skip
    text = _toml(base)
    if draw(st.integers(0, 30)) == 0:  # sometimes not even TOML
        text = text[: draw(st.integers(0, max(0, len(text) - 1)))] + "[[[\n"
    opts: list[str] = []
    for name, pool in (
        ("--rtol", ["1e-8", "0", "-1", "nan", "inf", "1e-300", "abc"]),
        ("--atol", ["1e-14", "0", "1e-250", "nan"]),
        ("--dt", ["0.01", "0", "-1", "1e-300", "inf"]),
        ("--stop", ["1", "0", "-5", "1e300", "nan", "inf", "1e-300", "10min", "3 kg", "1e9 yr"]),
        ("--method", ["dop853", "scipy:DOP853", "exact", "splitting", "rk99", "taylor"]),
        ("--formulation", ["canonical", "euler_angles", "bogus"]),
        ("--order", ["2", "4", "5", "x"]),
    ):
        if draw(st.integers(0, 9)) == 0:
            opts += [name, draw(st.sampled_from(pool))]
    return text, opts, files


def r_dimless(data: dict[str, Any]) -> bool:
    return "inertia_unit" not in data.get("body", {})


def _check_cli_result(code: int, err: str, out: Path) -> str | None:
    """None if the outcome of ``attitude run`` is clean, else what is wrong with it."""
    if "Traceback" in err:
        return "traceback"
    if code not in (0, 1, 2, 130):
        return f"exit code {code}"
    lines = [ln for ln in err.splitlines() if ln.startswith("attitude:")]
    if code in (1, 2):
        if not lines:
            return "no error message"
        if _RAW_CLI.match(lines[-1]):
            return f"raw exception: {lines[-1]}"
    if code == 0:  # a silent no-op is a failure
        if not out.exists():
            return "exit 0 without an output file"
        try:
            with io.read(out, load=False) as ds:
                n = ds.sizes.get("time", 0)
                status = ds.attrs.get("run_status", "")
        except Exception as exc:
            return f"exit 0 with an unreadable output: {exc!r}"
        if n < 2 or status != "complete":
            return f"exit 0 with {n} samples, run_status {status!r}"
        with io.read(out, load=True) as ds:
            nan = _nonfinite(ds)
        if nan:
            return f"silent NaN/inf: exit 0 with a file whose {nan}"
    raw = [ln for ln in lines if ln.startswith("attitude: warning:") and _RAW_WARNING.search(ln)]
    if raw:
        return f"raw warning: {raw[0]}"
    if code == 1 and out.exists():
        with io.read(out, load=False) as ds:
            if not str(ds.attrs.get("run_status", "")).startswith("failed"):
                return "exit 1 with a file that says complete"
    return None


def _warm_up(work: Path, bases: list[dict[str, Any]]) -> None:
    """Load (or compile) every compiled entry point the runs use, before any time limit: an
    interrupt inside numba's compiler leaves its dispatcher unusable in this process."""
    d = work / "warm"
    d.mkdir()
    runs = [
        [],
        ["--method", "scipy:RK45"],
        ["--method", "exact"],
        ["--formulation", "euler_angles"],
        ["--formulation", "schwab"],
        ["--formulation", "euler_equations"],
        ["--method", "splitting", "--dt", "0.1"],
        ["--method", "nosquish", "--dt", "0.1"],
    ]
    if bases is not BASES:  # the closed-loop runs: each base as it is, with taylor and dop853
        runs = [[], ["--method", "taylor"]]
    for i, base in enumerate(bases):
        base = dict(base)
        for name, content in base.pop("__files__", {}).items():
            (d / name).write_text(content)
        (d / f"b{i}.toml").write_text(_toml(base))
        for j, opts in enumerate(runs):
            with (
                contextlib.redirect_stderr(_stdio.StringIO()),
                contextlib.redirect_stdout(_stdio.StringIO()),
                warnings.catch_warnings(),
            ):
                warnings.simplefilter("ignore")
                main(["run", str(d / f"b{i}.toml"), "-o", str(d / f"o{i}_{j}.nc"), "-q", *opts])


# ------------------------------------------------------------------------------------------------
# 1. scenario files through the command line
# ------------------------------------------------------------------------------------------------


def test_fuzz_scenario_files_through_the_cli(tmp_path_factory, capsys):
    _fuzz_cli(tmp_path_factory.mktemp("fuzz_cli"), capsys, BASES, N_SCENARIOS,
              "scenario files through the CLI")  # fmt: skip


def test_fuzz_closed_loop_scenarios_through_the_cli(tmp_path_factory, capsys):
    """The closed-loop tables of issues 24-26 ([[spacecraft.wheels]], [[spacecraft.magnetorquers]],
    [[spacecraft.thrusters]], [commands] inline and from a CSV file, [software] with its laws
    and [[software.modes]], [[software.sensors]], [software.estimator]), mutated like the
    others, key by key inside each actuator, sensor and mode, and by adding or removing one."""
    _fuzz_cli(tmp_path_factory.mktemp("fuzz_cli_closed_loop"), capsys, CLOSED_LOOP_BASES,
              N_CLOSED_LOOP_SCENARIOS, "closed-loop scenario files through the CLI")  # fmt: skip


def _fuzz_cli(work: Path, capsys, bases: list[dict[str, Any]], n: int, title: str) -> None:
    counts: Counter = Counter()
    failures: list[str] = []
    null = work / "dev_null"
    if os.geteuid() == 0:
        with contextlib.suppress(OSError):
            os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a private /dev/null
    (work / "real.nc").write_bytes(b"")
    (work / "link.nc").symlink_to(work / "real.nc")
    seen = [0]
    slow: list[str] = []
    _warm_up(work, bases)

    @_settings(n)
    @given(case=mutated_scenario(bases))
    def run(case):
        text, opts, files = case
        seen[0] += 1
        d = work / f"c{seen[0]}"
        d.mkdir()
        (d / "s.toml").write_text(text, encoding="utf-8")
        for name, content in files.items():
            (d / name).write_text(content, encoding="utf-8")
        out = d / "o.nc"
        use_o = "output" not in text or seen[0] % 2 == 0
        args = ["run", "s.toml", "-q", *opts] + (["-o", str(out)] if use_o else [])
        buf = _stdio.StringIO()
        old = os.getcwd()
        os.chdir(d)
        try:
            with contextlib.redirect_stderr(buf), contextlib.redirect_stdout(_stdio.StringIO()):
                with warnings.catch_warnings():
                    warnings.simplefilter("always")  # the command prints them: raw ones fail
                    with guard(f"attitude {' '.join(args)}\n{text}"), _time_limit(TIME_LIMIT):
                        code = main(args)
        except BaseException as exc:
            code = -1
            buf.write(f"Traceback: main raised {exc!r}")
        finally:
            os.chdir(old)
        err = buf.getvalue()
        counts["tried"] += 1
        if code == 130:
            counts["slow (interrupted after 20 s)"] += 1
            slow.append(f"options {opts}\n{text[:3000]}")
        outcome = {0: "ok", 1: "clean failure (exit 1)", 2: "clean error (exit 2)"}.get(code)
        if outcome:
            counts[outcome] += 1
        problem = _check_cli_result(code, err, out if use_o else d / "none")
        if code == 0 and not use_o:
            problem = None  # written where output.path says (checked by the temp sweep below)
        if problem is None and code == 0 and use_o:
            for cmd in (["info", str(out)], ["export", str(out), "--ccsds-aem", str(d / "a.aem"),
                        "--epoch", "2024-01-01T00:00:00", "--time-unit-seconds", "1"]):  # fmt: skip
                b2 = _stdio.StringIO()
                with contextlib.redirect_stderr(b2), contextlib.redirect_stdout(_stdio.StringIO()):
                    c2 = main(cmd)
                if (
                    c2 not in (0, 2)
                    or _RAW_CLI.match(b2.getvalue())
                    or "Traceback" in b2.getvalue()
                ):
                    problem = f"{cmd[0]}: exit {c2}: {b2.getvalue()[-300:]}"
        temps = _temps(d) + _own_temps()
        if temps:
            problem = (problem or "") + f" temporary files left: {temps}"
        if problem:
            counts["other"] += 1
            kind = (
                "raw exceptions"
                if problem.startswith(
                    ("traceback", "raw exception", "info:", "export:", "exit code")
                )
                else "raw warnings"
                if problem.startswith("raw warning")
                else "silent NaN/inf"
                if problem.startswith("silent NaN")
                else "silent no-ops"
            )
            counts[kind] += 1
            failures.append(f"{problem}\n  options {opts}\n  stderr {err[-400:]!r}\n{text[:1500]}")
        with contextlib.suppress(OSError):
            for p in sorted(d.rglob("*"), reverse=True):
                if p.is_dir() and not p.is_symlink():
                    p.rmdir()
                else:
                    p.unlink()
            d.rmdir()

    guard = _Watchdog(work)
    try:
        run()
    finally:
        guard.close()
    if null.exists():
        assert stat.S_ISCHR(null.lstat().st_mode), "a device was replaced by a regular file"
    _report(capsys, title, counts, _figures(counts))
    if slow:
        _report(capsys, f"{title}: interrupted after 20 s", Counter(), "\n" + "\n".join(slow))
    assert not failures, "\n\n".join(failures[:10])


# ------------------------------------------------------------------------------------------------
# 2. the public API
# ------------------------------------------------------------------------------------------------


def _bad_values():
    from astropy import units as u

    base = [
        None, "1e-8", b"1", "", True, False, 1 + 2j, np.complex128(1j), math.nan, math.inf,
        -math.inf, 0, 0.0, -1, -1.0, 1e308, -1e308, 1e-308, 5e-324, 1e300, 1e-300, 2**70,
        -(2**70), np.int64(2**62), np.float32(1e-8), [], [[]], [1.0], [1.0, 2.0],
        [[1.0, 2.0], [3.0, 4.0]], ["a", "b", "c", "d"], [math.nan] * 4, [1e308] * 4,
        [1 + 1j, 0, 0, 0], np.zeros((0, 4)), np.ones((2, 3, 4)), np.array([True] * 4),
        np.array(["1", "0", "0", "0"]), object(), {}, {"a": 1}, (lambda x: x),
        1.0 * u.m, [1.0, 2.0, 3.0] * u.s, 1e-8 * u.dimensionless_unscaled, np.ones(10**5),
    ]  # fmt: skip
    return base


BAD = None


def _bad():
    global BAD
    if BAD is None:
        BAD = _bad_values()
    return st.sampled_from(range(len(BAD))).map(lambda i: BAD[i])


def _api_targets(tmp: Path) -> dict[str, tuple[Any, dict[str, Any]]]:
    from attitude import aem
    from orbit import KeplerOrbit

    I = [1.25, 1.0, 0.75]
    q0 = [1.0, 0.0, 0.0, 0.0]
    Q0 = list(attitude.canonical.momenta_from_angular_velocity(q0, [0.3, 0.2, 0.1], I))
    small = attitude.propagate(I, q0, Q0, np.linspace(0.0, 1.0, 5))
    orb = KeplerOrbit(7000.0, 0.1, 0.5, 0.2, 0.3)
    gbody = attitude.RigidBody([400.0, 500.0, 600.0], units="kg km2")

    def write_then_read(ds, path, complevel=4):
        p = io.write(ds, path, complevel=complevel)
        return io.read(p)

    # The real-spacecraft API (orbits with dates, environment models, frames, events, ensemble
    # statistics): one valid call of each, fuzzed like the others.
    from attitude import events as E
    from attitude import frames as F
    from orbit import EphemerisOrbit, SecularJ2Orbit

    leo = SecularJ2Orbit(7000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch="2024-03-01T00:00:00")
    tle = tomllib.loads((SCEN / "sso_tle_gravity_gradient.toml").read_text())["orbit"]["tle"]
    sbody = attitude.RigidBody([0.02, 0.03, 0.04], units="kg m2")
    box = attitude.box_wing([0.1, 0.1, 0.3])
    dipole = attitude.MagneticDipole(leo, [0.0, 0.0, 0.05], field="dipole")
    rate_ev = E.RateExceeds(0.25)
    ens = attitude.propagate_ensemble(I, np.tile(q0, (4, 1)), Q0, [0.0, 0.5, 1.0])
    aem.write_aem(small, tmp / "r.aem", epoch="2024-01-01T00:00:00", time_unit_seconds=1.0)
    heavy_big = attitude.HeavyTop(1e300, [1.0, 0.0, 1.0])
    oem = EphemerisOrbit.from_orbit(leo, 0.0, 600.0, 60.0).to_oem(tmp / "o.oem")

    return {
        "propagate": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], potential=None, method="dop853",
            rtol=1e-10, atol=1e-12, dt=None, order=4, max_step=math.inf, max_steps=10**6,
            chunk=None, formulation="canonical")),
        "propagate_splitting": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], method="splitting", dt=0.1, order=4)),
        "propagate_gg": (attitude.propagate, dict(
            body=gbody, q0=q0, Q0=[0.0, 1e-4, 0.0, 0.0], t=[0.0, 60.0],
            potential=attitude.GravityGradient(orb))),
        "propagate_ensemble": (attitude.propagate_ensemble, dict(
            bodies_or_body=I, q0=np.tile(q0, (3, 1)), Q0=Q0, t=[0.0, 0.5, 1.0],
            rtol=1e-10, atol=1e-12, max_step=math.inf, max_steps=10**6, chunk_size=None,
            threads=None, attrs=None)),
        "RigidBody": (attitude.RigidBody, dict(inertia=I, units=None)),
        "RigidBody.from_tensor": (attitude.RigidBody.from_tensor, dict(
            J=np.diag(I), units=None)),
        "HeavyTop": (attitude.HeavyTop, dict(weight=0.5, center_of_mass=[1.0, 0.0, 0.0])),
        "GravityGradient": (attitude.GravityGradient, dict(orbit=orb, inertia=None)),
        "KeplerOrbit": (KeplerOrbit, dict(
            a=7000.0, e=0.1, inc=0.5, raan=0.2, argp=0.3, f0=None, mu=None, t0=0.0)),
        "KeplerOrbit.circular": (KeplerOrbit.circular, dict(
            altitude=500.0, inc=0.9, raan=0.2, arg_lat=0.1, epoch=None, mu=None, t0=0.0)),
        "SecularJ2Orbit.sun_synchronous": (SecularJ2Orbit.sun_synchronous, dict(
            altitude=700.0, local_time_of_node="10:30", epoch="2024-03-20T12:00:00",
            arg_lat=0.0, mu=None, j2=None, radius=None)),
        "KeplerOrbit.radius": (orb.radius, dict(t=1.0)),
        "KeplerOrbit.frame_quaternion": (orb.frame_quaternion, dict(t=[0.0, 1.0])),
        "project_state": (attitude.canonical.project_state, dict(q=q0, Q=Q0)),
        "momenta_from_angular_velocity": (attitude.canonical.momenta_from_angular_velocity,
                                          dict(q=q0, omega=[0.1, 0.2, 0.3], inertia=I)),
        "io.write+read": (write_then_read, dict(ds=small, path=tmp / "w.nc", complevel=4)),
        "io.read": (io.read, dict(path=tmp / "w.nc", load=True)),
        "propagate_taylor": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], method="taylor", rtol=1e-10, atol=1e-12,
            potential=attitude.HeavyTop(0.5, [0.0, 0.0, 1.0]), max_steps=10**6)),
        "propagate_events": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], events=[rate_ev], rtol=1e-10)),
        "propagate_environment": (attitude.propagate, dict(
            body=sbody, q0=q0, Q0=[0.0, 1e-4, 0.0, 0.0], t=[0.0, 30.0, 60.0],
            potential=dipole + attitude.GravityGradient(leo), epoch=None)),
        "propagate_ensemble_statistics": (attitude.propagate_ensemble, dict(
            bodies_or_body=I, q0=np.tile(q0, (5, 1)), Q0=Q0, t=[0.0, 0.5, 1.0],
            output="statistics", every=1, percentiles=(5.0, 50.0, 95.0), max_output_size=None)),
        "SecularJ2Orbit": (SecularJ2Orbit, dict(
            a=7000.0, e=0.001, inc=1.7, raan=0.2, argp=0.3, f0=0.0,
            epoch="2024-03-01T00:00:00", mu=None, j2=None, radius=None)),
        "EphemerisOrbit.from_tle": (EphemerisOrbit.from_tle, dict(
            line1=tle[0], line2=tle[1], start=0.0, stop=600.0, step=60.0, epoch=None)),
        "MagneticDipole": (attitude.MagneticDipole, dict(
            orbit=leo, dipole=[0.0, 0.0, 0.05], field="dipole", step=None, span=None)),
        "AerodynamicDrag": (attitude.AerodynamicDrag, dict(
            orbit=leo, facets=box, density="exponential", f107=150.0, f107a=150.0, ap=4.0)),
        "SolarRadiation": (attitude.SolarRadiation, dict(
            orbit=leo, facets=box, eclipse="conical")),
        "EddyCurrentDamping": (attitude.EddyCurrentDamping, dict(
            orbit=leo, tensor=np.eye(3) * 1e3, field="dipole")),
        "Facet": (attitude.Facet, dict(
            area=0.1, normal=[1.0, 0.0, 0.0], center=[0.0, 0.0, 0.0], cd=2.2, specular=0.1,
            diffuse=0.1)),
        "box_wing": (attitude.box_wing, dict(size=[0.1, 0.1, 0.3], center=(0.0, 0.0, 0.0))),
        "frames.nadir": (F.nadir, dict(orbit=leo, axis="+z", secondary="+x", toward="velocity")),
        "frames.target": (F.target, dict(orbit=leo, latitude=0.5, longitude=0.1, height=0.0)),
        "initial_state": (attitude.initial_state, dict(
            body=sbody, frame=F.lvlh(leo), t0=0.0, offset=None, rates=None)),
        "PointingExceeds": (E.PointingExceeds, dict(
            frame=F.lvlh(leo), axis=[0.0, 0.0, 1.0], angle=0.1, direction="rising")),
        "RateExceeds": (E.RateExceeds, dict(rate=0.1, direction="rising", samples=8)),
        "EclipseEntry": (E.EclipseEntry, dict(orbit=leo, shadow="umbra")),
        "AngleToSun": (E.AngleToSun, dict(axis=[0.0, 0.0, 1.0], angle=0.5, orbit=leo)),
        "aem.read": (aem.read, dict(path=tmp / "r.aem", body_frame=None)),
        "pointing_error_percentiles": (attitude.pointing_error_percentiles, dict(
            ds=ens, reference=None, percentiles=(5.0, 50.0, 95.0), axis=None, degrees=False)),
        "rate_percentiles": (attitude.rate_percentiles, dict(
            ds=ens, percentiles=(5.0, 50.0, 95.0), norm=True, variable="omega", degrees=False)),
        "aem.write_aem": (aem.write_aem, dict(
            ds=small, path=tmp / "a.aem", epoch="2024-01-01T00:00:00", version=2,
            time_unit_seconds=1.0, object_name="X")),
        # issue 23: every integrator with states and torques that overflow (HeavyTop weights,
        # Q0 of 1e150 among the bad values), drag, the orbits' and frames' times, OEM files
        "propagate_methods": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], potential=attitude.HeavyTop(0.5, [0, 0, 1.0]),
            method="scipy:LSODA", dt=0.01, formulation="canonical")),
        "propagate_heavy": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], potential=heavy_big, method="dop853",
            dt=0.01)),
        "propagate_exact": (attitude.propagate, dict(
            body=I, q0=q0, Q0=[0.0, 1e150, 1e148, 0.0], t=[0.0, 0.5, 1.0], method="exact")),
        "propagate_drag": (attitude.propagate, dict(
            body=sbody, q0=q0, Q0=[0.0, 1e-4, 0.0, 0.0], t=[0.0, 30.0, 60.0],
            potential=attitude.AerodynamicDrag(leo, box, density="exponential"))),
        "propagate_ensemble_taylor": (attitude.propagate_ensemble, dict(
            bodies_or_body=I, q0=np.tile(q0, (3, 1)), Q0=Q0, t=[0.0, 0.5, 1.0], method="taylor",
            rtol=1e-10, max_steps=10**6)),
        "SecularJ2Orbit.position": (leo.position, dict(t=[0.0, 600.0])),
        "frames.target.quaternion": (F.target(leo, 0.7, 0.2).quaternion, dict(t=[0.0, 60.0])),
        "frames.nadir.quaternion": (F.nadir(orb).quaternion, dict(t=[0.0, 60.0])),
        "EphemerisOrbit.from_oem": (EphemerisOrbit.from_oem, dict(
            path=oem, epoch=None, mu=None)),
        "propagate_splitting_events": (attitude.propagate, dict(
            body=I, q0=q0, Q0=Q0, t=[0.0, 0.5, 1.0], method="splitting", dt=0.01,
            potential=attitude.HeavyTop(0.5, [0.0, 0.0, 1.0]), events=[rate_ev])),
    }  # fmt: skip


def _closed_loop_targets(tmp: Path) -> dict[str, tuple[Any, dict[str, Any]]]:
    """Issues 24-26: every constructor of the closed-loop API with valid arguments, each
    wrapped in a short run that uses what it built (a value a constructor accepts must not
    turn into a raw exception, a NaN trajectory or a hang in the run)."""
    from astropy import units as u

    from attitude import canonical as C
    from attitude import control as K
    from attitude import frames as F
    from attitude import sensors as S
    from attitude.actuators import (
        CommandSchedule,
        Magnetorquer,
        ReactionWheel,
        Thruster,
        pyramid,
    )
    from attitude.estimation import MEKF
    from attitude.software import (
        After,
        FlightSoftware,
        Mode,
        PointingBeyond,
        PointingWithin,
        RateAbove,
        RateBelow,
        Slew,
    )
    from orbit import SecularJ2Orbit

    leo = SecularJ2Orbit(7000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch="2024-03-01T00:00:00")
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    q0 = [1.0, 0.0, 0.0, 0.0]
    w0 = [0.02, 0.01, -0.015]
    t = [0.0, 1.0, 2.0]
    wheels = pyramid(0.05, max_torque=0.1, max_speed=600.0)
    rods = tuple(Magnetorquer(np.eye(3)[k], 0.2) for k in range(3))
    jets = (Thruster([0.5, 0.0, 0.0], [0.0, 1.0, 0.0], 1.0),)
    wcraft = attitude.Spacecraft(body, wheels)
    mcraft = attitude.Spacecraft(body, (), rods, (), leo, field="dipole")
    full = attitude.Spacecraft(body, wheels, rods, jets, leo, field="dipole")

    def run(craft, **kw):
        Q0 = C.momenta_from_angular_velocity(q0, w0, craft)
        return attitude.propagate(craft, q0, Q0, kw.pop("t", t), **kw)

    def sched(n_w=4, n_m=3, n_t=1):
        return CommandSchedule(
            [0.0, 0.7, 1.3],
            wheel_torque=np.tile([0.01, -0.02, 0.0, 0.005][:n_w], (3, 1)) if n_w else None,
            dipole=np.tile([0.1, -0.1, 0.05][:n_m], (3, 1)) if n_m else None,
            thrust=np.tile([0.3][:n_t], (3, 1)) if n_t else None,
        )

    def wheel(**kw):
        return run(attitude.Spacecraft(body, [ReactionWheel(**kw)]), commands=sched(1, 0, 0))

    def pyramid_run(**kw):
        return run(attitude.Spacecraft(body, pyramid(**kw)), commands=sched(4, 0, 0))

    def rod(**kw):
        return run(attitude.Spacecraft(body, (), [Magnetorquer(**kw)], (), leo, field="dipole"),
                   commands=sched(0, 1, 0))  # fmt: skip

    def jet(**kw):
        return run(attitude.Spacecraft(body, (), (), [Thruster(**kw)]), commands=sched(0, 0, 1))

    def spacecraft(**kw):
        return run(attitude.Spacecraft(**kw))

    def spacecraft_tensor(**kw):
        return run(attitude.Spacecraft.from_tensor(**kw)[0])

    def with_speeds(speeds):
        return run(wcraft.with_wheel_speeds(speeds))

    def schedule(**kw):
        return run(full, commands=CommandSchedule(**kw))

    def schedule_csv(cell, path=None):
        if path is None:
            path = tmp / "c.csv"
            path.write_text(
                f"time,wheel_torque_1,dipole_1,thrust_1\n0,0.01,0.1,0.5\n1,{cell},0,0\n"
            )
        s = CommandSchedule.from_csv(path)
        return run(attitude.Spacecraft(body, wheels[:1], rods[:1], jets, leo, field="dipole"),
                   commands=s)  # fmt: skip

    def software(craft=wcraft, **kw):
        return run(craft, software=FlightSoftware(**kw))

    def law(cls, craft=wcraft, guidance=None):
        def f(**kw):
            return run(craft, software=FlightSoftware(0.1, guidance, cls(**kw)))

        return f

    def dumping(**kw):
        fsw = FlightSoftware(0.1, F.inertial(), (K.MRPFeedback(1.0, 5.0), K.MomentumDumping(**kw)))
        return run(full, software=fsw)

    def allocation(**kw):
        fsw = FlightSoftware(0.1, F.inertial(), K.MRPFeedback(1.0, 5.0), K.WheelAllocation(**kw))
        return run(wcraft, software=fsw)

    def optimal_gain(**kw):
        return K.BDot.optimal_gain(**kw)

    def modes(rate, angle, axis, after, slew_rate, slew_accel, name):
        fsw = FlightSoftware(0.1, modes=[
            (None, Mode(control=K.RateDamping(2.0), name=name)),
            (RateBelow(rate), Mode(Slew(F.inertial(), slew_rate, slew_accel),
                                   K.QuaternionFeedback(2.0, 6.0))),
            (PointingWithin(F.inertial(), angle, axis), Mode(F.inertial(), K.RateDamping(1.0))),
            (After(after), Mode(F.lvlh(leo), K.MRPFeedback(1.0, 5.0))),
            (PointingBeyond(F.inertial(), angle), Mode(control=K.RateDamping(2.0))),
            (RateAbove(rate), Mode(control=K.RateDamping(2.0))),
        ])  # fmt: skip
        return run(full, software=fsw)

    def sensors(make, craft=full, estimator=True):
        def f(**kw):
            sens = [make(**kw)]
            kinds = {type(x) for x in sens}
            if S.Gyro not in kinds:
                sens.append(S.Gyro(1e-6, seed=1))
            if S.StarTracker not in kinds:
                sens.append(S.StarTracker(1e-5, seed=2))
            fsw = FlightSoftware(0.1, F.inertial(), K.MRPFeedback(1.0, 5.0), sensors=sens,
                                 estimator=MEKF() if estimator else None)  # fmt: skip
            return run(craft, software=fsw)

        return f

    def mekf(**kw):
        sens = [S.Gyro(1e-6, seed=1), S.StarTracker(1e-5, seed=2), S.Magnetometer(1e-7, seed=3),
                S.SunSensor(seed=4)]  # fmt: skip
        fsw = FlightSoftware(0.1, F.inertial(), K.MRPFeedback(1.0, 5.0), sensors=sens,
                             estimator=MEKF(**kw))  # fmt: skip
        return run(full, software=fsw)

    def step(ret, craft=wcraft):
        return run(craft, software=FlightSoftware(0.1, F.inertial(), lambda t, m: ret))

    def step_dict(wheel_torque, dipole, thrust):
        d = {"wheel_torque": wheel_torque, "dipole": dipole, "thrust": thrust}
        return run(full, software=FlightSoftware(0.1, F.inertial(), lambda t, m: d))

    def propagate_closed_loop(**kw):
        return attitude.propagate(**kw)

    Q0w = C.momenta_from_angular_velocity(q0, w0, wcraft)
    targets = {
        "ReactionWheel": (wheel, dict(
            axis=[1.0, 0.0, 0.0], inertia=0.05, max_torque=0.2, max_speed=600.0, speed=10.0,
            min_torque=0.0, max_power=math.inf, coulomb_friction=1e-3, static_friction=2e-3,
            viscous_friction=1e-6, stribeck_speed=0.1, limit_cycle_speed=1e-4, name=None)),
        "pyramid": (pyramid_run, dict(
            inertia=0.05, elevation=0.6, axis=(0.0, 0.0, 1.0), speeds=[1.0, 2.0, 3.0, 4.0],
            max_torque=0.1)),
        "Magnetorquer": (rod, dict(axis=[0.0, 0.0, 1.0], max_dipole=0.2, name="rod")),
        "Thruster": (jet, dict(
            position=[0.5, 0.0, 0.0], direction=[0.0, 1.0, 0.0], max_thrust=1.0,
            min_impulse_bit=0.01, name=None)),
        "Spacecraft": (spacecraft, dict(
            body=body, wheels=wheels, magnetorquers=rods, thrusters=jets, orbit=leo,
            center_of_mass=[0.01, 0.0, 0.0], field="dipole")),
        "Spacecraft.from_tensor": (spacecraft_tensor, dict(
            J=np.array([[12.0, 0.3, 0.0], [0.3, 10.0, 0.1], [0.0, 0.1, 8.0]]), wheels=wheels,
            units="kg m2")),
        "Spacecraft.with_wheel_speeds": (with_speeds, dict(speeds=[1.0, -2.0, 3.0, 0.0])),
        "CommandSchedule": (schedule, dict(
            times=[0.0, 0.7, 1.3], wheel_torque=np.full((3, 4), 0.01),
            dipole=np.full((3, 3), 0.1), thrust=np.full((3, 1), 0.2))),
        "CommandSchedule.from_csv": (schedule_csv, dict(cell="0.02", path=None)),
        "propagate_commands": (propagate_closed_loop, dict(
            body=full, q0=q0, Q0=C.momenta_from_angular_velocity(q0, w0, full), t=t,
            commands=sched(), method="dop853", rtol=1e-10, atol=1e-12, max_step=math.inf)),
        "propagate_software_taylor": (propagate_closed_loop, dict(
            body=wcraft, q0=q0, Q0=Q0w, t=t, method="taylor", rtol=1e-12,
            software=FlightSoftware(0.1, F.inertial(), K.MRPFeedback(1.0, 5.0)))),
        "propagate_software_recorded": (propagate_closed_loop, dict(
            body=wcraft, q0=q0, Q0=Q0w, t=t, method="dop853", max_output_size="1 GB",
            software=FlightSoftware(0.1, F.inertial(), K.MRPFeedback(1.0, 5.0),
                                    record_every=0.5 * u.s))),
        "FlightSoftware": (software, dict(
            period=0.1, guidance=F.inertial(), control=K.MRPFeedback(1.0, 5.0), allocation=None,
            sensors=None, estimator=None, modes=None, delay=1, phase=0.05,
            inertia=[12.0, 10.0, 8.0], record_every=2)),
        "FlightSoftware.ideal_torque": (software, dict(
            craft=body, period=0.25 * u.s, control=K.RateDamping(2.0))),
        "FlightSoftware.modes": (modes, dict(
            rate=0.01, angle=0.1, axis=[0.0, 0.0, 1.0], after=1.5, slew_rate=0.02,
            slew_accel=0.01, name="damp")),
        "MRPFeedback": (law(K.MRPFeedback, guidance=F.inertial()), dict(
            K=1.0, P=5.0, Ki=0.01, integral_limit=0.5)),
        "QuaternionFeedback": (law(K.QuaternionFeedback, guidance=F.lvlh(leo)),
                               dict(K=1.0, C=[5.0, 5.0, 5.0])),
        "RateDamping": (law(K.RateDamping), dict(K=np.diag([2.0, 2.0, 2.0]))),
        "BDot": (law(K.BDot, craft=mcraft), dict(gain=1e4, normalized=False)),
        "BDot.optimal_gain": (optimal_gain, dict(orbit=leo, inertia=[12.0, 10.0, 8.0])),
        "MomentumDumping": (dumping, dict(gain=1e-3, reference=[0.0, 0.0, 0.01])),
        "WheelAllocation": (allocation, dict(null_gain=0.1, null_speeds=[1.0, 1.0, 1.0, 1.0])),
        "Gyro": (sensors(S.Gyro), dict(
            arw=1e-6, rrw=1e-9, bias=[1e-5, 0.0, 0.0], scale_factor=1e-4,
            misalignment=[1e-4, 0.0, 0.0], quantization=1e-7, saturation=1.0, seed=3)),
        "StarTracker": (sensors(S.StarTracker), dict(
            noise=[1e-5, 1e-4], boresight=[0.0, 0.6, 0.8], rate=5.0, sun_exclusion=0.5,
            earth_exclusion=0.3, seed=4)),
        "Magnetometer": (sensors(S.Magnetometer), dict(noise=1e-7, bias=[1e-7, 0.0, 0.0],
                                                       seed=5)),
        "SunSensor": (sensors(S.SunSensor), dict(normals=None, noise=0.01, seed=6)),
        "MEKF": (mekf, dict(
            initial_attitude=q0, initial_bias=[0.0, 0.0, 0.0], attitude_sigma=0.01,
            bias_sigma=1e-5, use_magnetometer=True, use_sun_sensor=True)),
        "python_step": (step, dict(ret=[0.01, 0.0, -0.01, 0.0])),
        "python_step_dict": (step_dict, dict(
            wheel_torque=[0.01, 0.0, -0.01, 0.0], dipole=[0.0, 0.1, 0.0], thrust=[0.5])),
        "python_step_ideal": (step, dict(ret=[0.01, 0.0, -0.01], craft=body)),
        "momenta_from_angular_velocity_wheels": (C.momenta_from_angular_velocity, dict(
            q=q0, omega=w0, inertia=wcraft, wheel_speeds=[1.0, 2.0, 3.0, 4.0])),
        "angular_velocity_wheels": (C.angular_velocity, dict(
            q=q0, Q=Q0w, inertia=wcraft, wheel_speeds=[1.0, 2.0, 3.0, 4.0])),
        "initial_state_spacecraft": (attitude.initial_state, dict(
            body=full, frame=F.lvlh(leo), t0=0.0, offset=None, rates=None)),
    }  # fmt: skip
    _RUNS_OF_THREE.update(k for k in targets if not k.startswith("propagate"))
    return targets


#: Variables that are NaN by definition (no event occurred; a failed ensemble member's
#: samples after its failure are in a PropagationError, not a normal return; the coarse Sun
#: sensor's direction when too few heads are lit).
_NAN_BY_DESIGN = ("first_time", "detector_first_time", "event_first_time", "sun_direction")
#: Variables where inf is documented (a limit of inf: none) but NaN is not.
_INF_BY_DESIGN = ("wheel_max_torque", "wheel_max_speed")
#: The estimator's variables: NaN at the ticks before the filter starts (its first valid star
#: tracker measurement; docs/results.md), finite from then on.
_NAN_UNTIL_STARTED = ("estimate_q", "bias_estimate", "estimation_sigma", "estimation_error", "nees")
#: Closed-loop targets that run t = [0, 1, 2] (3 samples, else a silent no-op).
_RUNS_OF_THREE: set[str] = set()


def _nonfinite(result: Any) -> str | None:
    """The first variable of a normal return that holds NaN or inf (a silent NaN), or None."""
    import xarray as xr

    if isinstance(result, xr.Dataset):
        for k, v in result.data_vars.items():
            if v.dtype.kind == "f" and not k.endswith(_NAN_BY_DESIGN):
                if k in _INF_BY_DESIGN:
                    if np.any(np.isnan(v.values)):
                        return f"variable {k!r} holds NaN"
                elif k in _NAN_UNTIL_STARTED:
                    x = v.values.reshape(v.shape[0], -1)
                    started = np.cumsum(~np.all(np.isnan(x), axis=1)) > 0
                    if not np.all(np.isfinite(x[started])):
                        return f"variable {k!r} holds NaN or inf after the filter started"
                elif not np.all(np.isfinite(v.values)):
                    return f"variable {k!r} holds NaN or inf"
        return None
    arrays = result if isinstance(result, tuple) else (result,)
    for a in arrays:
        if isinstance(a, np.ndarray) and a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            return "an array with NaN or inf"
        if isinstance(a, float) and not math.isfinite(a):
            return "a NaN or inf"
    return None


def _check_api_result(name: str, result: Any, kwargs: dict[str, Any]) -> str | None:
    """Silent no-ops: a normal return without what was asked for."""
    if name.startswith("propagate") and not name.startswith("propagate_ensemble"):
        t = np.atleast_1d(np.asarray(kwargs["t"], dtype=float))
        if result.sizes["time"] != t.size:
            return f"returned {result.sizes['time']} samples for {t.size} times"
    if name in _RUNS_OF_THREE and hasattr(result, "sizes") and result.sizes.get("time") != 3:
        return f"returned {result.sizes.get('time')} samples for 3 times"
    if name.startswith("propagate_ensemble") and result is None:
        return "no ensemble result"
    if name == "io.write+read" and result.sizes.get("time", 0) == 0:
        return "wrote nothing"
    if name == "aem.write_aem" and not Path(result).stat().st_size:
        return "an empty AEM file"
    return None


def _raw_warning(w: warnings.WarningMessage) -> bool:
    """A warning of a library the package calls, not the package's own (ERFA's "dubious
    year", astropy's polar motion, numpy's "divide by zero encountered in log")."""
    from astropy.utils.exceptions import AstropyWarning
    from erfa import ErfaWarning

    if issubclass(w.category, (ErfaWarning, AstropyWarning)):
        return True
    return issubclass(w.category, RuntimeWarning) and "encountered in" in str(w.message)


def test_fuzz_public_api(tmp_path_factory, capsys, monkeypatch):
    tmp = tmp_path_factory.mktemp("fuzz_api")
    monkeypatch.chdir(tmp)  # a bad value that is a valid relative name ("1e-8") writes here
    targets = _api_targets(tmp)
    io.write(targets["io.write+read"][1]["ds"], tmp / "w.nc")
    _fuzz_api(targets, tmp, N_API, "public API", capsys)


def test_fuzz_closed_loop_api(tmp_path_factory, capsys, monkeypatch):
    """The closed-loop API of issues 24-26 (actuators, spacecraft, command schedules, flight
    software, control laws, sensors, the MEKF), each constructed from fuzzed arguments and
    run, so a value accepted by a constructor and refused (or not) only in the run is caught
    where it surfaces."""
    tmp = tmp_path_factory.mktemp("fuzz_closed_loop_api")
    monkeypatch.chdir(tmp)
    _fuzz_api(_closed_loop_targets(tmp), tmp, N_CLOSED_LOOP_API, "closed-loop API", capsys)


def _fuzz_api(targets, tmp: Path, n: int, title: str, capsys) -> None:
    counts: Counter = Counter()
    failures: list[str] = []
    if ONLY:
        targets = {k: v for k, v in targets.items() if re.search(ONLY, k)}
    names = sorted(targets)
    seen = [0]
    sigs: Counter = Counter()  # distinct raw exceptions: target, type, where
    slow: list[str] = []

    @_settings(n)
    @given(
        name=st.sampled_from(names),
        data=st.data(),
    )
    def run(name, data):
        func, valid = targets[name]
        kwargs = dict(valid)
        n_bad = data.draw(st.integers(1, 2))
        keys = sorted(kwargs)
        for _ in range(n_bad):
            k = data.draw(st.sampled_from(keys))
            kwargs[k] = data.draw(_bad())
        if name in ("io.write+read", "aem.write_aem", "io.read", "aem.read") and data.draw(
            st.booleans()
        ):
            kwargs["path"] = data.draw(st.sampled_from([
                None, 3, "a\x00b", tmp / ("x" * 300), tmp, tmp / "sub/", tmp / "nodir" / "f",
                tmp / "w.nc" / "under_a_file", "/proc/version", tmp / "ok.out",
            ]))  # fmt: skip
        seen[0] += 1
        counts["tried"] += 1
        raw_warnings: list[str] = []
        clean = False
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                warnings.simplefilter("error", np.exceptions.ComplexWarning)
                try:
                    with guard(f"{name}({_short(kwargs)})"), _time_limit(TIME_LIMIT):
                        result = func(**kwargs)
                finally:
                    raw_warnings = [
                        f"{w.category.__name__}: {w.message}" for w in caught if _raw_warning(w)
                    ]
        except (AttitudeError, OrbitError):
            counts["clean error"] += 1
            result = clean = None
        except KeyboardInterrupt:
            counts["slow (interrupted after 20 s)"] += 1
            slow.append(f"{name}({_short(kwargs)})")
            return
        except BaseException as exc:
            counts["other"] += 1
            counts["raw exceptions"] += 1
            tb = "".join(traceback.format_exception(exc)[-3:])
            where = traceback.extract_tb(exc.__traceback__)[-1]
            sig = f"{name}: {type(exc).__name__} at {Path(where.filename).name}:{where.lineno}"
            sigs[sig] += 1
            if sigs[sig] == 1:  # the first example of each distinct failure
                failures.append(f"{name}({_short(kwargs)}): {type(exc).__name__}: {exc}\n{tb}")
            return
        if raw_warnings:
            counts["other"] += 1
            counts["raw warnings"] += 1
            sig = f"{name}: {raw_warnings[0][:60]}"
            sigs[sig] += 1
            if sigs[sig] == 1:
                failures.append(f"{name}({_short(kwargs)}): raw warning {raw_warnings[0]}")
        if clean is None:  # a clean error
            return
        counts["ok"] += 1
        problem = _check_api_result(name, result, kwargs)
        nan = _nonfinite(result)
        with contextlib.suppress(Exception):
            result.close()
        if problem:
            counts["other"] += 1
            counts["silent no-ops"] += 1
            failures.append(f"{name}({_short(kwargs)}): silent no-op: {problem}")
        if nan:
            counts["other"] += 1
            counts["silent NaN/inf"] += 1
            sig = f"{name}: silent NaN: {nan}"
            sigs[sig] += 1
            if sigs[sig] == 1:
                failures.append(f"{name}({_short(kwargs)}): silent NaN/inf: {nan}")

    # Every target once with its valid arguments, before any time limit: compiles the kernels
    # (an interrupt inside numba's compiler leaves its dispatcher unusable in this process).
    for func, valid in targets.values():
        with contextlib.suppress(Exception), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = func(**valid)
            with contextlib.suppress(Exception):
                r.close()
    guard = _Watchdog(tmp)
    try:
        run()
    finally:
        guard.close()
    temps = _temps(tmp) + _own_temps()
    _report(capsys, title, counts, f", temporary files left {len(temps)}" + _figures(counts))
    if slow:
        _report(
            capsys,
            f"{title}: calls interrupted after 20 s",
            Counter(),
            "\n  " + "\n  ".join(slow),
        )
    assert not temps, temps
    assert not failures, (
        "\n".join(f"{n} x {k}" for k, n in sigs.most_common())
        + "\n\n"
        + ("\n\n".join(failures[:10]))
    )


def _short(kwargs: dict[str, Any]) -> str:
    parts = []
    for k, v in kwargs.items():
        r = repr(v)
        parts.append(f"{k}={r[:60]}{'...' if len(r) > 60 else ''}")
    return ", ".join(parts)


# ------------------------------------------------------------------------------------------------
# 3. interruptions
# ------------------------------------------------------------------------------------------------

_LONG = {
    "dop853": ("paper_torque_free.toml", {"stop = 20.0": "stop = 2000.0"}, []),
    "spinning": (
        "paper_torque_free.toml",
        {
            "stop = 20.0": "stop = 2000.0",
            "step = 0.01": "step = 1000.0",
            "Q = [0.3, -0.848528, 0.141421, -1.5]": "Q = [300.0, -848.528, 141.421, -1500.0]",
        },
        [],
    ),
    "keplerian": ("paper_keplerian.toml", {"stop = 6000.0": "stop = 2000000.0"}, []),
    "splitting": (
        "paper_heavy_top.toml",
        {"stop = 20.0": "stop = 2000.0"},
        ["--method", "splitting", "--dt", "0.002"],
    ),
    "scipy": (
        "paper_torque_free.toml",
        {"stop = 20.0": "stop = 5000.0"},
        ["--method", "scipy:DOP853"],
    ),
    "exact": ("paper_torque_free.toml", {"stop = 20.0": "stop = 40000.0"}, ["--method", "exact"]),
    "ensemble": ("ensemble_paper_keplerian.toml", {"size = 1000": "size = 40000"}, []),
}


def _scenario_file(d: Path, kind: str) -> tuple[Path, list[str]]:
    name, repl, opts = _LONG[kind]
    text = (SCEN / name).read_text()
    for a, b in repl.items():
        assert a in text, (name, a)
        text = text.replace(a, b)
    p = d / f"{kind}.toml"
    p.write_text(text)
    return p, opts


def test_fuzz_interruptions(tmp_path_factory, capsys):
    counts: Counter = Counter()
    failures: list[str] = []
    latencies: list[float] = []
    by_kind: dict[str, list[float]] = {}
    work = tmp_path_factory.mktemp("fuzz_sig")
    seen = [0]

    @_settings(N_INTERRUPTS)
    @given(
        kind=st.sampled_from(sorted(_LONG)),
        sig=st.sampled_from(["SIGINT"] * 6 + ["SIGTERM"] * 3 + ["SIGKILL"]),
        delay=st.floats(0.0, 3.0),
        previous=st.booleans(),
    )
    def run(kind, sig, delay, previous):
        seen[0] += 1
        d = work / f"s{seen[0]}"
        d.mkdir()
        scen, opts = _scenario_file(d, kind)
        out = d / "out.nc"
        if previous:
            out.write_bytes(b"previous result")
        proc = subprocess.Popen(
            [sys.executable, "-m", "attitude", "run", str(scen), "-o", str(out), "-q",
             "--progress", "always", *opts],
            cwd=d, env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        )  # fmt: skip
        err_chunks: list[bytes] = []
        ready = threading.Event()
        done_at: list[float] = []  # when the progress report said the run was complete
        eof = threading.Event()
        finished = re.compile(rb"100\.0%|\b(\d+)/\1 members done")

        def reader():
            tail = b""
            while True:
                b = proc.stderr.read(1)
                if not b:
                    break
                err_chunks.append(b)
                tail = (tail + b)[-64:]
                if b in (b"[", b"e"):  # a progress bar, or the ensemble's progress lines
                    ready.set()
                if not done_at and finished.search(tail):
                    done_at.append(time.monotonic())
            eof.set()  # stderr closed: the process is exiting
            ready.set()

        threading.Thread(target=reader, daemon=True).start()
        ready.wait(180)
        time.sleep(delay)
        alive = proc.poll() is None and not eof.is_set()
        sent = time.monotonic()
        if alive:
            proc.send_signal(getattr(signal, sig))
        try:
            proc.wait(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            failures.append(f"{kind} {sig}: still running 120 s after the signal")
            return
        latency = time.monotonic() - sent
        time.sleep(0.05)
        err = b"".join(err_chunks).decode(errors="replace")
        counts["tried"] += 1
        code = proc.returncode
        problem = None
        if "Traceback" in err:
            problem = "traceback"
        elif not alive:
            counts["finished before the signal"] += 1
            counts[f"  ({kind} finished before the signal)"] += 1
            if code != 0:
                problem = f"exit {code} without a signal"
        elif sig == "SIGKILL":
            counts["killed"] += 1
            if out.exists() and out.read_bytes() != (b"previous result" if previous else b""):
                with contextlib.suppress(Exception):
                    with io.read(out, load=False) as ds:
                        if ds.attrs.get("run_status") != "complete":
                            problem = "a killed run left a partial file under the final name"
            # the next run to the same path removes the killed run's temporary file
            r = subprocess.run(
                [sys.executable, "-m", "attitude", "run", str(SCEN / "paper_torque_free.toml"),
                 "-o", str(out), "--stop", "1", "-q"],
                cwd=d, env=ENV, capture_output=True, timeout=300,
            )  # fmt: skip
            if r.returncode != 0:
                problem = f"the run after a SIGKILL failed: {r.stderr[-300:]!r}"
        else:
            if code == 130:
                latencies.append(latency)
                by_kind.setdefault(kind, []).append(latency)
                counts["interrupted (exit 130)"] += 1
                if "after" in err and "was written" in err:
                    counts["interrupted after the output was complete"] += 1
                elif previous:
                    if out.read_bytes() != b"previous result":
                        problem = "the previous output was replaced by an interrupted run"
                elif out.exists():
                    problem = "an interrupted run left an output file"
            elif code == 0:
                # Ignored only once the command has finished: the run must have been complete
                # (its progress at 100 %) when the signal was sent.
                counts["finished (signal after the run, ignored)"] += 1
                if not done_at or sent < done_at[0]:
                    problem = (
                        f"the signal was lost: sent during the run, exit 0 {latency:.2f} s later"
                    )
            else:
                problem = f"exit {code} after {sig} (expected 130)"
        temps = _temps(d)
        if temps:
            problem = (problem or "") + f" temporary files left: {temps}"
        if problem:
            counts["other"] += 1
            failures.append(f"{kind} {sig} delay {delay:.2f}: {problem}\n{err[-500:]}")

    run()
    lat = np.array(latencies) if latencies else np.array([math.nan])
    _report(
        capsys,
        "interruptions",
        counts,
        f"; signal-to-exit latency of the interrupted runs median {np.median(lat):.2f} s, "
        f"max {np.max(lat):.2f} s ("
        + ", ".join(f"{k} {np.median(v):.2f}/{np.max(v):.2f}" for k, v in sorted(by_kind.items()))
        + " s median/max)",
    )
    assert not failures, "\n\n".join(failures[:10])

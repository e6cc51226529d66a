"""Every kind of file the package writes is read by every reader of the package (issue 43).

Single runs and ensembles, rigid bodies, open loop (wheel commands) and closed loop (flight
software, with and without sensors and the MEKF), written by ``io.write``, by a scenario's
``run_to_file``, by ``propagate_ensemble(path=...)`` and by ``run_scenario``: each is read by
``attitude.io.read`` and by ``attitude info``, ``attitude plot`` and ``attitude export
--ccsds-aem``, which must succeed, or, where they cannot apply (an AEM of a whole ensemble, of
an ensemble's final states or statistics), end with a clear one-line error and exit code 2,
never a traceback or "truncated, corrupt". The runs are tiny: seconds of simulated time."""

from __future__ import annotations

import numpy as np
import pytest

import attitude
from attitude import canonical, frames, io, scenario
from attitude.actuators import ReactionWheel
from attitude.cli import main
from attitude.control import MRPFeedback
from attitude.ensemble import propagate_ensemble, run_scenario
from attitude.estimation import MEKF
from attitude.results import time_unit
from attitude.sensors import Gyro, StarTracker
from attitude.software import FlightSoftware

pytest.importorskip("matplotlib")

JS = 0.08
BODY = [900.0, 800.0, 600.0]
T = np.linspace(0.0, 4.0, 5)
N = 3

_WHEELS = "".join(
    f"""
[[spacecraft.wheels]]
axis = {np.eye(3)[k].tolist()}
inertia = {JS}
inertia_unit = "kg m2"
speed = {10.0 * (k + 1)}
speed_unit = "rad/s"
max_torque = 0.2
max_torque_unit = "N m"
"""
    for k in range(3)
)
_HEAD = f"""
[scenario]
name = "tiny"
[body]
inertia = {BODY}
inertia_unit = "kg m2"
[initial_state]
form = "body_rates"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.001, -0.002, 0.003]
omega_unit = "rad/s"
[time]
start = 0.0
stop = 4.0
step = 1.0
unit = "s"
[integrator]
method = "dop853"
"""
_SOFTWARE = """
[software]
period = 0.5
guidance = "inertial"
control = "mrp_feedback"
K = 100.0
P = 300.0
"""
_SENSORS = """
[[software.sensors]]
type = "gyro"
arw = 1.45e-5
arw_unit = "rad/s(1/2)"
seed = 1
[[software.sensors]]
type = "star_tracker"
noise = [5e-5, 1.5e-4]
noise_unit = "rad"
seed = 2
[software.estimator]
type = "mekf"
"""
_COMMANDS = """
[commands]
times = [0.0, 2.0]
times_unit = "s"
wheel_torque = [[0.1, -0.1, 0.0], [0.0, 0.05, -0.05]]
wheel_torque_unit = "N m"
"""
_ENSEMBLE = f"""
[ensemble]
size = {N}
seed = 5
attitude_error = 0.1
attitude_error_unit = "deg"
rate_error = 0.001
rate_error_unit = "deg/s"
inertia_error = 0.02
"""


def _craft():
    wheels = [ReactionWheel(np.eye(3)[k], JS, speed=10.0 * (k + 1), max_torque=0.2)
              for k in range(3)]  # fmt: skip
    return attitude.Spacecraft(attitude.RigidBody(BODY, units="kg m2"), wheels)


def _software(sensors: bool):
    kw = {}
    if sensors:
        kw = dict(sensors=[Gyro(1.45e-5), StarTracker([5e-5, 1.5e-4])], estimator=MEKF())
    return FlightSoftware(0.5, guidance=frames.inertial(), control=MRPFeedback(100.0, 300.0), **kw)


def _states(craft, n=N):
    rng = np.random.default_rng(0)
    q = attitude.quaternion.from_rotation_vector(1e-3 * rng.normal(size=(n, 3)))
    w = [0.001, -0.002, 0.003] + 1e-4 * rng.normal(size=(n, 3))
    return q, canonical.momenta_from_angular_velocity(q, w, craft)


# kind -> (writes the file at path, is an ensemble, what export --ccsds-aem --member 0 gives)
def _single_rigid(p):
    body = attitude.RigidBody([1.25, 1.0, 0.75])
    Q0 = canonical.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.1, 0.0, 0.5], body)
    io.write(attitude.propagate(body, [1.0, 0, 0, 0], Q0, T, method="dop853"), p)


def _scenario_file(extra):
    return lambda p: scenario.loads(_HEAD + extra).run_to_file(p)


def _single_closed_loop_in_memory(p):
    craft = _craft()
    q, Q = _states(craft, 1)
    ds = attitude.propagate(craft, q[0], Q[0], T, software=_software(True), method="dop853")
    io.write(ds, p)


def _ensemble_rigid(output):
    def write(p):
        body = [1.25, 1.0, 0.75]
        q = attitude.quaternion.from_rotation_vector(1e-2 * np.eye(3))
        Q = canonical.momenta_from_angular_velocity(q, [0.1, 0.0, 0.5], body)
        Q0 = canonical.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.1, 0.0, 0.5], body)
        nominal = ([1.0, 0, 0, 0], Q0)
        propagate_ensemble(body, q, Q, T, path=p, output=output, nominal=nominal,
                           method="dop853").close()  # fmt: skip

    return write


def _ensemble_craft(output="samples", software=None, commands=None):
    def write(p):
        craft = _craft()
        q, Q = _states(craft)
        propagate_ensemble(craft, q, Q, T, path=p, output=output, software=software,
                           commands=commands, method="dop853", seed=3).close()  # fmt: skip

    return write


def _scenario_ensemble(extra):
    return lambda p: run_scenario(scenario.loads(_HEAD + extra + _ENSEMBLE), p)


SCHEDULE = attitude.CommandSchedule([0.0, 2.0], wheel_torque=[[0.1, -0.1, 0.0], [0.0, 0.05, -0.05]])
KINDS = {
    "single rigid (io.write)": (_single_rigid, False, "ok"),
    "single rigid (scenario)": (_scenario_file(""), False, "ok"),
    "single open loop (scenario)": (_scenario_file(_WHEELS + _COMMANDS), False, "ok"),
    "single closed loop (scenario)": (_scenario_file(_WHEELS + _SOFTWARE), False, "ok"),
    "single closed loop, sensors (scenario)": (
        _scenario_file(_WHEELS + _SOFTWARE + _SENSORS), False, "ok"),
    "single closed loop, sensors (io.write)": (_single_closed_loop_in_memory, False, "ok"),
    "ensemble rigid": (_ensemble_rigid("samples"), True, "ok"),
    "ensemble rigid, final": (_ensemble_rigid("final"), True, "final state"),
    "ensemble rigid, statistics": (_ensemble_rigid("statistics"), True, "statistics"),
    "ensemble rigid (scenario)": (_scenario_ensemble(""), True, "ok"),
    "ensemble open loop": (_ensemble_craft(commands=SCHEDULE), True, "ok"),
    "ensemble closed loop": (_ensemble_craft(software=_software(False)), True, "ok"),
    "ensemble closed loop, sensors": (_ensemble_craft(software=_software(True)), True, "ok"),
    "ensemble closed loop, sensors, final": (
        _ensemble_craft("final", software=_software(True)), True, "final state"),
    "ensemble closed loop, sensors (scenario)": (
        _scenario_ensemble(_WHEELS + _SOFTWARE + _SENSORS), True, "ok"),
}  # fmt: skip


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("roundtrip")


def _file(folder, kind):
    """The file of this kind (written once per module)."""
    p = folder / f"f{list(KINDS).index(kind)}.nc"
    if not p.exists():
        KINDS[kind][0](p)
    return p


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_reader_reads_every_kind_of_file(kind, folder, tmp_path, capsys):
    path = _file(folder, kind)
    _, ensemble, aem = KINDS[kind]
    ds = io.read(path)
    assert ds.sizes["time"] >= 1 and ("member" in ds.dims) == ensemble
    assert "q" in ds or "pointing_error_percentiles" in ds

    code, out, err = _run(capsys, "info", path)
    assert code == 0, err
    assert "status      complete" in out and "invariants  -" not in out

    png = tmp_path / "fig.png"
    code, out, err = _run(capsys, "plot", path, "-o", png)
    assert code == 0, err
    assert png.stat().st_size > 10_000  # a figure was drawn

    aem_path = tmp_path / "out.aem"
    member = ["--member", "0"] if ensemble else []
    if not ds.attrs.get("epoch"):  # (a CCSDS message needs dates and seconds)
        member += ["--epoch", "2024-01-01T00:00:00"]
    if str(time_unit(ds["time"])) == "1":  # a dimensionless run
        member += ["--time-unit-seconds", "1"]
    code, out, err = _run(capsys, "export", path, "--ccsds-aem", aem_path, *member)
    if aem == "ok":
        assert code == 0, err
        text = aem_path.read_text()
        assert text.count("\n") > T.size and "QUATERNION" in text
    else:  # an AEM needs the attitude history of one run
        assert code == 2 and not aem_path.exists()
        assert err.startswith("attitude: error:") and err.count("\n") == 1, err
        assert aem in err and "truncated" not in err
    if ensemble:  # the whole ensemble: one member has to be chosen
        code, out, err = _run(capsys, "export", path, "--ccsds-aem", aem_path, *member[2:])
        assert code == 2 and err.count("\n") == 1 and "truncated" not in err, err
        assert ("--member" in err) == (aem == "ok"), err


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_of_file_is_chunked_compressed_and_checksummed(kind, folder):
    """Issue 43: every variable along a growing dimension (time, tick; member in an ensemble
    file) is in zlib chunks with a Fletcher-32 checksum, bounded in size along that dimension
    (4096 samples or ticks; about 1 MiB of members); the static arrays one checksummed chunk."""
    path = _file(folder, kind)
    nc = _layout(path)
    grown = 0
    for name, v in nc.variables.items():
        if not v.dimensions:
            continue
        f = v.filters()
        assert f["zlib"] and f["shuffle"] and f["fletcher32"], (name, f)
        chunks = v.chunking()
        assert chunks != "contiguous", name
        growing = ("member",) if "member" in nc.dimensions else ("time", "tick")
        along = [d for d in growing if d in v.dimensions]
        if along == ["member"]:
            grown += 1
            assert 8 * int(np.prod(chunks)) <= 2**21, (name, chunks)
        elif along:
            grown += 1
            assert chunks[v.dimensions.index(along[0])] == 4096, (name, chunks)
        else:  # a static array (an ensemble's shared times): one chunk
            assert chunks == list(v.shape), (name, chunks)
    assert grown >= 5


_LAYOUT = """
import json, sys, netCDF4
with netCDF4.Dataset(sys.argv[1]) as nc:
    out = {"dimensions": list(nc.dimensions), "variables": {
        n: {"dimensions": list(v.dimensions), "shape": list(v.shape), "str": v.dtype is str,
            "filters": v.filters() if v.dtype is not str else {},
            "chunking": v.chunking() if v.dtype is not str else "contiguous"}
        for n, v in nc.variables.items()}}
print(json.dumps(out))
"""


class _Var:
    def __init__(self, d):
        self.dimensions = tuple(d["dimensions"])
        self.shape = tuple(d["shape"])
        self.dtype = str if d["str"] else float
        self._f, self._c = d["filters"], d["chunking"]

    def filters(self):
        return self._f

    def chunking(self):
        return self._c


class _Layout:
    def __init__(self, d):
        self.dimensions = d["dimensions"]
        self.variables = {n: _Var(v) for n, v in d["variables"].items()}


def _layout(path):
    """The file's variables, dimensions, filters and chunks, read by netCDF4 in a process of
    its own: the HDF5 library of a test worker has read corrupted files on purpose (test_cli)
    and is not thread-safe beside Dask's threads; a crash here would take the worker down."""
    import json
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _LAYOUT, str(path)], capture_output=True,
                         text=True, check=True, timeout=120)  # fmt: skip
    return _Layout(json.loads(out.stdout))

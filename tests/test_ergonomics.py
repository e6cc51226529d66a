"""Python ergonomics of issue 16: rates as deg/s Quantities, progress bars that advance during
the run without changing the results, Euler angles labelled by position, a clear message when
the plot extra is missing, and the Dask example of docs/ensemble.md as a script."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
from astropy import units as u

import attitude.accessor  # noqa: F401 - registers ds.attitude
from attitude import canonical as C
from attitude import quaternion as qt
from attitude.body import RigidBody
from attitude.errors import AttitudeTypeError
from attitude.potentials import HeavyTop
from attitude.propagate import propagate

ROOT = Path(__file__).resolve().parents[1]
Q_PAPER = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])
P_PAPER = np.array([0.3, -0.848528, 0.141421, -1.5])


def test_rates_in_deg_per_s():
    body = RigidBody([100.0, 200.0, 250.0], units="kg m2")
    q = qt.from_euler([0.3, 1.0, 0.2], "313")
    w_deg = np.array([1.0, -2.0, 0.5])
    Q_deg = C.momenta_from_angular_velocity(q, w_deg * u.deg / u.s, body)
    Q_rad = C.momenta_from_angular_velocity(q, np.radians(w_deg), body)
    np.testing.assert_allclose(Q_deg, Q_rad, rtol=1e-15)
    # rpm, rad/min: any angular rate; the angular velocity read back is the one given
    Q_rpm = C.momenta_from_angular_velocity(q, [0.1, 0.2, 0.3] * u.Unit("cycle / min"), body)
    w = C.angular_velocity(q, Q_rpm, body)
    np.testing.assert_allclose(w, 2 * np.pi * np.array([0.1, 0.2, 0.3]) / 60, rtol=1e-14)
    # a Quantity inertia as well
    Q_q = C.momenta_from_angular_velocity(q, w_deg * u.deg / u.s, [100, 200, 250] * u.kg * u.m**2)
    np.testing.assert_array_equal(Q_q, Q_deg)
    # angular momentum as a Quantity (N m s)
    g = body.inertia * np.radians(w_deg)
    Qg = C.momenta_from_body_angular_momentum(q, g * u.N * u.m * u.s)
    np.testing.assert_allclose(Qg, Q_rad, rtol=1e-15)
    # a dimensionless body has no time unit: deg/s is refused with the fix in the message
    with pytest.raises(AttitudeTypeError, match=r"omega.*dimensionless.*kg m2"):
        C.momenta_from_angular_velocity(q, w_deg * u.deg / u.s, [1.0, 2.0, 2.5])
    with pytest.raises(AttitudeTypeError, match="omega"):
        C.momenta_from_angular_velocity(q, w_deg * u.m / u.s, body)


class _Recorder:
    """Stands in for tqdm: records every update."""

    instances: ClassVar[list] = []

    def __init__(self, total, **kw):
        self.total, self.n, self.updates, self.closed = total, 0, [], False
        self.initial = self.last_print_n = 0
        self.dynamic_miniters = False
        _Recorder.instances.append(self)

    def update(self, k):
        self.n += k
        self.updates.append(self.n)

    def reset(self, total=None):  # the first report restarts the clock (attitude._ProgressBar)
        self.n = 0

    def refresh(self):
        self.updates.append(self.n)

    def close(self):
        self.closed = True


def test_progress_bar_advances_during_the_run(monkeypatch):
    import tqdm.auto

    t = np.linspace(0.0, 20.0, 2001)
    pot = HeavyTop(0.5, [1, 0, 0])
    with pytest.warns(UserWarning, match="projected"):
        ref = propagate([1.25, 1.0, 0.75], Q_PAPER, P_PAPER, t, pot, rtol=1e-12, atol=1e-14)
    monkeypatch.setattr(tqdm.auto, "tqdm", _Recorder)
    _Recorder.instances.clear()
    with pytest.warns(UserWarning, match="projected"):
        ds = propagate([1.25, 1.0, 0.75], Q_PAPER, P_PAPER, t, pot, rtol=1e-12, atol=1e-14,
                       progress=True)  # fmt: skip
    (bar,) = _Recorder.instances
    assert bar.total == 2001 and bar.closed
    assert len(bar.updates) >= 100  # ~200 reports, not one at the end
    assert bar.updates == sorted(bar.updates) and bar.updates[-1] == 2001
    for name in ref.data_vars:  # results do not depend on the chunking
        assert ds[name].values.tobytes() == ref[name].values.tobytes(), name
    assert ds.attrs["n_steps"] == ref.attrs["n_steps"]
    # a callable keeps working, also called during the run
    calls = []
    with pytest.warns(UserWarning, match="projected"):
        ds2 = propagate([1.25, 1.0, 0.75], Q_PAPER, P_PAPER, t, pot, rtol=1e-12, atol=1e-14,
                        progress=lambda n, m, tt: calls.append((n, m, tt)))  # fmt: skip
    assert len(calls) >= 100 and calls[-1][:2] == (2001, 2001) and calls[-1][2] == 20.0
    assert ds2.q.values.tobytes() == ref.q.values.tobytes()
    with pytest.raises(AttitudeTypeError, match="progress"):
        propagate([1.25, 1.0, 0.75], [1, 0, 0, 0], [0, 1, 0, 0], t, progress="yes")


def test_progress_bar_real_tqdm_output(capsys):
    t = np.linspace(0.0, 5.0, 501)
    propagate([1.25, 1.0, 0.75], [1, 0, 0, 0], [0, 0.2, 0.4, 0.1], t, progress=True)
    err = capsys.readouterr().err
    assert "propagate" in err and "501/501" in err and "100%" in err


def test_euler_angles_labelled_by_position():
    q0 = qt.from_euler([0.3, 1.0, 0.2], "313")
    body = RigidBody([1.0, 2.0, 2.5])
    ds = propagate(body, q0, C.momenta_from_angular_velocity(q0, [0.1, 0.2, 0.3], body),
                   np.linspace(0, 1, 3))  # fmt: skip
    for seq in ("313", "321", "121"):
        a = ds.attitude.euler_angles(seq)
        assert list(a.angle.values) == ["angle_1", "angle_2", "angle_3"]  # no collisions
        assert a.attrs["sequence"] == seq
        np.testing.assert_allclose(qt.from_euler(a.values, seq) * np.sign(ds.q.values[:, :1]),
                                   ds.q.values * np.sign(qt.from_euler(a.values, seq)[:, :1]),
                                   atol=1e-14)  # fmt: skip
    a = ds.attitude.euler_angles("313")
    assert float(a.sel(angle="angle_2")[0]) == pytest.approx(1.0, abs=1e-14)


def test_plot_without_matplotlib_says_how_to_install(tmp_path, monkeypatch, capsys):
    from attitude import io
    from attitude.cli import main

    ds = propagate([1.25, 1.0, 0.75], [1, 0, 0, 0], [0, 0.2, 0.4, 0.1], [0.0, 1.0])
    path = io.write(ds, tmp_path / "r.nc")
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    assert main(["plot", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'attitude[plot]'" in err
    assert not (tmp_path / "r.png").exists()


def test_docs_dask_example_runs_as_a_script(tmp_path):
    pytest.importorskip("distributed")
    text = (ROOT / "docs/ensemble.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    (code,) = [b for b in blocks if "LocalCluster(" in b]
    assert 'if __name__ == "__main__":' in code
    script = tmp_path / "mc_dask.py"
    script.write_text(code.replace("n = 1000", "n = 64"))
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300, start_new_session=True)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert "'member': 64" in r.stdout and (tmp_path / "mc.nc").exists()

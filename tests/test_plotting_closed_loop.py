"""The closed-loop panels of `attitude plot`: chosen when a run holds their variables and not
otherwise, and drawing the Dataset's values converted (rpm = rad/s · 60/2π, deg, ±3σ = 3 ·
sqrt(diag P), the limits the actuators were given) — asserted on the artists' data, not on
pixels. Short runs of the shipped closed-loop scenarios, one with modes, sensors and the MEKF,
one with thrusters on an open-loop schedule.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from astropy import units as u

import attitude
from attitude import frames, io, scenario
from attitude.actuators import CommandSchedule, ReactionWheel, Thruster
from attitude.control import MRPFeedback, RateDamping
from attitude.errors import AttitudeValueError
from attitude.estimation import MEKF
from attitude.plotting import CLOSED_LOOP_PANELS, plot_result
from attitude.plotting._closed_loop import guided_modes, mode_spans, outage_spans
from attitude.plotting._common import run_title
from attitude.sensors import Gyro, StarTracker
from attitude.software import After, FlightSoftware, Mode

ROOT = Path(__file__).resolve().parents[1]
RPM = 60.0 / (2.0 * np.pi)


@pytest.fixture(scope="module")
def rw_run():
    """Basilisk's wheel scenario, its first 40 s (the wheels at their torque limit)."""
    sc = scenario.load(ROOT / "scenarios/rw_inertial_pointing.toml")
    sc.t = sc.t[:81]
    return sc.run()


@pytest.fixture(scope="module")
def bdot_run():
    sc = scenario.load(ROOT / "scenarios/cubesat_bdot.toml")
    sc.t = sc.t[:31]  # 5 min
    return sc.run()


@pytest.fixture(scope="module")
def mekf_run():
    """Rate damping, then inertial pointing after 10 s, on a gyro and a star tracker through
    the MEKF (docs/sensors.md's sensors), 40 s at 2 Hz."""
    rpm = 2 * np.pi / 60
    wheels = [
        ReactionWheel(a, 50 / (6000 * rpm), speed=s * rpm, max_torque=0.2, max_speed=6000 * rpm)
        for a, s in zip(np.eye(3), (100, 200, 300), strict=True)
    ]
    craft = attitude.Spacecraft(attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2"), wheels)
    q0 = attitude.quaternion.from_mrp([0.1, 0.2, -0.3])
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    gyro = Gyro(arw=0.05 * u.deg / u.hour**0.5, rrw=2e-9 * u.rad / u.s**1.5,
                bias=[3.0, -2.0, 1.5] * u.deg / u.hour, seed=1)  # fmt: skip
    tracker = StarTracker([6, 45] * u.arcsec, boresight=[0.0, 0.6, 0.8], rate=2 * u.Hz, seed=2)
    modes = [
        (None, Mode(control=RateDamping(30.0), name="damping")),
        (After(10.0), Mode(frames.inertial(), MRPFeedback(3.5, 30.0), name="pointing")),
    ]
    fsw = FlightSoftware(0.5, modes=modes, sensors=[gyro, tracker], estimator=MEKF())
    return attitude.propagate(craft, q0, Q0, np.linspace(0.0, 40.0, 81), software=fsw)


def _lines(ax) -> dict:
    return {ln.get_label(): ln for ln in ax.get_lines()}


def _hlines(ax) -> list[float]:
    """The y of the horizontal dashed lines (limits, bounds drawn with axhline)."""
    out = []
    for ln in ax.get_lines():
        x, y = ln.get_xdata(), ln.get_ydata()
        if ln.get_linestyle() == "--" and len(y) == 2 and y[0] == y[1] and list(x) == [0, 1]:
            out.append(float(y[0]))
    return sorted(out)


def test_panels_chosen_from_the_variables(rw_run, bdot_run, mekf_run):
    names = lambda fig: [a.get_ylabel() for a in fig.axes]  # noqa: E731
    fig = plot_result(rw_run)  # no orbit, no frame: the engineer's figure all the same
    assert names(fig) == ["attitude error [deg]", "wheel speed [rpm]", "motor torque [N m]"]
    plt.close(fig)
    fig = plot_result(bdot_run)  # no guidance: |ω| instead of an attitude error
    assert names(fig) == ["|ω| [deg/s]", "ω, body axes [deg/s]", "dipole [A m²]"]
    plt.close(fig)
    fig = plot_result(mekf_run)  # a rate-damping mode, then pointing: |ω| too (issue 43)
    assert names(fig) == [
        "attitude error [deg]", "|ω| [deg/s]", "wheel speed [rpm]", "motor torque [N m]",
        "estimation error [arcsec]", "gyro bias [deg/h]",
    ]  # fmt: skip
    plt.close(fig)
    # a run without actuators or software: none of them, and asked for, a clear error
    free = attitude.propagate([1.0, 2.0, 2.5], [1, 0, 0, 0], [0, 0.2, 0.1, 0.0], [0.0, 1.0, 2.0])
    fig = plot_result(free, layout="engineer", frame="inertial")
    assert not {a.get_ylabel() for a in fig.axes} & set(names(plot_result(mekf_run)))
    plt.close("all")
    for p in set(CLOSED_LOOP_PANELS) - {"rate_norm"}:
        with pytest.raises(AttitudeValueError, match="cannot be drawn"):
            plot_result(free, layout="engineer", panels=[p])
    for p in ("wheel_speeds", "wheel_torque", "estimation", "thrust"):
        with pytest.raises(AttitudeValueError, match="cannot be drawn"):
            plot_result(bdot_run, panels=[p])


def test_wheel_speeds_in_rpm_with_limits_and_saturation(rw_run):
    fig = plot_result(rw_run, panels=["wheel_speeds"])
    ax = fig.axes[0]
    lines = _lines(ax)
    for k in range(3):
        np.testing.assert_array_equal(
            lines[f"wheel{k + 1}"].get_ydata(), rw_run.wheel_speed.values[:, k] * RPM
        )
    np.testing.assert_allclose(_hlines(ax), [-6000.0, 6000.0], rtol=1e-12)  # the HR16's
    lo, hi = ax.get_ylim()
    assert lo < -6000 and hi > 6000  # in view: the wheels reach 1/6 of it here
    # the bars: over exactly the samples flagged at a limit (edges half-way between samples)
    t = rw_run.time.values
    bars = [c for c in ax.collections if c.get_paths()]
    flagged = rw_run.wheel_limit.values != 0
    assert flagged.any() and "torque limit" in ax.get_title(loc="left")
    covered = np.zeros_like(flagged)
    for k, bar in enumerate(bars):
        for p in bar.get_paths():
            x0, x1 = p.vertices[:, 0].min(), p.vertices[:, 0].max()
            w = round(float(1.0 - p.vertices[:, 1].max()) / 0.05)  # the row: the wheel
            covered[(t >= x0) & (t <= x1), w] = True
        assert k < 3
    np.testing.assert_array_equal(covered, flagged)
    plt.close(fig)


def test_motor_torques_with_the_limit_and_the_commands(rw_run):
    fig = plot_result(rw_run, panels=["wheel_torque"])
    ax = fig.axes[0]
    assert ax.get_ylabel() == "motor torque [N m]"
    lines = _lines(ax)
    for k in range(3):
        np.testing.assert_array_equal(lines[f"wheel{k + 1}"].get_ydata(),
                                      rw_run.wheel_torque.values[:, k])  # fmt: skip
    np.testing.assert_allclose(_hlines(ax), [-0.2, 0.2], rtol=1e-12)
    # the commands beyond the limit are drawn (dotted) where they differ from the applied
    dotted = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
    cmd = rw_run.wheel_torque_command.values
    assert np.abs(cmd).max() > 0.2 and dotted
    drawn = {tuple(np.round(ln.get_ydata()[:5], 12)) for ln in dotted}
    for k in range(3):
        if not np.allclose(cmd[:, k], rw_run.wheel_torque.values[:, k]):
            assert tuple(np.round(cmd[:5, k], 12)) in drawn
    plt.close(fig)


def test_control_error_and_modes(mekf_run):
    fig = plot_result(mekf_run, panels=["control_error", "wheel_speeds"])
    ax = fig.axes[0]
    lines = _lines(ax)
    seen = lines["as the software sees it (estimate)"].get_ydata()
    mode = mekf_run["mode"].values
    assert guided_modes(mekf_run).tolist() == [False, True]
    assert set(mode) == {0, 1}
    # the error angle in degrees at every tick of the guided mode, left out of the other
    ea = np.degrees(mekf_run.error_angle.values)
    np.testing.assert_array_equal(seen, np.where(mode == 1, ea, np.nan))
    np.testing.assert_array_equal(lines["as the software sees it (estimate)"].get_xdata(),
                                  mekf_run.tick.values)  # fmt: skip
    # the true error: the reference against truth = estimate ∘ exp(δθ/2), an angle that the
    # estimation error bounds: |true − seen| <= |δθ|
    true = lines["true"].get_ydata()
    dth = np.degrees(np.linalg.norm(mekf_run.estimation_error.values[:, :3], axis=1))
    ok = mode == 1
    assert np.all(np.abs(true[ok] - seen[ok]) <= dth[ok] * (1 + 1e-9) + 1e-12)
    pos = np.concatenate([seen[ok], true[ok]])
    assert ax.get_yscale() == ("log" if pos.max() > 30.0 * pos.min() else "linear")
    # the mode switch: the first tick at or after 10 s, a band per mode and a line on each panel
    switch = float(mekf_run.tick.values[np.argmax(mode == 1)])
    assert switch == 10.0
    assert [(a, m) for a, _, m in mode_spans(mekf_run)] == [(0.0, 0), (10.0, 1)]
    for a in fig.axes:
        xs = [ln.get_xdata()[0] for ln in a.get_lines() if ln.get_linestyle() == "--"
              and list(ln.get_ydata()) == [0, 1]]  # fmt: skip
        assert switch in xs
    assert [t.get_text() for t in ax.texts] == ["damping", "pointing"]
    plt.close(fig)


def test_estimation_error_inside_three_sigma(mekf_run):
    fig = plot_result(mekf_run, panels=["estimation", "gyro_bias"])
    ax, bx = fig.axes
    assert ax.get_ylabel() == "estimation error [arcsec]"
    arcsec = np.degrees(1.0) * 3600.0
    err = mekf_run.estimation_error.values
    sig = mekf_run.estimation_sigma.values
    lines = _lines(ax)
    dashed = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
    for k, c in enumerate("xyz"):
        np.testing.assert_allclose(lines[f"δθ {c}"].get_ydata(), err[:, k] * arcsec, rtol=1e-14)
        bound = 3.0 * sig[:, k] * arcsec  # 3 sqrt(diag P): estimation_sigma is sqrt(diag P)
        assert any(np.allclose(ln.get_ydata(), bound, rtol=1e-14) for ln in dashed)
        assert any(np.allclose(ln.get_ydata(), -bound, rtol=1e-14) for ln in dashed)
    # the fraction inside, said in the title, counted independently
    title = ax.get_title(loc="left")
    for c, n_in in zip("xyz", np.sum(np.abs(err[:, :3]) <= 3.0 * sig[:, :3], axis=0), strict=True):
        n = err.shape[0]  # the percentage rounded down to 0.1 %, in integers
        want = "100%" if n_in == n else f"{(1000 * n_in) // n / 10:.1f}%"
        assert f"{c} {want}" in title
    plt.close(fig)
    # issue 39: 99.7 % inside was shown as "100%": rounded down at 0.1 % now
    ds = mekf_run.copy(deep=True)
    out = ds.estimation_error.values.copy()
    out[n // 2, 0] = 1e3 * sig[n // 2, 0]  # one x tick far outside its bound
    ds["estimation_error"] = (ds.estimation_error.dims, out)
    fig = plot_result(ds, panels=["estimation"])
    n_in = int(np.sum(np.abs(out[:, 0]) <= 3.0 * sig[:, 0]))
    assert n_in == n - 1  # 79 of 80: 98.75 %, shown 98.7 % (rounded down)
    title = fig.axes[0].get_title(loc="left")
    assert f"x {(1000 * n_in) // n / 10:.1f}%" in title and "x 100%" not in title
    plt.close(fig)
    fig = plot_result(mekf_run, panels=["estimation", "gyro_bias"])
    ax, bx = fig.axes
    # the bias: the estimate and the truth (estimate + error) in deg/h; the truth is the gyro's
    deg_h = np.degrees(1.0) * 3600.0
    bl = _lines(bx)
    est = mekf_run.bias_estimate.values
    np.testing.assert_allclose(bl["estimate x"].get_ydata(), est[:, 0] * deg_h, rtol=1e-14)
    true = [ln for ln in bx.get_lines() if ln.get_linestyle() == "--" and len(ln.get_ydata()) > 2]
    truth = np.stack([ln.get_ydata() for ln in true], axis=1)
    np.testing.assert_allclose(truth, (est + err[:, 3:]) * deg_h, rtol=1e-12)
    np.testing.assert_allclose(truth[-1], [3.0, -2.0, 1.5], atol=0.05)  # b0 + the slow RRW
    plt.close(fig)


@pytest.mark.parametrize(
    "p, shown",
    [(0.997, "99.7%"), (0.9995, "99.9%"), (1 - 1e-15, "99.9%"), (1.0, "100%"),
     (0.9875, "98.7%"), (0.0, "0.0%"), (1 / 3, "33.3%"), (float("nan"), "n/a")],
)  # fmt: skip
def test_fraction_inside_is_never_rounded_up_to_100_percent(p, shown):
    from attitude.plotting._closed_loop import _percent_floor

    assert _percent_floor(p) == shown


def test_dipoles_and_rate_with_their_references(bdot_run):
    fig = plot_result(bdot_run, panels=["rate_norm", "dipoles"])
    ax, bx = fig.axes
    w = np.degrees(np.linalg.norm(bdot_run.omega.values, axis=1))
    np.testing.assert_allclose(_lines(ax)["|ω|"].get_ydata(), w, rtol=1e-14)
    # the orbital rate from the run's radius: 2π over the period of the TLE's mean motion
    n = next(ln for ln in ax.get_lines() if ln.get_label().startswith("orbital rate"))
    n_tle = 360.0 * 14.90036668 / 86400.0  # deg/s
    assert abs(n.get_ydata()[0] / n_tle - 1.0) < 5e-3
    lines = _lines(bx)
    for k in range(3):
        np.testing.assert_array_equal(lines[f"magnetorquer{k + 1}"].get_ydata(),
                                      bdot_run.dipole.values[:, k])  # fmt: skip
    np.testing.assert_array_equal(bdot_run.magnetorquer_max_dipole.values, [0.2, 0.2, 0.2])
    np.testing.assert_allclose(_hlines(bx), [-0.2, 0.2], rtol=1e-12)
    plt.close(fig)


def test_thrust_panel_of_an_open_loop_schedule():
    th = [Thruster([0.5, 0, 0], [0, 1, 0], 0.02), Thruster([-0.5, 0, 0], [0, -1, 0], 0.02)]
    craft = attitude.Spacecraft(attitude.RigidBody([10.0, 12.0, 8.0], units="kg m2"),
                                thrusters=th)  # fmt: skip
    t = np.linspace(0.0, 10.0, 101)
    cmd = CommandSchedule([0.0, 5.0], thrust=[[0.5, 0.2], [0, 0]])
    ds = attitude.propagate(craft, [1.0, 0, 0, 0], np.zeros(4), t, commands=cmd)
    fig = plot_result(ds)
    # no software: |ω| and ω (nothing to point at), then the actuators
    assert [a.get_ylabel() for a in fig.axes] == ["|ω| [deg/s]", "ω, body axes [deg/s]",
                                                  "thrust [mN]"]  # fmt: skip
    lines = _lines(fig.axes[2])
    np.testing.assert_allclose(lines["thruster1"].get_ydata(), ds.thruster_force.values[:, 0] * 1e3)
    assert lines["thruster1"].get_ydata().max() == pytest.approx(20.0)  # 0.02 N when firing
    assert [ln.get_ydata()[0] for ln in fig.axes[2].get_lines() if ln.get_linestyle() == "--"] \
        == [pytest.approx(20.0)]  # fmt: skip
    plt.close(fig)


def test_rate_error_and_torque_request_by_name(rw_run):
    fig = plot_result(rw_run, panels=["rate_error", "torque_request"])
    ax, bx = fig.axes
    assert (ax.get_ylabel(), bx.get_ylabel()) == ("rate error [deg/s]", "torque request [N m]")
    for k, c in enumerate("xyz"):
        dw = np.degrees(rw_run.rate_error.values[:, k])
        np.testing.assert_allclose(_lines(ax)[f"δω {c}"].get_ydata(), dw, rtol=1e-14)
        np.testing.assert_array_equal(_lines(bx)[f"L {c}"].get_ydata(),
                                      rw_run.torque_request.values[:, k])  # fmt: skip
        np.testing.assert_array_equal(_lines(bx)[f"L {c}"].get_xdata(), rw_run.tick.values)
    plt.close(fig)


def test_limits_off_scale_are_said(rw_run):
    """Wheels far below their speed limit: the limit is named in the title, not drawn at a
    scale that would flatten the speeds."""
    ds = rw_run.copy()
    ds["wheel_max_speed"] = ds["wheel_max_speed"] * 1000.0
    fig = plot_result(ds, panels=["wheel_speeds"])
    ax = fig.axes[0]
    assert _hlines(ax) == []
    assert "speed limit ±6e+06 rpm off scale" in ax.get_title(loc="left")
    plt.close(fig)


def test_cli_run_and_plot_of_a_short_closed_loop_scenario(tmp_path, capsys):
    from attitude.cli import main

    text = (ROOT / "scenarios/rw_inertial_pointing.toml").read_text()
    text = text.replace("stop = 600.0", "stop = 20.0")
    toml = tmp_path / "rw.toml"
    toml.write_text(text)
    nc = tmp_path / "rw.nc"
    assert main(["run", str(toml), "-o", str(nc)]) == 0
    out = tmp_path / "rw.png"
    assert main(["plot", str(nc), "-o", str(out)]) == 0
    assert out.stat().st_size > 20_000
    assert main(["plot", str(nc), "-o", str(out), "--panels", "wheel_speeds,control_error"]) == 0
    capsys.readouterr()
    assert main(["plot", str(nc), "-o", str(out), "--panels", "dipoles"]) == 2
    assert "dipoles cannot be drawn" in capsys.readouterr().err
    ds = io.read(nc)
    # the default recording: the tick in effect at each of the 41 samples (0.5 s apart; the
    # last tick of the 200 is at 19.9 s, in effect at 20 s)
    t = ds.time.values
    assert ds.sizes["tick"] == 41 == t.size and ds.attrs["n_ticks"] == 200
    np.testing.assert_allclose(ds.tick.values, np.minimum(t, 19.9), rtol=0, atol=1e-12)


def test_star_tracker_outages_are_bands_on_the_estimation_panel(mekf_run):
    """Ticks whose star tracker status is an exclusion (Sun 2, Earth 3) are outages, drawn
    as bands from their first tick to the next recorded one; no update (1: a tracker slower
    than the ticks) is not an outage."""
    ds = mekf_run.copy(deep=True)
    t = ds.tick.values
    status = np.zeros(t.size, dtype=np.int8)
    status[(t >= 20.0) & (t < 25.0)] = 2
    status[t == 30.0] = 3
    status[(t >= 32.0) & (t < 34.0)] = 1
    ds["star_tracker_status"].values[:] = status
    assert outage_spans(ds) == [(20.0, 25.0), (30.0, 30.5)]
    assert outage_spans(mekf_run) == []  # no exclusion cone: never out
    fig = plot_result(ds, panels=["estimation"])
    ax = fig.axes[0]
    orange = matplotlib.colors.to_rgb("tab:orange")
    bands = [p for p in ax.patches if p.get_facecolor()[:3] == orange]
    spans = sorted((round(p.get_x(), 9), round(p.get_x() + p.get_width(), 9)) for p in bands)
    assert spans == [(20.0, 25.0), (30.0, 30.5)]  # the axis is in s on a 40 s run
    title = ax.get_title(loc="left")
    assert f"orange: star tracker out, {11 / t.size:.0%} of the ticks" in title  # 10 + 1 ticks
    plt.close(fig)
    fig = plot_result(mekf_run, panels=["estimation"])
    ax = fig.axes[0]
    assert not [p for p in ax.patches if p.get_facecolor()[:3] == orange]
    assert "star tracker" not in ax.get_title(loc="left")
    plt.close(fig)


def test_title_says_what_the_run_is(rw_run, mekf_run):
    """A run from Python has the generic title "attitude propagation": the figure names the
    spacecraft, the laws by mode, the sensors and the estimator instead; a scenario keeps its
    own title."""
    assert mekf_run.attrs["title"] == "attitude propagation"
    want = (
        "spacecraft 900/800/600 kg m² with 3 reaction wheels — RateDamping, then MRPFeedback "
        "to inertial; gyro, star tracker, MEKF"
    )
    assert run_title(mekf_run) == want
    fig = plot_result(mekf_run, panels=["control_error"])
    assert fig._suptitle.get_text().startswith(want)
    plt.close(fig)
    assert run_title(rw_run) == rw_run.attrs["title"] != "attitude propagation"
    free = attitude.propagate([1.0, 2.0, 2.5], [1, 0, 0, 0], [0, 0.2, 0.1, 0.0], [0.0, 1.0])
    assert run_title(free) == "rigid body 1/2/2.5 — torque free"

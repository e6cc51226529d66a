"""Figures of `attitude plot`: what the engineer's panels draw, against independent truth.

Truth: the reference frames of attitude.frames evaluated directly (LVLH from the stored orbital
frame p), the accessor's relative_to (pointing error), the events the integrator located (the
shadow bars), the choice of time units by span, the drawn artists themselves (what lies over
what), and the CLI's exits.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import attitude
from attitude import frames, io, scenario
from attitude.errors import AttitudeValueError
from attitude.plotting import (
    PANELS,
    PlotContext,
    plot_result,
    plot_torque_budget,
    register_panel,
)
from attitude.plotting._common import TimeAxis, series, shadow_along
from attitude.plotting._reference import orbit_of, reference, scenario_of

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def events_run(tmp_path_factory):
    sc = scenario.load(ROOT / "scenarios/lvlh_pointing_events.toml")
    path = tmp_path_factory.mktemp("plot") / "ev.nc"
    sc.run_to_file(path)
    return io.read(path)


@pytest.fixture(scope="module")
def gg_run(tmp_path_factory):
    sc = scenario.load(ROOT / "scenarios/gg_stabilised_leo.toml")
    sc.t = sc.t[:121]  # one hour
    path = tmp_path_factory.mktemp("plot") / "gg.nc"
    sc.run_to_file(path)
    return io.read(path)


def test_time_axis_units_follow_the_span():
    ds = attitude.propagate(attitude.RigidBody([1.0, 2.0, 2.5], units="kg m2"), [1, 0, 0, 0],
                            [0, 0.2, 0.1, 0.0], [0.0, 1.0])  # fmt: skip
    for span, unit in ((600.0, "s"), (601.0, "min"), (3 * 3600.0, "min"), (3 * 3600.0 + 1, "h"),
                       (3 * 86400.0, "h"), (4 * 86400.0, "d")):  # fmt: skip
        assert TimeAxis.of(ds, np.array([0.0, span])).unit == unit, span
    ds.attrs["epoch"] = "2024-03-20T12:00:00.500000Z"
    assert (
        TimeAxis.of(ds, np.array([0.0, 7200.0])).text == "t [min] since 2024-03-20 12:00:00.5 UTC"
    )


def test_lvlh_from_the_stored_orbital_frame_is_the_frame(gg_run):
    """Without the orbit, LVLH comes from the run's p (RSW) and a fixed rotation: the same
    attitude as attitude.frames.lvlh on the orbit (up to the quaternion's sign)."""
    t = gg_run.time.values
    o = orbit_of(scenario_of(gg_run))
    stored = reference(gg_run.drop_attrs(), t, "lvlh")  # no scenario: from p
    direct = frames.lvlh(o).quaternion(t)
    dot = np.abs(np.sum(stored.q * direct, axis=1))
    np.testing.assert_allclose(dot, 1.0, rtol=0, atol=1e-13)
    rsw = reference(gg_run.drop_attrs(), t, "orbital").q
    np.testing.assert_allclose(np.abs(np.sum(rsw * frames.rsw(o).quaternion(t), axis=1)), 1.0,
                               atol=1e-13)  # fmt: skip
    with pytest.raises(AttitudeValueError, match="needs the run's orbit"):
        reference(gg_run.drop_attrs(), t, "vnc")


def test_pointing_error_and_angles_are_those_of_relative_to(gg_run):
    t = gg_run.time.values
    o = orbit_of(scenario_of(gg_run))
    ctx = PlotContext(gg_run, t, TimeAxis.of(gg_run, t), reference(gg_run, t))
    assert ctx.reference.name == "the orbital frame (RSW)"  # the scenario's initial frame
    rel = gg_run.attitude.relative_to(frames.rsw(o), degrees=True)
    np.testing.assert_allclose(ctx.error_angle_deg, rel["error_angle"].values, atol=1e-9)
    np.testing.assert_allclose(ctx.roll_pitch_yaw_deg[:, 0], rel["roll"].values, atol=1e-9)
    np.testing.assert_allclose(ctx.roll_pitch_yaw_deg[:, 2], rel["yaw"].values, atol=1e-9)
    # the scenario's 3-2-1 offsets (5, 2, 3) deg about z, y, x
    np.testing.assert_allclose(ctx.roll_pitch_yaw_deg[0], [3.0, 2.0, 5.0], atol=1e-9)
    assert not ctx.tumbling


def test_shadow_bars_end_at_the_located_eclipse_events(events_run):
    """The shadow the figure shades, on its dense grid, starts and ends within a grid step of
    the shadow entry and exit the integrator located (conical shadow, penumbra boundary)."""
    t = events_run.time.values
    o = orbit_of(scenario_of(events_run))
    tt, nu = shadow_along(events_run, t, o)
    assert tt[1] - tt[0] <= 2.001
    inside = nu < 1.0
    entry = tt[np.argmax(inside)]
    labels = list(events_run.detector_label.values)
    ev = dict(zip([labels[i] for i in events_run.event_detector.values],
                  events_run.event_time.values, strict=True))  # fmt: skip
    assert abs(entry - ev["shadow_in"]) <= 2.001
    assert inside[-1]  # the run ends at the exit, which it located on the boundary
    # and from the stored r and p (no orbit): the same shadow at the output samples
    t2, nu2 = shadow_along(events_run, t, None)
    np.testing.assert_allclose(nu2, np.interp(t2, tt, nu), atol=0.02)


def test_engineer_figure_of_a_run_with_events(events_run, tmp_path):
    fig = plot_result(events_run)
    axes = fig.axes
    assert [a.get_ylabel() for a in axes] == [
        "pointing error [deg]", "3-2-1 angles [deg]", "ω, body axes [deg/s]",
    ]  # fmt: skip
    assert axes[-1].get_xlabel() == "t [min] since 2024-03-20 12:00:00 UTC"
    texts = [t.get_text() for t in axes[0].texts]
    assert "error_4deg ↓" in texts and "shadow_in ↓" in texts and "shadow_out ↑" in texts
    # the shadow is shaded on every panel
    assert all(any(p.get_alpha() in (0.10, 0.22) for p in a.patches) for a in axes)
    # |ω| lies under the components: a component equal to it stays visible
    lines = {ln.get_label(): ln for ln in axes[2].get_lines()}
    assert lines["|ω|"].get_zorder() < lines["ωy"].get_zorder()
    plt.close(fig)


def test_tumbling_body_gets_rates_energy_and_torques(tmp_path):
    sc = scenario.load(ROOT / "scenarios/tumbling_upper_stage.toml")
    sc.t = sc.t[:361]  # one hour: it turns through every attitude relative to LVLH
    path = tmp_path / "t.nc"
    sc.run_to_file(path)
    ds = io.read(path)
    fig = plot_result(ds)
    labels = [a.get_ylabel() for a in fig.axes]
    assert labels[:3] == ["pointing error [deg]", "ω, body axes [deg/s]", "energy [J]"]
    assert "tumbling" in fig.axes[0].get_title(loc="left")
    plt.close(fig)
    fig = plot_result(ds, frame="inertial", panels=["angles"])
    assert fig.axes[0].get_ylabel() == "3-2-1 angles [deg]"
    plt.close(fig)


def test_paper_layout_for_the_paper_scenarios(tmp_path):
    sc = scenario.load(ROOT / "scenarios/paper_keplerian.toml")
    sc.t = sc.t[:50]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = sc.run()
    assert ds.attrs["plot_layout"] == "paper"
    fig = plot_result(ds)
    titles = [a.get_title() for a in fig.axes]
    assert titles[:2] == ["Euler parameters q (body to space)", "conjugate momenta Q"]
    # the energy panel: H solid and T dashed over it, both drawn
    energy = fig.axes[3]
    styles = {ln.get_label(): ln.get_linestyle() for ln in energy.get_lines()}
    assert styles["H = T + U"] == "-" and styles["T (kinetic)"] == "--"
    plt.close(fig)
    fig = plot_result(ds, layout="engineer")
    assert fig.axes[0].get_ylabel() == "pointing error [deg]"
    plt.close(fig)


def test_registered_panels_and_errors(gg_run):
    @register_panel("altitude", needs=("r",))
    def altitude(ax, ctx):
        ax.plot(ctx.t, ctx.ds["r"].values - 6378.137)
        ax.set_ylabel("altitude [km]")

    try:
        fig = plot_result(gg_run, panels=["altitude", "rates"])
        assert [a.get_ylabel() for a in fig.axes] == ["altitude [km]", "ω, body axes [deg/s]"]
        plt.close(fig)
    finally:
        PANELS.pop("altitude")
    with pytest.raises(AttitudeValueError, match="panels: 'nope'"):
        plot_result(gg_run, panels=["nope"])
    with pytest.raises(AttitudeValueError, match="frame: 'ecef'"):
        plot_result(gg_run, frame="ecef")
    free = attitude.propagate([1.0, 2.0, 2.5], [1, 0, 0, 0], [0, 0.2, 0.1, 0.0], [0.0, 1.0, 2.0])
    with pytest.raises(AttitudeValueError, match="cannot be drawn"):
        plot_result(free, layout="engineer", panels=["pointing"])


def test_fast_oscillations_are_drawn_by_windows():
    t = np.linspace(0.0, 86400.0, 8641)
    fig, ax = plt.subplots()
    assert series(ax, t, np.sin(2 * np.pi * t / 40.0), "amplitude", label="x") == "amplitude"
    assert series(ax, t, np.sin(2 * np.pi * t / 5400.0), "amplitude", label="y") == "line"
    amp = ax.get_lines()[0].get_ydata()
    assert np.all(amp > 0.9)  # each window holds a whole period: its amplitude is ~1
    plt.close(fig)


def test_torque_budget_total_under_the_terms(tmp_path):
    sc = scenario.load(ROOT / "scenarios/cubesat_environment.toml")
    sc.t = sc.t[:200]
    ds = sc.run()
    fig = plot_torque_budget(ds)
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    assert lines["total"].get_zorder() < lines["magnetic_dipole"].get_zorder()
    assert lines["total"].get_linewidth() > 3 * lines["magnetic_dipole"].get_linewidth()
    plt.close(fig)


def test_cli_plot_options(gg_run, tmp_path, capsys):
    from attitude.cli import main

    nc = io.write(gg_run, tmp_path / "gg.nc")
    out = tmp_path / "f.png"
    assert main(["plot", str(nc), "-o", str(out), "--frame", "lvlh", "--panels",
                 "pointing,rates_relative"]) == 0  # fmt: skip
    assert out.stat().st_size > 10_000
    assert main(["plot", str(nc), "-o", str(out), "--panels", "wheels"]) == 2
    assert "plot: panels: 'wheels'" in capsys.readouterr().err
    assert main(["plot", str(nc), "-o", str(out), "--layout", "paper"]) == 0


def test_a_run_that_propagated_its_orbit_gets_the_orbit_panel(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import orbit
    from attitude import RigidBody, Spacecraft, propagate
    from attitude.plotting import plot_result

    o = orbit.NumericalOrbit([6778.137, 0.0, 0.0], [0.0, 7.6686, 0.0], "2026-03-20T00:00:00")
    sc = Spacecraft(RigidBody([1.0, 1.2, 1.4]), orbit=o, mass=10.0)
    t = np.linspace(0.0, 3 * 5560.0, 301)
    ds = propagate(sc, [1.0, 0, 0, 0], [0.0, 0.0, 0.0, 0.02], t, method="dop853")
    fig = plot_result(ds)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert "height [km]" in labels
    ax = fig.axes[labels.index("height [km]")]
    h = np.concatenate([ln.get_ydata() for ln in ax.get_lines()])
    assert 380.0 < h.min() and h.max() < 430.0  # 400 km above the equator's ellipsoid
    # the thick line: the semi-major axis of the orbital energy above the equator, here a point
    # mass's (J2 = 0): the two-body a of the initial state, conserved to the integration's error
    (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("energy semi-major")]
    mu = 1e-9 * ds.attrs["orbit_gm"]
    a0 = 1.0 / (2.0 / 6778.137 - 7.6686**2 / mu)
    np.testing.assert_allclose(line.get_ydata(), a0 - 6378.137, rtol=0, atol=1e-6)


def test_event_names_stay_inside_the_panel():
    # A terminal event is the run's last instant: its name goes left of its line, inside the
    # panel (it was drawn outside, over the legend); an event inside the run, right of it.
    from attitude.plotting._common import Event, mark_events

    fig, ax = plt.subplots()
    ax.set_xlim(0.0, 10.0)
    mark_events([ax], [Event(5.0, "middle", 1), Event(10.0, "last", -1)], TimeAxis(1.0, "s", None))
    fig.canvas.draw()
    box = ax.get_window_extent()
    for text in ax.texts:
        ext = text.get_window_extent()
        assert box.x0 <= ext.x0 and ext.x1 <= box.x1, text.get_text()
    plt.close(fig)

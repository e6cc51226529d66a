"""`attitude view`: the page, opened from a file in a real browser with the network blocked.

Truth: the run's own quaternions (the drawn body axes are the columns of to_matrix(q)), the
Sun's direction from orbit.sun and the orbit rebuilt from the scenario (computed here, not by
the page's code), the Dataset's times. The browser is the system's Chromium through Playwright
(`.ci/run` installs it when absent); the browser tests skip, saying why, only where neither
can be had.
"""

from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import attitude
from attitude import io, scenario
from attitude.errors import AttitudeFileError, AttitudeValueError
from attitude.plotting import view, view_html
from attitude.plotting._reference import orbit_of, scenario_of
from attitude.plotting._scene import MAX_FRAMES
from attitude.quaternion import rotate, rotate_inverse, to_matrix

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]  # fmt: skip
TOL = 1e-6


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        exe = shutil.which(name)
        if exe:
            return exe
    return "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None


@pytest.fixture(scope="module")
def browser():
    sync = pytest.importorskip(
        "playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')"
    )
    exe = _chromium()
    if exe is None:
        pytest.skip("no Chromium on this machine (.ci/run installs it: apt-get install chromium)")
    with sync.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        yield b
        b.close()


class Page:
    """A page opened from a file, every http(s) request aborted and recorded."""

    def __init__(self, browser, path: Path):
        self.page = browser.new_page(viewport={"width": 1400, "height": 800})
        self.console: list[tuple[str, str]] = []
        self.requests: list[str] = []
        self.page.on("console", lambda m: self.console.append((m.type, m.text)))
        self.page.on("pageerror", lambda e: self.console.append(("pageerror", str(e))))
        self.page.on("request", lambda r: self.requests.append(r.url))

        def route(r):
            if r.request.url.startswith(("http:", "https:")):
                r.abort()
            else:
                r.continue_()

        self.page.route("**/*", route)
        t0 = time.perf_counter()
        self.page.goto(path.resolve().as_uri())
        self.page.wait_for_function("window.attitudeView && window.attitudeView.ready")
        self.load_seconds = time.perf_counter() - t0

    def state(self, frame: int | None = None) -> dict:
        if frame is not None:
            self.page.evaluate(f"attitudeView.setFrame({frame})")
        return self.page.evaluate("attitudeView.state()")

    def check_clean(self) -> None:
        """No network request but the page's own file; no error in the console."""
        net = [u for u in self.requests if not u.startswith(("file:", "data:", "blob:"))]
        assert net == [], net
        errors = [c for c in self.console if c[0] in ("error", "pageerror")]
        assert errors == [], errors

    def close(self) -> None:
        self.page.close()


def _axes(q: np.ndarray) -> np.ndarray:
    """The body axes in space components: rows x, y, z = the columns of to_matrix(q)."""
    return to_matrix(q).T


def _sun_direction(ds: xr.Dataset, t: np.ndarray) -> np.ndarray:
    """Spacecraft -> Sun (unit, inertial) from orbit.sun and the scenario's orbit."""
    from orbit.sun import sun_position

    o = orbit_of(scenario_of(ds))
    r = np.asarray(o.position(t))
    s = sun_position(str(ds.attrs["epoch"]).rstrip("Z"), t) - r
    return s / np.linalg.norm(s, axis=-1, keepdims=True)


@pytest.fixture(scope="module")
def events_run(tmp_path_factory):
    """A run on a dated orbit (Sun, shadow, LVLH, events): the microsatellite near LVLH."""
    sc = scenario.load(ROOT / "scenarios/lvlh_pointing_events.toml")
    path = tmp_path_factory.mktemp("view") / "ev.nc"
    sc.run_to_file(path)
    return io.read(path)


@pytest.fixture(scope="module")
def free_run():
    """The paper's torque-free body: no orbit, dimensionless."""
    body = attitude.RigidBody([1.0, 2.0, 2.5])
    q0 = attitude.quaternion.from_euler([0.3, 1.0, 0.2], "313")
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.3, 0.5, 1.1], body)
    return attitude.propagate(body, q0, Q0, np.linspace(0.0, 20.0, 401))


def test_page_draws_the_runs_attitude_sun_and_time(browser, events_run, tmp_path):
    path = view(events_run, tmp_path / "ev.html")
    assert path == tmp_path / "ev.html"
    n = events_run.sizes["time"]
    assert n <= MAX_FRAMES  # every sample is a frame
    q = events_run.q.values
    t = events_run.time.values
    frames = [0, 1, n // 3, n // 2, (2 * n) // 3, n - 1]
    sun = _sun_direction(events_run, t[frames])
    page = Page(browser, path)
    try:
        assert page.page.evaluate("attitudeView.nFrames") == n
        worst = {"axes": 0.0, "sun": 0.0, "lvlh": 0.0}
        o = orbit_of(scenario_of(events_run))
        for k, i in enumerate(frames):
            st = page.state(i)
            assert st["frame"] == i and st["sliderValue"] == i
            assert st["sliderTime"] == t[i] and st["t"] == t[i]  # the Dataset's float64 time
            drawn = np.array(st["bodyAxes"])
            worst["axes"] = max(worst["axes"], float(np.abs(drawn - _axes(q[i])).max()))
            assert abs(abs(np.dot(st["q"], q[i])) - 1.0) < 1e-12
            worst["sun"] = max(worst["sun"], float(np.abs(np.array(st["sun"]) - sun[k]).max()))
            lvlh = attitude.frames.lvlh(o).quaternion(np.array([t[i]]))[0]
            worst["lvlh"] = max(
                worst["lvlh"], float(np.abs(np.array(st["lvlhAxes"]) - _axes(lvlh)).max())
            )
            r = np.asarray(o.position(np.array([t[i]])))[0]
            np.testing.assert_allclose(st["nadir"], -r / np.linalg.norm(r), atol=1e-6)
        assert worst["axes"] < TOL, worst
        assert worst["sun"] < TOL, worst
        assert worst["lvlh"] < TOL, worst
        # the run ends at the penumbra exit: the light is dimmed in the shadow before it
        lit = [page.state(i)["lit"] for i in (n - 3, 0)]
        assert lit[0] < 1.0 and lit[1] == 1.0
        assert page.state(n - 3)["sunLight"] < page.state(0)["sunLight"]
        # a camera fixed to the body turns with it
        page.page.evaluate("attitudeView.setCamera('body')")
        c0 = np.array(page.state(0)["cameraPosition"])
        c1 = np.array(page.state(n - 1)["cameraPosition"])
        np.testing.assert_allclose(rotate(q[n - 1], rotate_inverse(q[0], c0)), c1,
                                   rtol=1e-9, atol=1e-9)  # fmt: skip
        page.check_clean()
    finally:
        page.close()


def test_decimated_frames_are_samples_of_the_run(browser, events_run, tmp_path):
    """A page with fewer frames than samples: each frame is a sample, drawn as that sample."""
    path = view(events_run, tmp_path / "few.html", max_frames=20)
    t = events_run.time.values
    q = events_run.q.values
    page = Page(browser, path)
    try:
        nf = page.page.evaluate("attitudeView.nFrames")
        assert 10 <= nf < events_run.sizes["time"]
        for i in (0, 7, nf // 2, nf - 1):
            st = page.state(i)
            k = int(np.flatnonzero(t == st["sliderTime"])[0])  # a sample's exact time
            assert np.abs(np.array(st["bodyAxes"]) - _axes(q[k])).max() < TOL
        assert page.state(nf - 1)["t"] == t[-1]  # the last sample (a terminal event) kept
        page.check_clean()
    finally:
        page.close()


def test_a_run_without_an_orbit_says_so_and_draws_the_body(browser, free_run, tmp_path):
    path = view(free_run, tmp_path / "free.html")
    page = Page(browser, path)
    try:
        st = page.state(123)
        assert st["sun"] is None and st["nadir"] is None and st["lvlhAxes"] is None
        assert "no orbit" in st["warning"] and "the body and its axes are drawn" in st["warning"]
        assert np.abs(np.array(st["bodyAxes"]) - _axes(free_run.q.values[123])).max() < TOL
        assert st["timeText"].startswith("t = 6.15000  frame 124/401")  # dimensionless: no unit
        page.check_clean()
    finally:
        page.close()


def test_thruster_plumes_show_when_firing(browser, tmp_path):
    from attitude.actuators import CommandSchedule, Thruster

    th = [Thruster([0.5, 0, 0], [0, 1, 0], 0.02), Thruster([-0.5, 0, 0], [0, -1, 0], 0.02)]
    craft = attitude.Spacecraft(attitude.RigidBody([10.0, 12.0, 8.0], units="kg m2"),
                                thrusters=th)  # fmt: skip
    t = np.linspace(0.0, 10.0, 101)
    cmd = CommandSchedule([0.0, 5.0], thrust=[[0.5, 0.0], [0, 0]])
    ds = attitude.propagate(craft, [1.0, 0, 0, 0], np.zeros(4), t, commands=cmd)
    firing = ds.thruster_force.values > 0
    page = Page(browser, view(ds, tmp_path / "th.html"))
    try:
        for i in (0, 20, 49, 50, 80):
            assert page.state(i)["plumes"] == firing[i].tolist(), i
        assert firing[20].tolist() == [True, False] and not firing[80].any()
        page.check_clean()
    finally:
        page.close()


@pytest.fixture(scope="module")
def ensemble_run(tmp_path_factory):
    """Eight members of the wheel scenario with a gyro, a star tracker (its boresight moved
    here) and the MEKF; 60 s."""
    from attitude.ensemble import run_scenario

    text = (ROOT / "scenarios/ensemble_rw_inertial_pointing.toml").read_text()
    text = text.replace(
        'type = "star_tracker"', 'type = "star_tracker"\nboresight = [0.0, 0.6, 0.8]'
    )
    sc = scenario.loads(text, path=ROOT / "scenarios/ensemble_rw_inertial_pointing.toml")
    sc.t = sc.t[:41]
    path = tmp_path_factory.mktemp("view") / "mc.nc"
    run_scenario(sc, path)
    return io.read(path)


def test_ensemble_member_choice_and_boresight_cloud(browser, ensemble_run, tmp_path):
    ids = ensemble_run.member.values
    assert ids.size == 8
    b = np.array([0.0, 0.6, 0.8])
    path = view(ensemble_run, tmp_path / "mc.html", member=int(ids[3]))
    page = Page(browser, path)
    try:
        st = page.state(20)
        assert st["member"] == int(ids[3])
        q = ensemble_run.q.values  # (member, time, 4)
        assert np.abs(np.array(st["bodyAxes"]) - _axes(q[3, 20])).max() < TOL
        np.testing.assert_allclose(st["boresights"][0], rotate(q[3, 20], b), atol=TOL)
        cloud = np.array(st["cloud"]).reshape(-1, 3)
        np.testing.assert_allclose(cloud, rotate(q[:, 20], b), atol=1e-6)  # float32 on the page
        page.page.evaluate(f"attitudeView.setMember({int(ids[6])})")
        st = page.state(30)
        assert st["member"] == int(ids[6])
        assert np.abs(np.array(st["bodyAxes"]) - _axes(q[6, 30])).max() < 1e-6
        page.check_clean()
    finally:
        page.close()


# ------------------------------------------------------------------------------------------------
# bad input, without a browser
# ------------------------------------------------------------------------------------------------


def test_not_a_run_unknown_member_unwritable_path(free_run, ensemble_run, tmp_path):
    with pytest.raises(AttitudeValueError, match="not an attitude result"):
        view(xr.Dataset({"x": ("time", np.arange(3.0))}), tmp_path / "x.html")
    with pytest.raises(AttitudeValueError, match="no member 99 in this ensemble"):
        view(ensemble_run, tmp_path / "x.html", member=99)
    with pytest.raises(AttitudeValueError, match="not an ensemble"):
        view(free_run, tmp_path / "x.html", member=1)
    with pytest.raises(AttitudeFileError, match="is a directory"):
        view(free_run, tmp_path)
    with pytest.raises(AttitudeFileError, match="not a directory"):
        (tmp_path / "file").write_text("")
        view(free_run, tmp_path / "file" / "x.html")
    if os.geteuid() != 0:  # (root writes anywhere)
        (tmp_path / "ro").mkdir()
        (tmp_path / "ro").chmod(0o500)
        try:
            with pytest.raises(AttitudeFileError, match="permission denied"):
                view(free_run, tmp_path / "ro" / "x.html")
        finally:
            (tmp_path / "ro").chmod(0o700)
        (tmp_path / "ro").rmdir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]  # nothing written, no temp


def test_a_failure_while_writing_leaves_nothing(free_run, tmp_path, monkeypatch):
    from attitude.plotting import _view

    target = tmp_path / "page.html"
    target.write_text("previous")

    def boom(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(_view.Path, "write_text", boom)
    with pytest.raises(AttitudeFileError, match="disk is full"):
        view(free_run, target)
    assert target.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["page.html"]


def test_a_day_at_10_hz_stays_under_20_mb(tmp_path):
    """864 001 samples (a torque-free body, 0.1 s for a day): the page plays MAX_FRAMES
    frames, keeps each stretch's extremes, and weighs under 20 MB."""
    body = attitude.RigidBody([900.0, 800.0, 600.0], units="kg m2")
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = attitude.canonical.momenta_from_angular_velocity(q0, [0.01, 0.002, 0.05], body)
    t = np.arange(864_001) * 0.1
    ds = attitude.propagate(body, q0, Q0, t, method="exact")
    ds.attrs["inertia"] = np.array([900.0, 800.0, 600.0])
    t0 = time.perf_counter()
    path = view(ds, tmp_path / "day.html")
    seconds = time.perf_counter() - t0
    size = path.stat().st_size
    assert size < 20e6, size
    html = path.read_text()
    nf = int(re.search(r'"t":\{"dtype":"f64","shape":\[(\d+)\]', html).group(1))
    assert MAX_FRAMES // 2 < nf <= MAX_FRAMES + 2
    print(f"a day at 10 Hz: {nf} frames, {size / 1e6:.2f} MB, written in {seconds:.1f} s")


@pytest.fixture(scope="module")
def tracker_run():
    """Ten minutes of the nadir-pointing day with a star tracker looking away from the Earth,
    with Sun and Earth exclusion cones (30 and 20 deg)."""
    text = (ROOT / "scenarios/nadir_wheels_dumping.toml").read_text()
    tracker = (
        '\n[[software.sensors]]\ntype = "star_tracker"\nnoise = 10.0\nnoise_unit = "arcsec"\n'
        "boresight = [0.0, -0.6, -0.8]\nsun_exclusion = 30.0\nsun_exclusion_unit = "
        '"deg"\nearth_exclusion = 20.0\nearth_exclusion_unit = "deg"\nseed = 3\n'
    )
    text = text.replace("record_every = 10\n", "record_every = 10\n" + tracker)
    sc = scenario.loads(text, path=ROOT / "scenarios/nadir_wheels_dumping.toml")
    sc.t = sc.t[:21]
    return sc.run()


def test_boresight_and_exclusion_cones_turn_with_the_body(browser, tracker_run, tmp_path):
    b = np.array([0.0, -0.6, -0.8])
    page = Page(browser, view(tracker_run, tmp_path / "st.html"))
    try:
        q = tracker_run.q.values
        for i in (0, 10, 20):
            st = page.state(i)
            np.testing.assert_allclose(st["boresights"][0], rotate(q[i], b), atol=TOL)
            cones = {c["kind"]: c for c in st["cones"]}
            assert cones["sun"]["halfAngle"] == pytest.approx(np.radians(30.0), abs=1e-15)
            assert cones["earth"]["halfAngle"] == pytest.approx(np.radians(20.0), abs=1e-15)
            for c in cones.values():
                np.testing.assert_allclose(c["axis"], rotate(q[i], b), atol=TOL)
            assert st["referenceAxes"] is not None  # the guidance (LVLH) is drawn
            # the Sun's angle from the boresight, as the page reports it against its cone
            sun = _sun_direction(tracker_run, tracker_run.time.values[i : i + 1])[0]
            angle = np.degrees(np.arccos(np.dot(rotate(q[i], b), sun)))
            shown = float(re.search(r"Sun ([0-9.]+)° \(excl\. 30°\)", st["hud"]).group(1))
            assert abs(shown - angle) <= 0.05 + 1e-9, (shown, angle)
        page.check_clean()
    finally:
        page.close()


def test_cli_view(tmp_path, capsys, monkeypatch):
    from attitude import cli

    sc = scenario.load(ROOT / "scenarios/paper_torque_free.toml")
    sc.t = sc.t[:51]
    nc = tmp_path / "free.nc"
    sc.run_to_file(nc)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["view", str(nc)]) == 0  # default: RUN.html beside it
    assert "page        " in capsys.readouterr().out
    html = (tmp_path / "free.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and "http://" not in html.split("<script")[0]
    assert cli.main(["view", str(nc), "-o", f"{tmp_path}/out/"]) == 0
    assert (tmp_path / "out" / "free.html").exists()
    assert cli.main(["view", str(nc), "--member", "2"]) == 2
    assert "not an ensemble" in capsys.readouterr().err
    (tmp_path / "notes.txt").write_text("not a run")
    assert cli.main(["view", str(tmp_path / "notes.txt"), "-o", str(tmp_path / "n.html")]) == 2
    assert "not a netCDF4 file" in capsys.readouterr().err
    assert not (tmp_path / "n.html").exists()
    assert cli.main(["view", str(nc), "-o", str(tmp_path / "free.html" / "x.html")]) == 2
    assert "not a directory" in capsys.readouterr().err


def test_play_and_pause(browser, free_run, tmp_path):
    page = Page(browser, view(free_run, tmp_path / "play.html"))
    try:
        page.state(0)
        page.page.evaluate("attitudeView.play()")
        page.page.wait_for_timeout(600)  # the whole run plays in a minute: ~1 % of it
        st = page.state()
        assert st["playing"] and st["frame"] > 0
        page.page.evaluate("attitudeView.pause()")
        frame = page.state()["frame"]
        page.page.wait_for_timeout(300)
        st = page.state()
        assert not st["playing"] and st["frame"] == frame
        assert st["sliderTime"] == free_run.time.values[frame]
        page.check_clean()
    finally:
        page.close()


@pytest.mark.slow
def test_a_closed_loop_day_at_10_hz(tmp_path):
    """Basilisk's wheel scenario over a day at 10 Hz (864 001 samples, ~130 MB streamed to its
    file): the page stays under 20 MB (3.4 MB measured) with the frame budget used."""
    text = (ROOT / "scenarios/rw_inertial_pointing.toml").read_text()
    assert "stop = 600.0\nstep = 0.5" in text
    text = text.replace("stop = 600.0\nstep = 0.5", "stop = 86400.0\nstep = 0.1")
    sc = scenario.loads(text, path=ROOT / "scenarios/rw_inertial_pointing.toml")
    nc = tmp_path / "day.nc"
    sc.run_to_file(nc)
    ds = io.read(nc, load=False)
    try:
        assert ds.sizes["time"] == 864_001
        path = view(ds, tmp_path / "day.html")
    finally:
        ds.close()
    size = path.stat().st_size
    nf = int(re.search(r'"t":\{"dtype":"f64","shape":\[(\d+)\]', path.read_text()).group(1))
    assert size < 20e6 and 0.9 * MAX_FRAMES < nf <= MAX_FRAMES + 2, (size, nf)


def test_facets_and_sensors_of_a_run_made_in_python(browser, free_run, tmp_path):
    """A run made in Python stores neither its surface nor its sensors: given to view()."""
    from astropy import units as u

    from attitude.sensors import StarTracker

    facets = attitude.box_wing([0.1, 0.1, 0.34], wings=[(0.06, [1, 0, 0], [0, 0.25, 0])])
    tracker = StarTracker(10 * u.arcsec, boresight=[0.0, 0.6, 0.8], sun_exclusion=30 * u.deg)
    html = view_html(free_run, facets=facets, sensors=[tracker])
    assert len(re.findall(r"\[0\.06,1\.0,0\.0,0\.0,0\.0,0\.25,0\.0\]", html)) == 1  # the wing
    path = tmp_path / "py.html"
    path.write_text(html)
    page = Page(browser, path)
    try:
        st = page.state(50)
        q = free_run.q.values[50]
        np.testing.assert_allclose(st["boresights"][0], rotate(q, [0.0, 0.6, 0.8]), atol=TOL)
        (cone,) = st["cones"]
        assert cone["kind"] == "sun" and cone["halfAngle"] == pytest.approx(np.pi / 6, abs=1e-15)
        page.check_clean()
    finally:
        page.close()
    with pytest.raises(AttitudeValueError, match=r"facets: expected attitude\.Facet"):
        view_html(free_run, facets=[[1.0, 0, 0, 1, 0, 0, 0]])

"""Orbit and attitude in one state through ``attitude.propagate`` (issue 41): conservation of
the coupled system's energy and angular momentum, thrust against closed forms (Δv = F t/m,
the rocket equation, a thrust turning with the body), one-way against coupled, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

import attitude
import orbit
from attitude import CommandSchedule, RigidBody, Spacecraft
from attitude.actuators import Thruster
from attitude.canonical import momenta_from_angular_velocity
from attitude.quaternion import rotate, to_matrix

EPOCH = "2026-03-20T00:00:00"
INERTIA = np.array([1e9, 1e9, 2e7])  # a long bar: its spin and its orbit trade momentum
MASS = 1e5
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])


def _orbit(**kw):
    return orbit.NumericalOrbit([7000.0, 0.0, 0.0], [0.0, 7.546, 0.1], EPOCH, **kw)


def _state(inertia=INERTIA):
    q0 = np.array(
        [math.cos(0.2), math.sin(0.2) / math.sqrt(2.0), 0.0, math.sin(0.2) / math.sqrt(2)]
    )
    return q0, momenta_from_angular_velocity(q0, [1e-4, -2e-4, 1e-3], inertia)


def _invariants(ds, inertia, mass, mu):
    """Total energy and angular momentum of the coupled system, computed here from the Dataset's
    states (independent of the run's own diagnostics)."""
    q, g = ds.q.values, ds.g.values
    r, v = ds.position.values, ds.velocity.values
    R = to_matrix(q)
    rb = np.einsum("nji,nj->ni", R, r)
    rn = np.linalg.norm(r, axis=1)
    v2 = 1.5 * mu / rn**5 * np.einsum("ni,i,ni->n", rb, inertia, rb) - mu * inertia.sum() / (
        2 * rn**3
    )
    energy = np.sum(g**2 / inertia, axis=1) / 2 + mass * (np.sum(v**2, axis=1) / 2 - mu / rn) + v2
    spin = rotate(q, g)
    return energy, mass * np.cross(r, v) + spin, spin


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_coupled_gravity_gradient_conserves_energy_and_momentum(method):
    o = _orbit()
    sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
    q0, Q0 = _state()
    period = 2 * math.pi * math.sqrt(7.0e6**3 / (o.mu * 1e9))
    t = np.linspace(0.0, 10 * period, 501)
    ds = attitude.propagate(sc, q0, Q0, t, attitude.GravityGradient(o), method=method,
                            rtol=1e-14 if method == "taylor" else 1e-13, atol=1e-14)  # fmt: skip
    assert ds.attrs["method"] == method
    # a body in plain numbers is in kg m² on a coupled run (SI forces): its results say so
    assert sc.body.units == "kg m^2" and ds.energy.attrs["units"] == "J"
    # the orbit went with the attitude, by the run's method (not the NumericalOrbit's own)
    assert ds.attrs["orbit"].endswith(f"with the attitude by the run's method ({method})")
    energy, L, spin = _invariants(ds, INERTIA, MASS, o.mu * 1e9)
    scale = np.linalg.norm(L[0])
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 1e-12
    # the Dataset's own total energy is the one computed here (same terms, other order)
    assert np.max(np.abs(ds.total_energy.values / energy - 1.0)) < 1e-13
    assert ds.attrs["max_rel_total_energy_error"] < 1e-12
    assert np.max(np.linalg.norm(L - L[0], axis=1)) / scale < 1e-12
    # the exchange between spin and orbit is 100 times the bound (the test can fail)
    assert np.max(np.linalg.norm(spin - spin[0], axis=1)) / scale > 1e-10


def test_zonal_field_coupled_conserves_energy_and_polar_momentum():
    # J2..J4 about the pole of a uniformly turning Earth do not depend on time or longitude: the
    # coupled system's energy (the field's U for the orbit) and the polar component of the total
    # angular momentum (orbit + spin) are conserved; its other components are not (the test can
    # fail: J2 turns the orbital plane). Measured over five orbits: 1.2e-14 and 5.9e-15.
    field = orbit.SphericalHarmonics(4, 0)
    o = _orbit(gravity=field, earth_rotation="uniform", rtol=1e-13)
    sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
    q0, Q0 = _state()
    t = np.linspace(0.0, 5 * 5829.0, 201)
    ds = attitude.propagate(sc, q0, Q0, t, attitude.GravityGradient(o), method="dop853",
                            rtol=1e-13, atol=1e-14)  # fmt: skip
    mu = o.mu * 1e9
    energy, L, _ = _invariants(ds, INERTIA, MASS, mu)
    r = ds.position.values
    # the point mass's −μ m/r replaced by the zonal field's m U(r)
    energy = energy + MASS * (mu / np.linalg.norm(r, axis=1) + field.potential(r))
    assert np.max(np.abs(energy / energy[0] - 1.0)) < 1e-12
    scale = np.linalg.norm(L[0])
    assert np.max(np.abs(L[:, 2] - L[0, 2])) / scale < 1e-12
    assert np.ptp(L[:, 0]) / scale > 1e-4


def test_info_prints_the_total_energy_of_a_coupled_run(tmp_path, capsys):
    from attitude.cli import main

    o = _orbit()
    sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
    q0, Q0 = _state()
    ds = attitude.propagate(sc, q0, Q0, np.linspace(0.0, 600.0, 7), attitude.GravityGradient(o),
                            rtol=1e-13, atol=1e-14)  # fmt: skip
    attitude.io.write(ds, tmp_path / "c.nc")
    assert main(["info", str(tmp_path / "c.nc")]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if "E of orbit and attitude" in x)
    assert float(line.rsplit("=", 1)[1]) == pytest.approx(ds.attrs["max_rel_total_energy_error"],
                                                          rel=1e-2)  # fmt: skip


def test_taylor_and_dop853_agree():
    o = _orbit()
    sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
    q0, Q0 = _state()
    t = np.linspace(0.0, 6000.0, 61)
    gg = attitude.GravityGradient(o)
    a = attitude.propagate(sc, q0, Q0, t, gg, method="taylor", rtol=1e-14, atol=1e-14)
    b = attitude.propagate(sc, q0, Q0, t, gg, method="dop853", rtol=1e-13, atol=1e-14)
    assert np.max(np.abs(a.position - b.position)) / 7e6 < 1e-11
    assert np.max(np.abs(a.q - b.q)) < 1e-9


def _sphere(o):
    """A 50 kg sphere carrying ``o`` (no gravity-gradient torque, no force back): its inertia,
    the spacecraft and an initial state."""
    sph = np.array([10.0, 10.0, 10.0])
    return (sph, Spacecraft(RigidBody(sph), orbit=o, mass=50.0), *_state(sph))


def test_one_way_equals_coupled_when_nothing_acts_back():
    # A sphere feels no gravity-gradient torque and exerts no force back: the coupled orbit is
    # the NumericalOrbit's own (to the integrators' tolerances).
    o = _orbit(gravity=orbit.SphericalHarmonics(4), rtol=1e-13)
    sph, sc, q0, Q0 = _sphere(o)
    t = np.linspace(0.0, 5400.0, 91)
    coupled = attitude.propagate(sc, q0, Q0, t, attitude.GravityGradient(o), method="dop853",
                                 rtol=1e-13, atol=1e-13)  # fmt: skip
    alone = o.propagate(t)
    rel = np.abs(coupled.position.values - alone.position.values).max() / 7e6
    assert rel < 1e-12
    one_way = attitude.propagate(RigidBody(sph), q0, Q0, t, attitude.GravityGradient(o),
                                 method="dop853", rtol=1e-13, atol=1e-13)  # fmt: skip
    assert np.abs(one_way.r.values - coupled.r.values).max() < 1e-12 * 7000.0  # km
    assert np.abs(one_way.q.values - coupled.q.values).max() < 1e-12


def test_one_way_equals_coupled_to_round_off_at_the_taylor_limit():
    # Two integrations with their own steps (the coupled state's Taylor and the orbit's own
    # Taylor), both at rtol 1e-15: a sphere exerts no force back, so they are one trajectory,
    # to the rounding of a few thousand steps (measured 3.8e-15 of |r| over three orbits).
    o = _orbit(method="taylor", rtol=1e-15, atol=1e-20)
    _, sc, q0, Q0 = _sphere(o)
    t = np.linspace(0.0, 17_500.0, 31)
    coupled = attitude.propagate(sc, q0, Q0, t, attitude.GravityGradient(o), method="taylor",
                                 rtol=1e-15, atol=1e-20)  # fmt: skip
    alone = o.propagate(t)
    assert np.abs(coupled.position.values - alone.position.values).max() / 7e6 < 1e-14
    assert np.abs(coupled.velocity.values - alone.velocity.values).max() / 7.5e3 < 1e-14


def _deep_space(mu=1e-20):
    """An orbit far from any pull (μ tiny): the thrust alone changes the velocity."""
    return orbit.NumericalOrbit([1e5, 0.0, 0.0], [0.0, 0.0, 0.0], EPOCH, mu=mu)


def test_burn_delta_v_and_rocket_equation():
    o = _deep_space()
    f, m0, burn = 20.0, 500.0, 100.0
    for isp in (None, 220.0):
        th = Thruster([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], f, isp=isp)
        sc = Spacecraft(RigidBody([100.0, 120.0, 80.0]), thrusters=[th], orbit=o, mass=m0)
        cmd = CommandSchedule([0.0, burn], thrust=[[1.0], [0.0]])
        q0 = np.array([1.0, 0.0, 0.0, 0.0])
        t = np.array([0.0, 50.0, burn, 150.0])
        ds = attitude.propagate(sc, q0, np.zeros(4), t, commands=cmd, method="dop853",
                                rtol=1e-13, atol=1e-13)  # fmt: skip
        dv = ds.velocity.values[-1] - ds.velocity.values[0]
        if isp is None:
            assert abs(dv[0] / (f * burn / m0) - 1.0) < 1e-12
            assert ds.mass.values[-1] == m0
        else:
            m1 = m0 - f / (isp * 9.80665) * burn
            assert abs(ds.mass.values[-1] / m1 - 1.0) < 1e-13
            assert abs(dv[0] / (isp * 9.80665 * math.log(m0 / m1)) - 1.0) < 1e-12
        assert np.max(np.abs(dv[1:])) < 1e-12 * abs(dv[0])


def test_thrust_turns_with_the_body():
    # Spinning at ω about z while a thruster along body x fires for a quarter turn:
    # Δv = F/(m ω) (sin ωT, 1 − cos ωT, 0) = F/(m ω) (1, 1, 0).
    o = _deep_space()
    f, m, w = 1.0, 100.0, 0.01
    T = math.pi / 2 / w
    th = Thruster([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], f)
    inertia = np.array([10.0, 12.0, 14.0])
    sc = Spacecraft(RigidBody(inertia), thrusters=[th], orbit=o, mass=m)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = momenta_from_angular_velocity(q0, [0.0, 0.0, w], inertia)
    cmd = CommandSchedule([0.0, T], thrust=[[1.0], [0.0]])
    ds = attitude.propagate(sc, q0, Q0, np.array([0.0, T]), commands=cmd, method="dop853",
                            rtol=1e-13, atol=1e-13)  # fmt: skip
    dv = ds.velocity.values[-1] - ds.velocity.values[0]
    want = f / (m * w) * np.array([1.0, 1.0, 0.0])
    assert np.max(np.abs(dv - want)) < 1e-11 * np.linalg.norm(want)


def test_bad_input():
    o = _orbit()
    with pytest.raises(attitude.AttitudeValueError, match="mass"):
        Spacecraft(RigidBody(INERTIA), orbit=o, mass=0.0)
    with pytest.raises(attitude.AttitudeValueError, match="isp"):
        Thruster([0, 0, 0], [1, 0, 0], 1.0, isp=-3.0)
    sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
    q0, Q0 = _state()
    with pytest.raises(attitude.AttitudeValueError, match="formulation"):
        attitude.propagate(sc, q0, Q0, [0.0, 10.0], formulation="schwab")
    field = _orbit(gravity=orbit.SphericalHarmonics(2))
    sc2 = Spacecraft(RigidBody(INERTIA), orbit=field, mass=MASS)
    with pytest.raises(attitude.AttitudeValueError, match="method"):
        attitude.propagate(sc2, q0, Q0, [0.0, 10.0], attitude.GravityGradient(field),
                           method="taylor")  # fmt: skip
    # no actuators: the message says what carries the orbit, not what models wheels
    with pytest.raises(attitude.AttitudeValueError, match=r"carrying its orbit.*'exact' does not"):
        attitude.propagate(sc, q0, Q0, [0.0, 10.0], method="exact")
    with pytest.raises(attitude.AttitudeValueError, match=r"TorqueFree \(with no torque"):
        attitude.propagate(sc, q0, Q0, [0.0, 10.0], method="splitting", dt=1.0)


def test_a_coupled_run_has_the_epoch_of_the_orbit_it_carries():
    # Torque-free (no orbit in the model): the run's time origin is the carried orbit's epoch,
    # and an epoch= or an event orbit of another date is refused before any work.
    from attitude.events import EclipseEntry

    o = _orbit()
    sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
    q0, Q0 = _state()
    ds = attitude.propagate(sc, q0, Q0, [0.0, 10.0], method="dop853")
    assert ds.attrs["epoch"] == "2026-03-20T00:00:00.000000Z"
    assert ds.time.attrs["units"].startswith("seconds since 2026-03-20")
    with pytest.raises(
        attitude.AttitudeValueError, match=r"^epoch: .*\(spacecraft\.orbit\.epoch\)"
    ):
        attitude.propagate(sc, q0, Q0, [0.0, 10.0], method="dop853", epoch="2026-03-21")
    other = orbit.KeplerOrbit(7000.0, 0.001, 0.5, 0.1, 0.0, epoch="2026-03-21T00:00:00")
    with pytest.raises(attitude.AttitudeValueError, match=r"^events: .*one time origin"):
        attitude.propagate(sc, q0, Q0, [0.0, 10.0], method="dop853",
                           events=[EclipseEntry(other)])  # fmt: skip


def _plate(face_area, edge_area):
    """A thin plate: faces ±x (area face_area), edges ±y (edge_area), centres at the centre of
    mass (no torque), C_D = 2.2."""
    from attitude import Facet

    return [
        Facet(face_area, [1, 0, 0], [0, 0, 0], cd=2.2),
        Facet(face_area, [-1, 0, 0], [0, 0, 0], cd=2.2),
        Facet(edge_area, [0, 1, 0], [0, 0, 0], cd=2.2),
        Facet(edge_area, [0, -1, 0], [0, 0, 0], cd=2.2),
    ]


def test_drag_decay_face_on_against_edge_on():
    # The same plate face-on (normal along the wind) and edge-on (its edge along the wind),
    # turning with a circular equatorial orbit so the wind stays fixed in the body, in a
    # constant-density atmosphere: the orbital energy falls at the ratio of the areas.
    mu = orbit.earth_mu()
    r0 = 6778.137
    v0 = math.sqrt(mu / r0)
    o = orbit.NumericalOrbit([r0, 0.0, 0.0], [0.0, v0, 0.0], EPOCH)
    face, edge = 1.0, 0.02
    facets = _plate(face, edge)
    inertia = np.array([2.0, 2.0, 3.0])
    t = np.linspace(0.0, 120.0, 3)
    drops = []
    # q0 = 1: body y along the velocity (the edge faces the wind); turned by −90° about z:
    # body −x along it (the face)
    for q0 in ([1.0, 0.0, 0.0, 0.0], [math.cos(math.pi / 4), 0, 0, -math.sin(math.pi / 4)]):
        q0 = np.array(q0)
        Q0 = momenta_from_angular_velocity(q0, [0.0, 0.0, v0 / r0], inertia)
        sc = Spacecraft(RigidBody(inertia), orbit=o, mass=100.0)
        drag = attitude.AerodynamicDrag(o, facets, density=1e-11)
        ds = attitude.propagate(sc, q0, Q0, t, drag, method="dop853", rtol=1e-13, atol=1e-13)
        r, v = ds.position.values, ds.velocity.values
        e = 0.5 * np.sum(v**2, axis=1) - mu * 1e9 / np.linalg.norm(r, axis=1)
        drops.append(e[0] - e[-1])
    edge_on, face_on = drops
    assert face_on > 0.0 and edge_on > 0.0
    assert abs((face_on / edge_on) / (face / edge) - 1.0) < 1e-6


def test_cubesat_decay_depends_on_its_attitude():
    # The shipped scenario's CubeSat, tumbling (coupled) against the same CubeSat held at a
    # fixed attitude (its inertia made enormous): drag slows them differently.
    from pathlib import Path

    from attitude.scenario import load

    sc = load(Path(__file__).resolve().parents[1] / "scenarios" / "cubesat_drag_decay.toml")
    craft = sc.spacecraft
    assert craft.coupled
    t = np.linspace(0.0, 3 * 5500.0, 4)
    mu = craft.orbit.mu * 1e9

    def energy_drop(body, q0, Q0):
        sc_ = Spacecraft(body, orbit=craft.orbit, mass=craft.mass)
        ds = attitude.propagate(sc_, q0, Q0, t, sc.potential, method="dop853", rtol=1e-10,
                                atol=1e-12)  # fmt: skip
        r, v = ds.position.values, ds.velocity.values
        e = 0.5 * np.sum(v**2, axis=1) - mu / np.linalg.norm(r, axis=1)
        return e[0] - e[-1]

    tumbling = energy_drop(craft.body, sc.q0, sc.Q0)
    frozen = RigidBody(craft.body.inertia * 1e9)
    c = math.cos(math.pi / 4)
    fixed = ([1.0, 0.0, 0.0, 0.0], [c, 0.0, c, 0.0], [c, c, 0.0, 0.0])  # b3 turned to b1, b2
    drops = [energy_drop(frozen, np.array(q), np.zeros(4)) for q in fixed]
    assert tumbling > 0.0 and all(d > 0.0 for d in drops)
    # fixed attitudes present different areas to the wind (18 % apart between these three),
    # and the tumbling CubeSat another (2 % from the nearest)
    assert max(drops) / min(drops) > 1.1
    assert min(abs(tumbling / d - 1.0) for d in drops) > 0.01


def test_orbit_raising_scenario_obeys_the_rocket_equation():
    from pathlib import Path

    from attitude.scenario import loads

    path = Path(__file__).resolve().parents[1] / "scenarios" / "orbit_raising_burn.toml"
    text = path.read_text().replace("stop = 4.0\nunit = \"h\"\ncount = 1441",
                                    "stop = 1500.0\nunit = \"s\"\ncount = 151")  # fmt: skip
    text = text.replace("duration = 2400.0", "duration = 600.0")
    sc = loads(text, path=path)
    ds = sc.run()
    m = ds.mass.values
    burnt = 1.0 / (220.0 * 9.80665) * 600.0
    assert abs((m[0] - m[-1]) / burnt - 1.0) < 1e-9
    # the orbital energy gained is the thrust's work v·Δv (to the pointing and v's change)
    r, v = ds.position.values, ds.velocity.values
    field = sc.spacecraft.orbit.gravity
    from astropy.time import Time, TimeDelta

    from orbit.frames import gcrs_to_itrs_matrix

    times = Time(sc.epoch.rstrip("Z"), scale="utc") + TimeDelta(ds.time.values, format="sec")
    R = gcrs_to_itrs_matrix(times)
    energy = 0.5 * np.sum(v**2, axis=1) + field.potential(np.einsum("nij,nj->ni", R, r))
    dv = 220.0 * 9.80665 * math.log(m[0] / m[-1])
    assert abs((energy[-1] - energy[0]) / (np.linalg.norm(v[0]) * dv) - 1.0) < 0.01
    assert float(np.nanmax(ds.error_angle.values[ds.tick.values > 60.0])) < 1e-2  # rad


def test_coupled_run_stops_at_impact():
    # A ballistic arc from 200 km with the attitude carried: the run ends at the surface,
    # keeping the samples before it and the state there.
    o = orbit.NumericalOrbit([6578.0, 0, 0], [0.5, 3.0, 0.0], EPOCH)
    sc = Spacecraft(RigidBody([10.0, 12.0, 14.0]), orbit=o, mass=100.0)
    q0, Q0 = _state(np.array([10.0, 12.0, 14.0]))
    t = np.linspace(0.0, 3600.0, 361)
    ds = attitude.propagate(sc, q0, Q0, t, method="dop853", rtol=1e-12, atol=1e-12)
    alone = o.propagate(t)
    ti = alone.attrs["impact_time"]
    assert ds.attrs["status"] == "event" and ds.attrs["event"] == "impact"
    assert (
        abs(ds.attrs["impact_time"] - ti) < 1e-6 and ds.time.values[-1] == ds.attrs["impact_time"]
    )
    assert ds.sizes["time"] == alone.sizes["time"] + 1  # the samples before, and the impact
    r = ds.position.values
    assert np.all(np.linalg.norm(r[:-1], axis=1) > 6.3567e6)
    np.testing.assert_allclose(r[:-1], alone.position.values, rtol=0, atol=1e-3)


def test_ensemble_member_stops_at_impact_on_its_last_sample():
    # The ballistic arc of test_coupled_run_stops_at_impact as an ensemble: a member's rows are
    # the shared samples' times, so it ends at its last sample before the surface (not the
    # state at the surface filed under the next sample's time); its stop time is the single
    # run's impact time.
    from attitude.ensemble import propagate_ensemble

    o = orbit.NumericalOrbit([6578.0, 0, 0], [0.5, 3.0, 0.0], EPOCH)
    crafts = [Spacecraft(RigidBody([10.0, 12.0, 14.0]), orbit=o, mass=100.0)] * 2
    t = np.linspace(0.0, 3600.0, 361)
    kw = dict(method="dop853", rtol=1e-12, atol=1e-12)
    one = attitude.propagate(crafts[0], Q_ID, np.zeros(4), t, **kw)
    ens = propagate_ensemble(crafts, np.tile(Q_ID, (2, 1)), np.zeros((2, 4)), t, **kw)
    n = one.sizes["time"] - 1  # the samples before the impact
    assert list(ens.member_status.values) == [4, 4]  # terminal_event
    assert np.all(ens.member_t_stop.values == one.attrs["impact_time"])
    p = ens.position.values[0]
    assert np.array_equal(p[:n], one.position.values[:n]) and np.all(np.isnan(p[n:]))


def test_ensemble_members_are_their_single_runs():
    # Dispersed orbits and masses about a nominal NumericalOrbit (with_state: one force model),
    # the model on the nominal orbit: each member is bit for bit its single run.
    from attitude.ensemble import propagate_ensemble

    o = _orbit()
    body = RigidBody(INERTIA)
    rng = np.random.default_rng(3)
    y0 = o.initial_state
    crafts = [
        Spacecraft(body, orbit=o.with_state((y0[:3] + rng.normal(0, 100.0, 3)) * 1e-3,
                                            (y0[3:] + rng.normal(0, 0.1, 3)) * 1e-3),
                   mass=MASS * (1.0 + 0.01 * k))
        for k in range(3)
    ]  # fmt: skip
    q0, Q0 = _state()
    t = np.linspace(0.0, 3000.0, 31)
    gg = attitude.GravityGradient(o)
    ens = propagate_ensemble(crafts, np.tile(q0, (3, 1)), np.tile(Q0, (3, 1)), t, gg,
                             method="dop853", rtol=1e-12, atol=1e-12)  # fmt: skip
    assert ens.position.dims == ("member", "time", "axis")
    for k, craft in enumerate(crafts):
        one = attitude.propagate(craft, q0, Q0, t, gg, method="dop853", rtol=1e-12, atol=1e-12)
        assert np.array_equal(ens.position.values[k], one.position.values)
        assert np.array_equal(ens.q.values[k], one.q.values)
        assert np.array_equal(ens.mass.values[k], one.mass.values)
        assert np.array_equal(ens.r.values[k], one.r.values)
    # the members differ: their orbits were dispersed by 100 m and 0.1 m/s
    gap = np.linalg.norm(ens.position.values[0, -1] - ens.position.values[1, -1])
    assert gap > 10.0


def test_scenario_ensemble_disperses_the_orbit_and_the_mass(tmp_path):
    from pathlib import Path

    import xarray as xr

    from attitude.ensemble import run_scenario
    from attitude.scenario import loads

    path = Path(__file__).resolve().parents[1] / "scenarios" / "cubesat_drag_decay.toml"
    text = path.read_text().replace('stop = 24.0\nunit = "h"\ncount = 1441',
                                    'stop = 600.0\nunit = "s"\ncount = 11')  # fmt: skip
    text += (
        "\n[ensemble]\nsize = 3\nseed = 7\nposition_error = 100.0\nposition_error_unit = 'm'\n"
        "velocity_error = 0.1\nvelocity_error_unit = 'm/s'\nmass_error = 0.02\n"
    )
    sc = loads(text, path=path)
    info = run_scenario(sc, tmp_path / "ens.nc")
    with xr.open_dataset(info["path"]) as ds:
        dr = ds.dispersion_position.values
        assert ds.position.dims == ("member", "time", "axis") and dr.shape == (3, 3)
        nominal = sc.spacecraft.orbit.initial_state
        np.testing.assert_allclose(ds.position.values[:, 0], nominal[:3] + dr, rtol=0, atol=1e-6)
        np.testing.assert_allclose(ds.mass.values[:, 0],
                                   4.0 * (1.0 + ds.dispersion_mass.values), rtol=1e-15)  # fmt: skip
        assert 50.0 < np.std(dr) < 200.0


def test_facet_forces_are_the_sums_of_each_facets_force():
    # The grouped compiled forces (what acts on a coupled orbit) against each facet's force in
    # numpy, from what the models' torques use (their `atmosphere` and `sunlight`); and their
    # moments about the centre of mass are the models' torques.
    from attitude import AerodynamicDrag, SolarRadiation
    from attitude._core import environment as _ke
    from attitude.facets import box_wing
    from attitude.quaternion import conjugate

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.7, 0.3, 0.2, epoch=EPOCH)
    facets = box_wing([0.3, 0.2, 0.5], center=[0.02, -0.01, 0.05], specular=0.3, diffuse=0.2)
    rng = np.random.default_rng(11)
    t = np.sort(rng.uniform(0.0, 5000.0, 12))
    qs = rng.normal(size=(12, 4))
    qs /= np.linalg.norm(qs, axis=1)[:, None]
    drag = AerodynamicDrag(o, facets, density="exponential")
    srp = SolarRadiation(o, facets)
    air, sun = drag.atmosphere(t), srp.sunlight(t)
    pd, ps = drag._kernel_params(t), srp._kernel_params(t)
    for k in range(t.size):
        q = qs[k]
        v = rotate(conjugate(q), air["velocity"][k])  # body axes
        s = rotate(conjugate(q), sun["direction"][k])
        pressure = sun["shadow"][k] * ps[_ke.SRP.P] * (ps[_ke.SRP.AU] / sun["distance"][k]) ** 2
        fd = np.zeros(3)
        fs = np.zeros(3)
        td = np.zeros(3)
        ts = np.zeros(3)
        for f in facets:
            c = float(f.normal @ v)
            if c > 0.0:
                fk = -0.5 * air["density"][k] * f.cd * f.area * c * v
                fd += fk
                td += np.cross(f.center, fk)
            c = float(f.normal @ s)
            if c > 0.0:
                along_n = 2.0 * (f.specular * c + f.diffuse / 3.0)
                fk = -pressure * f.area * c * ((1.0 - f.specular) * s + along_n * f.normal)
                fs += fk
                ts += np.cross(f.center, fk)
        got_d = np.array(_ke.drag_force(q, t[k], pd, 0))
        got_s = np.array(_ke.solar_force(q, t[k], ps, 0))
        assert np.linalg.norm(got_d - fd) <= 1e-13 * np.linalg.norm(fd)
        assert np.linalg.norm(got_s - fs) <= 1e-13 * max(np.linalg.norm(fs), 1e-30)
        np.testing.assert_allclose(_ke.drag_torque(q, t[k], pd, 0), td, rtol=1e-12, atol=1e-24)
        np.testing.assert_allclose(_ke.solar_torque(q, t[k], ps, 0), ts, rtol=1e-12, atol=1e-24)
    assert np.any(sun["shadow"] > 0.0)


def test_recorded_drag_and_radiation_torques_follow_each_samples_environment():
    # The drag and radiation models of a coupled run read the environment the right-hand side
    # writes at the integrated state; the recorded torques must be evaluated at each sample's
    # own (was: the last one written, the same for a whole chunk: the radiation torque on in
    # shadow, off in sunlight). Truth: the same spacecraft on the same orbit given as a table
    # (not coupled), whose torques come from the models' tables: zero in the same samples
    # (umbra), and equal elsewhere to the small difference the coupling makes.
    from attitude.facets import box_wing

    o = orbit.NumericalOrbit([6622.60852, 1167.744565, 0.0], [-0.830622688, 4.71069535,
                                                              6.035105174], EPOCH)  # fmt: skip
    body = RigidBody([0.04226, 0.04057, 0.007975])
    facets = box_wing([0.1, 0.1, 0.34], center=[0.0, 0.0, -0.015], specular=0.1, diffuse=0.2)
    pot = attitude.SolarRadiation(o, facets) + attitude.AerodynamicDrag(o, facets, density=1e-11)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = momenta_from_angular_velocity(q0, [0.05, -0.04, 0.05], body.inertia)
    t = np.arange(0.0, 3 * 3600.0 + 1.0, 60.0)
    runs = [attitude.propagate(sc, q0, Q0, t, pot, rtol=1e-11, atol=1e-13)
            for sc in (Spacecraft(body, orbit=o, mass=4.0), Spacecraft(body, orbit=o))]  # fmt: skip
    (srp_c, drag_c), (srp_t, drag_t) = (ds.torque.values[:, :2].transpose(1, 0, 2) for ds in runs)
    dark = np.linalg.norm(srp_t, axis=1) == 0.0
    assert 20 < dark.sum() < len(t) - 20
    assert np.array_equal(np.linalg.norm(srp_c, axis=1) == 0.0, dark)
    # measured 1.0e-5 and 1.6e-4 of the largest torque: the coupled attitude differs by 5e-6
    assert np.abs(srp_c - srp_t).max() < 1e-4 * np.abs(srp_t).max()
    assert np.abs(drag_c - drag_t).max() < 1e-3 * np.abs(drag_t).max()


def test_sampled_field_is_fourth_order_and_off_for_long_steps():
    # At 10 Hz the closed loop's steps are 0.1 s: the field beyond the point mass and the Sun
    # and Moon are sampled every field_step seconds and taken from the cubic through the last
    # four samples (attitude._core.coupled). Against the same run with them evaluated at every
    # stage, the orbit's error falls as field_step⁴ (a cubic extrapolation's); measured 600 s:
    # 1.4e-6, 2.1e-5, 3.2e-4 m at 2, 4, 8 s, 7e-8 m at the default 1 s.
    from test_software import hr16_spacecraft

    from attitude.control import MRPFeedback
    from attitude.quaternion import from_mrp
    from attitude.software import FlightSoftware

    base = hr16_spacecraft()
    q0 = from_mrp([0.1, 0.2, -0.3])
    fsw = FlightSoftware(0.1, attitude.frames.inertial(), MRPFeedback(3.5, 30.0))
    field = orbit.SphericalHarmonics(20)
    t = np.linspace(0.0, 600.0, 5)
    err = {}
    for h in (0.0, 1.0, 2.0, 4.0, 8.0):
        o = orbit.NumericalOrbit([6878.137, 0.0, 0.0], [0.0, 4.7329, 5.9744], EPOCH,
                                 gravity=field, third_bodies=("sun", "moon"),
                                 field_step=h)  # fmt: skip
        craft = Spacecraft(base.body, base.wheels, orbit=o, mass=750.0)
        Q0 = momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
        ds = attitude.propagate(craft, q0, Q0, t, attitude.GravityGradient(o), software=fsw,
                                method="dop853", rtol=1e-12)  # fmt: skip
        # the Dataset says how its orbit was integrated
        assert ("sampled every" in ds.attrs["orbit"]) == (h > 0.0)
        if h == 0.0:
            exact = ds.position.values
        else:
            assert f"sampled every {h:g} s" in ds.attrs["orbit"]
            err[h] = np.linalg.norm(ds.position.values - exact, axis=1).max()
    for h in (2.0, 4.0):
        assert 12.0 < err[2 * h] / err[h] < 20.0  # 2⁴
    assert err[1.0] < 1e-12 * 6.9e6
    # Steps longer than half the interval (a free body on its own) never sample: the field is
    # evaluated at every stage, bit for bit the run with field_step = 0.
    runs = []
    for h in (0.0, 1.0):
        o = _orbit(gravity=field, third_bodies=("sun",), field_step=h)
        sc = Spacecraft(RigidBody(INERTIA), orbit=o, mass=MASS)
        runs.append(attitude.propagate(sc, *_state(), np.linspace(0.0, 3000.0, 4),
                                       attitude.GravityGradient(o), method="dop853"))  # fmt: skip
    assert runs[0].sizes == runs[1].sizes
    np.testing.assert_array_equal(runs[0].position.values, runs[1].position.values)

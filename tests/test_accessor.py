"""The ds.attitude accessor, checked against scipy's rotations and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from astropy import units as u
from astropy.constants import GM_earth
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

import attitude.accessor  # noqa: F401 - registers ds.attitude
from attitude import scenario
from attitude.propagate import propagate

I_SAT = u.Quantity([400.0, 500.0, 600.0], "kg m2")


@pytest.fixture(scope="module")
def run():
    rng = np.random.default_rng(3)
    q0 = rng.normal(size=4)
    q0 /= np.linalg.norm(q0)
    w = np.array([0.02, -0.01, 0.015])  # rad/s
    g = I_SAT.value * w
    gq = np.concatenate([[0.0], g])
    # Q0 = 2 q∘(0, g), Hamilton product written out
    a0, a = q0[0], q0[1:]
    Q0 = 2 * np.concatenate([[-a @ gq[1:]], a0 * gq[1:] + np.cross(a, gq[1:])])
    ds = propagate(I_SAT, q0, Q0, np.linspace(0, 600.0, 61))
    ds.attrs["epoch"] = "2024-03-20T12:00:00.000000Z"
    return ds


def _scipy(q):
    return Rotation.from_quat(np.roll(q, -1, axis=-1))  # scipy is scalar last


def test_quantity_units(run):
    G = run.attitude.quantity("G")
    assert G.unit == u.Unit("kg m2 / s")  # SI (was kg km² s⁻¹ before issue 16)
    np.testing.assert_array_equal(G.value, run.G.values)
    assert run.attitude.quantity("q").unit == u.dimensionless_unscaled
    assert run.attitude.quantity("time").to_value("min")[-1] == pytest.approx(10.0)
    E = run.attitude.quantity("energy").to(u.erg)  # J = 1e7 erg
    np.testing.assert_allclose(E.value, run.energy.values * 1e7, rtol=1e-15)
    with pytest.raises(ValueError, match="no variable 'nope'"):
        run.attitude.quantity("nope")


@pytest.mark.parametrize("seq,scipy_seq", [("313", "ZXZ"), ("321", "ZYX"), ("123", "XYZ")])
def test_euler_angles_match_scipy_intrinsic(run, seq, scipy_seq):
    a = run.attitude.euler_angles(seq)
    assert a.dims == ("time", "angle") and a.attrs["units"] == "rad"
    ref = _scipy(run.q.values).as_euler(scipy_seq)  # upper case: intrinsic
    # same rotation (angles may differ by the equivalent-set ambiguity): compare rotations
    back = Rotation.from_euler(scipy_seq, a.values)
    d = (back.inv() * Rotation.from_euler(scipy_seq, ref)).magnitude()
    assert np.max(d) < 1e-12


def test_matrix_maps_body_to_space(run):
    R = run.attitude.matrix().values
    np.testing.assert_allclose(R, _scipy(run.q.values).as_matrix(), atol=1e-15)
    # G (space) = R g (body), both from the result (to the run's |q| - 1 drift)
    scale = np.max(np.abs(run.G.values)) * max(1e-14, 4 * float(np.max(abs(run.norm_error))))
    np.testing.assert_allclose(
        np.einsum("nij,nj->ni", R, run.g.values), run.G.values, rtol=0, atol=scale
    )


def test_angle_between_known_rotation(run):
    alpha = 0.3
    r = np.array([np.cos(alpha / 2), 0.0, np.sin(alpha / 2) * 0.6, np.sin(alpha / 2) * 0.8])
    other = run.copy()
    other["q"] = run.q.copy(data=(_scipy(run.q.values) * _scipy(r)).as_quat()[:, [3, 0, 1, 2]])
    ang = run.attitude.angle_between(other)
    np.testing.assert_allclose(ang.values, alpha, rtol=1e-12)
    np.testing.assert_allclose(run.attitude.angle_between(run).values, 0.0, atol=1e-15)
    with pytest.raises(ValueError, match="same output times"):
        run.attitude.angle_between(run.isel(time=slice(1, None)))


def test_an_ensemble_is_refused_by_the_views_of_one_history(run):
    """The views of one attitude history refuse an ensemble (a member dimension) with the
    package's error naming the fix, as relative_to does; they raised xarray's 'different
    number of dimensions' and numpy's 'axis remapping' errors. A member selected works."""
    from attitude.errors import AttitudeValueError

    ens = xr.concat([run, run], dim="member").transpose("member", ...)
    for call in (
        lambda d: d.attitude.euler_angles("313"),
        lambda d: d.attitude.matrix(),
        lambda d: d.attitude.angle_between(run),
    ):
        with pytest.raises(AttitudeValueError, match=r"^ds: an ensemble; select a member first"):
            call(ens)
        call(ens.isel(member=1))
    np.testing.assert_array_equal(
        ens.isel(member=1).attitude.euler_angles("321").values,
        run.attitude.euler_angles("321").values,
    )


def test_times_and_no_orbit(run):
    t = run.attitude.times()
    assert t[-1].isot == "2024-03-20T12:10:00.000"
    assert not run.attitude.has_orbit
    with pytest.raises(ValueError, match="no orbit"):
        run.attitude.radius()


def test_orbit_views_on_gravity_gradient_run():
    sc = scenario.loads(
        """
        [scenario]
        epoch = "2024-03-20T12:00:00"
        [body]
        inertia = [60.0, 950.0, 1000.0]
        inertia_unit = "kg m2"
        [initial_state]
        form = "euler_body_rates"
        frame = "orbital"
        seq = "321"
        angles = [5.0, 2.0, 3.0]
        angles_unit = "deg"
        omega = [0.0, 0.0, 0.0]
        omega_unit = "deg/s"
        [potential]
        kind = "gravity_gradient"
        [orbit]
        a = 7078.137
        a_unit = "km"
        e = 0.001
        inc = 98.19
        inc_unit = "deg"
        raan = 30.0
        raan_unit = "deg"
        argp = 90.0
        argp_unit = "deg"
        [time]
        stop = 600.0
        step = 60.0
        unit = "s"
        """
    )
    ds = sc.run()
    assert ds.attitude.has_orbit
    assert ds.attitude.radius().unit == u.km
    t = ds.attitude.quantity("time").to_value(u.s)
    # Kepler's closed form with the documented default μ (astropy's GM_earth), f0 = 0 at t = 0
    a, e = 7078.137e3, 0.001
    inc, raan, argp = np.radians([98.19, 30.0, 90.0])
    mu = GM_earth.to_value("m3 / s2")
    n = np.sqrt(mu / a**3)
    E = np.array([brentq(lambda x, m=n * ti: x - e * np.sin(x) - m, -1.0, n * ti + 1.0,
                         xtol=1e-15) for ti in t])  # fmt: skip
    r = a * (1 - e * np.cos(E))
    f = 2 * np.arctan2(np.sqrt(1 + e) * np.sin(E / 2), np.sqrt(1 - e) * np.cos(E / 2))
    np.testing.assert_allclose(ds.attitude.radius().to_value(u.m), r, rtol=1e-13)
    np.testing.assert_allclose(ds.attitude.true_anomaly().to_value(u.rad), f, rtol=0, atol=1e-12)
    # orbital frame: columns radial, along-track, orbit normal (R3(Ω) R1(i) R3(ω + f))
    orb = Rotation.from_euler("ZXZ", np.column_stack([np.full_like(f, raan),
                              np.full_like(f, inc), argp + f]))  # fmt: skip
    d = (orb.inv() * _scipy(ds.attitude.orbit_frame().values)).magnitude()
    assert np.max(d) < 1e-12
    # The attitude by a second formulation: Euler's equations with the gravity-gradient torque
    # 3μ/r³ x̂_B × I x̂_B and q̇ = ½ q∘(0, ω), in SI, integrated by scipy; initial rates: zero
    # relative to the orbital frame, i.e. the frame's rate ḟ = √(μ a (1 − e²))/r² about z_O.
    inertia = np.array([60.0, 950.0, 1000.0])
    rel0 = Rotation.from_euler("ZYX", [5.0, 2.0, 3.0], degrees=True)
    att0 = orb[0] * rel0
    w0 = rel0.inv().apply([0.0, 0.0, np.sqrt(mu * a * (1 - e**2)) / r[0] ** 2])

    def rhs(ti, y):
        q, w = y[:4] / np.linalg.norm(y[:4]), y[4:]
        Ei = brentq(lambda x: x - e * np.sin(x) - n * ti, -1.0, n * ti + 1.0, xtol=1e-15)
        fi = 2 * np.arctan2(np.sqrt(1 + e) * np.sin(Ei / 2), np.sqrt(1 - e) * np.cos(Ei / 2))
        ri = a * (1 - e * np.cos(Ei))
        xs = Rotation.from_euler("ZXZ", [raan, inc, argp + fi]).apply([1.0, 0.0, 0.0])
        xb = _scipy(q).inv().apply(xs)
        tau = 3 * mu / ri**3 * np.cross(xb, inertia * xb)
        dw = (tau - np.cross(w, inertia * w)) / inertia
        dq = 0.5 * np.array([-q[1:] @ w, *(q[0] * w + np.cross(q[1:], w))])
        return np.concatenate([dq, dw])

    y0 = np.concatenate([np.roll(att0.as_quat(), 1), w0])
    sol = solve_ivp(rhs, (t[0], t[-1]), y0, method="DOP853", t_eval=t, rtol=1e-12, atol=1e-15)
    ref_rel = orb.inv() * _scipy(sol.y[:4].T)
    rel = ds.attitude.relative_to_orbit().values
    err = (_scipy(rel).inv() * ref_rel).magnitude()
    assert np.max(err) < 1e-9, np.max(err)  # measured 1.1e-10 (the run's rtol 1e-10)
    # at t0 the relative attitude is the scenario's 3-2-1 angles (scipy: intrinsic "ZYX")
    assert (_scipy(rel[0]).inv() * rel0).magnitude() < 1e-14
    np.testing.assert_allclose(ds.omega.values[0], w0, rtol=1e-12)
    # and it librates: the attitude moves away from its initial value relative to the frame
    assert np.max((_scipy(rel).inv() * rel0).magnitude()) > 0.01  # measured 0.05 rad


def test_frames_of_a_coupled_run_are_on_its_propagated_orbit():
    # A spacecraft carrying its orbit, pushed along +y body for ten minutes (Δv = 12 m/s): the
    # VNC frame of the run's own orbit (x = v̂, y = ĥ) written out from the Dataset's position
    # and velocity is what relative_to(vnc(o)) measures against, not the frame of o alone.
    import orbit
    from attitude import CommandSchedule, RigidBody, Spacecraft, frames
    from attitude.actuators import Thruster
    from attitude.quaternion import conjugate, from_matrix, multiply

    o = orbit.NumericalOrbit([7000.0, 0.0, 0.0], [0.0, 7.546, 0.1], "2026-03-20T00:00:00")
    th = Thruster([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 2.0)
    sc = Spacecraft(RigidBody([10.0, 12.0, 14.0]), thrusters=[th], orbit=o, mass=100.0)
    t = np.linspace(0.0, 6000.0, 101)
    ds = propagate(sc, [1.0, 0, 0, 0], np.zeros(4), t, method="dop853", rtol=1e-12, atol=1e-12,
                   commands=CommandSchedule([0.0, 600.0], thrust=[[1.0], [0.0]]))  # fmt: skip
    rel = ds.attitude.relative_to(frames.vnc(o))
    assert rel.attrs["frame_orbit"].startswith("the run's propagated orbit")
    r, v = ds.position.values, ds.velocity.values
    x = v / np.linalg.norm(v, axis=1)[:, None]
    y = np.cross(r, v)
    y /= np.linalg.norm(y, axis=1)[:, None]
    R = np.stack([x, y, np.cross(x, y)], axis=-1)  # reference → space, columns the axes
    q_br = multiply(conjugate(from_matrix(R)), ds.q.values)
    want = 2.0 * np.arctan2(np.linalg.norm(q_br[:, 1:], axis=1), np.abs(q_br[:, 0]))
    np.testing.assert_allclose(rel.error_angle.values, want, rtol=0, atol=1e-12)
    # the frame of the orbit alone is another one after the burn
    alone = frames.vnc(o).evaluate(t)[0]
    gap = 2.0 * np.arcsin(np.minimum(1.0, np.linalg.norm(
        multiply(conjugate(alone), from_matrix(R))[:, 1:], axis=1)))  # fmt: skip
    assert gap[0] < 1e-12 and gap[-1] > 1e-2  # 0.028 rad
    # the same frame on another orbit (a target's, starting elsewhere) is left as it is
    other = orbit.NumericalOrbit([7100.0, 0.0, 0.0], [0.0, 7.49, 0.1], "2026-03-20T00:00:00")
    assert "frame_orbit" not in ds.attitude.relative_to(frames.vnc(other)).attrs
    po = ds.attitude.propagated_orbit()
    np.testing.assert_allclose(po.position(t[50]) * 1e3, r[50], rtol=0, atol=1e-6)

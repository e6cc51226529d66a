"""The ds.attitude accessor, checked against scipy's rotations and closed forms."""

from __future__ import annotations

import numpy as np
import pytest
from astropy import units as u
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
    # e = 0.001: r within a(1 ± e)
    assert np.all(np.abs(ds.attitude.radius().value - 7078.137) <= 7078.137 * 0.001 + 1e-9)
    rel = ds.attitude.relative_to_orbit().values
    # at t0 the relative attitude is the scenario's 3-2-1 angles (scipy: intrinsic "ZYX")
    ref = Rotation.from_euler("ZYX", [5.0, 2.0, 3.0], degrees=True)
    assert (_scipy(rel[0]).inv() * ref).magnitude() < 1e-14
    # librating about nadir pointing: stays within a few degrees over the 10 minutes
    ang = np.degrees((_scipy(rel)).magnitude())
    assert np.all(ang < 10.0)

"""The environment a user torque reads: ``CustomTorque(tau, orbit=o)``, ``tau(q, t, env)``.

Against independent truth: the field torque m × B_B written by hand from ``env`` is the built-in
MagneticDipole's (same tables: equal to round-off, and so are the trajectories); the Sun's
direction, distance and shadow against astropy's Sun (``orbit.sun.sun_position``) and the shadow
function called from Python; r, v against the orbit's own state, the orbital frame against the
closed form of its elements; a rate-dependent torque against EddyCurrentDamping in a constant
field. The user torques live in tests/env_torques.py (cached by numba across runs).
"""

from __future__ import annotations

import env_torques as et
import numpy as np
import pytest
from astropy.time import Time, TimeDelta

import attitude
import orbit
from attitude import quaternion as aq
from attitude.canonical import momenta_from_angular_velocity
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import (
    CustomTorque,
    EddyCurrentDamping,
    EnvironmentIndex,
    GravityGradient,
    MagneticDipole,
)
from orbit.sun import shadow_function, sun_position

E = EnvironmentIndex
EPOCH = "2024-03-20T12:00:00"
INERTIA = [0.05, 0.06, 0.02]
RNG = np.random.default_rng(25)


@pytest.fixture(scope="module")
def leo():
    # 600 km, i = 97.8°: the orbit's eclipses at this date are ~35 min of each 97 min
    return orbit.KeplerOrbit(6978.0, 0.001, np.radians(97.8), 0.3, 0.2, M0=0.1, epoch=EPOCH)


def _samples(n, hi):
    t = np.sort(RNG.uniform(0.0, hi, n))
    return t, aq.normalize(RNG.normal(size=(n, 4)))


def test_field_torque_from_env_is_the_magnetic_dipole_torque(leo):
    """m × B_B from env's FIELD is MagneticDipole(m)'s torque: the same table, the same
    interpolation, the same rotation into body axes (equal to the last bit here)."""
    ct = CustomTorque(et.dipole_torque, orbit=leo)
    md = MagneticDipole(leo, et.DIPOLE)
    t, q = _samples(40, 6000.0)
    got, want = ct.torque(q, t), md.torque(q, t)
    scale = np.abs(want).max()
    assert np.abs(got - want).max() <= 1e-15 * scale
    b_body = aq.rotate_inverse(q, md.magnetic_field(t))
    env = ct.environment(t, q)
    np.testing.assert_allclose(env[:, E.FIELD : E.FIELD + 3], b_body, rtol=0, atol=1e-15 * 5e-5)


def test_run_with_field_torque_is_the_magnetic_dipole_run(leo):
    """dop853 with the hand-written field torque, alone and plus the gravity gradient, follows
    MagneticDipole's trajectory to round-off (the right-hand sides agree to the last bit)."""
    t = np.linspace(0.0, 1800.0, 19)
    q0 = aq.normalize([1.0, 0.2, -0.1, 0.3])
    Q0 = momenta_from_angular_velocity(q0, [0.01, -0.02, 0.03], INERTIA)
    ct = CustomTorque(et.dipole_torque, orbit=leo, name="rods")
    md = MagneticDipole(leo, et.DIPOLE)
    for a, b in (
        (ct, md),
        (GravityGradient(leo) + ct, GravityGradient(leo) + md),
    ):
        x = attitude.propagate(INERTIA, q0, Q0, t, potential=a, rtol=1e-12, atol=1e-14)
        y = attitude.propagate(INERTIA, q0, Q0, t, potential=b, rtol=1e-12, atol=1e-14)
        assert float(np.abs(x.q - y.q).max()) <= 1e-14
        assert float(np.abs(x.Q - y.Q).max()) <= 1e-14 * float(np.abs(y.Q).max())
        # the per-term torques name the user term and add up to the built-in ones
        np.testing.assert_allclose(
            x.torque.values[:, -1], y.torque.values[:, -1], rtol=0, atol=1e-15 * 1e-5
        )
    assert "rods" in list(x.model_label.values)


def test_auto_picks_dop853_for_an_environment_torque_bit_for_bit(leo):
    """taylor has no series for a user's torque: method="auto" (the default) runs dop853 with
    CustomTorque(..., orbit=o), alone and beside the gravity gradient, bit for bit."""
    from test_propagate import _same_run

    t = np.linspace(0.0, 600.0, 7)
    q0 = aq.normalize([1.0, 0.2, -0.1, 0.3])
    Q0 = momenta_from_angular_velocity(q0, [0.01, -0.02, 0.03], INERTIA)
    ct = CustomTorque(et.dipole_torque, orbit=leo)
    for pot in (ct, GravityGradient(leo) + ct):
        auto = attitude.propagate(INERTIA, q0, Q0, t, potential=pot, rtol=1e-12, atol=1e-14)
        assert auto.attrs["method"] == "dop853" and auto.attrs["method_requested"] == "auto"
        kw = dict(potential=pot, method="dop853", rtol=1e-12, atol=1e-14)
        _same_run(auto, attitude.propagate(INERTIA, q0, Q0, t, **kw))


def test_splitting_with_field_torque_is_the_magnetic_dipole_run(leo):
    """The composition methods take a torque tau(q, t, env) (not rate-dependent) like any user
    torque: the same trajectory as MagneticDipole's."""
    t = np.linspace(0.0, 600.0, 7)
    q0 = aq.normalize([1.0, 0.2, -0.1, 0.3])
    Q0 = momenta_from_angular_velocity(q0, [0.01, -0.02, 0.03], INERTIA)
    ct = CustomTorque(et.dipole_torque, orbit=leo)
    assert not ct.rate_dependent
    md = MagneticDipole(leo, et.DIPOLE)
    x = attitude.propagate(INERTIA, q0, Q0, t, potential=ct, method="splitting", dt=10.0)
    y = attitude.propagate(INERTIA, q0, Q0, t, potential=md, method="splitting", dt=10.0)
    assert float(np.abs(x.q - y.q).max()) <= 1e-14


def test_euler_equations_with_field_torque_is_the_magnetic_dipole_run(leo):
    """The formulations append their scratch to the parameters: the environment blocks are
    where that does not reach (same trajectory as MagneticDipole's)."""
    t = np.linspace(0.0, 600.0, 7)
    q0 = aq.normalize([1.0, 0.2, -0.1, 0.3])
    Q0 = momenta_from_angular_velocity(q0, [0.01, -0.02, 0.03], INERTIA)
    kw = dict(formulation="euler_equations", rtol=1e-12, atol=1e-14)
    ct = CustomTorque(et.dipole_torque, orbit=leo)
    x = attitude.propagate(INERTIA, q0, Q0, t, potential=ct, **kw)
    y = attitude.propagate(INERTIA, q0, Q0, t, potential=MagneticDipole(leo, et.DIPOLE), **kw)
    assert float(np.abs(x.q - y.q).max()) <= 1e-14


def test_two_environment_torques_in_a_sum_read_their_own_blocks(leo):
    """Two user terms reading the environment (different field models) with built-in terms:
    the sum's torque is the sum of the terms' torques, each term's the one alone."""
    a = CustomTorque(et.dipole_torque, orbit=leo, name="rods")
    b = CustomTorque(et.sun_torque, orbit=leo, field="dipole", name="sun")
    gg = GravityGradient(leo, inertia=INERTIA)
    md = MagneticDipole(leo, [0.0, 0.0, 0.01], field="dipole")
    total = gg + a + md + b
    assert total.term_names() == ["gravity_gradient", "magnetic_dipole", "rods", "sun"]
    t, q = _samples(20, 3000.0)
    each = [p.torque(q, t) for p in (gg, md, a, b)]
    got = total.torque(q, t)
    scale = max(np.abs(x).max() for x in each)
    np.testing.assert_allclose(got, sum(each), rtol=0, atol=4e-16 * scale)


@pytest.mark.slow
def test_flight_software_run_with_field_torque_is_the_magnetic_dipole_run(leo):
    """A closed-loop run (the software's compiled loop) with the environment torque."""
    from attitude import frames
    from attitude.control import MRPFeedback
    from attitude.software import FlightSoftware

    t = np.linspace(0.0, 600.0, 13)
    q0 = aq.normalize([1.0, 0.2, -0.1, 0.3])
    Q0 = momenta_from_angular_velocity(q0, [0.01, -0.02, 0.03], INERTIA)
    craft = attitude.Spacecraft(attitude.RigidBody(INERTIA), orbit=leo)
    fsw = FlightSoftware(1.0, guidance=frames.inertial(), control=MRPFeedback(K=0.001, P=0.01))
    kw = dict(software=fsw, rtol=1e-12, atol=1e-14)
    ct = CustomTorque(et.dipole_torque, orbit=leo)
    x = attitude.propagate(craft, q0, Q0, t, potential=ct, **kw)
    y = attitude.propagate(craft, q0, Q0, t, potential=MagneticDipole(leo, et.DIPOLE), **kw)
    assert float(np.abs(x.q - y.q).max()) <= 1e-14


@pytest.mark.slow
def test_ensemble_with_field_torque_members_are_magnetic_dipole_runs(leo):
    """propagate_ensemble takes the environment torque (its parameters shared by the members):
    each member is MagneticDipole's single run to round-off."""
    from attitude.ensemble import propagate_ensemble

    t = np.linspace(0.0, 1800.0, 19)
    n = 4
    q = aq.normalize(RNG.normal(size=(n, 4)))
    Q = momenta_from_angular_velocity(q, RNG.normal(scale=0.02, size=(n, 3)), INERTIA)
    ct = CustomTorque(et.dipole_torque, orbit=leo)
    ds = propagate_ensemble(INERTIA, q, Q, t, ct, rtol=1e-12, atol=1e-14)
    md = MagneticDipole(leo, et.DIPOLE)
    for i in range(n):
        x = attitude.propagate(INERTIA, q[i], Q[i], t, potential=md, rtol=1e-12, atol=1e-14)
        assert np.abs(ds.q.values[i] - x.q.values).max() <= 1e-13


def test_sun_torque_from_env_matches_astropy_sun(leo):
    """k ν ŝ_B from env against the Sun of astropy (orbit.sun.sun_position, called directly at
    each time), the orbit's positions and the conical shadow function called from Python; the
    samples cross an eclipse and both penumbrae."""
    ct = CustomTorque(et.sun_torque, orbit=leo)
    nu_all = shadow_function(leo.position(np.arange(0, 6000.0, 1.0)), sun_position(EPOCH, 0.0))
    edges = np.flatnonzero(np.diff(nu_all > 0.5))  # the shadow's entry and exit
    assert edges.size >= 2
    t_pen = np.concatenate([e + np.linspace(-6.0, 6.0, 7) for e in edges[:2]])
    t = np.sort(np.concatenate([RNG.uniform(0.0, 6000.0, 30), t_pen]))
    q = aq.normalize(RNG.normal(size=(t.size, 4)))
    r = leo.position(t)
    s = sun_position(EPOCH, t)
    d = s - r
    dist = np.linalg.norm(d, axis=1)
    nu = shadow_function(r, s)
    assert (nu == 0).any() and (nu == 1).any() and ((nu > 0) & (nu < 1)).sum() >= 4
    want = et.SUN_GAIN * nu[:, None] * aq.rotate_inverse(q, d / dist[:, None])
    got = ct.torque(q, t)
    assert np.abs(got - want).max() < 1e-8 * et.SUN_GAIN  # the penumbra: ν from the table's Sun
    env = ct.environment(t, q)
    sb = env[:, E.SUN : E.SUN + 3]
    assert np.linalg.norm(sb - aq.rotate_inverse(q, d / dist[:, None]), axis=1).max() < 1e-12
    assert np.abs(env[:, E.SUN_DISTANCE] / dist - 1.0).max() < 1e-13
    lit = (nu == 0) | (nu == 1)
    np.testing.assert_array_equal(env[lit, E.SHADOW], nu[lit])


@pytest.mark.parametrize("source", ["kepler", "tle"])
def test_position_velocity_and_orbital_frame_are_the_orbits(leo, source):
    """r through the torque path and v through env equal the orbit's state(t); the RSW frame
    is the orbit's frame quaternion (closed form of the elements for a Kepler orbit)."""
    if source == "kepler":
        o = leo
        t, q = _samples(25, 20000.0)
    else:
        line1 = "1 40027U PLANET   20053.08335648  .00000000  00000+0  34079-4 0    09"
        line2 = "2 40027 097.9376 341.9424 0011991 325.7224 261.4362 14.90036668    06"
        start = Time("2020-02-22T02:00:00", scale="utc")
        o = orbit.EphemerisOrbit.from_tle(
            line1, line2, start, start + TimeDelta(3 * 3600, format="sec"), 60.0, epoch=start
        )
        t, q = _samples(25, 3 * 3600.0)
        t[0], t[-1] = 0.0, 3 * 3600.0  # the table's ends
    ct = CustomTorque(et.position_torque, orbit=o, field=None)
    r, v = o.to_state(t)
    assert np.abs(ct.torque(q, t) - r).max() <= 1e-15 * 7000.0
    env = ct.environment(t, q)
    assert np.abs(env[:, E.R : E.R + 3] - r).max() <= 1e-15 * 7000.0
    assert np.abs(env[:, E.V : E.V + 3] - v).max() <= 1e-15 * 8.0
    assert np.isnan(env[:, E.FIELD : E.FIELD + 3]).all()  # field=None
    p = o.frame_quaternion(t)
    qr = env[:, E.Q_RSW : E.Q_RSW + 4]
    err = np.minimum(np.abs(qr - p).max(axis=1), np.abs(qr + p).max(axis=1))
    assert err.max() < 1e-12


def test_rate_dependent_env_torque_is_eddy_current_damping_in_a_constant_field(leo):
    """tau(q, omega, t, env) = (M (ω × B)) × B with a constant space-frame field is
    EddyCurrentDamping's torque (whose field rate is zero there) to round-off."""
    b_space = np.array([1.8e-5, -2.2e-5, 3.1e-5])
    ct = CustomTorque(et.eddy_torque, orbit=leo, field=b_space)
    assert ct.rate_dependent
    ref = EddyCurrentDamping(None, et.EDDY, field=b_space)
    t, q = _samples(20, 3000.0)
    w = RNG.normal(scale=0.1, size=(t.size, 3))
    got, want = ct.torque(q, t, omega=w), ref.torque(q, t, omega=w)
    assert np.abs(got - want).max() <= 4e-16 * np.abs(want).max()


def test_undated_orbit_gives_r_and_v_and_nan_for_the_sun():
    """Without an epoch, field=None (or a constant field) still gives r and v; the Sun's entries
    are NaN (the date is unknown)."""
    o = orbit.KeplerOrbit(7000.0, 0.01, 0.9, 0.1, 0.2, M0=0.0)
    ct = CustomTorque(et.position_torque, orbit=o, field=None)
    env = ct.environment([0.0, 100.0])
    np.testing.assert_array_equal(env[:, E.R : E.R + 3], o.position([0.0, 100.0]))
    assert np.isnan(env[:, E.SUN : E.SUN + 3]).all() and np.isnan(env[:, E.SHADOW]).all()


def test_bad_environment_input_is_refused_with_the_parameter_named(leo):
    with pytest.raises(AttitudeTypeError, match=r"^orbit: a torque tau\(q, omega, t, env\)"):
        CustomTorque(lambda q, w, t, env: (0.0, 0.0, 0.0))
    undated = orbit.KeplerOrbit(7000.0, 0.01, 0.9, 0.1, 0.2, M0=0.0)
    with pytest.raises(AttitudeValueError, match=r"^orbit: .*field='igrf'.*dated orbit"):
        CustomTorque(lambda q, t, env: (0.0, 0.0, 0.0), orbit=undated)
    with pytest.raises(AttitudeTypeError, match=r"^torque: expected a function tau\(q, t, env\)"):
        CustomTorque(lambda q, t: (0.0, 0.0, 0.0), orbit=leo)
    with pytest.raises(AttitudeTypeError, match=r"^orbit: .*got str"):
        CustomTorque(lambda q, t, env: (0.0, 0.0, 0.0), orbit="leo")
    with pytest.raises(AttitudeValueError, match=r"^field: .*give orbit="):
        CustomTorque(lambda q, t: (0.0, 0.0, 0.0), field="dipole")
    with pytest.raises(AttitudeValueError, match=r"^field: expected 'igrf'"):
        CustomTorque(lambda q, t, env: (0.0, 0.0, 0.0), orbit=leo, field="wmm")
    with pytest.raises(AttitudeTypeError, match=r"^torque: must be .*tau\(q, t, env\)"):
        CustomTorque(lambda q, t, env: env[E.FIELD : E.FIELD + 2], orbit=leo)
    with pytest.raises(AttitudeValueError, match=r"^orbit: this CustomTorque reads no env"):
        CustomTorque(lambda q, t: (0.0, 0.0, 0.0)).environment(0.0)
    # one run, one time origin: the environment models' orbit and the torque's share the epoch
    other = orbit.KeplerOrbit(6978.0, 0.001, 1.7, 0.3, 0.2, M0=0.1, epoch="2024-03-21T12:00:00")
    tau = CustomTorque(lambda q, t, env: (0.0, 0.0, 0.0), orbit=other, field=None)
    with pytest.raises(AttitudeValueError, match=r"^orbit: .*different epochs"):
        MagneticDipole(leo, [0, 0, 1]) + tau
    # outside an ephemeris' table
    line1 = "1 40027U PLANET   20053.08335648  .00000000  00000+0  34079-4 0    09"
    line2 = "2 40027 097.9376 341.9424 0011991 325.7224 261.4362 14.90036668    06"
    start = Time("2020-02-22T02:00:00", scale="utc")
    eph = orbit.EphemerisOrbit.from_tle(
        line1, line2, start, start + TimeDelta(3600, format="sec"), 60.0, epoch=start
    )
    with pytest.raises(AttitudeValueError, match=r"^t: "):
        CustomTorque(et.position_torque, orbit=eph, field=None).torque([1, 0, 0, 0], 7200.0)

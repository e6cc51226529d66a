"""Sensors and the MEKF (issue 26): noise statistics that are provably what the parameters say
(Allan deviation, chi-square), exclusion geometry, the filter's consistency (NEES) and
convergence, reproducibility from seeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy import units as u
from scipy import stats

import attitude
from attitude import canonical as C
from attitude import frames
from attitude import quaternion as qt
from attitude._core import rng as _rng
from attitude.control import MRPFeedback
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.estimation import MEKF
from attitude.sensors import Gyro, Magnetometer, StarTracker
from attitude.software import FlightSoftware

BODY = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])


def test_xoshiro256starstar_is_the_published_generator():
    """The stream against xoshiro256** and SplitMix64 written again with Python's integers."""
    M = 2**64 - 1

    def splitmix(x):
        x = (x + 0x9E3779B97F4A7C15) & M
        z = x
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M
        return x, z ^ (z >> 31)

    def rotl(x, k):
        return ((x << k) | (x >> (64 - k))) & M

    x = 12345
    s = []
    for _ in range(4):
        x, z = splitmix(x)
        s.append(z)
    ref = []
    for _ in range(1000):
        ref.append((rotl((s[1] * 5) & M, 7) * 9) & M)
        t = (s[1] << 17) & M
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = rotl(s[3], 45)
    st = np.zeros(_rng.RNG_SIZE)
    _rng.seed_stream(st, 0, np.uint64(12345))
    ours = [int(_rng.next_u64(st, 0)) for _ in range(1000)]
    assert ours == ref


def test_normal_deviates_are_standard_normal():
    st = np.zeros(_rng.RNG_SIZE)
    _rng.seed_stream(st, 0, np.uint64(7))
    x = np.empty(200_000)
    _rng.normals_loop(st, 0, x)
    assert stats.kstest(x, "norm").pvalue > 0.001
    assert abs(x.mean()) < 4.0 / math.sqrt(x.size)
    # the sample variance: chi-square with n − 1 degrees of freedom, 99 % two-sided
    n = x.size
    v = (n - 1) * x.var(ddof=1)
    assert stats.chi2.ppf(0.005, n - 1) < v < stats.chi2.ppf(0.995, n - 1)


def _record(sensors, period, t_end, craft=None, q0=Q_ID, w0=(0.0, 0.0, 0.0), **kw):
    craft = craft if craft is not None else attitude.Spacecraft(BODY)
    fsw = FlightSoftware(period, sensors=sensors, **kw)
    Q0 = C.momenta_from_angular_velocity(q0, w0, craft)
    return attitude.propagate(
        craft,
        q0,
        Q0,
        np.array([0.0, t_end]),
        software=fsw,
        method="taylor" if not craft.magnetorquers else "dop853",
        rtol=1e-12,
    )


@pytest.mark.parametrize("period", [0.1, 1.0])
def test_gyro_allan_deviation_has_the_slopes_and_levels_of_its_parameters(period):
    """A stationary gyro's overlapping Allan deviation (allantools, checked against our own
    estimator) follows σ_v²/τ + σ_u² τ/3 (slopes −½ and +½) within its statistical
    uncertainty, at two tick rates: the discretisation is exact for any Δt."""
    allantools = pytest.importorskip("allantools")
    arw = 0.2 * u.deg / u.hour**0.5
    rrw = 3e-6 * u.rad / u.s**1.5
    g = Gyro(arw, rrw, seed=11)
    n = 40_000
    ds = _record([g], period, n * period)
    y = ds.gyro_rate.values[1:, 0]  # the first tick has no interval behind it
    taus = period * np.array([1, 3, 10, 30, 100, 300, 1000])
    t2, ad, _ade, _ = allantools.oadev(y, rate=1.0 / period, data_type="freq", taus=taus)
    model = np.sqrt(g.allan_variance(t2))
    m = np.rint(t2 / period)
    # our own overlapping estimator agrees with allantools
    x = np.concatenate([[0.0], np.cumsum(y)]) * period
    for k, mk in enumerate(m.astype(int)):
        d = x[2 * mk :] - 2 * x[mk:-mk] + x[: -2 * mk]
        own = math.sqrt(np.mean(d**2) / (2 * (mk * period) ** 2))
        assert abs(own / ad[k] - 1) < 1e-10
    # within 3 standard errors (edf of the overlapping estimator ~ (N/m) for white noise)
    rel = 3.0 * np.sqrt(1.0 / (2.0 * (y.size / m - 1)) + 0.5 * m / y.size)
    assert np.all(np.abs(ad / model - 1) < np.maximum(rel, 0.02))
    # the slopes: −½ at short τ (angle random walk), +½ at long τ (rate random walk)
    assert abs(math.log(ad[1] / ad[0]) / math.log(3.0) + 0.5) < 0.05


def test_star_tracker_and_magnetometer_noise_is_what_their_parameters_say():
    """The star tracker's error rotation in its sensor frame: N(0, diag(σc², σc², σb²)),
    uncorrelated (chi-square at 99 %); the magnetometer's error minus its bias: N(0, σ²)."""
    import orbit

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.0, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    craft = attitude.Spacecraft(BODY, orbit=o)
    st = StarTracker([5 * u.arcsec, 40 * u.arcsec], boresight=[1.0, 1.0, 0.0], seed=3)
    mag = Magnetometer(200 * u.nT, bias=[1e-7, -2e-7, 0.0], seed=4)
    q0 = qt.normalize([0.8, 0.3, -0.2, 0.4])
    ds = _record([st, mag], 1.0, 2000.0, craft, q0, (0.002, -0.001, 0.003))
    tick_t = ds.tick.values
    truth = attitude.propagate(
        craft,
        q0,
        C.momenta_from_angular_velocity(q0, (0.002, -0.001, 0.003), craft),
        tick_t,
        rtol=1e-13,
    )
    err = qt.to_rotation_vector(qt.multiply(qt.conjugate(truth.q.values), ds.star_tracker_q.values))
    e_s = err @ st.frame.T  # in the sensor frame
    sig = np.array([st.noise[0], st.noise[0], st.noise[1]])
    z = e_s / sig
    n = z.shape[0]
    chi = np.sum(z**2)
    assert stats.chi2.ppf(0.005, 3 * n) < chi < stats.chi2.ppf(0.995, 3 * n)
    corr = np.corrcoef(z.T)
    assert np.all(np.abs(corr[np.triu_indices(3, 1)]) < 3.5 / math.sqrt(n))
    for k in range(3):
        assert stats.chi2.ppf(0.005, n) < np.sum(z[:, k] ** 2) < stats.chi2.ppf(0.995, n)
    B = attitude.MagneticDipole(o, [0, 0, 0]).magnetic_field(tick_t)
    Bb = qt.rotate_inverse(truth.q.values, B)
    zm = (ds.magnetometer.values - Bb - mag.bias) / mag.noise
    assert stats.chi2.ppf(0.005, 3 * n) < np.sum(zm**2) < stats.chi2.ppf(0.995, 3 * n)


def test_star_tracker_exclusion_flags_exactly_when_the_geometry_says():
    """A turning spacecraft: the status says Sun (Earth) exclusion at exactly the ticks where
    the boresight is within the angle of the Sun, outside the Earth's shadow (of the Earth's
    limb), from astropy's Sun and the orbit, computed here independently."""
    import orbit
    from orbit.sun import R_EARTH, shadow_function, sun_position

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.0, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    # a sphere turning about the normal of the plane of its boresight and the Sun: the
    # boresight sweeps across the Sun and the Earth
    craft = attitude.Spacecraft(attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2"), orbit=o)
    st = StarTracker(
        5 * u.arcsec, [0.0, 0.0, 1.0], sun_exclusion=30 * u.deg, earth_exclusion=20 * u.deg, seed=5
    )
    s0 = sun_position(o.epoch, 0.0) - o.position(0.0)
    axis = np.cross([0.0, 0.0, 1.0], s0)
    w0 = tuple(0.01 * axis / np.linalg.norm(axis))
    ds = _record([st], 1.0, 3000.0, craft, Q_ID, w0)
    t = ds.tick.values
    truth = attitude.propagate(
        craft, Q_ID, C.momenta_from_angular_velocity(Q_ID, w0, craft), t, rtol=1e-13
    )
    bs = qt.rotate(truth.q.values, [0.0, 0.0, 1.0])
    r = o.position(t)
    sun = sun_position(o.epoch, t)
    lit = shadow_function(r, sun) > 0.0  # the Sun is excluded only where it is seen
    s = sun - r
    s /= np.linalg.norm(s, axis=1)[:, None]
    sun_ang = np.arccos(np.clip(np.sum(bs * s, axis=1), -1, 1))
    rn = np.linalg.norm(r, axis=1)
    earth_ang = np.arccos(np.clip(-np.sum(bs * r, axis=1) / rn, -1, 1)) - np.arcsin(R_EARTH / rn)
    expect = np.where(
        lit & (sun_ang < math.radians(30)), 2, np.where(earth_ang < math.radians(20), 3, 0)
    )
    got = ds.star_tracker_status.values
    margin = np.minimum(np.abs(sun_ang - math.radians(30)), np.abs(earth_ang - math.radians(20)))
    sure = margin > 1e-7  # the Sun table interpolates to ~1e-9 rad
    np.testing.assert_array_equal(got[sure], expect[sure])
    assert (expect == 2).any() and (expect == 3).any() and (expect == 0).any()


def _mekf_run(t_end, seed, q_err_deg=10.0, period=0.5):
    """Inertial pointing with three wheels, a gyro with bias and a 2 Hz star tracker, through
    the MEKF started 10° off."""
    from test_software import hr16_spacecraft

    craft = hr16_spacecraft()
    q0 = qt.from_mrp([0.02, -0.01, 0.03])
    Q0 = C.momenta_from_angular_velocity(q0, [0.0, 0.0, 0.0], craft)
    gyro = Gyro(
        0.05 * u.deg / u.hour**0.5,
        2e-9 * u.rad / u.s**1.5,
        bias=np.radians([3.0, -2.0, 1.5]) / 3600.0,
        seed=seed,
    )
    st = StarTracker([6 * u.arcsec, 45 * u.arcsec], [0.0, 0.6, 0.8], seed=seed + 1)
    q_est = qt.multiply(q0, qt.from_rotation_vector(np.radians([q_err_deg, 0.0, 0.0])))
    fsw = FlightSoftware(
        period,
        guidance=frames.inertial(),
        control=MRPFeedback(3.5, 30.0),
        sensors=[gyro, st],
        estimator=MEKF(initial_attitude=q_est),
        record_every=1,
    )
    return gyro, attitude.propagate(
        craft, q0, Q0, np.array([0.0, t_end]), software=fsw, method="taylor", rtol=1e-12
    )


def test_mekf_converges_from_ten_degrees_and_is_consistent():
    """From a 10° initial error the MEKF converges; afterwards the NEES lies in its 95 %
    chi-square interval (6 dof) at about 95 % of the ticks, the estimation errors stay within
    3σ, and the bias estimate converges to the true bias. Across ten independent runs (seeds)
    the NEES at the last tick sums to a chi-square of 60 dof, inside its 95 % interval (the
    bias error decorrelates slowly: one run's time average is not 60 independent draws)."""
    gyro, ds = _mekf_run(3000.0, seed=21)
    e = ds.estimation_error.values
    sg = ds.estimation_sigma.values
    nees = ds.nees.values
    # the first star tracker update removes most of the 10° (the linearised update's residual
    # is third order in the angle), the next ones the rest
    assert np.linalg.norm(e[0, :3]) < math.radians(0.05)
    assert np.max(np.linalg.norm(e[5:, :3], axis=1)) < 1e-3
    late = ds.tick.values > 600.0
    assert np.max(np.linalg.norm(e[late, :3], axis=1)) < 2e-4
    lo, hi = stats.chi2.ppf([0.025, 0.975], 6)
    inside = np.mean((nees[late] > lo) & (nees[late] < hi))
    assert 0.90 < inside < 0.995
    assert np.mean(np.abs(e[late]) < 3 * sg[late]) > 0.98
    # the attitude error's normalised squares average 1 per axis (they decorrelate quickly)
    z2 = np.mean((e[late, :3] / sg[late, :3]) ** 2, axis=0)
    assert np.all((z2 > 0.75) & (z2 < 1.25))
    b_err = np.abs(ds.bias_estimate.values[-1] - gyro.bias)
    assert np.all(b_err < 3 * sg[-1, 3:]) and np.all(b_err < 0.05 * np.abs(gyro.bias))
    final = [_mekf_run(1500.0, seed=100 + 7 * k)[1].nees.values[-1] for k in range(10)]
    lo60, hi60 = stats.chi2.ppf([0.025, 0.975], 60)
    assert lo60 < np.sum(final) < hi60


def test_runs_are_reproducible_from_their_seeds():
    g = Gyro(0.1 * u.deg / u.hour**0.5, seed=5)
    a = _record([g], 0.1, 10.0)
    b = _record([Gyro(0.1 * u.deg / u.hour**0.5, seed=5)], 0.1, 10.0)
    c = _record([Gyro(0.1 * u.deg / u.hour**0.5, seed=6)], 0.1, 10.0)
    np.testing.assert_array_equal(a.gyro_rate.values, b.gyro_rate.values)
    assert not np.array_equal(a.gyro_rate.values, c.gyro_rate.values)
    assert a.attrs["sensor_seeds"] == "gyro=5"
    fresh = Gyro(0.1 * u.deg / u.hour**0.5)
    d = _record([fresh], 0.1, 10.0)
    assert d.attrs["sensor_seeds"] == f"gyro={fresh.seed}"


def test_bad_sensor_parameters_are_refused():
    with pytest.raises(AttitudeValueError, match="arw"):
        Gyro(-1.0)
    with pytest.raises(AttitudeTypeError, match="seed"):
        Gyro(1e-4, seed=1.5)
    with pytest.raises(AttitudeTypeError, match="seed"):
        StarTracker(1e-5, seed="a")
    with pytest.raises(AttitudeValueError, match="boresight"):
        StarTracker(1e-5, boresight=[0, 0, 0])
    with pytest.raises(AttitudeValueError, match="noise"):
        Magnetometer(-1e-7)
    craft = attitude.Spacecraft(BODY)
    fsw = FlightSoftware(0.1, sensors=[StarTracker(1e-5)], estimator=MEKF())
    with pytest.raises(AttitudeValueError, match="gyro"):
        attitude.propagate(craft, Q_ID, np.zeros(4), [0.0, 1.0], software=fsw)
    with pytest.raises(AttitudeValueError, match="orbit"):
        attitude.propagate(
            craft,
            Q_ID,
            np.zeros(4),
            [0.0, 1.0],
            software=FlightSoftware(0.1, sensors=[Magnetometer(1e-7)]),
        )


def test_mekf_covariance_steps_equal_the_dense_matrix_formulas():
    """The filter's covariance steps, written by blocks on scalars, against the dense textbook
    formulas in numpy: propagation P ← Φ P Φᵀ + Q with Φ = expm(F Δt) of the error dynamics
    F = [[−[ω×], −1], [0, 0]] (scipy, independent of the closed form), and the star tracker's
    update in Joseph form (1 − KH) P (1 − KH)ᵀ + K R Kᵀ, K = P Hᵀ (H P Hᵀ + R)⁻¹, H = [1 0]."""
    from scipy.linalg import expm

    from attitude._core import mekf as M

    rng = np.random.default_rng(7)
    A = rng.normal(size=(6, 6)) * np.array([1e-3] * 3 + [1e-6] * 3)[:, None]
    P0 = A @ A.T + np.diag([1e-6] * 3 + [1e-12] * 3)
    ep = np.zeros(M.EP_SIZE)
    ep[M.EP_SV], ep[M.EP_SU] = 3e-6, 2e-9
    R = np.diag([4e-10, 4e-10, 9e-9])
    ep[M.EP_ST_R : M.EP_ST_R + 9] = R.ravel()
    es = np.zeros(M.E_SIZE)
    M.mekf_init(es, ep, (1.0, 0.0, 0.0, 0.0), (1e-5, -2e-5, 3e-5))
    es[M.E_P : M.E_P + 36] = P0.ravel()
    om, dt = np.array([0.02, -0.05, 0.03]), 0.1
    M.mekf_propagate(es, ep, om, dt)
    w = om - np.array([1e-5, -2e-5, 3e-5])
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    F = np.zeros((6, 6))
    F[:3, :3], F[:3, 3:] = -W, -np.eye(3)
    Phi = expm(F * dt)
    sv2, su2 = ep[M.EP_SV] ** 2, ep[M.EP_SU] ** 2
    Q = np.zeros((6, 6))
    Q[:3, :3] = (sv2 * dt + su2 * dt**3 / 3) * np.eye(3)
    Q[:3, 3:] = Q[3:, :3] = -su2 * dt**2 / 2 * np.eye(3)
    Q[3:, 3:] = su2 * dt * np.eye(3)
    P1 = Phi @ P0 @ Phi.T + Q
    got = es[M.E_P : M.E_P + 36].reshape(6, 6)
    np.testing.assert_array_equal(got, got.T)
    np.testing.assert_allclose(got, P1, rtol=1e-12, atol=1e-12 * np.abs(P1).max())
    q_before = es[M.E_Q : M.E_Q + 4].copy()
    b_before = es[M.E_B : M.E_B + 3].copy()
    qm = qt.multiply(q_before, qt.from_rotation_vector([2e-5, -1e-5, 3e-5]))
    M.mekf_update_quaternion(es, ep, tuple(qm))
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    K = P1 @ H.T @ np.linalg.inv(H @ P1 @ H.T + R)
    IKH = np.eye(6) - K @ H
    P2 = IKH @ P1 @ IKH.T + K @ R @ K.T
    got = es[M.E_P : M.E_P + 36].reshape(6, 6)
    np.testing.assert_array_equal(got, got.T)
    np.testing.assert_allclose(got, P2, rtol=1e-9, atol=1e-9 * np.abs(P2).max())
    r = qt.multiply(qt.conjugate(q_before), qm)
    dx = K @ (2.0 * np.sign(r[0]) * r[1:])
    np.testing.assert_allclose(es[M.E_B : M.E_B + 3], b_before + dx[3:], rtol=1e-12, atol=1e-20)
    dq = np.concatenate([[1.0], 0.5 * dx[:3]])
    want_q = qt.multiply(q_before, dq / np.linalg.norm(dq))
    np.testing.assert_allclose(es[M.E_Q : M.E_Q + 4], want_q, rtol=0, atol=1e-15)

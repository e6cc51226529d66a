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
    # uniform deviates: the top 53 bits of the same stream, times 2⁻⁵³
    _rng.seed_stream(st, 0, np.uint64(12345))
    assert [_rng.uniform(st, 0) for _ in range(1000)] == [(r >> 11) / 2**53 for r in ref]


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
    # the tails, which the KS test hardly sees: beyond 2, 3 and the ziggurat's edge r (whose
    # draws come from its separate tail algorithm), binomial 99.9 % two-sided
    for a in (2.0, 3.0, _rng.ZIG_R):
        p = math.erfc(a / math.sqrt(2.0))
        lo, hi = stats.binom.ppf([0.0005, 0.9995], n, p)
        assert lo <= np.count_nonzero(np.abs(x) > a) <= hi, a


def _ziggurat_reference(words, k, w, f, r, paths=None):
    """The ziggurat of NumPy's ``random_standard_normal`` written again in plain Python on a
    list of 64-bit words (the uniforms it needs taken from the same list); ``paths`` (a dict)
    counts the draws by the branch taken."""
    it = iter(words)
    paths = {} if paths is None else paths

    def seen(name):
        paths[name] = paths.get(name, 0) + 1

    def uniform():
        return (int(next(it)) >> 11) * 2.0**-53

    out = []
    try:
        while True:
            while True:
                b = int(next(it))
                idx = b & 0xFF
                b >>= 8
                j = (b >> 1) & (2**52 - 1)
                x = -(j * w[idx]) if b & 1 else j * w[idx]
                if j < int(k[idx]):
                    break
                if idx == 0:
                    while True:
                        xx = -math.log1p(-uniform()) / r
                        yy = -math.log1p(-uniform())
                        if yy + yy > xx * xx:
                            x = -(r + xx) if (j >> 8) & 1 else r + xx
                            seen("tail")
                            break
                        seen("tail rejected")
                    break
                if (f[idx - 1] - f[idx]) * uniform() + f[idx] < math.exp(-0.5 * x * x):
                    seen("wedge")
                    break
                seen("wedge rejected")
            out.append(x)
    except StopIteration:
        return np.array(out)


def _check_ziggurat_tables(mp):
    r = mp.mpf(_rng.ZIG_R)
    fm = lambda x: mp.exp(-x * x / 2)  # noqa: E731
    v = r * fm(r) + mp.quad(fm, [r, mp.inf])
    assert abs(v - _rng.ZIG_V) < 1e-17
    k, w, f = _rng.ziggurat_tables()
    x = [mp.mpf(0)] * 256
    x[255] = r
    for i in range(254, 0, -1):
        x[i] = mp.sqrt(-2 * mp.log(fm(x[i + 1]) + v / x[i + 1]))
    scale = mp.mpf(2) ** 52
    xs = np.array([float(xi) for xi in x])
    np.testing.assert_allclose(w[1:] * 2.0**52, xs[1:], rtol=1e-14, atol=0)
    assert abs(w[0] * 2.0**52 - float(v / fm(r))) < 4e-15 * float(v / fm(r))
    np.testing.assert_allclose(f, [float(fm(xi)) for xi in x], rtol=1e-14, atol=0)
    kk = [0] + [int(mp.nint(x[i - 1] / x[i] * scale)) for i in range(1, 256)]
    kk[0] = int(mp.nint(r * fm(r) / v * scale))
    assert max(abs(int(a) - b) for a, b in zip(k, kk, strict=True)) <= 64  # 1.4e-14 relative


def test_ziggurat_is_numpys_algorithm_on_tables_checked_in_arbitrary_precision():
    """The normal deviates' ziggurat three ways.
    (1) Its tables against the definition evaluated with mpmath (40 digits): every layer has
    the base strip's area v = r f(r) + ∫_r^∞ f, the edges follow x_{i−1} = f⁻¹(f(x_i) +
    v/x_i). (2) The algorithm written again in Python on our tables, fed PCG64's raw words,
    against NumPy's ``standard_normal`` of the same seed: the same deviates to a few ulps
    (NumPy's tables differ from ours in the last bits), tail and wedge draws included.
    (3) The compiled kernel against that Python version on our own xoshiro256** words: bit for
    bit, both as a call per deviate and with the state held in registers (the sensors')."""
    mpmath = pytest.importorskip("mpmath")
    mp = mpmath.mp
    with mpmath.workdps(40):
        _check_ziggurat_tables(mp)
    k, w, f = _rng.ziggurat_tables()
    # (2) NumPy on PCG64
    seed = 20261126
    words = np.random.PCG64(seed).random_raw(200_000)
    ours = _ziggurat_reference(words, k, w, f, _rng.ZIG_R)
    ref = np.random.Generator(np.random.PCG64(seed)).standard_normal(ours.size)
    np.testing.assert_allclose(ours, ref, rtol=1e-13, atol=0)
    assert np.count_nonzero(np.abs(ref) > _rng.ZIG_R) > 20  # the tail was exercised
    # (3) the kernel on xoshiro256**: the first seed whose first 20 000 words take every branch
    # (a tail draw rejected once in ~600 draws of the tail: found within a few dozen seeds)
    for s in range(1000):
        st = np.zeros(_rng.RNG_SIZE)
        _rng.seed_stream(st, 0, np.uint64(s))
        copy = st.copy()
        words = [_rng.next_u64(copy, 0) for _ in range(20_000)]
        paths = {}
        py = _ziggurat_reference(words, k, w, f, _rng.ZIG_R, paths)
        if len(paths) == 4:
            break
    assert len(paths) == 4, paths
    start = st.copy()
    got = np.empty(py.size)
    _rng.normals_loop(st, 0, got)
    np.testing.assert_array_equal(got, py)
    # the sensors' draws with the state held in registers: the same deviates, the same stream
    held = np.empty(py.size)
    _rng.normals_held_loop(start, 0, held)
    np.testing.assert_array_equal(held, py)
    np.testing.assert_array_equal(start.view(np.uint64), st.view(np.uint64))


def _record(sensors, period, t_end, craft=None, q0=Q_ID, w0=(0.0, 0.0, 0.0), **kw):
    craft = craft if craft is not None else attitude.Spacecraft(BODY)
    fsw = FlightSoftware(period, sensors=sensors, **{"record_every": 1, **kw})
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


@pytest.mark.parametrize("case", ["identity", "matrix", "limits"])
def test_gyro_deterministic_errors_are_its_matrix_bias_and_limits(case):
    """A noiseless gyro on a sphere spinning at a constant rate ω: each tick reads
    (1 + S) M ω + b₀ (M the rotation by the misalignment vector, built here by scipy), then
    quantised to the nearest step and clipped at the saturation; with neither scale factor nor
    misalignment it reads ω + b₀ (the kernel skips the identity matrix then)."""
    from scipy.spatial.transform import Rotation

    sphere = attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2")
    w = np.array([0.01, -0.02, 0.03])
    b0 = np.array([1e-5, -2e-5, 3e-5])
    S = np.array([1e-3, -2e-3, 5e-4]) if case == "matrix" else np.zeros(3)
    m = np.array([1e-3, -2e-3, 3e-3]) if case == "matrix" else None
    kw = {"quantization": 1e-4, "saturation": 0.025} if case == "limits" else {}
    g = Gyro(0.0, 0.0, bias=b0, scale_factor=S, misalignment=m, seed=1, **kw)
    ds = _record([g], 0.1, 2.0, craft=attitude.Spacecraft(sphere), w0=w)
    got = ds.gyro_rate.values[1:]
    truth = ds.omega.values[-1]
    assert np.abs(truth - w).max() < 1e-17  # the sphere's rate is constant
    M = Rotation.from_rotvec(m).as_matrix() if m is not None else np.eye(3)
    want = np.diag(1.0 + S) @ M @ truth + b0
    if case != "limits":  # (the truth at each tick equals ω to round-off: an ulp of 0.03)
        if case == "matrix":
            assert np.abs(want - truth - b0).max() > 1e-5  # the errors are visible
        np.testing.assert_allclose(got, np.broadcast_to(want, got.shape), rtol=0, atol=2e-17)
    else:
        lim = np.clip(1e-4 * np.floor(want / 1e-4 + 0.5), -0.025, 0.025)
        assert lim[2] == 0.025 and lim[0] != want[0]  # both limits act
        np.testing.assert_array_equal(got, np.broadcast_to(lim, got.shape))


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


@pytest.mark.parametrize("epoch", ["2024-03-20T12:00:00", "2024-06-21T06:00:00"])
def test_star_tracker_exclusion_flags_exactly_when_the_geometry_says(epoch):
    """A turning spacecraft: the status says Sun (Earth) exclusion at exactly the ticks where
    the boresight is within the angle of the Sun, outside the Earth's shadow (of the Earth's
    limb), from astropy's Sun and the orbit, computed here independently; at an equinox (the
    Sun near +x) and a solstice (the Sun far from every axis)."""
    import orbit
    from orbit.sun import R_EARTH, shadow_function, sun_position

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.0, 0.3, 0.0, epoch=epoch)
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


def test_star_tracker_exclusions_do_not_depend_on_the_record():
    """The exclusion test of the last test at every update tick, recorded or not: the
    turning sphere with a gyro and the MEKF taking the star tracker's valid measurements,
    recorded at every tick and at every third; the estimate (and every other tick variable)
    at the common ticks bit for bit the same. (The Sun's and the Earth's geometry is computed
    only where something needs it: an update taken while excluded would move the estimate.)"""
    import orbit
    from orbit.sun import sun_position

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.0, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    craft = attitude.Spacecraft(attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2"), orbit=o)
    s0 = sun_position(o.epoch, 0.0) - o.position(0.0)
    axis = np.cross([0.0, 0.0, 1.0], s0)
    w0 = tuple(0.01 * axis / np.linalg.norm(axis))

    def run(every):
        sensors = [
            Gyro(0.05 * u.deg / u.hour**0.5, 2e-9 * u.rad / u.s**1.5, seed=4),
            StarTracker(5 * u.arcsec, [0.0, 0.0, 1.0], sun_exclusion=30 * u.deg,
                        earth_exclusion=20 * u.deg, seed=5),
        ]  # fmt: skip
        return _record(sensors, 1.0, 1500.0, craft, Q_ID, w0, estimator=MEKF(), record_every=every)

    dense, sparse = run(1), run(3)
    status = dense.star_tracker_status.values
    assert (status[1::3] == 2).any() or (status[2::3] == 2).any()  # excluded, unrecorded ticks
    names = [v for v in dense.variables if "tick" in dense[v].dims]
    assert "estimation_error" in names
    for v in names:
        np.testing.assert_array_equal(sparse[v].values, dense[v].values[::3], err_msg=v)


def test_star_tracker_measures_at_its_own_rate():
    """A 2 Hz star tracker under 10 Hz software: a measurement (status valid, a unit
    quaternion within its noise of the truth) at every fifth tick from the first, "no update"
    at the others; at 10 Hz (the default, the software's rate) at every tick."""
    st = StarTracker(5 * u.arcsec, [0.0, 0.0, 1.0], rate=2 * u.Hz, seed=6)
    ds = _record([st], 0.1, 20.0, w0=(0.01, -0.02, 0.005))
    status = ds.star_tracker_status.values
    k = np.arange(status.size)
    np.testing.assert_array_equal(status, np.where(k % 5 == 0, 0, 1))
    upd = k % 5 == 0
    qm = ds.star_tracker_q.values[upd]
    np.testing.assert_allclose(np.linalg.norm(qm, axis=1), 1.0, rtol=0, atol=1e-15)
    w0 = (0.01, -0.02, 0.005)
    craft = attitude.Spacecraft(BODY)
    truth = attitude.propagate(
        craft, Q_ID, C.momenta_from_angular_velocity(Q_ID, w0, craft), ds.tick.values[upd],
        rtol=1e-13,
    )  # fmt: skip
    ang = qt.angle_between(qm, truth.q.values)
    assert ang.max() < 6 * math.hypot(st.noise[0], st.noise[0], st.noise[1])
    every = _record([StarTracker(5 * u.arcsec, [0.0, 0.0, 1.0], seed=6)], 0.1, 2.0)
    assert np.all(every.star_tracker_status.values == 0)


def _mekf_run(t_end, seed, q_err_deg=10.0, period=0.5):
    """Inertial pointing with three wheels, a gyro with bias and a 2 Hz star tracker, through
    the MEKF started ``q_err_deg`` off (None: from the first star tracker measurement)."""
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
    est = MEKF()  # from the first star tracker measurement
    if q_err_deg is not None:
        est = MEKF(initial_attitude=qt.multiply(
            q0, qt.from_rotation_vector(np.radians([q_err_deg, 0.0, 0.0]))))  # fmt: skip
    fsw = FlightSoftware(
        period,
        guidance=frames.inertial(),
        control=MRPFeedback(3.5, 30.0),
        sensors=[gyro, st],
        estimator=est,
        record_every=1,
    )
    return gyro, attitude.propagate(
        craft, q0, Q0, np.array([0.0, t_end]), software=fsw, method="taylor", rtol=1e-12
    )


def test_mekf_converges_from_ten_degrees():
    """From a 10° initial error (the default 10° prior) the MEKF converges: the first star
    tracker update removes most of the 10° (the linearised update's residual is third order in
    the angle), the next ones the rest; the bias estimate converges to the true bias (at the
    end of 6 000 s within 3σ and 5 %). The large first updates leave a bias error of several σ
    that decays over thousands of seconds (a nonlinear transient: with seed 21 it is −5.5σ at
    1 s, −3.3σ at 3 000 s, −1.7σ at 6 000 s), so consistency is tested on its own below."""
    gyro, ds = _mekf_run(6000.0, seed=21)
    e = ds.estimation_error.values
    sg = ds.estimation_sigma.values
    assert np.linalg.norm(e[0, :3]) < math.radians(0.05)
    assert np.max(np.linalg.norm(e[5:, :3], axis=1)) < 1e-3
    late = ds.tick.values > 600.0
    assert np.max(np.linalg.norm(e[late, :3], axis=1)) < 2e-4
    b_err = np.abs(ds.bias_estimate.values[-1] - gyro.bias)
    assert np.all(b_err < 3 * sg[-1, 3:]) and np.all(b_err < 0.05 * np.abs(gyro.bias))


def test_mekf_is_consistent():
    """Started as the filter assumes (from the first star tracker measurement, its prior three
    times the tracker's noise). One run: the attitude errors stay within 3σ and their
    normalised squares average 1 per axis (they decorrelate within seconds). Ten independent
    runs (seeds), Bar-Shalom's Monte Carlo NEES test: the ten runs' NEES summed at each tick
    is a chi-square of 60 dof, inside its 95 % interval at about 95 % of the ticks after 600 s
    and at the last tick. (A single run's 6-dof NEES is no test: its bias part decorrelates
    over thousands of seconds, so one run can sit at 3σ in bias for most of it: seed 21 does,
    with bias z² = 12 on one axis.)"""
    _gyro, ds = _mekf_run(3000.0, seed=21, q_err_deg=None)
    e = ds.estimation_error.values[:, :3]
    sg = ds.estimation_sigma.values[:, :3]
    late = ds.tick.values > 600.0
    assert np.mean(np.abs(e[late]) < 3 * sg[late]) > 0.98
    z2 = np.mean((e[late] / sg[late]) ** 2, axis=0)
    assert np.all((z2 > 0.75) & (z2 < 1.25))
    runs = [_mekf_run(1500.0, seed=100 + 7 * k, q_err_deg=None)[1] for k in range(10)]
    total = np.sum([r.nees.values for r in runs], axis=0)
    late = runs[0].tick.values > 600.0
    lo60, hi60 = stats.chi2.ppf([0.025, 0.975], 60)
    inside = np.mean((total[late] > lo60) & (total[late] < hi60))
    assert 0.90 < inside < 0.995
    assert lo60 < total[-1] < hi60


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


def _joseph_update(P, H, R):
    """The Kalman gain K = P Hᵀ (H P Hᵀ + R)⁻¹ and the updated covariance in Joseph form
    (1 − KH) P (1 − KH)ᵀ + K R Kᵀ, as dense matrices."""
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    IKH = np.eye(P.shape[0]) - K @ H
    return K, IKH @ P @ IKH.T + K @ R @ K.T


def test_small_rotation_series_against_mpmath():
    """The series of sin x / x and cos x (x² below SERIES_X2: the half angle of the filter's
    propagation and of the star tracker's noise rotation) and the filter's (x − sin x)/x³ are
    exact to round-off: within 2 ulp of mpmath at 40 digits over the whole range."""
    import mpmath

    from attitude._core import mekf as M
    from attitude._core import quat as Q

    es = np.zeros(M.E.SIZE)
    ep = np.zeros(M.EP.SIZE)
    for x2 in np.concatenate([[0.0, 1e-30, 1e-12], np.linspace(1e-6, Q.SERIES_X2, 40)[:-1]]):
        sinc, cos = Q.sinc_cos_series(x2)
        with mpmath.workdps(40):
            x = mpmath.sqrt(mpmath.mpf(x2))
            want_s = mpmath.sin(x) / x if x2 > 0 else mpmath.mpf(1)
            want_c = mpmath.cos(x)
            assert abs(sinc - float(want_s)) <= 2 * math.ulp(float(want_s))
            assert abs(cos - float(want_c)) <= 2 * math.ulp(float(want_c))
        # the filter's coefficients c2 = (1 − cos wΔt)/w², c3 = (wΔt − sin wΔt)/w³ at a half
        # angle a = wΔt/2 with a² = x2 (Δt = 0.1 s, ω along x), through the covariance of a
        # P = diag(0, 0, 0, 1, 1, 1) start: P_aa = Φ₁₂ Φ₁₂ᵀ, its (1, 1) entry (w²c3 − Δt)² +
        # (w c2)² = 4 sin²(wΔt/2)/w²
        if x2 == 0.0:
            continue
        dt = 0.1
        w = 2.0 * math.sqrt(x2) / dt
        M.mekf_init(es, ep, (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        es[M.E.P : M.E.P + 36] = np.diag([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]).ravel()
        M.mekf_propagate(es, ep, np.array([w, 0.0, 0.0]), dt)
        M.mekf_covariance(es, ep)
        with mpmath.workdps(40):
            mw = mpmath.mpf(w)
            want = float(4 * mpmath.sin(mw * mpmath.mpf(dt) / 2) ** 2 / mw**2)
        got = es[M.E.P + 7]
        assert abs(got - want) <= 8 * math.ulp(dt * dt), (x2, got, want)


def _dense_transition(w, dt, sv, su):
    """The MEKF's error-state transition Φ = expm(F Δt), F = [[−[w×], −I], [0, 0]], and its
    discrete process noise Q (Farrenkopf; Markley & Crassidis 2014, Sect. 6.2), as dense
    matrices."""
    from scipy.linalg import expm

    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    F = np.zeros((6, 6))
    F[:3, :3], F[:3, 3:] = -W, -np.eye(3)
    sv2, su2 = sv**2, su**2
    Q = np.zeros((6, 6))
    Q[:3, :3] = (sv2 * dt + su2 * dt**3 / 3) * np.eye(3)
    Q[:3, 3:] = Q[3:, :3] = -su2 * dt**2 / 2 * np.eye(3)
    Q[3:, 3:] = su2 * dt * np.eye(3)
    return expm(F * dt), Q


def test_mekf_covariance_steps_equal_the_dense_matrix_formulas():
    """The filter's covariance steps, written by blocks on scalars, against the dense textbook
    formulas in numpy: propagation P ← Φ P Φᵀ + Q with Φ = expm(F Δt) of the error dynamics
    F = [[−[ω×], −1], [0, 0]] (scipy, independent of the closed form), and the star tracker's
    update in Joseph form (1 − KH) P (1 − KH)ᵀ + K R Kᵀ, K = P Hᵀ (H P Hᵀ + R)⁻¹, H = [1 0]."""

    from attitude._core import mekf as M

    rng = np.random.default_rng(7)
    A = rng.normal(size=(6, 6)) * np.array([1e-3] * 3 + [1e-6] * 3)[:, None]
    P0 = A @ A.T + np.diag([1e-6] * 3 + [1e-12] * 3)
    ep = np.zeros(M.EP.SIZE)
    ep[M.EP.SV], ep[M.EP.SU] = 3e-6, 2e-9
    R = np.diag([4e-10, 4e-10, 9e-9])
    ep[M.EP.ST_R : M.EP.ST_R + 9] = R.ravel()
    es = np.zeros(M.E.SIZE)
    M.mekf_init(es, ep, (1.0, 0.0, 0.0, 0.0), (1e-5, -2e-5, 3e-5))
    es[M.E.P : M.E.P + 36] = P0.ravel()
    om, dt = np.array([0.02, -0.05, 0.03]), 0.1
    M.mekf_propagate(es, ep, om, dt)
    M.mekf_covariance(es, ep)
    w = om - np.array([1e-5, -2e-5, 3e-5])
    Phi, Q = _dense_transition(w, dt, ep[M.EP.SV], ep[M.EP.SU])
    P1 = Phi @ P0 @ Phi.T + Q
    got = es[M.E.P : M.E.P + 36].reshape(6, 6)
    np.testing.assert_array_equal(got, got.T)
    np.testing.assert_allclose(got, P1, rtol=1e-12, atol=1e-12 * np.abs(P1).max())
    q_before = es[M.E.Q : M.E.Q + 4].copy()
    b_before = es[M.E.B : M.E.B + 3].copy()
    qm = qt.multiply(q_before, qt.from_rotation_vector([2e-5, -1e-5, 3e-5]))
    M.mekf_update_quaternion(es, ep, tuple(qm))
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    K, P2 = _joseph_update(P1, H, R)
    got = es[M.E.P : M.E.P + 36].reshape(6, 6)
    np.testing.assert_array_equal(got, got.T)
    np.testing.assert_allclose(got, P2, rtol=1e-9, atol=1e-9 * np.abs(P2).max())
    r = qt.multiply(qt.conjugate(q_before), qm)
    dx = K @ (2.0 * np.sign(r[0]) * r[1:])
    np.testing.assert_allclose(es[M.E.B : M.E.B + 3], b_before + dx[3:], rtol=1e-12, atol=1e-20)
    dq = np.concatenate([[1.0], 0.5 * dx[:3]])
    want_q = qt.multiply(q_before, dq / np.linalg.norm(dq))
    np.testing.assert_allclose(es[M.E.Q : M.E.Q + 4], want_q, rtol=0, atol=1e-15)


def test_mekf_vector_update_and_estimation_error_against_dense_formulas():
    """The magnetometer's and Sun sensor's update (a body-axes measurement b̃ of a known space
    vector r) against the dense formulas: H = ∂b/∂δθ by central differences of
    b(δθ) = A(q̂∘δq(δθ)) r (not the kernel's [b̂×]), K = P Hᵀ (H P Hᵀ + σ² 1)⁻¹, Joseph form,
    δx = K (b̃ − b̂), q̂ ← q̂∘(1, δθ/2)/|·|. Then the estimation error: the rotation vector of
    q̂⁻¹∘q (scipy's Rotation), β − β̂, and its NEES δxᵀ P⁻¹ δx by a linear solve."""
    from scipy.spatial.transform import Rotation

    from attitude._core import mekf as M

    rng = np.random.default_rng(11)
    A = rng.normal(size=(6, 6)) * np.array([1e-2] * 3 + [1e-5] * 3)[:, None]
    P0 = A @ A.T + np.diag([1e-5] * 3 + [1e-11] * 3)
    q_hat = qt.normalize([0.7, -0.2, 0.5, 0.4])
    b_hat = np.array([2e-5, -1e-5, 4e-5])
    es = np.zeros(M.E.SIZE)
    M.mekf_init(es, np.zeros(M.EP.SIZE), tuple(q_hat), tuple(b_hat))
    es[M.E.P : M.E.P + 36] = P0.ravel()
    r = np.array([0.3, -0.8, 0.5])
    r /= np.linalg.norm(r)
    sigma = 3e-3

    def body(dth):
        return qt.rotate_inverse(qt.multiply(q_hat, qt.from_rotation_vector(dth)), r)

    h = 1e-6
    H = np.zeros((3, 6))
    for k in range(3):
        d = np.zeros(3)
        d[k] = h
        H[:, k] = (body(d) - body(-d)) / (2 * h)
    bm = body(np.array([0.01, -0.02, 0.015])) + np.array([1e-3, -2e-3, 5e-4])
    M.mekf_update_vector(es, np.zeros(M.EP.SIZE), *bm, *r, sigma)
    R = sigma**2 * np.eye(3)
    K, P1 = _joseph_update(P0, H, R)
    got = es[M.E.P : M.E.P + 36].reshape(6, 6)
    np.testing.assert_array_equal(got, got.T)
    np.testing.assert_allclose(got, P1, rtol=1e-8, atol=1e-8 * np.abs(P1).max())
    dx = K @ (bm - body(np.zeros(3)))
    np.testing.assert_allclose(es[M.E.B : M.E.B + 3], b_hat + dx[3:], rtol=1e-8, atol=1e-16)
    dq = np.concatenate([[1.0], 0.5 * dx[:3]])
    want_q = qt.multiply(q_hat, dq / np.linalg.norm(dq))
    np.testing.assert_allclose(es[M.E.Q : M.E.Q + 4], want_q, rtol=0, atol=1e-10)

    # the estimation error of the updated estimate against a truth 2° away, and its NEES
    q_new = es[M.E.Q : M.E.Q + 4].copy()
    b_new = es[M.E.B : M.E.B + 3].copy()
    q_true = qt.multiply(q_new, qt.from_rotation_vector(np.radians([1.2, -0.9, 1.3])))
    beta = b_new + np.array([3e-6, -1e-6, 2e-6])
    for sign in (1.0, -1.0):  # q and −q: the same attitude, the same error
        e, nees = M.estimation_error(es, M.E.P, tuple(sign * q_true), tuple(beta))
        rot = Rotation.from_quat(np.roll(q_new, -1)).inv() * Rotation.from_quat(np.roll(q_true, -1))
        want = np.concatenate([rot.as_rotvec(), beta - b_new])
        np.testing.assert_allclose(e, want, rtol=1e-12, atol=1e-18)
        np.testing.assert_allclose(nees, want @ np.linalg.solve(P1, want), rtol=1e-8)


def test_sun_sensor_direction_and_eclipse_against_astropys_sun():
    """A spacecraft at rest in space with the six-face coarse Sun sensor, over an orbit with an
    eclipse: noise-free, the direction (least squares over the lit heads) is the Sun's direction
    from the satellite (astropy's Sun, the orbit's position) in body axes, to the Sun table's
    interpolation error, wherever any of the Sun is seen, and NaN in the umbra; the sunlight is
    the conical shadow function of the same positions. With noise σ and three heads facing the
    Sun, in full sunlight, the direction's error across the Sun line has 2 components of
    variance σ² per tick (each head's current is the Sun's component plus N(0, σ²)):
    chi-square at 99 %; the same with the six faces, whose dark heads' noise must not enter."""
    import orbit
    from attitude.sensors import SunSensor
    from orbit.sun import shadow_function, sun_position

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.0, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    craft = attitude.Spacecraft(attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2"), orbit=o)
    s0 = sun_position(o.epoch, 0.0) - o.position(0.0)
    s0 /= np.linalg.norm(s0)
    u_b = np.array([0.6, -0.48, 0.64])  # the Sun in body axes at t = 0: three faces lit
    axis = np.cross(u_b, s0)
    q0 = qt.from_rotation_vector(axis / np.linalg.norm(axis) * math.acos(u_b @ s0))
    assert np.allclose(qt.rotate_inverse(q0, s0), u_b, atol=1e-14)

    ds = _record([SunSensor(noise=0.0)], 10.0, 6000.0, craft, q0)
    t = ds.tick.values
    r = o.position(t)
    sun = sun_position(o.epoch, t)
    s = sun - r
    s /= np.linalg.norm(s, axis=1)[:, None]
    sb = qt.rotate_inverse(q0, s)  # at rest: q = q0 throughout
    nu = ds.sunlight.values
    np.testing.assert_allclose(nu, shadow_function(r, sun), rtol=0, atol=1e-6)
    seen = nu > 0.0
    assert (~seen).any() and (nu == 1.0).any() and ((nu > 0.0) & (nu < 1.0)).any()
    got = ds.sun_direction.values
    np.testing.assert_allclose(got[seen], sb[seen], rtol=0, atol=1e-8)
    assert np.all(np.isnan(got[~seen]))

    sigma = 0.01
    heads = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
    ds = _record([SunSensor(heads, noise=sigma, seed=8)], 10.0, 6000.0, craft, q0)
    lit = ds.sunlight.values == 1.0
    z = ds.sun_direction.values[lit]
    e = z - np.sum(z * sb[lit], axis=1)[:, None] * sb[lit]  # across the Sun line
    n = int(lit.sum())
    chi = np.sum(e**2) / sigma**2
    assert stats.chi2.ppf(0.005, 2 * n) < chi < stats.chi2.ppf(0.995, 2 * n)
    assert np.all(np.linalg.norm(e, axis=1) < 6 * sigma)
    # The six-face default: the three dark heads read noise alone, above 3σ on 0.4 % of the
    # ticks (one to three of these 387 for a seed: each pulled the direction by ~25σ when it
    # joined the fit). The fit drops a head facing away from its first solution, so the
    # direction has the statistics of the three lit heads'.
    ds = _record([SunSensor(noise=sigma, seed=8)], 10.0, 6000.0, craft, q0)
    z = ds.sun_direction.values[lit]
    e = z - np.sum(z * sb[lit], axis=1)[:, None] * sb[lit]
    chi = np.sum(e**2) / sigma**2
    assert stats.chi2.ppf(0.005, 2 * n) < chi < stats.chi2.ppf(0.995, 2 * n)
    assert np.all(np.linalg.norm(e, axis=1) < 6 * sigma)


@pytest.mark.parametrize("rate", [0.0, 0.02, 0.5])
def test_mekf_propagation_against_expm_at_any_rotation_per_step(rate):
    """The covariance propagation against Φ = expm(F Δt) (scipy) where the closed form of Φ
    switches to the series of (wΔt − sin wΔt)/w³ (wΔt < 0.1) and above it, and at ω = 0; and,
    from P = 0, the process noise Q alone, every entry to 1e-12 relative (its terms are far
    below the rest of P otherwise): σ_v² Δt + σ_u² Δt³/3, −σ_u² Δt²/2, σ_u² Δt (Farrenkopf)."""

    from attitude._core import mekf as M

    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6)) * np.array([1e-3] * 3 + [1e-5] * 3)[:, None]
    P0 = A @ A.T + np.diag([1e-6] * 3 + [1e-10] * 3)
    ep = np.zeros(M.EP.SIZE)
    ep[M.EP.SV], ep[M.EP.SU] = 3e-4, 2e-5
    bias = np.array([1e-3, -2e-3, 3e-3]) * (rate > 0)
    om = bias + rate * np.array([0.6, -0.48, 0.64])
    dt = 2.0
    Phi, Q = _dense_transition(rate * np.array([0.6, -0.48, 0.64]), dt, ep[M.EP.SV], ep[M.EP.SU])
    for P, want in ((P0, Phi @ P0 @ Phi.T + Q), (np.zeros((6, 6)), Q)):
        es = np.zeros(M.E.SIZE)
        M.mekf_init(es, ep, (1.0, 0.0, 0.0, 0.0), tuple(bias))
        es[M.E.P : M.E.P + 36] = P.ravel()
        M.mekf_propagate(es, ep, om, dt)
        M.mekf_covariance(es, ep)
        got = es[M.E.P : M.E.P + 36].reshape(6, 6)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-13 * np.abs(want).max())
        if not P.any():
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    # the attitude turned by exp(ω̂ Δt/2), ω̂ = ω − β̂
    q = es[M.E.Q : M.E.Q + 4]
    np.testing.assert_allclose(q, qt.from_rotation_vector((om - bias) * dt), rtol=0, atol=1e-15)


def test_mekf_covariance_over_a_span_is_the_product_of_its_ticks():
    """P is propagated when it is read (an update) and at least every SPAN_TICKS ticks, in one
    step over the ticks since with their mean rate, against the per-tick steps (each tick
    propagated and brought current at once): at rest (ω̂ = 0) the same to round-off, Q
    included; at a constant rate Φ is still their product, and Q differs only by its rotation
    within the span, which the closed-form Q neglects (as it does within a tick): O(|ω| nΔt) of
    Q's share of P, here 6e-12; at the sensor day's rates (1e-5 rad/s, gyro noise 5e-5 rad/s a
    tick, five ticks) Φ₁₂ too, by the order the rates came in, |δω| (nΔt)²/2 ~ 6e-6 of it,
    which reaches P through the bias covariance: 1.3e-9 here. Entries relative to
    √(P_ii P_jj). The copy the record reads (mekf_covariance_at) is that P and leaves the
    filter's state as it was; the span is brought current by itself after SPAN_TICKS ticks."""
    from attitude._core import mekf as M

    rng = np.random.default_rng(5)
    A = rng.normal(size=(6, 6)) * np.array([1e-4] * 3 + [1e-7] * 3)[:, None]
    P0 = A @ A.T + np.diag([1e-9] * 3 + [1e-14] * 3)
    ep = np.zeros(M.EP.SIZE)
    ep[M.EP.SV], ep[M.EP.SU] = 1.45e-5, 2e-9
    dt, n = 0.1, 5
    bias = np.array([1e-6, 0.0, -1e-6])
    for rates, rel in (
        (np.tile(bias, (n, 1)), 4e-15),
        (np.tile([2e-3, -1e-3, 3e-3], (n, 1)), 2e-11),
        (np.array([1e-5, -2e-5, 1e-5]) + rng.normal(0.0, 5e-5, (n, 3)), 5e-9),
    ):
        es = [np.zeros(M.E.SIZE) for _ in range(2)]
        for e in es:
            M.mekf_init(e, ep, (1.0, 0.0, 0.0, 0.0), tuple(bias))
            e[M.E.P : M.E.P + 36] = P0.ravel()
        for w in rates:
            M.mekf_propagate(es[0], ep, w, dt)
            M.mekf_covariance(es[0], ep)  # every tick: the per-tick product
            M.mekf_propagate(es[1], ep, w, dt)
        before = es[1].copy()
        M.mekf_covariance_at(es[1], ep, M.E.PHI)
        lazy = es[1][M.E.PHI : M.E.PHI + 36].reshape(6, 6)
        untouched = np.r_[0 : M.E.PHI, M.E.PHI + 36 : M.E.SIZE]
        np.testing.assert_array_equal(es[1][untouched], before[untouched])
        M.mekf_covariance(es[1], ep)
        np.testing.assert_array_equal(es[1][M.E.P : M.E.P + 36].reshape(6, 6), lazy)
        np.testing.assert_array_equal(es[1][M.E.Q : M.E.Q + 4], es[0][M.E.Q : M.E.Q + 4])
        ticks = es[0][M.E.P : M.E.P + 36].reshape(6, 6)
        scale = np.sqrt(np.outer(np.diag(ticks), np.diag(ticks)))
        err = np.max(np.abs(lazy - ticks) / scale)
        assert err < rel, err
    # SPAN_TICKS ticks without an update: the span is brought current by itself
    for _ in range(M.SPAN_TICKS):
        assert es[1][M.E.SPAN] < (M.SPAN_TICKS - 0.5) * dt
        M.mekf_propagate(es[1], ep, rates[0], dt)
    assert es[1][M.E.SPAN] == 0.0 and es[1][M.E.NSPAN] == 0.0


@pytest.mark.parametrize("vector", ["magnetometer", "sun_sensor"])
def test_mekf_with_a_vector_sensor_in_the_loop_is_the_filter_replayed_by_hand(vector):
    """Gyro and magnetometer (or coarse Sun sensor) through the MEKF, no star tracker, at 1 Hz:
    the estimate at every tick equals the filter's kernels applied by hand to the recorded
    measurements: start from the given attitude, bias and σ's (updated at the first tick),
    then at each tick propagate with that tick's gyro rate over the period and update with the
    measured vector against its model in space axes (MagneticDipole's field; astropy's Sun
    seen from the orbit), not the loop's own."""
    import orbit
    from attitude._core import mekf as M
    from attitude.sensors import SunSensor
    from orbit.sun import sun_position

    o = orbit.KeplerOrbit(6878.0, 0.001, 1.2, 0.3, 0.0, epoch="2024-03-20T12:00:00")
    craft = attitude.Spacecraft(attitude.RigidBody([10.0, 10.0, 10.0], units="kg m2"), orbit=o)
    q0 = qt.normalize([0.8, 0.3, -0.2, 0.4])
    w0 = (0.002, -0.001, 0.003)
    gyro = Gyro(0.05 * u.deg / u.hour**0.5, 2e-8 * u.rad / u.s**1.5, bias=[2e-5, -1e-5, 3e-5],
                seed=3)  # fmt: skip
    if vector == "magnetometer":
        vec = Magnetometer(200 * u.nT, seed=4)
        kw = {"use_magnetometer": True}
    else:
        vec = SunSensor(noise=0.01, seed=4)
        kw = {"use_sun_sensor": True}
    q_e = qt.multiply(q0, qt.from_rotation_vector(np.radians([1.0, -0.5, 0.7])))
    sa, sb = math.radians(2.0), 1e-4
    est = MEKF(initial_attitude=q_e, attitude_sigma=sa, bias_sigma=sb, **kw)
    ds = _record([gyro, vec], 1.0, 300.0, craft, q0, w0, estimator=est)
    t = ds.tick.values
    if vector == "magnetometer":
        ref = attitude.MagneticDipole(o, [0, 0, 0]).magnetic_field(t)  # space axes
        meas = ds.magnetometer.values
    else:
        ref = sun_position(o.epoch, t) - o.position(t)
        ref /= np.linalg.norm(ref, axis=1)[:, None]
        meas = ds.sun_direction.values
        assert np.isnan(meas[:, 0]).sum() < t.size / 2
    ep = np.zeros(M.EP.SIZE)
    ep[M.EP.SV], ep[M.EP.SU] = gyro.arw, gyro.rrw
    ep[M.EP.MAG if vector == "magnetometer" else M.EP.SUN] = vec.noise
    ep[M.EP.P0 : M.EP.P0 + 6] = [sa**2] * 3 + [sb**2] * 3
    es = np.zeros(M.E.SIZE)
    M.mekf_init(es, ep, tuple(q_e), (0.0, 0.0, 0.0))
    q_hat, b_hat = [], []
    for n in range(t.size):
        if n > 0:
            M.mekf_propagate(es, ep, ds.gyro_rate.values[n], t[n] - t[n - 1])
        if not np.isnan(meas[n, 0]):  # (no Sun direction with fewer than 3 heads lit)
            M.mekf_update_vector(es, ep, *meas[n], *ref[n], vec.noise)
        q_hat.append(es[M.E.Q : M.E.Q + 4].copy())
        b_hat.append(es[M.E.B : M.E.B + 3].copy())
    np.testing.assert_allclose(ds.estimate_q.values, q_hat, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ds.bias_estimate.values, b_hat, rtol=0, atol=1e-12)
    # and the filter is consistent: its attitude errors within its own 3σ
    e, sg = ds.estimation_error.values[100:, :3], ds.estimation_sigma.values[100:, :3]
    assert np.mean(np.abs(e) < 3 * sg) > 0.97


def test_basilisk_reference_needs_the_sensors_for_its_filter():
    import basilisk_reference as br

    with pytest.raises(ValueError, match="sensors=True"):
        br.rw_feedback_scenario(0.1, 1.0, sensors=False, estimator=True)


def test_basilisks_inertial_ukf_closes_the_reference_loop():
    """The Basilisk reference of benchmarks/software.py with its own filter in the loop
    (``inertialUKF`` on the star tracker, the control on its estimate) really converges, so
    its timing is that of a working loop. After the scenario's transient (an 80° slew on
    saturated wheels, about 20 min, ours as long), over [1800, 3600] s:

    - the filter's attitude error, at the measurement times, is at most the tracker's total
      noise σ_st = (2·6² + 45²)^½ ″ (a filter that follows its measurements, as this one with
      Basilisk's process noise does, sits at that level; 3 600 samples leave ~1 % sampling
      error, the bound has 10 %), and its rate error is below σ_st/T (T = 0.5 s: differencing
      two measurements);
    - the true pointing error's RMS is below σ_st/4: the second-order loop (ω_n² = K/4I,
      2ζω_n = P/I) averages the estimate's white noise, held over T, down to about
      σ_st (T ω_n / 4ζ)^½ ≈ 0.09 σ_st from the attitude term (the rate estimate's noise adds a
      little), and its largest value is below σ_st."""
    pytest.importorskip("Basilisk")
    import basilisk_reference as br

    r = br.rw_feedback_scenario(0.1, 3600.0, sensors=True, estimator=True)
    arcsec = math.radians(1.0 / 3600.0)
    across, about = br.ST_NOISE
    sigma_st = math.sqrt(2 * across**2 + about**2) * arcsec
    T = 0.5
    t = r["t"]
    late = t >= 1800.0
    truth = br.mrp_to_quaternion(r["sigma"])
    pointing = qt.angle_between(truth[late], Q_ID)
    assert np.sqrt(np.mean(pointing**2)) < sigma_st / 4
    assert pointing.max() < sigma_st
    # the estimate read at t = 0.5 m + 0.1 s is that of the measurement at the previous tick
    k = np.nonzero(late & np.isclose(np.mod(t - 0.1, T), 0.0, atol=1e-6))[0]
    assert len(k) == 3600
    est = qt.angle_between(br.mrp_to_quaternion(r["sigma_est"][k]), truth[k - 1])
    assert np.sqrt(np.mean(est**2)) < 1.1 * sigma_st
    rate = np.linalg.norm(r["omega_est"][k] - r["omega"][k - 1], axis=1)
    assert np.sqrt(np.mean(rate**2)) < sigma_st / T

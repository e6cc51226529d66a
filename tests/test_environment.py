"""Environment torques: magnetic dipole, eddy currents, aerodynamic drag, solar radiation.

Every check is against an independent truth: the reference libraries called directly (ppigrf
through its geodetic entry, pymsis, astropy's ITRS velocities and Sun), closed forms (the
tilted dipole, the flat-plate formulas of Montenbruck & Gill 2000 and Wertz 1978, the
eddy-current decay of a sphere), a geometric calculation of the shadow cones, and conservation
laws. The tables are interpolated at times off their nodes.
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np
import pytest
from astropy import units as u
from astropy.time import Time, TimeDelta

import attitude
import orbit
from attitude import quaternion as qt
from attitude.canonical import momenta_from_angular_velocity
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import (
    AerodynamicDrag,
    EddyCurrentDamping,
    Facet,
    GravityGradient,
    MagneticDipole,
    SolarRadiation,
)

# FLOCK 1C-1 (NORAD 40027), a 3U CubeSat in a sun-synchronous orbit (~600 km, i = 97.9 deg):
# Planet's element set of 2020-02-22 (the one of scenarios/cubesat_environment.toml).
TLE = (
    "1 40027U PLANET   20053.08335648  .00000000  00000+0  34079-4 0    09",
    "2 40027 097.9376 341.9424 0011991 325.7224 261.4362 14.90036668    06",
)
EPOCH = Time("2020-02-22T02:00:00", scale="utc")
SPAN = 3 * 3600.0  # two orbits
RNG = np.random.default_rng(14)


@pytest.fixture(scope="module")
def sso():
    return orbit.EphemerisOrbit.from_tle(
        *TLE, EPOCH, EPOCH + TimeDelta(SPAN, format="sec"), 60.0, epoch=EPOCH
    )


def _off_grid_times(n, lo=0.0, hi=SPAN):
    # whole seconds 7 s off the 30 s nodes (pymsis reads whole seconds)
    k = RNG.integers(int(lo // 30) + 1, int(hi // 30) - 1, size=n)
    return np.sort(30.0 * k + 7.0)


def _random_unit(n):
    return qt.normalize(RNG.normal(size=(n, 4)))


def _itrs_to_gcrs(times, v):
    from astropy.coordinates import GCRS, ITRS, CartesianRepresentation

    from orbit.timescales import offline_iers

    with offline_iers():
        c = ITRS(CartesianRepresentation(v.T * u.km), obstime=times)
        return c.transform_to(GCRS(obstime=times)).cartesian.xyz.to_value(u.km).T


# ---------------------------------------------------------------------------------------------
# Magnetic field


def _ppigrf_gcrs(orb, t):
    """The IGRF field [T] at the orbit's positions, GCRS components: geodetic (astropy) →
    ppigrf.igrf (E, N, U) → ITRS → GCRS (astropy), called directly at each time."""
    import ppigrf

    lat, lon, h = orb.geodetic(t)
    times = orb.absolute_times(t)
    b_itrs = np.empty((t.size, 3))
    for i in range(t.size):
        date = times[i].utc.to_datetime()
        be, bn, bu = (float(np.ravel(x)[0]) for x in ppigrf.igrf(
            np.degrees(lon[i]), np.degrees(lat[i]), h[i], date
        ))  # fmt: skip
        sp, cp, sl, cl = np.sin(lat[i]), np.cos(lat[i]), np.sin(lon[i]), np.cos(lon[i])
        east = np.array([-sl, cl, 0.0])
        north = np.array([-sp * cl, -sp * sl, cp])
        up = np.array([cp * cl, cp * sl, sp])
        b_itrs[i] = 1e-9 * (be * east + bn * north + bu * up)
    return _itrs_to_gcrs(times, b_itrs)


def test_magnetic_torque_matches_ppigrf_called_directly_at_off_grid_times(sso):
    """geodetic (astropy) → ppigrf.igrf (E, N, U) → ITRS → GCRS (astropy) → body, m × B."""
    m = np.array([0.02, -0.03, 0.05])
    model = MagneticDipole(sso, m)
    t = _off_grid_times(12)
    q = _random_unit(t.size)
    tau = model.torque(q, t)
    b_gcrs = _ppigrf_gcrs(sso, t)
    b_body = qt.rotate_inverse(q, b_gcrs)
    want = np.cross(m, b_body)
    scale = np.linalg.norm(m) * np.linalg.norm(b_gcrs, axis=1)
    err = np.linalg.norm(tau - want, axis=1) / scale
    assert err.max() < 1e-6, err.max()
    # the field itself, space frame
    berr = np.linalg.norm(model.magnetic_field(t) - b_gcrs, axis=1) / np.linalg.norm(b_gcrs, axis=1)
    assert berr.max() < 1e-6, berr.max()
    # and the potential: U = −m·B_B
    np.testing.assert_allclose(model.value(q, t), -(b_body @ m), rtol=1e-6)


def test_dipole_field_is_the_closed_form_of_igrf_degree_one(sso):
    import ppigrf.ppigrf as pp

    model = MagneticDipole(sso, [0.0, 0.0, 1.0], field="dipole")
    t = _off_grid_times(10)
    b = model.magnetic_field(t)
    times = sso.absolute_times(t)
    r_itrs = sso.itrs_position(t)
    # closed form: B = (a/r)³ [3 (m·r̂) r̂ − m], m = (g11, h11, g10) of the date (linear in time)
    g, h = pp.read_shc(pp.shc_fn)
    x = g.index.values.astype("datetime64[ns]").astype(np.int64).astype(float)
    want = np.empty_like(r_itrs)
    for i in range(t.size):
        d = np.datetime64(times[i].utc.to_datetime(), "ns").astype(np.int64).astype(float)
        g10, g11, h11 = (np.interp(d, x, c.values) for c in (g[(1, 0)], g[(1, 1)], h[(1, 1)]))
        mvec = np.array([g11, h11, g10])
        r = np.linalg.norm(r_itrs[i])
        rh = r_itrs[i] / r
        want[i] = 1e-9 * (6371.2 / r) ** 3 * (3.0 * (mvec @ rh) * rh - mvec)
    want = _itrs_to_gcrs(times, want)
    err = np.linalg.norm(b - want, axis=1) / np.linalg.norm(want, axis=1)
    assert err.max() < 1e-8, err.max()
    # and it is ppigrf's field truncated at degree 1
    rr = np.linalg.norm(r_itrs, axis=1)
    theta = np.degrees(np.arccos(r_itrs[:, 2] / rr))
    phi = np.degrees(np.arctan2(r_itrs[:, 1], r_itrs[:, 0]))
    for i in range(3):
        date = times[i].utc.to_datetime()
        br, bt, bp = (float(np.ravel(v)[0]) for v in pp.igrf_gc(
            rr[i], theta[i], phi[i], date, max_degree=1
        ))  # fmt: skip
        th, ph = np.radians(theta[i]), np.radians(phi[i])
        rhat = np.array([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
        that = np.array([np.cos(th) * np.cos(ph), np.cos(th) * np.sin(ph), -np.sin(th)])
        phat = np.array([-np.sin(ph), np.cos(ph), 0.0])
        bi = 1e-9 * (br * rhat + bt * that + bp * phat)
        np.testing.assert_allclose(
            _itrs_to_gcrs(times[i : i + 1], bi[None])[0], want[i], rtol=0, atol=1e-14
        )


def test_constant_field_dipole_is_m_cross_b_and_needs_no_orbit():
    b_space = np.array([1e-5, -2e-5, 3e-5])
    m = np.array([0.1, 0.2, -0.05])
    model = MagneticDipole(None, m, field=b_space * 1e9 * u.nT)
    q = _random_unit(20)
    t = RNG.uniform(-1e6, 1e6, 20)
    bb = qt.rotate_inverse(q, b_space)
    scale = np.linalg.norm(m) * np.linalg.norm(b_space)
    np.testing.assert_allclose(model.torque(q, t), np.cross(m, bb), rtol=0, atol=1e-15 * scale)
    np.testing.assert_allclose(model.value(q, t), -(bb @ m), rtol=1e-14)


# ---------------------------------------------------------------------------------------------
# Atmosphere


def test_density_matches_pymsis_called_directly_and_never_fetches(sso, monkeypatch):
    import pymsis
    import pymsis.utils

    def no_download(*a, **k):
        raise AssertionError("pymsis tried to read or download its space-weather file")

    monkeypatch.setattr(pymsis.utils, "get_f107_ap", no_download)
    monkeypatch.setattr(pymsis.utils, "download_f107_ap", no_download)
    monkeypatch.setattr(pymsis.msis, "get_f107_ap", no_download)
    facets = [Facet(0.01, [1, 0, 0], [0.1, 0, 0])]
    model = AerodynamicDrag(sso, facets, f107=180.0, f107a=160.0, ap=12.0)
    t = _off_grid_times(40)
    rho = model.atmosphere(t)["density"]
    lat, lon, h = sso.geodetic(t)
    dates = sso.absolute_times(t).utc.to_value("datetime64")
    n = t.size
    want = pymsis.calculate(
        dates, np.degrees(lon), np.degrees(lat), h,
        np.full(n, 180.0), np.full(n, 160.0), np.full((n, 7), 12.0), version=2.1,
    )[:, 0]  # fmt: skip
    err = np.abs(rho / want - 1.0)
    # pymsis runs NRLMSIS in single precision (~3e-6 rms noise along an orbit): the table
    # reproduces it to that noise, not to the 1e-6 of the smooth quantities
    assert err.max() < 3e-5 and np.median(err) < 1e-5, (err.max(), np.median(err))
    # at times with a fraction of a second pymsis drops the fraction (it reads the time of day
    # in whole seconds): the same call at the truncated time gives the same density, and the
    # table (smooth in time) differs from it by more, as docs/potentials.md says
    tf = t + RNG.uniform(0.1, 0.9, t.size)
    lat, lon, h = sso.geodetic(tf)
    dates = sso.absolute_times(tf).utc.to_value("datetime64")
    args = (np.degrees(lon), np.degrees(lat), h, np.full(n, 180.0), np.full(n, 160.0),
            np.full((n, 7), 12.0))  # fmt: skip
    frac = pymsis.calculate(dates, *args, version=2.1)[:, 0]
    whole = pymsis.calculate(dates.astype("datetime64[s]"), *args, version=2.1)[:, 0]
    np.testing.assert_array_equal(frac, whole)
    err = np.abs(model.atmosphere(tf)["density"] / frac - 1.0)
    assert err.max() < 1e-4, err.max()


def test_density_table_is_cut_at_utc_midnight_where_pymsis_jumps():
    o = orbit.KeplerOrbit(6975.0, 0.0012, np.radians(97.9), 1.0, 2.0, epoch="2020-02-22T22:00:00")
    model = AerodynamicDrag(o, [Facet(0.01, [1, 0, 0], [0.1, 0, 0])])
    midnight = 7200.0
    t = midnight + np.array([-60.0, -5.0, -1.0, 0.0, 1.0, 5.0, 60.0])
    import pymsis

    lat, lon, h = o.geodetic(t)
    dates = o.absolute_times(t).utc.to_value("datetime64")
    n = t.size
    want = pymsis.calculate(
        dates, np.degrees(lon), np.degrees(lat), h,
        np.full(n, 150.0), np.full(n, 150.0), np.full((n, 7), 4.0), version=2.1,
    )[:, 0]  # fmt: skip
    got = model.atmosphere(t)["density"]
    # pymsis's density jumps by ~0.7 % at 00:00 UTC (integer day of year); the table follows it
    assert abs(want[4] / want[2] - 1.0) > 1e-3
    np.testing.assert_allclose(got, want, rtol=5e-5)


def test_exponential_density_is_vallados_table_at_the_geodetic_height(sso):
    model = AerodynamicDrag(sso, [Facet(0.01, [1, 0, 0], [0.1, 0, 0])], density="exponential")
    t = _off_grid_times(20)
    rho = model.atmosphere(t)["density"]
    h = sso.geodetic(t)[2]
    # Vallado (2013) Table 8-4: the 500-600 km and 600-700 km bands, written out here
    want = np.where(
        h < 600.0,
        6.967e-13 * np.exp(-(h - 500.0) / 63.822),
        1.454e-13 * np.exp(-(h - 600.0) / 71.835),
    )
    assert np.all((h > 500.0) & (h < 700.0))
    np.testing.assert_allclose(rho, want, rtol=1e-9)


def test_relative_velocity_is_astropys_itrs_velocity(sso):
    from astropy.coordinates import GCRS, ITRS, CartesianDifferential, CartesianRepresentation

    from orbit.frames import gcrs_to_itrs_matrix
    from orbit.timescales import offline_iers

    model = AerodynamicDrag(sso, [Facet(0.01, [1, 0, 0], [0.1, 0, 0])])
    t = _off_grid_times(10)
    v_rel = model.atmosphere(t)["velocity"]  # m/s, GCRS axes
    r, v = sso.to_state(t)
    times = sso.absolute_times(t)
    rep = CartesianRepresentation(r.T * u.km, differentials=CartesianDifferential(v.T * u.km / u.s))
    with offline_iers():
        it = GCRS(rep, obstime=times).transform_to(ITRS(obstime=times))
    v_itrs = it.cartesian.differentials["s"].d_xyz.to_value(u.m / u.s).T
    R = gcrs_to_itrs_matrix(times)
    got = np.einsum("nij,nj->ni", R, v_rel)
    err = np.linalg.norm(got - v_itrs, axis=1) / np.linalg.norm(v_itrs, axis=1)
    assert err.max() < 1e-6, err.max()


def _plate_drag_reference(model, q, t, area, normal, center, cd):
    atm = model.atmosphere(t)
    vb = qt.rotate_inverse(q, atm["velocity"])
    v = np.linalg.norm(vb, axis=-1)
    vh = vb / v[:, None]
    cos = vh @ normal
    # Montenbruck & Gill (2000) Sect. 3.5: F = −½ ρ C_D A cos θ v² v̂ (facing facets only)
    f = (-0.5 * atm["density"] * cd * area * np.maximum(cos, 0.0) * v * v)[:, None] * vh
    return np.cross(center, f), cos


def test_drag_on_one_flat_plate_is_the_textbook_force(sso):
    area, normal, center, cd = 0.06, np.array([0.0, 0.6, 0.8]), np.array([0.1, -0.2, 0.3]), 2.4
    model = AerodynamicDrag(sso, [Facet(area * u.m**2, normal, center * u.m, cd=cd)])
    t = _off_grid_times(60)
    q = _random_unit(t.size)
    want, cos = _plate_drag_reference(model, q, t, area, normal, center, cd)
    assert (cos > 0).sum() > 10 and (cos < 0).sum() > 10  # both sides seen
    got = model.torque(q, t)
    scale = np.abs(want).max()
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * scale)
    assert np.all(got[cos < 0] == 0.0)
    # C_D and A enter linearly
    m2 = AerodynamicDrag(sso, [Facet(2 * area, normal, center, cd=cd / 4)])
    np.testing.assert_allclose(m2.torque(q, t), 0.5 * got, rtol=1e-13, atol=1e-13 * scale)


def _aligned(direction, axis_b, tilt_axis, alpha):
    """q with body ``axis_b`` along ``direction`` (space), then tilted by alpha about tilt_axis."""
    d = direction / np.linalg.norm(direction)
    c = np.cross(axis_b, d)
    s = np.linalg.norm(c)
    q0 = qt.from_axis_angle(c / s, np.arctan2(s, axis_b @ d))
    return qt.multiply(qt.from_axis_angle(tilt_axis, alpha), q0)


def test_plate_behind_the_center_of_mass_weathervanes_into_the_flow(sso):
    # a plate 0.5 m behind the centre of mass (along −b1), facing the flow when b1 points along
    # the velocity: a tilt of the body in either direction gives a torque tilting it back
    model = AerodynamicDrag(sso, [Facet(0.1, [1.0, 0.0, 0.0], [-0.5, 0.0, 0.0])])
    t = np.array([1234.0])
    v = model.atmosphere(t)["velocity"][0]
    k = np.cross(v, [0.0, 0.0, 1.0])
    k /= np.linalg.norm(k)
    for alpha in (0.05, -0.05, 0.3, -0.3):
        q = _aligned(v, np.array([1.0, 0.0, 0.0]), k, alpha)
        tau = model.torque(q, t)[0]
        k_body = qt.rotate_inverse(q, k)
        assert np.sign(tau @ k_body) == -np.sign(alpha), (alpha, tau @ k_body)
        assert abs(tau @ k_body) > 0.9 * np.linalg.norm(tau)
    # aligned: no torque
    assert np.linalg.norm(model.torque(_aligned(v, np.array([1.0, 0, 0]), k, 0.0), t)) < 1e-20


# ---------------------------------------------------------------------------------------------
# Solar radiation


@pytest.mark.parametrize(
    ("specular", "diffuse", "formula"),
    [
        (0.0, 0.0, "absorbed"),  # F = −P A cos θ ŝ
        (1.0, 0.0, "specular"),  # F = −2 P A cos² θ n̂
        (0.0, 1.0, "diffuse"),  # F = −P A cos θ (ŝ + 2/3 n̂)
        (0.3, 0.5, "mixed"),
    ],
)
def test_radiation_on_one_flat_plate_is_the_textbook_force(sso, specular, diffuse, formula):
    area, normal, center = 0.05, np.array([0.0, 0.0, 1.0]), np.array([0.2, -0.1, 0.05])
    model = SolarRadiation(sso, [Facet(area, normal, center, specular=specular, diffuse=diffuse)])
    t = _off_grid_times(80)
    sun = model.sunlight(t)
    lit = sun["shadow"] == 1.0
    assert lit.sum() > 20 and (sun["shadow"] == 0.0).sum() > 5
    q = _random_unit(t.size)
    s = qt.rotate_inverse(q, sun["direction"])
    cos = s @ normal
    p = 1361.0 / 299_792_458.0 * (149_597_870.7 / sun["distance"]) ** 2 * sun["shadow"]
    a = (p * area * np.maximum(cos, 0.0))[:, None]
    n = normal[None, :]
    # Wertz (1978) Sect. 17.2.2, each part separately
    absorbed = -a * s
    spec = -2.0 * a * cos[:, None] * n
    diff = -a * (s + 2.0 / 3.0 * n)
    f = (1 - specular - diffuse) * absorbed + specular * spec + diffuse * diff
    want = np.cross(center, f)
    got = model.torque(q, t)
    scale = np.abs(want).max()
    assert scale > 0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13 * scale)
    assert np.all(got[~lit & (sun["shadow"] == 0.0)] == 0.0)


def test_sun_direction_and_distance_match_astropy(sso):
    from astropy.coordinates import get_body

    model = SolarRadiation(sso, [Facet(0.01, [1, 0, 0], [0.1, 0, 0])])
    t = _off_grid_times(10)
    sun = model.sunlight(t)
    times = sso.absolute_times(t)
    s = get_body("sun", times).cartesian.xyz.to_value(u.km).T  # apparent, GCRS
    d = s - sso.position(t)
    dn = np.linalg.norm(d, axis=1)
    np.testing.assert_allclose(sun["distance"], dn, rtol=1e-12)
    np.testing.assert_allclose(sun["direction"], d / dn[:, None], rtol=0, atol=1e-12)


def _cone_functions(r, s):
    """Signed distances (km) of r outside the penumbra and umbra cones of a spherical Earth
    lit by the Sun at s (geocentric): negative inside. Geometry of the tangent cones."""
    from orbit.sun import R_EARTH as RE
    from orbit.sun import R_SUN as RS

    d = np.linalg.norm(s)
    shat = s / d
    x = -(r @ shat)  # distance behind the Earth along the anti-Sun axis
    rho = np.linalg.norm(r + x * shat)  # distance from the axis
    # umbra: vertex at L_u = RE d/(RS − RE) behind the Earth; penumbra: vertex at
    # L_p = RE d/(RS + RE) towards the Sun
    tan_u = np.tan(np.arcsin((RS - RE) / d))
    tan_p = np.tan(np.arcsin((RS + RE) / d))
    lu = RE * d / (RS - RE)
    lp = RE * d / (RS + RE)
    if x <= 0.0:  # the Sun's side of the terminator: lit (the cones' contacts are behind it)
        return RE, RE
    return rho - (x + lp) * tan_p, rho - (lu - x) * tan_u


def test_eclipse_entry_and_exit_times_match_the_shadow_cones(sso):
    from scipy.optimize import brentq

    from orbit.sun import sun_position

    model = SolarRadiation(sso, [Facet(0.01, [1, 0, 0], [0.1, 0, 0])])
    tg = np.arange(0.0, SPAN, 10.0)
    rg, sg = sso.position(tg), sun_position(sso.epoch, tg)  # astropy, directly
    f = np.array([_cone_functions(rg[i], sg[i]) for i in range(tg.size)])
    events = []
    for k in (0, 1):
        for i in np.nonzero(np.sign(f[1:, k]) != np.sign(f[:-1, k]))[0]:
            a, b = tg[i], tg[i + 1]
            # the Sun moves 0.04"/s: linear between the bracket's ends is exact to ~1e-9 rad

            def g(x, a=a, b=b, i=i, k=k):
                s = sg[i] + (x - a) / (b - a) * (sg[i + 1] - sg[i])
                return _cone_functions(sso.position(x), s)[k]

            events.append((k, brentq(g, a, b, xtol=1e-6)))
    assert len(events) >= 6  # two eclipses: penumbra and umbra entry and exit each

    # the model's contacts, where ν leaves 1 (penumbra) or reaches 0 (umbra): bisection of all
    # events at once
    kind = np.array([k for k, _ in events])
    te = np.array([x for _, x in events])

    def inside(x):
        nu = model.sunlight(x)["shadow"]
        return np.where(kind == 0, nu < 1.0, nu == 0.0)

    a, b = te - 5.0, te + 5.0
    ia = inside(a)
    assert np.all(ia != inside(b))
    for _ in range(40):
        m = 0.5 * (a + b)
        same = inside(m) == ia
        a = np.where(same, m, a)
        b = np.where(same, b, m)
    err = 0.5 * (a + b) - te
    assert np.abs(err).max() < 1e-3, err


def test_shadow_function_and_kernels():
    from attitude._core.environment import (
        ECLIPSE_CONICAL,
        ECLIPSE_CYLINDRICAL,
        ECLIPSE_NONE,
        shadow,
    )
    from attitude.environment import AU_KM
    from orbit.sun import R_EARTH, R_SUN, shadow_function

    s = np.array([AU_KM, 0.0, 0.0])
    assert shadow_function([7000.0, 0.0, 0.0], s) == 1.0
    assert shadow_function([-7000.0, 0.0, 0.0], s) == 0.0
    assert shadow_function([0.0, 7000.0, 0.0], s) == 1.0
    # across the penumbra ν falls monotonically from 1 to 0
    y = np.linspace(6420.0, 6330.0, 400)
    r = np.stack([np.full_like(y, -7000.0), y, np.zeros_like(y)], axis=1)
    nu, gp, gu = shadow_function(r, s, margins=True)
    assert nu[0] == 1.0 and nu[-1] == 0.0 and np.all(np.diff(nu) <= 0)
    assert np.any((nu > 0.01) & (nu < 0.99))
    assert np.all((gp >= 0) == (nu == 1.0)) and np.all((gu <= 0) == (nu == 0.0))
    # the torque kernel's shortcut (full light and umbra from cosines) agrees everywhere
    for i in range(r.shape[0]):
        d = s - r[i]
        k = shadow(ECLIPSE_CONICAL, *r[i], *d, R_EARTH, R_SUN)
        assert k == nu[i]
        assert shadow(ECLIPSE_CYLINDRICAL, *r[i], *d, R_EARTH, R_SUN) == (
            0.0 if y[i] < R_EARTH else 1.0
        )
        assert shadow(ECLIPSE_NONE, *r[i], *d, R_EARTH, R_SUN) == 1.0
    with pytest.raises(orbit.OrbitValueError, match="r_sat"):
        shadow_function([1.0, 2.0], s)


def test_sun_position_is_the_apparent_sun_of_astropy():
    from astropy.coordinates import get_body_barycentric

    from orbit.sun import sun_position

    t = np.linspace(0.0, 86400.0 * 200, 7)
    s = sun_position("2024-03-20T12:00:00", t)
    times = Time("2024-03-20T12:00:00", scale="utc") + TimeDelta(t, format="sec")
    geo = (get_body_barycentric("sun", times) - get_body_barycentric("earth", times)).xyz
    geo = geo.to_value(u.km).T  # geometric: differs by the annual aberration (20.5")
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", s, geo) / (
        np.linalg.norm(s, axis=1) * np.linalg.norm(geo, axis=1)), -1, 1))  # fmt: skip
    assert np.all(np.degrees(ang) * 3600 < 25.0) and np.all(np.degrees(ang) * 3600 > 15.0)
    np.testing.assert_allclose(np.linalg.norm(s, axis=1), np.linalg.norm(geo, axis=1), rtol=1e-4)


# ---------------------------------------------------------------------------------------------
# Eddy currents


def test_eddy_currents_on_a_sphere_damp_the_spin_across_the_field_only():
    # sphere I = i 1, isotropic tensor p 1, constant field B: ω∥ stays, ω⊥ decays as
    # exp(−p B² t / i) (τ = −p B² ω⊥; Ortiz Gómez & Walker 2015)
    i, p = 0.02, 8000.0  # a strong damper (k = 1e-3 /s), to keep the run short
    b = np.array([0.0, 3e-5, 4e-5])  # |B| = 5e-5 T
    model = EddyCurrentDamping(None, p, field=b)
    body = attitude.RigidBody([i, i, i] * u.Unit("kg m2"))
    q0 = qt.normalize([0.9, 0.1, -0.3, 0.2])
    w0_space = np.array([0.05, 0.02, -0.04])
    w0 = qt.rotate_inverse(q0, w0_space)
    Q0 = momenta_from_angular_velocity(q0, w0, body)
    k = p * (b @ b) / i
    t = np.linspace(0.0, 3.0 / k, 61)
    ds = attitude.propagate(body, q0, Q0, t, potential=model, rtol=1e-12, atol=1e-16)
    w_space = qt.rotate(ds.q.values, ds.omega.values)
    bh = b / np.linalg.norm(b)
    par0 = w0_space @ bh
    perp0 = w0_space - par0 * bh
    want = par0 * bh + np.exp(-k * t)[:, None] * perp0
    np.testing.assert_allclose(w_space, want, rtol=0, atol=1e-10 * np.linalg.norm(w0))
    np.testing.assert_allclose(w_space @ bh, par0, rtol=1e-10)


def test_eddy_currents_dissipate_at_the_rate_of_the_tensor_model():
    # a general body and tensor in a constant field: dT/dt = ω·τ = −(ω × B)·M(ω × B), so the
    # kinetic energy (the results' energy: the model has no potential) loses its integral; the
    # angular momentum along B is conserved (τ ⊥ B)
    body = attitude.RigidBody([0.03, 0.05, 0.06] * u.Unit("kg m2"))
    M = 1e4 * np.array([[3.0, 0.4, -0.2], [0.4, 2.0, 0.1], [-0.2, 0.1, 1.5]])  # strong
    b = np.array([2e-5, -1e-5, 3e-5])
    model = EddyCurrentDamping(None, M * u.Unit("S m4"), field=b * u.T)
    q0 = qt.from_euler([0.3, 1.0, -0.4], "313")
    Q0 = momenta_from_angular_velocity(q0, [0.1, -0.05, 0.08], body)
    t = np.linspace(0.0, 2000.0, 10001)
    ds = attitude.propagate(body, q0, Q0, t, potential=model, rtol=1e-12, atol=1e-16)
    E = ds.energy.values
    w = ds.omega.values
    bb = qt.rotate_inverse(ds.q.values, b)
    u_ = np.cross(w, bb)
    rate = -np.einsum("ij,jk,ik->i", u_, M, u_)
    # (the kernel rotates B with the integrated q, |q| = 1 to ~1e-11 at this tolerance)
    np.testing.assert_allclose(
        np.einsum("ij,ij->i", w, ds.torque.isel(model=0).values), rate, rtol=1e-9
    )
    assert E[-1] < 0.5 * E[0]  # it does damp
    from scipy.interpolate import CubicSpline

    lost = CubicSpline(t, rate).antiderivative()(t)  # ∫ ω·τ dt
    np.testing.assert_allclose(E - E[0], lost, rtol=0, atol=1e-7 * (E[0] - E[-1]))
    G_along_b = ds.G.values @ (b / np.linalg.norm(b))
    np.testing.assert_allclose(G_along_b, G_along_b[0], rtol=0, atol=1e-9 * abs(G_along_b[0]))


def test_eddy_currents_follow_the_change_of_the_field_seen_from_the_body(sso):
    """m = −M dB_B/dt, τ = m × B_B: along the orbit B_B changes by the body's rotation and by
    the field's own change in space (up to ~3e-3 rad/s in LEO). The reference differentiates
    the field seen from the propagated body: ppigrf + astropy called directly at t ± δ,
    rotated by the run's attitude (interpolated on its own dense output), central differences.
    Leaving out dB_S/dt (the model before issue 27) is 2-10 % off."""
    M = np.diag([4.5, 4.5, 1.5])
    model = EddyCurrentDamping(sso, M * u.Unit("S m4"))
    body = attitude.RigidBody([0.0434, 0.0418, 0.0090] * u.Unit("kg m2"))
    q0 = qt.normalize([0.9, 0.1, -0.3, 0.2])
    Q0 = momenta_from_angular_velocity(q0, [0.6, -0.5, 0.4] * u.deg / u.s, body)
    t = np.array([600.0, 1500.0, 2400.0, 3300.0, 4500.0])
    d = 0.25
    tt = np.sort(np.concatenate([t - d, t, t + d]))
    ds = attitude.propagate(body, q0, Q0, np.concatenate([[0.0], tt]), potential=model,
                            rtol=1e-12, atol=1e-16)  # fmt: skip
    q = ds.q.values[1:].reshape(-1, 3, 4)
    tau = ds.torque.sel(model=0).values[1:].reshape(-1, 3, 3)[:, 1]
    b_s = _ppigrf_gcrs(sso, tt).reshape(-1, 3, 3)
    b_b = qt.rotate_inverse(q, b_s)  # (n, 3 times, 3)
    db_dt = (b_b[:, 2] - b_b[:, 0]) / (2 * d)
    want = np.cross(-db_dt @ M, b_b[:, 1])
    err = np.linalg.norm(tau - want, axis=1) / np.linalg.norm(want, axis=1)
    assert err.max() < 1e-4, err
    # the part from the field's own change along the orbit is not small
    w = ds.omega.values[1:].reshape(-1, 3, 3)[:, 1]
    old = np.cross(np.cross(w, b_b[:, 1]) @ M, b_b[:, 1])
    part = np.linalg.norm(old - want, axis=1) / np.linalg.norm(want, axis=1)
    assert part.min() > 0.01, part
    # the field rate the model tabulates, against ppigrf's central differences
    rate = model.magnetic_field_rate(t)
    ref = (_ppigrf_gcrs(sso, t + 1.0) - _ppigrf_gcrs(sso, t - 1.0)) / 2.0
    np.testing.assert_allclose(rate, ref, rtol=0, atol=2e-5 * np.abs(ref).max())
    spin = (
        np.linalg.norm(np.cross(b_s[:, 1], rate), axis=1) / np.linalg.norm(b_s[:, 1], axis=1) ** 2
    )
    assert 5e-4 < spin.max() < 5e-3  # rad/s: the field direction turns along the orbit


def test_spherical_shell_tensor():
    M = EddyCurrentDamping.spherical_shell(5 * u.cm, 1.5 * u.mm, 3.5e7)
    np.testing.assert_allclose(M, 2 * np.pi / 3 * 3.5e7 * 1.5e-3 * 0.05**4 * np.eye(3))


# ---------------------------------------------------------------------------------------------
# Sums, runs and tables


def test_sum_of_environment_terms_is_the_sum_of_their_torques(sso):
    facets = attitude.box_wing(
        [0.1, 0.1, 0.34],
        center=[0.0, 0.0, 0.02],
        specular=0.1,
        diffuse=0.2,
        wings=[(0.03, [1, 0, 0], [0, 0.2, 0.02]), (0.03, [1, 0, 0], [0, -0.2, 0.02])],
    )
    inertia = [0.044, 0.044, 0.0067]
    parts = [
        GravityGradient(sso, inertia=inertia),
        MagneticDipole(sso, [0.0, 0.0, 0.05]),
        AerodynamicDrag(sso, facets),
        SolarRadiation(sso, facets),
        EddyCurrentDamping(sso, 0.7),
    ]
    total = sum(parts[1:], parts[0])
    assert [t.name for t in total.terms] == [p.name for p in parts]
    t = _off_grid_times(30)
    q = _random_unit(t.size)
    w = RNG.normal(scale=0.1, size=(t.size, 3))
    each = [p.torque(q, t, omega=w) for p in parts]
    got = total.torque(q, t, omega=w)
    scale = max(np.abs(x).max() for x in each)
    np.testing.assert_allclose(got, sum(each), rtol=0, atol=4e-16 * scale)
    np.testing.assert_allclose(
        total.value(q, t), parts[0].value(q, t) + parts[1].value(q, t), rtol=1e-14
    )


def test_facets_grouped_by_normal_give_the_sum_of_the_single_facet_torques(sso):
    # The kernels sum facets by normal up to sign (attitude.facets.drag_groups,
    # optical_groups): a box with wings, an off-axis facet and a facet repeated must give the
    # sum of the torques of one-facet models (each its own table, same grid) to round-off.
    facets = [
        *attitude.box_wing(
            [0.1, 0.1, 0.34],
            center=[0.003, 0.0, -0.015],
            specular=0.1,
            diffuse=0.2,
            wings=[(0.03, [1, 0, 0], [0.05, 0.2, 0.0]), (0.03, [1, 0, 0], [0.05, -0.2, 0.0])],
        ),
        Facet(0.02, [0.0, 0.6, 0.8], [0.01, -0.03, 0.1], cd=2.0, specular=0.4, diffuse=0.1),
        Facet(0.02, [0.0, 0.6, 0.8], [0.02, 0.03, -0.1], cd=2.6, specular=0.0, diffuse=0.5),
    ]
    groups = attitude.facets.drag_groups(facets)
    assert len(groups) == 4 < len(facets)  # ±b1, ±b2, ±b3 and the tilted pair
    t = _off_grid_times(60)
    q = _random_unit(t.size)
    for model in (AerodynamicDrag, SolarRadiation):
        got = model(sso, facets).torque(q, t)
        each = sum(model(sso, [f]).torque(q, t) for f in facets)
        scale = np.abs(each).max()
        assert scale > 0
        np.testing.assert_allclose(got, each, rtol=0, atol=1e-14 * scale)


def test_drag_tables_fold_the_density_only_where_it_interpolates_as_well(sso, monkeypatch):
    from attitude._core import environment as ke
    from attitude.environment import FOLD_TOLERANCE

    facets = attitude.box_wing([0.1, 0.1, 0.34], center=[0.0, 0.0, 0.02])
    t = _off_grid_times(80)
    q = _random_unit(t.size)
    folded = AerodynamicDrag(sso, facets)
    tau = folded.torque(q, t)
    assert folded._density_code == ke.DENSITY_FOLDED  # near-circular LEO: √ρ v tabulated
    monkeypatch.setattr("attitude.environment.FOLD_TOLERANCE", -1.0)
    plain = AerodynamicDrag(sso, facets)
    want = plain.torque(q, t)
    assert plain._density_code == ke.DENSITY_TABLE
    # the same torque to the tolerance the choice allows (2 x: ρ v² from √ρ v squared)
    np.testing.assert_allclose(tau, want, rtol=0, atol=2 * FOLD_TOLERANCE * np.abs(want).max())
    a, b = folded.atmosphere(t), plain.atmosphere(t)
    np.testing.assert_allclose(a["density"], b["density"], rtol=1e-14)  # ln ρ in both
    v = np.abs(b["velocity"]).max()
    np.testing.assert_allclose(a["velocity"], b["velocity"], rtol=0, atol=2 * FOLD_TOLERANCE * v)
    monkeypatch.undo()
    # a fast dive through the lower thermosphere (perigee 200 km, e = 0.3): √ρ is far from a
    # polynomial over a window, so v and ln ρ stay apart
    a = (6378.137 + 200.0) / 0.7
    dive = orbit.KeplerOrbit(a, 0.3, 1.7, 0.0, 0.0, epoch="2020-02-22T02:00:00")
    m = AerodynamicDrag(dive, facets, span=(-600.0, 600.0))
    m.torque(q[:3], np.array([-100.0, 0.0, 100.0]))
    assert m._density_code == ke.DENSITY_TABLE


def test_shadow_margins_decide_light_and_umbra_as_the_shadow_function_does(sso):
    # Inside the light or the umbra the kernel reads the tabulated margins; the shadow
    # function at the interpolated positions must agree at every time, across both penumbrae.
    from attitude._core import environment as ke
    from attitude.environment import earth_disk_larger, sun_shadow

    model = SolarRadiation(sso, [Facet(0.05, [0.0, 0.0, 1.0], [0.2, -0.1, 0.05])])
    t = np.linspace(0.0, SPAN, 40_001)
    nu = model.sunlight(t)["shadow"]
    assert model._umbra  # LEO: the Earth's disk is the larger
    assert (nu == 0).sum() > 1000 and (nu == 1).sum() > 1000 and ((nu > 0) & (nu < 1)).sum() > 5
    params = model._kernel_params(t)
    r = np.empty((t.size, 8))
    ke.table_loop(t, params, int(params[ke.BLOCK.TAB]), r)
    d, x = r[:, :3], r[:, 3:6]
    exact = [
        ke.shadow(ke.ECLIPSE_CONICAL, *x[i], *d[i], params[ke.SRP.REARTH], params[ke.SRP.RSUN])
        for i in range(t.size)
    ]
    np.testing.assert_array_equal(nu, exact)
    # far from the Earth (1.5 million km) g_umbra < 0 is an annular shadow, not the umbra
    rows = np.zeros((1, 8))
    rows[0, :3] = [1.5e8, 0.0, 0.0]
    rows[0, 3:6] = [-1.5e6, 0.0, 0.0]
    assert not earth_disk_larger(rows)
    assert earth_disk_larger(sun_shadow(attitude.environment.grid(sso, 0.0, SPAN, 30.0)))


def test_cubesat_run_with_all_models_reports_each_torque(sso):
    facets = attitude.box_wing([0.1, 0.1, 0.34], center=[0.0, 0.0, 0.02])
    body = attitude.RigidBody([0.044, 0.044, 0.0067] * u.Unit("kg m2"))
    model = (
        GravityGradient(sso)
        + MagneticDipole(sso, [0.0, 0.0, 0.05] * u.Unit("A m2"))
        + AerodynamicDrag(sso, facets)
        + SolarRadiation(sso, facets)
        + EddyCurrentDamping(sso, 0.7)
    )
    q0 = qt.from_euler([0.1, 0.2, 0.3], "313")
    Q0 = momenta_from_angular_velocity(q0, [3.0, -2.0, 4.0] * u.deg / u.s, body)
    t = np.linspace(0.0, 1800.0, 181)
    ds = attitude.propagate(body, q0, Q0, t, potential=model, rtol=1e-10)
    labels = list(ds.model_label.values)
    assert labels == [
        "gravity_gradient", "magnetic_dipole", "aerodynamic_drag", "solar_radiation",
        "eddy_current_damping", "total",
    ]  # fmt: skip
    tau = ds.torque.values
    np.testing.assert_allclose(tau[:, :-1].sum(axis=1), tau[:, -1], rtol=0, atol=1e-20)
    assert ds.torque.attrs["units"] == "N m"
    for name in ("aerodynamic_drag", "solar_radiation", "eddy_current_damping"):
        assert name in ds.attrs["terms_without_potential"]
    assert "magnetic_dipole" not in ds.attrs["terms_without_potential"]
    # the magnetic torque dominates a 0.05 A m² residual dipole in LEO
    mags = np.linalg.norm(tau, axis=-1).max(axis=0)
    assert mags[1] == mags[:-1].max()
    # the splittings compose exact flows and refuse the rate-dependent eddy currents
    with pytest.raises(AttitudeValueError):
        attitude.propagate(body, q0, Q0, t, potential=model, method="splitting", dt=1.0)


def test_tables_cover_the_run_and_are_reused(sso):
    model = MagneticDipole(sso, [0.0, 0.0, 0.05])
    model.prepare(np.array([0.0, 3600.0]))
    block = model._block
    assert model.prepare(np.array([100.0, 3000.0]))._block is block  # inside: reused
    model.prepare(np.array([0.0, 7200.0]))
    assert model._block is not block
    with pytest.raises(AttitudeValueError, match="t:"):
        model.torque([1, 0, 0, 0], SPAN + 100.0)  # beyond the ephemeris
    # an orbit defined at all times: the parameters need the run's span
    kep = orbit.KeplerOrbit(7000.0, 0.001, 1.7, 0.0, 0.0, epoch="2020-01-01T00:00:00")
    with pytest.raises(AttitudeValueError, match="span"):
        MagneticDipole(kep, [0, 0, 1])._params(np.ones(3))
    p = MagneticDipole(kep, [0, 0, 1], span=(0.0, 600.0) * u.s)._params(np.ones(3))
    assert p.size > 100


# ---------------------------------------------------------------------------------------------
# Bad input


def test_facet_validation():
    with pytest.raises(AttitudeValueError, match="area"):
        Facet(0.0, [1, 0, 0], [0, 0, 0])
    with pytest.raises(AttitudeValueError, match="area"):
        Facet(-1.0, [1, 0, 0], [0, 0, 0])
    with pytest.raises(AttitudeValueError, match="normal"):
        Facet(1.0, [1, 1, 0], [0, 0, 0])
    with pytest.raises(AttitudeValueError, match="specular"):
        Facet(1.0, [1, 0, 0], [0, 0, 0], specular=1.2)
    with pytest.raises(AttitudeValueError, match="diffuse"):
        Facet(1.0, [1, 0, 0], [0, 0, 0], diffuse=-0.1)
    with pytest.raises(AttitudeValueError, match="specular, diffuse"):
        Facet(1.0, [1, 0, 0], [0, 0, 0], specular=0.6, diffuse=0.5)
    with pytest.raises(AttitudeValueError, match="cd"):
        Facet(1.0, [1, 0, 0], [0, 0, 0], cd=-2.0)
    with pytest.raises(AttitudeTypeError, match="area"):
        Facet(1.0 * u.m, [1, 0, 0], [0, 0, 0])
    f = Facet(300 * u.cm**2, [0, 0, 1], [10, 0, 0] * u.cm, specular=0.25, diffuse=0.25)
    assert f.area == pytest.approx(0.03) and f.center[0] == pytest.approx(0.1)
    assert f.absorbed == 0.5
    box = attitude.box_wing([0.1, 0.2, 0.3], wings=[(0.05, [1, 0, 0], [0, 0.5, 0])])
    assert len(box) == 8 and box[0].area == pytest.approx(0.06)
    assert np.allclose(box[7].normal, [-1, 0, 0])


@pytest.mark.filterwarnings("ignore::orbit.timescales.IERSRangeWarning")  # dates beyond IERS
def test_environment_models_reject_bad_input(sso):
    f = [Facet(0.01, [1, 0, 0], [0.1, 0, 0])]
    undated = orbit.KeplerOrbit(7000.0, 0.001, 1.7, 0.0, 0.0)
    for make in (
        lambda: MagneticDipole(undated, [0, 0, 1]),
        lambda: EddyCurrentDamping(undated, 1.0),
        lambda: AerodynamicDrag(undated, f),
        lambda: SolarRadiation(undated, f),
    ):
        with pytest.raises(AttitudeValueError, match=r"^orbit: .*epoch"):
            make()
    with pytest.raises(AttitudeValueError, match="f107"):
        AerodynamicDrag(sso, f, f107=20.0)
    with pytest.raises(AttitudeValueError, match="f107a"):
        AerodynamicDrag(sso, f, f107a=900.0)
    with pytest.raises(AttitudeValueError, match="ap"):
        AerodynamicDrag(sso, f, ap=-1.0)
    with pytest.raises(AttitudeValueError, match="density"):
        AerodynamicDrag(sso, f, density="jacchia")
    with pytest.raises(AttitudeValueError, match="eclipse"):
        SolarRadiation(sso, f, eclipse="sometimes")
    with pytest.raises(AttitudeValueError, match="field"):
        MagneticDipole(sso, [0, 0, 1], field="wmm")
    with pytest.raises(AttitudeValueError, match="dipole"):
        MagneticDipole(sso, [0, 1])
    with pytest.raises(AttitudeTypeError, match="dipole"):
        MagneticDipole(sso, [0, 0, 1] * u.N)
    with pytest.raises(AttitudeValueError, match="tensor"):
        EddyCurrentDamping(sso, [[1, 2, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(AttitudeValueError, match="tensor"):
        EddyCurrentDamping(sso, [1.0, -1.0, 1.0])
    with pytest.raises(AttitudeTypeError, match="facets"):
        AerodynamicDrag(sso, ["plate"])
    with pytest.raises(AttitudeValueError, match="facets"):
        SolarRadiation(sso, [])
    with pytest.raises(AttitudeValueError, match="step"):
        MagneticDipole(sso, [0, 0, 1], step=0.0)
    # IGRF-14 ends in 2030
    late = orbit.KeplerOrbit(7000.0, 0.001, 1.7, 0.0, 0.0, epoch="2029-12-31T23:00:00")
    MagneticDipole(late, [0, 0, 1]).torque([1, 0, 0, 0], 0.0)
    with pytest.raises(AttitudeValueError, match="IGRF"):
        MagneticDipole(late, [0, 0, 1]).torque([1, 0, 0, 0], 7200.0)
    later = orbit.KeplerOrbit(7000.0, 0.001, 1.7, 0.0, 0.0, epoch="2031-01-01T00:00:00")
    with pytest.raises(AttitudeValueError, match="IGRF"):
        EddyCurrentDamping(later, 1.0, field="dipole")
    # rate-dependent: omega is needed to evaluate
    with pytest.raises(AttitudeValueError, match="omega"):
        EddyCurrentDamping(sso, 1.0).torque([1, 0, 0, 0], 0.0)


def test_dates_of_the_igrf_interpolation_are_exact(sso):
    # the field at a date is the linear combination of the fields at two dates of its IGRF
    # interval (Gauss coefficients linear in time): one call for many dates equals many calls
    import ppigrf

    from attitude.environment import igrf_field_itrs

    r = sso.itrs_position(np.array([0.0, 3000.0, 9000.0]))
    dates = np.array(["2020-02-22T02:00", "2024-12-31T23:00", "2025-01-03T00:00"], "datetime64[ns]")
    got = igrf_field_itrs(dates, r)
    for i in range(3):
        rr = np.linalg.norm(r[i])
        th = np.degrees(np.arccos(r[i, 2] / rr))
        ph = np.degrees(np.arctan2(r[i, 1], r[i, 0]))
        d = dates[i].astype("datetime64[us]").item()
        assert isinstance(d, _dt.datetime)
        br, bt, bp = (float(np.ravel(v)[0]) for v in ppigrf.igrf_gc(rr, th, ph, d))
        t_, p_ = np.radians(th), np.radians(ph)
        want = 1e-9 * (
            br * np.array([np.sin(t_) * np.cos(p_), np.sin(t_) * np.sin(p_), np.cos(t_)])
            + bt * np.array([np.cos(t_) * np.cos(p_), np.cos(t_) * np.sin(p_), -np.sin(t_)])
            + bp * np.array([-np.sin(p_), np.cos(p_), 0.0])
        )
        np.testing.assert_allclose(got[i], want, rtol=1e-12, atol=1e-18)


def test_gcrs_to_itrs_matrices_with_the_earth_rotation_factored_out():
    from orbit.frames import gcrs_to_itrs, gcrs_to_itrs_matrix

    times = EPOCH + TimeDelta(np.linspace(-100.0, 86500.0, 577), format="sec")
    exact = gcrs_to_itrs_matrix(times)
    fast = gcrs_to_itrs_matrix(times, step=600.0)
    assert np.abs(fast - exact).max() < 1e-11
    r = RNG.normal(size=(times.size, 3)) * 7000.0
    np.testing.assert_allclose(
        np.einsum("nij,nj->ni", exact, r), gcrs_to_itrs(times, r), rtol=0, atol=1e-10
    )
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", fast, fast), np.broadcast_to(
        np.eye(3), fast.shape), rtol=0, atol=1e-13)  # fmt: skip


# ---------------------------------------------------------------------------------------------
# Scenarios and the command line

SCENARIO = Path(__file__).parent.parent / "scenarios" / "cubesat_environment.toml"


def test_cubesat_scenario_builds_the_five_models():
    from attitude import scenario

    sc = scenario.load(SCENARIO)
    names = [t.name for t in sc.potential.terms]
    assert names == [
        "gravity_gradient", "magnetic_dipole", "aerodynamic_drag", "solar_radiation",
        "eddy_current_damping",
    ]  # fmt: skip
    mag, drag, srp, eddy = sc.potential.terms[1:]
    np.testing.assert_array_equal(mag.dipole, [0.0, 0.0, 0.05])
    assert len(drag.facets) == 10 and drag.f107 == 150.0 and drag.ap == 4.0
    assert srp.eclipse == "conical" and srp.facets[6].specular == 0.05
    np.testing.assert_array_equal(np.diag(eddy.tensor), [4.5, 4.5, 1.5])
    assert sum(f.area for f in drag.facets) == pytest.approx(4 * 0.034 + 2 * 0.01 + 4 * 0.03)
    omega = attitude.canonical.angular_velocity(sc.q0, sc.Q0, sc.body)
    assert np.degrees(np.linalg.norm(omega)) == pytest.approx(5.0, rel=1e-12)


def test_cubesat_scenario_runs_and_plots_its_torque_budget(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from attitude.cli import main

    out = tmp_path / "cube.nc"
    assert main(["run", str(SCENARIO), "--stop", "0.25", "-o", str(out), "-q"]) == 0
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    for name in ("magnetic_dipole", "aerodynamic_drag", "solar_radiation", "eddy_current_damping"):
        assert name in text
    fig = tmp_path / "budget.png"
    assert main(["plot", str(out), "--torques", "-o", str(fig)]) == 0
    assert fig.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("edit", "key", "message"),
    [
        (("models = [", 'kind = "gravity_gradient"\nmodels = ['), "potential.models", "either"),
        (
            ('"eddy_current_damping",\n]', '"eddy_current_damping",\n"eddy_current_damping"]'),
            "potential.models",
            "twice",
        ),
        (("f107 = 150.0", "f107 = 500.0"), "potential.f107", "[50, 400]"),
        (('density = "msis"', 'density = "jb2008"'), "potential.density", "msis"),
        (('eclipse = "conical"', 'eclipse = "partial"'), "potential.eclipse", "conical"),
        (('dipole_unit = "A m2"', 'dipole_unit = "T"'), "spacecraft.dipole_unit", "dipole"),
        (
            ("normal = [0.0, 1.0, 0.0]", "normal = [0.0, 2.0, 0.0]"),
            "spacecraft.facets[2].normal",
            "unit vector",
        ),
        (
            ("diffuse = 0.3", "diffuse = 0.3\nspecular = 0.8"),
            "spacecraft.facets[7].specular",
            "sum",
        ),
        (("area = 0.01\n", "area = -0.01\n"), "spacecraft.facets[4].area", "> 0"),
        (('"aerodynamic_drag",\n    "solar_radiation",\n', ""), "potential.ap", "not used"),
        (
            [
                ('"aerodynamic_drag",\n    "solar_radiation",\n', ""),
                ('density = "msis"', ""),
                ("f107 = 150.0", ""),
                ("f107a = 150.0", ""),
                ("ap = 4.0", ""),
                ('eclipse = "conical"', ""),
            ],
            "spacecraft.facets",
            "not used",
        ),
        (
            ('[spacecraft]\ndipole = [0.0, 0.0, 0.05]\ndipole_unit = "A m2"\n', "[spacecraft]\n"),
            "spacecraft.dipole",
            "missing",
        ),
        (
            ("eddy_tensor = [4.5, 4.5, 1.5]", "eddy_tensor = [4.5, 4.5]"),
            "spacecraft.eddy_tensor",
            "3",
        ),
    ],
)
def test_environment_scenario_errors_name_the_key(edit, key, message):
    from attitude import scenario

    text = SCENARIO.read_text(encoding="utf-8")
    for old, new in edit if isinstance(edit, list) else [edit]:
        assert old in text
        text = text.replace(old, new, 1)
    with pytest.raises(scenario.ScenarioError) as exc:
        scenario.loads(text)
    assert str(exc.value).startswith(key) and message in str(exc.value), str(exc.value)


def test_environment_models_need_a_dated_orbit_in_scenarios():
    from attitude import scenario

    text = SCENARIO.read_text(encoding="utf-8")
    start = text.index("[orbit]")
    stop = text.index("[time]")
    kepler = (
        '[orbit]\na = 6975.0\na_unit = "km"\ne = 0.001\ninc = 97.9\ninc_unit = "deg"\n'
        'raan = 0.0\nraan_unit = "deg"\nargp = 0.0\nargp_unit = "deg"\n\n'
    )
    undated = text[:start] + kepler + text[stop:]
    undated = undated.replace('epoch = "2020-02-22T02:00:00"', "")
    with pytest.raises(scenario.ScenarioError, match=r"^orbit: .*epoch"):
        scenario.loads(undated)

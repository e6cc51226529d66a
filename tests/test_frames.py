"""Reference frames (attitude.frames), relative_to and initial_state, against closed forms,
finite differences, the orbit's own frame, astropy/ERFA called directly and a hand computation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from astropy import units as u

import attitude
import orbit
from attitude import frames
from attitude import quaternion as aq

EPOCH = "2024-03-20T12:00:00"


def _angle(u, v):
    """Angle between vectors (..., 3), accurate near 0 (not arccos of a dot product)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def _omega_fd(fr, t, h):
    """ω_R from a 4th-order central difference of q_R: ω = 2 vec(q̃ q̇) (reference axes)."""
    q = fr.quaternion(t)

    def at(s):
        qs = fr.quaternion(t + s)
        return qs * np.sign(np.sum(qs * q, axis=-1))[:, None]

    qdot = (-at(2 * h) + 8 * at(h) - 8 * at(-h) + at(-2 * h)) / (12 * h)
    return 2.0 * aq.multiply(aq.conjugate(q), qdot)[:, 1:]


def test_lvlh_circular_equatorial_closed_form():
    """r = a(cos nt, sin nt, 0): z_R = −r̂, y_R = −ẑ, x_R = v̂; ω_R = (0, −n, 0)."""
    o = orbit.KeplerOrbit(7000.0, 0.0, 0.0, 0.0, 0.0)
    n = o.mean_motion
    t = np.linspace(0.0, o.period, 37)
    q, w = frames.lvlh(o).evaluate(t)
    c, s = np.cos(n * t), np.sin(n * t)
    R = np.zeros((t.size, 3, 3))
    R[:, 0, 0], R[:, 1, 0] = -s, c  # x: along-track
    R[:, 2, 1] = -1.0  # y: −orbit normal
    R[:, 0, 2], R[:, 1, 2] = -c, -s  # z: nadir
    assert np.max(np.abs(aq.to_matrix(q) - R)) < 2e-15
    assert np.max(np.abs(w - [0.0, -n, 0.0])) < 1e-18
    # continuous sign along t
    assert np.all(np.sum(q[1:] * q[:-1], axis=-1) > 0)


def test_named_frames_axes_from_the_state():
    """rsw is the paper's p(t); vnc and lvlh axes built from r, v by hand; nadir defaults = lvlh."""
    o = orbit.KeplerOrbit(7000.0, 0.2, math.pi / 6, math.pi / 4, math.pi / 12)
    t = np.linspace(0.0, o.period, 25)
    r, v = o.to_state(t)
    rh = r / np.linalg.norm(r, axis=-1)[:, None]
    h = np.cross(r, v)
    hh = h / np.linalg.norm(h, axis=-1)[:, None]
    vh = v / np.linalg.norm(v, axis=-1)[:, None]
    # rsw: the orbital frame of Arribas et al. Sect. 6.2
    R_rsw = aq.to_matrix(frames.rsw(o).quaternion(t))
    assert np.max(np.abs(R_rsw - aq.to_matrix(o.frame_quaternion(t)))) < 1e-15
    # vnc: x = v̂, y = ĥ, z = x × y
    R = aq.to_matrix(frames.vnc(o).quaternion(t))
    for k, axis in enumerate((vh, hh, np.cross(vh, hh))):
        assert np.max(np.abs(R[:, :, k] - axis)) < 1e-15
    # lvlh: z = −r̂, y = −ĥ, x = y × z
    R = aq.to_matrix(frames.lvlh(o).quaternion(t))
    for k, axis in enumerate((np.cross(-hh, -rh), -hh, -rh)):
        assert np.max(np.abs(R[:, :, k] - axis)) < 1e-15
    R_nadir = aq.to_matrix(frames.nadir(o).quaternion(t))
    assert np.max(np.abs(R_nadir - R)) < 1e-15
    # nadir with other axes: +x to nadir, +y toward the velocity (as close as possible)
    R = aq.to_matrix(frames.nadir(o, axis="+x", secondary="+y").quaternion(t))
    assert np.max(np.abs(R[:, :, 0] + rh)) < 1e-15
    along = vh - np.sum(vh * rh, axis=-1)[:, None] * rh
    along /= np.linalg.norm(along, axis=-1)[:, None]
    assert np.max(np.abs(R[:, :, 1] - along)) < 1e-15


@pytest.mark.parametrize(
    "make",
    [
        lambda: frames.lvlh(orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3)),
        lambda: frames.vnc(orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3)),
        lambda: frames.nadir(orbit.KeplerOrbit(8000.0, 0.4, 2.0, 0.8, 0.3), "-y", [1, 1, 0]),
        lambda: frames.lvlh(orbit.SecularJ2Orbit(7000.0, 0.01, 1.2, 0.8, 0.3)),
        lambda: frames.vnc(
            orbit.EphemerisOrbit.from_orbit(
                orbit.SecularJ2Orbit(7000.0, 0.01, 1.2, 0.8, 0.3), 0.0, 6000.0, 60.0
            )
        ),
        lambda: frames.aligned(
            orbit.KeplerOrbit(7000.0, 0.1, 0.5, 0.8, 0.3), ("+x", [0, 0, 1]), ("+y", "velocity")
        ),
        lambda: frames.sun_pointing(orbit.KeplerOrbit(7000.0, 0.01, 0.9, 0.8, 0.3, epoch=EPOCH)),
        lambda: frames.target(
            orbit.KeplerOrbit(7000.0, 0.01, 0.9, 0.8, 0.3, epoch=EPOCH), 0.7, -0.06, 0.65
        ),
        lambda: frames.lvlh(orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3)).offset(
            aq.from_euler([0.3, -0.2, 1.1], "321")
        ),
    ],
    ids=["lvlh", "vnc", "nadir", "lvlh-J2", "vnc-ephemeris", "fixed", "sun", "target", "offset"],
)
def test_angular_velocity_is_the_derivative_of_the_quaternion(make):
    fr = make()
    t = np.array([300.0, 1700.0, 2900.0, 4100.0, 5300.0])
    w = fr.angular_velocity(t)
    # the Sun frame turns at ~2e-7 rad/s: a wider difference step against rounding
    wfd = _omega_fd(fr, t, 20.0 if fr.name == "sun_pointing" else 0.5)
    scale = max(np.max(np.abs(w)), 1e-6)
    assert np.max(np.abs(wfd - w)) < 2e-9 * scale + 1e-15, (np.max(np.abs(wfd - w)), scale)


def test_orbit_acceleration_is_the_derivative_of_the_velocity():
    for o in (
        orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3),
        orbit.SecularJ2Orbit(7000.0, 0.05, 1.7, 0.8, 0.3),
        orbit.EphemerisOrbit.from_orbit(orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3), 0, 6000, 60),
    ):
        t = np.array([500.0, 2000.0, 3700.0, 5100.0])
        h = 0.5
        v = o.velocity
        fd = (-v(t + 2 * h) + 8 * v(t + h) - 8 * v(t - h) + v(t - 2 * h)) / (12 * h)
        a = o.acceleration(t)
        assert np.max(np.abs(a - fd)) < 1e-9 * np.max(np.abs(a))
    k = orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3)
    r = k.position(t)
    ref = -k.mu * r / np.linalg.norm(r, axis=-1)[:, None] ** 3
    np.testing.assert_allclose(k.acceleration(t), ref, rtol=1e-15, atol=0)


def test_offset_composes_on_the_right():
    o = orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3)
    off = aq.from_euler([0.3, -0.2, 1.1], "321")
    t = np.linspace(0, 3000, 7)
    q, w = frames.lvlh(o).evaluate(t)
    q2, w2 = frames.lvlh(o).offset(off).evaluate(t)
    assert np.max(np.abs(aq.to_matrix(q2) - aq.to_matrix(aq.multiply(q, off)))) < 1e-15
    assert np.max(np.abs(w2 - aq.rotate_inverse(off, w))) < 1e-18
    fi = frames.inertial(off)
    qi, wi = fi.evaluate(t)
    assert np.all(qi == off) and np.all(wi == 0.0)


def test_offsets_compose_in_order():
    """Two offsets in a row: (lvlh.offset(a)).offset(b) turns by a, then by b about the new
    axes, q = q_R∘a∘b: the same frame as one offset a∘b, and not b∘a (a, b do not commute)."""
    o = orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3)
    a = aq.from_euler([0.3, -0.2, 1.1], "321")
    b = aq.from_euler([-0.7, 0.4, 0.25], "321")
    ab, ba = aq.multiply(a, b), aq.multiply(b, a)
    assert np.max(np.abs(aq.to_matrix(ab) - aq.to_matrix(ba))) > 0.1
    t = np.linspace(0, 3000, 7)
    q, w = frames.lvlh(o).evaluate(t)
    q2, w2 = frames.lvlh(o).offset(a).offset(b).evaluate(t)
    q1, w1 = frames.lvlh(o).offset(ab).evaluate(t)
    assert np.max(np.abs(aq.to_matrix(q2) - aq.to_matrix(q1))) < 1e-15
    assert np.max(np.abs(w2 - w1)) < 1e-17
    # the definition, by hand: reference axes turned by a, then by b
    want_q = aq.multiply(aq.multiply(q, a), b)
    want_w = aq.rotate_inverse(b, aq.rotate_inverse(a, w))
    assert np.max(np.abs(aq.to_matrix(q2) - aq.to_matrix(want_q))) < 1e-15
    assert np.max(np.abs(w2 - want_w)) < 1e-17
    # the same on an inertial frame (its constant q)
    qi, _ = frames.inertial(a).offset(b).evaluate(t[:2])
    assert np.max(np.abs(aq.to_matrix(qi) - aq.to_matrix(ab))) < 1e-15


def test_sun_pointing_against_astropy():
    from orbit.sun import sun_position

    o = orbit.KeplerOrbit(7000.0, 0.01, 0.9, 0.8, 0.3, epoch=EPOCH)
    t = np.linspace(0.0, 86400.0, 9)
    q = frames.sun_pointing(o, axis="-x", secondary="+z").quaternion(t)
    s = sun_position(o.epoch, t) - o.position(t)  # astropy directly, seen from the satellite
    s /= np.linalg.norm(s, axis=-1)[:, None]
    assert np.max(_angle(aq.rotate(q, [-1.0, 0, 0]), s)) < 1e-12
    # the secondary axis: as close as possible to the orbit normal (the default)
    q = frames.sun_pointing(o, axis="+x", secondary="+z").quaternion(t)
    z = aq.rotate(q, [0, 0, 1.0])
    hh = np.cross(*o.to_state(t))
    hh /= np.linalg.norm(hh, axis=-1)[:, None]
    assert np.all(np.sum(z * hh, axis=-1) > 0) and np.max(np.abs(np.sum(z * s, axis=-1))) < 1e-10


def test_target_against_a_hand_computation():
    """WGS 84 geodetic → ECEF by the textbook formula, ITRS → GCRS by ERFA's c2t06a matrix
    (UT1 and polar motion from the bundled IERS table), line of sight from the satellite."""
    import erfa
    from astropy.time import Time

    from orbit.timescales import iers_table, ut1_minus_utc

    lat, lon, hgt = math.radians(40.4), math.radians(-3.7), 0.65  # rad, rad, km
    o = orbit.KeplerOrbit(7000.0, 0.001, math.radians(60), 0.3, 0.0, epoch=EPOCH)
    t = 1234.5
    fr = frames.target(o, lat * u.rad, math.degrees(lon) * u.deg, hgt * u.km)
    zb = aq.rotate(fr.quaternion(np.array([t]))[0], [0.0, 0.0, 1.0])
    # hand: WGS 84
    a, f = 6378.137, 1 / 298.257223563
    e2 = f * (2 - f)
    N = a / math.sqrt(1 - e2 * math.sin(lat) ** 2)
    x_itrs = np.array(
        [
            (N + hgt) * math.cos(lat) * math.cos(lon),
            (N + hgt) * math.cos(lat) * math.sin(lon),
            (N * (1 - e2) + hgt) * math.sin(lat),
        ]
    )
    tt = Time(EPOCH, scale="utc") + t * u.s
    dut1 = float(ut1_minus_utc(tt))
    ut1 = Time(tt.utc.jd1, tt.utc.jd2 + dut1 / 86400.0, format="jd", scale="ut1")
    tab = iers_table()
    xp, yp = (x.to_value(u.rad) for x in tab.pm_xy(tt.utc))
    rc2t = erfa.c2t06a(tt.tt.jd1, tt.tt.jd2, ut1.jd1, ut1.jd2, float(xp), float(yp))
    x_gcrs = rc2t.T @ x_itrs
    los = x_gcrs - o.position(t)
    los /= np.linalg.norm(los)
    # the station's GCRS position agrees with the hand chain to ~1e-12 km; the line of sight
    # through the 10-minute table to 1e-12 rad
    assert float(_angle(zb, los)) < 1e-11
    # the secondary axis lies in the plane of the line of sight and the velocity
    xb = aq.rotate(fr.quaternion(np.array([t]))[0], [1.0, 0.0, 0.0])
    assert abs(float(xb @ np.cross(los, o.velocity(t)))) < 1e-12


def test_initial_state_and_relative_to_offsets():
    o = orbit.KeplerOrbit(7000.0, 0.1, 0.5, 0.8, 0.3)
    body = attitude.RigidBody([400.0, 500.0, 600.0], units="kg km2")
    angles = np.array([0.2, -0.1, 0.3])  # yaw, pitch, roll (3-2-1)
    rates = np.array([0.01, -0.02, 0.005]) * u.deg / u.s
    fr = frames.lvlh(o)
    q0, Q0 = attitude.initial_state(body, fr, 100.0, aq.from_euler(angles, "321"), rates)
    qR, wR = fr.evaluate(np.array([100.0]))
    np.testing.assert_allclose(q0, aq.multiply(qR[0], aq.from_euler(angles, "321")), atol=1e-16)
    w = attitude.canonical.angular_velocity(q0, Q0, body)
    expect = aq.rotate_inverse(aq.from_euler(angles, "321"), wR[0]) + rates.to_value("rad/s")
    np.testing.assert_allclose(w, expect, rtol=0, atol=1e-17)
    t = np.linspace(100.0, 400.0, 4)
    ds = attitude.propagate(body, q0, Q0, t, rtol=1e-12, atol=1e-14)
    rel = ds.attitude.relative_to(fr, degrees=True)
    np.testing.assert_allclose(rel["euler_angles"].values[0], np.degrees(angles), atol=1e-12)
    assert [rel[n].values[0] for n in ("yaw", "pitch", "roll")] == pytest.approx(
        list(np.degrees(angles)), abs=1e-12
    )
    np.testing.assert_allclose(rel["omega_BR"].values[0], rates.to_value("deg/s"), atol=1e-14)
    assert rel["omega_BR"].attrs["units"] == "deg s-1" and rel["roll"].attrs["units"] == "deg"
    err = 2 * np.degrees(np.arccos(abs(aq.from_euler(angles, "321")[0])))
    assert float(rel["error_angle"][0]) == pytest.approx(err, abs=1e-12)
    r313 = ds.attitude.relative_to(fr, "313")
    assert "roll" not in r313 and r313["euler_angles"].attrs["units"] == "rad"
    np.testing.assert_allclose(
        aq.from_euler(r313["euler_angles"].values, "313"),
        aq.canonical(r313["q_BR"].values) * np.sign(aq.canonical(r313["q_BR"].values)[:, :1]),
        atol=1e-14,
    )


def test_gravity_gradient_equilibrium_stays_in_lvlh():
    """A body with the gravity-gradient equilibrium inertia (least axis to nadir, greatest
    along the orbit normal), started aligned with LVLH and turning with it in a circular orbit,
    stays aligned: relative_to(lvlh) is zero to the integrator's accuracy."""
    o = orbit.KeplerOrbit(7000.0, 0.0, 0.7, 0.3, 0.0)
    body = attitude.RigidBody([500.0, 600.0, 300.0], units="kg km2")  # x, y (−normal), z nadir
    fr = frames.lvlh(o)
    q0, Q0 = attitude.initial_state(body, fr)
    t = np.linspace(0.0, 2 * o.period, 201)
    ds = attitude.propagate(
        body, q0, Q0, t, potential=attitude.GravityGradient(o), rtol=1e-12, atol=1e-14
    )
    rel = ds.attitude.relative_to(fr)
    assert float(rel["error_angle"].max()) < 1e-11
    assert float(np.abs(rel["omega_BR"]).max()) < 1e-13  # vs the orbit rate 1.1e-3 rad/s


def test_frame_errors():
    o = orbit.KeplerOrbit(7000.0, 0.1, 0.5, 0.8, 0.3)
    with pytest.raises(attitude.AttitudeValueError, match="epoch"):
        frames.sun_pointing(o)
    with pytest.raises(attitude.AttitudeValueError, match="parallel"):
        frames.nadir(o, axis="+x", secondary="-x")
    with pytest.raises(attitude.AttitudeValueError, match="axis"):
        frames.nadir(o, axis="+w")
    with pytest.raises(attitude.AttitudeValueError, match="direction"):
        frames.aligned(o, ("+x", "moon"), ("+y", "nadir"))
    with pytest.raises(attitude.AttitudeTypeError, match="orbit"):
        frames.lvlh("LEO")
    with pytest.raises(attitude.AttitudeValueError, match="latitude"):
        frames.target(orbit.KeplerOrbit(7000.0, 0.1, 0.5, 0.8, 0.3, epoch=EPOCH), 2.0, 0.0)
    # a dimensionless run cannot be compared with an orbit's frame
    body = attitude.RigidBody([1.0, 2.0, 3.0])
    ds = attitude.propagate(body, [1, 0, 0, 0], [0, 0, 0, 0], [0.0, 1.0])
    with pytest.raises(attitude.AttitudeValueError, match="dimensionless"):
        ds.attitude.relative_to(frames.lvlh(o))
    assert float(ds.attitude.relative_to(frames.inertial())["error_angle"].max()) == 0.0
    eph = orbit.EphemerisOrbit.from_orbit(o, 0.0, 600.0, 60.0)
    with pytest.raises(attitude.AttitudeValueError, match="table"):
        frames.lvlh(eph).quaternion([0.0, 1000.0])


def test_with_orbit_is_the_frame_built_on_that_orbit():
    a = orbit.KeplerOrbit(7000.0, 0.01, 0.9, 0.3, 0.2, epoch="2024-03-20T12:00:00")
    b = orbit.KeplerOrbit(7300.0, 0.02, 1.2, 0.1, 0.5, epoch="2024-03-20T12:00:00")
    turn = aq.from_euler([0.1, -0.2, 0.3], "321")
    t = np.linspace(0.0, 5000.0, 11)
    for make in (frames.lvlh, frames.sun_pointing):
        moved = make(a).offset(turn).with_orbit(b)
        want = make(b).offset(turn).evaluate(t)
        got = moved.evaluate(t)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        assert moved.orbit is b and make(a).orbit is a
    with pytest.raises(attitude.AttitudeValueError, match="no orbit to replace"):
        frames.inertial().with_orbit(b)
    undated = orbit.KeplerOrbit(7300.0, 0.02, 1.2, 0.1, 0.5)
    with pytest.raises(attitude.AttitudeValueError, match="needs an orbit with an epoch"):
        frames.sun_pointing(a).with_orbit(undated)

"""Monte Carlo from Python: per-member inertia in the canonical maps, the dispersion helper
(the scenario's ``[ensemble]`` draws, made public), and the nominal run of dispersed bodies.

Truth: row-by-row single-body calls; the members a scenario run stores (the same draws, bit
for bit); the moments of a normal distribution truncated at ±3σ (closed form); a single
``propagate`` of the nominal state.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from astropy import units as u
from scipy.stats import norm

import attitude
from attitude import canonical as C
from attitude import io, scenario
from attitude.ensemble import disperse, propagate_ensemble, run_scenario
from attitude.errors import AttitudeValueError

ROOT = Path(__file__).resolve().parents[1]


def test_momenta_from_angular_velocity_takes_per_member_inertia():
    rng = np.random.default_rng(7)
    n = 50
    inertia = np.array([40.0, 50.0, 60.0]) * (1 + 0.05 * rng.uniform(-1, 1, (n, 3)))
    q = attitude.quaternion.normalize(rng.normal(size=(n, 4)))
    w = rng.normal(size=(n, 3)) * u.deg / u.s
    Q = C.momenta_from_angular_velocity(q, w, inertia * u.Unit("kg m2"))
    assert Q.shape == (n, 4)
    for i in (0, 17, n - 1):  # the single-body call, row by row
        body = attitude.RigidBody(inertia[i] * u.Unit("kg m2"))
        np.testing.assert_array_equal(Q[i], C.momenta_from_angular_velocity(q[i], w[i], body))
    # and back: omega and T with the same rows; a sequence of bodies is the same
    np.testing.assert_allclose(
        C.angular_velocity(q, Q, inertia), w.to_value("rad/s"), rtol=1e-14, atol=0
    )
    bodies = [attitude.RigidBody(row, units="kg m2") for row in inertia]
    np.testing.assert_array_equal(C.momenta_from_angular_velocity(q, w, bodies), Q)
    T = C.kinetic_energy(q, Q, inertia)
    np.testing.assert_allclose(T, 0.5 * np.sum(inertia * w.to_value("rad/s") ** 2, axis=1))
    # one attitude for all members broadcasts
    Q1 = C.momenta_from_angular_velocity(q[0], w, inertia * u.Unit("kg m2"))
    np.testing.assert_array_equal(Q1[3], C.momenta_from_angular_velocity(q[0], w[3], bodies[3]))


def test_per_member_inertia_errors_say_what_to_do():
    q = np.array([1.0, 0.0, 0.0, 0.0])
    with pytest.raises(AttitudeValueError, match=r"row 1: .* triangle inequality.*disperse"):
        C.momenta_from_angular_velocity(q, [0.1, 0, 0], [[1.0, 2.0, 2.5], [1.0, 2.0, 5.0]])
    with pytest.raises(
        AttitudeValueError, match=r"one row of principal moments per member \(N, 3\)"
    ):
        C.momenta_from_angular_velocity(q, [0.1, 0, 0], np.ones((2, 4)))
    with pytest.raises(AttitudeValueError, match="row 0: principal moments must be positive"):
        C.momenta_from_angular_velocity(q, [0.1, 0, 0], [[-1.0, 2.0, 2.5]])


@pytest.fixture(scope="module")
def ens_scenario():
    sc = scenario.load(ROOT / "scenarios/ensemble_paper_keplerian.toml")
    sc.t = sc.t[:6]
    sc.ensemble.size = 24
    return sc


def test_disperse_draws_the_scenario_members_and_its_nominal_run(ens_scenario, tmp_path):
    sc = ens_scenario
    e = sc.ensemble
    d = disperse(
        sc.body, sc.q0, sc.Q0, e.size,
        attitude_error=e.attitude_error * u.rad, rate_error=e.rate_error * u.rad / u.s,
        inertia_error=e.inertia_error, seed=e.seed,
    )  # fmt: skip
    run_scenario(sc, tmp_path / "e.nc")
    ref = io.read(tmp_path / "e.nc")
    np.testing.assert_array_equal(d.q, ref.initial_q.values)
    np.testing.assert_array_equal(d.Q, ref.initial_Q.values)
    np.testing.assert_array_equal(d.inertia.to_value("kg m2"), ref.inertia.values)
    np.testing.assert_array_equal(d.errors["inertia"], ref.dispersion_inertia.values)
    # the same run from Python, nominal run included (dispersed bodies: nominal=(q0, Q0, body))
    # (the scenario's method, dop853, named: the default "auto" would pick taylor)
    assert ref.attrs["method"] == sc.method == "dop853"
    ds = propagate_ensemble(d.inertia, d.q, d.Q, sc.t, sc.potential, sc.method, rtol=1e-10,
                            atol=1e-12, nominal=d.nominal)  # fmt: skip
    np.testing.assert_array_equal(ds.q.values, ref.q.values)
    np.testing.assert_array_equal(ds.reference_q.values, ref.reference_q.values)
    # a slice of members is the same members
    part = disperse(
        sc.body, sc.q0, sc.Q0, 5, start=10,
        attitude_error=e.attitude_error * u.rad, rate_error=e.rate_error * u.rad / u.s,
        inertia_error=e.inertia_error, seed=e.seed,
    )  # fmt: skip
    np.testing.assert_array_equal(part.q, d.q[10:15])


def test_nominal_with_dispersed_inertia_is_the_nominal_body_propagated(ens_scenario):
    sc = ens_scenario
    d = disperse(sc.body, sc.q0, sc.Q0, 8, inertia_error=0.02, attitude_error=0.01, seed=3)
    with pytest.raises(AttitudeValueError, match=r"nominal=\(q0, Q0, body\)"):
        propagate_ensemble(d.inertia, d.q, d.Q, sc.t, sc.potential, nominal=d.nominal[:2])
    ds = propagate_ensemble(d.inertia, d.q, d.Q, sc.t, sc.potential, rtol=1e-12, atol=1e-14,
                            nominal=d.nominal)  # fmt: skip
    q0, Q0, body = d.nominal
    single = attitude.propagate(body, q0, Q0, sc.t, sc.potential, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ds.reference_q.values, single.q.values, rtol=0, atol=1e-11)
    with pytest.raises(AttitudeValueError, match="different unit systems"):
        propagate_ensemble(d.inertia, d.q, d.Q, sc.t, sc.potential,
                           nominal=(q0, Q0, body.inertia))  # fmt: skip


def test_inertia_errors_are_a_normal_truncated_at_three_sigma():
    body = attitude.RigidBody([400.0, 500.0, 600.0], units="kg m2")
    sigma = 0.05
    d = disperse(body, [1, 0, 0, 0], [0, 1, 0, 0], 100_000, inertia_error=sigma, seed=11)
    eps = d.errors["inertia"].ravel()
    assert np.max(np.abs(eps)) <= 3 * sigma and np.max(np.abs(eps)) > 2.9 * sigma
    # variance of a standard normal truncated at ±a: 1 - 2 a φ(a) / (2 Φ(a) - 1)
    a = 3.0
    var = 1 - 2 * a * norm.pdf(a) / (2 * norm.cdf(a) - 1)
    np.testing.assert_allclose(np.std(eps) / sigma, np.sqrt(var), rtol=4e-3)
    np.testing.assert_allclose(np.mean(eps), 0.0, atol=4 * sigma / np.sqrt(eps.size))
    np.testing.assert_array_equal(
        d.inertia.to_value("kg m2"), body.inertia * (1 + d.errors["inertia"])
    )
    # every member is a rigid body: the canonical maps and the ensemble take them
    C.momenta_from_angular_velocity(d.q, np.zeros((eps.size // 3, 3)), d.inertia)
    # no inertia error: the nominal body itself, so nominal=(q0, Q0) works too
    d0 = disperse(body, [1, 0, 0, 0], [0, 1, 0, 0], 4, attitude_error=1 * u.deg)
    assert d0.inertia is body


@pytest.mark.parametrize(
    "kw,match",
    [
        ({"attitude_error": 1 * u.s}, "attitude_error: units s are not an angle"),
        ({"attitude_error": -1.0}, "attitude_error: must be >= 0"),
        ({"rate_error": 1 * u.m}, "rate_error"),
        ({"inertia_distribution": "cauchy"}, "inertia_distribution: expected one of"),
        ({"inertia_error": 0.5}, "inertia_error: a relative error up to 1.5"),
        ({"start": -1}, "start: expected an integer >= 0"),
    ],
)
def test_disperse_errors(kw, match):
    body = attitude.RigidBody([400.0, 500.0, 600.0], units="kg m2")
    with pytest.raises((AttitudeValueError, attitude.AttitudeTypeError), match=match):
        disperse(body, [1, 0, 0, 0], [0, 1, 0, 0], 4, **kw)

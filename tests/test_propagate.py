"""The canonical propagator against independent truth.

Closed forms (uniform spin, the symmetric top), conservation laws (heavy top), a second
independently coded formulation (Euler's equations with q̇ = ½ q∘(0, ω), plain numpy + scipy),
and scipy's DOP853 on the same equations.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import attitude
from attitude import canonical as C
from attitude import quaternion as qt
from attitude.body import RigidBody
from attitude.errors import AttitudeTypeError, AttitudeValueError, PropagationError
from attitude.potentials import CustomTorque, HeavyTop, TorqueFree
from attitude.propagate import propagate

I_PAPER = np.array([1.25, 1.0, 0.75])
Q0_PRINTED = np.array([0.3, -0.848528, 0.141421, -1.5])
q0_PRINTED = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])


@pytest.fixture(scope="module")
def paper_state():
    q, Q, _ = C.project_state(q0_PRINTED, Q0_PRINTED)
    return q, Q


def test_uniform_spin_about_each_principal_axis():
    rng = np.random.default_rng(10)
    q0 = qt.normalize(rng.normal(size=4))
    # Spin about the intermediate axis (k = 1) is unstable: rounding errors grow like
    # exp(λt), λ = ω sqrt((I1 − I2)(I2 − I3)/(I1 I3)) ≈ 0.44 here, so keep that span short.
    for k, t_end in ((0, 50.0), (1, 10.0), (2, 50.0)):
        t = np.linspace(0.0, t_end, 101)
        w = np.zeros(3)
        w[k] = 1.7
        Q0 = C.momenta_from_angular_velocity(q0, w, I_PAPER)
        ds = propagate(I_PAPER, q0, Q0, t, rtol=1e-13, atol=1e-15)
        exact = qt.multiply(q0, qt.from_rotation_vector(np.outer(t, w)))
        assert np.max(qt.angle_between(ds.q.values, exact)) < 1e-11
        np.testing.assert_allclose(ds.omega.values, np.broadcast_to(w, (101, 3)), atol=1e-12)


def test_symmetric_top_closed_form():
    """I1 = I2: q(t) = exp_S(Ĝ |G| t / I1)∘q0∘exp_B(e3 ν t), ν = g3 (1/I3 − 1/I1)."""
    inertia = np.array([2.0, 2.0, 0.7])
    rng = np.random.default_rng(11)
    q0 = qt.normalize(rng.normal(size=4))
    g0 = np.array([0.4, -0.9, 1.3])
    Q0 = C.momenta_from_body_angular_momentum(q0, g0)
    t = np.linspace(0.0, 200.0, 401)
    ds = propagate(inertia, q0, Q0, t, rtol=1e-13, atol=1e-15)
    G = qt.rotate(q0, g0)
    nu = g0[2] * (1 / inertia[2] - 1 / inertia[0])
    prec = qt.from_rotation_vector(np.outer(t, G / inertia[0]))
    spin = qt.from_rotation_vector(np.outer(t, [0.0, 0.0, nu]))
    exact = qt.multiply(qt.multiply(prec, q0), spin)
    err = qt.angle_between(ds.q.values, exact)
    # global error of a rtol = 1e-13 run after ~160 rad of rotation
    assert np.max(err) < 2e-10
    np.testing.assert_allclose(ds.G.values, np.broadcast_to(G, (401, 3)), atol=1e-11)


def test_heavy_top_conserves_energy_and_vertical_momentum(paper_state):
    q0, Q0 = paper_state
    pot = HeavyTop(0.5, [1.0, 0.0, 0.0])
    t = np.linspace(0.0, 1000.0, 2001)
    ds = propagate(I_PAPER, q0, Q0, t, potential=pot, rtol=1e-14, atol=1e-16)
    E = ds.energy.values
    G3 = ds.G.values[:, 2]
    # relative to the conserved values themselves (measured: 1.7e-12 and 1.1e-13)
    assert np.max(np.abs(E - E[0])) / abs(E[0]) < 3e-12
    assert np.max(np.abs(G3 - G3[0])) / abs(G3[0]) < 1e-12
    assert np.max(np.abs(ds.norm_error.values)) < 1e-12
    assert np.max(np.abs(ds.qQ.values)) < 1e-12


def euler_equations_reference(inertia, q0, w0, t, torque, rtol=1e-13):
    """Independent second formulation: I ω̇ = τ − ω × Iω, q̇ = ½ q∘(0, ω) (Schwab 16, 19)."""

    def qmul(a, b):
        return np.array(
            [
                a[0] * b[0] - a[1:] @ b[1:],
                *(a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])),
            ]
        )

    def f(tt, y):
        q, w = y[:4], y[4:]
        tau = torque(q, tt)
        wd = (tau - np.cross(w, inertia * w)) / inertia
        qd = 0.5 * qmul(q, np.array([0.0, *w]))
        return np.concatenate([qd, wd])

    sol = solve_ivp(
        f, (t[0], t[-1]), np.concatenate([q0, w0]), method="DOP853", t_eval=t, rtol=rtol, atol=1e-15
    )
    return sol.y.T


def test_against_euler_equations_heavy_top(paper_state):
    q0, Q0 = paper_state
    W, c = 0.5, np.array([1.0, 0.0, 0.0])

    def torque(q, tt):
        # F_B = q̃ (−W s3) q written with the DCM, τ = c × F_B
        R = qt.to_matrix(q / np.linalg.norm(q))
        return np.cross(c, R.T @ np.array([0.0, 0.0, -W]))

    t = np.linspace(0.0, 30.0, 61)
    w0 = C.angular_velocity(q0, Q0, I_PAPER)
    ref = euler_equations_reference(I_PAPER, q0, w0, t, torque)
    ds = propagate(I_PAPER, q0, Q0, t, potential=HeavyTop(W, c), rtol=1e-13, atol=1e-15)
    assert np.max(qt.angle_between(ds.q.values, ref[:, :4])) < 1e-9
    np.testing.assert_allclose(ds.omega.values, ref[:, 4:], atol=1e-9)


def test_scipy_path_agrees(paper_state):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 20.0, 41)
    pot = HeavyTop(0.5, [1.0, 0.0, 0.0])
    a = propagate(I_PAPER, q0, Q0, t, potential=pot, rtol=1e-12, atol=1e-14)
    b = propagate(I_PAPER, q0, Q0, t, potential=pot, method="scipy:DOP853", rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(a.q.values, b.q.values, atol=1e-10)
    assert b.attrs["method"] == "scipy:DOP853"


def test_chunked_run_is_bit_identical(paper_state):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 100.0, 333)
    a = propagate(I_PAPER, q0, Q0, t, potential=HeavyTop(0.5, [1, 0, 0]))
    calls = []
    b = propagate(
        I_PAPER,
        q0,
        Q0,
        t,
        potential=HeavyTop(0.5, [1, 0, 0]),
        chunk=7,
        progress=lambda n, m, tr: calls.append((n, m, tr)),
    )
    assert np.array_equal(a.q.values, b.q.values) and np.array_equal(a.Q.values, b.Q.values)
    assert calls[-1][0] == 333 and len(calls) == 48
    assert a.attrs["n_steps"] == b.attrs["n_steps"]


def test_backward_run_returns(paper_state):
    q0, Q0 = paper_state
    pot = HeavyTop(0.5, [1, 0, 0])
    fwd = propagate(I_PAPER, q0, Q0, [0.0, 50.0], potential=pot, rtol=1e-13, atol=1e-15)
    back = propagate(
        I_PAPER,
        fwd.q.values[-1],
        fwd.Q.values[-1],
        [50.0, 0.0],
        potential=pot,
        rtol=1e-13,
        atol=1e-15,
    )
    assert qt.angle_between(back.q.values[-1], q0) < 1e-10


def test_output_times_exact_and_initial_sample(paper_state):
    q0, Q0 = paper_state
    t = np.array([0.0, 0.1, 0.3, 7.0])
    ds = propagate(I_PAPER, q0, Q0, t)
    np.testing.assert_array_equal(ds.time.values, t)
    # the initial sample is the (re-projected) initial state, to the last bit of |q| = 1
    np.testing.assert_allclose(ds.q.values[0], q0, rtol=0, atol=3e-16)
    # single sample: just the initial state
    ds1 = propagate(I_PAPER, q0, Q0, [3.0])
    np.testing.assert_array_equal(ds1.q.values, ds.q.values[:1])


def test_dataset_schema(paper_state):
    from astropy import units as u

    q0, Q0 = paper_state
    ds = propagate(I_PAPER, q0, Q0, np.linspace(0, 1, 5), potential=TorqueFree())
    for name in ("q", "Q", "omega", "g", "G", "energy", "norm_error", "qQ"):
        assert name in ds
        u.Unit(ds[name].attrs["units"])
        assert ds[name].attrs["long_name"]
    # CF: numeric dimension coordinates, letters in auxiliary label coordinates
    assert ds.component.values.tolist() == [0, 1, 2, 3]
    assert list(ds.component_label.values) == ["w", "x", "y", "z"]
    assert ds.axis.values.tolist() == [0, 1, 2]
    assert list(ds.axis_label.values) == ["x", "y", "z"]
    # the default "auto" picks taylor for a built-in potential and says so
    assert ds.attrs["method"] == "taylor" and ds.attrs["method_requested"] == "auto"
    assert ds.attrs["rtol"] == 1e-10


#: A constant body torque along b3 (N m), the user model of the tests below (one function:
#: each user function compiles its own copy of the entry points).
SPIN_UP = 0.02


def _spin_up(q, t):
    return (0.0, 0.0, SPIN_UP)


def _same_run(a, b):
    """Every variable and coordinate of two results equal bit for bit (attrs aside)."""
    assert sorted(a.variables) == sorted(b.variables)
    for name in a.variables:
        assert a[name].values.tobytes() == b[name].values.tobytes(), name


def test_auto_is_bit_for_bit_the_method_it_picks(paper_state):
    """method="auto" (the default): taylor wherever the model supports it, dop853 otherwise;
    the run is the picked method's, bit for bit, and the attrs record both."""
    import orbit
    from attitude import ReactionWheel, Spacecraft
    from attitude.events import RateExceeds
    from attitude.potentials import GravityGradient
    from attitude.propagate import choose_method

    q0, Q0 = paper_state
    t = np.linspace(0.0, 50.0, 11)
    o = orbit.KeplerOrbit(7000.0, 0.2, 0.5, 0.8, 0.3, f0=0.0)

    cases = [  # (potential, keyword arguments, the method auto must pick)
        (TorqueFree(), {}, "taylor"),
        (HeavyTop(0.5, [1.0, 0.0, 0.0]), {}, "taylor"),
        (GravityGradient(o), {}, "taylor"),
        (CustomTorque(_spin_up), {}, "dop853"),  # a user's torque: no series
        (HeavyTop(0.5, [1.0, 0.0, 0.0]), {"events": [RateExceeds(10.0)]}, "dop853"),
        (TorqueFree(), {"formulation": "euler_angles"}, "dop853"),
    ]
    for pot, kw, picked in cases:
        auto = propagate(I_PAPER, q0, Q0, t, pot, **kw)
        assert auto.attrs["method"] == picked and auto.attrs["method_requested"] == "auto"
        explicit = propagate(I_PAPER, q0, Q0, t, pot, picked, **kw)
        assert "method_requested" not in explicit.attrs
        _same_run(auto, explicit)
        arrays = propagate(I_PAPER, q0, Q0, t, pot, output="arrays", **kw) if not kw else None
        if arrays is not None:
            assert arrays.q.tobytes() == explicit.q.values.tobytes()
    # a spacecraft with a wheel: taylor (its friction is piecewise affine)
    craft = Spacecraft(RigidBody(I_PAPER), wheels=[ReactionWheel([1.0, 0.0, 0.0], 0.01)])
    assert choose_method("auto", TorqueFree(), spacecraft=craft) == "taylor"
    auto = propagate(craft, q0, Q0, t)
    assert auto.attrs["method"] == "taylor"
    _same_run(auto, propagate(craft, q0, Q0, t, method="taylor"))
    # an explicit method is never changed
    assert choose_method("dop853", TorqueFree()) == "dop853"
    with pytest.raises(AttitudeValueError, match="method"):
        propagate(I_PAPER, q0, Q0, t, method="automatic")


def test_auto_is_bit_for_bit_the_method_it_picks_with_sensors_and_the_mekf():
    """method="auto" (the default) on a closed loop with wheels, a gyro, a star tracker and the
    MEKF picks taylor and is that run bit for bit (every variable, the sensors' and the
    estimator's included)."""
    from astropy import units as u
    from test_software import hr16_spacecraft

    from attitude import frames
    from attitude.control import MRPFeedback
    from attitude.estimation import MEKF
    from attitude.sensors import Gyro, StarTracker
    from attitude.software import FlightSoftware

    def run(**kw):
        craft = hr16_spacecraft()
        q0 = qt.from_mrp([0.02, -0.01, 0.03])
        Q0 = C.momenta_from_angular_velocity(q0, [0.001, 0.0, -0.002], craft)
        fsw = FlightSoftware(
            0.5,
            guidance=frames.inertial(),
            control=MRPFeedback(3.5, 30.0),
            sensors=[Gyro(0.05 * u.deg / u.hour**0.5, seed=4), StarTracker(6 * u.arcsec, seed=5)],
            estimator=MEKF(initial_attitude=q0),
            record_every=1,
        )
        t = np.linspace(0.0, 6.0, 4)
        return attitude.propagate(craft, q0, Q0, t, software=fsw, rtol=1e-12, **kw)

    auto = run()
    assert auto.attrs["method"] == "taylor" and auto.attrs["method_requested"] == "auto"
    assert "estimation_error" in auto and "nees" in auto
    _same_run(auto, run(method="taylor"))


def test_units_follow_the_body(paper_state):
    from astropy import units as u

    q0, _ = paper_state
    body = RigidBody([400, 500, 600] * u.Unit("kg km2"))
    Q0 = C.momenta_from_angular_velocity(q0, [1e-3, 0, 2e-3], body)
    ds = propagate(body, q0, Q0, np.linspace(0, 10, 3))
    # no epoch: CF placeholder reference, the plain unit of the numbers in elapsed_time_units
    assert ds.time.attrs["units"] == "seconds since 1970-01-01 00:00:00"
    assert ds.time.attrs["elapsed_time_units"] == "s" and "no epoch" in ds.time.attrs["comment"]
    # a body with units gives SI results (was kg km² based before issue 16)
    assert u.Unit(ds.g.attrs["units"]) == u.Unit("kg m2 / s")
    assert u.Unit(ds.energy.attrs["units"]) == u.J
    # Quantities at the boundary: Q0 in any angular-momentum unit, t in any time unit
    Q0_km = (Q0 * 1e-6) * u.Unit("kg km2 / s")
    ds2 = propagate(body, q0, Q0_km, np.linspace(0, 10, 3) / 60 * u.min)
    np.testing.assert_allclose(ds2.q.values, ds.q.values, rtol=0, atol=1e-15)
    with pytest.raises(AttitudeTypeError, match="Q0"):
        propagate(body, q0, Q0 * u.kg, [0.0, 1.0])


def test_constant_body_torque_closed_form():
    """Spin about b3 with a constant torque along b3: ω3(t) = ω0 + c t / I3, exactly."""
    c = SPIN_UP
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    Q0 = C.momenta_from_angular_velocity(q0, [0, 0, 0.3], I_PAPER)
    t = np.linspace(0.0, 10.0, 21)
    ds = propagate(I_PAPER, q0, Q0, t, potential=CustomTorque(_spin_up), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(ds.omega.values[:, 2], 0.3 + c * t / I_PAPER[2], rtol=1e-12)
    angle = 0.3 * t + 0.5 * c * t**2 / I_PAPER[2]
    exact = qt.from_axis_angle([0, 0, 1], angle)
    assert np.max(qt.angle_between(ds.q.values, exact)) < 1e-11
    assert "energy_note" in ds.attrs


def test_failure_midway_keeps_samples(paper_state):
    q0, Q0 = paper_state

    def tau(q, t):
        # a torque model that breaks down after t = 5 (NaN), as a bad user model would
        return (0.0, 0.0, np.sqrt(5.0 - t))

    t = np.linspace(0.0, 10.0, 41)
    with pytest.raises(PropagationError, match=r"non-finite|step size") as info:
        propagate(I_PAPER, q0, Q0, t, potential=CustomTorque(tau))
    part = info.value.partial
    assert part is not None and 0 < part.sizes["time"] < 41
    assert float(part.time.values[-1]) < 5.0
    assert np.all(np.isfinite(part.q.values))
    assert info.value.time <= 5.0


@pytest.mark.filterwarnings("ignore:this run needs about:RuntimeWarning")  # on purpose
def test_max_steps_stops_with_partial(paper_state):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 100.0, 11)
    with pytest.raises(PropagationError, match="maximum number of steps") as info:
        propagate(I_PAPER, q0, Q0, t, max_steps=100)
    assert 0 < info.value.partial.sizes["time"] < 11


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"q0": [1, 0, 0, np.nan]}, AttitudeValueError, "q0"),
        ({"q0": [1, 0, 0]}, AttitudeValueError, "q0"),
        ({"Q0": [0, 0, 0, 0, 0]}, AttitudeValueError, "Q0"),
        ({"t": [0, 1, 1, 2]}, AttitudeValueError, "t"),
        ({"t": [[0, 1]]}, AttitudeValueError, "t"),
        ({"method": "rk99"}, AttitudeValueError, "method"),
        ({"method": "scipy:Euler"}, AttitudeValueError, "method"),
        ({"potential": "gravity"}, AttitudeTypeError, "potential"),
        ({"body": [1.0, 1.0, 3.0]}, AttitudeValueError, "triangle"),
        ({"rtol": -1.0}, AttitudeValueError, "rtol"),
        ({"q0": [2.0, 0, 0, 0]}, AttitudeValueError, "q0"),
        ({"Q0": [0.3, 0.0, 0.0, 0.0]}, AttitudeValueError, "Q0"),
    ],
)
def test_bad_input(kwargs, exc, match):
    args = {"body": I_PAPER, "q0": [1, 0, 0, 0], "Q0": [0, 0.2, 0, 0], "t": [0.0, 1.0]}
    args.update(kwargs)
    with pytest.raises(exc, match=match):
        propagate(args.pop("body"), args.pop("q0"), args.pop("Q0"), args.pop("t"), **args)


def test_projection_warns_and_is_recorded():
    with pytest.warns(UserWarning, match="projected"):
        ds = propagate(I_PAPER, q0_PRINTED, Q0_PRINTED, [0.0, 1.0])
    assert 1e-8 < ds.attrs["initial_projection"] < 1e-6


def test_kernels_run_with_jit_disabled(paper_state):
    """The compiled kernels are valid Python: same numbers with ATTITUDE_DISABLE_JIT=1."""
    q0, Q0 = paper_state
    code = (
        "import numpy as np, sys\n"
        "from attitude.propagate import propagate\n"
        "from attitude.potentials import HeavyTop\n"
        f"q0 = np.array({q0.tolist()}); Q0 = np.array({Q0.tolist()})\n"
        "ds = propagate([1.25, 1.0, 0.75], q0, Q0, np.linspace(0, 2, 5),"
        " potential=HeavyTop(0.5, [1, 0, 0]))\n"
        "np.save(sys.argv[1], ds.q.values)\n"
    )
    out = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"nojit_{os.getpid()}.npy")
    env = {**os.environ, "ATTITUDE_DISABLE_JIT": "1"}
    subprocess.run([sys.executable, "-c", code, out], check=True, env=env, timeout=300)
    nojit = np.load(out)
    os.remove(out)
    ds = propagate(I_PAPER, q0, Q0, np.linspace(0, 2, 5), potential=HeavyTop(0.5, [1, 0, 0]))
    np.testing.assert_allclose(nojit, ds.q.values, atol=1e-14)


def test_exact_method_matches_dop853(paper_state):
    q0, Q0 = paper_state
    t = np.linspace(0.0, 100.0, 21)
    a = propagate(I_PAPER, q0, Q0, t, method="exact")
    b = propagate(I_PAPER, q0, Q0, t, rtol=1e-13, atol=1e-15)
    assert np.max(qt.angle_between(a.q.values, b.q.values)) < 1e-10
    np.testing.assert_allclose(a.G.values, np.broadcast_to(a.G.values[0], (21, 3)), atol=1e-14)
    with pytest.raises(AttitudeValueError, match="exact"):
        propagate(I_PAPER, q0, Q0, t, method="exact", potential=HeavyTop(0.5, [1, 0, 0]))


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"method": "taylor", "rtol": 1e-12},
        {"method": "splitting", "dt": 0.05},
        {"formulation": "euler_equations"},
        {"method": "scipy:DOP853", "rtol": 1e-9},
    ],
)
def test_arrays_output_is_the_dataset_bit_for_bit(kw):
    # output="arrays" (issue 17: a short call without the Dataset) returns the same states
    body = attitude.RigidBody([1.25, 1.0, 0.75])
    Q0 = attitude.canonical.momenta_from_angular_velocity([1.0, 0, 0, 0], [0.3, 2.0, 0.1], body)
    t = np.linspace(0.0, 20.0, 41)
    pot = attitude.HeavyTop(0.5, [0.0, 0.0, 1.0])
    ds = attitude.propagate(body, [1.0, 0, 0, 0], Q0, t, potential=pot, **kw)
    tr = attitude.propagate(body, [1.0, 0, 0, 0], Q0, t, potential=pot, output="arrays", **kw)
    assert isinstance(tr, attitude.Trajectory)
    assert np.array_equal(tr.t, ds.time.values)
    assert np.array_equal(tr.q, ds.q.values) and np.array_equal(tr.Q, ds.Q.values)
    assert tr.stats["method"] == ds.attrs["method"]
    assert tr.stats.get("n_steps") == ds.attrs.get("n_steps")


@pytest.mark.filterwarnings("ignore:this run needs about:RuntimeWarning")  # on purpose
def test_arrays_output_errors_and_partial():
    body = [1.25, 1.0, 0.75]
    Q0 = [0.0, 0.6, 0.4, 0.2]
    t = np.linspace(0.0, 1000.0, 11)  # ~1000 steps
    with pytest.raises(AttitudeValueError, match="output"):
        attitude.propagate(body, [1.0, 0, 0, 0], Q0, t, output="array")
    with pytest.raises(AttitudeValueError, match="output"):
        attitude.propagate(body, [1.0, 0, 0, 0], Q0, t, output=["arrays"])
    with pytest.raises(AttitudeValueError, match="events"):
        attitude.propagate(
            body, [1.0, 0, 0, 0], Q0, t, output="arrays",
            events=[attitude.events.RateExceeds(0.1)],
        )  # fmt: skip
    with pytest.raises(PropagationError) as exc:
        attitude.propagate(body, [1.0, 0, 0, 0], Q0, t, output="arrays", max_steps=30)
    part = exc.value.partial
    assert isinstance(part, attitude.Trajectory)
    full = attitude.propagate(body, [1.0, 0, 0, 0], Q0, t)
    k = part.q.shape[0]
    assert 0 < k < t.size and np.array_equal(part.q, full.q.values[:k])

"""attitude.scenario: the shipped TOML files, the initial-state forms, units and validation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude import potentials as P
from attitude import scenario
from attitude.scenario import ScenarioError

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.toml"))
Q_PRINTED = [0.5, -math.sqrt(0.5), 0.0, 0.5]  # correctly rounded -1/sqrt(2)
P_PRINTED = [0.3, -0.848528, 0.141421, -1.5]


def hamilton(a, b):
    a0, av, b0, bv = a[0], np.asarray(a[1:]), b[0], np.asarray(b[1:])
    return np.concatenate([[a0 * b0 - av @ bv], a0 * bv + b0 * av + np.cross(av, bv)])


def test_all_shipped_scenarios_load():
    names = {p.stem for p in SCENARIOS}
    assert {"paper_torque_free", "paper_heavy_top", "paper_keplerian"} <= names
    assert len(names) >= 5
    for p in SCENARIOS:
        sc = scenario.load(p)
        assert sc.name == p.stem and sc.title
        assert sc.output == Path(f"{p.stem}.nc")
        assert len(sc.t) >= 100


def test_paper_cases_are_the_printed_ones():
    tf = scenario.load(ROOT / "scenarios/paper_torque_free.toml")
    ht = scenario.load(ROOT / "scenarios/paper_heavy_top.toml")
    kp = scenario.load(ROOT / "scenarios/paper_keplerian.toml")
    for sc in (tf, ht, kp):
        np.testing.assert_array_equal(sc.q0, Q_PRINTED)
    for sc in (tf, ht):  # dimensionless: the printed numbers, bit for bit
        np.testing.assert_array_equal(sc.Q0, P_PRINTED)
    # Sect. 6.2 is printed in kg km² and kg km² s⁻¹; bodies with units are held in SI
    np.testing.assert_allclose(kp.Q0, np.multiply(P_PRINTED, 1e6), rtol=1e-15)
    np.testing.assert_array_equal(tf.body.inertia, [1.25, 1.0, 0.75])
    assert tf.body.is_dimensionless and isinstance(tf.potential, P.TorqueFree)
    assert isinstance(ht.potential, P.HeavyTop)
    assert ht.potential.weight == 0.5
    np.testing.assert_array_equal(ht.potential.center_of_mass, [1, 0, 0])
    np.testing.assert_allclose(kp.body.inertia, [4e8, 5e8, 6e8], rtol=1e-15)  # kg m²
    assert kp.body.units == "kg m^2"
    orb = kp.potential.orbit
    assert orb.a == 7000.0 and orb.e == 0.2
    assert orb.inc == pytest.approx(math.pi / 6, rel=1e-15)
    assert orb.raan == pytest.approx(math.pi / 4, rel=1e-15)
    assert orb.argp == pytest.approx(math.pi / 12, rel=1e-15)
    assert float(orb.true_anomaly(0.0)) == pytest.approx(0.0, abs=1e-15)


def test_paper_euler_form_is_not_the_printed_state():
    # Eq. 12 at (π/4, 3π/2, π/4) gives −q_printed, eq. 14 gives Q_printed: a different state.
    sc = scenario.loads(
        """
        [body]
        inertia = [1.25, 1.0, 0.75]
        [initial_state]
        form = "euler_canonical"
        angles = [45.0, 270.0, 45.0]
        angles_unit = "deg"
        momenta = [0.5, 0.6, 0.4]
        [time]
        stop = 1.0
        count = 11
        """
    )
    np.testing.assert_allclose(sc.q0, -np.array(Q_PRINTED), atol=1e-15)
    np.testing.assert_allclose(sc.Q0, P_PRINTED, atol=1e-6)
    # body angular momentum g = ½ vec(q̃∘Q) flips sign between the two
    conj = np.array([1, -1, -1, -1])
    g_euler = 0.5 * hamilton(sc.q0 * conj, sc.Q0)[1:]
    g_print = 0.5 * hamilton(np.array(Q_PRINTED) * conj, P_PRINTED)[1:]
    np.testing.assert_allclose(g_euler, -g_print, atol=1e-6)


BODY_UNITS = """
[body]
inertia = [1500.0, 28000.0, 28400.0]
inertia_unit = "kg m2"
[time]
stop = 10.0
step = 1.0
unit = "s"
"""


def test_body_rates_and_units():
    a = scenario.loads(
        BODY_UNITS
        + """
        [initial_state]
        form = "body_rates"
        q = [0.5, 0.5, 0.5, 0.5]
        omega = [0.5, 2.0, 1.0]
        omega_unit = "deg/s"
        """
    )
    np.testing.assert_allclose(a.body.inertia, [1500.0, 28000.0, 28400.0])  # SI: kg m²
    w = np.radians([0.5, 2.0, 1.0])
    g = a.body.inertia * w
    np.testing.assert_allclose(a.Q0, 2 * hamilton([0.5, 0.5, 0.5, 0.5], [0.0, *g]), rtol=1e-15)
    b = scenario.loads(
        BODY_UNITS.replace('"kg m2"', '"kg km2"').replace(
            "[1500.0, 28000.0, 28400.0]", "[1.5e-3, 2.8e-2, 2.84e-2]"
        )
        + """
        [initial_state]
        form = "body_rates"
        q = [0.5, 0.5, 0.5, 0.5]
        omega = [0.5, 2.0, 1.0]
        omega_unit = "deg / s"
        """
    )
    np.testing.assert_allclose(b.Q0, a.Q0, rtol=1e-14)
    assert b.t[-1] == 10.0 and len(b.t) == 11


@pytest.mark.parametrize("seq,scipy_seq", [("321", "ZYX"), ("313", "ZXZ"), ("231", "YZX")])
def test_euler_body_rates_any_sequence(seq, scipy_seq):
    sc = scenario.loads(
        BODY_UNITS
        + f"""
        [initial_state]
        form = "euler_body_rates"
        seq = "{seq}"
        angles = [30.0, -20.0, 45.0]
        angles_unit = "deg"
        omega = [0.01, 0.0, 0.0]
        omega_unit = "rad/s"
        """
    )
    ref = Rotation.from_euler(scipy_seq, [30.0, -20.0, 45.0], degrees=True).as_quat()
    ref = np.roll(ref, 1)
    assert min(np.max(abs(sc.q0 - ref)), np.max(abs(sc.q0 + ref))) < 1e-15


def test_time_units_minutes():
    sc = scenario.loads(
        BODY_UNITS.replace('unit = "s"', 'unit = "min"')
        + """
        [initial_state]
        form = "body_rates"
        q = [1.0, 0.0, 0.0, 0.0]
        omega = [0.0, 0.0, 0.0]
        omega_unit = "rad/s"
        """
    )
    assert sc.t[-1] == 600.0 and sc.time_scale == 60.0


GOOD = """
[body]
inertia = [1.25, 1.0, 0.75]
[initial_state]
form = "canonical"
q = [1.0, 0.0, 0.0, 0.0]
Q = [0.0, 0.2, 0.1, 0.3]
[time]
stop = 1.0
step = 0.1
"""


@pytest.mark.parametrize(
    "edit,key,what",
    [
        (("inertia =", "inertai ="), "body.inertai", "did you mean 'inertia'"),
        (("[time]", "[time]\nfoo = 1"), "time.foo", "unknown key"),
        (("[time]", "[timing]"), "timing", "unknown table"),
        (("stop = 1.0", 'stop = "1.0"'), "time.stop", "expected a number"),
        (("Q = [0.0, 0.2, 0.1, 0.3]", "Q = [0.0, 0.2]"), "initial_state.Q", "4 finite numbers"),
        (('form = "canonical"', 'form = "quaternions"'), "initial_state.form", "one of"),
        (("q = [1.0, 0.0, 0.0, 0.0]", "q = [1.0, 0.1, 0.0, 0.0]"), "initial_state.q", "unit q"),
        (("step = 0.1", "step = 0.3"), "time.step", "whole steps"),
        (("[time]", '[time]\nunit = "s"'), "time.unit", "dimensionless"),
        (
            ("Q = [0.0, 0.2, 0.1, 0.3]", 'Q = [0.0, 0.2, 0.1, 0.3]\nQ_unit = "kg m2 s-1"'),
            "initial_state.Q_unit",
            "dimensionless",
        ),
        (("[body]", '[integrator]\nmethod = "rk99"\n[body]'), "integrator.method", "unknown"),
        (("[body]", "[integrator]\nrtol = -1.0\n[body]"), "integrator.rtol", "positive"),
        (("[body]", '[potential]\nkind = "heavy_top"\n[body]'), "potential.weight", "missing"),
        (("[body]", "[integrator]\ndt = -0.1\n[body]"), "integrator.dt", "positive"),
        (("[body]", "[integrator]\norder = 3\n[body]"), "integrator.order", "2, 4 or 6"),
        (
            ("[body]", '[integrator]\nformulation = "lagrange"\n[body]'),
            "integrator.formulation",
            "unknown formulation",
        ),
        (
            ("[body]", '[integrator]\nmethod = "splitting"\nformulation = "schwab"\n[body]'),
            "integrator.formulation",
            "canonical",
        ),
    ],
)
def test_errors_name_the_key(edit, key, what):
    text = GOOD.replace(*edit)
    assert text != GOOD
    with pytest.raises(ScenarioError) as err:
        scenario.loads(text)
    msg = str(err.value)
    assert msg.startswith(key + ":"), msg
    assert what in msg, msg


ORBIT_NO_A_UNIT = """[orbit]
a = 7000.0
e = 0.1
inc = 10.0
inc_unit = "deg"
raan = 0.0
raan_unit = "deg"
argp = 0.0
argp_unit = "deg"
"""

DIM = """
[body]
inertia = [400.0, 500.0, 600.0]
inertia_unit = "kg km2"
[initial_state]
form = "body_rates"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.0, 0.01, 0.0]
omega_unit = "rad/s"
[time]
stop = 10.0
step = 1.0
unit = "s"
"""


@pytest.mark.parametrize(
    "edit,key,what",
    [
        (('omega_unit = "rad/s"\n', ""), "initial_state.omega", "needs a unit"),
        (('omega_unit = "rad/s"', 'omega_unit = "km"'), "initial_state.omega_unit", "not a rate"),
        (
            ('omega_unit = "rad/s"', 'omega_unit = "furlongs"'),
            "initial_state.omega_unit",
            "not a unit astropy",
        ),
        (('unit = "s"\n', ""), "time.unit", "missing"),
        (('inertia_unit = "kg km2"', 'inertia_unit = "kg m"'), "body.inertia_unit", "inertia"),
        (("[time]", '[potential]\nkind = "gravity_gradient"\n[time]'), "orbit", "needs [orbit]"),
        (
            ("[time]", ORBIT_NO_A_UNIT + "[time]"),
            "orbit.a",
            "needs a unit",
        ),
    ],
)
def test_unit_errors_name_the_key(edit, key, what):
    text = DIM.replace(*edit)
    assert text != DIM
    with pytest.raises(ScenarioError) as err:
        scenario.loads(text)
    msg = str(err.value)
    assert msg.startswith(key), msg
    assert what in msg, msg


def test_invalid_toml_and_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="invalid TOML"):
        scenario.loads("[body\ninertia = 1")
    with pytest.raises(ScenarioError, match="no such scenario file"):
        scenario.load(tmp_path / "nope.toml")


def test_run_attrs():
    sc = scenario.loads(
        GOOD.replace("[body]", '[scenario]\nepoch = "2024-01-01T00:00:00Z"\n[body]')
    )
    ds = sc.run()
    assert ds.attrs["epoch"] == "2024-01-01T00:00:00.000000Z"
    assert ds.attrs["run_status"] == "complete"
    assert ds.attrs["scenario_toml"] == sc.source
    assert "scenario" in ds.attrs["history"]
    assert ds.sizes["time"] == 11


def test_fixed_step_method_and_formulation_from_the_integrator_table():
    """[integrator] dt/order/formulation reach propagate: same trajectory as the library call."""
    from attitude.propagate import propagate

    sc = scenario.loads(
        GOOD.replace("[body]", '[integrator]\nmethod = "splitting"\ndt = 0.05\norder = 4\n[body]')
    )
    ds = sc.run()
    assert ds.attrs["method"] == "splitting" and ds.attrs["dt"] == 0.05 and ds.attrs["order"] == 4
    ref = propagate(sc.body, sc.q0, sc.Q0, sc.t, method="splitting", dt=0.05, order=4)
    np.testing.assert_array_equal(ds.q.values, ref.q.values)
    sc2 = scenario.loads(
        GOOD.replace("[body]", '[integrator]\nformulation = "euler_equations"\n[body]')
    )
    ds2 = sc2.run(rtol=1e-12, atol=1e-14)
    assert ds2.attrs["formulation"] == "euler_equations"
    ref2 = propagate(sc2.body, sc2.q0, sc2.Q0, sc2.t, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(ds2.q.values, ref2.q.values, atol=1e-10)


def test_cubesat_scenario_mass_model_facets_and_inertia_agree():
    """scenarios/cubesat_environment.toml: the mass model its comment gives (a uniform 3.2 kg
    box, a 0.6 kg battery 10 cm up the long axis, two 0.1 kg panels on the +b1 face) puts the
    centre of mass where the facets put it (the box's centre at (-0.0025, 0, -0.015) m from it),
    and its inertia about that centre (parallel-axis terms included) is the scenario's."""
    from attitude.scenario import tomllib

    text = (ROOT / "scenarios/cubesat_environment.toml").read_text()
    toml = tomllib.loads(text)
    centres = np.array([f["center"] for f in toml["spacecraft"]["facets"][:6]])
    box_centre = centres.mean(axis=0)  # opposite faces of the box
    np.testing.assert_allclose(box_centre, [-0.0025, 0.0, -0.015], atol=1e-15)

    def box(m, a, b, c):
        return m / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])

    parts = [  # (mass, position from the box's centre, own inertia)
        (3.2, np.zeros(3), box(3.2, 0.1, 0.1, 0.34)),
        (0.6, np.array([0.0, 0.0, 0.10]), np.zeros((3, 3))),
        (0.1, np.array([0.05, 0.10, 0.0]), box(0.1, 0.0, 0.1, 0.3)),
        (0.1, np.array([0.05, -0.10, 0.0]), box(0.1, 0.0, 0.1, 0.3)),
    ]
    mass = sum(m for m, _, _ in parts)
    com = sum(m * r for m, r, _ in parts) / mass
    np.testing.assert_allclose(com, -box_centre, atol=1e-15)  # 2.5 mm to +b1, 15 mm to +b3
    tensor = sum(I + m * ((r - com) @ (r - com) * np.eye(3) - np.outer(r - com, r - com))
                 for m, r, I in parts)  # fmt: skip
    np.testing.assert_allclose(np.diag(tensor), toml["body"]["inertia"], rtol=2e-4)
    assert abs(tensor[0, 2] - 1.5e-4) < 1e-8 and tensor[0, 1] == tensor[1, 2] == 0.0
    tilt = 0.5 * np.degrees(np.arctan2(2 * tensor[0, 2], tensor[0, 0] - tensor[2, 2]))
    assert f"{tilt:.2f} deg about b2" in text.replace("\n# ", " ")


NUMERICAL = """
[scenario]
epoch = "2026-03-20T00:00:00"
[body]
inertia = [1.25, 1.0, 0.75]
inertia_unit = "kg m2"
[initial_state]
form = "canonical"
q = [1.0, 0.0, 0.0, 0.0]
Q = [0.0, 0.2, 0.1, 0.3]
Q_unit = "kg m2 s-1"
[orbit]
type = "numerical"
r0 = [7000.0, 0.0, 0.0]
r0_unit = "km"
v0 = [0.0, 7.5, 0.1]
v0_unit = "km/s"
degree = 4
earth_rotation = "uniform"
[potential]
kind = "gravity_gradient"
[time]
stop = 60.0
step = 10.0
unit = "s"
"""


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_numerical_orbit_method(method):
    import orbit

    text = NUMERICAL.replace("degree = 4", f'degree = 4\nmethod = "{method}"')
    orb = scenario.loads(text).potential.orbit
    same = orbit.NumericalOrbit([7000.0, 0.0, 0.0], [0.0, 7.5, 0.1], "2026-03-20T00:00:00",
                                gravity=orbit.SphericalHarmonics(4), earth_rotation="uniform",
                                method=method)  # fmt: skip
    assert orb.method == method
    t = np.linspace(0.0, 3600.0, 7)
    np.testing.assert_array_equal(orb.position(t), same.position(t))


def test_numerical_orbit_bad_method_names_the_key():
    text = NUMERICAL.replace('earth_rotation = "uniform"', 'method = "rk4"')
    with pytest.raises(ScenarioError, match=r"^orbit\.method: .*'taylor'"):
        scenario.loads(text)
    bodies = NUMERICAL.replace("degree = 4", 'degree = 4\nthird_bodies = ["pluto"]')
    with pytest.raises(ScenarioError, match=r"^orbit\.third_bodies: 'sun' or 'moon'"):
        scenario.loads(bodies)

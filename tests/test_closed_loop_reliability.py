"""Regression tests of the defects the fuzz suites found in the closed-loop API (issues 24-26:
actuators, command schedules, flight software, control laws, sensors, the MEKF, and their
scenario tables): each was a raw exception, a NaN result, a run that could not finish, or
nonsense accepted in silence, and is now a package error naming the parameter, raised before
any work (tests/test_fuzz.py, docs/reliability.md)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import astropy.units as u
import numba
import numpy as np
import pytest

import attitude
from attitude import canonical as C
from attitude import frames, scenario
from attitude import quaternion as qt
from attitude.actuators import CommandSchedule, ReactionWheel, pyramid
from attitude.control import BDot, MRPFeedback, QuaternionFeedback, RateDamping, WheelAllocation
from attitude.errors import AttitudeError, AttitudeFileError, AttitudeTypeError, AttitudeValueError
from attitude.estimation import MEKF
from attitude.sensors import Gyro, Magnetometer, StarTracker
from attitude.software import FlightSoftware

BODY = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
Q_ID = [1.0, 0.0, 0.0, 0.0]

ROOT = Path(__file__).resolve().parents[1]


def _craft():
    return attitude.Spacecraft(BODY, pyramid(0.05, max_torque=0.1))


def _run(craft, fsw, t=(0.0, 1.0)):
    Q0 = C.momenta_from_angular_velocity(Q_ID, [0.01, 0.0, 0.0], craft)
    return attitude.propagate(craft, Q_ID, Q0, list(t), software=fsw)


# --- actuators and schedules -------------------------------------------------------------------


def test_pyramid_speeds_that_are_not_a_sequence_are_a_type_error():
    with pytest.raises(AttitudeTypeError, match="speeds"):
        pyramid(0.05, speeds=object())  # was: TypeError: object has no len()
    with pytest.raises(AttitudeTypeError, match="speeds"):
        pyramid(0.05, speeds="1234")
    with pytest.raises(AttitudeValueError, match="speeds"):
        pyramid(0.05, speeds=[1.0, 2.0])
    w = pyramid(0.05, speeds=[1.0, 2.0, 3.0, 4.0] * u.rad / u.s)
    assert [x.speed for x in w] == [1.0, 2.0, 3.0, 4.0]


def test_wheel_speeds_in_units_that_are_not_rates_are_a_type_error():
    # was: astropy's UnitConversionError
    with pytest.raises(AttitudeTypeError, match="speeds"):
        _craft().with_wheel_speeds(np.ones(4) * u.m)
    with pytest.raises(AttitudeTypeError, match="speed"):
        ReactionWheel([0, 0, 1.0], 0.05, speed=1.0 * u.dimensionless_unscaled)
    with pytest.raises(AttitudeTypeError, match="null_speeds"):
        WheelAllocation(0.1, null_speeds=np.ones(4) * u.s)
    rpm = _craft().with_wheel_speeds([60.0] * 4 * u.cycle / u.min).wheel_speeds
    np.testing.assert_allclose(rpm, 2 * math.pi, rtol=1e-15)


def test_command_csv_with_a_nul_byte_duplicate_or_huge_column_numbers(tmp_path):
    with pytest.raises(AttitudeFileError, match="NUL"):
        CommandSchedule.from_csv("a\x00b.csv")  # was: ValueError: embedded null byte
    p = tmp_path / "c.csv"
    p.write_text("time,dipole_1,dipole_1\n0,0.1,0.2\n")
    with pytest.raises(AttitudeValueError, match="twice"):  # was: the first column dropped
        CommandSchedule.from_csv(p)
    p.write_text("time,dipole_99999999999\n0,0.1\n")
    t0 = time.perf_counter()
    with pytest.raises(AttitudeValueError, match="numbered 1 to 99999999999"):
        CommandSchedule.from_csv(p)  # was: a list of 1e11 numbers built to compare with
    assert time.perf_counter() - t0 < 5.0


# --- flight software and laws ------------------------------------------------------------------


def test_a_step_function_returning_values_that_are_not_numbers_is_a_clean_error():
    def step(value):
        return lambda t, m: {"wheel_torque": value}

    for bad in (lambda x: x, ["1", "0", "0", "0"], None, [1j, 0, 0, 0]):
        with pytest.raises(AttitudeError, match="wheel_torque"):  # was: numpy's TypeError
            _run(_craft(), FlightSoftware(0.1, control=step(bad)))


def test_a_period_with_more_ticks_than_max_steps_is_refused_before_any_work():
    fsw = FlightSoftware(1e-300, frames.inertial(), MRPFeedback(1.0, 5.0))
    t0 = time.perf_counter()
    with pytest.raises(AttitudeValueError, match=r"period: .*ticks, more than max_steps"):
        _run(_craft(), fsw)  # was: a run of 1e300 ticks, interrupted only by its time limit
    assert time.perf_counter() - t0 < 5.0
    Q0 = C.momenta_from_angular_velocity(Q_ID, [0.01, 0.0, 0.0], _craft())
    with pytest.raises(AttitudeValueError, match="max_steps = 5"):
        attitude.propagate(_craft(), Q_ID, Q0, [0.0, 1.0], max_steps=5,
                           software=FlightSoftware(0.1, control=RateDamping(1.0)))  # fmt: skip


def test_a_period_longer_than_the_run_or_a_phase_past_its_end_is_refused_before_any_work():
    """issue 39: FlightSoftware(5.0) on a 2 s run ticked once, at t0, silently; a phase of
    1e6 s never ticked. Both are refused, naming the parameter, the span and the fix, in
    single runs and ensembles (before the members run)."""
    from attitude.ensemble import propagate_ensemble

    law = RateDamping(1.0)
    t = (0.0, 1.0, 2.0)
    cases = [
        (FlightSoftware(5.0, control=law), r"period: the software's period 5 s is not shorter "
         r"than the run's span 2 s \(t = 0 … 2 s\).*below 2 s"),
        (FlightSoftware(2.0, control=law), r"period: .* 2 s is not shorter than"),
        (FlightSoftware(0.1, control=law, phase=1e6), r"phase: the first tick t0 \+ phase = "
         r"1e\+06 s is at or after the end of the run's span 2 s.*below 2 s"),
        (FlightSoftware(0.1, control=law, phase=2.0), r"phase: .* = 2 s is at or after"),
    ]  # fmt: skip
    craft = _craft()
    Q0 = C.momenta_from_angular_velocity(Q_ID, [0.01, 0.0, 0.0], craft)
    for fsw, match in cases:
        with pytest.raises(AttitudeValueError, match=match):
            _run(craft, fsw, t)
        with pytest.raises(AttitudeValueError, match=match):
            propagate_ensemble([craft] * 2, [Q_ID] * 2, [Q0] * 2, list(t), software=fsw)
    # just inside the limits the software runs (ticks t < 2 s): a period a little shorter
    # than the span, a phase inside it, and a single time (only the tick at t0)
    for fsw, t_, ticks in (
        (FlightSoftware(1.9, control=law), t, [0.0, 1.9]),
        (FlightSoftware(1.0, control=law, phase=1.5), t, [1.5]),
        (FlightSoftware(5.0, control=law), (0.0,), [0.0]),
    ):
        np.testing.assert_array_equal(_run(craft, fsw, t_).tick.values, ticks)


def test_gain_matrices_near_the_overflow_threshold_are_checked_without_overflow():
    # was: numpy's LinAlgError "Eigenvalues did not converge" (m + m.T overflowed)
    assert QuaternionFeedback(1.0, 1e308).C[0, 0] == 1e308
    with pytest.raises(AttitudeValueError, match="positive definite"):
        RateDamping(np.array([[1e308, 1.7e308, 0.0], [1.7e308, 1e308, 0.0], [0, 0, 1e308]]))


def test_bdot_optimal_gain_refuses_inertias_that_are_not_moments():
    from orbit import SecularJ2Orbit

    leo = SecularJ2Orbit(7000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch="2024-03-01T00:00:00")
    for bad in (-math.inf, [1.0, -2.0, 3.0], [1.0, 2.0]):
        with pytest.raises(AttitudeError, match="inertia"):  # was: a NaN or inf gain
            BDot.optimal_gain(leo, bad)
    k = BDot.optimal_gain(leo, [12.0, 10.0, 8.0])
    assert k == BDot.optimal_gain(leo, BODY) == BDot.optimal_gain(leo, _craft())
    # k = 2 n (1 + sin ξ_m) I_min (Avanzini & Giulietti), n from vis-viva at a near-circle
    n = math.sqrt(leo.mu / 7000.0**3)
    assert 2 * n * 8.0 < k < 2 * n * 2 * 8.0 * 1.01


# --- sensors and the estimator ------------------------------------------------------------------


def test_star_tracker_angles_beyond_180_degrees_are_refused():
    # was: earth_exclusion = 1.2e21 rad accepted: the tracker always excluded, the MEKF never
    # started and its estimate NaN throughout
    for key in ("sun_exclusion", "earth_exclusion"):
        with pytest.raises(AttitudeValueError, match=key):
            StarTracker(1e-5, **{key: 4.0})
        with pytest.raises(AttitudeValueError, match=key):
            StarTracker(1e-5, **{key: 180 * u.deg})
        StarTracker(1e-5, **{key: 179 * u.deg})
    with pytest.raises(AttitudeValueError, match="noise"):
        StarTracker([1e-5, 3.2])


def test_noise_whose_square_overflows_is_refused():
    # was: StarTracker(1e308) -> OverflowError squaring it for the MEKF's covariance
    with pytest.raises(AttitudeValueError, match="noise"):
        Magnetometer(1e200)
    with pytest.raises(AttitudeValueError, match="arw"):
        Gyro(1e300)
    with pytest.raises(AttitudeValueError, match="rrw"):
        Gyro(1e-6, rrw=1e155)


def test_a_gyro_bias_at_its_saturation_is_refused():
    # was: accepted; the gyro read its saturation only and the MEKF's NEES became NaN
    with pytest.raises(AttitudeValueError, match="bias"):
        Gyro(1e-6, bias=[0.0, 2.0, 0.0], saturation=1.0)
    assert Gyro(1e-6, bias=0.5, saturation=1.0).bias.tolist() == [0.5, 0.5, 0.5]


def test_mekf_sigmas_whose_square_is_not_a_variance_are_refused():
    # was: attitude_sigma = 5e-324 accepted: a singular covariance, NEES NaN
    for key, v in (("attitude_sigma", 5e-324), ("attitude_sigma", 1e-160),
                   ("bias_sigma", 1e160)):  # fmt: skip
        with pytest.raises(AttitudeValueError, match=key):
            MEKF(**{key: v})
    MEKF(attitude_sigma=1e-150, bias_sigma=1e150)


def test_a_star_tracker_rate_too_slow_for_any_tick_is_refused():
    # was: OverflowError: cannot convert float infinity to integer
    fsw = FlightSoftware(0.1, frames.inertial(), MRPFeedback(1.0, 5.0),
                         sensors=[Gyro(1e-6, seed=1), StarTracker(1e-5, rate=1e-308, seed=2)],
                         estimator=MEKF())  # fmt: skip
    with pytest.raises(AttitudeValueError, match="star tracker's rate"):
        _run(_craft(), fsw)


# --- scenario tables ----------------------------------------------------------------------------

_RW = """
[body]
inertia = [900.0, 800.0, 600.0]
inertia_unit = "kg m2"

[[spacecraft.wheels]]
axis = [1.0, 0.0, 0.0]
inertia = 0.08
inertia_unit = "kg m2"

[[spacecraft.wheels]]
axis = [0.0, 1.0, 0.0]
inertia = 0.08
inertia_unit = "kg m2"

[[spacecraft.wheels]]
axis = [0.0, 0.0, 1.0]
inertia = 0.08
inertia_unit = "kg m2"

[initial_state]
form = "body_rates"
q = [1.0, 0.0, 0.0, 0.0]
omega = [0.001, -0.01, 0.03]
omega_unit = "rad/s"

[time]
start = 0.0
stop = 2.0
count = 3
unit = "s"
"""


@pytest.mark.parametrize(
    ("software", "key"),
    [
        # keys the chosen law does not read were ignored in silence
        ('control = "rate_damping"\nC = 30.0\nK = 3.5', "software.K"),
        ('control = "mrp_feedback"\nK = 3.5\nP = 30.0\ngain = 1.0', "software.gain"),
        ('control = "none"\nnormalized = true', "software.normalized"),
        ('control = "rate_damping"\nC = 30.0\nthreshold = 1.0', "software.threshold"),
        ('control = "rate_damping"\nC = 30.0\nguidance_q = [1.0, 0.0, 0.0, 0.0]',
         "software.guidance_q"),
        ('guidance = "inertial"\nslew_accel = 0.1', "software.slew_accel"),
        # units on keys that are not quantities, units without their key
        ('control = "rate_damping"\nC = 30.0\ndelay = 1\ndelay_unit = "s"', "software.delay_unit"),
        ('control = "rate_damping"\nC = 30.0\nK_unit = "N m"', "software.K_unit"),
    ],
)  # fmt: skip
def test_scenario_software_keys_that_would_be_ignored_are_errors(software, key):
    text = _RW + "\n[software]\nperiod = 0.5\n" + software + "\n"
    with pytest.raises(scenario.ScenarioError, match=key.replace(".", r"\.")):
        scenario.loads(text)


_AFTER = 'condition = "after"\nthreshold = 60.0\nthreshold_unit = "s"\n'


@pytest.mark.parametrize(
    ("mode", "key", "example"),
    [
        ('condition = "rate_below"\nthreshold = 0.5', "threshold", "deg/s"),
        ('condition = "pointing_within"\nthreshold = 5.0', "threshold", "deg"),
        ('condition = "after"\nthreshold = 60.0', "threshold", "s"),
        (_AFTER + 'guidance = "inertial"\nslew_rate = 1.0\nslew_accel = 0.1\n'
         'slew_accel_unit = "deg/s2"', "slew_rate", "deg/s"),
        (_AFTER + 'guidance = "inertial"\nslew_rate = 1.0\nslew_rate_unit = "deg/s"\n'
         "slew_accel = 0.1", "slew_accel", "deg/s2"),
    ],
)  # fmt: skip
def test_scenario_mode_angles_and_rates_without_units_are_errors(mode, key, example):
    """A plain `threshold = 0.5` of `rate_below` was 0.5 rad/s (28.6 deg/s): a second mode
    meant for 0.5 deg/s started at the first tick and the first never ran, in silence. Angles
    and rates need their unit, as everywhere in a scenario; with it, the mode is taken."""
    text = (_RW + '\n[software]\nperiod = 0.5\n\n[[software.modes]]\nname = "damp"\n'
            'control = "rate_damping"\nC = 30.0\nC_unit = "N m s"\n\n[[software.modes]]\n'
            'name = "next"\ncontrol = "rate_damping"\nC = 30.0\n' + mode + "\n")  # fmt: skip
    with pytest.raises(
        scenario.ScenarioError,
        match=rf"software\.modes\[1\]\.{key}: needs a unit: add {key}_unit = '{example}'",
    ):
        scenario.loads(text)
    sc = scenario.loads(text.replace(f"{key} = ", f'{key}_unit = "{example}"\n{key} = ', 1))
    assert sc.software is not None


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (("\nK = 3.5\n", "\nK = -3.5\n"), r"^software\.K: the gain must be a positive"),
        (("\nP = 30.0\n", "\nP = [[1.0, 0.0], [0.0, 1.0]]\n"),
         r"^software\.P: expected a number, 3 diagonal entries or a 3 x 3 matrix, got shape"),
        (("\nP = 30.0\n", "\nP = [[1.0, 0.0], [0.0]]\n"),
         r"^software\.P: expected finite numbers .*rows"),
    ],
)  # fmt: skip
def test_scenario_law_errors_name_the_full_key(edit, message):
    """A law's own error named its parameter alone ('K: ...'), and a 2 x 2 P got 'expected
    finite numbers' without the shape: now the scenario key and what the law expects."""
    text = (ROOT / "scenarios" / "rw_inertial_pointing.toml").read_text()
    assert edit[0] in text
    with pytest.raises(scenario.ScenarioError, match=message):
        scenario.loads(text.replace(edit[0], edit[1], 1))


def test_scenario_orbit_element_errors_name_the_element():
    """'orbit: a: a hyperbolic orbit ...' (a doubled prefix) is now 'orbit.a: ...'."""
    text = (ROOT / "scenarios" / "paper_keplerian.toml").read_text()
    assert "e = 0.2\n" in text
    with pytest.raises(scenario.ScenarioError, match=r"^orbit\.a: a hyperbolic orbit \(e = 1\.5"):
        scenario.loads(text.replace("e = 0.2\n", "e = 1.5\n", 1))


def test_scenario_sensor_keys_without_units_and_bad_normals_are_errors():
    base = _RW + '\n[software]\nperiod = 0.5\ncontrol = "rate_damping"\nC = 30.0\n'
    with pytest.raises(scenario.ScenarioError, match=r"software\.sensors\[0\]\.seed_unit"):
        scenario.loads(base + '[[software.sensors]]\ntype = "gyro"\narw = 1e-6\nseed = 1\n'
                       'seed_unit = "s"\n')  # fmt: skip
    # was: numpy's ValueError for an array of strings
    with pytest.raises(scenario.ScenarioError, match=r"software\.sensors\[0\]\.normals"):
        scenario.loads(base + '[[software.sensors]]\ntype = "sun_sensor"\n'
                       'normals = [["a", "b", "c"]]\n')  # fmt: skip


def test_scenario_center_of_mass_without_thrusters_is_an_error():
    # was: accepted with wheels only, and unused (it is the thrusters' lever arms' origin)
    text = _RW.replace(
        "[[spacecraft.wheels]]\naxis = [1.0",
        '[spacecraft]\ncenter_of_mass = [0.0, 0.0, 0.1]\ncenter_of_mass_unit = "m"\n\n'
        "[[spacecraft.wheels]]\naxis = [1.0",
        1,
    )
    with pytest.raises(scenario.ScenarioError, match=r"spacecraft\.center_of_mass"):
        scenario.loads(text)


@pytest.mark.slow  # (compiles the loop for a secular-J2 frame: minutes in a fresh cache)
def test_scenario_guidance_q_turns_an_orbit_frame_instead_of_being_ignored():
    """``guidance_q`` with an orbit frame (here LVLH) was ignored: the reference is now the
    frame turned by q about its own axes, as ``frame.offset(q)`` (for ``inertial``, the
    inertial attitude q itself, as before)."""
    from orbit import SecularJ2Orbit

    q = qt.from_euler([0.3, -0.2, 0.1], "321")
    text = (
        _RW.replace(
            "[initial_state]",
            '[scenario]\nepoch = "2024-03-01T00:00:00"\n\n[orbit]\ntype = "secular_j2"\n'
            'a = 7000.0\na_unit = "km"\ne = 0.001\ninc = 97.0\ninc_unit = "deg"\nraan = 0.0\n'
            'raan_unit = "deg"\nargp = 0.0\nargp_unit = "deg"\n\n[initial_state]',
        )
        + '\n[software]\nperiod = 1.0\nguidance = "lvlh"\nguidance_q = '
        + str(q.tolist())
        + '\ncontrol = "mrp_feedback"\nK = 3.5\nP = 30.0\n'
    )
    ds = scenario.loads(text).run()
    orb = SecularJ2Orbit(7000.0, 0.001, math.radians(97.0), 0.0, 0.0, f0=0.0,
                         epoch="2024-03-01T00:00:00")  # fmt: skip
    want = frames.lvlh(orb).offset(q).quaternion(ds.tick.values)
    got = ds.reference_q.values
    assert np.max(qt.angle_between(got, want)) < 1e-9
    assert np.min(qt.angle_between(got, frames.lvlh(orb).quaternion(ds.tick.values))) > 0.1


def test_scenario_tle_span_far_from_the_epoch_is_refused_without_raw_warnings():
    """A TLE scenario whose times reach past 2200 (or overflow) was turned into dates by astropy
    first: ERFA's "dubious year" and numpy's overflow warnings reached the user before the
    error. The dates are now checked first, by plain arithmetic."""
    import re
    import warnings
    from pathlib import Path

    base = (Path(__file__).parent.parent / "scenarios" / "cubesat_bdot.toml").read_text()
    for stop in ("1e12", "1e308"):
        text = re.sub(r"\[time\][^\[]*", f'[time]\nstart = 0.0\nstop = {stop}\nunit = "s"\n'
                      "count = 10\n\n", base)  # fmt: skip
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(scenario.ScenarioError, match="dates are accepted from 1900"):
                scenario.loads(text)


def test_scenario_times_that_overflow_in_seconds_warn_nothing():
    """time.start = -1e308 h overflowed in numpy's scalar arithmetic: its "overflow encountered
    in scalar multiply" warning reached the user before the error."""
    import warnings

    text = _RW.replace('start = 0.0\nstop = 2.0\ncount = 3\nunit = "s"',
                       'start = -1e308\nstop = 2.0\ncount = 3\nunit = "h"')  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(scenario.ScenarioError, match=r"time\.start: .*overflows in seconds"):
            scenario.loads(text)


# --- inputs that slipped through (issue 39) -----------------------------------------------------


def test_quantities_in_wrong_units_are_refused_not_stripped():
    # was: BDot(1 * u.m).gain == 1.0 and integral_limit=400 * u.deg read as 400 N m s
    with pytest.raises(AttitudeTypeError, match="gain: units m"):
        BDot(1 * u.m)
    with pytest.raises(AttitudeTypeError, match="gain: units N m s"):
        BDot(1 * u.N * u.m * u.s)  # the normalized law's unit, not m = -k dB/dt's
    assert BDot(2 * u.N * u.m * u.s, normalized=True).gain == 2.0
    assert BDot(3e3 * u.A * u.m**2 * u.s / u.mT).gain == pytest.approx(3e6)
    with pytest.raises(AttitudeTypeError, match="integral_limit: units deg"):
        MRPFeedback(1.0, 5.0, Ki=0.01, integral_limit=400 * u.deg)
    with pytest.raises(AttitudeTypeError, match="Ki: units m"):
        MRPFeedback(1.0, 5.0, Ki=0.01 * u.m)
    law = MRPFeedback(1.0, 5.0, Ki=0.6 / u.min, integral_limit=2 * u.N * u.m * u.s)
    assert (law.Ki, law.integral_limit) == (pytest.approx(0.01), 2.0)
    with pytest.raises(AttitudeTypeError, match="P: units m cannot"):
        MRPFeedback(1.0, 5 * u.m)
    assert MRPFeedback(1.0, 5e3 * u.mN * u.m * u.s).P[0, 0] == pytest.approx(5.0)
    assert RateDamping([1.0, 2.0, 3.0] * u.N * u.m * u.s).K[2, 2] == 3.0
    with pytest.raises(AttitudeTypeError, match="tau: units m"):
        Gyro(1e-6).allan_variance(1 * u.m)  # was: np.asarray, the unit dropped
    with pytest.raises(AttitudeTypeError, match="speed: units m"):
        ReactionWheel([0, 0, 1.0], 0.05, coulomb_friction=1e-3).friction(1 * u.m)


def test_a_negative_integral_gain_is_refused_with_the_documented_way_to_omit_it():
    # was: Ki=-1.0 accepted as "no integral term" (Basilisk's convention; ours is Ki=None)
    with pytest.raises(AttitudeValueError, match=r"Ki: .*-1\.0; use Ki=None for no integral"):
        MRPFeedback(1.0, 5.0, Ki=-1.0)
    assert MRPFeedback(1.0, 5.0).Ki == MRPFeedback(1.0, 5.0, Ki=None).Ki  # no integral term


def test_inertias_that_no_rigid_body_has_are_refused_by_the_software_and_bdot():
    from orbit import SecularJ2Orbit

    # was: accepted (1 + 2 < 4 violates the triangle inequality of principal moments)
    with pytest.raises(AttitudeValueError, match="inertia: violates the triangle inequality"):
        FlightSoftware(0.1, control=MRPFeedback(1.0, 5.0), inertia=[1, 2, 4])
    with pytest.raises(AttitudeValueError, match="inertia: violates the triangle inequality"):
        FlightSoftware(0.1, control=MRPFeedback(1.0, 5.0), inertia=np.diag([4.0, 2.0, 1.0]))
    leo = SecularJ2Orbit(7000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch="2024-03-01T00:00:00")
    with pytest.raises(AttitudeValueError, match="inertia: violates the triangle inequality"):
        BDot.optimal_gain(leo, [1, 2, 4])
    FlightSoftware(0.1, control=MRPFeedback(1.0, 5.0), inertia=[1, 2, 3])  # a flat plate


def test_bdot_optimal_gain_on_an_orbit_inside_the_earth_is_an_error():
    import warnings

    from orbit import KeplerOrbit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the orbit package's PerigeeInsideEarthWarning
        low = KeplerOrbit(3000.0, 0.001, 1.7, 0.2, 0.3, f0=0.0, epoch="2024-03-01T00:00:00")
    with pytest.raises(AttitudeValueError, match=r"orbit: its perigee radius .* inside the Earth"):
        BDot.optimal_gain(low, BODY)  # was: a gain, with the orbit's warning only


def test_gyro_misalignment_must_be_a_rotation_and_quantization_plausible():
    # was: the zero matrix, -I and a reflection accepted as the misalignment matrix
    cases = ((np.zeros((3, 3)), "not a rotation matrix"), (-np.eye(3), "det M"),
             (np.diag([1.0, 1.0, -1.0]), "det M"), (2 * np.eye(3), "not a rotation"))  # fmt: skip
    for bad, why in cases:
        with pytest.raises(AttitudeValueError, match=f"misalignment: {why}"):
            Gyro(1e-6, misalignment=bad)
    from scipy.spatial.transform import Rotation

    M = Rotation.from_rotvec([1e-3, -2e-3, 3e-3]).as_matrix()
    np.testing.assert_array_equal(Gyro(1e-6, misalignment=M).misalignment, M)
    # was: quantization=1e12 rad/s accepted (every reading rounded to 0)
    with pytest.raises(AttitudeValueError, match=r"quantization: .*coarser than any rate gyro"):
        Gyro(1e-6, quantization=1e12)
    with pytest.raises(AttitudeValueError, match=r"quantization: .*saturation"):
        Gyro(1e-6, quantization=0.2, saturation=0.1)
    assert Gyro(1e-6, quantization=1e-4, saturation=0.1).quantization == 1e-4


def test_sensor_noise_beyond_what_the_sensor_measures_is_refused():
    # was: Magnetometer(100) (100 T, a scenario's noise = 100 without its nT) accepted
    with pytest.raises(AttitudeValueError, match=r"noise: .*not a magnetometer of the Earth"):
        Magnetometer(100.0)
    assert Magnetometer(100 * u.nT).noise == pytest.approx(1e-7)
    from attitude.sensors import SunSensor

    with pytest.raises(AttitudeValueError, match=r"noise: .*full-Sun current"):
        SunSensor(noise=1.0)


def test_an_unknown_field_model_is_refused_without_magnetorquers():
    # was: Spacecraft(body, field='bogus') accepted (checked only with magnetorquers)
    with pytest.raises(AttitudeValueError, match=r"field: expected 'igrf' .*'dipole'.*'bogus'"):
        attitude.Spacecraft(BODY, field="bogus")
    with pytest.raises(AttitudeValueError, match="field: a constant field"):
        attitude.Spacecraft(BODY, field=[1e-5, 0.0])
    assert attitude.Spacecraft(BODY, field="dipole").field == "dipole"


def test_atol_wider_than_the_state_is_refused():
    # was: atol = 2**70 ran (rtol > 0.1 was refused, atol had only a floor)
    Q0 = C.momenta_from_angular_velocity(Q_ID, [0.01, 0.0, 0.0], BODY)
    with pytest.raises(AttitudeValueError, match=r"atol: .* above 0\.1 times the state's scale"):
        attitude.propagate(BODY, Q_ID, Q0, [0.0, 1.0], atol=2.0**70)
    with pytest.raises(AttitudeValueError, match=r"atol: .* use at most 0\.1 "):
        attitude.propagate(BODY, Q_ID, Q0, [0.0, 1.0], atol=0.2)  # |Q0| = 0.24 < 1: |q| rules


def test_a_method_that_is_not_a_string_is_a_type_error():
    # was: numpy's "truth value of an array is ambiguous" from choose_method
    Q0 = C.momenta_from_angular_velocity(Q_ID, [0.01, 0.0, 0.0], BODY)
    with pytest.raises(AttitudeTypeError, match="method: expected a method name"):
        attitude.propagate(BODY, Q_ID, Q0, [0.0, 1.0], method=np.array(["a", "b"]))
    with pytest.raises(AttitudeTypeError, match="method: expected a method name"):
        attitude.propagate(BODY, Q_ID, Q0, [0.0, 1.0], method=None)


def test_scenario_sensor_quantities_need_their_unit_and_a_plausible_noise():
    # was: noise = 100.0 without noise_unit read as 100 T, the run exiting 0
    base = _RW + '\n[software]\nperiod = 0.5\ncontrol = "rate_damping"\nC = 30.0\n'
    mag = '[[software.sensors]]\ntype = "magnetometer"\nnoise = 100.0\nseed = 1\n'
    with pytest.raises(scenario.ScenarioError, match=r"sensors\[0\]\.noise: needs a unit"):
        scenario.loads(base + mag)
    with pytest.raises(scenario.ScenarioError, match=r"sensors\[0\]\.noise: .*Earth's field"):
        scenario.loads(base + mag + 'noise_unit = "T"\n')
    with pytest.raises(scenario.ScenarioError, match=r"sensors\[0\]\.arw: needs a unit"):
        scenario.loads(base + '[[software.sensors]]\ntype = "gyro"\narw = 1e-6\n')
    st = '[[software.sensors]]\ntype = "star_tracker"\nnoise = 5.0\nnoise_unit = "arcsec"\n'
    with pytest.raises(scenario.ScenarioError, match=r"sensors\[0\]\.rate: needs a unit"):
        scenario.loads(base + st + "rate = 2.0\n")
    sc = scenario.loads(base + mag + 'noise_unit = "nT"\n')
    assert sc.software.sensors[0].noise == pytest.approx(1e-7)


@numba.njit
def _untyped_step(t, m):
    return m.no_such_attribute


@numba.njit
def _tuple_step(t, m):
    return (0.0, 0.0, 0.0, 0.0)


@numba.njit("float64[:](float64, int64[:])")
def _int_step(t, m):
    return -m[0:3] * 1.0


@numba.njit("float64[:](float64, float64[:])")
def _signed_step(t, m):
    return -m[0:3]


def test_a_compiled_step_that_numba_cannot_compile_is_a_package_error():
    from attitude._user_kernels import check_step

    with pytest.raises(AttitudeTypeError, match=r"_int_step\(t, m\).*none of its signatures"):
        _run(_craft(), FlightSoftware(0.1, control=_int_step))
    check_step(_signed_step)  # a signature that takes the loop's arguments: no recompiling

    # was: numba's TypingError out of propagate (its message ~60 lines of the package's kernels)
    with pytest.raises(AttitudeTypeError, match=r"(?s)_untyped_step\(t, m\).*cannot be compiled.*"
                       "no_such_attribute"):  # fmt: skip
        _run(_craft(), FlightSoftware(0.1, control=_untyped_step))
    with pytest.raises(AttitudeTypeError, match=r"_tuple_step\(t, m\).* returns UniTuple"):
        _run(_craft(), FlightSoftware(0.1, control=_tuple_step))


@pytest.mark.parametrize(
    ("value", "why"),
    [
        ([np.nan, 0.0, 0.0, 0.0], "non-finite"),
        ([np.inf, 0.0, 0.0, 0.0], "non-finite"),
        (None, "returned None"),
        ({"wheel_torque": None}, "returned wheel_torque = None"),
        (np.zeros(3), r"returned shape \(3,\)"),
        (np.zeros((4, 1)), r"returned shape \(4, 1\)"),  # was: flattened in silence
        ({"wheel_torque": np.zeros((1, 4))}, r"wheel_torque of shape \(1, 4\)"),
    ],
)
def test_a_python_step_returning_bad_commands_stops_with_the_partial_result(value, why):
    # was: AttitudeValueError without .partial (docs/flight_software.md promises the samples)
    def step(t, m):
        return value if t > 0.25 else np.zeros(4)

    with pytest.raises(attitude.errors.PropagationError, match=why) as info:
        _run(_craft(), FlightSoftware(0.1, control=step), t=(0.0, 0.2, 0.4, 0.6))
    assert info.value.partial is not None
    np.testing.assert_array_equal(info.value.partial.time.values, [0.0, 0.2])


@pytest.mark.parametrize(
    "table, close",
    [
        ('\n[software]\nperiod = 0.5\nguidance = "intertial"\ncontrol = "mrp_feedback"\n'
         "K = 3.5\nP = 30.0\n", "inertial"),
        ('\n[software]\nperiod = 0.5\nguidance = "lvhl"\ncontrol = "mrp_feedback"\n'
         "K = 3.5\nP = 30.0\n", "lvlh"),
        ("\n[[software.modes]]\nname = \"a\"\ncontrol = \"rate_damping\"\nC = 30.0\n"
         '[[software.modes]]\nname = "b"\ncondition = "pointing_within"\nthreshold = 5.0\n'
         'threshold_unit = "deg"\n'
         'condition_frame = "nadirr"\ncontrol = "rate_damping"\nC = 30.0\n', "nadir"),
    ],
)  # fmt: skip
def test_scenario_misspelled_frame_is_named_with_the_choices(table, close):
    """issue 39: guidance = "intertial" (no [orbit] table) was reported as 'needs an [orbit]
    table'; the error now names the unknown frame, the valid ones and the closest."""
    text = _RW + table
    if "modes" in table:
        text = text.replace(
            "[[software.modes]]", "[software]\nperiod = 0.5\n\n[[software.modes]]", 1
        )
    with pytest.raises(scenario.ScenarioError) as exc:
        scenario.loads(text)
    msg = str(exc.value)
    assert "unknown name" in msg and "[orbit]" not in msg
    assert "inertial, orbital, lvlh, rsw, vnc, nadir, sun_pointing" in msg
    assert msg.endswith(f"did you mean {close!r}?")


def test_scenario_misspelled_initial_frame_suggests_the_close_one():
    text = _RW.replace("[initial_state]", '[initial_state]\nframe = "inertal"', 1)
    with pytest.raises(scenario.ScenarioError, match=r"initial_state\.frame: unknown name "
                       r"'inertal': .*did you mean 'inertial'\?"):  # fmt: skip
        scenario.loads(text)

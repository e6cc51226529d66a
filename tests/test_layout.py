"""Layouts declared once (issue 40, point 1): the helper of :mod:`orbit._layout`, and
each public object packed through its declaration and read back field by field."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import attitude
from attitude import frames
from attitude._core import fsw as _kf
from attitude._core.fsw_layout import FW, MB
from attitude.actuators import Magnetorquer, ReactionWheel
from attitude.control import MomentumDumping, MRPFeedback, RateDamping, WheelAllocation
from attitude.software import FlightSoftware, Mode, RateBelow, Slew
from attitude.software._software import _frame_data, program
from orbit._layout import Appender, Field, Gap, layout

# -- the helper --------------------------------------------------------------------------------


def test_offsets_follow_the_declaration():
    """Fields follow one another; gaps and a padded size keep later offsets; a zero-size field
    marks where a variable tail starts."""
    L = layout("t", a=1, b=Field(3, "m"), _g=Gap(2), c=Field(9, "kg m2", shape=(3, 3)), d=0)
    assert (L.A, L.B, L.C, L.D, L.SIZE) == (0, 1, 6, 15, 15)
    assert layout("p", a=2, size=8).SIZE == 8
    assert L.unit("b") == "m" and list(L.fields) == ["a", "b", "c", "d"]
    with pytest.raises(ValueError, match="more than size"):
        layout("p", a=9, size=8)
    with pytest.raises(ValueError, match="shape"):
        layout("p", a=Field(4, shape=(3, 3)))
    with pytest.raises(ValueError, match="lower case"):
        layout("p", A=1)


def test_pack_and_read_round_trip():
    """pack writes each field where the offsets say; read gives them back (floats, vectors,
    matrices in their shape), also a column per field from a block of records."""
    L = layout("t", a=1, b=3, c=Field(4, shape=(2, 2)))
    x = L.pack(a=2.5, b=[1, 2, 3], c=np.array([[1.0, 2.0], [3.0, 4.0]]))
    assert x.tolist() == [2.5, 1, 2, 3, 1, 2, 3, 4]
    r = L.read(x)
    assert r["a"] == 2.5 and r["b"].tolist() == [1, 2, 3] and r["c"].tolist() == [[1, 2], [3, 4]]
    big = L.pack_into(np.zeros(20), 5, a=7.0)
    assert big[5] == 7.0 and L.read(big, 5)["a"] == 7.0
    rows = np.vstack([x, 2 * x])
    assert L.read(rows)["a"].tolist() == [2.5, 5.0] and L.read(rows)["b"].shape == (2, 3)
    with pytest.raises(ValueError, match="2 values for 3 words"):
        L.pack(b=[1, 2])
    with pytest.raises(KeyError, match="no field 'z'"):
        L.pack(z=1)


def test_layouts_pickle():
    """A layout pickles by reference to its declaring module (as numba's cache and process
    pools may need)."""
    import pickle

    from attitude._core.mekf import E

    assert pickle.loads(pickle.dumps(FW)) == FW and type(pickle.loads(pickle.dumps(E))) is type(E)
    assert pickle.loads(pickle.dumps(FW)).fields == FW.fields


def test_appender_returns_offsets():
    out = Appender(np.zeros(3))
    assert out.append([1.0, 2.0]) == 3 and out.append(np.eye(2)) == 5
    assert out.array().tolist() == [0, 0, 0, 1, 2, 1, 0, 0, 1]


def test_numba_reads_offsets_as_constants():
    """A layout is a named tuple of ints: numba compiles ``a[L.X]`` to a constant index, and
    uses the offsets where it needs compile-time constants (a tuple's index)."""
    numba = pytest.importorskip("numba")
    L = layout("t", a=1, b=3)

    @numba.njit
    def f(a):
        t = (10.0, 20.0, 30.0, 40.0)
        return a[L.B + 2] + t[L.B] + L.SIZE

    assert f(np.arange(5.0)) == 3.0 + 20.0 + 4


# -- the flight software -------------------------------------------------------------------------


def _software_and_craft():
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    wheels = [ReactionWheel(np.eye(3)[k], 0.02, max_torque=0.1) for k in range(3)]
    rods = [Magnetorquer(np.eye(3)[k], 5.0) for k in range(3)]
    craft = attitude.Spacecraft(body, wheels, rods, field=[2e-5, -1e-5, 3e-5])
    target = frames.inertial([math.cos(0.3), math.sin(0.3), 0.0, 0.0])
    fsw = FlightSoftware(
        0.5,
        modes=[
            (None, Mode(control=RateDamping(2.0), name="damp")),
            (
                RateBelow(0.01),
                Mode(
                    Slew(target, 0.02, 0.001),
                    (MRPFeedback(1.5, 12.0, Ki=0.01, integral_limit=0.2), MomentumDumping(1e-3)),
                    WheelAllocation(null_gain=0.05, null_speeds=[10.0, -5.0, 2.0]),
                ),
            ),
        ],
        delay=1,
        phase=0.25,
        inertia=[12.5, 10.0, 8.0],
        record_every=2,
    )
    return fsw, craft


def test_flight_software_round_trip():
    """The program's header and mode blocks, read through their declarations, are the
    software's and its modes' attributes (SI)."""
    fsw, craft = _software_and_craft()
    prog = program(fsw, craft, 10.0, 40.0)
    h = FW.read(prog.fw)
    assert h["period"] == fsw.period and h["t0"] == 10.0 + fsw.phase
    assert h["delay"] == fsw.delay and h["nmodes"] == len(fsw.modes)
    assert h["ncmd"] == 6 and h["ideal"] == 0.0 and h["record_every"] == 2
    np.testing.assert_array_equal(h["inertia"], fsw.inertia)
    assert FW.unit("inertia") == "kg m2" and FW.unit("period") == "s"
    table = prog.fw[int(h["modes"]) : int(h["modes"]) + len(fsw.modes)].astype(int)
    for (cond, mode), at in zip(fsw.modes, table, strict=True):
        m = MB.read(prog.fw, at)
        law, dump = (mode.control, None) if not isinstance(mode.control, tuple) else mode.control
        K, P, Ki, lim, lt = law._gains()
        assert (m["ctrl"], m["k"], m["ki"], m["ilim"], m["lawtype"]) == (law._kind, K, Ki, lim, lt)
        np.testing.assert_array_equal(m["p"], P)
        if cond is not None:
            assert m["cond"] == cond._kind and m["cond_x"] == cond.threshold
        if isinstance(mode.guidance, Slew):
            assert m["guid"] == _kf.GUID_SLEW
            assert (m["slew_rate"], m["slew_acc"]) == (0.02, 0.001)
            want = _frame_data(mode.guidance.target, 10.0, 40.0)
            at_f = int(m["guid_frame"])
            np.testing.assert_array_equal(prog.fw[at_f : at_f + want.size], want)
        if dump is not None:
            assert m["dump"] == dump.gain
            np.testing.assert_array_equal(m["dump_ref"], dump.reference)
        if mode.allocation is not None:
            al = mode.allocation
            at_s = int(m["null_speeds"])
            assert m["null"] == al.null_gain
            np.testing.assert_array_equal(prog.fw[at_s : at_s + 3], al.null_speeds)


# -- sensors, the estimator, the measurements ----------------------------------------------------


def _sensor_craft():
    from attitude.scenario import load

    orbit = None
    for name in ("cubesat_environment", "nadir_wheels_dumping", "cubesat_bdot"):
        sc = load(f"{Path(__file__).parent.parent}/scenarios/{name}.toml").spacecraft
        if sc is not None and getattr(getattr(sc, "orbit", None), "epoch", None) is not None:
            orbit = sc.orbit
            break
    if orbit is None:
        pytest.skip("no shipped scenario with a dated orbit")
    return attitude.Spacecraft(attitude.RigidBody([10.0, 11.0, 12.0], units="kg m2"), orbit=orbit)


def test_sensor_program_round_trip():
    """Each sensor's record, read through its declaration, holds the sensor's attributes; the
    header's offsets point at the records."""
    from attitude._core import sensors as _ks
    from attitude.sensors import Gyro, Magnetometer, StarTracker, SunSensor
    from attitude.sensors._models import sensor_program

    craft = _sensor_craft()
    gyro = Gyro(3e-6, 2e-9, bias=[1e-5, -2e-5, 3e-6], saturation=0.5, seed=1)
    st = StarTracker([5e-5, 4e-4], boresight=[1.0, 1.0, 0.0], rate=0.5, sun_exclusion=0.5, seed=2)
    mag = Magnetometer(2e-7, bias=[1e-7, -2e-7, 0.0], seed=3)
    sun = SunSensor(np.vstack([np.eye(3), -np.eye(3)]), 0.01, seed=4)
    period = 0.5
    sn, ss = sensor_program((gyro, st, mag, sun), period, craft, 0.0, 100.0)
    h = _ks.SN.read(sn)
    assert all(h[k] >= _ks.SN.SIZE for k in ("gyro", "st", "mag", "sun", "orbit", "suntab"))
    g = _ks.GYRO.read(sn, int(h["gyro"]))
    assert (g["sv"], g["su"], g["sat"], g["identity"]) == (gyro.arw, gyro.rrw, 0.5, 1.0)
    assert (g["sd"], g["sq"]) == _ks.gyro_tick_sigmas(gyro.arw, gyro.rrw, period)
    np.testing.assert_array_equal(g["b0"], gyro.bias)
    np.testing.assert_array_equal(g["c"], gyro.matrix)
    t = _ks.ST.read(sn, int(h["st"]))
    assert (t["sc"], t["sb"]) == tuple(st.noise) and t["every"] == 4
    assert (t["sun_excl"], t["earth_excl"]) == (st.sun_exclusion, st.earth_exclusion)
    np.testing.assert_array_equal(t["cbs"], st.frame)
    m = _ks.MAG.read(sn, int(h["mag"]))
    assert m["sigma"] == mag.noise
    np.testing.assert_array_equal(m["bias"], mag.bias)
    s = _ks.SUNS.read(sn, int(h["sun"]))
    assert (s["nheads"], s["sigma"]) == (6, sun.noise)
    at = int(h["sun"]) + _ks.SUNS.NORMALS
    np.testing.assert_array_equal(sn[at : at + 18].reshape(6, 3), sun.normals)
    states = sorted(int(x["state"]) for x in (g, t, m, s))
    assert states[0] == 0 and states[-1] < ss.size  # each stream in the sensor state


def test_mekf_record_round_trip():
    """The MEKF's record, read through its declaration, holds the filter's settings and the
    sensors' noise it weighs the updates with."""
    from attitude._core import mekf as _km
    from attitude.estimation import MEKF
    from attitude.sensors import Gyro, Magnetometer, StarTracker

    gyro = Gyro(3e-6, 2e-9, seed=1)
    st = StarTracker(5e-5, seed=2)
    mag = Magnetometer(2e-7, seed=3)
    q0 = np.array([math.cos(0.1), 0.0, math.sin(0.1), 0.0])
    est = MEKF(q0, [1e-6, 0.0, -1e-6], 0.01, 1e-4, use_magnetometer=True)
    r = _km.EP.read(est.record((gyro, st, mag)))
    assert (r["sv"], r["su"], r["init"], r["mag"], r["sun"]) == (3e-6, 2e-9, 1.0, 2e-7, 0.0)
    np.testing.assert_array_equal(r["p0"], [1e-4] * 3 + [1e-8] * 3)
    np.testing.assert_array_equal(r["q0"], est.initial_attitude)
    np.testing.assert_array_equal(r["b0"], est.initial_bias)
    np.testing.assert_array_equal(r["st_r"], st.covariance)


def test_measurement_index_is_the_declared_layout():
    """MeasurementIndex (public) names the offsets of the declared measurement vector, in the
    order of the fields of Measurements."""
    from attitude._core.fsw_step import MEAS
    from attitude.software import MeasurementIndex, Measurements

    assert {k.upper(): f.offset for k, f in MEAS.fields.items()} == {
        m.name: int(m) for m in MeasurementIndex
    }
    assert set(MEAS.fields) - {"wheel_speeds"} <= set(Measurements._fields)


# -- the spacecraft block -------------------------------------------------------------------------


def test_spacecraft_block_round_trip():
    """The spacecraft block's header and each actuator's record, read through their
    declarations, hold the spacecraft's and the actuators' attributes (SI)."""
    from attitude._core import actuators as _ka
    from attitude.actuators import Thruster

    wheels = [
        ReactionWheel([1.0, 0.0, 0.0], 0.02, max_torque=0.1, max_speed=600.0, speed=50.0,
                      coulomb_friction=1e-3, static_friction=2e-3, viscous_friction=1e-5,
                      stribeck_speed=0.1, min_torque=1e-4, max_power=20.0),
        ReactionWheel([0.0, 0.6, 0.8], 0.03),
    ]  # fmt: skip
    rods = [Magnetorquer([0.0, 0.0, 1.0], 5.0)]
    jets = [Thruster([0.5, 0.0, 0.0], [0.0, 1.0, 0.0], 2.0, min_impulse_bit=0.01)]
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    craft = attitude.Spacecraft(body, wheels, rods, jets, field=[2e-5, -1e-5, 3e-5])
    sc = craft.block([0.0, 10.0])
    h = _ka.SC.read(sc)
    assert (h["nw"], h["nm"], h["nt"]) == (2, 1, 1) and h["mtq"] > _ka.SC.WHEELS
    np.testing.assert_array_equal(h["minv"], craft._minv)
    for k, w in enumerate(wheels):
        r = _ka.WHEEL.read(sc, _ka.wheel_base(sc, k))
        np.testing.assert_array_equal(r["axis"], w.axis)
        assert (r["j"], r["invj"], r["umax"], r["omax"]) == (
            w.inertia,
            1.0 / w.inertia,
            w.max_torque,
            w.max_speed,
        )
        assert (r["fc"], r["fs"], r["cv"], r["lc"]) == (
            w.coulomb_friction,
            w.static_friction,
            w.viscous_friction,
            w.limit_cycle_speed,
        )
        assert (r["umin"], r["pmax"], r["omega_before"]) == (w.min_torque, w.max_power, w.speed)
        assert r["beta"] == (-1.0 if w.stribeck_speed is None else w.stribeck_speed)
        assert r["friction"] == float(w.coulomb_friction > 0)
        assert r["u"] == r["ucmd"] == r["flags"] == 0.0  # held slots: zero until a hold
    m = _ka.MTQ.read(sc, _ka.magnetorquer_base(sc, 0))
    np.testing.assert_array_equal(m["axis"], rods[0].axis)
    assert m["max"] == rods[0].max_dipole and m["cmd"] == 0.0
    t = _ka.THR.read(sc, _ka.thruster_base(sc, 0))
    np.testing.assert_array_equal(t["dir"], jets[0].direction)
    np.testing.assert_allclose(t["arm"], np.cross(jets[0].position - craft.center_of_mass,
                                                  jets[0].direction))  # fmt: skip
    assert (t["fmax"], t["min_on"]) == (jets[0].max_thrust, jets[0].min_on_time)


# -- the environment models ---------------------------------------------------------------------


def test_environment_blocks_round_trip():
    """Each environment model's block, read through its declaration, holds the model's
    attributes; its table's segment header the table's nodes; the facet groups follow."""
    from attitude import environment as env
    from attitude._core import environment as _ke
    from attitude.facets import box_wing, drag_groups, optical_groups
    from attitude.potentials import (
        AerodynamicDrag,
        EddyCurrentDamping,
        MagneticDipole,
        SolarRadiation,
    )

    orbit = _sensor_craft().orbit
    span = np.array([0.0, 600.0])
    facets = box_wing([1.0, 2.0, 3.0], center=[0.1, 0.0, -0.2], specular=0.3, diffuse=0.2)
    dip = MagneticDipole(orbit, [0.1, 0.2, 0.3], "dipole")
    p = dip.prepare(span)._kernel_params(span)
    b = _ke.DIPOLE.read(p)
    assert b["kind"] == dip._kind and b["vec"].tolist() == [0.1, 0.2, 0.3]
    seg = int(b["tab"]) + 1 + int(p[int(b["tab"])])  # the first segment follows the offsets
    s = _ke.SEG.read(p, seg)
    assert s["ncomp"] == 3 and s["n"] >= _ke.WINDOW and s["lo"] <= 0.0 and s["hi"] >= 600.0
    assert s["inv_h"] == 1.0 / s["h"]
    eddy = EddyCurrentDamping(orbit, np.diag([1.0, 2.0, 3.0]), "dipole")
    e = _ke.EDDY.read(eddy.prepare(span)._kernel_params(span))
    np.testing.assert_array_equal(e["tensor"], eddy.tensor)
    drag = AerodynamicDrag(orbit, facets, density="exponential")
    p = drag.prepare(span)._kernel_params(span)
    d = _ke.DRAG.read(p)
    groups = drag_groups(facets)
    assert (d["kind"], d["nf"], d["density"]) == (drag._kind, len(groups), _ke.DENSITY_EXPONENTIAL)
    at = _ke.DRAG.FACETS
    np.testing.assert_array_equal(p[at : at + groups.size].reshape(groups.shape), groups)
    g0 = _ke.DRAG_GROUP.read(p, at)
    np.testing.assert_array_equal(g0["normal"], groups[0, :3])
    bands = np.ravel(env.VALLADO_EXPONENTIAL)
    assert d["bands"] == at + groups.size and d["nb"] == len(env.VALLADO_EXPONENTIAL)
    np.testing.assert_array_equal(p[int(d["bands"]) : int(d["bands"]) + bands.size], bands)
    # the force sums (Σ C_D A along ±n̂ per group) follow the bands
    forces = np.array([[sum(f.cd * f.area for f in facets if np.allclose(f.normal, s * g[:3]))
                        for s in (1.0, -1.0)] for g in groups])  # fmt: skip
    assert d["forces"] == d["bands"] + bands.size and d["live"] == 0.0
    np.testing.assert_allclose(p[int(d["forces"]) : int(d["forces"]) + forces.size],
                               forces.ravel(), rtol=1e-15)  # fmt: skip
    srp = SolarRadiation(orbit, facets)
    p = srp.prepare(span)._kernel_params(span)
    r = _ke.SRP.read(p)
    groups = optical_groups(facets)
    assert (r["nf"], r["p"], r["au"]) == (len(groups), env.P_SUN_1AU, env.AU_KM)
    assert r["eclipse"] == _ke.ECLIPSE_CONICAL and r["umbra"] == float(srp._umbra)
    np.testing.assert_array_equal(p[_ke.SRP.FACETS : int(r["forces"])], groups.ravel())
    assert r["forces"] == _ke.SRP.FACETS + groups.size and r["live"] == 0.0
    assert int(r["tab"]) == int(r["forces"]) + 6 * len(groups)


def test_environment_index_is_the_declared_layout():
    """EnvironmentIndex (public) names the offsets of the declared environment vector; the
    environment block's header points at the field, the orbit and the Sun."""
    from attitude._core import environment as _ke
    from attitude.potentials import ENVIRONMENT_SIZE, EnvironmentIndex
    from attitude.potentials._user import _TorqueEnvironment

    assert {m.name: int(m) for m in EnvironmentIndex} == {
        k.upper(): f.offset for k, f in _ke.ENV.fields.items()
    }
    assert ENVIRONMENT_SIZE == _ke.ENV.SIZE
    orbit = _sensor_craft().orbit
    te = _TorqueEnvironment(orbit, "dipole", 60.0)
    te.prepare(np.array([0.0, 600.0]))
    h = _ke.ENVB.read(te._block)
    data = np.asarray(orbit.kernel_data(), dtype=np.float64)
    at = int(h["orbit"])
    np.testing.assert_array_equal(te._block[at : at + data.size], data)
    assert _ke.DIPOLE.read(te._block, int(h["field"]))["vec"].tolist() == [0.0, 0.0, 0.0]
    assert h["sun"] > at


# -- the records --------------------------------------------------------------------------------


def test_actuator_record_columns_round_trip():
    """The commands in force, written into the spacecraft block's held slots, come back from
    a sample's record columns read through their declarations."""
    from attitude._core import actuators as _ka
    from attitude._core import holds as _kh
    from attitude.actuators import Thruster

    wheels = [ReactionWheel(np.eye(3)[k], 0.02) for k in range(2)]
    rods = [Magnetorquer([0.0, 0.0, 1.0], 5.0)]
    jets = [Thruster([0.5, 0.0, 0.0], [0.0, 1.0, 0.0], 2.0)]
    body = attitude.RigidBody([12.0, 10.0, 8.0], units="kg m2")
    craft = attitude.Spacecraft(body, wheels, rods, jets, field=[2e-5, -1e-5, 3e-5])
    sc = craft.block([0.0, 10.0])
    for k in range(2):
        _ka.WHEEL.pack_into(sc, _ka.wheel_base(sc, k), ucmd=0.1 + k, u=0.05 + k, flags=k + 1,
                            stribeck=k)  # fmt: skip
    _ka.MTQ.pack_into(sc, _ka.magnetorquer_base(sc, 0), cmd=7.0, applied=5.0)
    _ka.THR.pack_into(sc, _ka.thruster_base(sc, 0), cmd=0.25, firing=1.0)
    _ka.SC.pack_into(sc, 0, ideal=[1.0, 2.0, 3.0])
    row = np.full(_kh.record_width(2, 1, 1) + 1, np.nan)
    _kh.record.py_func(sc, row, 1)
    w = _kh.WHEEL_REC.read(row[1 : 1 + 2 * _kh.WHEEL_REC.SIZE].reshape(2, -1))
    assert w["cmd"].tolist() == [0.1, 1.1] and w["torque"].tolist() == [0.05, 1.05]
    assert w["flags"].tolist() == [1, 2] and w["stribeck"].tolist() == [0, 1]
    c = 1 + 2 * _kh.WHEEL_REC.SIZE
    assert _kh.MTQ_REC.read(row, c) == {"cmd": 7.0, "applied": 5.0}
    c += _kh.MTQ_REC.SIZE
    assert _kh.THR_REC.read(row, c) == {"cmd": 0.25, "firing": 1.0}
    c += _kh.THR_REC.SIZE
    assert _kh.IDEAL_REC.read(row, c)["torque"].tolist() == [1.0, 2.0, 3.0]
    assert c + _kh.IDEAL_REC.SIZE == row.size


def test_diagnostic_blocks_follow_the_declaration():
    """The diagnostic buffer's blocks (the result's variables) are the declared sample's
    fields, in order, contiguous."""
    from attitude._core import diagnostics as _kd

    names = [b[0] for b in _kd.BLOCKS]
    assert names[:3] == ["q", "Q", "omega"] and names[-1] == "p"
    ends = [off + w for _, off, w in _kd.BLOCKS]
    assert [off for _, off, _ in _kd.BLOCKS] == [0, *ends[:-1]] and ends[-1] == _kd.SAMPLE.SIZE


# -- frames and events --------------------------------------------------------------------------


def test_frame_data_round_trip():
    """A frame's kernel data, read through its declaration, holds the frame's attributes."""
    from attitude._core import frames as _kfr

    q = np.array([0.6, 0.8, 0.0, 0.0])
    f = frames.inertial(q).offset([math.cos(0.2), 0.0, 0.0, math.sin(0.2)])
    d = _kfr.INERTIAL.read(f.kernel_data(0.0, 10.0))
    assert d["type"] == _kfr.FRAME_INERTIAL
    np.testing.assert_array_equal(d["q"], f.q)
    np.testing.assert_array_equal(d["offset"], f._offset)
    orbit = _sensor_craft().orbit
    a = frames.aligned(orbit, ("+x", "sun"), ("+z", "nadir"))
    data = a.kernel_data(0.0, 600.0)
    r = _kfr.ALIGNED.read(data)
    assert r["type"] == _kfr.FRAME_ALIGNED
    assert (r["pdir"], r["sdir"]) == (a.primary_code, a.secondary_code) == (
        _kfr.DIR_SUN, _kfr.DIR_NADIR)  # fmt: skip
    np.testing.assert_array_equal(r["body"].ravel(), a._body)
    od = np.asarray(orbit.kernel_data(), dtype=np.float64)
    assert r["orbit"] == _kfr.ALIGNED.SIZE and r["sun"] == _kfr.ALIGNED.SIZE + od.size
    np.testing.assert_array_equal(data[int(r["orbit"]) : int(r["orbit"]) + od.size], od)
    assert r["target"] == 0.0


def test_event_data_round_trip():
    """The event set's data, read through its declarations: the header, each event's block
    (kind, direction, terminal) where the header's offsets say."""
    from attitude._core import events as _kev
    from attitude.events import PointingExceeds, RateExceeds, build

    evs = [
        RateExceeds(0.1, terminal=True),
        PointingExceeds(frames.inertial(), [0.0, 0.0, 1.0], 0.3, direction="falling"),
    ]
    ev = build(evs, np.linspace(0.0, 10.0, 11))
    h = _kev.EV.read(ev.data)
    assert h["n"] == 2 and h["nsub"] == max(e.samples for e in evs)
    offsets = ev.data[_kev.EV.OFFSETS : _kev.EV.OFFSETS + 2].astype(int)
    assert offsets[0] == _kev.EV.SIZE + 2
    for e, at in zip(evs, offsets, strict=True):
        b = _kev.EVB.read(ev.data, at)
        assert (b["kind"], b["terminal"]) == (e._code, float(e.terminal))
    assert _kev.EVB.read(ev.data, offsets[0])["direction"] == _kev.RISING
    assert _kev.EVB.read(ev.data, offsets[1])["direction"] == _kev.FALLING


def test_model_parameters_round_trip():
    """A model's parameters, read through their declarations: the inertia and kind, a single
    model's block, a sum's term offsets pointing at its terms' blocks."""
    from attitude._core import potentials as _kp
    from attitude.potentials import HeavyTop, MagneticDipole

    inertia = np.array([1.0, 2.0, 2.5])
    top = HeavyTop(9.81, [0.0, 0.1, 0.3])
    p = top._params(inertia)
    m = _kp.MODEL.read(p)
    assert m["inertia"].tolist() == inertia.tolist() and m["kind"] == _kp.KIND_HEAVY_TOP
    b = _kp.HEAVY_TOP.read(p, _kp.MODEL.KIND)
    assert b["weight"] == top.weight and b["cm"].tolist() == top.center_of_mass.tolist()
    dip = MagneticDipole(_sensor_craft().orbit, [0.1, 0.2, 0.3], "dipole")
    dip.prepare(np.array([0.0, 600.0]))
    p = (top + dip)._params(inertia)
    s = _kp.SUM.read(p)
    assert (s["kind"], s["nterms"]) == (_kp.KIND_SUM, 2)
    at = p[_kp.SUM.OFFSETS : _kp.SUM.OFFSETS + 2].astype(int)
    assert _kp.HEAVY_TOP.read(p, at[0])["weight"] == top.weight
    assert p[at[1]] == _kp.KIND_MAGNETIC_DIPOLE


# -- no hand-numbered offsets -------------------------------------------------------------------

#: What may stay a number in attitude._core: enumerations (codes a block holds, not offsets),
#: statuses, and sizes that are not layouts (SIMD widths, orders, stage counts).
_CODES = re.compile(
    r"^(KIND|COND|GUID|CTRL|DIR|FRAME|FLAG|DENSITY|ECLIPSE|PIECE|INVARIANTS|FORCE)_"
)
_STATUSES = {"SUCCESS", "NONFINITE", "STEP_TOO_SMALL", "TOO_MANY_STEPS", "EVENT", "PAUSED",
             "EVENT_BUFFER_FULL", "NOT_STARTED", "RUNNING", "RECORDS_WAIT", "BOUNDARY_DONE",
             "BOUNDARY_NEEDS_COMMANDS", "NEEDS_COMMANDS", "RECORDS_FULL", "STEP_FAILED",
             "RISING", "FALLING", "BOTH", "KICK", "ROTOR", "FREE", "FREE_KEPLER",
             "ROTOR_KEPLER", "MUTUAL"}  # fmt: skip
_SIZES = {"LANES", "PMAX", "PMIN", "WINDOW", "N_STAGES", "N_STAGES_EXTENDED",
          "INTERPOLATOR_POWER", "RNG_SIZE", "SPAN_TICKS", "N_COUNTERS", "NDIAG", "MAX_SLOTS",
          "MAX_ENV"}  # fmt: skip


def test_no_hand_numbered_offsets_in_core():
    """Every integer constant written as a number in attitude._core is a code, a status or a
    size; the offsets of the float arrays come from layout declarations."""
    core = Path(attitude.__file__).parent / "_core"
    found = set()
    for f in core.glob("*.py"):
        found |= set(re.findall(r"^([A-Z][A-Z0-9_]*) = -?\d+\s*(?:#.*)?$", f.read_text(), re.M))
    stray = {n for n in found if not _CODES.match(n)} - _STATUSES - _SIZES
    assert not stray, f"hand-numbered constants (declare them with orbit._layout): {stray}"

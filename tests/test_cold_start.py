"""What a fresh install compiles less of gives the same numbers (docs/cold_start.md).

* A model of one kind alone runs on a copy of the entry points compiled with its own kernels
  (attitude._core.models); a sum runs on the generic ones. The two must integrate the same model
  to the same bits: a gravity gradient alone against the same gravity gradient through the
  generic switch, on every orbit type (an ellipse's copy is compiled without the hyperbolic
  solver), the torque-free and heavy-top cases, and each environment model.
* One-off evaluations run the kernels as plain Python (orbit._shared_jit.interpreted): an
  orbit's mean anomaly at epoch and a reference frame at the initial time must be the compiled
  kernels' values, bit for bit.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import orbit
from attitude import frames
from attitude._core import entry_points as generic
from attitude.canonical import project_state
from attitude.potentials import (
    AerodynamicDrag,
    EddyCurrentDamping,
    Facet,
    GravityGradient,
    HeavyTop,
    MagneticDipole,
    SolarRadiation,
    TorqueFree,
)
from orbit import _kernels as K
from orbit import _rk as rk
from orbit._shared_jit import interpreted

EPOCH = "2024-03-20T12:00:00"
INERTIA = np.array([400.0, 500.0, 600.0])


def _orbits():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the paper's orbit dips below the surface
        ell = orbit.KeplerOrbit(7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12, epoch=EPOCH)
        return {
            "ellipse": ell,
            "hyperbola": orbit.KeplerOrbit(-20000.0, 1.5, 0.5, 0.7, 0.2, epoch=EPOCH),
            "secular J2": orbit.SecularJ2Orbit(7078.0, 0.01, 1.7, 0.5, 1.5, epoch=EPOCH),
            "ephemeris": orbit.EphemerisOrbit.from_orbit(ell, 0.0, 7000.0, 60.0),
        }


def _run(entry, params, t):
    q0, Q0, _ = project_state([0.5, -(0.5**0.5), 0.0, 0.5], [0.3, -0.848528, 0.141421, -1.5])
    y = np.empty((t.size, 8))
    work, tstate, counters = rk.new_state(8)
    status, k = entry.dop853_canonical(
        params, np.concatenate([q0, Q0]), t[0], t, y, work, tstate, counters,
        1e-11, 1e-13, t[-1], np.inf, 10**6,
    )  # fmt: skip
    assert status == rk.SUCCESS and k == t.size
    diag = np.empty((t.size, 13))
    entry.diagnostics(t, y, params, diag)
    return y, diag, counters.copy()


def _same_as_generic(pot, t):
    """Run ``pot`` on its own entry points and on the generic switch: the same bits. Returns
    how far its final state is from a torque-free run's (the torque must move the state)."""
    params = pot._params(INERTIA)
    model = pot._entry_points()
    assert model is not generic  # its own copy, compiled for this kind (and orbit type)
    y1, d1, c1 = _run(model, params, t)
    y2, d2, c2 = _run(generic, params, t)
    np.testing.assert_array_equal(y1, y2)
    np.testing.assert_array_equal(d1, d2)
    np.testing.assert_array_equal(c1, c2)
    y0, _, _ = _run(generic, TorqueFree()._params(INERTIA), t)
    return np.max(np.abs(y0[-1] - y1[-1]))


@pytest.mark.parametrize("name", ["ellipse", "hyperbola", "secular J2", "ephemeris"])
def test_gravity_gradient_alone_matches_the_generic_switch_bit_for_bit(name):
    pot = GravityGradient(_orbits()[name])
    assert _same_as_generic(pot, np.linspace(0.0, 3000.0, 31)) > 1e-6


@pytest.mark.parametrize("pot", [TorqueFree(), HeavyTop(3e-3, [0.0, 0.0, 1.0])], ids=repr)
def test_classic_models_alone_match_the_generic_switch_bit_for_bit(pot):
    moved = _same_as_generic(pot, np.linspace(0.0, 200.0, 21))
    assert moved == 0.0 if isinstance(pot, TorqueFree) else moved > 1e-6


def _environment_models():
    leo = orbit.KeplerOrbit(6978.0, 0.001, 1.7, 0.3, 0.4, epoch=EPOCH)
    plates = [Facet(0.1, [1.0, 0.0, 0.0], [0.05, 0.02, 0.0], specular=0.2, diffuse=0.1)]
    return [
        MagneticDipole(leo, [0.1, 0.0, 0.3]),
        EddyCurrentDamping(leo, 4.0),
        AerodynamicDrag(leo, plates),
        SolarRadiation(leo, plates),
    ]


@pytest.mark.parametrize("pot", _environment_models(), ids=lambda p: p.name)
def test_environment_models_alone_match_the_generic_switch_bit_for_bit(pot):
    t = np.linspace(0.0, 3000.0, 31)
    pot.prepare(t)
    assert _same_as_generic(pot, t) > 1e-9


def test_mean_anomaly_at_epoch_interpreted_is_the_compiled_kernels():
    py = interpreted(K)
    rng = np.random.default_rng(7)
    for _ in range(2000):
        e = float(rng.choice([rng.uniform(0.0, 1.0), 1.0 - 10 ** rng.uniform(-12, -1)]))
        f = float(rng.uniform(-50.0, 50.0))
        a = K.mean_from_eccentric_scalar(K.eccentric_from_true_scalar(f, e), e)
        b = py.mean_from_eccentric_scalar(py.eccentric_from_true_scalar(f, e), e)
        assert a == b, (f, e)
        eh = float(1.0 + 10 ** rng.uniform(-10, 4))
        fh = float(rng.uniform(-1.0, 1.0) * 0.999 * np.arccos(-1.0 / eh))
        a = K.mean_from_hyperbolic_scalar(K.hyperbolic_from_true_scalar(fh, eh), eh)
        b = py.mean_from_hyperbolic_scalar(py.hyperbolic_from_true_scalar(fh, eh), eh)
        assert a == b, (fh, eh)


def test_frame_at_the_initial_time_interpreted_is_the_compiled_kernels():
    rng = np.random.default_rng(11)
    n = 0
    for o in _orbits().values():
        for fr in (
            frames.lvlh(o),
            frames.vnc(o),
            frames.nadir(o),
            frames.sun_pointing(o),
            frames.target(o, 0.7, 0.2),
            frames.inertial([0.5, 0.5, 0.5, 0.5]),
        ):
            for t in rng.uniform(0.0, 6000.0, 3):
                qa, wa = fr._evaluate(np.array([t]), interpreted=True)
                qb, wb = fr.evaluate(np.array([t]))
                np.testing.assert_array_equal(qa, qb)
                np.testing.assert_array_equal(wa, wb)
                assert np.all(np.isfinite(qa)) and abs(np.linalg.norm(qa) - 1.0) < 1e-14
                n += 1
    assert n == 4 * 6 * 3

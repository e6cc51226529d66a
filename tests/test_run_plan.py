"""The planner of the run pipeline (attitude._run.plan): the method "auto" resolves to, for a
run and for every member of an ensemble, the runner or spacecraft driver of a run, and the
checks that refuse a run before any work."""

from __future__ import annotations

import math

import numpy as np
import pytest

import attitude
from attitude import _holds, propagate
from attitude._methods import run_scipy
from attitude._run import plan as P
from attitude.actuators import Magnetorquer, ReactionWheel
from attitude.errors import AttitudeTypeError, AttitudeValueError, OutputSizeError
from attitude.potentials import CustomTorque, HeavyTop, TorqueFree

BODY = attitude.RigidBody([1.25, 1.0, 0.75])


def _mtq():
    mtq = [Magnetorquer([0.0, 0.0, 1.0], 1.0)]
    return attitude.Spacecraft(BODY, magnetorquers=mtq, field=[0.0, 0.0, 3e-5])


def _wheels():
    return attitude.Spacecraft(BODY, [ReactionWheel([1.0, 0.0, 0.0], 0.01)])


def test_the_registry_is_the_one_propagate_exports():
    # benchmarks/cold_start.py replaces an entry of attitude.propagate.METHODS: it must be
    # the registry the planner looks up
    import sys

    assert sys.modules["attitude.propagate"].METHODS is P.METHODS
    assert P.lookup_method("dop853") == (P.METHODS["dop853"], {})
    assert P.lookup_method("scipy:Radau") == (run_scipy, {"solver": "Radau"})
    with pytest.raises(AttitudeValueError, match=r"unknown scipy solver 'Foo'"):
        P.lookup_method("scipy:Foo")
    with pytest.raises(AttitudeValueError, match=r"unknown method 'rk4'; known: dop853, exact"):
        P.lookup_method("rk4")
    with pytest.raises(AttitudeTypeError, match=r"method: expected a string"):
        P.lookup_method(3)


def test_auto_is_taylor_where_the_model_allows_it():
    pot = TorqueFree().bind(BODY)
    assert P.choose_method("auto", pot) == "taylor"
    assert P.choose_method("dop853", pot) == "dop853"
    assert P.choose_method("auto", pot, events=[lambda t, q, w: 1.0]) == "dop853"
    assert P.choose_method("auto", pot, formulation="euler_equations") == "dop853"
    user = CustomTorque(lambda q, t: (0.0, 0.0, 0.1)).bind(BODY)
    assert P.choose_method("auto", user) == "dop853"
    mtq = _mtq()
    assert P.choose_method("auto", pot, spacecraft=_wheels()) == "taylor"
    assert P.choose_method("auto", pot, spacecraft=mtq) == "dop853"
    with pytest.raises(AttitudeTypeError, match=r"method: expected a method name"):
        P.choose_method(None, pot)


def test_one_method_for_every_member_of_an_ensemble():
    tf, user = TorqueFree().bind(BODY), CustomTorque(lambda q, t: (0.0, 0.0, 0.1)).bind(BODY)
    assert P.ensemble_method("auto", [tf, tf]) == "taylor"
    assert P.ensemble_method("auto", [tf, user]) == "dop853"  # one member cannot: none does
    assert P.ensemble_method("auto", [tf], events=[lambda t, q, w: 1.0]) == "dop853"
    assert P.ensemble_method("dop853", [user]) == "dop853"
    with pytest.raises(AttitudeValueError, match=r"events: method='taylor' does not locate"):
        P.ensemble_method("taylor", [tf], events=[lambda t, q, w: 1.0])
    with pytest.raises(AttitudeValueError, match=r"method"):
        P.ensemble_method("taylor", [user])  # the Taylor method expands built-ins only
    mtq = _mtq()
    assert P.ensemble_method("auto", [tf], crafts=[_wheels(), _wheels()]) == "taylor"
    assert P.ensemble_method("auto", [tf], crafts=[_wheels(), mtq]) == "dop853"
    # a spacecraft's explicit "taylor" is checked by each member's preparation
    assert P.ensemble_method("taylor", [tf], crafts=[mtq]) == "taylor"


def test_the_plan_of_a_run_names_its_runner():
    pot = HeavyTop(0.5, [0.0, 0.0, 1.0]).bind(BODY)
    plan = P.pick("auto", pot, None, "canonical", None, "dataset")
    assert (plan.requested, plan.method, plan.runner) == ("auto", "taylor", P.METHODS["taylor"])
    assert plan.form is None and not plan.streaming
    sc = P.pick("auto", pot, _wheels(), "canonical", None, "dataset")
    assert (sc.method, sc.runner) == ("taylor", _holds.run_taylor)
    sc = P.pick("dop853", pot, _wheels(), "canonical", None, "dataset")
    assert sc.runner is _holds.run_dop853
    with pytest.raises(AttitudeValueError, match=r"formulation: a spacecraft with actuators"):
        P.pick("dop853", pot, _wheels(), "schwab", None, "dataset")
    with pytest.raises(AttitudeValueError, match=r"'splitting' does not model wheels"):
        P.pick("splitting", pot, _wheels(), "canonical", None, "dataset")
    with pytest.raises(AttitudeValueError, match=r"output: a spacecraft with actuators"):
        P.pick("dop853", pot, _wheels(), "canonical", None, "arrays")


def test_runs_that_cannot_finish_or_fit_are_refused_before_any_work():
    P.check_max_step(10.0, 1.0, 10)
    with pytest.raises(AttitudeValueError, match=r"max_step: 0.5 over the time span 10 means"):
        P.check_max_step(10.0, 0.5, 10)
    P.check_memory("auto", 1000, None, False, True)
    P.check_memory(None, 10**9, None, False, True)  # no limit
    with pytest.raises(OutputSizeError, match=r"about 192 MB \(1000000 output samples"):
        P.check_memory("1 MB", 10**6, None, False, True)
    P.check_memory("1 MB", 10**6, None, True, True)  # streamed: nothing held
    with pytest.raises(OutputSizeError):  # the same through propagate, before any work
        propagate(BODY, [1, 0, 0, 0], [0, 0.1, 0, 0], np.linspace(0, 1, 10**6),
                  max_output_size="1 MB")  # fmt: skip
    P.check_max_step(1.0, math.inf, 1)  # no step limit

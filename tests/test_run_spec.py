"""The run specification (attitude._run.spec.RunSpec): every argument of propagate checked once,
before any work, with errors that name it; the validated run laid out for the runners."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import attitude
from attitude._run.spec import PROGRESS_CHUNKS, RunSpec, check_steps, epoch_attrs, for_span
from attitude.actuators import ReactionWheel
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import HeavyTop, TorqueFree

I = [1.25, 1.0, 0.75]
Q0 = [0.0, 0.3, 0.2, 0.1]
T = np.linspace(0.0, 1.0, 11)
DEFAULTS = dict(
    potential=None, method="auto", rtol=1e-10, atol=1e-12, dt=None, order=4,
    max_step=math.inf, max_steps=100_000_000, progress=None, chunk=None,
    formulation="canonical", on_chunk=None, epoch=None, events=None, output="dataset",
    commands=None, software=None, max_output_size="auto",
)  # fmt: skip


def spec(body=I, q0=(1.0, 0.0, 0.0, 0.0), Q0=Q0, t=T, **kw):
    a = {**DEFAULTS, **kw}
    return RunSpec.single(
        body, q0, Q0, t, a.pop("potential"), a.pop("method"), a.pop("rtol"), a.pop("atol"),
        a.pop("dt"), a.pop("order"), **a,
    )  # fmt: skip


def test_a_valid_run_is_laid_out_for_its_runner():
    s = spec(potential=HeavyTop(0.5, [0.0, 0.0, 1.0]))
    assert (s.plan.requested, s.plan.method) == ("auto", "taylor")
    assert s.problem.y0.shape == (8,) and s.problem.t.shape == (11,)
    assert s.problem.params[:3].tolist() == I
    assert s.options["rtol"] == 1e-10 and s.options["order"] == 4 and s.options["chunk"] is None
    assert s.correction == 0.0 and s.attrs == {} and not s.arrays
    # progress reports PROGRESS_CHUNKS times; streaming hands out 4096 samples at a time
    assert spec(progress=lambda *a: None).options["chunk"] == 1  # 11 samples / 200 chunks
    long = np.linspace(0.0, 1.0, 4001)
    assert spec(t=long, progress=True).options["chunk"] == -(-4001 // PROGRESS_CHUNKS)
    streamed = spec(method="dop853", on_chunk=lambda ds: None)
    assert streamed.plan.streaming and streamed.options["chunk"] == 4096
    assert not spec(method="dop853", formulation="schwab", on_chunk=print).plan.streaming


def test_the_initial_state_is_projected_once_with_a_warning():
    with pytest.warns(UserWarning, match=r"projected onto \|q\| = 1") as rec:
        s = spec(q0=[1.0 + 1e-9, 0.0, 0.0, 0.0])
    assert rec[0].filename == __file__  # (the caller's line, as propagate's warning)
    assert 0.0 < s.correction < 1e-8
    assert np.linalg.norm(s.problem.y0[:4]) == 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec()


@pytest.mark.parametrize(
    ("kw", "exc", "match"),
    [
        (dict(output="xarray"), AttitudeValueError, r"^output: expected 'dataset' or 'arrays'"),
        (dict(output="arrays", on_chunk=print), AttitudeValueError, r"^output: 'arrays'"),
        (dict(method=3), AttitudeTypeError, r"^method: expected a method name"),
        (dict(method="rk4"), AttitudeValueError, r"^method: unknown method 'rk4'"),
        (dict(commands=1), AttitudeValueError, r"^commands: a CommandSchedule drives"),
        (dict(formulation=1), AttitudeTypeError, r"^formulation: expected a name"),
        (dict(q0=[0.0, 0, 0, 0]), AttitudeValueError, r"^q0: the zero quaternion"),
        (dict(q0=[1.0, 0, 0]), AttitudeValueError, r"^q0"),
        (dict(rtol=0.5), AttitudeValueError, r"^rtol"),
        (dict(order=4.0), AttitudeTypeError, r"^order: expected an integer"),
        (dict(chunk=0), AttitudeValueError, r"^chunk"),
        (dict(progress="yes"), AttitudeTypeError, r"^progress: expected True"),
        (dict(on_chunk=1), AttitudeTypeError, r"^on_chunk: expected a callable"),
        (dict(method="dop853", max_step=1e-9, max_steps=10), AttitudeValueError, r"^max_step"),
        (dict(method="taylor", events=[lambda t, q, w: 1.0]), AttitudeValueError, r"^events: "),
        (dict(Q0=[0.0, 1e160, 0.0, 0.0]), AttitudeValueError, r"^Q0: the body rates"),
    ],
)
def test_bad_arguments_are_named(kw, exc, match):
    with pytest.raises(exc, match=match):
        spec(**kw)


def test_the_checks_an_ensemble_shares():
    assert check_steps(math.inf, 5) == (math.inf, 5)
    with pytest.raises(AttitudeValueError, match=r"^max_steps"):
        check_steps(1.0, 0)
    pot = TorqueFree().bind(attitude.RigidBody(I))
    assert for_span(pot, np.array([0.0, 1.0])).name == pot.name
    assert epoch_attrs(pot, "2024-01-01T00:00:00") == {"epoch": "2024-01-01T00:00:00.000000Z"}
    assert epoch_attrs(pot, None) == {}


def test_a_spacecraft_run_carries_its_preparation():
    craft = attitude.Spacecraft(attitude.RigidBody(I), [ReactionWheel([1.0, 0.0, 0.0], 0.01)])
    s = spec(body=craft, method="dop853")
    assert s.problem.spacecraft is not None and s.problem.y0.shape == (9,)
    assert s.attrs["spacecraft"] == craft.describe()
    # events are located by DOP853 between the command boundaries, not by the Taylor series
    assert spec(body=craft, method="dop853", events=[lambda t, q, w: 1.0]).problem.events.n == 1
    with pytest.raises(AttitudeValueError, match=r"^events: .* by method='dop853'.*'taylor'"):
        spec(body=craft, method="taylor", events=[lambda t, q, w: 1.0])

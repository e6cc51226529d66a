"""The ensemble's run specification (attitude.ensemble._spec.EnsembleSpec): the arguments of
propagate_ensemble checked once, before any work, with the single run's shared checks; rigid
bodies or spacecraft members; one method for all."""

from __future__ import annotations

import math

import numpy as np
import pytest

import attitude
from attitude.actuators import ReactionWheel
from attitude.ensemble._members import CraftMembers, _Members
from attitude.ensemble._spec import EnsembleSpec
from attitude.errors import AttitudeTypeError, AttitudeValueError
from attitude.potentials import HeavyTop

I = [1.25, 1.0, 0.75]
Q0 = [0.0, 0.3, 0.2, 0.1]
T = np.linspace(0.0, 1.0, 5)
Q = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
ARGS = dict(
    method="auto", rtol=1e-10, atol=1e-12, max_step=math.inf, max_steps=100_000_000,
    chunk_size=None, path=None, client=None, threads=None, progress=None,
    scheduler_timeout=None, attrs=None, lazy=False, events=None, epoch=None, output="samples",
    every=1, percentiles=None, nominal=None, reference=None, boresight=None,
    max_output_size=1e9, on_estimate=None, commands=None, software=None, seed=None,
    _source=None, _member_vars=None,
)  # fmt: skip


def build(body=I, q0=Q, Q0=Q0, t=T, potential=None, **kw):
    a = {**ARGS, **kw}
    return EnsembleSpec.build(
        body, q0, Q0, t, potential, a.pop("method"), a.pop("rtol"), a.pop("atol"), **a
    )


def craft():
    return attitude.Spacecraft(attitude.RigidBody(I), [ReactionWheel([1.0, 0.0, 0.0], 0.01)])


def test_rigid_members_and_their_method():
    s = build(potential=HeavyTop(0.5, [0.0, 0.0, 1.0]))
    assert not s.spacecraft and isinstance(s.members, _Members) and s.members.n == 3
    assert (s.requested, s.method) == ("auto", "taylor")
    assert s.plan.output == "samples" and np.array_equal(s.plan.kernel_t, T)
    assert build(events=[lambda t, q, w: 1.0]).method == "dop853"


def test_spacecraft_members_are_prepared_as_their_single_runs():
    s = build(body=craft(), seed=4)
    assert s.spacecraft and isinstance(s.members, CraftMembers)
    assert s.method == "taylor" and s.members.n_state == 9
    assert s.run_attrs["spacecraft"] == craft().describe()
    assert int(s.run_attrs["ensemble_seed"]) == 4


@pytest.mark.parametrize(
    ("kw", "exc", "match"),
    [
        (dict(method="splitting"), AttitudeValueError, r"^method: propagate_ensemble runs"),
        (dict(rtol=0.5), AttitudeValueError, r"^rtol"),
        (dict(max_step=1e-6, max_steps=10), AttitudeValueError, r"^max_step: 1e-06 over"),
        (dict(chunk_size=0), AttitudeValueError, r"^chunk_size"),
        (dict(progress=1), AttitudeTypeError, r"^progress: expected a callable"),
        (dict(attrs=[1]), AttitudeTypeError, r"^attrs: expected a dict"),
        (dict(output="all"), AttitudeValueError, r"^output: expected one of"),
        (dict(on_estimate=1), AttitudeTypeError, r"^on_estimate: expected a callable"),
        (dict(seed=3), AttitudeValueError, r"^seed: the ensemble seed of noisy sensors"),
        (dict(nominal=([1, 0, 0, 0], Q0), reference=[1, 0, 0, 0]), AttitudeValueError,
         r"^nominal, reference: give one"),
        (dict(output="statistics"), AttitudeValueError, r"^nominal: output='statistics'"),
        (dict(boresight=[1, 0, 0]), AttitudeValueError, r"^boresight: only with"),
        (dict(method="taylor", events=[lambda t, q, w: 1.0]), AttitudeValueError, r"^events"),
        (dict(q0=[1.0, 0, 0, 0]), AttitudeValueError, r"^q0, Q0: both have shape \(4,\)"),
    ],
)  # fmt: skip
def test_bad_arguments_are_named(kw, exc, match):
    with pytest.raises(exc, match=match):
        build(**kw)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        (dict(client="tcp://localhost:1"), r"^client: Dask clusters run rigid-body"),
        (dict(lazy=True), r"^lazy: a lazy Dask result is for rigid-body"),
        (dict(output="statistics"), r"^output: a spacecraft ensemble stores its members"),
        (dict(t=T[::-1]), r"^t: a spacecraft with actuators is propagated forward"),
        (dict(potential=[None, None, None]), r"^potential: a spacecraft ensemble runs one"),
        (dict(body=[craft(), craft()]), r"^bodies_or_body: 2 spacecraft for 3 members"),
    ],
)
def test_what_a_spacecraft_ensemble_refuses(kw, match):
    with pytest.raises(AttitudeValueError, match=match):
        build(**{"body": craft(), **kw})

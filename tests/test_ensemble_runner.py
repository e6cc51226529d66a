"""The ensemble runner (attitude.ensemble._runner): one chunk loop for rigid bodies and
spacecraft; a one-member ensemble is its single run bit for bit, whatever the kind; the chunk
size does not change a member; failures name the members and keep the others."""

from __future__ import annotations

import numpy as np
import pytest

import attitude
from attitude import propagate
from attitude.actuators import ReactionWheel
from attitude.ensemble import _runner, propagate_ensemble
from attitude.errors import PropagationError
from attitude.potentials import HeavyTop

I = [1.25, 1.0, 0.75]
Q0 = np.array([0.0, 0.3, 0.2, 0.1])
T = np.linspace(0.0, 5.0, 11)
POT = HeavyTop(0.5, [0.0, 0.0, 1.0])
NAMES = ("q", "Q", "omega", "g", "G", "energy", "norm_error", "qQ")


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_a_one_member_ensemble_is_its_single_run_bit_for_bit(method):
    ens = propagate_ensemble(I, [[1.0, 0, 0, 0]], Q0, T, POT, method=method)
    one = propagate(I, [1.0, 0, 0, 0], Q0, T, POT, method=method)
    for v in NAMES:
        assert np.array_equal(ens[v].values[0], one[v].values), v
    assert int(ens.member_n_steps[0]) == one.attrs["n_steps"]
    assert ens.attrs["run_status"] == "complete" and ens.attrs["n_members_failed"] == 0


def test_a_one_member_spacecraft_ensemble_is_its_single_run_bit_for_bit():
    craft = attitude.Spacecraft(
        attitude.RigidBody(I), [ReactionWheel([1.0, 0.0, 0.0], 0.01, speed=5.0)]
    )
    sched = attitude.CommandSchedule([0.0, 2.0], wheel_torque=[[0.01], [-0.02]])
    # torque-free: the drivers other tests compile (a heavy top's cost 57 s of a cold suite)
    ens = propagate_ensemble(craft, [[1.0, 0, 0, 0]], Q0, T, commands=sched, method="dop853")
    one = propagate(craft, [1.0, 0, 0, 0], Q0, T, commands=sched, method="dop853")
    for v in (*NAMES, "wheel_speed"):
        assert np.array_equal(ens[v].values[0], one[v].values), v
    assert ens.attrs["run_status"] == "complete"


def test_chunks_do_not_change_members_and_failures_keep_the_others():
    q0 = np.tile([1.0, 0.0, 0.0, 0.0], (5, 1))
    Q = np.array([Q0 * (1.0 + 0.1 * k) for k in range(5)])
    a = propagate_ensemble(I, q0, Q, T, POT, method="dop853", chunk_size=2)
    b = propagate_ensemble(I, q0, Q, T, POT, method="dop853")
    assert int(a.attrs["chunk_size"]) == 2
    for v in NAMES:
        assert np.array_equal(a[v].values, b[v].values), v
    with pytest.raises(PropagationError, match=r"member\(s\) 0-4 failed .* other members") as e:
        propagate_ensemble(I, q0, Q, T, POT, method="dop853", max_steps=3, chunk_size=2)
    assert e.value.partial.sizes["member"] == 5


def test_the_default_chunk():
    assert _runner._default_chunk(10_000, 100, 2, "dop853") == 500  # about 20 chunks
    assert _runner._default_chunk(100, 100, 4, "dop853") == 64  # 16 a thread at least
    assert _runner._default_chunk(10**6, 10**5, 2, "taylor") == 2  # 32 MiB of output at most

"""The results builder of the run pipeline (attitude._run.results): a RunResult to the
Dataset or Trajectory propagate returns, and a failed run to a PropagationError whose partial
holds the samples computed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from attitude import propagate
from attitude._methods import RunResult
from attitude._run import results, runner
from attitude._run.spec import RunSpec
from attitude.errors import PropagationError
from attitude.results import Trajectory
from orbit import _rk as rk

I = [1.25, 1.0, 0.75]
Q0 = [0.0, 0.3, 0.2, 0.1]
T = np.linspace(0.0, 2.0, 9)


def spec(method="dop853", **kw):
    a = dict(
        max_step=math.inf, max_steps=100_000_000, progress=None, chunk=None,
        formulation="canonical", on_chunk=None, epoch=None, events=None, output="dataset",
        commands=None, software=None, max_output_size="auto",
    )  # fmt: skip
    a.update(kw)
    return RunSpec.single(I, [1.0, 0, 0, 0], Q0, T, None, method, 1e-10, 1e-12, None, 4, **a)


def test_the_dataset_and_the_arrays_are_propagate_s():
    s = spec("auto")
    ds = results.build(s, runner.run(s))
    ref = propagate(I, [1.0, 0, 0, 0], Q0, T)
    assert ds.attrs["method"] == "taylor" and ds.attrs["method_requested"] == "auto"
    assert ds.attrs["initial_projection"] == 0.0 and isinstance(ds.attrs["n_steps"], np.int64)
    for v in ("q", "Q", "omega", "energy"):
        assert np.array_equal(ds[v].values, ref[v].values), v
    s = spec("auto", output="arrays")
    tr = results.build(s, runner.run(s))
    assert isinstance(tr, Trajectory) and np.array_equal(tr.q, ref.q.values)


def test_a_failed_run_raises_with_its_partial():
    s = spec()
    good = runner.run(s)
    failed = RunResult(good.y[:4], rk.NONFINITE, "the state became non-finite", good.stats)
    msg = r"t = 0.75: the state became non-finite \(4 of 9"
    with pytest.raises(PropagationError, match=msg) as err:
        results.build(s, failed)
    assert err.value.partial.sizes["time"] == 4 and err.value.time == 0.75
    assert np.array_equal(err.value.partial.q.values, good.y[:4, :4])
    # how a run ended is on every Dataset: a complete one says so; a partial one does not
    assert results.build(s, good).attrs["status"] == "success"
    assert "status" not in err.value.partial.attrs


def test_finished_samples_are_handed_out_in_chunks_when_not_streamed():
    parts = []
    s = spec(formulation="euler_equations", on_chunk=parts.append, chunk=4)
    assert not s.plan.streaming
    ds = results.build(s, runner.run(s))
    assert [p.sizes["time"] for p in parts] == [4, 4, 1]
    assert np.array_equal(np.concatenate([p.q.values for p in parts]), ds.q.values)

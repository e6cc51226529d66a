"""The runner of the run pipeline (attitude._run.runner): a validated run through its method,
with a progress bar, streamed chunks or a formulation, bit for bit the samples propagate
returns."""

from __future__ import annotations

import math

import numpy as np
import pytest

from attitude import propagate
from attitude._run import runner
from attitude._run.spec import RunSpec
from attitude.potentials import HeavyTop
from orbit import _rk as rk

I = [1.25, 1.0, 0.75]
Q0 = [0.0, 0.3, 0.2, 0.1]
T = np.linspace(0.0, 5.0, 21)
POT = HeavyTop(0.5, [0.0, 0.0, 1.0])


def spec(method="auto", **kw):
    a = dict(
        max_step=math.inf, max_steps=100_000_000, progress=None, chunk=None,
        formulation="canonical", on_chunk=None, epoch=None, events=None, output="dataset",
        commands=None, software=None, max_output_size="auto",
    )  # fmt: skip
    a.update(kw)
    return RunSpec.single(I, [1.0, 0, 0, 0], Q0, T, POT, method, 1e-10, 1e-12, None, 4, **a)


@pytest.mark.parametrize(
    "kw",
    [dict(method="dop853"), dict(method="taylor"), dict(method="dop853", formulation="schwab")],
    ids=["dop853", "taylor", "schwab"],
)
def test_the_runner_gives_propagate_s_samples_bit_for_bit(kw):
    result = runner.run(spec(**kw))
    assert result.status == rk.SUCCESS and result.first == 0
    ds = propagate(I, [1.0, 0, 0, 0], Q0, T, POT, **kw)
    assert np.array_equal(result.y[:, :4], ds.q.values)
    assert np.array_equal(result.y[:, 4:8], ds.Q.values)
    assert result.stats["n_steps"] == ds.attrs["n_steps"]


def test_streamed_chunks_and_progress_reports():
    parts, calls = [], []
    s = spec("dop853", on_chunk=parts.append, chunk=5, progress=lambda *a: calls.append(a))
    result = runner.run(s)
    assert [p.sizes["time"] for p in parts] == [5, 5, 5, 5, 1]
    assert result.first + result.y.shape[0] == T.shape[0]
    assert parts[0].attrs["method"] == "dop853" and "method_requested" not in parts[0].attrs
    assert calls and calls[-1][:2] == (21, 21)
    ref = propagate(I, [1.0, 0, 0, 0], Q0, T, POT, method="dop853")
    got = np.concatenate([p.q.values for p in parts])
    assert np.array_equal(got, ref.q.values)
    assert runner.chunk_attrs(spec())["method_requested"] == "auto"

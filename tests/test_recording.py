"""What a closed-loop run records of its flight software (issue 39): by default the ticks in
effect at the output samples; tick-level telemetry on request, streamed to files in compressed
chunks; results too large for memory refused before any work, with remedies that work."""

from __future__ import annotations

import math

import astropy.units as u
import netCDF4
import numpy as np
import pytest
from test_software import hr16_spacecraft

import attitude
from attitude import canonical as C
from attitude import frames, io
from attitude import quaternion as qt
from attitude._memory import check_run_memory, parse_size
from attitude.control import MRPFeedback
from attitude.errors import AttitudeTypeError, AttitudeValueError, OutputSizeError
from attitude.software import FlightSoftware
from attitude.software._software import tick_count, ticks_at

Q0_MRP = [0.1, 0.2, -0.3]


def _case():
    craft = hr16_spacecraft()
    q0 = qt.from_mrp(Q0_MRP)
    Q0 = C.momenta_from_angular_velocity(q0, [0.001, -0.01, 0.03], craft)
    return craft, q0, Q0


def _fsw(every=None, period=0.1, **kw):
    return FlightSoftware(
        period, frames.inertial(), MRPFeedback(3.5, 30.0), record_every=every, **kw
    )


TICK_VARS = ("mode", "reference_q", "sigma_error", "error_angle", "rate_error",
             "torque_request", "command_sent", "command_applied")  # fmt: skip


def test_default_records_the_tick_in_effect_at_each_sample():
    """Default recording against every tick of the same run: at each output time the record is
    that of the last tick at or before it (found here by searchsorted on every tick's time), bit
    for bit; the trajectory is the same bits; samples before the first tick (a phase) have none;
    two samples in one tick interval share its record once."""
    craft, q0, Q0 = _case()
    # samples off the tick grid, two in one interval (3.01, 3.05), one before the phase's tick
    t = np.array([0.0, 0.02, 0.5, 3.01, 3.05, 7.333, 12.0, 19.96, 20.0])
    for phase in (0.0, 0.03):
        every = attitude.propagate(craft, q0, Q0, t, software=_fsw(1, phase=phase), rtol=1e-12)
        dflt = attitude.propagate(craft, q0, Q0, t, software=_fsw(phase=phase), rtol=1e-12)
        np.testing.assert_array_equal(dflt.q.values, every.q.values)
        tk = every.tick.values
        k = np.searchsorted(tk, t, side="right") - 1
        k = np.unique(k[k >= 0])
        np.testing.assert_array_equal(dflt.tick.values, tk[k])
        # by hand: ticks 0, 5, 30, 73, 120, 199 (0 and 0.02 s share tick 0, 3.01 and 3.05
        # tick 30, 19.96 and 20 tick 199); with the phase none, 4, 29, 30, 73, 119, 199
        assert dflt.sizes["tick"] == 6
        for v in TICK_VARS:
            np.testing.assert_array_equal(dflt[v].values, every[v].values[k], err_msg=v)
        assert dflt.attrs["n_ticks"] == every.attrs["n_ticks"] == tk.size


def test_tick_indices_are_the_compiled_loops_arithmetic():
    """tick_count and ticks_at against brute force on the loop's own expression
    t_k = t0 + k·period (float64), at random t0, periods and sample times, including samples on
    tick times exactly and the span's end (no tick at t_end)."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        t0 = float(rng.choice([0.0, rng.uniform(-1e4, 1e4)]))
        per = float(rng.choice([0.1, 1 / 3, rng.uniform(1e-3, 10.0)]))
        t_end = t0 + float(rng.uniform(0.0, 200.0)) * per
        k = np.arange(int((t_end - t0) / per) + 3)
        tk = t0 + k * per
        n = int(np.sum(tk < t_end))
        assert tick_count(t0, per, t_end) == n
        ts = np.sort(np.concatenate([rng.uniform(t0 - per, t_end, 20), tk[:n:7], [t_end]]))
        got = ticks_at(t0, per, n, ts, block=8)
        want = np.searchsorted(tk[:n], ts, side="right") - 1
        np.testing.assert_array_equal(got, np.unique(want[want >= 0]))


def test_record_every_choices():
    assert _fsw(None).record_every is None and _fsw("samples").record_every is None
    assert _fsw(60 * u.s).record_every == 600
    assert _fsw(3).record_every == 3
    assert FlightSoftware(2 * u.Hz, record_every=1 * u.min).record_every == 120
    with pytest.raises(AttitudeValueError, match=r"record_every: .*whole number of periods"):
        _fsw(0.25 * u.s)
    with pytest.raises(AttitudeValueError, match=r"record_every: .*shorter than the period"):
        _fsw(0.01 * u.s)
    with pytest.raises(AttitudeTypeError, match="record_every: expected a time"):
        _fsw(3 * u.m)
    with pytest.raises(AttitudeValueError, match="record_every: 'tick' is not"):
        _fsw("tick")
    with pytest.raises(AttitudeValueError, match=r"record_every: .*2\^53"):
        _fsw(2**70)
    with pytest.raises(AttitudeValueError, match="record_every"):
        _fsw(0)


def test_a_day_as_a_user_writes_it_is_small():
    """Basilisk's reaction-wheel day with 101 samples and the default recording: 101 ticks, the
    result under 1 MB; the ticks are those of a run recording every 600th tick where both
    record one (the samples are 864 s apart: every 8640th tick)."""
    craft, q0, Q0 = _case()
    t = np.linspace(0.0, 86400.0, 101)
    ds = attitude.propagate(craft, q0, Q0, t, software=_fsw())
    assert ds.sizes["tick"] == 101 and ds.nbytes < 1e6
    ref = attitude.propagate(craft, q0, Q0, t, software=_fsw(600))
    assert ref.attrs["n_ticks"] == ds.attrs["n_ticks"] == 864_000
    np.testing.assert_array_equal(ds.q.values, ref.q.values)
    # the last k with k·0.1 <= t_j in float64 (8640 j · 0.1 rounds above 864 j for some j)
    k = [int(x / 0.1) + 1 for x in t]
    k = np.array(
        [next(m for m in (kk, kk - 1, kk - 2) if m * 0.1 <= x) for kk, x in zip(k, t, strict=True)]
    )
    k[-1] = 863_999  # no tick at the span's end
    np.testing.assert_array_equal(ds.tick.values, k * 0.1)
    common = k % 600 == 0
    assert common.sum() >= 10
    for v in TICK_VARS:
        np.testing.assert_array_equal(ds[v].values[common], ref[v].values[k[common] // 600], v)


def _file_layout(path):
    """{variable: (chunk sizes, zlib)} of every variable along time or tick."""
    with netCDF4.Dataset(path) as nc:
        return {
            name: (v.chunking(), v.filters()["zlib"])
            for name, v in nc.variables.items()
            if "time" in v.dimensions or "tick" in v.dimensions
        }


def test_tick_telemetry_streams_to_a_file_in_compressed_chunks(tmp_path):
    """Every tick streamed (StreamWriter through on_chunk) and the same run in memory written
    with io.write: both files read back equal to the in-memory Dataset bit for bit; every
    sample and tick variable in zlib chunks of 4096 along its growing dimension; the tick
    buffer in memory is one chunk (records handed out as they fill it)."""
    craft, q0, Q0 = _case()
    t = np.linspace(0.0, 1500.0, 151)
    ds = attitude.propagate(craft, q0, Q0, t, software=_fsw(1), rtol=1e-12)
    assert ds.sizes["tick"] == 15000
    io.write(ds, tmp_path / "mem.nc")
    seen = []
    with io.StreamWriter(tmp_path / "stream.nc") as w:

        def sink(chunk):
            seen.append((chunk.sizes.get("time", 0), chunk.sizes.get("tick", 0)))
            w.append(chunk)

        last = attitude.propagate(
            craft, q0, Q0, t, software=_fsw(1), rtol=1e-12, on_chunk=sink, chunk=50
        )
        w.attrs.update(last.attrs)
    assert w.n_ticks == 15000 and w.n == 151
    assert max(k for _, k in seen) == 4096 and sum(k for _, k in seen) == 15000
    assert all(n == 0 or k == 0 for n, k in seen)  # tick chunks are Datasets of their own
    for name in ("mem.nc", "stream.nc"):
        back = io.read(tmp_path / name)
        for v in ds.variables:
            assert back[v].dims == ds[v].dims, (name, v)
            np.testing.assert_array_equal(back[v].values, ds[v].values, err_msg=f"{name} {v}")
        layout = _file_layout(tmp_path / name)
        assert {"error_angle", "command_applied", "tick", "q", "time"} <= set(layout)
        for v, (chunks, zlib) in layout.items():
            assert zlib, (name, v)
            assert chunks != "contiguous" and chunks[0] == 4096, (name, v, chunks)


def test_a_result_too_large_for_memory_is_refused_before_any_work_and_its_remedies_work(tmp_path):
    """An hour at 10 Hz with every tick against a 2 MB limit: refused (OutputSizeError naming
    max_output_size, the estimate and each remedy) before any work; then each remedy the
    message names, tried under the same limit: the default recording, streaming to a file,
    a raised limit."""
    craft, q0, Q0 = _case()
    t = np.linspace(0.0, 3600.0, 61)
    with pytest.raises(OutputSizeError) as info:
        attitude.propagate(craft, q0, Q0, t, software=_fsw(1), max_output_size="2 MB")
    msg = str(info.value)
    assert msg.startswith("max_output_size: ") and "36000 tick records" in msg
    assert info.value.expected > info.value.limit == 2e6
    assert "record_every=None" in msg and "StreamWriter" in msg and "max_output_size='20 GB'" in msg
    ok = attitude.propagate(craft, q0, Q0, t, software=_fsw(None), max_output_size="2 MB")
    assert ok.sizes["tick"] == 61
    with io.StreamWriter(tmp_path / "run.nc") as w:
        attitude.propagate(craft, q0, Q0, t, software=_fsw(1), max_output_size="2 MB",
                           on_chunk=w.append)  # fmt: skip
    assert w.n_ticks == 36000
    big = attitude.propagate(craft, q0, Q0, t, software=_fsw(1), max_output_size="20 GB")
    assert big.sizes["tick"] == 36000
    # the estimate bounds what the result takes
    assert big.nbytes < info.value.expected


def test_memory_estimate_and_limit_parsing():
    assert parse_size("2 GB") == 2e9 and parse_size(None) == math.inf
    with pytest.raises(AttitudeValueError, match="max_output_size"):
        parse_size("-1 GB")
    # samples dominate: the advice is fewer samples or streaming, not record_every
    with pytest.raises(OutputSizeError) as info:
        check_run_memory(1e6, 10**6, 8, 0, 0, every=None, streamable=True)
    assert "fewer output samples" in str(info.value) and "record_every" not in str(info.value)
    # a run that cannot stream (events, another formulation) is not told to stream
    with pytest.raises(OutputSizeError) as info:
        check_run_memory(1e6, 10**6, 8, 0, 0, every=None, streamable=False)
    assert "StreamWriter" not in str(info.value)
    assert check_run_memory(1e9, 100, 8, 100, 25, every=1, streamable=True) < 1e6


def test_the_command_reports_memory_exhaustion_as_bad_input(tmp_path, monkeypatch, capsys):
    """A MemoryError that escapes the estimates is exit 2 with what to ask for less of, never
    exit 1 with numpy's message; no output file."""
    from pathlib import Path

    from attitude.cli import main
    from attitude.scenario import _scenario

    def exhausted(self, *a, **k):
        raise MemoryError("Unable to allocate 3.12 GiB for an array")

    monkeypatch.setattr(_scenario.Scenario, "run_to_file", exhausted)
    toml = Path(__file__).parents[1] / "scenarios" / "rw_inertial_pointing.toml"
    out = tmp_path / "rw.nc"
    assert main(["run", str(toml), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "out of memory" in err and "record_every" in err and "Traceback" not in err
    assert not out.exists() and not list(tmp_path.iterdir())


def test_a_control_law_subclass_is_refused_not_zero_torque():
    """Issue 40's silent trap: a user subclass of ControlLaw compiled to zero torque; a
    subclass of a built-in law would run the parent's kernel, never its own code. Both are
    refused, naming what works; the built-in laws themselves are accepted."""
    from attitude.control import ControlLaw, RateDamping

    class Mine(ControlLaw):
        def torque(self, sigma, omega):
            return -sigma

    class Tuned(MRPFeedback):
        pass

    for law in (Mine(), Tuned(3.5, 30.0)):
        with pytest.raises(AttitudeTypeError, match=r"control: .* subclasses .*step\(t, meas"):
            FlightSoftware(0.1, frames.inertial(), law)
        with pytest.raises(AttitudeTypeError, match="control: "):
            FlightSoftware(0.1, frames.inertial(), (law,))
    for law in (MRPFeedback(3.5, 30.0), RateDamping(2.0)):
        assert FlightSoftware(0.1, frames.inertial(), law).modes[0][1].control is law


def test_a_closed_loop_ensembles_size_error_names_remedies_that_work():
    """Issue 43: the ensemble's limit error suggested output='statistics' (refused for a
    spacecraft ensemble) and never the flight software's recording. Now every remedy it names
    is tried on the ensemble at hand and fits under the same limit (every=K as estimated:
    about the smallest K that does); statistics are never named for a spacecraft ensemble."""
    import re

    from attitude.ensemble import propagate_ensemble

    craft, q0, Q0 = _case()
    Qs = np.tile(Q0, (8, 1))
    t = np.linspace(0.0, 60.0, 61)  # 600 ticks

    def run(record, limit, **kw):
        return propagate_ensemble(craft, q0, Qs, t, software=_fsw(record), method="dop853",
                                  max_output_size=limit, **kw)  # fmt: skip

    named = set()
    for record, limit in ((1, "500 kB"), (1, "1.2 MB"), (None, "300 kB")):
        with pytest.raises(OutputSizeError) as info:
            run(record, limit)
        msg = str(info.value)
        assert "statistics" not in msg and "max_output_size='10 GB'" in msg
        if "record_every=None" in msg:
            named.add("record_every")
            assert record == 1
            run(None, limit)
        if "output='final'" in msg:
            named.add("final")
            assert run(record, limit, output="final").sizes["time"] == 1
        m = re.search(r"every=(\d+) or more", msg)
        if m:
            named.add("every")
            k = int(m.group(1))
            run(record, limit, every=k)
    assert named == {"record_every", "final", "every"}

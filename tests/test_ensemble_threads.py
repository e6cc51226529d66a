"""attitude/ensemble/_threads.py: the threads that run an ensemble's compiled drivers.

Every index runs, a paused block is requeued until it is done, blocks of consecutive indices
go to whichever thread is free, and a failure or an interrupt request stops the queue and is
raised in the calling thread (the ensemble tests check the members' bits through it)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from attitude import _interrupt
from attitude.ensemble import _threads


@pytest.mark.parametrize("n_threads", [1, 2, 3])
def test_every_block_runs_until_it_is_done(n_threads):
    n, block = 103, 8
    need = np.arange(n) % 4 + 1  # calls each index needs (a member paused at its budget)
    calls = np.zeros(n, dtype=int)
    seen = set()

    def body(a, b):
        assert b - a <= block and (a % block == 0) and b == min(n, a + block)
        calls[a:b] += 1
        seen.add(threading.get_ident())
        time.sleep(1e-4)  # (let the other threads take blocks)

    def more(a, b):
        return bool(np.any(calls[a:b] < need[a:b]))

    _threads.on_blocks(n_threads, n, body, block, more)
    # each block runs until its slowest index is done, never once more
    expect = np.repeat([need[a : a + block].max() for a in range(0, n, block)], block)[:n]
    np.testing.assert_array_equal(calls, expect)
    assert len(seen) <= n_threads
    if n_threads == 2:  # the blocks are spread (a third thread may find nothing left)
        assert len(seen) == 2


def test_without_more_each_index_runs_once():
    hits = np.zeros(50, dtype=int)
    _threads.on_threads(2, 50, lambda i: hits.__setitem__(i, hits[i] + 1), block=3)
    assert hits.tolist() == [1] * 50


def test_block_size_is_at_least_the_chunk_and_about_32_a_thread():
    assert _threads.block_size(10, 2) == _threads.PARALLEL_CHUNK
    assert _threads.block_size(6400, 2) == 100
    assert _threads.block_size(6401, 2) == 101


def test_a_failing_block_stops_the_queue_and_raises_in_the_caller():
    started = []

    def body(a, b):
        started.append(a)
        if a == 16:
            raise ZeroDivisionError("member 16")
        time.sleep(1e-3)

    with pytest.raises(ZeroDivisionError, match="member 16"):
        _threads.on_blocks(2, 8000, body, 8, lambda a, b: True)  # (never done by itself)
    assert len(started) < 50  # the queue stopped: not all 1000 blocks, not forever


def test_an_interrupt_request_ends_the_calls_and_is_raised():
    calls = []

    def body(a, b):
        calls.append(a)
        if len(calls) == 5:
            _interrupt.request()

    try:
        with pytest.raises(KeyboardInterrupt):
            _threads.on_blocks(2, 1000, body, 1, lambda a, b: True)
    finally:
        _interrupt.clear()
    assert len(calls) < 20  # each thread ends the call it is in, and no block is taken after


def test_thread_count_is_the_argument_else_numbas():
    import numba

    assert _threads.thread_count(3) == 3
    assert _threads.thread_count(None) == numba.get_num_threads()

"""The threads that run an ensemble's compiled drivers (a chunk's member blocks, or its batch
integrators' groups): Python threads calling kernels that release the GIL, started once per
process and reused. numba's ``parallel`` is not used: its parfor passes cost seconds of every
first compile, and a loop body inlined into them once lost its writes (the Taylor gyrostat
lanes, every member stopped at t0)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .. import _interrupt

__all__ = ["PARALLEL_CHUNK", "block_size", "on_blocks", "on_threads", "thread_count"]

#: Fewest members handed to a thread at a time (each call costs a few microseconds of Python).
PARALLEL_CHUNK = 8

_POOL: list[Any] = []  # [ThreadPoolExecutor, its size]: started once, reused by every chunk


def _pool(n_threads: int) -> Any:
    """The process's worker threads for chunks (at least ``n_threads`` of them; a chunk of a
    few milliseconds would otherwise spend a tenth of its time starting threads)."""
    from concurrent.futures import ThreadPoolExecutor

    if not _POOL or _POOL[1] < n_threads:
        if _POOL:
            _POOL[0].shutdown(wait=False)
        _POOL[:] = [ThreadPoolExecutor(n_threads, thread_name_prefix="attitude-ensemble"),
                    n_threads]  # fmt: skip
    return _POOL[0]


def on_blocks(
    n_threads: int,
    n: int,
    body: Callable[[int, int], None],
    block: int = 8,
    more: Callable[[int, int], bool] | None = None,
) -> None:
    """``body(a, b)`` over the blocks ``a..b-1`` of ``block`` consecutive indices in 0..n-1, on
    ``n_threads`` threads (``body`` calls compiled code that releases the GIL), each block to
    whichever thread is free: a thread that gets less CPU, or slower members, does not hold the
    others up. A block for which ``more(a, b)`` is true (members paused at their step budget)
    goes back in the queue, so the threads never wait for each other before the last block.
    An interrupt (:func:`attitude._interrupt.check` after each call, or Ctrl-C in the calling
    thread) lets every thread finish its call and requeue nothing; it is raised here."""
    import threading
    from collections import deque

    queue = deque((a, min(n, a + block)) for a in range(0, n, block))
    cond = threading.Condition()
    busy = [0]
    stop: list[BaseException | None] = []

    def worker():
        while True:
            with cond:
                while not queue and busy[0] and not stop:
                    cond.wait()
                if stop or not queue:
                    return
                a, b = queue.popleft()
                busy[0] += 1
            again = False
            try:
                body(a, b)
                again = more is not None and more(a, b)
                _interrupt.check()  # between compiled calls, as a single run
            except BaseException as exc:  # raised again by the calling thread
                with cond:
                    stop.append(exc)
            finally:
                with cond:
                    busy[0] -= 1
                    if again and not stop:
                        queue.append((a, b))
                    cond.notify_all()

    if n_threads <= 1:
        worker()
        if stop:
            raise stop[0]
        return
    from concurrent.futures import wait

    jobs = [_pool(n_threads).submit(worker) for _ in range(n_threads)]
    try:
        # (a timeout: the signal may reach a worker thread, and this thread runs Python's
        # handler only when it wakes)
        while wait(jobs, timeout=0.05).not_done:
            pass
    except BaseException:  # Ctrl-C in this thread: the others end their calls, then it is raised
        with cond:
            stop.append(None)
            cond.notify_all()
        for job in jobs:
            job.exception()
        raise
    errors = [e for e in stop if e is not None]
    if errors:
        raise errors[0]


def block_size(n: int, n_threads: int) -> int:
    """Members per call of a serial driver: about 32 blocks a thread (the last call of a chunk
    is short), at least :data:`PARALLEL_CHUNK` (each call costs a few microseconds of Python,
    under the GIL)."""
    return max(PARALLEL_CHUNK, -(-n // (32 * max(1, n_threads))))


def on_threads(
    n_threads: int,
    n: int,
    body: Callable[[int], None],
    block: int = 1,
    more: Callable[[int], bool] | None = None,
) -> None:
    """``body(i)`` for i in 0..n-1 as :func:`on_blocks` runs its blocks (``more(i)``: index i
    needs another call)."""

    def run(a, b):
        for i in range(a, b):
            body(i)

    again = None if more is None else (lambda a, b: any(more(i) for i in range(a, b)))
    on_blocks(n_threads, n, run, block, again)


def thread_count(threads: int | None) -> int:
    """The threads of a local run: ``threads``, else numba's count (the cores; 1 without the
    JIT)."""
    from orbit._shared_jit import JIT_DISABLED

    if threads is not None:
        return int(threads)
    if JIT_DISABLED:
        return 1
    import numba

    return numba.get_num_threads()

"""Running chunks as Dask tasks: connecting to a scheduler, lazy graphs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from orbit import _rk

from ..errors import AttitudeError, AttitudeTypeError, AttitudeValueError, PropagationError
from ._chunks import _N_DIAG, _chunk_task, _compute_chunk, _failure_message, _Setup

#: Seconds to wait for a Dask scheduler to answer.
SCHEDULER_TIMEOUT = 10.0

# ------------------------------------------------------------------------------------------------
# Dask
# ------------------------------------------------------------------------------------------------


def _connect(client: Any, timeout: float):
    """(client, owned): a connected ``distributed.Client`` (``owned``: we must close it)."""
    try:
        import distributed
    except ImportError:
        raise AttitudeValueError(
            "client: Dask is not installed; install the optional extra "
            "(pip install 'attitude[dask]') or run without a client (local threads)"
        ) from None
    if isinstance(client, str):
        try:
            return distributed.Client(client, timeout=timeout, set_as_default=False), True
        except Exception as exc:  # OSError, TimeoutError, ValueError (bad address)...
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise AttitudeValueError(
                f"scheduler: no Dask scheduler answered at {client!r} within {timeout:g} s "
                f"({type(exc).__name__}: {msg}); check the address (e.g. tcp://host:8786) "
                "and that the scheduler is running. Nothing was written."
            ) from None
    if not isinstance(client, distributed.Client):
        raise AttitudeTypeError(
            f"client: expected a dask.distributed.Client or a scheduler address string, got "
            f"{type(client).__name__}"
        )
    if client.status not in ("running", "newly-created"):
        raise AttitudeValueError(f"client: the Dask client is {client.status}, not running")
    return client, False


def _worker_threads(client) -> int:
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # pragma: no cover - scheduler gone: the tasks will say so
        return 1


def _dask_results(client, setup, members, bounds, n_threads):
    """Chunks as Dask tasks, a bounded window in flight, results yielded in member order."""
    from collections import deque

    window = max(2, 2 * n_threads)
    setup_f = client.scatter(setup, broadcast=True, hash=False)
    pending: deque = deque()
    nxt = 0
    while pending or nxt < len(bounds):
        while nxt < len(bounds) and len(pending) < window:
            start, stop = bounds[nxt]
            params, y0, inertia, corr = members.block(start, stop)
            fut = client.submit(
                _chunk_task, setup_f, params, y0, pure=False, priority=-nxt, retries=0
            )
            pending.append((fut, inertia, corr))
            nxt += 1
        fut, inertia, corr = pending.popleft()
        try:
            out = fut.result()
        except Exception as exc:  # this chunk's task failed: the others go on
            yield exc
            continue
        finally:
            fut.release()
        yield out, inertia, corr


def _lazy_task(setup: _Setup, params: np.ndarray, y0: np.ndarray, start: int):
    """A chunk as a task of the lazy graph: raises if a member failed (naming it)."""
    out = _compute_chunk(setup, params, y0, parallel=False)
    bad = np.flatnonzero((out["status"] != _rk.SUCCESS) & (out["status"] != _rk.EVENT))
    if bad.size:
        msg, t_fail = _failure_message(out, bad, start, setup.t)
        raise PropagationError(msg, time=t_fail)
    return out


def _lazy_result(setup, members, bounds, asm) -> xr.Dataset:
    """The ensemble as a dask-backed Dataset: one task per chunk, nothing computed yet."""
    import dask
    import dask.array as dsa

    m = setup.t.shape[0]
    setup_d = dask.delayed(setup, traverse=False)
    parts = []
    for start, stop in bounds:
        params, y0, inertia, corr = members.block(start, stop)
        asm.max_projection = max(asm.max_projection, corr)
        c = stop - start
        task = dask.delayed(_lazy_task, pure=True)(setup_d, params, y0, start)
        out = {
            "y": dsa.from_delayed(task["y"], (c, m, 8), np.float64),
            "diag": dsa.from_delayed(task["diag"], (c, m, _N_DIAG), np.float64),
            "counters": dsa.from_delayed(task["counters"], (c, 5), np.int64),
            "status": dsa.from_delayed(task["status"], (c,), np.int64),
        }
        if setup.events is not None:
            ne = setup.events.n
            out["event_count"] = dsa.from_delayed(task["event_count"], (c, ne), np.int64)
            out["event_first"] = dsa.from_delayed(task["event_first"], (c, ne), np.float64)
        parts.append(asm.dataset(start, out, inertia, lazy=True))
    if len(parts) == 1:
        return parts[0]
    return xr.concat(parts, dim="member", data_vars="minimal", coords="minimal", compat="override")


def _write_lazy(ds: xr.Dataset, path: Path, client: Any) -> None:
    """``ds.to_netcdf`` to a temporary name, computed by ``client`` (or dask), then renamed."""
    from .._files import OutputFile, file_error
    from ..io import check_attrs

    ds = ds.copy()
    ds.attrs = check_attrs(ds.attrs, "attrs")
    out = OutputFile(path, "path")
    out.prepare()
    try:
        # CF: coordinate variables have no _FillValue (xarray adds NaN to floats by default)
        enc = {c: {"_FillValue": None} for c in ds.coords if ds[c].dtype.kind == "f"}
        # labels as character arrays (attitude.io._text_variable says why)
        enc.update({c: {"dtype": "S1"} for c in ds.variables if ds[c].dtype.kind in "UO"})
        job = ds.to_netcdf(out.tmp, engine="netcdf4", format="NETCDF4", compute=False, encoding=enc)
        if client is not None:
            client.compute(job).result()
        else:
            job.compute()
        out.commit()
    except AttitudeError:
        out.discard()
        raise
    except (OSError, RuntimeError) as exc:
        err = file_error(exc, out.target)  # a full disk: before the discard frees it
        out.discard()
        raise err from None
    except BaseException:
        out.discard()
        raise

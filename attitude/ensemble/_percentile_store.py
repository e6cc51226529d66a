"""Statistics-only output: per-member scalars in a bounded store, exact percentiles at the end.

As each chunk of members finishes, two scalars per member and stored time are kept: the
pointing error (the rotation angle from the reference attitude, Arribas et al.'s q read against
``reference_q``: 2 atan2(|vec(q̃_ref∘q)|, |scalar(q̃_ref∘q)|), or the boresight angle) and |ω|.
The store is laid out time-major, shape (2, m, N) float64, 16 bytes per member and time (the
members' trajectories take 168): in memory up to :data:`STORE_MEMORY`, beyond that a temporary
file in a private directory beside the output, removed at the end, also on errors and
interrupts. The file is written from a buffer of :data:`BLOCK_BYTES` (members gathered chunk by
chunk, then one write per time and quantity) and read back with plain file reads, not a memory
map, so that the process's memory stays bounded by the buffers whatever N × m. When the last
chunk is done the store is read back in blocks of output times (about :data:`BLOCK_BYTES` each)
and ``np.percentile`` (NumPy's default "linear" method:
linear interpolation between the order statistics, Hyndman & Fan type 7) is taken over the
members at each time. Nothing is approximated: the result is ``np.percentile`` over the members
of a run that stores every sample, bit for bit (tests/test_ensemble.py).

Members that failed (``member_status != 0``) are left out: NaN in the store, and
``np.nanpercentile`` on the blocks that hold NaN. ``statistics_members`` counts those used.
"""

from __future__ import annotations

import contextlib
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from orbit import _rk

from .statistics import _error_angles

#: Largest store kept in memory (bytes); larger ones go to a temporary file.
STORE_MEMORY = 256 * 2**20
#: Bytes of store buffered before a write, and read at a time when taking the percentiles.
BLOCK_BYTES = 32 * 2**20


class _PercentileStore:
    """Records the per-member scalars of each chunk; :meth:`finish` gives the percentiles.

    Parameters
    ----------
    n : int
        Members of the ensemble.
    t : ndarray, shape (m,)
        The stored output times.
    percentiles : ndarray, shape (P,)
    reference : ndarray, shape (m, 4)
        Reference attitude at the stored times (unit quaternions).
    boresight : ndarray, shape (3,), optional
        Unit body axis: the error is then the angle between the directions it points to.
    scratch : Path, optional
        Directory of the temporary file (default: the system's temporary directory).
    """

    def __init__(self, n, t, percentiles, reference, boresight=None, scratch=None):
        self.n = int(n)
        self.m = int(t.shape[0])
        self.p = np.asarray(percentiles, dtype=np.float64)
        self.reference = np.ascontiguousarray(reference, dtype=np.float64)
        self.boresight = boresight
        self.n_done = 0
        self.n_used = 0
        self.omega_units = "1"
        self._dir: Any = None
        self._file: Any = None
        if 16 * self.m * self.n <= STORE_MEMORY:
            self._a = np.empty((2, self.m, self.n))
        else:  # a file (2, m, N) and a buffer of whole members (2, m, B)
            if scratch is not None:
                Path(scratch).mkdir(parents=True, exist_ok=True)
            self._dir = tempfile.TemporaryDirectory(prefix=".attitude-stats-", dir=scratch)
            self._file = open(Path(self._dir.name) / "members.f8", "w+b")
            self._file.truncate(16 * self.m * self.n)  # sparse: members never written read 0
            width = max(1, min(self.n, BLOCK_BYTES // (16 * self.m)))
            self._a = np.empty((2, self.m, width))
            self._b0 = 0  # first member in the buffer

    @property
    def on_disk(self) -> bool:
        return self._dir is not None

    def add(self, ds: xr.Dataset) -> xr.Dataset:
        """Record a chunk's scalars; return the chunk without its (member, time) variables."""
        start = int(ds["member"].values[0])
        c = ds.sizes["member"]
        if start != self.n_done:  # pragma: no cover - chunks arrive in member order
            raise RuntimeError(f"chunk of members {start}.. out of order")
        q = np.asarray(ds["q"].transpose("member", "time", "component").values)
        w = np.asarray(ds["omega"].transpose("member", "time", "axis").values)
        self.omega_units = str(ds["omega"].attrs.get("units", "1"))
        err = _error_angles(q, self.reference[None, :, :], self.boresight)
        wn = np.sqrt(np.sum(w * w, axis=-1))
        st = np.asarray(ds["member_status"].values)
        ok = (st == _rk.SUCCESS) | (st == _rk.EVENT)  # NaN after a terminal event: skipped
        err[~ok] = np.nan
        wn[~ok] = np.nan
        if self._file is None:
            self._a[0, :, start : start + c] = err.T
            self._a[1, :, start : start + c] = wn.T
        else:
            done = 0
            while done < c:  # fill the buffer, write it out when full
                at = start + done - self._b0
                k = min(c - done, self._a.shape[2] - at)
                self._a[0, :, at : at + k] = err[done : done + k].T
                self._a[1, :, at : at + k] = wn[done : done + k].T
                done += k
                if at + k == self._a.shape[2]:
                    self._flush(at + k)
        self.n_done += c
        self.n_used += int(ok.sum())
        drop = [k for k, v in ds.data_vars.items() if "member" in v.dims and "time" in v.dims]
        return ds.drop_vars(drop)

    def _flush(self, k: int) -> None:
        """Write the buffer's first ``k`` members to the file (one write per time and value)."""
        f, n, m = self._file, self.n, self.m
        for v in (0, 1):
            for r in range(m):
                f.seek(((v * m + r) * n + self._b0) * 8)
                f.write(self._a[v, r, :k].tobytes())
        self._b0 += k

    def _block(self, j: int, b: int) -> np.ndarray:
        """Store values (2, b, n_done) of the output times j..j+b−1."""
        if self._file is None:
            return np.asarray(self._a[:, j : j + b, : self.n_done])
        out = np.empty((2, b, self.n))
        for v in (0, 1):
            self._file.seek(((v * self.m + j) * self.n) * 8)
            got = self._file.readinto(memoryview(out[v]).cast("B"))
            if got != b * self.n * 8:  # pragma: no cover - a regular file reads in full
                raise OSError("short read from the statistics store")
        return out[:, :, : self.n_done]

    def _percentiles_of(self, x: np.ndarray) -> np.ndarray:
        """(P, b) percentiles over the members (axis 1) of the block ``x`` (b, n)."""
        if not np.isnan(x).any():
            return np.percentile(x, self.p, axis=1)
        with warnings.catch_warnings():  # a time at which every member failed: NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            return np.nanpercentile(x, self.p, axis=1)

    def finish(self, time_coord: xr.Variable) -> xr.Dataset:
        """The percentile variables (percentile, time), from the members recorded so far."""
        n = self.n_done
        out = np.full((2, self.p.shape[0], self.m), np.nan)
        if self._file is not None and n > self._b0:
            self._flush(n - self._b0)
            self._file.flush()
        if n:
            b = max(1, BLOCK_BYTES // (16 * self.n))
            for j in range(0, self.m, b):
                blk = self._block(j, min(b, self.m - j))
                for v in (0, 1):
                    out[v, :, j : j + blk.shape[1]] = self._percentiles_of(blk[v])
        kind = "boresight pointing error" if self.boresight is not None else "attitude error angle"
        coords = {
            "percentile": (
                "percentile",
                self.p.copy(),
                {"units": "percent", "long_name": "percentile over members (100: the maximum)"},
            ),
            "time": time_coord,
        }
        data = {
            "pointing_error_percentiles": (
                ("percentile", "time"),
                out[0],
                {
                    "units": "rad",
                    "long_name": f"percentiles over members of the {kind} from reference_q",
                },
            ),
            "omega_norm_percentiles": (
                ("percentile", "time"),
                out[1],
                {
                    "units": self.omega_units,
                    "long_name": "percentiles over members of the angular velocity magnitude",
                },
            ),
        }
        return xr.Dataset(data, coords=coords)

    def attrs(self) -> dict[str, Any]:
        return {
            "statistics_members": np.int64(self.n_used),
            "statistics_method": (
                "exact: every member's pointing error and |omega| at every stored time were "
                "kept, then numpy.percentile (linear interpolation) over the members at each time"
            ),
        }

    def close(self) -> None:
        """Release the store (removes the temporary file)."""
        self._a = None
        if self._file is not None:
            with contextlib.suppress(OSError):
                self._file.close()
            self._file = None
        if self._dir is not None:
            with contextlib.suppress(OSError):
                self._dir.cleanup()
            self._dir = None

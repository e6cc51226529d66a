"""netCDF4 files of propagation results: atomic, compressed, streamable.

:func:`write` stores a result Dataset (docs/results.md) and :func:`read` gives back an identical
one: data bit for bit, every attr with its value and type (str, int64, float64 and float64
arrays; see "Attribute types" below). :class:`StreamWriter` appends chunks of output samples as
they are computed (``propagate(..., on_chunk=writer.append)``), so a run of 10⁷ samples needs
memory for one chunk only.

Atomicity: everything is written to a temporary file beside the target (``.NAME.<pid>.tmp``),
flushed to disk and renamed over the final name only when complete (``os.replace``, atomic on
POSIX and Windows). A crash or interrupt therefore leaves either no file or the previous one
under the final name, never a half-written file. A propagation that fails midway is still
committed, with what it computed and ``run_status = "failed: ..."`` in the attrs.

Attribute types
---------------
netCDF attributes are typed scalars, strings or 1-D arrays. ``str``, ``int`` (int64),
``float`` (float64), numpy scalars and 1-D numeric arrays round-trip exactly. A ``bool`` is
stored as int8 0/1 and ``None`` is dropped (netCDF has neither); anything else is stored as its
``str``. Length-1 arrays come back as scalars (a netCDF convention).

CF
--
Files follow CF-1.10 (``compliance-checker --test=cf:1.10`` reports no errors, tests/test_cf.py):
the attrs of ``time`` follow the global attr ``epoch`` when the file is committed
(:func:`attitude.results.time_attrs`: ``seconds since <epoch>`` with an epoch), and data
variables name their auxiliary label coordinates (``component_label``, ``axis_label``) in a
``coordinates`` attr, which :func:`read` turns back into coordinates.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["StreamWriter", "read", "write"]

#: Samples per netCDF chunk along ``time`` (also the default streaming chunk).
TIME_CHUNK = 4096
#: zlib level: 4 is within ~3 % of the best ratio for these smooth float64 series, 3× faster.
COMPLEVEL = 4


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _attr_value(name: str, value: Any) -> Any:
    """An attr value netCDF4 can store (see the module docstring)."""
    if isinstance(value, (bool, np.bool_)):
        return np.int8(bool(value))
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)):
        return np.int64(value)
    if isinstance(value, (float, np.floating)):
        return np.float64(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        if arr.ndim == 1 and arr.size and arr.dtype.kind in "iuf":
            return arr.astype(np.int64 if arr.dtype.kind in "iu" else np.float64)
    return str(value)


def _variable_attrs(ds: xr.Dataset, name: str) -> dict[str, Any]:
    """The attrs to write for ``ds[name]``: its own, plus the CF ``coordinates`` attr naming the
    auxiliary (non-dimension) coordinates along its dimensions (e.g. ``component_label``)."""
    var = ds.variables[name]
    attrs = dict(var.attrs)
    if name in ds.data_vars:
        aux = [
            c
            for c in ds.coords
            if c not in ds.dims and ds[c].dims and set(ds[c].dims) <= set(var.dims)
        ]
        if aux:
            attrs["coordinates"] = " ".join(map(str, aux))
    return attrs


def _sync_time_attrs(nc: Any, attrs: Mapping[str, Any]) -> None:
    """Rewrite the attrs of the file's ``time`` variable to follow the global ``epoch``."""
    from .results import time_attrs

    if "time" not in nc.variables:
        return
    v = nc.variables["time"]
    names = v.ncattrs()
    plain = str(v.getncattr("elapsed_time_units")) if "elapsed_time_units" in names else None
    if plain is None:
        plain = "1" if "units" not in names or str(v.getncattr("units")) == "1" else "s"
    for k in ("standard_name", "axis", "calendar", "comment", "units", "long_name"):
        if k in names:
            v.delncattr(k)
    _set_attrs(v, time_attrs(plain, attrs.get("epoch")))


def _set_attrs(obj: Any, attrs: Mapping[str, Any]) -> None:
    for k, v in attrs.items():
        if v is None:
            continue
        if not isinstance(k, str) or not k:
            raise AttitudeTypeError(f"attrs: netCDF attribute names must be strings, got {k!r}")
        obj.setncattr(k, _attr_value(k, v))


class StreamWriter:
    """Write a result Dataset to netCDF4 chunk by chunk, atomically.

    Parameters
    ----------
    path : str or Path
        Final file name. Parent directories are created.
    complevel : int
        zlib compression level (0 turns compression off).

    Examples
    --------
    >>> with StreamWriter("run.nc") as w:                        # doctest: +SKIP
    ...     ds_last = propagate(body, q0, Q0, t, on_chunk=w.append)
    ...     w.attrs.update(ds_last.attrs)

    Leaving the ``with`` block normally commits the file (renames it into place); an exception
    removes the temporary file, unless :meth:`commit` was called first.
    """

    def __init__(self, path: str | os.PathLike, *, complevel: int = COMPLEVEL):
        self.path = Path(path)
        self.tmp = _tmp_path(self.path)
        self.complevel = int(complevel)
        self.attrs: dict[str, Any] = {}
        self.n = 0
        self._nc: Any = None
        self._vars: list[str] = []
        self._done = False

    # -- writing ----------------------------------------------------------------------------
    def _create(self, ds: xr.Dataset) -> None:
        import netCDF4

        if "time" not in ds.dims:
            raise AttitudeValueError("ds: a result Dataset has a 'time' dimension")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        nc = netCDF4.Dataset(self.tmp, "w", format="NETCDF4")
        self._nc = nc
        nc.createDimension("time", None)
        for dim, size in ds.sizes.items():
            if dim != "time":
                nc.createDimension(dim, size)
        comp = {"zlib": self.complevel > 0, "complevel": max(self.complevel, 1), "shuffle": True}
        # Dimension coordinates first (the time coordinate grows with the data).
        for name in ds.coords:
            var = ds[name].variable
            if var.dtype.kind in "UO":
                v = nc.createVariable(name, str, var.dims)
                v[:] = np.asarray(var.values, dtype=object)
            elif "time" in var.dims:
                v = nc.createVariable(
                    name, var.dtype, var.dims, chunksizes=self._chunks(var), **comp
                )
                self._vars.append(name)
            else:
                v = nc.createVariable(name, var.dtype, var.dims)
                v[:] = var.values
            _set_attrs(v, _variable_attrs(ds, name))
        for name, da in ds.data_vars.items():
            var = da.variable
            if var.dtype.kind not in "iuf":
                raise AttitudeTypeError(f"ds[{name!r}]: only numeric data variables are written")
            if "time" not in var.dims:  # e.g. the events of a run (docs/events.md): once
                self._static(name, var)
                continue
            v = nc.createVariable(name, var.dtype, var.dims, chunksizes=self._chunks(var), **comp)
            _set_attrs(v, _variable_attrs(ds, name))
            self._vars.append(name)

    def _static(self, name: str, var: xr.Variable) -> None:
        """Write a variable without a time dimension at once (creating its dimensions)."""
        nc = self._nc
        for dim, size in zip(var.dims, var.shape, strict=True):
            if dim not in nc.dimensions:
                nc.createDimension(dim, size)
        if var.dtype.kind in "UO":
            v = nc.createVariable(name, str, var.dims)
            if var.size:
                v[:] = np.asarray(var.values, dtype=object)
        else:
            v = nc.createVariable(name, var.dtype, var.dims)
            if var.size:
                v[:] = var.values
        _set_attrs(v, var.attrs)

    def add_static(self, ds: xr.Dataset) -> None:
        """Add the variables of ``ds`` without a ``time`` dimension that the file lacks yet.

        For what is known only at the end of a streamed run (its events, docs/events.md);
        call before :meth:`commit`.
        """
        if self._nc is None or self._done:
            raise AttitudeValueError("add_static: the file is not open (append samples first)")
        for name in [*ds.coords, *ds.data_vars]:
            var = ds[name].variable
            if "time" in var.dims or name in self._nc.variables:
                continue
            self._static(str(name), var)

    @staticmethod
    def _chunks(var: xr.Variable) -> list[int]:
        return [TIME_CHUNK if d == "time" else s for d, s in zip(var.dims, var.shape, strict=False)]

    def append(self, ds: xr.Dataset) -> None:
        """Append the samples of ``ds`` (same schema as the first chunk) along ``time``.

        The attrs of the first chunk are kept as the file's global attrs unless replaced
        through :attr:`attrs` before :meth:`commit`.
        """
        if self._done:
            raise AttitudeValueError("append: the file was already committed or aborted")
        if self._nc is None:
            self._create(ds)
            self.attrs = dict(ds.attrs)
        k = ds.sizes["time"]
        if k == 0:
            return
        for name in self._vars:
            var = ds[name].variable.transpose("time", ...)
            self._nc.variables[name][self.n : self.n + k, ...] = var.values
        self.n += k

    def commit(self) -> Path:
        """Write the global attrs, flush to disk and rename into place. Returns the path."""
        if self._done:
            return self.path
        if self._nc is None:
            raise AttitudeValueError(f"{self.path}: nothing was written (no samples)")
        _set_attrs(self._nc, self.attrs)
        _sync_time_attrs(self._nc, self.attrs)
        self._nc.close()
        self._nc = None
        with open(self.tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(self.tmp, self.path)
        with contextlib.suppress(OSError):  # persist the rename (POSIX)
            fd = os.open(self.path.parent, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        self._done = True
        return self.path

    def abort(self) -> None:
        """Remove the temporary file; the final name is left untouched."""
        if self._nc is not None:
            with contextlib.suppress(Exception):
                self._nc.close()
            self._nc = None
        with contextlib.suppress(FileNotFoundError):
            self.tmp.unlink()
        self._done = True

    def __enter__(self) -> StreamWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        elif not self._done:
            self.abort()


def write(ds: xr.Dataset, path: str | os.PathLike, *, complevel: int = COMPLEVEL) -> Path:
    """Write a result Dataset to a netCDF4 file (compressed, CF attrs, atomic).

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result (docs/results.md): dimension ``time``, numeric data variables.
    path : str or Path
        Output file; an existing file is replaced only once the new one is complete.
    complevel : int
        zlib level, 0 for none.

    Returns
    -------
    Path
        The written file.
    """
    if not isinstance(ds, xr.Dataset):
        raise AttitudeTypeError(f"ds: expected an xarray.Dataset, got {type(ds).__name__}")
    with StreamWriter(path, complevel=complevel) as w:
        n = ds.sizes.get("time", 0)
        if n == 0:
            raise AttitudeValueError("ds: no output samples to write (time has length 0)")
        step = 16 * TIME_CHUNK
        for i in range(0, n, step):
            w.append(ds.isel(time=slice(i, i + step)))
        w.attrs = dict(ds.attrs)
    return Path(path)


def read(path: str | os.PathLike, *, load: bool = True) -> xr.Dataset:
    """Read a result file written by :func:`write` or :class:`StreamWriter`.

    Parameters
    ----------
    path : str or Path
    load : bool
        True (default): load everything into memory and close the file. False: variables are
        read lazily on access (for files too large for memory); close with ``ds.close()``.

    Returns
    -------
    xarray.Dataset
        Identical to the Dataset that was written (values bit for bit, attrs, coordinates).
    """
    p = Path(path)
    if not p.is_file():
        raise AttitudeValueError(f"{p}: no such file")
    try:
        ds = xr.open_dataset(
            p,
            engine="netcdf4",
            decode_times=False,
            decode_timedelta=False,
            mask_and_scale=False,
            decode_coords=False,
        )
    except OSError as exc:
        raise AttitudeValueError(f"{p}: not a netCDF4 file ({exc})") from None
    # CF auxiliary coordinates (named in the data variables' "coordinates" attrs) back to
    # coordinates, the attr dropped (as in the Dataset that was written).
    aux: list[str] = []
    for v in ds.variables.values():
        names = v.attrs.pop("coordinates", None)
        if names:
            aux += [c for c in str(names).split() if c in ds.variables and c not in aux]
    if aux:
        ds = ds.set_coords(aux)
    # String coordinates come back as object arrays; make them the fixed-width unicode the
    # Dataset builder uses.
    for name in list(ds.coords):
        if ds[name].dtype.kind == "O":
            ds = ds.assign_coords({name: ds[name].copy(data=np.asarray(ds[name].values, str))})
    if load:
        with ds:
            ds = ds.load()
    return ds


def iter_chunks(ds: xr.Dataset, size: int = 16 * TIME_CHUNK) -> Iterator[xr.Dataset]:
    """Consecutive time slices of ``ds`` (each loaded; bounded memory on a lazy Dataset)."""
    n = ds.sizes["time"]
    for i in range(0, n, size):
        yield ds.isel(time=slice(i, i + size)).load()

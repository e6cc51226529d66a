"""netCDF4 files of propagation results: atomic, compressed, streamable.

:func:`write` stores a result Dataset (docs/results.md) and :func:`read` gives back an identical
one: data bit for bit, every attr with its value and type (str, int64, float64 and float64
arrays; see "Attribute types" below). :class:`StreamWriter` appends chunks of output samples as
they are computed (``propagate(..., on_chunk=writer.append)``), so a run of 10⁷ samples needs
memory for one chunk only.

Atomicity: everything is written to a temporary file beside the target
(``.NAME.attitude-<pid>.tmp``), flushed to disk and renamed over the final name only when
complete (``os.replace``, atomic on POSIX and Windows). A crash or interrupt therefore leaves
either no file or the previous one under the final name, never a half-written file; every
failure removes the temporary file, and the temporary files of killed processes are removed by
the next write to the same name. Pipes and character devices (``/dev/stdout``) are written
through, never replaced; see :mod:`attitude._files`. A propagation that fails midway is still
committed, with what it computed and ``run_status = "failed: ..."`` in the attrs.

Attribute types
---------------
netCDF attributes are typed scalars, strings or 1-D arrays. ``str``, ``int`` (int64),
``float`` (float64), numpy scalars and 1-D numeric arrays round-trip exactly. A ``bool`` is
stored as int8 0/1 and ``None`` is dropped (netCDF has neither); anything else is stored as its
``str``. Length-1 arrays come back as scalars (a netCDF convention).

CF
--
Files follow CF-1.11 (``compliance-checker --test=cf:1.11`` reports no errors, tests/test_cf.py):
the attrs of ``time`` (and of the event times, encoded alike) follow the global attr ``epoch``
when the file is committed (:func:`attitude.results.time_attrs`: ``seconds since <epoch>``
with an epoch), and data variables name their auxiliary label coordinates
(``component_label``, ``axis_label``) in a ``coordinates`` attr, which :func:`read` turns
back into coordinates.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._files import OutputFile, file_error, input_path, tmp_path_for
from .errors import AttitudeError, AttitudeFileError, AttitudeTypeError, AttitudeValueError

__all__ = ["StreamWriter", "read", "write"]

#: Samples per netCDF chunk along ``time`` (also the default streaming chunk).
TIME_CHUNK = 4096
#: zlib level: 4 is within ~3 % of the best ratio for these smooth float64 series, 3× faster.
COMPLEVEL = 4


def _tmp_path(path: Path) -> Path:
    return tmp_path_for(path)


#: Dimensions stored unlimited besides ``time``: the flight software's ``tick`` (a second time
#: axis, which CF §2.4 then leaves right of its components as it does ``time``'s).
UNLIMITED = ("tick",)
#: The dimensions :class:`StreamWriter` appends along, each in chunks of :data:`TIME_CHUNK`.
GROWING = ("time", "tick")


def _attr_value(name: str, value: Any) -> Any:
    """An attr value netCDF4 can store (see the module docstring)."""
    if isinstance(value, (bool, np.bool_)):
        return np.int8(bool(value))
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)):
        if not -(2**63) <= int(value) < 2**63:
            raise AttitudeValueError(
                f"attrs[{name!r}]: the integer {value} does not fit in a netCDF int64; store it "
                "as a string or a float"
            )
        return np.int64(value)
    if isinstance(value, (float, np.floating)):
        return np.float64(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        try:
            arr = np.asarray(value)
        except (ValueError, TypeError):
            arr = np.asarray(None)
        if arr.ndim == 1 and arr.size and arr.dtype.kind in "iuf":
            if name in ("flag_values", "flag_masks") and arr.dtype.kind in "iu":
                return arr  # CF §3.5: the type of the flagged variable
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
    """Rewrite the attrs of the file's ``time`` variable, and the encoding of the instant
    variables (event times), to follow the global ``epoch``."""
    from .results import INSTANT_VARIABLES, instant_attrs, time_attrs

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
    for name in INSTANT_VARIABLES:
        if name in nc.variables:
            _set_attrs(nc.variables[name], instant_attrs(plain, attrs.get("epoch")))


_SCRATCH: list[Any] = []


def _scratch() -> Any:
    """An in-memory netCDF4 dataset to try attributes on (never written to disk)."""
    if not _SCRATCH:
        import netCDF4

        _SCRATCH.append(
            netCDF4.Dataset("attitude-attr-check.nc", "w", diskless=True, persist=False)
        )
    return _SCRATCH[0]


def check_attrs(attrs: Mapping[Any, Any], where: str = "attrs") -> dict[str, Any]:
    """The attrs as they will be stored, or an error naming the attribute, before any writing.

    Each name and value is tried on an in-memory netCDF4 dataset: what netCDF refuses (a name
    with '/', a string that is not valid UTF-8, an integer beyond int64) is found here, not
    after the data are written.
    """
    out: dict[str, Any] = {}
    nc = _scratch()
    for k, v in attrs.items():
        if v is None:
            continue
        if not isinstance(k, str) or not k:
            raise AttitudeTypeError(f"{where}: netCDF attribute names must be strings, got {k!r}")
        val = _attr_value(k, v)
        if isinstance(val, str) and "\x00" in val:
            raise AttitudeValueError(f"{where}[{k!r}]: a netCDF string cannot hold a NUL byte")
        try:
            nc.setncattr(k, val)
            nc.delncattr(k)
        except (AttributeError, RuntimeError, ValueError, TypeError, UnicodeError) as exc:
            raise AttitudeValueError(
                f"{where}[{k!r}]: netCDF cannot store this attribute ({type(exc).__name__}: "
                f"{exc}); use a name of letters, digits and '_' and a str, int, float or 1-D "
                "numeric array value"
            ) from None
        out[k] = val
    return out


def _set_attrs(obj: Any, attrs: Mapping[str, Any]) -> None:
    for k, v in check_attrs(attrs).items():
        obj.setncattr(k, v)


def _descriptors_of(fd: int) -> list[int]:
    """The other open descriptors of this process on the file of ``fd`` (Linux /proc; else [])."""
    try:
        st = os.fstat(fd)
        names = os.listdir("/proc/self/fd")
    except OSError:
        return []
    out = []
    for name in names:
        try:
            h = int(name)
            if h == fd:
                continue
            o = os.fstat(h)
        except (OSError, ValueError):
            continue
        if (o.st_dev, o.st_ino) == (st.st_dev, st.st_ino):
            out.append(h)
    return out


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
        # The path is checked now, before any work (type, NUL bytes, a directory, a device).
        self._out = OutputFile(path, "path")
        self.path = self._out.path
        self.tmp = self._out.tmp
        if isinstance(complevel, bool) or not isinstance(complevel, (int, np.integer)):
            raise AttitudeTypeError(f"complevel: expected an integer 0..9, got {complevel!r}")
        if not 0 <= complevel <= 9:
            raise AttitudeValueError(f"complevel: expected an integer 0..9, got {complevel!r}")
        self.complevel = int(complevel)
        self.attrs: dict[str, Any] = {}
        self.n = 0
        self.n_ticks = 0
        self._nc: Any = None
        self._vars: list[str] = []
        self._tick_vars: list[str] = []
        self._done = False

    # -- writing ----------------------------------------------------------------------------
    def _open_tmp(self) -> Any:
        """Create the temporary netCDF4 file (parents made, stale temporaries removed)."""
        import netCDF4

        self._out.prepare()
        with self._or_abort():
            self._nc = netCDF4.Dataset(self.tmp, "w", format="NETCDF4")
        return self._nc

    def _create(self, ds: xr.Dataset) -> None:
        """Open the file and create the variables of the first chunk."""
        if "time" not in ds.dims and "tick" not in ds.dims:
            raise AttitudeValueError("ds: a result Dataset has a 'time' dimension")
        for name in ds.variables:  # every attr checked before anything is written
            check_attrs(ds[name].attrs, f"ds[{name!r}].attrs")
        nc = self._open_tmp()
        nc.createDimension("time", None)
        self._add(ds)

    def _add(self, ds: xr.Dataset) -> None:
        """Create the variables of ``ds`` the file does not hold yet: those along ``time`` or
        ``tick`` chunked and compressed (:meth:`append` writes them), the others at once."""
        nc = self._nc
        for name in ds.variables:
            if name not in nc.variables:
                check_attrs(ds[name].attrs, f"ds[{name!r}].attrs")
        for dim, size in ds.sizes.items():
            if dim not in nc.dimensions:
                nc.createDimension(dim, None if dim in UNLIMITED else size)
        comp = self._filters()
        # Dimension coordinates first (the time coordinate grows with the data).
        for name in [*ds.coords, *ds.data_vars]:
            if name in nc.variables:
                continue
            var = ds[name].variable
            along = next((d for d in GROWING if d in var.dims), None)
            if name in ds.data_vars and var.dtype.kind not in "iuf":
                raise AttitudeTypeError(f"ds[{name!r}]: only numeric data variables are written")
            if along is None and name in ds.data_vars:  # e.g. the events of a run: once
                self._static(name, var)
                continue
            if var.dtype.kind in "UO":
                v = _text_variable(nc, name, var, comp)
            elif along is not None:
                v = nc.createVariable(
                    name, var.dtype, var.dims, chunksizes=self._chunks(var), **comp
                )
                self._small_cache(v, var)
                (self._vars if along == "time" else self._tick_vars).append(name)
            elif var.ndim and var.size and all(d not in UNLIMITED for d in var.dims):
                v = nc.createVariable(name, var.dtype, var.dims, chunksizes=list(var.shape),
                                      **comp)  # fmt: skip
                v[:] = var.values
            else:
                v = nc.createVariable(name, var.dtype, var.dims)
                v[:] = var.values
            _set_attrs(v, _variable_attrs(ds, name))

    def _filters(self) -> dict[str, Any]:
        """HDF5 filters of every chunked variable: zlib with shuffle, and a Fletcher-32
        checksum per chunk, so that a reader finds a corrupted chunk instead of reading it."""
        return {
            "zlib": self.complevel > 0,
            "complevel": max(self.complevel, 1),
            "shuffle": True,
            "fletcher32": True,
        }

    def _static(self, name: str, var: xr.Variable) -> None:
        """Write a variable without a time dimension at once (creating its dimensions)."""
        nc = self._nc
        for dim, size in zip(var.dims, var.shape, strict=True):
            if dim not in nc.dimensions:
                nc.createDimension(dim, None if dim in UNLIMITED else size)
        if var.dtype.kind in "UO":
            v = _text_variable(nc, name, var, self._filters())
        elif var.ndim and var.size:  # chunked: checksummed (the file's readers agree)
            v = nc.createVariable(name, var.dtype, var.dims, chunksizes=list(var.shape),
                                  **self._filters())  # fmt: skip
            v[:] = var.values
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
        ticks = [n for n in ds.data_vars if "tick" in ds[n].dims and n not in self._nc.variables]
        if ticks:  # the flight software's records of a run kept in memory: chunked
            sub = ds[ticks]
            for i in range(0, max(sub.sizes["tick"], 1), 16 * TIME_CHUNK):
                self.append(sub.isel(tick=slice(i, i + 16 * TIME_CHUNK)))
        for name in [*ds.coords, *ds.data_vars]:
            var = ds[name].variable
            if "time" in var.dims or name in self._nc.variables:
                continue
            self._static(str(name), var)

    @staticmethod
    def _chunks(var: xr.Variable) -> list[int]:
        return [
            TIME_CHUNK if d in GROWING else max(1, s)
            for d, s in zip(var.dims, var.shape, strict=False)
        ]

    def _small_cache(self, v: Any, var: xr.Variable) -> None:
        """A chunk cache of two chunks: complete chunks are compressed and written at once.

        netCDF's default (64 MiB per variable) kept up to ~0.7 GB of a streamed run in
        memory and made closing (or aborting, on Ctrl-C) the file take seconds.
        """
        nbytes = var.dtype.itemsize * int(np.prod(self._chunks(var)))
        v.set_var_chunk_cache(size=2 * nbytes + 4096, nelems=17, preemption=1.0)

    #: The dimension chunks are appended along (``_MemberWriter``: ``member``).
    _along = "time"

    @contextlib.contextmanager
    def _or_abort(self) -> Iterator[None]:
        """Any failure inside removes the temporary file; OS and netCDF errors are reported as
        :class:`AttitudeFileError` naming the output (a full disk, no permission...)."""
        try:
            yield
        except AttitudeError:
            self.abort()
            raise
        except (OSError, RuntimeError) as exc:
            err = file_error(exc, self._out.target)  # a full disk: before the abort frees it
            self.abort()
            raise err from None
        except BaseException:
            self.abort()
            raise

    def append(self, ds: xr.Dataset) -> None:
        """Append the samples of ``ds`` (same schema as the first chunk) along ``time``.

        The attrs of the first chunk are kept as the file's global attrs unless replaced
        through :attr:`attrs` before :meth:`commit`. Any failure removes the temporary file.
        """
        if self._done:
            raise AttitudeValueError("append: the file was already committed or aborted")
        with self._or_abort():
            if self._nc is None:
                self._create(ds)
                self.attrs = dict(ds.attrs)
            elif self._along == "time":
                self._add(ds)  # e.g. the first chunk of ticks after the first samples
            k = ds.sizes.get(self._along, 0)
            if k:
                for name in self._vars:
                    var = ds[name].variable.transpose(self._along, ...)
                    self._nc.variables[name][self.n : self.n + k, ...] = var.values
                self.n += k
            k = ds.sizes.get("tick", 0) if self._along == "time" else 0
            if k:
                for name in self._tick_vars:
                    var = ds[name].variable.transpose("tick", ...)
                    self._nc.variables[name][self.n_ticks : self.n_ticks + k, ...] = var.values
                self.n_ticks += k

    def commit(self) -> Path:
        """Write the global attrs, flush to disk and put the file in place. Returns the path.

        The attrs are checked before anything else; any failure removes the temporary file and
        leaves the target as it was.
        """
        if self._done:
            return self.path
        if self._nc is None:
            self.abort()
            raise AttitudeValueError(f"{self.path}: nothing was written (no samples)")
        with self._or_abort():
            attrs = check_attrs(self.attrs, "attrs")
            for k, v in attrs.items():
                self._nc.setncattr(k, v)
            _sync_time_attrs(self._nc, attrs)
            self._nc.close()
            self._nc = None
            self._out.commit()
        self._done = True
        return self.path

    def abort(self) -> None:
        """Remove the temporary file; the final name is left untouched.

        After a full disk HDF5 cannot close the file and keeps it open, which held its space
        until the process ended: the file is truncated through a descriptor of our own once
        HDF5 has given up on it.
        """
        nc, self._nc = self._nc, None
        fd = None
        with contextlib.suppress(OSError):
            fd = os.open(self.tmp, os.O_WRONLY)
        held = _descriptors_of(fd) if (fd is not None and nc is not None) else []
        self._out.discard()
        if held:
            # HDF5's own descriptors of the file now write to /dev/null: what it flushes when
            # the handle is closed or garbage-collected later cannot fill the disk again.
            null = os.open(os.devnull, os.O_WRONLY)
            for h in held:
                with contextlib.suppress(OSError):
                    os.dup2(null, h)
            os.close(null)
        if nc is not None:
            with contextlib.suppress(Exception):
                nc.close()
        if fd is not None:
            with contextlib.suppress(OSError):
                os.ftruncate(fd, 0)
            os.close(fd)
        self._done = True

    def __enter__(self) -> StreamWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.commit()
        elif not self._done:
            self.abort()


class _MemberWriter(StreamWriter):
    """:class:`StreamWriter` appending along ``member`` (unlimited) instead of time.

    Variables without a ``member`` dimension (time, orbit of a shared orbit) are written once.
    """

    _along = "member"

    def _create(self, ds: xr.Dataset) -> None:
        for name in ds.variables:  # every attr checked before anything is written
            check_attrs(ds[name].attrs, f"ds[{name!r}].attrs")
        nc = self._open_tmp()
        nc.createDimension("member", None)
        for dim, size in ds.sizes.items():
            if dim != "member":
                nc.createDimension(dim, size)
        comp = self._filters()
        for name in [*ds.coords, *ds.data_vars]:
            var = ds[name].variable
            if var.dtype.kind in "UO":
                v = _text_variable(nc, name, var, comp)
            elif "member" in var.dims:
                chunks = self._chunks(var)
                v = nc.createVariable(name, var.dtype, var.dims, chunksizes=chunks, **comp)
                # A chunk cache of two netCDF chunks: complete chunks are written out at once
                # instead of accumulating in HDF5's cache (memory would grow with N).
                nbytes = var.dtype.itemsize * int(np.prod(chunks))
                v.set_var_chunk_cache(size=2 * nbytes + 4096, nelems=17, preemption=1.0)
                self._vars.append(name)
            elif var.ndim and var.size:  # one checksummed chunk (the file's readers agree)
                v = nc.createVariable(name, var.dtype, var.dims, chunksizes=list(var.shape),
                                      **comp)  # fmt: skip
                v[:] = var.values
            else:
                v = nc.createVariable(name, var.dtype, var.dims)
                v[:] = var.values
            _set_attrs(v, _variable_attrs(ds, name))  # CF "coordinates" of the label variables

    @staticmethod
    def _chunks(var: xr.Variable) -> list[int]:
        # About 1 MiB per netCDF chunk: all of each member's record, as many members as fit.
        rest = list(var.shape[1:])
        per = 8 * int(np.prod(rest)) if rest else 8
        while per > 2**20 and rest:  # very long records: cut the time axis
            i = int(np.argmax(rest))
            rest[i] = max(1, rest[i] // 2)
            per = 8 * int(np.prod(rest))
        members = int(max(1, min(var.shape[0], 2**20 // per)))
        return [members, *rest]

    def add_variables(self, ds: xr.Dataset) -> None:
        """Write the variables of ``ds`` that the file does not hold yet (e.g. the percentiles
        of a statistics run, computed when every member is done); before :meth:`commit`."""
        nc = self._nc
        for dim, size in ds.sizes.items():
            if dim not in nc.dimensions:
                nc.createDimension(dim, size)
        comp = self._filters()
        for name in [*ds.coords, *ds.data_vars]:
            if name in nc.variables:
                continue
            var = ds[name].variable
            if var.dtype.kind in "UO":
                v = _text_variable(nc, name, var, comp)
            elif var.ndim and var.size:  # one checksummed chunk (or the writer's chunks)
                chunks = self._chunks(var) if "member" in var.dims else list(var.shape)
                v = nc.createVariable(name, var.dtype, var.dims, chunksizes=chunks, **comp)
                v[:] = var.values
            else:
                v = nc.createVariable(name, var.dtype, var.dims)
                v[:] = var.values
            _set_attrs(v, _variable_attrs(ds, name))


def _text_variable(nc: Any, name: str, var: xr.Variable, filters: dict[str, Any]) -> Any:
    """Write a text variable (labels) as CF's character array, UTF-8 (``_Encoding``; a
    ``{name}_strlen`` dimension), read back as strings by xarray and netCDF4; one chunk, with
    ``filters`` (a checksum), as every static array.

    Not as an HDF5 variable-length string: with the HDF5 of netCDF4's wheels (2.2.0) a process
    that holds such a file open through xarray and opens it again through netCDF4 and xarray
    crashes (a segmentation fault in the fill value's conversion, ``H5T__conv_vlen``).
    """
    values = np.asarray(var.values, dtype=str)
    width = max([1, *(len(x.encode("utf-8")) for x in values.ravel())])
    dim = f"{name}_strlen"
    nc.createDimension(dim, width)
    if values.size:
        v = nc.createVariable(name, "S1", (*var.dims, dim), chunksizes=[*values.shape, width],
                              **filters)  # fmt: skip
    else:
        v = nc.createVariable(name, "S1", (*var.dims, dim))
    v._Encoding = "utf-8"
    if values.size:
        v[:] = values
    return v


def write(ds: xr.Dataset, path: str | os.PathLike, *, complevel: int = COMPLEVEL) -> Path:
    """Write a result Dataset to a netCDF4 file (compressed, CF attrs, atomic).

    Parameters
    ----------
    ds : xarray.Dataset
        A propagation result (docs/results.md): dimension ``time``, numeric data variables;
        or an ensemble's (dimension ``member``, written as ``propagate_ensemble(path=...)``
        writes it).
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
    n = ds.sizes.get("time", 0)
    if n == 0:
        raise AttitudeValueError("ds: no output samples to write (time has length 0)")
    check_attrs(ds.attrs, "ds.attrs")  # before anything is written
    for name in ds.variables:
        check_attrs(ds[name].attrs, f"ds[{name!r}].attrs")
    if "member" in ds.dims:  # an ensemble (propagate_ensemble's layout): member by member
        with _MemberWriter(path, complevel=complevel) as w:
            w._out.check_space(float(ds.nbytes), f"an ensemble of {ds.sizes['member']} members")
            per = max(1, int(ds.nbytes // max(1, ds.sizes["member"])))
            step = max(1, (64 << 20) // per)  # ~64 MB a slice
            for i in range(0, ds.sizes["member"], step):
                w.append(ds.isel(member=slice(i, i + step)))
            w.attrs = dict(ds.attrs)
        return w.path
    ticks = [k for k in ds.data_vars if "tick" in ds[k].dims]
    samples = ds.drop_vars(ticks + [k for k in ds.coords if "tick" in ds[k].dims])
    with StreamWriter(path, complevel=complevel) as w:
        w._out.check_space(float(ds.nbytes), f"a Dataset of {n} samples")
        step = 16 * TIME_CHUNK  # bounded memory: the writer's copies are of one slice
        for i in range(0, n, step):
            w.append(samples.isel(time=slice(i, i + step)))
        if ticks:
            w.add_static(ds[ticks])
        w.attrs = dict(ds.attrs)
    return w.path


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

    Raises
    ------
    AttitudeFileError
        No such file, a directory, not a netCDF4 file, or a truncated or corrupt one.
    """
    if not isinstance(load, (bool, np.bool_)):
        raise AttitudeTypeError(f"load: expected True or False, got {load!r}")
    p = input_path(path, "path")
    try:
        ds = xr.open_dataset(
            p,
            engine="netcdf4",
            decode_times=False,
            decode_timedelta=False,
            mask_and_scale=False,
            decode_coords=False,
        )
    except (OSError, RuntimeError, ValueError, KeyError, IndexError, AttributeError) as exc:
        raise AttitudeFileError(f"{p}: not a netCDF4 file ({exc})") from None
    try:
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
    except (OSError, RuntimeError, ValueError, KeyError, IndexError, AttributeError) as exc:
        ds.close()
        raise file_error(exc, p, "read") from None
    return ds


def iter_chunks(ds: xr.Dataset, size: int = 16 * TIME_CHUNK) -> Iterator[xr.Dataset]:
    """Consecutive time slices of ``ds`` (each loaded; bounded memory on a lazy Dataset)."""
    n = ds.sizes["time"]
    for i in range(0, n, size):
        yield ds.isel(time=slice(i, i + size)).load()

"""Output files written atomically, checked before any work (used by ``io``, ``aem``, ensembles).

:class:`OutputFile` is where a result goes. It checks the path when it is made (before any
computation), names a temporary file beside the target, removes the temporary files that dead
processes left there, and at :meth:`OutputFile.commit` puts the complete file in place:

* a regular file, or a name that does not exist yet: renamed over it (``os.replace``, atomic),
  so a crash leaves the previous file or none, never a half-written one;
* a symbolic link: the file it points to is replaced the same way, the link is kept;
* a character device or a pipe (``/dev/stdout``, ``/dev/null``, a FIFO), and any path under
  ``/dev`` or ``/proc``: the complete file is *written through* to it (copied into it), never
  renamed over it (which would replace the device by a regular file);
* a directory, a block device, a socket: refused, with the reason.

Temporary files are named ``.NAME.attitude-<pid>.tmp`` (``NAME`` shortened, with a hash, when
the name is long): hidden, recognisable, and owned by a process id. A process killed with
SIGKILL cannot remove its temporary file; the next :class:`OutputFile` for the same target
removes every such file whose process is gone (or whose pid now belongs to a process that
started after the file was last written).

Errors are :class:`~attitude.errors.AttitudeFileError` (a ``ValueError`` and an ``OSError``)
naming the path and the fix: no permission, a read-only file system, a full disk (also when
HDF5 reports only "NetCDF: HDF error"), a name too long.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from . import _interrupt
from .errors import AttitudeFileError, AttitudeTypeError

__all__ = ["OutputFile", "file_error", "input_path", "is_stdout"]

#: Suffix of every temporary file (with the pid before it).
TMP_TAG = "attitude"
#: Free bytes below which a failed write is reported as a full disk.
FULL_DISK_BYTES = 2**20
_NAME_MAX = 255


def _as_path(path: Any, what: str) -> Path:
    """A Path from a str/bytes/PathLike, refusing other types, empty names and NUL bytes."""
    if isinstance(path, (bool, int, float)) or path is None:
        raise AttitudeTypeError(
            f"{what}: expected a file name (str or pathlib.Path), got {type(path).__name__} "
            f"{path!r}"
        )
    try:
        p = os.fsdecode(os.fspath(path))
    except TypeError:
        raise AttitudeTypeError(
            f"{what}: expected a file name (str or pathlib.Path), got {type(path).__name__}"
        ) from None
    if "\x00" in p:
        raise AttitudeFileError(f"{what}: {p!r} contains a NUL byte, which no file name can hold")
    if not p:
        raise AttitudeFileError(f"{what}: the file name is empty")
    return Path(p)


def input_path(path: Any, what: str = "path") -> Path:
    """A path to read: checked for type and NUL bytes; an existing regular file or device."""
    p = _as_path(path, what)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise AttitudeFileError(f"{p}: no such file") from None
    except OSError as exc:
        raise file_error(exc, p, "read") from None
    if stat.S_ISDIR(st.st_mode):
        raise AttitudeFileError(f"{p}: is a directory, not a file")
    return p


def is_stdout(path: Any) -> bool:
    """Whether ``path`` is this process's standard output (``-o /dev/stdout``)."""
    try:
        p = _as_path(path, "path")
        return os.path.samestat(os.stat(p), os.fstat(1))
    except (OSError, ValueError, TypeError):
        return False


def _free_bytes(where: Path) -> int | None:
    d = where if where.is_dir() else where.parent
    while not d.exists() and d != d.parent:
        d = d.parent
    try:
        return shutil.disk_usage(d).free
    except OSError:
        return None


def _read_only(where: Path) -> bool:
    d = where if where.is_dir() else where.parent
    while not d.exists() and d != d.parent:
        d = d.parent
    try:
        return bool(os.statvfs(d).f_flag & os.ST_RDONLY)
    except (OSError, AttributeError):
        return False


def _size(n: float) -> str:
    for unit, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= f:
            return f"{n / f:.3g} {unit}"
    return f"{n:.0f} bytes"


def file_error(exc: BaseException, path: Path, action: str = "write") -> AttitudeFileError:
    """An :class:`AttitudeFileError` for an OS or netCDF/HDF5 error while writing/reading.

    netCDF/HDF5 often report a full disk as "NetCDF: HDF error" or even as "Permission
    denied", and a read-only file system as "Permission denied": for a write, the file system
    is asked (free space, read-only flag) before the error code is believed.
    """
    if isinstance(exc, AttitudeFileError):
        return exc
    code = getattr(exc, "errno", None)
    where = path.parent if str(path.parent) else Path(".")
    full = (
        f"{path}: the disk is full (no space left on the file system of {where}); free some "
        "space or write the output elsewhere"
    )
    if code in (errno.ENOSPC, errno.EDQUOT):
        return AttitudeFileError(full)
    if code == errno.ENAMETOOLONG:
        return AttitudeFileError(f"{path}: the file name is too long for the file system")
    if code == errno.ENOTDIR:
        return AttitudeFileError(f"{path}: a component of the path is a file, not a directory")
    if code == errno.EISDIR:
        return AttitudeFileError(f"{path}: is a directory; give a file name")
    if code == errno.ENOENT:
        return AttitudeFileError(f"{path}: no such file or directory")
    if action == "write":
        if code == errno.EROFS or _read_only(where):
            return AttitudeFileError(
                f"{path}: the file system is read-only; write the output elsewhere"
            )
        free = _free_bytes(path)
        if free is not None and free < FULL_DISK_BYTES:
            return AttitudeFileError(
                f"{path}: the disk is full ({free} bytes left on the file system of {where}; "
                f"the write failed with: {type(exc).__name__}: {exc}); free some space or "
                "write the output elsewhere"
            )
    if code in (errno.EACCES, errno.EPERM):
        return AttitudeFileError(
            f"{path}: permission denied: cannot {action} it; choose a file in a directory "
            "you can write to"
            if action == "write"
            else f"{path}: permission denied: cannot read it"
        )
    if code == errno.EFBIG:
        return AttitudeFileError(
            f"{path}: the file is larger than this process may write (ulimit -f)"
        )
    if action == "write":
        return AttitudeFileError(f"{path}: writing failed: {type(exc).__name__}: {exc}")
    return AttitudeFileError(
        f"{path}: cannot be read ({type(exc).__name__}: {exc}); the file is truncated, "
        "corrupt or not a netCDF4 result file"
    )


# ------------------------------------------------------------------------------------------------
# temporary files
# ------------------------------------------------------------------------------------------------


def _tmp_stem(name: str) -> str:
    """``.NAME`` of the temporary file of target ``name``, shortened (with a hash) if long."""
    room = _NAME_MAX - len(f"..{TMP_TAG}-4194304.tmp") - 1
    if len(os.fsencode(name)) <= room:
        return f".{name}"
    digest = hashlib.sha256(os.fsencode(name)).hexdigest()[:12]
    keep = name
    while len(os.fsencode(keep)) > room - 13:
        keep = keep[: len(keep) - max(1, (len(os.fsencode(keep)) - room + 13) // 4)]
    return f".{keep}~{digest}"


def tmp_path_for(target: Path, directory: Path | None = None) -> Path:
    """``.NAME.attitude-<pid>.tmp`` beside ``target`` (or in ``directory``)."""
    d = target.parent if directory is None else directory
    return d / f"{_tmp_stem(target.name)}.{TMP_TAG}-{os.getpid()}.tmp"


def _process_started_after(pid: int, when: float) -> bool | None:
    """Whether process ``pid`` started after time ``when`` (None: unknown). Linux /proc."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            fields = fh.read().rsplit(b")", 1)[1].split()
        start_ticks = int(fields[19])
        with open("/proc/stat", "rb") as fh:
            btime = next(int(ln.split()[1]) for ln in fh if ln.startswith(b"btime"))
        started = btime + start_ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        return None
    return started > when + 2.0  # /proc times have a resolution of ~1 s


def _stale(pid: int, mtime: float) -> bool:
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except (PermissionError, OSError):
        pass  # alive (someone else's)
    return bool(_process_started_after(pid, mtime))  # the pid was reused since


def remove_stale_temps(target: Path, directory: Path | None = None) -> list[Path]:
    """Remove the temporary files of ``target`` left by processes that are gone."""
    d = target.parent if directory is None else directory
    stem = _tmp_stem(target.name)
    pat = re.compile(
        re.escape(stem) + r"\.(?:" + re.escape(TMP_TAG) + r"-)?(\d+)\.tmp$"
    )  # also the older ".NAME.<pid>.tmp"
    removed = []
    try:
        entries = list(os.scandir(d if str(d) else "."))
    except OSError:
        return removed
    for e in entries:
        m = pat.match(e.name)
        if not m:
            continue
        try:
            st = e.stat(follow_symlinks=False)
            if not stat.S_ISREG(st.st_mode):
                continue
            if _stale(int(m.group(1)), st.st_mtime):
                os.unlink(e.path)
                removed.append(Path(e.path))
        except OSError:
            continue
    return removed


# ------------------------------------------------------------------------------------------------
# the output file
# ------------------------------------------------------------------------------------------------


class OutputFile:
    """An output path, checked now; a temporary file to write; :meth:`commit` puts it in place.

    Parameters
    ----------
    path : str or Path
        Where the user wants the file.
    what : str
        The parameter name used in error messages.

    Attributes
    ----------
    path : Path
        As given.
    target : Path
        The file that will hold the result (``path`` with symbolic links resolved).
    through : bool
        True for a character device or a pipe: the result is copied into it at commit.
    tmp : Path
        The temporary file to write.
    """

    def __init__(self, path: Any, what: str = "path"):
        p = _as_path(path, what)
        self.path = p
        self.what = what
        if os.fsdecode(os.fspath(path)).endswith(("/", os.sep)):
            raise AttitudeFileError(f"{what}: {p} is a directory; give a file name")
        self._check_name(p.name)
        special = str(p.absolute()).startswith(("/dev/", "/proc/"))
        try:
            st = os.stat(p)  # follows symbolic links
        except FileNotFoundError:
            st = None
        except OSError as exc:
            raise file_error(exc, p) from None
        self.through = False
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise AttitudeFileError(f"{what}: {p} is a directory; give a file name")
        if st is not None and not stat.S_ISREG(st.st_mode):
            mode = st.st_mode
            if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
                self.through = True
            else:
                kind = (
                    "a block device"
                    if stat.S_ISBLK(mode)
                    else "a socket"
                    if stat.S_ISSOCK(mode)
                    else "not a regular file"
                )
                raise AttitudeFileError(
                    f"{what}: {p} is {kind}; results are written to regular files, pipes or "
                    "character devices such as /dev/stdout"
                )
        elif st is not None and special:
            self.through = True  # e.g. /dev/stdout redirected to a file: write into it
        if self.through:
            self.target = p
            self._tmpdir = Path(tempfile.gettempdir())
        else:
            self.target = Path(os.path.realpath(p)) if os.path.islink(p) else p
            self._tmpdir = None
            self._check_name(self.target.name)
        self.tmp = tmp_path_for(self.target, self._tmpdir)

    def _check_name(self, name: str) -> None:
        size = len(os.fsencode(name))
        if size > _NAME_MAX:
            raise AttitudeFileError(
                f"{self.what}: the file name {name[:40]!r}... is {size} bytes long: too long, "
                f"file systems allow at most {_NAME_MAX}"
            )

    def check_space(self, nbytes: float, what: str = "the output") -> None:
        """Refuse before any work an output that cannot fit on the file system.

        ``nbytes`` is the uncompressed size; the file is zlib-compressed, so it is refused
        only if a quarter of it does not fit (a write-through target is not checked).
        """
        if self.through:
            return
        if _read_only(self.target.parent):  # (a read-only tmpfs reports its size as free)
            raise AttitudeFileError(
                f"{self.what}: {self.target}: the file system is read-only; write the output "
                "elsewhere"
            )
        free = _free_bytes(self.target)
        if free is not None and nbytes / 4.0 > free:
            raise AttitudeFileError(
                f"{self.what}: {what} needs about {_size(nbytes)} ({_size(nbytes / 4.0)} "
                f"compressed at best), but the file system of {self.target.parent} has "
                f"{_size(free)} free; write it elsewhere, or ask for fewer samples or members"
            )

    def prepare(self) -> None:
        """Create the parent directories and remove stale temporary files (call before writing)."""
        parent = self.tmp.parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise AttitudeFileError(
                f"{self.what}: {parent} exists and is not a directory"
            ) from None
        except OSError as exc:
            raise file_error(exc, self.target) from None
        remove_stale_temps(self.target, self._tmpdir)

    @contextlib.contextmanager
    def _discard_on_failure(self) -> Iterator[None]:
        """Any failure inside removes the temporary file; an OSError is reported as an
        :class:`AttitudeFileError` naming the output."""
        try:
            yield
        except OSError as exc:
            err = file_error(exc, self.target)  # before the discard frees the space
            self.discard()
            raise err from None
        except BaseException:
            self.discard()
            raise

    def commit(self) -> Path:
        """Put the complete temporary file in place (rename, or copy into a device/pipe).

        A pending interrupt request (:func:`attitude._interrupt.check`) aborts before that.
        """
        with self._discard_on_failure():
            with open(self.tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            _interrupt.check()
            if self.through:
                with open(self.tmp, "rb") as src, open(self.target, "wb") as dst:
                    shutil.copyfileobj(src, dst, 2**20)
                self.discard()
            else:
                os.replace(self.tmp, self.target)
                with contextlib.suppress(OSError):  # persist the rename (POSIX)
                    fd = os.open(self.target.parent, os.O_RDONLY)
                    try:
                        os.fsync(fd)
                    finally:
                        os.close(fd)
        return self.path

    @contextlib.contextmanager
    def writing(self) -> Iterator[Path]:
        """``with target.writing() as tmp: ...write tmp...; target.commit()``: the temporary
        file is prepared, and removed on any failure inside (an OSError reported as an
        :class:`AttitudeFileError` naming the output)."""
        self.prepare()
        with self._discard_on_failure():
            yield self.tmp

    def discard(self) -> None:
        """Remove the temporary file (the target is untouched)."""
        with contextlib.suppress(FileNotFoundError, OSError):
            self.tmp.unlink()

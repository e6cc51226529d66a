"""Layouts of the float64 arrays the compiled kernels read, each declared once.

The public objects (flight software, sensors, estimator, actuators, ...) hand the kernels
flat float64 arrays; each block of such an array is declared here once, by :func:`layout`,
with its fields in order, their sizes, units and meaning. The declaration gives

* the offsets, as upper-case attributes of a named tuple of ints (``FW.PERIOD``, ``FW.SIZE``):
  a module-level named tuple is a compile-time constant for numba, so ``fw[FW.PERIOD]``
  compiles to the same constant index as a hand-written literal would;
* the packing from Python (:meth:`Layout.pack`, :meth:`Layout.pack_into`) and the readers
  (:meth:`Layout.read`, which also reads a block of records, one per row), with the
  fields' units (:meth:`Layout.unit`) for the results built from them.

Variable-length sections (mode tables, matrices, tables appended after a header whose fields
hold their offsets) are laid out by :class:`Appender`.

Pure Python and numpy: nothing here is compiled.
"""

from __future__ import annotations

import sys
from collections import namedtuple
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

__all__ = ["Appender", "Field", "Gap", "Layout", "layout"]


@dataclass(frozen=True)
class Field:
    """One field of a layout: ``size`` float64 words (0: where a variable tail starts), in
    ``unit``, meaning ``doc``; ``shape`` for a matrix (row-major)."""

    size: int = 1
    unit: str = ""
    doc: str = ""
    shape: tuple[int, ...] | None = None


@dataclass(frozen=True)
class Gap:
    """``size`` unused words (kept so that the offsets after them stay where they were)."""

    size: int = 1


@dataclass(frozen=True)
class FieldInfo:
    """A declared field with its offset."""

    name: str
    offset: int
    size: int
    unit: str
    doc: str
    shape: tuple[int, ...] | None


class Layout(tuple):
    """Base of the named tuples :func:`layout` makes: the Python-side methods.

    The tuple's items are the fields' offsets, then ``SIZE``; the methods below are plain
    Python (numba reads the offsets only).
    """

    __slots__ = ()
    _name: ClassVar[str] = ""
    _infos: ClassVar[dict[str, FieldInfo]] = {}

    @property
    def fields(self) -> dict[str, FieldInfo]:
        """The declared fields by (lower-case) name, in order."""
        return dict(self._infos)

    def unit(self, name: str) -> str:
        """The unit of field ``name``."""
        return self._info(name).unit

    def _info(self, name: str) -> FieldInfo:
        try:
            return self._infos[name]
        except KeyError:
            raise KeyError(
                f"{self._name}: no field {name!r} (fields: {list(self._infos)})"
            ) from None

    def pack(self, /, **values: Any) -> np.ndarray:
        """A new block (zeros where a field is not given) holding ``values``."""
        out = np.zeros(self.SIZE)  # type: ignore[attr-defined]
        self.pack_into(out, 0, **values)
        return out

    def pack_into(self, a: np.ndarray, offset: int = 0, /, **values: Any) -> np.ndarray:
        """Write ``values`` (a field's name: a number, or as many as its size) into the block
        of ``a`` at ``offset``; returns ``a``."""
        for name, v in values.items():
            f = self._info(name)
            x = np.asarray(v, dtype=np.float64).reshape(-1)
            if x.size != f.size:
                raise ValueError(f"{self._name}.{name}: {x.size} values for {f.size} words")
            a[offset + f.offset : offset + f.offset + f.size] = x
        return a

    def read(self, a: np.ndarray, offset: int = 0) -> dict[str, Any]:
        """The fields of the block of ``a`` at ``offset`` (along the last axis: from a 2-D
        array, a column or columns per field, one record per row); single words as floats
        (or columns), the others as arrays (matrices in their shape). Variable tails (size 0)
        are left to the caller."""
        a = np.asarray(a)
        out: dict[str, Any] = {}
        for name, f in self._infos.items():
            if f.size == 0:
                continue
            o = offset + f.offset
            if f.size == 1:
                v = a[..., o]
                out[name] = float(v) if v.ndim == 0 else v
            else:
                v = a[..., o : o + f.size]
                out[name] = v.reshape(v.shape[:-1] + f.shape) if f.shape else v
        return out


def layout(name: str, *, size: int | None = None, **fields: int | Field | Gap) -> Layout:
    """Declare a block: ``fields`` in order (an int is a field of that many words, a
    :class:`Field` gives its size, unit and meaning, a :class:`Gap` leaves words unused);
    ``size`` pads the block to that many words (room to grow).

    Returns
    -------
    Layout
        A named tuple of the offsets (upper-case names) and ``SIZE``.
    """
    infos: dict[str, FieldInfo] = {}
    at = 0
    for key, spec in fields.items():
        if isinstance(spec, Gap):
            at += spec.size
            continue
        f = spec if isinstance(spec, Field) else Field(int(spec))
        if f.size < 0 or (f.shape is not None and int(np.prod(f.shape)) != f.size):
            raise ValueError(f"{name}.{key}: size {f.size} does not fit shape {f.shape}")
        if key != key.lower() or key.upper() == "SIZE":
            raise ValueError(f"{name}.{key}: field names are lower case, and not 'size'")
        infos[key] = FieldInfo(key, at, f.size, f.unit, f.doc, f.shape)
        at += f.size
    if size is not None:
        if size < at:
            raise ValueError(f"{name}: the fields take {at} words, more than size={size}")
        at = size
    names = [k.upper() for k in infos] + ["SIZE"]
    # the class lives in the declaring module under a name of its own, so that it pickles by
    # reference (a process that imports that module finds it)
    where = sys._getframe(1).f_globals
    tag = "_layout_" + "".join(c if c.isalnum() else "_" for c in name)
    qual, k = tag, 2
    while qual in where:
        qual, k = f"{tag}_{k}", k + 1
    base = namedtuple(qual, names)
    cls = type(qual, (base, Layout), {"__slots__": (), "_name": name, "_infos": infos})
    cls.__module__ = where.get("__name__", __name__)
    where[qual] = cls
    return cls(*[f.offset for f in infos.values()], at)


class Appender:
    """A float64 array built by appending blocks: each :meth:`append` returns where its block
    starts (what a header's offset field holds)."""

    def __init__(self, head: np.ndarray | None = None):
        self._parts: list[np.ndarray] = []
        self.size = 0
        if head is not None:
            self.append(head)

    def append(self, block: Any) -> int:
        """Append ``block`` (flattened); returns its offset."""
        at = self.size
        x = np.asarray(block, dtype=np.float64).reshape(-1)
        self._parts.append(x)
        self.size += x.size
        return at

    def array(self) -> np.ndarray:
        """The concatenated array (a new, contiguous one)."""
        if not self._parts:
            return np.zeros(0)
        return np.ascontiguousarray(np.concatenate(self._parts))

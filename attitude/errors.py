"""Exceptions raised by ``attitude``.

Every exception raised on purpose derives from :class:`AttitudeError` and also from the
built-in class a caller would naturally catch (``ValueError``, ``TypeError`` or
``RuntimeError``). Messages name the offending argument and say how to fix it.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "AttitudeError",
    "AttitudeFileError",
    "AttitudeTypeError",
    "AttitudeValueError",
    "OutputSizeError",
    "PropagationError",
    "SingularityError",
]


class AttitudeError(Exception):
    """Base class of every exception raised on purpose by ``attitude``."""


class AttitudeValueError(AttitudeError, ValueError):
    """An argument has a bad value: non-finite, wrong shape, not a rotation, unknown name..."""


class AttitudeTypeError(AttitudeError, TypeError):
    """An argument has the wrong type or units that cannot be converted."""


class AttitudeFileError(AttitudeValueError, OSError):
    """A file cannot be written or read where asked: a bad path, a directory, no permission, a
    full disk, a file that is not a result file. The message names the path and the fix.

    Also an ``OSError``, as the errors of ``open()`` are; ``errno`` is not set.
    """


class OutputSizeError(AttitudeValueError):
    """An ensemble's output would exceed its size limit (``max_output_size``); nothing was run.

    Attributes
    ----------
    expected, limit : float
        The expected output size and the limit, in bytes.
    """

    def __init__(self, message: str, *, expected: float, limit: float):
        super().__init__(message)
        self.expected = expected
        self.limit = limit


class SingularityError(AttitudeValueError):
    """A representation is singular at the requested state (e.g. 3-1-3 angles at ϑ = 0 or π)."""


class PropagationError(AttitudeError, RuntimeError):
    """A propagation stopped before the final time.

    Attributes
    ----------
    time : float
        Time at which the integration stopped.
    partial : xarray.Dataset or None
        The output samples computed before the failure (same schema as a complete run).
    """

    def __init__(self, message: str, *, time: float = float("nan"), partial: Any = None):
        super().__init__(message)
        self.time = time
        self.partial = partial

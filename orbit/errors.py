"""Exceptions raised by the ``orbit`` package (all subclasses of ValueError or TypeError)."""

from __future__ import annotations

__all__ = ["OrbitError", "OrbitTypeError", "OrbitValueError"]


class OrbitError(Exception):
    """Base class of every exception raised on purpose by ``orbit``."""


class OrbitValueError(OrbitError, ValueError):
    """An orbit argument has a bad value (names the parameter and the fix)."""


class OrbitTypeError(OrbitError, TypeError):
    """An orbit argument has the wrong type or incompatible units."""

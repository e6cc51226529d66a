"""Kepler's equation and anomaly conversions, vectorised over numpy arrays.

Elliptic orbits (0 <= e < 1)::

    M = E − e sin E                                   (mean M, eccentric E)
    tan(f/2) = sqrt((1 + e)/(1 − e)) tan(E/2)         (true anomaly f)

Hyperbolic orbits (e > 1)::

    M = e sinh H − H                                  (hyperbolic anomaly H)
    tan(f/2) = sqrt((e + 1)/(e − 1)) tanh(H/2),       |f| < acos(−1/e)

All angles are in radians (astropy angle Quantities are converted). Arguments broadcast
against each other like numpy ufuncs; two scalars give a Python float. Elliptic anomalies are
continuous: no wrapping to [0, 2π), E(M + 2π) = E(M) + 2π and f(E + 2π) = f(E) + 2π.

:func:`solve_kepler` and :func:`solve_kepler_hyperbolic` can also be called from numba-compiled
code (scalars or arrays); inside compiled right-hand sides prefer the scalar kernels
``orbit._kernels.kepler_E`` / ``kepler_H``, which skip the argument checks.

Accuracy of :func:`solve_kepler` (tests/test_kepler.py, 50-digit mpmath reference): for every
M with |M| <= π and 0 <= e <= 1 − 1e-9, |E − E_exact| <= 1.4 ulp(E) (< 3e-16 rad) and the
residual |E − e sin E − M|, evaluated exactly for the returned float, is at most 0.82 of
4e-16·max(1, |M|) (45 000 points, including the hard corner e -> 1, M -> 0). The method:
Markley (1995) starter, one sixth-order correction with a cancellation-free residual; see
:mod:`orbit._kernels` and docs/orbit.md.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _kernels as _k
from ._shared_jit import JIT_DISABLED
from .errors import OrbitTypeError, OrbitValueError

__all__ = [
    "MAX_HYPERBOLIC_E",
    "MAX_MEAN_ANOMALY",
    "eccentric_from_true",
    "hyperbolic_from_true",
    "mean_from_eccentric",
    "mean_from_hyperbolic",
    "mean_from_true",
    "mean_from_true_hyperbolic",
    "solve_kepler",
    "solve_kepler_hyperbolic",
    "true_from_eccentric",
    "true_from_hyperbolic",
    "true_from_mean",
    "true_from_mean_hyperbolic",
]

#: Largest |angle| [rad] accepted where an angle is reduced modulo 2π (2**50 ≈ 1.1e15 rad;
#: beyond it a float angle has less than 3 significant bits modulo 2π).
MAX_MEAN_ANOMALY = float(2**50)


# ---------------------------------------------------------------------------------------------
# Boundary validation (shared with orbit.keplerorbit).
def _to_value(x: Any, name: str, unit: Any) -> Any:
    """Strip astropy units after converting to ``unit`` (None: must be dimensionless)."""
    try:
        from astropy import units as u
    except ImportError:  # pragma: no cover - astropy is a dependency
        return x
    if isinstance(x, u.Quantity):
        target = u.dimensionless_unscaled if unit is None else u.Unit(unit)
        try:
            return x.to_value(target)
        except u.UnitConversionError as exc:
            if unit is None:
                msg = f"{name}: expected a plain number or a dimensionless quantity, got {x.unit}"
            else:
                msg = (
                    f"{name}: units {x.unit} cannot be converted to {target}; give {name} "
                    f"as a plain number in {target} or a Quantity compatible with {target}"
                )
            raise OrbitTypeError(msg) from exc
    return x


def _as_array(x: Any, name: str, unit: Any = None) -> np.ndarray:
    """Finite float64 array from a number, array or Quantity (converted to ``unit``)."""
    x = _to_value(x, name, unit)
    if isinstance(x, (str, bytes)):
        raise OrbitTypeError(f"{name}: expected real numbers, got {x!r}")
    try:
        raw = np.asarray(x)
        if isinstance(x, (bool, np.bool_)) or raw.dtype.kind in "bcUSVMm":  # not real numbers
            raise TypeError(f"{raw.dtype} values")
        arr = raw.astype(np.float64, copy=False)
    except OverflowError as exc:
        raise OrbitValueError(f"{name}: a value is too large for double precision") from exc
    except (TypeError, ValueError) as exc:
        raise OrbitTypeError(f"{name}: expected real numbers, got {x!r}") from exc
    if not np.all(np.isfinite(arr)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(arr))[0])
        where = f" at index {bad}" if bad else ""
        raise OrbitValueError(f"{name}: must be finite (got NaN or infinity{where})")
    return arr


_HYPERBOLIC_COUNTERPART = {
    "solve_kepler": "solve_kepler_hyperbolic",
    "true_from_eccentric": "true_from_hyperbolic",
    "eccentric_from_true": "hyperbolic_from_true",
    "mean_from_eccentric": "mean_from_hyperbolic",
    "true_from_mean": "true_from_mean_hyperbolic",
    "mean_from_true": "mean_from_true_hyperbolic",
}


def _scalar(x: Any, name: str, unit: Any) -> float:
    arr = _as_array(x, name, unit)
    if arr.ndim != 0:
        if arr.size == 1:
            return float(arr.reshape(()))
        raise OrbitValueError(
            f"{name}: expected a single number (one orbit), got an array of shape {arr.shape}"
        )
    return float(arr)


def _check_elliptic_e(e: np.ndarray, func: str, name: str = "e") -> None:
    bad = ~((e >= 0.0) & (e < 1.0))
    if np.any(bad):
        val = float(e[tuple(np.argwhere(bad)[0])])
        other = _HYPERBOLIC_COUNTERPART.get(func, "the hyperbolic function")
        hint = (
            f" (for a hyperbola, e > 1, use {other})"
            if val > 1.0
            else " (a parabola, e = 1, is not supported)"
            if val == 1.0
            else " (eccentricity cannot be negative)"
        )
        raise OrbitValueError(
            f"{name}: {func} needs an elliptic eccentricity 0 <= {name} < 1, "
            f"got {name} = {val!r}{hint}"
        )


#: Largest hyperbolic eccentricity accepted (e sinh H must stay far from float overflow).
MAX_HYPERBOLIC_E = 1.0e100


def _check_hyperbolic_e(e: np.ndarray, func: str, name: str = "e") -> None:
    if np.any(e > MAX_HYPERBOLIC_E):
        raise OrbitValueError(
            f"{name}: {func} supports e <= 1e100, got {name} = {float(np.max(e))!r}"
        )
    bad = ~(e > 1.0)
    if np.any(bad):
        val = float(e[tuple(np.argwhere(bad)[0])])
        raise OrbitValueError(
            f"{name}: {func} needs a hyperbolic eccentricity {name} > 1, got {name} = {val!r}"
            + (" (use the elliptic function for 0 <= e < 1)" if 0.0 <= val < 1.0 else "")
        )


def _check_reducible(x: np.ndarray, name: str) -> None:
    if np.any(np.abs(x) > MAX_MEAN_ANOMALY):
        raise OrbitValueError(
            f"{name}: |{name}| must be at most 2**50 rad (~1.1e15) to be reduced modulo 2π "
            f"with any accuracy; got {float(np.max(np.abs(x)))!r}"
        )


def _apply(loop, x: np.ndarray, e: np.ndarray) -> Any:
    """Broadcast (x, e), run the compiled loop on contiguous copies, restore the shape."""
    try:
        xb, eb = np.broadcast_arrays(x, e)
    except ValueError as exc:
        raise OrbitValueError(
            f"shapes {x.shape} and {e.shape} of the anomaly and e do not broadcast"
        ) from exc
    xf = np.ascontiguousarray(xb, dtype=np.float64).ravel()
    ef = np.ascontiguousarray(eb, dtype=np.float64).ravel()
    out = np.empty(xf.size, dtype=np.float64)
    loop(xf, ef, out)
    if xb.ndim == 0:
        return float(out[0])
    return out.reshape(xb.shape)


# ---------------------------------------------------------------------------------------------
# Kepler's equation.
def _elliptic(loop: Any, x: Any, name: str, e: Any, func: str) -> Any:
    """``loop`` over the anomaly ``x`` (``name``, rad) and elliptic eccentricities ``e`` after
    the checks of ``func``'s input."""
    xa = _as_array(x, name, "rad")
    ea = _as_array(e, "e")
    _check_elliptic_e(ea, func)
    _check_reducible(xa, name)
    return _apply(loop, xa, ea)


def solve_kepler(M: Any, e: Any) -> Any:
    """Eccentric anomaly E from the mean anomaly M of an elliptic orbit: M = E − e sin E.

    Parameters
    ----------
    M : float or array_like [rad]
        Mean anomaly, any real value with |M| <= 2**50 (reduced internally; E is continuous
        in M and E(M + 2π) = E(M) + 2π). Angle Quantities accepted.
    e : float or array_like
        Eccentricity, 0 <= e < 1; broadcasts against M.

    Returns
    -------
    E : float or ndarray, shape of broadcast(M, e) [rad]

    Raises
    ------
    OrbitValueError
        e outside [0, 1), non-finite input, |M| > 2**50.
    OrbitTypeError
        Non-numeric input or incompatible units.

    Notes
    -----
    Markley (1995) cubic starter and one sixth-order correction, with the residual
    E − e sin E − M evaluated without cancellation ((1 − e) E + e (E − sin E) by series near
    E = 0; error-free sum and product elsewhere). Error at most ~1.4 ulp(E) for |M| <= π,
    including e -> 1 with M -> 0.
    """
    return _elliptic(_k.kepler_E_loop, M, "M", e, "solve_kepler")


def solve_kepler_hyperbolic(M: Any, e: Any) -> Any:
    """Hyperbolic anomaly H from the mean anomaly M of a hyperbolic orbit: M = e sinh H − H.

    Parameters
    ----------
    M : float or array_like [rad]
        Hyperbolic mean anomaly, any finite real value.
    e : float or array_like
        Eccentricity, 1 < e <= 1e100; broadcasts against M.

    Returns
    -------
    H : float or ndarray, shape of broadcast(M, e)

    Raises
    ------
    OrbitValueError
        e <= 1, e > 1e100 or non-finite input.
    OrbitTypeError
        Non-numeric input or incompatible units.

    Notes
    -----
    Starts from the smaller of two upper bounds of H and converges monotonically with Halley
    steps (at most 3 on the whole domain), then one Newton polish with a cancellation-free
    residual; error at most ~1.0 ulp(H) measured.
    """
    Ma = _as_array(M, "M", "rad")
    ea = _as_array(e, "e")
    _check_hyperbolic_e(ea, "solve_kepler_hyperbolic")
    return _apply(_k.kepler_H_loop, Ma, ea)


# ---------------------------------------------------------------------------------------------
# Elliptic anomaly conversions.
def true_from_eccentric(E: Any, e: Any) -> Any:
    """True anomaly f from the eccentric anomaly E (elliptic), continuous in E.

    Parameters
    ----------
    E : float or array_like [rad]
        Eccentric anomaly, |E| <= 2**50.
    e : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    f : float or ndarray [rad]
        tan(f/2) = sqrt((1 + e)/(1 − e)) tan(E/2), with f = E at E = kπ.
    """
    return _elliptic(_k.true_from_eccentric_loop, E, "E", e, "true_from_eccentric")


def eccentric_from_true(f: Any, e: Any) -> Any:
    """Eccentric anomaly E from the true anomaly f (elliptic), continuous in f.

    Parameters
    ----------
    f : float or array_like [rad]
        True anomaly, |f| <= 2**50.
    e : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    E : float or ndarray [rad]
    """
    return _elliptic(_k.eccentric_from_true_loop, f, "f", e, "eccentric_from_true")


def mean_from_eccentric(E: Any, e: Any) -> Any:
    """Mean anomaly M = E − e sin E (elliptic), cancellation-free near E = 0 as e -> 1.

    Parameters
    ----------
    E : float or array_like [rad]
    e : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    M : float or ndarray [rad]
    """
    return _elliptic(_k.mean_from_eccentric_loop, E, "E", e, "mean_from_eccentric")


def true_from_mean(M: Any, e: Any) -> Any:
    """True anomaly f from the mean anomaly M (elliptic), continuous in M.

    Parameters
    ----------
    M : float or array_like [rad]
    e : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    f : float or ndarray [rad]
    """
    return _elliptic(_k.true_from_mean_loop, M, "M", e, "true_from_mean")


def mean_from_true(f: Any, e: Any) -> Any:
    """Mean anomaly M from the true anomaly f (elliptic), continuous in f.

    Parameters
    ----------
    f : float or array_like [rad]
    e : float or array_like
        Eccentricity, 0 <= e < 1.

    Returns
    -------
    M : float or ndarray [rad]
    """
    return _elliptic(_k.mean_from_true_loop, f, "f", e, "mean_from_true")


# ---------------------------------------------------------------------------------------------
# Hyperbolic anomaly conversions.
def _check_true_hyperbolic(f: np.ndarray, e: np.ndarray, func: str) -> None:
    fb, eb = np.broadcast_arrays(f, e)
    lim = np.arccos(-1.0 / eb)
    bad = ~(np.abs(fb) < lim)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise OrbitValueError(
            f"f: {func} needs |f| < acos(−1/e), the asymptote of the hyperbola; got "
            f"f = {float(fb[idx])!r} with e = {float(eb[idx])!r} (limit {float(lim[idx])!r})"
        )


def _hyperbolic(loop: Any, x: Any, name: str, e: Any, func: str, true: bool = False) -> Any:
    """``loop`` over the anomaly ``x`` (``name``, rad) and hyperbolic eccentricities ``e`` after
    the checks of ``func``'s input (``true``: ``x`` is a true anomaly, inside the asymptotes;
    e sinh H for the mean anomaly: |H| at most 709)."""
    xa = _as_array(x, name, "rad")
    ea = _as_array(e, "e")
    _check_hyperbolic_e(ea, func)
    if true:
        _check_true_hyperbolic(xa, ea, func)
    if func == "mean_from_hyperbolic" and np.any(np.abs(xa) > 709.0):
        raise OrbitValueError("H: |H| must be at most 709 (e sinh H overflows a float beyond)")
    return _apply(loop, xa, ea)


def true_from_hyperbolic(H: Any, e: Any) -> Any:
    """True anomaly f from the hyperbolic anomaly H: tan(f/2) = sqrt((e+1)/(e−1)) tanh(H/2).

    Parameters
    ----------
    H : float or array_like
    e : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    f : float or ndarray [rad], |f| < acos(−1/e)
    """
    return _hyperbolic(_k.true_from_hyperbolic_loop, H, "H", e, "true_from_hyperbolic")


def hyperbolic_from_true(f: Any, e: Any) -> Any:
    """Hyperbolic anomaly H from the true anomaly f, |f| < acos(−1/e).

    Parameters
    ----------
    f : float or array_like [rad]
    e : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    H : float or ndarray
    """
    return _hyperbolic(_k.hyperbolic_from_true_loop, f, "f", e, "hyperbolic_from_true", True)


def mean_from_hyperbolic(H: Any, e: Any) -> Any:
    """Hyperbolic mean anomaly M = e sinh H − H (cancellation-free near H = 0 as e -> 1).

    Parameters
    ----------
    H : float or array_like
    e : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    M : float or ndarray
    """
    return _hyperbolic(_k.mean_from_hyperbolic_loop, H, "H", e, "mean_from_hyperbolic")


def true_from_mean_hyperbolic(M: Any, e: Any) -> Any:
    """True anomaly f from the hyperbolic mean anomaly M (e > 1).

    Parameters
    ----------
    M : float or array_like
    e : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    f : float or ndarray [rad], |f| < acos(−1/e)
    """
    return _hyperbolic(_k.true_from_mean_hyperbolic_loop, M, "M", e, "true_from_mean_hyperbolic")


def mean_from_true_hyperbolic(f: Any, e: Any) -> Any:
    """Hyperbolic mean anomaly M from the true anomaly f, |f| < acos(−1/e).

    Parameters
    ----------
    f : float or array_like [rad]
    e : float or array_like
        Eccentricity, e > 1.

    Returns
    -------
    M : float or ndarray
    """
    return _hyperbolic(
        _k.mean_from_true_hyperbolic_loop, f, "f", e, "mean_from_true_hyperbolic", True
    )


# ---------------------------------------------------------------------------------------------
# numba: make solve_kepler / solve_kepler_hyperbolic callable from compiled code. Registering
# an overload compiles nothing; the implementation is compiled when a jitted caller is.
def _register_numba_overloads() -> None:
    from numba import types
    from numba.extending import overload

    _num = (types.Float, types.Integer)

    def _make(func_name: str, kernel, ok, msg: str, check_m):
        def typer(M, e):
            m_scalar = isinstance(M, _num)
            e_scalar = isinstance(e, _num)
            m_arr = isinstance(M, types.Array) and isinstance(M.dtype, _num)
            e_arr = isinstance(e, types.Array) and isinstance(e.dtype, _num)
            if m_scalar and e_scalar:

                def impl(M, e):
                    if not ok(e):
                        raise OrbitValueError(msg)
                    if not check_m(M):
                        raise OrbitValueError(func_name + ": M must be finite (|M| <= 2**50)")
                    return kernel(float(M), float(e))

                return impl
            if m_arr and e_scalar:

                def impl(M, e):
                    if not ok(e):
                        raise OrbitValueError(msg)
                    Mf = M.ravel()
                    out = np.empty(Mf.size, dtype=np.float64)
                    for i in range(Mf.size):
                        if not check_m(Mf[i]):
                            raise OrbitValueError(func_name + ": M must be finite (|M| <= 2**50)")
                        out[i] = kernel(float(Mf[i]), float(e))
                    return out.reshape(M.shape)

                return impl
            if m_arr and e_arr:

                def impl(M, e):
                    if M.shape != e.shape:
                        raise OrbitValueError(func_name + ": M and e arrays must have one shape")
                    Mf = M.ravel()
                    ef = e.ravel()
                    out = np.empty(Mf.size, dtype=np.float64)
                    for i in range(Mf.size):
                        if not ok(ef[i]):
                            raise OrbitValueError(msg)
                        if not check_m(Mf[i]):
                            raise OrbitValueError(func_name + ": M must be finite (|M| <= 2**50)")
                        out[i] = kernel(float(Mf[i]), float(ef[i]))
                    return out.reshape(M.shape)

                return impl
            return None

        return typer

    from ._shared_jit import jit

    @jit
    def _ok_ell(e):
        return e >= 0.0 and e < 1.0

    @jit
    def _ok_hyp(e):
        return e > 1.0 and e <= 1.0e100

    @jit
    def _ok_m_ell(M):
        return abs(M) <= MAX_MEAN_ANOMALY

    @jit
    def _ok_m_hyp(M):
        return math.isfinite(M)

    overload(solve_kepler)(
        _make(
            "solve_kepler",
            _k.kepler_E,
            _ok_ell,
            "solve_kepler: e must satisfy 0 <= e < 1 (use solve_kepler_hyperbolic for e > 1)",
            _ok_m_ell,
        )
    )
    overload(solve_kepler_hyperbolic)(
        _make(
            "solve_kepler_hyperbolic",
            _k.kepler_H,
            _ok_hyp,
            "solve_kepler_hyperbolic: e must satisfy 1 < e <= 1e100",
            _ok_m_hyp,
        )
    )


if not JIT_DISABLED:
    _register_numba_overloads()

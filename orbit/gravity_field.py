"""The Earth's gravity field in spherical harmonics: ``SphericalHarmonics(degree, order)``.

The coefficients are EGM2008's (Pavlis, Holmes, Kenyon & Factor 2012, J. Geophys. Res. 117,
B04406), tide-free and fully normalised, to degree and order 150, shipped with the package
(``orbit/data/egm2008.npz``; released by the US National Geospatial-Intelligence Agency for
public use; extracted by ``tools/extract_egm2008.py``), with the model's GM = 3.986004415e14
m³/s² and reference radius a = 6 378 136.3 m. The field is evaluated in compiled code by
Pines' non-singular recursion (:mod:`orbit._gravity_field_kernels`).
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from . import _gravity_field_kernels as _kg
from .errors import OrbitValueError
from .kepler import _as_array

__all__ = ["SphericalHarmonics"]

_DATA = Path(__file__).resolve().parent / "data" / "egm2008.npz"

#: The WGS 84 polar radius (m): nowhere on the Earth's surface is nearer its centre.
POLAR_RADIUS = 6_356_752.314245


@cache
def _egm2008() -> dict[str, Any]:
    with np.load(_DATA) as d:
        return {k: d[k] for k in d.files}


def _positions(r: Any, name: str) -> np.ndarray:
    arr = _as_array(r, name, "m")
    if arr.shape[-1:] != (3,):
        raise OrbitValueError(f"{name}: positions of shape (..., 3) in metres, got {arr.shape}")
    dist = np.linalg.norm(arr, axis=-1)
    if np.any(dist < POLAR_RADIUS):
        raise OrbitValueError(
            f"{name}: a position {float(dist.min()):.1f} m from the Earth's centre is inside the "
            f"Earth (the polar radius is {POLAR_RADIUS:.0f} m), where the series does not hold"
        )
    return arr


class SphericalHarmonics:
    """The Earth's gravity field to a degree and order, from a published model.

    Parameters
    ----------
    degree : int
        Maximum degree n, 0 (a point mass) to 150.
    order : int, optional
        Maximum order m, 0 to ``degree`` (default ``degree``).
    model : str
        ``"EGM2008"`` (the model shipped with the package).

    Attributes
    ----------
    mu : float
        The model's gravitational parameter GM, m³/s².
    radius : float
        The model's reference radius a, m.
    C, S : ndarray, shape (degree + 1, degree + 1)
        The fully normalised coefficients C̄ₙₘ, S̄ₙₘ to the degree and order (zero beyond).

    Examples
    --------
    >>> import numpy as np
    >>> from orbit import SphericalHarmonics
    >>> field = SphericalHarmonics(20)
    >>> g = field.acceleration(np.array([7.0e6, 0.0, 0.0]))  # ITRS, m -> m/s²
    >>> round(float(g[0]), 4)
    -8.1457
    """

    def __init__(self, degree: int, order: int | None = None, model: str = "EGM2008") -> None:
        if model != "EGM2008":
            raise OrbitValueError(f"model: the shipped model is 'EGM2008', got {model!r}")
        data = _egm2008()
        top = data["C"].shape[0] - 1
        for name, v in (("degree", degree), ("order", order)):
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer))):
                raise OrbitValueError(f"{name}: a whole number, got {v!r}")
        if not 0 <= degree <= top:
            raise OrbitValueError(
                f"degree: 0 to {top} (the shipped {model} goes to degree {top}), got {degree}"
            )
        order = degree if order is None else int(order)
        if not 0 <= order <= degree:
            raise OrbitValueError(f"order: 0 to the degree {degree}, got {order}")
        self.degree = int(degree)
        self.order = order
        self.model = model
        self.mu = float(data["mu"])
        self.radius = float(data["radius"])
        n = self.degree + 1
        keep = np.tril(np.ones((n, n), dtype=bool)) & (np.arange(n)[None, :] <= order)
        self.C = np.where(keep, data["C"][:n, :n], 0.0)
        self.S = np.where(keep, data["S"][:n, :n], 0.0)
        self.C.flags.writeable = False
        self.S.flags.writeable = False
        self._factors = _kg.factors(self.degree)

    def __repr__(self) -> str:
        return f"SphericalHarmonics({self.degree}, {self.order}, model={self.model!r})"

    @property
    def j2(self) -> float:
        """The field's J₂ = −√5 C̄₂₀ (0 below degree 2): the oblateness term of its potential."""
        return -math.sqrt(5.0) * float(self.C[2, 0]) if self.degree >= 2 else 0.0

    def _evaluate(self, r: Any, name: str) -> tuple[np.ndarray, np.ndarray, tuple]:
        pos = _positions(r, name)
        shape = pos.shape[:-1]
        flat = np.ascontiguousarray(pos.reshape(-1, 3))
        V = np.empty(flat.shape[0])
        g = np.empty((flat.shape[0], 3))
        _kg.field_loop(flat, self.C, self.S, self.degree, self.order, self.mu, self.radius,
                       self._factors, V, g)  # fmt: skip
        return V, g, shape

    def acceleration(self, r_itrs: Any) -> np.ndarray:
        """The gravitational acceleration at Earth-fixed positions.

        Parameters
        ----------
        r_itrs : array_like or Quantity, shape (..., 3) [m]
            Positions in the Earth-fixed frame (ITRS), outside the Earth.

        Returns
        -------
        ndarray, shape (..., 3) [m/s²]
            The acceleration in the same frame, −∇U.
        """
        _, g, shape = self._evaluate(r_itrs, "r_itrs")
        return g.reshape(*shape, 3)

    def potential(self, r_itrs: Any) -> np.ndarray:
        """The potential energy per unit mass at Earth-fixed positions.

        Parameters
        ----------
        r_itrs : array_like or Quantity, shape (..., 3) [m]
            Positions in the Earth-fixed frame (ITRS), outside the Earth.

        Returns
        -------
        ndarray, shape (...) [J/kg]
            U = −μ/r (1 + Σ ...): negative, the physicists' sign (the geodesists' V is −U),
            so that the acceleration is −∇U and a body's energy is v²/2 + U.
        """
        V, _, shape = self._evaluate(r_itrs, "r_itrs")
        return -V.reshape(shape)

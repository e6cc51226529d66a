"""Third bodies on an Earth orbit: ``ThirdBody("sun")``, ``ThirdBody("moon")``.

A point mass μ at the geocentric position s pulls a satellite at r (both in the GCRS) by
μ [(s − r)/|s − r|³ − s/|s|³]: its pull on the satellite less its pull on the Earth, which the
geocentric frame moves with (evaluated in Battin's form: :func:`orbit._gravity_field_kernels.
third_body`). The positions are the bodies' geometric ones (no light time: gravity acts on where
the body is) from astropy's ephemeris (``solar_system_ephemeris``, the built-in one by default:
ERFA's, no download), geocentric, in the ICRS axes the GCRS shares.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import _gravity_field_kernels as _kg
from .errors import OrbitValueError
from .kepler import _as_array
from .timescales import as_epoch, check_dates, offline_iers

__all__ = ["ThirdBody"]

#: Gravitational parameters (m³/s²): the Sun's, IAU 2015 Resolution B3 nominal GM☉; the Moon's,
#: JPL DE440's (Park et al. 2021, Astron. J. 161, 105: 4902.800118 km³/s²).
MU = {"sun": 1.3271244e20, "moon": 4.902800118e12}


class ThirdBody:
    """The Sun's or the Moon's point-mass perturbation of an Earth orbit.

    Parameters
    ----------
    body : {"sun", "moon"}
        The perturbing body.
    mu : float, optional
        Its gravitational parameter, m³/s² (default :data:`MU`).

    Examples
    --------
    >>> import numpy as np
    >>> from orbit import ThirdBody
    >>> moon = ThirdBody("moon")
    >>> a = moon.acceleration(np.array([7.0e6, 0.0, 0.0]), "2020-02-22T02:00:00", 0.0)
    >>> bool(1e-7 < np.linalg.norm(a) < 2e-6)  # m/s²: the Moon's tide at LEO
    True
    """

    def __init__(self, body: str, mu: float | None = None) -> None:
        if not isinstance(body, str) or body.lower() not in MU:
            raise OrbitValueError(f"body: 'sun' or 'moon', got {body!r}")
        self.body = body.lower()
        mu = MU[self.body] if mu is None else mu
        if isinstance(mu, bool) or not isinstance(mu, (int, float)) or not 0 < mu < np.inf:
            raise OrbitValueError(f"mu: a positive gravitational parameter in m³/s², got {mu!r}")
        self.mu = float(mu)

    def __repr__(self) -> str:
        return f"ThirdBody({self.body!r}, mu={self.mu!r})"

    def position(self, epoch: Any, t: Any) -> np.ndarray:
        """The body's geometric geocentric position (GCRS axes).

        Parameters
        ----------
        epoch : astropy Time or str
            Time origin of ``t``.
        t : float or array_like [s]
            Seconds since ``epoch``.

        Returns
        -------
        ndarray, shape t.shape + (3,) [m]
        """
        from astropy import units as u
        from astropy.coordinates import get_body_barycentric
        from astropy.time import TimeDelta

        ep = as_epoch(epoch, "epoch", allow_none=False)
        tt = _as_array(t, "t", "s")
        flat = tt.ravel()
        check_dates(ep, flat, "t")
        times = ep + TimeDelta(flat, format="sec")
        with offline_iers():
            rel = get_body_barycentric(self.body, times) - get_body_barycentric("earth", times)
            xyz = rel.xyz.to_value(u.m).T
        return np.ascontiguousarray(xyz).reshape((*tt.shape, 3))

    def acceleration(self, r_gcrs: Any, epoch: Any, t: Any) -> np.ndarray:
        """The perturbing acceleration on satellites at ``r_gcrs`` at times ``t``.

        Parameters
        ----------
        r_gcrs : array_like or Quantity, shape (..., 3) [m]
            Geocentric positions (GCRS).
        epoch : astropy Time or str
            Time origin of ``t``.
        t : float or array_like [s]
            Seconds since ``epoch``, broadcast against ``r_gcrs[..., 0]``.

        Returns
        -------
        ndarray, shape (..., 3) [m/s²]
        """
        r = _as_array(r_gcrs, "r_gcrs", "m")
        if r.shape[-1:] != (3,):
            raise OrbitValueError(f"r_gcrs: positions of shape (..., 3), got {r.shape}")
        tt = _as_array(t, "t", "s")
        try:
            shape = np.broadcast_shapes(r.shape[:-1], tt.shape)
        except ValueError:
            raise OrbitValueError(
                f"t: shape {tt.shape} does not broadcast against r_gcrs {r.shape}"
            ) from None
        s = self.position(epoch, np.broadcast_to(tt, shape))
        rr = np.ascontiguousarray(np.broadcast_to(r, (*shape, 3)).reshape(-1, 3))
        out = np.empty_like(rr)
        _kg.third_body_loop(self.mu, np.ascontiguousarray(s.reshape(-1, 3)), rr, out)
        return out.reshape(*shape, 3)

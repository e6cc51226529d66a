"""Flat-plate surface models: :class:`Facet` and the box-wing helper :func:`box_wing`.

A facet is a flat plate fixed to the body: area A, outward unit normal n̂ and the centre of
pressure c relative to the centre of mass (body axes), a drag coefficient C_D and the optical
fractions of the light it reflects specularly (C_s) and diffusely (C_d); the rest,
1 − C_s − C_d, is absorbed. :class:`attitude.potentials.AerodynamicDrag` and
:class:`attitude.potentials.SolarRadiation` sum the forces on the facets that face the flow or
the Sun (one-sided plates; a two-sided panel is two facets with opposite normals). Facets
shadowing each other from the flow or the light are not modelled.

Units: SI (m², m); astropy Quantities are converted.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ._validation import as_float_array, as_scalar
from .errors import AttitudeTypeError, AttitudeValueError

__all__ = ["Facet", "box_wing", "facet_array"]

#: Tolerance on |n̂| − 1 (normals are checked, never normalised silently).
NORMAL_TOL = 1e-6


class Facet:
    """A flat plate of the spacecraft surface (body axes, SI).

    Parameters
    ----------
    area : float or Quantity
        A > 0 [m²].
    normal : array_like, shape (3,)
        Outward unit normal n̂ (body axes); |n̂| must be 1 to 1e-6.
    center : array_like or Quantity, shape (3,)
        Centre of pressure relative to the centre of mass [m] (body axes).
    cd : float
        Drag coefficient C_D >= 0 (2.2 is the usual flat-plate value in free-molecular flow).
    specular, diffuse : float
        Fractions C_s, C_d of the incident light reflected specularly and diffusely, each in
        [0, 1] with C_s + C_d <= 1; the absorbed fraction is 1 − C_s − C_d.

    Raises
    ------
    AttitudeValueError
        A non-positive area, a non-unit normal, a negative C_D, optical coefficients outside
        [0, 1] or summing above 1 (the message names the parameter).
    """

    __slots__ = ("area", "cd", "center", "diffuse", "normal", "specular")

    def __init__(
        self,
        area: Any,
        normal: Any,
        center: Any,
        cd: float = 2.2,
        specular: float = 0.0,
        diffuse: float = 0.0,
    ):
        a = as_float_array(area, "area", unit="m2")
        if a.shape != ():
            raise AttitudeValueError(f"area: expected one number (m²), got shape {a.shape}")
        if not float(a) > 0.0:
            raise AttitudeValueError(f"area: must be > 0 (m²), got {float(a)!r}")
        n = as_float_array(normal, "normal")
        if n.shape != (3,):
            raise AttitudeValueError(f"normal: expected 3 body-axis components, got {n.shape}")
        nn = float(np.linalg.norm(n))
        if abs(nn - 1.0) > NORMAL_TOL:
            raise AttitudeValueError(
                f"normal: must be a unit vector (|n| = {nn!r}); give n / |n| "
                f"(e.g. {np.round(n / nn, 6).tolist() if nn > 0 else [1.0, 0.0, 0.0]})"
            )
        c = as_float_array(center, "center", unit="m")
        if c.shape != (3,):
            raise AttitudeValueError(f"center: expected 3 body-axis components (m), got {c.shape}")
        cdv = as_scalar(cd, "cd")
        if not cdv >= 0.0:
            raise AttitudeValueError(f"cd: the drag coefficient must be >= 0, got {cdv!r}")
        s = as_scalar(specular, "specular")
        d = as_scalar(diffuse, "diffuse")
        for name, v in (("specular", s), ("diffuse", d)):
            if not 0.0 <= v <= 1.0:
                raise AttitudeValueError(
                    f"{name}: an optical coefficient is a fraction of the incident light, in "
                    f"[0, 1]; got {v!r}"
                )
        if s + d > 1.0 + 1e-12:
            raise AttitudeValueError(
                f"specular, diffuse: the reflected fractions sum to {s + d!r} > 1; the absorbed "
                "fraction 1 − specular − diffuse cannot be negative"
            )
        self.area = float(a)
        self.normal = n / nn
        self.center = c
        self.cd = cdv
        self.specular = s
        self.diffuse = d

    @property
    def absorbed(self) -> float:
        """Absorbed fraction C_a = 1 − C_s − C_d."""
        return max(0.0, 1.0 - self.specular - self.diffuse)

    def drag_row(self) -> list[float]:
        """[A, n̂ (3), c (3), C_D]: the facet in the drag block (attitude._core.environment)."""
        return [self.area, *self.normal, *self.center, self.cd]

    def optical_row(self) -> list[float]:
        """[A, n̂ (3), c (3), C_s, C_d]: the facet in the solar-radiation block."""
        return [self.area, *self.normal, *self.center, self.specular, self.diffuse]

    def __repr__(self) -> str:
        return (
            f"Facet(area={self.area!r}, normal={self.normal.tolist()}, "
            f"center={self.center.tolist()}, cd={self.cd!r}, specular={self.specular!r}, "
            f"diffuse={self.diffuse!r})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Facet):
            return NotImplemented
        return self.drag_row() == other.drag_row() and self.optical_row() == other.optical_row()

    __hash__ = None  # type: ignore[assignment]

    @classmethod
    def box_wing(cls, *args: Any, **kwargs: Any) -> list[Facet]:
        """The facets of a box with flat wings: see :func:`box_wing`."""
        return box_wing(*args, **kwargs)


def box_wing(
    size: Any,
    *,
    center: Any = (0.0, 0.0, 0.0),
    cd: float = 2.2,
    specular: float = 0.0,
    diffuse: float = 0.0,
    wings: Iterable[Any] = (),
    wing_cd: float | None = None,
    wing_specular: float | None = None,
    wing_diffuse: float | None = None,
    wing_back: dict[str, float] | None = None,
) -> list[Facet]:
    """Facets of a box-wing spacecraft: a rectangular box and flat two-sided panels (wings).

    Parameters
    ----------
    size : array_like or Quantity, shape (3,)
        Edge lengths (l1, l2, l3) of the box along the body axes [m]; its six faces get outward
        normals ±b_i, areas l_j l_k and centres at ± l_i / 2 from the box centre.
    center : array_like or Quantity, shape (3,)
        Geometric centre of the box relative to the centre of mass [m].
    cd, specular, diffuse : float
        Coefficients of the box faces (see :class:`Facet`).
    wings : iterable of (area, normal, center)
        Panels: area [m²] of one side, unit normal of the front side, centre relative to the
        centre of mass [m]. Each wing gives two facets, front (``normal``) and back
        (``-normal``), at the same centre.
    wing_cd, wing_specular, wing_diffuse : float, optional
        Coefficients of the wings' front sides (default: those of the box).
    wing_back : dict, optional
        ``cd``, ``specular``, ``diffuse`` of the wings' back sides (default: the front's).

    Returns
    -------
    list of Facet
        The six box faces (+b1, −b1, +b2, −b2, +b3, −b3), then front and back of each wing.

    Examples
    --------
    A 3U CubeSat (10 × 10 × 34 cm) with two deployed 30 × 10 cm panels facing +b1:

    >>> box_wing([0.1, 0.1, 0.34], wings=[(0.03, [1, 0, 0], [0, 0.2, 0]),
    ...                                   (0.03, [1, 0, 0], [0, -0.2, 0])])  # doctest: +SKIP
    """
    s = as_float_array(size, "size", unit="m")
    if s.shape != (3,) or not np.all(s > 0):
        raise AttitudeValueError(
            f"size: expected three positive edge lengths (m) along b1, b2, b3, got {s.tolist()}"
        )
    c0 = as_float_array(center, "center", unit="m")
    if c0.shape != (3,):
        raise AttitudeValueError(f"center: expected 3 body-axis components (m), got {c0.shape}")
    out: list[Facet] = []
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[i] = sign
            c = c0 + 0.5 * s[i] * n
            out.append(Facet(s[j] * s[k], n, c, cd=cd, specular=specular, diffuse=diffuse))
    front = {
        "cd": cd if wing_cd is None else wing_cd,
        "specular": specular if wing_specular is None else wing_specular,
        "diffuse": diffuse if wing_diffuse is None else wing_diffuse,
    }
    back = dict(front)
    if wing_back is not None:
        if not isinstance(wing_back, dict):
            raise AttitudeTypeError(
                f"wing_back: expected a dict of the wings' back-face coefficients such as "
                f"{{'cd': 2.2, 'specular': 0.0, 'diffuse': 0.1}}, got {type(wing_back).__name__}"
            )
        unknown = set(wing_back) - {"cd", "specular", "diffuse"}
        if unknown:
            raise AttitudeValueError(
                f"wing_back: unknown keys {sorted(unknown)}; use cd, specular, diffuse"
            )
        back.update(wing_back)
    for i, w in enumerate(wings):
        try:
            area, normal, wc = w
        except (TypeError, ValueError):
            raise AttitudeTypeError(
                f"wings[{i}]: expected (area, normal, center), got {w!r}"
            ) from None
        f = Facet(area, normal, wc, **front)
        out.append(f)
        out.append(Facet(f.area, -f.normal, f.center, **back))
    return out


def facet_array(facets: Any, name: str = "facets") -> tuple[Facet, ...]:
    """Validate a sequence of :class:`Facet` (at least one)."""
    if isinstance(facets, Facet):
        facets = [facets]
    if not isinstance(facets, Sequence) and not isinstance(facets, Iterable):
        raise AttitudeTypeError(f"{name}: expected a list of attitude.Facet")
    try:
        out = tuple(facets)
    except TypeError:  # iterable by type but not by value (a scalar Quantity, a 0-d array)
        raise AttitudeTypeError(f"{name}: expected a list of attitude.Facet") from None
    if not out:
        raise AttitudeValueError(f"{name}: needs at least one attitude.Facet")
    for i, f in enumerate(out):
        if not isinstance(f, Facet):
            raise AttitudeTypeError(
                f"{name}[{i}]: expected an attitude.Facet, got {type(f).__name__}"
            )
    return out


def _normal_groups(facets: Sequence[Facet]) -> tuple[list[np.ndarray], list[list[tuple]]]:
    """Group facets by their normal up to sign: (unit normals n̂_g, per group the facets as
    (facet, side)), side +1 for a facet along n̂_g, −1 for one along −n̂_g (exact comparison)."""
    normals: list[np.ndarray] = []
    members: list[list[tuple]] = []
    where: dict[tuple, tuple[int, int]] = {}
    for f in facets:
        key = tuple(float(x) for x in f.normal)
        hit = where.get(key)
        if hit is None:
            hit = where[key] = (len(normals), 1)
            where.setdefault(tuple(-x for x in key), (len(normals), -1))
            normals.append(np.asarray(f.normal, dtype=np.float64))
            members.append([])
        members[hit[0]].append((f, hit[1]))
    return normals, members


def _group_rows(facets: Sequence[Facet], side: Any) -> np.ndarray:
    """(g, 3 + 2 k) rows [n̂ (3), Σ side(f) over the facets along +n̂ (k), then along −n̂ (k)],
    one per normal up to sign; ``side(f)`` the k numbers a facet's torque is linear in."""
    normals, members = _normal_groups(facets)
    k = len(side(facets[0]))
    rows = np.zeros((len(normals), 3 + 2 * k))
    for g, (n, fs) in enumerate(zip(normals, members, strict=True)):
        rows[g, :3] = n
        for f, sign in fs:
            at = 3 if sign > 0 else 3 + k
            rows[g, at : at + k] += side(f)
    return rows


def drag_groups(facets: Sequence[Facet]) -> np.ndarray:
    """The facets as the drag kernel sums them (attitude._core.environment): (g, 9) rows
    [n̂ (3), a₊ (3), a₋ (3)], one per normal up to sign, a± = Σ C_D A c [m³] over the facets
    along ±n̂.

    A facet's drag torque is −½ ρ max(n̂_f·v, 0) (C_D A c) × v (v the velocity relative to the
    atmosphere, body axes), linear in C_D A c: facets with one normal share max(n̂·v, 0), and
    of two opposite normals at most one faces the flow, so one dot product serves both.
    """
    return _group_rows(facets, lambda f: f.cd * f.area * f.center)


def force_groups(facets: Sequence[Facet], side: Any) -> np.ndarray:
    """(g, 2 k): per group of :func:`drag_groups` (the same order), the sums of the k numbers
    ``side(f)`` a facet's *force* is linear in, over the facets along +n̂ then −n̂ (a coupled
    run's orbit feels the forces whose moments the torques sum)."""
    return _group_rows(facets, lambda f: np.asarray(side(f), dtype=np.float64))[:, 3:]


def optical_groups(facets: Sequence[Facet]) -> np.ndarray:
    """The facets as the solar-radiation kernel sums them: (g, 21) rows [n̂ (3), then for the
    facets along +n̂ and then −n̂: a (3) m³, β_s (3) m³, β_d (3) m³], one row per normal up to
    sign, with a = Σ A (1 − C_s) c, β_s = Σ 2 A C_s c × n̂_f, β_d = Σ (2/3) A C_d c × n̂_f.

    A facet's torque −P [cos θ A (1 − C_s) c × ŝ + (2 A C_s cos² θ + (2/3) A C_d cos θ) c × n̂_f]
    (cos θ = n̂_f·ŝ > 0; Wertz 1978, Sect. 17.2.2) is linear in those three vectors.
    """

    def side(f: Facet) -> np.ndarray:
        cn = np.cross(f.center, f.normal)
        a = f.area
        return np.concatenate(
            [
                a * (1.0 - f.specular) * f.center,
                2.0 * a * f.specular * cn,
                (2.0 / 3.0) * a * f.diffuse * cn,
            ]
        )

    return _group_rows(facets, side)

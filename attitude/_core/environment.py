"""Compiled kernels of the environment torques: tables along the orbit, and the torques.

The environment along the orbit (magnetic field, atmospheric density and the velocity relative
to the atmosphere, the Sun) does not depend on the attitude: :mod:`attitude.environment`
computes it once per run on a uniform time grid with the reference libraries (ppigrf, pymsis,
astropy) and stores it in the model's block of ``params``; here it is interpolated inside the
right-hand side. No call into Python per step.

Table (at offset ``o`` of ``params``; every offset inside a block is relative to the block's
start, so blocks can be moved into a sum). A table is a list of segments, each a uniform
grid valid on [lo, hi] (a quantity with jumps, such as the NRLMSIS density of pymsis at UTC
midnight, is cut there; a time on a boundary belongs to the later segment)::

    d[o]                      nseg, the number of segments
    d[o + 1 + j]              offset of segment j relative to o (j < nseg)

    segment at s:
    d[s]                      n, the number of nodes (1: a constant, valid at every t)
    d[s + 1]                  h, the uniform node spacing [s]
    d[s + 2]                  1/h [1/s] (the lookup multiplies: no division per evaluation)
    d[s + 3]                  ncomp, values per node
    d[s + 4], d[s + 5]        lo, hi: where the segment is valid (the nodes may start or end
                              up to one step inside it: the edge window extrapolates)
    d[s + 6 : s + 6 + n]      node times t_k = t_0 + k h [s]
    d[s + 6 + n : ...]        n rows of ncomp values (row-major)

Block layouts (``kind`` first, ``tab`` the relative offset of the table):

* magnetic dipole ``[kind, tab, m (3, A m²), table: B (3, T, space axes)]``
* eddy currents ``[kind, tab, M (9, row-major, body axes, S m⁴), table: B (3, T), dB/dt
  (3, T/s: the field's rate of change along the orbit, space axes)]``
* drag ``[kind, tab, ng, density code, bands, nb, facet groups (ng × 9: n̂ (3), a₊ (3), a₋ (3),
  m³), density bands (nb × 3: h0 km, ρ0 kg m⁻³, H km), table: v_rel (3, m/s, space axes),
  then ln ρ (density code 0) or the geodetic height in km (code 1); code 2: √ρ v_rel (3,
  kg^½ m^-½ s⁻¹), then ln ρ]``
* solar radiation ``[kind, tab, ng, eclipse code, P (N m⁻², at 1 AU), AU km, R_sun km,
  R_earth km, umbra shortcut (1 or 0), facet groups (ng × 21: n̂ (3), then for +n̂ and −n̂:
  a (3), β_s (3), β_d (3), m³), table: Sun − satellite (3, km), satellite (3, km), both
  space axes, the shadow margins g_penumbra, g_umbra (rad)]``

The facets are grouped by their normal up to sign, with the per-facet constants the torques
are linear in summed over each group (:func:`attitude.facets.drag_groups`,
:func:`attitude.facets.optical_groups`): a box's six faces are three groups, each one dot
product, no branch.
"""

from __future__ import annotations

import math

import numpy as np

from orbit._layout import Field, layout
from orbit._shared_jit import jit
from orbit._state_kernels import frame_from_state, orbit_state
from orbit.sun import R_EARTH, R_SUN, conical_shadow

from .quat import cross, rotate_inverse

# A table: [nseg, nseg segment offsets (relative to the table), the segments]; a segment: its
# header, then n node times, then n rows of ncomp values.
SEG = layout(
    "table segment header",
    n=Field(1, "", "nodes"),
    h=Field(1, "s", "node spacing"),
    inv_h=Field(1, "1/s", "1/h"),
    ncomp=Field(1, "", "values per node"),
    lo=Field(1, "s", "start of the segment's validity"),
    hi=Field(1, "s", "its end"),
    times=Field(0, "s", "the n node times, then the n rows of values"),
)
#: Nodes of the interpolation window (degree 7).
WINDOW = 8

# Blocks of the environment models: [kind, offset of the table, the model's fields, table].
_BLOCK_HEAD = dict(
    kind=Field(1, "", "the model's KIND_* (attitude._core.potentials)"),
    tab=Field(1, "", "offset of the table, relative to the block"),
)
BLOCK = layout("environment model block", **_BLOCK_HEAD, fields=Field(0))
DIPOLE = layout("magnetic dipole block", **_BLOCK_HEAD, vec=Field(3, "A m2", "the dipole"))
EDDY = layout(
    "eddy-current block", **_BLOCK_HEAD, tensor=Field(9, "A m2 s/T", "magnetic tensor", (3, 3))
)
#: A coupled run (attitude._core.coupled) writes the environment at the integrated state into
#: these words of a block (``live`` = 1), which the torque and force kernels then read instead
#: of the table along the orbit.
_LIVE = dict(
    forces=Field(1, "", "offset of the facet groups' force sums, relative to the block"),
    live=Field(1, "", "1: the words below hold the environment at the integrated state"),
)
DRAG = layout(
    "drag block",
    **_BLOCK_HEAD,
    nf=Field(1, "", "facet groups"),
    density=Field(1, "", "DENSITY_*"),
    bands=Field(1, "", "offset of the exponential bands (h0, ρ0, H), relative to the block"),
    nb=Field(1, "", "their number"),
    **_LIVE,
    live_v=Field(3, "m/s", "velocity relative to the atmosphere, space axes"),
    live_rho=Field(1, "kg/m3", "density"),
    facets=Field(0, "", "nf facet groups (DRAG_GROUP), the bands, the force sums"),
)
#: A drag facet group: its normal, then Σ C_D A r of the facets along n̂ and along −n̂.
DRAG_GROUP = layout("drag facet group", normal=3, plus=Field(3, "m3"), minus=Field(3, "m3"))
DENSITY_TABLE = 0  # ln ρ tabulated
DENSITY_EXPONENTIAL = 1  # geodetic height tabulated, exponential bands evaluated here
DENSITY_FOLDED = 2  # √ρ v_rel tabulated in place of v_rel (then ln ρ, for the Python side)

SRP = layout(
    "solar radiation block",
    **_BLOCK_HEAD,
    nf=Field(1, "", "facet groups"),
    eclipse=Field(1, "", "ECLIPSE_*"),
    p=Field(1, "N/m2", "solar pressure at 1 AU"),
    au=Field(1, "km", "1 AU"),
    rsun=Field(1, "km", "the Sun's radius"),
    rearth=Field(1, "km", "the Earth's radius"),
    umbra=Field(1, "", "1: the shadow margins may decide the umbra"),
    **_LIVE,
    live_ds=Field(3, "km", "satellite → Sun, space axes"),
    live_nu=Field(1, "", "shadow fraction"),
    facets=Field(0, "", "nf facet groups (SRP_GROUP), then the force sums"),
)
#: A solar radiation facet group: its normal, then a, β_s, β_d (3 each) of the facets along n̂
#: and along −n̂ (attitude.facets.optical_groups).
SRP_GROUP = layout(
    "solar radiation facet group",
    normal=3,
    plus=Field(9, "m3", "a, β_s, β_d along n̂"),
    minus=Field(9, "m3", "a, β_s, β_d along −n̂"),
)
#: Margin [rad] of the tabulated shadow margins beyond which light or umbra is taken from them
#: (the interpolation error of the margins is ~1e-12 rad; the exact shadow function decides
#: nearer the boundaries).
SHADOW_MARGIN = 1e-6
ECLIPSE_NONE = 0
ECLIPSE_CYLINDRICAL = 1
ECLIPSE_CONICAL = 2

_NAN = math.nan
#: Unsigned offsets 0 ... 12 (an unsigned index compiles without wraparound code).
_U = tuple(np.uint64(k) for k in range(13))
# the Lagrange denominators' reciprocals, 1 / ((−1)^(7−j) j! (7−j)!)
_C0 = -1.0 / 5040.0
_C1 = 1.0 / 720.0
_C2 = -1.0 / 240.0
_C3 = 1.0 / 144.0
_C4 = -1.0 / 144.0
_C5 = 1.0 / 240.0
_C6 = -1.0 / 720.0
_C7 = 1.0 / 5040.0


@jit
def lagrange8(x):
    """Weights of the degree-7 Lagrange interpolant on the nodes 0, 1, ..., 7 at x.

    L_j(x) = Π_{k≠j} (x − k) / Π_{k≠j} (j − k), the products taken as a tree of pairs (depth
    three multiplications instead of seven: the weights sit on the critical path of every
    right-hand side) and without division by x − j, so exact at the nodes.
    """
    d0 = x
    d1 = x - 1.0
    d2 = x - 2.0
    d3 = x - 3.0
    d4 = x - 4.0
    d5 = x - 5.0
    d6 = x - 6.0
    d7 = x - 7.0
    a01 = d0 * d1
    a23 = d2 * d3
    a45 = d4 * d5
    a67 = d6 * d7
    lo = a01 * a23  # Π_{k<4} (x − k)
    hi = a45 * a67  # Π_{k>=4} (x − k)
    # 1 / Π_{k≠j} (j − k) = (−1)^(7−j) / (j! (7−j)!), as products (no divisions)
    return (
        (d1 * a23) * (hi * _C0),
        (d0 * a23) * (hi * _C1),
        (a01 * d3) * (hi * _C2),
        (a01 * d2) * (hi * _C3),
        (d5 * a67) * (lo * _C4),
        (d4 * a67) * (lo * _C5),
        (a45 * d7) * (lo * _C6),
        (a45 * d6) * (lo * _C7),
    )


@jit(inline="always")
def table_segment(d, o, t):
    """Offset of the segment of the table at ``o`` that holds t (the last one starting <= t)."""
    nseg = int(d[o])
    s = o + 1 + nseg  # the first segment follows the offsets
    for j in range(1, nseg):
        sj = o + int(d[o + 1 + j])
        if t >= d[sj + SEG.LO] - 1e-9 * d[sj + SEG.H]:  # a boundary belongs to the later segment
            s = sj
    return s


@jit(inline="always")
def table_locate(d, o, t):
    """(segment offset, row offset of the window's first node, weights (8)) for time t.

    The window is the 8 nodes j0 ... j0 + 7 centred on the interval of t (clamped at the
    ends), j0 from (t − t_0)/h; the local coordinate is taken from the stored time of node j0.
    A rounding of (t − t_0)/h at a node picks the window one node over, which holds t as well:
    the two interpolants differ by the interpolation error, not more. A constant (n = 1) gives
    its row with weights (1, 0, ...); t outside the table gives NaN weights.

    On the critical path of every right-hand side, so no dependent load more than needed: the
    header, then the window.
    """
    s = table_segment(d, o, t)
    n = int(d[s + SEG.N])
    ncomp = int(d[s + SEG.NCOMP])
    toff = s + SEG.TIMES
    voff = toff + n
    if n == 1:
        return s, voff, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    tol = 1e-9 * d[s + SEG.H]
    if not (t >= d[s + SEG.LO] - tol and t <= d[s + SEG.HI] + tol):
        return s, voff, (_NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN)
    inv_h = d[s + SEG.INV_H]
    u = (t - d[toff]) * inv_h - 3.0
    j0 = 0
    if u >= n - WINDOW:
        j0 = n - WINDOW
    elif u > 0.0:
        j0 = int(u)
    x = (t - d[toff + j0]) * inv_h
    return s, voff + j0 * ncomp, lagrange8(x)


@jit(inline="always")
def window_sum(d, r, ncomp, w):
    """Σ_j w_j d[r + j ncomp] over the window's 8 nodes, summed as a tree of pairs."""
    u = np.uint64(r)
    c = np.uint64(ncomp)
    r1 = u + c
    r2 = r1 + c
    r3 = r2 + c
    r4 = r3 + c
    r5 = r4 + c
    r6 = r5 + c
    r7 = r6 + c
    return ((w[0] * d[u] + w[1] * d[r1]) + (w[2] * d[r2] + w[3] * d[r3])) + (
        (w[4] * d[r4] + w[5] * d[r5]) + (w[6] * d[r6] + w[7] * d[r7])
    )


@jit(inline="always")
def table_component(d, s, row, w, c):
    """Interpolated component ``c`` of segment ``s`` from the window at ``row``, weights ``w``."""
    if int(d[s + SEG.N]) == 1:
        return d[row + c]
    return window_sum(d, row + c, int(d[s + SEG.NCOMP]), w)


@jit(inline="always")
def table_vec3(d, s, row, w, c0):
    """Components c0, c0 + 1, c0 + 2 as a 3-tuple."""
    r = row + c0
    if int(d[s + SEG.N]) == 1:
        return d[r], d[r + 1], d[r + 2]
    ncomp = int(d[s + SEG.NCOMP])
    return (
        window_sum(d, r, ncomp, w),
        window_sum(d, r + 1, ncomp, w),
        window_sum(d, r + 2, ncomp, w),
    )


@jit
def table_eval(d, o, t, out):
    """All components at t into ``out`` (for the Python-side checks of the tables)."""
    s, row, w = table_locate(d, o, t)
    for c in range(int(d[s + SEG.NCOMP])):
        out[c] = table_component(d, s, row, w, c)


# Magnetic field ---------------------------------------------------------------------------------


@jit(inline="always")
def field_body(q, t, params, base):
    """The magnetic field in body axes, B_B = q̃∘B_S∘q [T], B_S from the block's table."""
    s, row, w = table_locate(params, base + int(params[base + BLOCK.TAB]), t)
    return rotate_inverse(q, table_vec3(params, s, row, w, 0))


@jit
def magnetic_torque(q, t, params, base):
    # τ = m × B_B for a body-fixed dipole m (Wertz 1978, Sect. 17.2.3).
    b = field_body(q, t, params, base)
    m = (params[base + DIPOLE.VEC], params[base + DIPOLE.VEC + 1], params[base + DIPOLE.VEC + 2])
    return cross(m, b)


@jit
def magnetic_potential(q, t, params, base):
    # U = −m·B_B: the torque above is minus its derivative under body rotations.
    b = field_body(q, t, params, base)
    k = base + DIPOLE.VEC
    return -(params[k] * b[0] + params[k + 1] * b[1] + params[k + 2] * b[2])


@jit
def eddy_torque(q, w, t, params, base):
    # The induced moment opposes the change of the field seen from the body (Faraday, the
    # low-frequency limit): m = −M dB_B/dt with dB_B/dt = −ω × B_B + q̃∘(dB_S/dt)∘q, and
    # τ = m × B_B, all in body axes; M the magnetic tensor of the conducting body. For a field
    # constant in space this is Ortiz Gómez & Walker (2015), τ = (M (ω × B)) × B; along an
    # orbit dB_S/dt (tabulated) adds the field's own rotation, up to ~4e-3 rad/s in LEO.
    # τ ⊥ B, and ω·τ = −(ω × B)·M (ω × B) ≤ 0 for M ≥ 0 when dB_S/dt = 0.
    s, row, wt = table_locate(params, base + int(params[base + BLOCK.TAB]), t)
    b = rotate_inverse(q, table_vec3(params, s, row, wt, 0))
    bd = rotate_inverse(q, table_vec3(params, s, row, wt, 3))
    wb = cross(w, b)
    u = (wb[0] - bd[0], wb[1] - bd[1], wb[2] - bd[2])
    k = base + EDDY.TENSOR
    mu = (
        params[k] * u[0] + params[k + 1] * u[1] + params[k + 2] * u[2],
        params[k + 3] * u[0] + params[k + 4] * u[1] + params[k + 5] * u[2],
        params[k + 6] * u[0] + params[k + 7] * u[1] + params[k + 8] * u[2],
    )
    return cross(mu, b)


# Aerodynamic drag -------------------------------------------------------------------------------


@jit
def exponential_density(params, bands, nb, h):
    """ρ [kg/m³] of the exponential bands (h0, ρ0, H) at geodetic height h [km]: the last band
    with h0 <= h (the first below it), ρ = ρ0 exp(−(h − h0)/H)."""
    k = 0
    for j in range(nb):
        if params[bands + 3 * j] <= h:
            k = j
    r = bands + 3 * k
    return params[r + 1] * math.exp(-(h - params[r]) / params[r + 2])


@jit(inline="always")
def drag_wind(t, params, base):
    """(v, ρ): the velocity relative to the atmosphere (m/s, space axes) and the density at t,
    from the table (folded: √ρ v and 1) or, in a coupled run, at the integrated state."""
    if params[base + DRAG.LIVE] != 0.0:
        o = base + DRAG.LIVE_V
        return (params[o], params[o + 1], params[o + 2]), params[base + DRAG.LIVE_RHO]
    s, row, w = table_locate(params, base + int(params[base + BLOCK.TAB]), t)
    vs = table_vec3(params, s, row, w, 0)
    code = int(params[base + DRAG.DENSITY])
    if code == DENSITY_FOLDED:
        rho = 1.0
    else:
        x = table_component(params, s, row, w, 3)
        if code == DENSITY_EXPONENTIAL:
            rho = exponential_density(
                params, base + int(params[base + DRAG.BANDS]), int(params[base + DRAG.NB]), x
            )
        else:
            rho = math.exp(x)
    return vs, rho


# The facet kernels let LLVM fuse multiply-adds (fastmath "contract" only: no reassociation, no
# assumption about NaN or infinities): a third fewer instructions in the sums over the facets
# and the table window, and one rounding less in each fused pair.
@jit(fastmath={"contract"})
def drag_torque(q, t, params, base):
    # Flat plates in free-molecular flow: a facet whose outward normal n̂ faces the flow
    # (cos θ = n̂·v̂ > 0, v the velocity relative to the atmosphere) feels
    # F = −½ ρ C_D A cos θ |v|² v̂ at its centre c (Montenbruck & Gill 2000, Sect. 3.5, with the
    # projected area A cos θ); τ = Σ c × F = −½ ρ (Σ max(n̂·v, 0) C_D A c) × v, with no
    # normalisation of v. Facets shadowing each other are not handled.
    # With √ρ v tabulated (DENSITY_FOLDED, where the tables showed it interpolates as well as
    # v and ln ρ apart) the same sum over that vector is the torque with ρ = 1: τ is
    # homogeneous of degree 2 in v (max(n̂·λv, 0) = λ max(n̂·v, 0) for λ > 0).
    vs, rho = drag_wind(t, params, base)
    v = rotate_inverse(q, vs)
    ax = 0.0
    ay = 0.0
    az = 0.0
    f0 = base + DRAG.FACETS
    for i in range(int(params[base + DRAG.NF])):
        f = params[f0 + DRAG_GROUP.SIZE * i : f0 + DRAG_GROUP.SIZE * (i + 1)]
        c = v[0] * f[0] + v[1] * f[1] + v[2] * f[2]
        # the facets along n̂ face the flow when c > 0, those along −n̂ when c < 0 (unsigned
        # offsets: no negative-index wraparound code on the loads)
        k = _U[3] if c > 0.0 else _U[6]
        c = abs(c)
        ax += c * f[k]
        ay += c * f[k + _U[1]]
        az += c * f[k + _U[2]]
    k = -0.5 * rho
    return k * (ay * v[2] - az * v[1]), k * (az * v[0] - ax * v[2]), k * (ax * v[1] - ay * v[0])


@jit(fastmath={"contract"})
def drag_force(q, t, params, base):
    """The drag force (N, body axes) of the model's facets: −½ ρ Σ C_D A max(n̂·v, 0) v, the
    sum of the forces whose moments :func:`drag_torque` sums."""
    vs, rho = drag_wind(t, params, base)
    v = rotate_inverse(q, vs)
    a = 0.0
    f0 = base + DRAG.FACETS
    fo = base + int(params[base + DRAG.FORCES])
    for i in range(int(params[base + DRAG.NF])):
        f = params[f0 + DRAG_GROUP.SIZE * i : f0 + DRAG_GROUP.SIZE * (i + 1)]
        c = v[0] * f[0] + v[1] * f[1] + v[2] * f[2]
        k = fo + 2 * i if c > 0.0 else fo + 2 * i + 1
        a += abs(c) * params[k]
    k = -0.5 * rho * a
    return k * v[0], k * v[1], k * v[2]


# Solar radiation pressure -----------------------------------------------------------------------


@jit
def cylindrical_shadow(rx, ry, rz, sx, sy, sz, re):
    """Cylindrical shadow (Montenbruck & Gill 2000, Sect. 3.4.2): 0 behind the Earth inside a
    cylinder of radius ``re`` along the Sun direction, else 1 (no penumbra)."""
    sn = math.sqrt(sx * sx + sy * sy + sz * sz)
    ux = sx / sn
    uy = sy / sn
    uz = sz / sn
    p = rx * ux + ry * uy + rz * uz
    if p >= 0.0:
        return 1.0
    qx = rx - p * ux
    qy = ry - p * uy
    qz = rz - p * uz
    if qx * qx + qy * qy + qz * qz < re * re:
        return 0.0
    return 1.0


@jit
def shadow(code, rx, ry, rz, dx, dy, dz, re, rs):
    """Shadow fraction ν at satellite r with the Sun at r + d (km) for an eclipse code.

    Conical: full light (c > a + b ⇔ cos c < cos a cos b − sin a sin b) and the umbra
    (c < b − a) are recognised from cosines and square roots alone; near the boundaries and in
    the penumbra :func:`orbit.sun.conical_shadow` (Montenbruck & Gill 2000, Sect. 3.4.2).
    """
    if code == ECLIPSE_NONE:
        return 1.0
    sx = rx + dx
    sy = ry + dy
    sz = rz + dz
    if code == ECLIPSE_CYLINDRICAL:
        return cylindrical_shadow(rx, ry, rz, sx, sy, sz, re)
    rn = math.sqrt(rx * rx + ry * ry + rz * rz)
    dn = math.sqrt(dx * dx + dy * dy + dz * dz)
    sa = rs / dn
    sb = re / rn
    if sb < 1.0:
        cc = -(rx * dx + ry * dy + rz * dz) / (rn * dn)
        ca = math.sqrt(1.0 - sa * sa)
        cb = math.sqrt(1.0 - sb * sb)
        if cc < ca * cb - sa * sb - 1e-12:  # c > a + b: full light
            return 1.0
        if sb > sa and cc > ca * cb + sa * sb + 1e-12:  # c < b − a: umbra
            return 0.0
    return conical_shadow(rx, ry, rz, sx, sy, sz, re, rs)[0]


@jit(inline="always")
def sunlight(code, umbra, params, base, s, row, w):
    """Shadow fraction ν at the table window (s, row, w).

    Conical: well inside the light or the umbra the interpolated shadow margins decide
    (:data:`SHADOW_MARGIN`; the umbra only where the Earth's disk is the larger, ``umbra``),
    elsewhere :func:`shadow` at the interpolated positions, which gives the same ν there.
    """
    if code == ECLIPSE_NONE:
        return 1.0
    if code == ECLIPSE_CONICAL:
        if table_component(params, s, row, w, 6) > SHADOW_MARGIN:
            return 1.0
        if umbra and table_component(params, s, row, w, 7) < -SHADOW_MARGIN:
            return 0.0
    ds = table_vec3(params, s, row, w, 0)
    r = table_vec3(params, s, row, w, 3)
    return shadow(
        code, r[0], r[1], r[2], ds[0], ds[1], ds[2],
        params[base + SRP.REARTH], params[base + SRP.RSUN],
    )  # fmt: skip


@jit(inline="always")
def solar_light(t, params, base):
    """(ν, satellite → Sun [km, space axes]) at t: from the table or, in a coupled run, at the
    integrated state."""
    if params[base + SRP.LIVE] != 0.0:
        o = base + SRP.LIVE_DS
        return params[base + SRP.LIVE_NU], (params[o], params[o + 1], params[o + 2])
    s, row, w = table_locate(params, base + int(params[base + BLOCK.TAB]), t)
    nu = sunlight(
        int(params[base + SRP.ECLIPSE]), params[base + SRP.UMBRA] != 0.0, params, base, s, row, w
    )
    if nu == 0.0:
        return 0.0, (1.0, 0.0, 0.0)
    return nu, table_vec3(params, s, row, w, 0)


@jit(fastmath={"contract"})
def solar_force(q, t, params, base):
    """The radiation-pressure force (N, body axes) of the model's facets:
    −P Σ A cos θ [(1 − C_s) ŝ + 2 (C_s cos θ + C_d/3) n̂_f] over the facets facing the Sun,
    the sum of the forces whose moments :func:`solar_torque` sums."""
    nu, ds = solar_light(t, params, base)
    if nu == 0.0:
        return 0.0, 0.0, 0.0
    d2 = ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2]
    idn = 1.0 / math.sqrt(d2)
    au = params[base + SRP.AU] * idn
    pressure = nu * params[base + SRP.P] * (au * au)
    sb = rotate_inverse(q, (ds[0] * idn, ds[1] * idn, ds[2] * idn))
    a = 0.0
    bx = 0.0
    by = 0.0
    bz = 0.0
    f0 = base + SRP.FACETS
    fo = base + int(params[base + SRP.FORCES])
    for i in range(int(params[base + SRP.NF])):
        f = params[f0 + SRP_GROUP.SIZE * i : f0 + SRP_GROUP.SIZE * (i + 1)]
        c = sb[0] * f[0] + sb[1] * f[1] + sb[2] * f[2]
        # the facets along n̂ face the Sun when c > 0 (their normal n̂), those along −n̂ when
        # c < 0 (their normal −n̂)
        k = fo + 6 * i if c > 0.0 else fo + 6 * i + 3
        sg = 1.0 if c > 0.0 else -1.0
        c = abs(c)
        a += c * params[k]
        m = sg * (c * c * params[k + 1] + c * params[k + 2])
        bx += m * f[0]
        by += m * f[1]
        bz += m * f[2]
    return (
        -pressure * (a * sb[0] + bx),
        -pressure * (a * sb[1] + by),
        -pressure * (a * sb[2] + bz),
    )


@jit(fastmath={"contract"})  # (as drag_torque)
def solar_torque(q, t, params, base):
    # Flat plates with absorbed, specular and diffuse fractions (1 − C_s − C_d, C_s, C_d): a
    # facet facing the Sun (cos θ = n̂·ŝ > 0, ŝ towards the Sun) feels
    # F = −P A cos θ [(1 − C_s) ŝ + 2 (C_s cos θ + C_d/3) n̂] (Wertz 1978, Sect. 17.2.2;
    # Montenbruck & Gill 2000, Sect. 3.4.1), P = ν P_1AU (1 AU/d)², ν the shadow fraction;
    # τ = Σ c × F = −P [(Σ cos θ A (1 − C_s) c) × ŝ + Σ (2 A C_s cos² θ + ⅔ A C_d cos θ) c × n̂]
    # over the facets with cos θ > 0. Facets shadowing each other are not handled.
    nu, ds = solar_light(t, params, base)
    if nu == 0.0:
        return 0.0, 0.0, 0.0
    d2 = ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2]
    idn = 1.0 / math.sqrt(d2)
    au = params[base + SRP.AU] * idn  # 1 AU / d
    pressure = nu * params[base + SRP.P] * (au * au)
    sb = rotate_inverse(q, (ds[0] * idn, ds[1] * idn, ds[2] * idn))
    ax = 0.0
    ay = 0.0
    az = 0.0
    bx = 0.0
    by = 0.0
    bz = 0.0
    f0 = base + SRP.FACETS
    for i in range(int(params[base + SRP.NF])):
        f = params[f0 + SRP_GROUP.SIZE * i : f0 + SRP_GROUP.SIZE * (i + 1)]
        c = sb[0] * f[0] + sb[1] * f[1] + sb[2] * f[2]
        # the facets along n̂ face the Sun when c > 0, those along −n̂ when c < 0 (unsigned
        # offsets: no negative-index wraparound code on the loads)
        k = _U[3] if c > 0.0 else _U[12]
        c = abs(c)
        c2 = c * c
        ax += c * f[k]
        ay += c * f[k + _U[1]]
        az += c * f[k + _U[2]]
        bx += c2 * f[k + _U[3]] + c * f[k + _U[6]]
        by += c2 * f[k + _U[4]] + c * f[k + _U[7]]
        bz += c2 * f[k + _U[5]] + c * f[k + _U[8]]
    return (
        -pressure * (ay * sb[2] - az * sb[1] + bx),
        -pressure * (az * sb[0] - ax * sb[2] + by),
        -pressure * (ax * sb[1] - ay * sb[0] + bz),
    )


@jit
def solar_state(t, params, base):
    """(ν, |Sun − satellite| km, ŝ space axes 3) at t: the Sun as the torque kernel sees it."""
    s, row, w = table_locate(params, base + int(params[base + BLOCK.TAB]), t)
    ds = table_vec3(params, s, row, w, 0)
    dn = math.sqrt(ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2])
    nu = sunlight(
        int(params[base + SRP.ECLIPSE]), params[base + SRP.UMBRA] != 0.0, params, base, s, row, w
    )
    return nu, dn, ds[0] / dn, ds[1] / dn, ds[2] / dn


@jit
def solar_state_loop(t, params, base, out):
    """:func:`solar_state` at each of the times ``t`` into ``out`` (m, 5)."""
    for i in range(t.shape[0]):
        s = solar_state(t[i], params, base)
        for j in range(5):
            out[i, j] = s[j]


@jit
def table_loop(t, params, o, out):
    """Every component of the table at ``o`` at each of the times ``t`` into ``out`` (m, ncomp)."""
    for i in range(t.shape[0]):
        table_eval(params, o, t[i], out[i])


# The environment a user torque sees ---------------------------------------------------------
# A CustomTorque given an orbit reads the environment at t through a vector ``env`` (the layout
# ENV_* below, which attitude.potentials.EnvironmentIndex names), filled here from a block of
# ``params`` holding the same tables the built-in models and the flight software read:
#
#     [field offset, orbit offset, Sun offset, blocks...]   (offsets relative to the block; 0:
#                                                            none)
#     field block: a magnetic dipole's [kind, tab, m (3), table: B (3, T, space axes)]
#     orbit: the orbit's kernel_data() (orbit._state_kernels)
#     Sun: the Sun's table (orbit.sun.SunTable.kernel_data(), geocentric GCRS km)

#: The environment vector (body axes unless noted; NaN where unavailable), whose public face
#: is :class:`attitude.potentials.EnvironmentIndex`.
ENV = layout(
    "environment vector",
    field=Field(3, "T", "geomagnetic field, body axes"),
    sun=Field(3, "", "unit vector from the spacecraft to the Sun, body axes"),
    r=Field(3, "km", "position, space axes (GCRS)"),
    v=Field(3, "km/s", "velocity, space axes"),
    q_rsw=Field(4, "", "orbital frame (radial, along-track, normal) → space, scalar first"),
    sun_distance=Field(1, "km", "spacecraft to Sun"),
    shadow=Field(1, "", "fraction of the Sun's disk seen (conical shadow): 1 lit, 0 umbra"),
)
#: The header of the environment's block (offsets relative to the block; 0: none).
ENVB = layout("environment block header", field=1, orbit=1, sun=1)


@jit
def environment_vector(q, t, params, base, out):
    """The environment at t seen by a body at attitude ``q`` into ``out`` (ENV.SIZE): the
    field as :func:`field_body` (the magnetic dipole's kernel), r and v from the orbit's
    dispatcher, the Sun's direction (as the flight software's measurements), the RSW frame from
    r and v, the Sun's distance and the Earth's conical shadow."""
    for i in range(ENV.SIZE):
        out[i] = _NAN
    fo = int(params[base + ENVB.FIELD])
    if fo > 0:
        b = field_body(q, t, params, base + fo)
        for i in range(3):
            out[ENV.FIELD + i] = b[i]
    st = orbit_state(params[base + int(params[base + ENVB.ORBIT]) :], t)
    for i in range(3):
        out[ENV.R + i] = st[i]
        out[ENV.V + i] = st[3 + i]
    _r, p0, p1, p2, p3 = frame_from_state(st[0], st[1], st[2], st[3], st[4], st[5])
    out[ENV.Q_RSW] = p0
    out[ENV.Q_RSW + 1] = p1
    out[ENV.Q_RSW + 2] = p2
    out[ENV.Q_RSW + 3] = p3
    so = int(params[base + ENVB.SUN])
    if so > 0:
        sun = orbit_state(params[base + so :], t)
        dx = sun[0] - st[0]
        dy = sun[1] - st[1]
        dz = sun[2] - st[2]
        n = math.sqrt(dx * dx + dy * dy + dz * dz)
        sb = rotate_inverse(q, (dx / n, dy / n, dz / n))
        for i in range(3):
            out[ENV.SUN + i] = sb[i]
        out[ENV.SUN_DISTANCE] = n
        out[ENV.SHADOW] = conical_shadow(
            st[0], st[1], st[2], sun[0], sun[1], sun[2], R_EARTH, R_SUN
        )[0]


@jit
def environment_loop(q, t, params, base, out):
    """:func:`environment_vector` at each (q[i], t[i]) into ``out`` (m, ENV.SIZE)."""
    for i in range(t.shape[0]):
        environment_vector(q[i], t[i], params, base, out[i])

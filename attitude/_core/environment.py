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
    d[s + 2]                  ncomp, values per node
    d[s + 3], d[s + 4]        lo, hi: where the segment is valid (the nodes may start or end
                              up to one step inside it: the edge window extrapolates)
    d[s + 5 : s + 5 + n]      node times t_k = t_0 + k h [s]
    d[s + 5 + n : ...]        n rows of ncomp values (row-major)

Block layouts (``kind`` first, ``tab`` the relative offset of the table):

* magnetic dipole ``[kind, tab, m (3, A m²), table: B (3, T, space axes)]``
* eddy currents ``[kind, tab, M (9, row-major, body axes, S m⁴), table: B (3, T)]``
* drag ``[kind, tab, nf, density code, bands, nb, facets (nf × 8: A m², n̂ (3), c (3) m, C_D),
  density bands (nb × 3: h0 km, ρ0 kg m⁻³, H km), table: v_rel (3, m/s, space axes), then
  ln ρ (density code 0) or the geodetic height in km (code 1)]``
* solar radiation ``[kind, tab, nf, eclipse code, P (N m⁻², at 1 AU), AU km, R_sun km,
  R_earth km, facets (nf × 9: A, n̂ (3), c (3), specular, diffuse), table: Sun − satellite
  (3, km), satellite (3, km), both space axes]``
"""

from __future__ import annotations

import math

from orbit._shared_jit import jit
from orbit._state_kernels import table_interval
from orbit.sun import conical_shadow

from .quat import cross, rotate_inverse

# Segment header.
T_N = 0
T_H = 1
T_NCOMP = 2
T_LO = 3
T_HI = 4
T_TIMES = 5
#: Nodes of the interpolation window (degree 7).
WINDOW = 8

# Block fields shared by every environment kind.
B_TAB = 1  # relative offset of the table

# Magnetic dipole / eddy currents.
M_VEC = 2  # dipole (3) or tensor (9)

# Drag.
D_NF = 2
D_DENSITY = 3
D_BANDS = 4
D_NB = 5
D_FACETS = 6
D_STRIDE = 8
DENSITY_TABLE = 0  # ln ρ tabulated
DENSITY_EXPONENTIAL = 1  # geodetic height tabulated, exponential bands evaluated here

# Solar radiation.
S_NF = 2
S_ECLIPSE = 3
S_P = 4
S_AU = 5
S_RSUN = 6
S_REARTH = 7
S_FACETS = 8
S_STRIDE = 9
ECLIPSE_NONE = 0
ECLIPSE_CYLINDRICAL = 1
ECLIPSE_CONICAL = 2

_NAN = math.nan
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

    L_j(x) = Π_{k≠j} (x − k) / Π_{k≠j} (j − k), from prefix and suffix products (no division
    by x − j, so exact at the nodes).
    """
    d0 = x
    d1 = x - 1.0
    d2 = x - 2.0
    d3 = x - 3.0
    d4 = x - 4.0
    d5 = x - 5.0
    d6 = x - 6.0
    d7 = x - 7.0
    p1 = d0
    p2 = p1 * d1
    p3 = p2 * d2
    p4 = p3 * d3
    p5 = p4 * d4
    p6 = p5 * d5
    p7 = p6 * d6
    s6 = d7
    s5 = s6 * d6
    s4 = s5 * d5
    s3 = s4 * d4
    s2 = s3 * d3
    s1 = s2 * d2
    s0 = s1 * d1
    # 1 / Π_{k≠j} (j − k) = (−1)^(7−j) / (j! (7−j)!), as products (no divisions)
    return (
        s0 * _C0,
        p1 * s1 * _C1,
        p2 * s2 * _C2,
        p3 * s3 * _C3,
        p4 * s4 * _C4,
        p5 * s5 * _C5,
        p6 * s6 * _C6,
        p7 * _C7,
    )


@jit
def table_segment(d, o, t):
    """Offset of the segment of the table at ``o`` that holds t (the last one starting <= t)."""
    s = o + int(d[o + 1])
    for j in range(1, int(d[o])):
        sj = o + int(d[o + 1 + j])
        if t >= d[sj + T_LO] - 1e-9 * d[sj + T_H]:  # a boundary belongs to the later segment
            s = sj
    return s


@jit
def table_locate(d, o, t):
    """(segment offset, row offset of the window's first node, weights (8)) for time t.

    A constant (n = 1) gives its row with weights (1, 0, ...); t outside the table gives NaN
    weights.
    """
    s = table_segment(d, o, t)
    n = int(d[s + T_N])
    ncomp = int(d[s + T_NCOMP])
    toff = s + T_TIMES
    voff = toff + n
    if n == 1:
        return s, voff, (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    h = d[s + T_H]
    tol = 1e-9 * h
    if not (t >= d[s + T_LO] - tol and t <= d[s + T_HI] + tol):
        return s, voff, (_NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN)
    i = table_interval(d, toff, n, h, t)
    j0 = min(max(i - 3, 0), n - WINDOW)
    x = (t - d[toff + j0]) / h
    return s, voff + j0 * ncomp, lagrange8(x)


@jit
def table_component(d, s, row, w, c):
    """Interpolated component ``c`` of segment ``s`` from the window at ``row``, weights ``w``."""
    ncomp = int(d[s + T_NCOMP])
    if int(d[s + T_N]) == 1:
        return d[row + c]
    v = 0.0
    for j in range(WINDOW):
        v += w[j] * d[row + j * ncomp + c]
    return v


@jit
def table_vec3(d, s, row, w, c0):
    """Components c0, c0 + 1, c0 + 2 as a 3-tuple."""
    ncomp = int(d[s + T_NCOMP])
    if int(d[s + T_N]) == 1:
        return d[row + c0], d[row + c0 + 1], d[row + c0 + 2]
    x = 0.0
    y = 0.0
    z = 0.0
    for j in range(WINDOW):
        r = row + j * ncomp + c0
        wj = w[j]
        x += wj * d[r]
        y += wj * d[r + 1]
        z += wj * d[r + 2]
    return x, y, z


@jit
def table_eval(d, o, t, out):
    """All components at t into ``out`` (for the Python-side checks of the tables)."""
    s, row, w = table_locate(d, o, t)
    for c in range(int(d[s + T_NCOMP])):
        out[c] = table_component(d, s, row, w, c)


# Magnetic field ---------------------------------------------------------------------------------


@jit
def field_body(q, t, params, base):
    """The magnetic field in body axes, B_B = q̃∘B_S∘q [T], B_S from the block's table."""
    s, row, w = table_locate(params, base + int(params[base + B_TAB]), t)
    return rotate_inverse(q, table_vec3(params, s, row, w, 0))


@jit
def magnetic_torque(q, t, params, base):
    # τ = m × B_B for a body-fixed dipole m (Wertz 1978, Sect. 17.2.3).
    b = field_body(q, t, params, base)
    m = (params[base + M_VEC], params[base + M_VEC + 1], params[base + M_VEC + 2])
    return cross(m, b)


@jit
def magnetic_potential(q, t, params, base):
    # U = −m·B_B: the torque above is minus its derivative under body rotations.
    b = field_body(q, t, params, base)
    k = base + M_VEC
    return -(params[k] * b[0] + params[k + 1] * b[1] + params[k + 2] * b[2])


@jit
def eddy_torque(q, w, t, params, base):
    # Ortiz Gómez & Walker (2015): τ = (M (ω × B)) × B, all in body axes; M the magnetic
    # tensor of the conducting body. τ ⊥ B, and ω·τ = −(ω × B)·M (ω × B) ≤ 0 for M ≥ 0.
    b = field_body(q, t, params, base)
    u = cross(w, b)
    k = base + M_VEC
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


@jit
def drag_torque(q, t, params, base):
    # Flat plates in free-molecular flow: a facet whose outward normal n̂ faces the flow
    # (cos θ = n̂·v̂ > 0, v the velocity relative to the atmosphere) feels
    # F = −½ ρ C_D A cos θ |v|² v̂ at its centre c (Montenbruck & Gill 2000, Sect. 3.5, with the
    # projected area A cos θ); τ = Σ c × F. Facets shadowing each other are not handled.
    s, row, w = table_locate(params, base + int(params[base + B_TAB]), t)
    vs = table_vec3(params, s, row, w, 0)
    x = table_component(params, s, row, w, 3)
    if int(params[base + D_DENSITY]) == DENSITY_EXPONENTIAL:
        rho = exponential_density(
            params, base + int(params[base + D_BANDS]), int(params[base + D_NB]), x
        )
    else:
        rho = math.exp(x)
    vb = rotate_inverse(q, vs)
    v = math.sqrt(vb[0] * vb[0] + vb[1] * vb[1] + vb[2] * vb[2])
    ux = vb[0] / v
    uy = vb[1] / v
    uz = vb[2] / v
    k = -0.5 * rho * v * v
    tx = 0.0
    ty = 0.0
    tz = 0.0
    f0 = base + D_FACETS
    for i in range(int(params[base + D_NF])):
        p = f0 + D_STRIDE * i
        c = ux * params[p + 1] + uy * params[p + 2] + uz * params[p + 3]
        if c > 0.0:
            g = k * params[p + 7] * params[p] * c
            fx = g * ux
            fy = g * uy
            fz = g * uz
            cx = params[p + 4]
            cy = params[p + 5]
            cz = params[p + 6]
            tx += cy * fz - cz * fy
            ty += cz * fx - cx * fz
            tz += cx * fy - cy * fx
    return tx, ty, tz


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


@jit
def solar_torque(q, t, params, base):
    # Flat plates with absorbed, specular and diffuse fractions (1 − C_s − C_d, C_s, C_d): a
    # facet facing the Sun (cos θ = n̂·ŝ > 0, ŝ towards the Sun) feels
    # F = −P A cos θ [(1 − C_s) ŝ + 2 (C_s cos θ + C_d/3) n̂] (Wertz 1978, Sect. 17.2.2;
    # Montenbruck & Gill 2000, Sect. 3.4.1), P = ν P_1AU (1 AU/d)², ν the shadow fraction;
    # τ = Σ c × F. Facets shadowing each other are not handled.
    s, row, w = table_locate(params, base + int(params[base + B_TAB]), t)
    ds = table_vec3(params, s, row, w, 0)  # satellite → Sun [km]
    dn = math.sqrt(ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2])
    nu = 1.0
    ecl = int(params[base + S_ECLIPSE])
    if ecl != ECLIPSE_NONE:
        r = table_vec3(params, s, row, w, 3)
        nu = shadow(
            ecl, r[0], r[1], r[2], ds[0], ds[1], ds[2],
            params[base + S_REARTH], params[base + S_RSUN],
        )  # fmt: skip
        if nu == 0.0:
            return 0.0, 0.0, 0.0
    au = params[base + S_AU] / dn
    pressure = nu * params[base + S_P] * au * au
    sb = rotate_inverse(q, (ds[0] / dn, ds[1] / dn, ds[2] / dn))
    tx = 0.0
    ty = 0.0
    tz = 0.0
    f0 = base + S_FACETS
    for i in range(int(params[base + S_NF])):
        p = f0 + S_STRIDE * i
        nx = params[p + 1]
        ny = params[p + 2]
        nz = params[p + 3]
        c = sb[0] * nx + sb[1] * ny + sb[2] * nz
        if c > 0.0:
            cs = params[p + 7]
            cd = params[p + 8]
            a = -pressure * params[p] * c
            gs = a * (1.0 - cs)
            gn = a * 2.0 * (cs * c + cd / 3.0)
            fx = gs * sb[0] + gn * nx
            fy = gs * sb[1] + gn * ny
            fz = gs * sb[2] + gn * nz
            cx = params[p + 4]
            cy = params[p + 5]
            cz = params[p + 6]
            tx += cy * fz - cz * fy
            ty += cz * fx - cx * fz
            tz += cx * fy - cy * fx
    return tx, ty, tz


@jit
def solar_state(t, params, base):
    """(ν, |Sun − satellite| km, ŝ space axes 3) at t: the Sun as the torque kernel sees it."""
    s, row, w = table_locate(params, base + int(params[base + B_TAB]), t)
    ds = table_vec3(params, s, row, w, 0)
    dn = math.sqrt(ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2])
    r = table_vec3(params, s, row, w, 3)
    nu = shadow(
        int(params[base + S_ECLIPSE]), r[0], r[1], r[2], ds[0], ds[1], ds[2],
        params[base + S_REARTH], params[base + S_RSUN],
    )  # fmt: skip
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

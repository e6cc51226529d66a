"""Compiled exact torque-free rigid-body motion (the free flow of the splitting integrators).

Everything here works on plain floats; :mod:`attitude.exact` validates and calls these kernels.
Derivation and accuracy notes: ``docs/exact.md``. Summary:

* Canonical variables (Arribas et al. 2006, Sect. 3): ``g = ½ vec(q̃∘Q)`` is the body angular
  momentum (eq. 17). The Hamiltonian ``T = (1/8) Σ_{i=1..3} (q̃∘Q)_i² / I_i`` (eq. 6) generates
  ``q̇ = ½ q∘(0, ω)``, ``Q̇ = ½ Q∘(0, ω)``, ``ω = g / I`` (eq. 7 torque-free), so the exact flow
  right-multiplies both quaternions by the same unit quaternion ``M(t)``:
  ``q(t) = q0∘M(t)``, ``Q(t) = Q0∘M(t)``, and ``g(t) = M̃ g0 M``.
* Body frame sorted internally to ``I_A ≤ I_B ≤ I_C`` by a signed axis permutation (a proper
  rotation). With ``E_i = G² − 2T I_i`` written as sums of same-sign terms, the two regimes are
  ``E_B > 0`` (momentum circulates about the largest axis C) and ``E_B < 0`` (about the smallest
  axis A); ``E_B = 0`` is the separatrix. Then (Landau & Lifshitz §37, in terms of g)
  ``g_o = σ_o a_o cn u``, ``g_B = σ_B a_B sn u``, ``g_c = s_c a_c dn u``, ``u = u0 + λ t``,
  c the circulation axis, o the other extreme axis, with ``m`` and ``m1 = 1 − m`` both formed
  from the E's and inertia differences (no cancellation near the separatrix).
* Attitude (after Celledoni, Fassò, Säfström & Zanna 2008): with ``ê`` a body axis p ∈ {A, C}
  chosen so that ``|g_p| ≤ G/√2`` along the whole orbit, ``a(g)`` the minimal rotation taking
  ``g`` to ``G ê``, ``M(t) = ã(g0)∘r(φ)∘a(g(t))`` with ``r(φ)`` a rotation by φ about ê and
  ``φ̇ = G/I_p + D_p / (G + g_p)``, ``D_p = 2T − G²/I_p``. Splitting
  ``1/(G + h) = G/(G² − h²) − h/(G² − h²)`` gives Legendre's Π(n; am u | m) with
  ``n ∈ [−1, 0]`` (Carlson RF, RJ) plus an elementary arctangent.
* Evaluation by increments: g(t) − g(u0), ΔΠ and the arctangent's change are formed from
  (sn, cn, dn)(u0) (read off the state) and (sn, cn, dn)(λt mod 2K) by the addition theorems
  of the Jacobi functions and of Π, each proportional to sn(λt): they keep full relative
  accuracy however small λt is. (They multiply D_p/λ, which is huge for a slowly precessing,
  nearly axisymmetric body; forming them as differences of values at u and u0 lost
  everything there.) M is built from Δg as B∘r' (no cancelling products of O(1) quaternions)
  and free_flow applies it as q + q∘(M − 1): composed flows do not drift in T or |g|.
"""

from __future__ import annotations

import math
from collections import namedtuple

from orbit._shared_jit import jit

from .elliptic import ellipj_reduced, ellipkm1, ellippi_complete, ellippi_sc
from .quat import mul

__all__ = [
    "FreeRigidBody",
    "free_flow",
    "free_flow_inplace",
    "free_rotation",
    "prepare",
    "torque_free_kernel",
]

#: Precomputed description of one torque-free motion (all floats, for numba).
FreeRigidBody = namedtuple(
    "FreeRigidBody",
    [
        "kind",  # 0: uniform rotation, 1: periodic (elliptic), 2: separatrix
        "i0",  # sorted axis k (k = 0, 1, 2) is original axis i_k, middle one times sg
        "i1",
        "i2",
        "sg",
        "w1",  # uniform rotation: body angular velocity (original frame)
        "w2",
        "w3",
        "G",  # |y|
        "lam",
        "m",
        "m1",
        "K",
        "s0",  # (sn, cn, dn)(u0): the initial phase, taken from the state itself
        "c0",
        "d0",
        "u0",  # separatrix only: u0 = asinh(s0/c0) (sn = tanh, cn = dn = sech)
        "So",  # signed amplitudes: g_o = So cn, g_B = S2 sn, g_c = Sc dn
        "S2",
        "Sc",
        "cidx",  # sorted index of the circulation axis (0 or 2)
        "pidx",  # sorted index of the pole axis (0 or 2)
        "polec",  # 1.0 if the pole is the circulation axis, else 0.0
        "n",  # characteristic of Π
        "kap",  # √(n (n − m)(1 − n)) ≥ 0 of the addition theorem of Π
        "V",  # arctangent scale
        "Wd",
        "Gp",  # G / I_p
        "coefP",  # D_p G / (λ A_p)
        "coefW",  # D_p h_amp / (λ Wd V)
        "Pic",  # complete Π(n | m) (NaN: not computed yet)
        "y1",  # the orbit's point at u0 (sorted frame): g(t) = y + Δ(t)
        "y2",
        "y3",
        "N0",  # |(G + y_p, y × e_p)|: norm of the alignment quaternion a(y)
    ],
)

_NAN = math.nan

# --------------------------------------------------------------------------------------------
# double-double helpers (Dekker 1971): only for the quantities that cancel near the separatrix
# --------------------------------------------------------------------------------------------


@jit
def _two_sum(a, b):
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


@jit
def _fast_two_sum(a, b):
    s = a + b
    return s, b - (s - a)


@jit
def _split(a):
    c = 134217729.0 * a
    hi = c - (c - a)
    return hi, a - hi


@jit
def _two_prod(a, b):
    p = a * b
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


@jit
def _dd_add(ah, al, bh, bl):
    s, e = _two_sum(ah, bh)
    t, f = _two_sum(al, bl)
    e += t
    s, e = _fast_two_sum(s, e)
    e += f
    return _fast_two_sum(s, e)


@jit
def _dd_mul(ah, al, bh, bl):
    p, e = _two_prod(ah, bh)
    e += ah * bl + al * bh
    return _fast_two_sum(p, e)


@jit
def _dd_dot4(a0, a1, a2, a3, b0, b1, b2, b3):
    """a0 b0 + a1 b1 + a2 b2 + a3 b3 in double-double (products exact)."""
    p0, e0 = _two_prod(a0, b0)
    p1, e1 = _two_prod(a1, b1)
    p2, e2 = _two_prod(a2, b2)
    p3, e3 = _two_prod(a3, b3)
    sh, sl = _dd_add(p0, e0, p1, e1)
    sh, sl = _dd_add(sh, sl, p2, e2)
    return _dd_add(sh, sl, p3, e3)


@jit
def _sorted_axes(I1, I2, I3):
    """Indices (i0, i1, i2) of the ascending moments and the sign of the middle axis that makes
    the axis permutation a proper rotation."""
    if I1 <= I2:
        if I2 <= I3:
            return 0, 1, 2, 1.0
        if I1 <= I3:
            return 0, 2, 1, -1.0
        return 2, 0, 1, 1.0
    if I1 <= I3:
        return 1, 0, 2, -1.0
    if I2 <= I3:
        return 1, 2, 0, 1.0
    return 2, 1, 0, -1.0


@jit
def _uniform(i0, i1, i2, sg, w1, w2, w3):
    return FreeRigidBody(
        0.0,
        float(i0),
        float(i1),
        float(i2),
        sg,
        w1,
        w2,
        w3,
        0.0,
        0.0,
        0.0,
        1.0,
        _NAN,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        _NAN,
        0.0,
        0.0,
        0.0,
        1.0,
    )


@jit
def prepare(I1, I2, I3, q, Q, with_pic):
    """Precompute the torque-free motion from the state (q, Q) -> FreeRigidBody.

    ``with_pic``: also compute the complete Π (needed whenever the motion is evaluated more
    than half a period away; :func:`free_rotation` computes it lazily otherwise).
    """
    # Work with Q and I scaled by powers of two (exact) to O(1): no overflow or underflow in
    # the squares and products below for any representable data. Only λ and G/I_p carry the
    # scale (by 2^(eQ − eI)); every other quantity is scale-free or scaled consistently.
    mQ = max(abs(Q[0]), abs(Q[1]), abs(Q[2]), abs(Q[3]))
    i0, i1, i2, sg = _sorted_axes(I1, I2, I3)
    if mQ == 0.0:
        return _uniform(i0, i1, i2, sg, 0.0, 0.0, 0.0)
    eQ = math.frexp(mQ)[1]
    eI = math.frexp(max(I1, I2, I3))[1]
    Q0s = math.ldexp(Q[0], -eQ)
    Q1s = math.ldexp(Q[1], -eQ)
    Q2s = math.ldexp(Q[2], -eQ)
    Q3s = math.ldexp(Q[3], -eQ)
    Iv = (math.ldexp(I1, -eI), math.ldexp(I2, -eI), math.ldexp(I3, -eI))
    # g = ½ vec(q̃∘Q) (Arribas et al. eq. 17) in double-double: E_B below cancels near the
    # separatrix, so g must carry more than double precision into it.
    gh0, gl0 = _dd_dot4(q[0], -q[1], -q[2], q[3], Q1s, Q0s, Q3s, Q2s)
    gh1, gl1 = _dd_dot4(q[0], q[1], -q[2], -q[3], Q2s, Q3s, Q0s, Q1s)
    gh2, gl2 = _dd_dot4(q[0], -q[1], q[2], -q[3], Q3s, Q2s, Q1s, Q0s)
    gh = (0.5 * gh0, 0.5 * gh1, 0.5 * gh2)
    gl = (0.5 * gl0, 0.5 * gl1, 0.5 * gl2)
    g = (gh[0] + gl[0], gh[1] + gl[1], gh[2] + gl[2])
    scale = math.ldexp(1.0, eQ - eI)
    A = Iv[i0]
    B = Iv[i1]
    C = Iv[i2]
    x1 = g[i0]
    x2 = sg * g[i1]
    x3 = g[i2]
    s1 = x1 * x1
    s2 = x2 * x2
    s3 = x3 * x3
    G2 = s1 + s2 + s3
    if G2 == 0.0:
        return _uniform(i0, i1, i2, sg, 0.0, 0.0, 0.0)
    G = math.sqrt(G2)
    # E_i = G² − 2T I_i as sums of same-sign terms (E_A ≥ 0, E_C ≤ 0) ...
    EA = s2 * ((B - A) / B) + s3 * ((C - A) / C)
    ECn = s1 * ((C - A) / A) + s2 * ((C - B) / B)  # −E_C ≥ 0
    # ... and E_B = [x3² A (C − B) − x1² C (B − A)] / (A C), which changes sign on the
    # separatrix, in double-double from exact differences and products
    cbh, cbl = _two_sum(C, -B)
    bah, bal = _two_sum(B, -A)
    cbh, cbl = _dd_mul(cbh, cbl, A, 0.0)
    bah, bal = _dd_mul(bah, bal, C, 0.0)
    s3h, s3l = _dd_mul(gh[i2], gl[i2], gh[i2], gl[i2])
    s1h, s1l = _dd_mul(gh[i0], gl[i0], gh[i0], gl[i0])
    t3h, t3l = _dd_mul(s3h, s3l, cbh, cbl)
    t1h, t1l = _dd_mul(s1h, s1l, bah, bal)
    ebh, ebl = _dd_add(t3h, t3l, -t1h, -t1l)
    EB = (ebh + ebl) / (A * C)
    uniform = False
    kind = 1.0
    if EB > 0.0:  # circulation about the largest axis C
        cidx = 2
        xo = x1
        xc = x3
        ao2 = A * ECn / (C - A)
        a22 = B * ECn / (C - B)
        ac2 = C * EA / (C - A)
        lam2 = (C - B) * EA / (A * B * C)
        m = (B - A) * ECn / ((C - B) * EA)
        m1 = (C - A) * EB / ((C - B) * EA)
        uniform = ao2 == 0.0 or a22 == 0.0
    elif EB < 0.0:  # circulation about the smallest axis A
        cidx = 0
        xo = x3
        xc = x1
        ao2 = C * EA / (C - A)
        a22 = B * EA / (B - A)
        ac2 = A * ECn / (C - A)
        lam2 = (B - A) * ECn / (A * B * C)
        m = (C - B) * EA / ((B - A) * ECn)
        m1 = (C - A) * (-EB) / ((B - A) * ECn)
        uniform = ao2 == 0.0 or a22 == 0.0
    else:  # separatrix, or an axisymmetric / saddle equilibrium
        cidx = 2
        xo = x1
        xc = x3
        uniform = A == B or B == C or (x1 == 0.0 and x3 == 0.0)
        ao2 = 0.0
        a22 = 0.0
        ac2 = 0.0
        lam2 = 0.0
        m = 1.0
        m1 = 0.0
        if not uniform:
            kind = 2.0
            ao2 = A * ECn / (C - A)
            a22 = B * ECn / (C - B)
            ac2 = C * EA / (C - A)
            lam2 = (C - B) * EA / (A * B * C)
            uniform = ao2 == 0.0 or a22 == 0.0 or ac2 == 0.0
    if uniform or lam2 == 0.0:
        return _uniform(
            i0,
            i1,
            i2,
            sg,
            math.ldexp(g[0] / Iv[0], eQ - eI),
            math.ldexp(g[1] / Iv[1], eQ - eI),
            math.ldexp(g[2] / Iv[2], eQ - eI),
        )
    if kind == 1.0:
        if m1 <= m:
            m = 1.0 - m1
        else:
            m1 = 1.0 - m
        if m < 0.0:
            m = 0.0
            m1 = 1.0
    ao = math.sqrt(ao2)
    a2 = math.sqrt(a22)
    ac = math.sqrt(ac2)
    lam = math.sqrt(lam2)
    sc = 1.0 if xc >= 0.0 else -1.0
    so = 1.0
    if kind == 2.0:
        so = 1.0 if xo >= 0.0 else -1.0
    s2g = so * sc  # from Euler's equations: σ_B = σ_o s_c
    So = so * ao
    S2 = s2g * a2
    Sc = sc * ac
    cnx = xo / So
    snx = x2 / S2
    # pole: the extreme axis the momentum stays away from (|g_p| ≤ G/√2)
    polec = ac2 <= ao2
    if polec:
        pidx = cidx
        Ap = ao2
        n = -ac2 * m / ao2
        V = math.sqrt(ao2 + ac2 * m)
        Wd = ao
        hamp = Sc
    else:
        pidx = 2 - cidx
        Ap = ac2
        n = -ao2 / ac2
        V = math.sqrt(ac2 * m + ao2)
        Wd = ac
        hamp = So
    if pidx == 0:
        Ip = A
        Ep = EA
    else:
        Ip = C
        Ep = -ECn
    D = -Ep / Ip  # 2T − G²/I_p
    coefP = D * G / (lam * Ap)
    coefW = D * hamp / (lam * Wd * V)
    K = _NAN
    Pic = _NAN
    # The initial phase enters only through (sn, cn, dn)(u0), read off the state: the motion at
    # u0 + λt follows from the addition theorems (free_rotation), so u0 itself is never formed.
    # On the separatrix (m = 1) sn = tanh, cn = dn = sech and cn0 > 0.
    rho = math.hypot(cnx, snx)
    c0 = cnx / rho
    s0 = snx / rho
    d0 = math.sqrt(m1 + m * c0 * c0)
    u0 = 0.0
    if kind == 1.0:
        K = ellipkm1(m1)
        if with_pic:
            Pic = ellippi_complete(n, m1, K)
    else:
        u0 = math.asinh(snx / cnx)
    kap = math.sqrt((-n) * (m - n) * (1.0 - n))
    # The orbit's own point y at u0 (it differs from the input g by rounding). M(t) is built
    # as the rotation taking y to the orbit's point y + Δ(t) at u0 + λt, from Δ itself.
    if cidx == 2:
        y1 = So * c0
        y3 = Sc * d0
    else:
        y1 = Sc * d0
        y3 = So * c0
    y2 = S2 * s0
    G0 = math.sqrt(y1 * y1 + y2 * y2 + y3 * y3)
    if pidx == 0:
        p0 = G0 + y1
        N0 = math.sqrt(p0 * p0 + y2 * y2 + y3 * y3)
    else:
        p0 = G0 + y3
        N0 = math.sqrt(p0 * p0 + y1 * y1 + y2 * y2)
    fpolec = 1.0 if polec else 0.0
    return FreeRigidBody(
        kind,
        float(i0),
        float(i1),
        float(i2),
        sg,
        0.0,
        0.0,
        0.0,
        G0,
        lam * scale,
        m,
        m1,
        K,
        s0,
        c0,
        d0,
        u0,
        So,
        S2,
        Sc,
        float(cidx),
        float(pidx),
        fpolec,
        n,
        kap,
        V,
        Wd,
        (G / Ip) * scale,
        coefP,
        coefW,
        Pic,
        y1,
        y2,
        y3,
        N0,
    )


@jit
def free_rotation(P, t):
    """Unit quaternion M(t) (original body frame) with q(t) = q0∘M, Q(t) = Q0∘M -> 4-tuple."""
    i0 = int(P.i0)
    i1 = int(P.i1)
    if P.kind == 0.0:
        w1, w2, w3 = P.w1, P.w2, P.w3
        wn = math.sqrt(w1 * w1 + w2 * w2 + w3 * w3)
        if wn == 0.0:
            return 1.0, 0.0, 0.0, 0.0
        half = 0.5 * wn * t
        sh = math.sin(half) / wn
        return math.cos(half), sh * w1, sh * w2, sh * w3
    # Phase advance δ = λt, reduced to δ = 2jK + r, r ∈ [−K, K] (no period on the separatrix)
    # with (sn, cn, dn)(r) to full relative accuracy. Everything below is built from these and
    # (sn, cn, dn)(u0) by the addition theorems, so every increment is proportional to sn r
    # and keeps its relative accuracy however small λt is (a slowly precessing, nearly
    # axisymmetric body has λ → 0 while the factors D_p/λ below grow like 1/λ).
    dl = P.lam * t
    m = P.m
    n = P.n
    if P.kind == 1.0:
        sr, cr, dr, j = ellipj_reduced(dl, m, P.m1, P.K)
        Pr = ellippi_sc(n, sr, cr, dr)  # Π(n; am r | m)
    else:
        j = 0.0
        sr = math.tanh(dl)
        ea = math.exp(-abs(dl))
        cr = 2.0 * ea / (1.0 + ea * ea)
        dr = cr
        nu = -n
        snu = math.sqrt(nu)
        Pr = (dl + snu * math.atan(snu * sr)) / (1.0 + nu)  # Π(n; am r | 1)
    s0 = P.s0
    c0 = P.c0
    d0 = P.d0
    # (sn, cn, dn)(u0 + r) − (sn, cn, dn)(u0) from the addition theorems (DLMF 22.8.1-3),
    # rearranged with c − 1 = −s²/(1 + c), d − 1 = −m s²/(1 + d) (c = cn r ≥ 0, d = dn r > 0)
    # so that each increment is sn r times a sum that does not cancel as r → 0.
    # Denominator 1 − m s0² sr² = d0² + m s0² cr².
    ms0 = m * s0 * s0
    den = 1.0 - ms0 * sr * sr
    if den < 0.5:
        den = d0 * d0 + ms0 * cr * cr
    if P.kind == 2.0 and abs(dl) >= 1.0:
        # separatrix, a step of at least one e-folding: tanh and sech of u directly (the
        # addition formulas would divide underflowed sech values by each other)
        u = P.u0 + dl
        sw = math.tanh(u)
        ea = math.exp(-abs(u))
        cw = 2.0 * ea / (1.0 + ea * ea)
        dw = cw
        dsw = sw - s0
        dcw = cw - c0
        ddw = dcw
    else:
        # The brackets m s0² − m cr/(1 + dr) − 1/(1 + cr), m s0² − 1/(1 + cr) and
        # s0² − 1/(1 + dr) are rewritten with 1 − m s0² = d0², 1 − s0² = c0² and
        # dr − m cr = m1 (1 + m cr²)/(dr + m cr) (no absolute O(ε) error where d0, c0 are
        # small: near the separatrix den can be small). dr ≥ √m1 > 0 when m1 > 0.
        ic = 1.0 / (1.0 + cr)
        idr = 1.0 / (1.0 + dr)
        bs = -d0 * d0
        if P.m1 != 0.0:
            bs += cr * P.m1 * (1.0 + (1.0 + m * cr * cr) / (dr + m * cr)) * ic * idr
        dsw = sr * (c0 * d0 + s0 * sr * bs) / den
        dcw = sr * (c0 * sr * (cr * ic - d0 * d0) - s0 * d0 * dr) / den
        ddw = m * sr * (d0 * sr * (dr * idr - c0 * c0) - s0 * c0 * cr) / den
        sw = s0 + dsw
        cw = c0 + dcw
        dw = d0 + ddw
    # at u = u0 + 2jK + r: sn u = (−1)^j sw, cn u = (−1)^j cw, dn u = dw
    if j % 2.0 == 0.0:
        sn = sw
        dsn = dsw
        dcn = dcw
    else:
        sn = -sw
        dsn = -(s0 + sw)
        dcn = -(c0 + cw)
    dn = dw
    # Π(n; am u|m) − Π(n; am u0|m) = 2jΠ(n|m) + Π(n; am r|m) + E, with the addition theorem
    # Π(u0 + r) − Π(u0) − Π(r) = (n/κ) atan(κ s0 sr sw / X), κ² = n(n − m)(1 − n),
    # X = 1 − n (sw² − s0 sr cw dw) ≥ 1 (derived from Jacobi's addition theorem for his Π(u, a)
    # with n = m sn²a, a imaginary for n < 0; checked against quadrature in the tests)
    X = 1.0 - n * (sw * sw - s0 * sr * cw * dw)
    z = s0 * sr * sw / X
    kz = P.kap * z
    dP = Pr + n * z * (math.atan(kz) / kz if kz != 0.0 else 1.0)
    if j != 0.0:
        Pic = P.Pic
        if Pic != Pic:
            Pic = ellippi_complete(n, P.m1, P.K)
        dP += 2.0 * j * Pic
    # the arctangent term: W(u) − W(u0) as one atan2 of (cross, dot), the cross product formed
    # from the increments
    V = P.V
    Wd = P.Wd
    if P.polec == 1.0:
        # W = atan2(V sn, Wd cn), unwrapped by π per 2K; |W(u0 + r) − W(u0)| < π for |r| ≤ K
        cross = dsw * c0 - dcw * s0  # = sw c0 − cw s0
        dW = math.atan2(V * Wd * cross, Wd * Wd * cw * c0 + V * V * sw * s0) + math.pi * j
    else:
        # W = atan2(V sn, Wd dn) ∈ (−π/2, π/2): periodic
        cross = dsn * d0 - ddw * s0  # = sn d0 − dn s0
        dW = math.atan2(V * Wd * cross, Wd * Wd * dn * d0 + V * V * sn * s0)
    phi = P.Gp * t + P.coefP * dP - P.coefW * dW
    # body momentum g = y + Δ in the sorted frame (y: the orbit's point at u0)
    if P.cidx == 2.0:
        e1 = P.So * dcn
        e3 = P.Sc * ddw
    else:
        e1 = P.Sc * ddw
        e3 = P.So * dcn
    e2 = P.S2 * dsn
    y1 = P.y1
    y2 = P.y2
    y3 = P.y3
    x1 = y1 + e1
    x2 = y2 + e2
    x3 = y3 + e3
    G0 = P.G
    Gt = math.sqrt(x1 * x1 + x2 * x2 + x3 * x3)
    dG = (e1 * (y1 + x1) + e2 * (y2 + x2) + e3 * (y3 + x3)) / (G0 + Gt)  # Gt − G0
    # M = ã(y)∘r(φ)∘a(g) with a(g) = (G + g_p, g × ê)/N the minimal rotation taking g to G ê
    # (section 3 of docs/exact.md), regrouped as M = B∘r' with B = ã(y)∘a(g) and
    # r' = ã(g)∘r(φ)∘a(g) = (cos ½φ, sin ½φ g/|g|). B's vector part is linear in Δ = g − y and
    # is formed from Δ: a small step gives a rotation accurate to ε relative to its own size,
    # with no O(ε) error from products of O(1) quaternions that nearly cancel.
    if P.pidx == 0.0:
        p0 = G0 + y1
        dp = dG + e1
        # v = g × e1 = (0, g3, −g2)
        v0x, v0y, v0z = 0.0, y3, -y2
        dvx, dvy, dvz = 0.0, e3, -e2
    else:
        p0 = G0 + y3
        dp = dG + e3
        # v = g × e3 = (g2, −g1, 0)
        v0x, v0y, v0z = y2, -y1, 0.0
        dvx, dvy, dvz = e2, -e1, 0.0
    p = p0 + dp
    vx = v0x + dvx
    vy = v0y + dvy
    vz = v0z + dvz
    nn = P.N0 * math.sqrt(p * p + vx * vx + vy * vy + vz * vz)
    bw = (p0 * p + v0x * vx + v0y * vy + v0z * vz) / nn
    # p0 v − p v0 − v0 × v = p0 Δv − Δp v0 − v0 × Δv
    bx = (p0 * dvx - dp * v0x - (v0y * dvz - v0z * dvy)) / nn
    by = (p0 * dvy - dp * v0y - (v0z * dvx - v0x * dvz)) / nn
    bz = (p0 * dvz - dp * v0z - (v0x * dvy - v0y * dvx)) / nn
    hs = math.sin(0.5 * phi) / Gt
    M = mul((bw, bx, by, bz), (math.cos(0.5 * phi), hs * x1, hs * x2, hs * x3))
    # back to the original body frame: v[i_k] = s_k v'_k
    v0 = M[1]
    v1 = P.sg * M[2]
    v2 = M[3]
    o0 = v0 if i0 == 0 else (v1 if i1 == 0 else v2)
    o1 = v0 if i0 == 1 else (v1 if i1 == 1 else v2)
    o2 = v0 if i0 == 2 else (v1 if i1 == 2 else v2)
    return M[0], o0, o1, o2


@jit
def _mul_unit(q, M):
    """q∘M for M a unit quaternion up to rounding, applied as q + q∘(M − 1) with the scalar
    part of M − 1 taken as √(1 − |v|²) − 1 = −|v|²/(1 + √(1 − |v|²)) (v = vec M).

    The computed M has |M|² − 1 = O(ε), mostly from rounding its scalar part near 1, and that
    error is nearly the same from one call to the next when the motion changes little between
    calls, so q∘M would scale |q|, |Q| and T by the same 1 + O(ε) at every call of a composed
    flow (a drift ∝ the number of calls). In the increment form the applied rotation is unit to
    O(ε |v|²) and the only rounding left is that of q + (small), which varies from call to call.
    """
    w, x, y, z = M
    if w < 0.5:  # large rotations (not the composed small steps): plain product
        return mul(q, M)
    s2 = x * x + y * y + z * z
    d = mul(q, (-s2 / (1.0 + math.sqrt(1.0 - s2)), x, y, z))
    return q[0] + d[0], q[1] + d[1], q[2] + d[2], q[3] + d[3]


@jit
def free_flow(I1, I2, I3, q, Q, h):
    """Exact torque-free flow over a step h from an arbitrary state -> (q_new, Q_new) 4-tuples.

    q_new = q∘M(h), Q_new = Q∘M(h), with g = ½ vec(q̃∘Q) (no normalisation of q is assumed
    or applied; |q| and q·Q are carried unchanged, as by the exact Hamiltonian flow).
    """
    P = prepare(I1, I2, I3, q, Q, False)
    M = free_rotation(P, h)
    return _mul_unit(q, M), _mul_unit(Q, M)


@jit
def free_flow_inplace(I1, I2, I3, y, h):
    """In-place variant on a length-8 array y = (q, Q)."""
    q = (y[0], y[1], y[2], y[3])
    Q = (y[4], y[5], y[6], y[7])
    qn, Qn = free_flow(I1, I2, I3, q, Q, h)
    for k in range(4):
        y[k] = qn[k]
        y[4 + k] = Qn[k]


@jit
def torque_free_kernel(I1, I2, I3, q0, Q0, t, out_q, out_Q):
    """Fill out_q[i], out_Q[i] (shape (len(t), 4)) with the exact motion at times t[i]."""
    P = prepare(I1, I2, I3, q0, Q0, True)
    for i in range(t.shape[0]):
        M = free_rotation(P, t[i])
        qn = mul(q0, M)
        Qn = mul(Q0, M)
        for k in range(4):
            out_q[i, k] = qn[k]
            out_Q[i, k] = Qn[k]

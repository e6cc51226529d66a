"""Compiled composition steppers of the symplectic methods ``"nosquish"`` and ``"splitting"``.

One generic stepper runs any palindromic sequence of exactly integrated sub-flows; the methods
are the data below. Sub-flows (``KICK``, ``ROTOR``, ``FREE``) of the canonical Hamiltonian
H = T + U in the quaternion variables (q, Q) of Arribas, Elipe & Palacios (2006), eq. 6:

``KICK`` — the flow of U (q and t frozen): Q ← Q + τ 2 q∘(0, τ_B(q, t)) (eq. 7 with the
    generalised force of Schwab eq. 25). It is exact: q does not move, so the force is constant.
``ROTOR`` — the NO_SQUISH free-rotor sequence of Miller et al., J. Chem. Phys. 116, 8649 (2002):
    T₁(τ/2) T₂(τ/2) T₃(τ) T₂(τ/2) T₁(τ/2), where T_k = (q̃∘Q)_k² / (8 I_k) = g_k² / (2 I_k) is the
    kinetic energy about principal axis k. Its flow is exact: g_k is constant and
    q̇ = ½ q∘(0, ω_k e_k), Q̇ = ½ Q∘(0, ω_k e_k) with ω_k = g_k / I_k, so
    q ← q∘r, Q ← Q∘r, r = (cos φ/2, sin φ/2 e_k), φ = τ g_k / I_k.
``FREE`` — the exact torque-free flow of T (Euler–Poinsot), :mod:`attitude._core.exact`.

Orbit and attitude in one state (issue 41): a rigid body of mass m around a point mass μ,
H = |p|²/(2m) − μm/|r| + T + V2(q, r) with MacCullagh's V2 = −μ/(2|r|³)(tr I − 3 r̂ᵀ I r̂) (r̂ in
body axes), split Wisdom–Holman style into A = Kepler + T and B = V2, each flow exact:

``FREE_KEPLER`` — the flow of A: ``FREE`` and the Kepler drift of (r, v)
    (:func:`orbit._kepler_drift.kepler_drift`, universal variables); the two act on disjoint
    variables, so they commute.
``ROTOR_KEPLER`` — ``ROTOR`` and the Kepler drift (the coupled ``"nosquish"``).
``MUTUAL`` — the flow of V2 (q and r frozen): the body's momentum takes the gravity-gradient
    torque τ_B = 3μ/|r|⁵ r_B × I r_B (eq. 20) as ``KICK`` does, the orbit the force
    F = −∇_r V2 = −3μ I r_B/|r|⁵ − (3μ/2)(tr I − 5 r_Bᵀ I r_B/|r|²) r_B/|r|⁵ (body axes, turned to
    space axes by q): v ← v + τ F/m. τ_B = −r_B × F_B, so the kick leaves r × p + R(q) g as
    it was; so do the drifts (rotation invariant), so the total angular momentum is conserved
    to round-off by every coupled method.

The coupled state is :data:`COUPLED_STATE` (q, w, r, v: r [m] and v [m/s] in space axes) and
the parameters :data:`COUPLED` (I, μ, 1/m); :func:`coupled_composition` is its entry point.

State representation
--------------------
Inside the loop the state is (q, w) with w = q̃∘Q = (q·Q, 2g) instead of (q, Q): the map
(q, Q) ↔ (q, w = q̃∘Q, Q = q∘w/|q|²) is a bijection for q ≠ 0, so every sub-flow is the same
map written in other coordinates, but the round-off is kinder: the rotor moves w by the
rotation r̃∘w∘r of its vector part about e_k (its scalar part w₀ = q·Q is never touched), and
the kick adds 2τ|q|²(0, τ_B) to it (q̃∘q∘(0, τ) = |q|²(0, τ)). So q·Q = w₀ is constant to the
last bit between output times and |q| changes only by the rounding of q∘r.

Time-dependent potentials
-------------------------
t is a coordinate of an extended phase space with conjugate momentum p_t,
H_ext = (T + p_t) + U(q, t): the free sub-flows (``ROTOR``, ``FREE``) advance t by their
duration, the kicks evaluate the torque at the frozen t. Every method is therefore a
symmetric composition of exact flows of H_ext, symplectic and time-reversible.

Methods as data
---------------
A method is three arrays of the same length: ``kinds`` (sub-flow code per stage), ``coefs``
(duration per stage in units of the step h) and ``toffs`` (the time, relative to the step start
and in units of h, at which that stage is evaluated). The sequence is palindromic, with the same
kind first and last: the last stage of a step and the first of the next are one flow at the same
(q, t), so they are merged into one evaluation (exactly, not approximately), except at output
times.
"""

from __future__ import annotations

import math

import numpy as np

from orbit._kepler_drift import kepler_drift_state
from orbit._layout import Field, layout
from orbit._shared_jit import jit, jit_generic

from .exact import free_flow
from .quat import mul, rotate, rotate_inverse

# Sub-flow codes.
KICK = 0
ROTOR = 1
FREE = 2
FREE_KEPLER = 3
ROTOR_KEPLER = 4
MUTUAL = 5
#: The kicks (flows of a potential: they do not advance t).
KICKS = (KICK, MUTUAL)

#: Parameters of the coupled orbit–attitude methods (``params`` of :func:`coupled_composition`).
COUPLED = layout(
    "coupled splitting parameters",
    inertia=Field(3, "kg m2", "principal moments of inertia I1, I2, I3"),
    mu=Field(1, "m3 s-2", "gravitational parameter μ of the central point mass"),
    inv_mass=Field(1, "1/kg", "1/m (0: no back-reaction on the orbit)"),
)
#: The state of the coupled methods inside the loop (the first 8 values: the attitude's).
COUPLED_STATE = layout(
    "coupled splitting state",
    q=Field(4, "", "attitude quaternion (body → space)"),
    w=Field(4, "kg m2/s", "w = q̃∘Q = (q·Q, 2g)"),
    r=Field(3, "m", "position of the centre of mass, space axes"),
    v=Field(3, "m/s", "its velocity, space axes"),
)

# Status codes (same meaning as in orbit._rk).
SUCCESS = 0
NONFINITE = 1
#: The call's step budget (``counters[4]``) ran out inside an interval: call again.
PAUSED = 2

#: Length of the ``counters`` array of :func:`composition_run`.
N_COUNTERS = 5

# --------------------------------------------------------------------------------------------
# Coefficients (all of them, in one place)
# --------------------------------------------------------------------------------------------

#: Symmetric compositions Φ_{γ_m h} ∘ … ∘ Φ_{γ_1 h} of a symmetric 2nd-order method Φ.
#: Order 4: Suzuki's fractal 5-stage composition (Phys. Lett. A 146, 319, 1990),
#: γ₁ = γ₂ = γ₄ = γ₅ = 1/(4 − 4^{1/3}), γ₃ = 1 − 4γ₁.
_SUZUKI4 = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))
COMPOSITION_GAMMA = {
    2: np.array([1.0]),
    4: np.array([_SUZUKI4, _SUZUKI4, 1.0 - 4.0 * _SUZUKI4, _SUZUKI4, _SUZUKI4]),
    # Order 6: Kahan & Li, Math. Comp. 66, 1089 (1997), "s9odr6a" (as printed in Hairer, Lubich
    # & Wanner, Geometric Numerical Integration, 2nd ed., eq. V.3.13).
    6: np.array(
        [
            0.39216144400731413927925056,
            0.33259913678935943859974864,
            -0.70624617255763935980996482,
            0.08221359629355080023149045,
            0.79854399093482996339895035,
            0.08221359629355080023149045,
            -0.70624617255763935980996482,
            0.33259913678935943859974864,
            0.39216144400731413927925056,
        ]
    ),
}

#: Yoshida's triple jump (Phys. Lett. A 150, 262, 1990), order 4: kept for the tests (a second,
#: independent order-4 composition), not used by a method.
YOSHIDA4_GAMMA = np.array(
    [
        1.0 / (2.0 - 2.0 ** (1.0 / 3.0)),
        -(2.0 ** (1.0 / 3.0)) / (2.0 - 2.0 ** (1.0 / 3.0)),
        1.0 / (2.0 - 2.0 ** (1.0 / 3.0)),
    ]
)


def _blanes_moan(a_half, b_half):
    """Full palindromic (a, b) of Blanes & Moan's symmetric PRK methods from their half tables.

    The scheme is e^{a₁hA} e^{b₁hB} e^{a₂hA} … e^{b₁hB} e^{a₁hA}; the middle coefficients
    follow from consistency (Σa = Σb = 1).
    """
    a_half = np.asarray(a_half, dtype=np.float64)
    b_half = np.asarray(b_half, dtype=np.float64)
    a_mid = 1.0 - 2.0 * a_half.sum()
    b_mid = 0.5 - b_half.sum()
    a = np.concatenate([a_half, [a_mid], a_half[::-1]])
    b = np.concatenate([b_half, [b_mid, b_mid], b_half[::-1]])
    return a, b


#: Splittings e^{a₁hA} e^{b₁hB} … e^{a_{s+1}hA} of H = A + B with A the free rigid body (exact)
#: and B the potential (kick). Order 2: Strang. Orders 4 and 6: Blanes & Moan, J. Comput. Appl.
#: Math. 142, 313 (2002), Table 2, the symmetric PRK methods S₆ (order 4, 6 stages) and S₁₀
#: (order 6, 10 stages), whose small error coefficients pay off for a weak perturbation B.
SPLITTING_AB = {
    2: (np.array([0.5, 0.5]), np.array([1.0])),
    4: _blanes_moan(
        [0.0792036964311957, 0.353172906049774, -0.0420650803577195],
        [0.209515106613362, -0.143851773179818],
    ),
    6: _blanes_moan(
        [
            0.0502627644003922,
            0.413514300428344,
            0.0450798897943977,
            -0.188054853819569,
            0.541960678450780,
        ],
        [0.148816447901042, -0.132385865767784, 0.067307604692185, 0.432666402578175],
    ),
}


def _ops_from_ab(a, b, outer, inner):
    """Stage tables (kinds, coefs, toffs) of e^{a₁h·outer} e^{b₁h·inner} … e^{a_{s+1}h·outer}."""
    n = len(a) + len(b)
    kinds = np.empty(n, dtype=np.int64)
    coefs = np.empty(n)
    kinds[0::2] = outer
    kinds[1::2] = inner
    coefs[0::2] = a
    coefs[1::2] = b
    toffs = np.empty(n)
    elapsed = 0.0
    for i in range(n):
        toffs[i] = elapsed
        if kinds[i] not in KICKS:  # free flows advance t (extended phase space)
            elapsed += coefs[i]
    return kinds, coefs, toffs


def composition_tables(gamma, kick=KICK, rotor=ROTOR):
    """Stage tables of the symmetric composition of kick(γh/2)·ROTOR(γh)·kick(γh/2).

    Adjacent half kicks of consecutive factors are one kick of (γᵢ + γᵢ₊₁)h/2. ``kick`` and
    ``rotor``: the sub-flow codes (``MUTUAL``, ``ROTOR_KEPLER`` for the coupled method).
    """
    gamma = np.asarray(gamma, dtype=np.float64)
    kicks = np.empty(gamma.size + 1)
    kicks[0] = 0.5 * gamma[0]
    kicks[-1] = 0.5 * gamma[-1]
    kicks[1:-1] = 0.5 * (gamma[:-1] + gamma[1:])
    return _ops_from_ab(kicks, gamma, kick, rotor)


def method_tables(name: str, order: int, coupled: bool = False):
    """(kinds, coefs, toffs) of method ``name`` ("nosquish" or "splitting") at ``order``;
    ``coupled``: the orbit–attitude version (the same coefficients, the sub-flows of A = Kepler
    + T and B = V2)."""
    if name == "nosquish":
        if coupled:
            return composition_tables(COMPOSITION_GAMMA[order], MUTUAL, ROTOR_KEPLER)
        return composition_tables(COMPOSITION_GAMMA[order])
    if name == "splitting":
        a, b = SPLITTING_AB[order]
        if coupled:
            return _ops_from_ab(a, b, FREE_KEPLER, MUTUAL)
        return _ops_from_ab(a, b, FREE, KICK)
    raise KeyError(name)


# --------------------------------------------------------------------------------------------
# Sub-flows (compiled)
# --------------------------------------------------------------------------------------------


@jit
def _rotor_axis(q, w, a, tau, inertia_a):
    """Exact flow of T_a = w_a²/(8 I_a) for a time tau (a = 1, 2, 3)."""
    # φ = τ g_a / I_a with g_a = w_a / 2; r = (cos φ/2, sin φ/2 e_a).
    half = 0.25 * tau * w[a] / inertia_a
    c = math.cos(half)
    s = math.sin(half)
    b = a % 3 + 1
    d = b % 3 + 1
    # q ← q∘r (cyclic form of the Hamilton product with a pure-axis factor)
    q0 = q[0]
    qa = q[a]
    qb = q[b]
    qd = q[d]
    q[0] = q0 * c - qa * s
    q[a] = qa * c + q0 * s
    q[b] = qb * c + qd * s
    q[d] = qd * c - qb * s
    # w ← r̃∘w∘r: the vector part turns by −φ about e_a (cos φ, sin φ from the half angle).
    cf = (c - s) * (c + s)
    sf = 2.0 * s * c
    wb = w[b]
    wd = w[d]
    w[b] = wb * cf + wd * sf
    w[d] = wd * cf - wb * sf


@jit
def rotor_flow(q, w, tau, params):
    """NO_SQUISH free part: T₁(τ/2) T₂(τ/2) T₃(τ) T₂(τ/2) T₁(τ/2) (Miller et al. 2002)."""
    h2 = 0.5 * tau
    _rotor_axis(q, w, 1, h2, params[0])
    _rotor_axis(q, w, 2, h2, params[1])
    _rotor_axis(q, w, 3, tau, params[2])
    _rotor_axis(q, w, 2, h2, params[1])
    _rotor_axis(q, w, 1, h2, params[0])


@jit
def free_flow_state(q, w, tau, params):
    """Exact torque-free flow for a time tau: q ← q∘M, w ← M̃∘w∘M (Q ← Q∘M)."""
    # The free flow right-multiplies q and Q by the same unit quaternion M(τ), which depends on
    # g = ½ vec(q̃∘Q) = ½ vec(w) only: it is the first output for the state (1, (0, w)).
    M = free_flow(
        params[0], params[1], params[2], (1.0, 0.0, 0.0, 0.0), (0.0, w[1], w[2], w[3]), tau
    )[0]
    qn = mul(q, M)
    q[0] = qn[0]
    q[1] = qn[1]
    q[2] = qn[2]
    q[3] = qn[3]
    g = rotate_inverse(M, (w[1], w[2], w[3]))  # vector part of M̃∘w∘M; w₀ = q·Q untouched
    w[1] = g[0]
    w[2] = g[1]
    w[3] = g[2]


@jit
def mutual_kick(q, w, x, tau, params):
    """Exact flow of V2(q, r) for a time tau (q, r frozen): w += 2τ|q|²(0, τ_B), v += τ F/m.

    ``x`` = (r, v) in space axes [m, m/s]; ``params`` the :data:`COUPLED` block.
    """
    i1 = params[COUPLED.INERTIA]
    i2 = params[COUPLED.INERTIA + 1]
    i3 = params[COUPLED.INERTIA + 2]
    rb = rotate_inverse(q, (x[0], x[1], x[2]))  # r in body axes
    r2 = rb[0] * rb[0] + rb[1] * rb[1] + rb[2] * rb[2]
    k = 3.0 * params[COUPLED.MU] / (r2 * r2 * math.sqrt(r2))  # 3μ/|r|⁵
    ir0 = i1 * rb[0]
    ir1 = i2 * rb[1]
    ir2 = i3 * rb[2]
    # τ_B = 3μ/|r|⁵ r_B × I r_B (Arribas et al. eq. 20)
    t0 = k * (rb[1] * ir2 - rb[2] * ir1)
    t1 = k * (rb[2] * ir0 - rb[0] * ir2)
    t2 = k * (rb[0] * ir1 - rb[1] * ir0)
    # F_B = −∇V2 = −k I r_B − (k/2)(tr I − 5 r_Bᵀ I r_B/|r|²) r_B, so that r_B × F_B = −τ_B
    c = 0.5 * k * ((i1 + i2 + i3) - 5.0 * (rb[0] * ir0 + rb[1] * ir1 + rb[2] * ir2) / r2)
    fs = rotate(q, (-k * ir0 - c * rb[0], -k * ir1 - c * rb[1], -k * ir2 - c * rb[2]))
    f = 2.0 * tau * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w[1] += f * t0
    w[2] += f * t1
    w[3] += f * t2
    sm = tau * params[COUPLED.INV_MASS]
    x[3] += sm * fs[0]
    x[4] += sm * fs[1]
    x[5] += sm * fs[2]


@jit_generic
def apply_stage(torque, params, kind, tau, t, q, w, x, counters):
    """Sub-flow ``kind`` (``KICK``, ``ROTOR``, ``FREE``) for a time ``tau`` on the state (q, w);
    ``t`` is the clock of a ``KICK``'s torque, ``x`` unused. Counts kicks in ``counters[1]``,
    free flows in ``counters[2]``."""
    if kind == KICK:
        # Exact flow of U: Q += 2τ q∘(0, τ_B), i.e. w += 2τ|q|²(0, τ_B).
        # ω = g/I with g = ½ vec(w); the splittings take only models whose torque does not
        # depend on ω (checked by attitude.splitting).
        om = (0.5 * w[1] / params[0], 0.5 * w[2] / params[1], 0.5 * w[3] / params[2])
        tq = torque(q, om, t, params)
        f = 2.0 * tau * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        w[1] += f * tq[0]
        w[2] += f * tq[1]
        w[3] += f * tq[2]
        counters[1] += 1
    elif kind == ROTOR:
        rotor_flow(q, w, tau, params)
        counters[2] += 1
    else:
        free_flow_state(q, w, tau, params)
        counters[2] += 1


@jit_generic
def apply_coupled_stage(torque, params, kind, tau, t, q, w, x, counters):
    """Sub-flow ``kind`` (``FREE_KEPLER``, ``ROTOR_KEPLER``, ``MUTUAL``) for a time ``tau`` on
    the coupled state (q, w) and x = (r, v); ``torque`` and ``t`` unused (V2 does not depend on
    t). Counts as :func:`apply_stage`."""
    if kind == MUTUAL:
        mutual_kick(q, w, x, tau, params)
        counters[1] += 1
    else:  # the attitude's free flow and the orbit's Kepler drift, which commute
        if kind == FREE_KEPLER:
            free_flow_state(q, w, tau, params)
        else:
            rotor_flow(q, w, tau, params)
        kepler_drift_state(x, params[COUPLED.MU], tau)
        counters[2] += 1


@jit
def n_steps_for(span, dt):
    """Fewest equal steps no longer than dt (up to a relative 1e-9) covering |span|."""
    r = abs(span) / dt
    n = math.ceil(r * (1.0 - 1e-9))
    return max(1, int(n))


@jit
def state_to_canonical(state, out):
    """(q, w) -> (q, Q = q∘w/|q|²) into out[0:8]."""
    q0, q1, q2, q3 = state[0], state[1], state[2], state[3]
    w0, w1, w2, w3 = state[4], state[5], state[6], state[7]
    inv = 1.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    out[0] = q0
    out[1] = q1
    out[2] = q2
    out[3] = q3
    out[4] = (q0 * w0 - q1 * w1 - q2 * w2 - q3 * w3) * inv
    out[5] = (q0 * w1 + q1 * w0 + q2 * w3 - q3 * w2) * inv
    out[6] = (q0 * w2 - q1 * w3 + q2 * w0 + q3 * w1) * inv
    out[7] = (q0 * w3 + q1 * w2 - q2 * w1 + q3 * w0) * inv


@jit
def canonical_to_state(y, state):
    """(q, Q) -> (q, w = q̃∘Q) into state[0:8]."""
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    Q0, Q1, Q2, Q3 = y[4], y[5], y[6], y[7]
    state[0] = q0
    state[1] = q1
    state[2] = q2
    state[3] = q3
    state[4] = q0 * Q0 + q1 * Q1 + q2 * Q2 + q3 * Q3
    state[5] = q0 * Q1 - q1 * Q0 - q2 * Q3 + q3 * Q2
    state[6] = q0 * Q2 + q1 * Q3 - q2 * Q0 - q3 * Q1
    state[7] = q0 * Q3 - q1 * Q2 + q2 * Q1 - q3 * Q0


# --------------------------------------------------------------------------------------------
# The generic loop
# --------------------------------------------------------------------------------------------


@jit_generic
def composition_run(
    stage, torque, params, kinds, coefs, toffs, state, t_start, t_out, dt, y_out, counters
):
    """Run a composition method through the output times ``t_out``.

    ``stage`` applies one sub-flow (:func:`apply_stage`, or :func:`apply_coupled_stage` for
    the coupled methods: passed in, so that an entry point compiles the sub-flows it runs only),
    ``torque`` is the model of a ``KICK``.

    Starting from ``state`` = (q, w) (coupled: (q, w, r, v)) at ``t_start``, each interval
    between consecutive times (t_start, t_out[0], t_out[1], …) is covered by the fewest equal
    steps no longer than ``dt``; the state at each output time is written to ``y_out[k]`` as
    (q, Q) (coupled: (q, Q, r, v)), and ``state`` holds the last one on return (a later call
    continues from it: chunked runs are bit-for-bit identical).

    ``counters`` (int64, :data:`N_COUNTERS`): steps, kick (torque) evaluations, free-flow
    evaluations; ``counters[3]`` the step at which the first interval resumes (0: from its
    start); ``counters[4]`` the most steps this call takes (0: no limit). When that budget runs
    out inside an interval the call returns ``PAUSED`` with ``state`` mid-interval and
    ``counters[3]`` set; called again with the same ``t_start`` and the remaining ``t_out`` it
    continues bit for bit (the pending merged stage is recomputed: it is ``coefs[-1] h``).

    Returns
    -------
    status : int
        ``SUCCESS``, ``NONFINITE`` or ``PAUSED``.
    n_done : int
        Rows of ``y_out`` filled.
    """
    m = t_out.shape[0]
    nops = kinds.shape[0]
    q = state[0:4]
    w = state[4:8]
    x = state[COUPLED_STATE.R :]  # the orbit (r, v) of the coupled methods; empty otherwise
    nx = x.shape[0]
    t_a = t_start
    budget = counters[4]
    taken = 0
    for k in range(m):
        t_b = t_out[k]
        span = t_b - t_a
        if span != 0.0:
            n = n_steps_for(span, dt)
            h = span / n
            j0 = counters[3]
            counters[3] = 0
            pend = 0.0
            if j0 > 0:
                pend = coefs[nops - 1] * h  # the merged last stage of step j0 - 1
            for j in range(j0, n):
                if budget > 0 and taken >= budget:
                    counters[3] = j
                    return PAUSED, k
                taken += 1
                counters[0] += 1
                ts = t_a + j * h
                last = j == n - 1
                for o in range(nops):
                    tau = coefs[o] * h
                    if o == 0:
                        tau += pend
                    elif o == nops - 1 and not last:
                        # Same flow at the same (q, t) as the next step's first stage: merged.
                        pend = tau
                        break
                    stage(torque, params, kinds[o], tau, ts + toffs[o] * h, q, w, x, counters)
                # once per step: a NaN or inf anywhere in the state (a non-finite torque, an
                # overflow) ends the run here, not at the next output time
                total = q[0] + q[1] + q[2] + q[3] + w[0] + w[1] + w[2] + w[3]
                for i in range(nx):
                    total += x[i]
                if not math.isfinite(total):
                    return NONFINITE, k
        state_to_canonical(state, y_out[k])
        for i in range(nx):
            y_out[k, COUPLED_STATE.R + i] = x[i]
        ok = True
        for i in range(COUPLED_STATE.R + nx):
            if not math.isfinite(y_out[k, i]):
                ok = False
        if not ok:
            return NONFINITE, k
        t_a = t_b
    return SUCCESS, m


@jit
def _no_torque(q, w, t, params):
    """The torque of a ``KICK``, which the coupled methods do not have."""
    return 0.0, 0.0, 0.0


@jit
def coupled_composition(params, kinds, coefs, toffs, state, t_start, t_out, dt, y_out, counters):
    """:func:`composition_run` of the coupled methods: ``params`` the :data:`COUPLED` block,
    ``state`` (q, w, r, v) (:data:`COUPLED_STATE`), rows of ``y_out`` (q, Q, r, v) [m, m/s],
    space axes."""
    return composition_run(
        apply_coupled_stage, _no_torque, params, kinds, coefs, toffs, state, t_start, t_out,
        dt, y_out, counters,
    )  # fmt: skip

"""Compiled torque and potential kernels of the built-in models, and of sums of them.

Every built-in model is data: a parameter vector ``params`` whose first entries are the
principal moments of inertia and a kind code, followed by the model's own numbers:

    params[0:3]  I1, I2, I3          principal moments of inertia
    params[3]    kind                KIND_* below
    params[4:]   the model's numbers

A sum of models (``GravityGradient(o) + MagneticDipole(...) + ...``) is one more kind,
``KIND_SUM``, whose numbers say where each term's block starts:

    params[3]    KIND_SUM
    params[4]    n, the number of terms
    params[5:5+n]  offsets b_j of the term blocks: params[b_j] = kind of term j,
                   params[b_j + 1:] its numbers (the layout of that kind alone)

A single model is its own block at offset 3, so every term kernel reads its numbers relative
to the offset ``base`` of its kind code, and one cached, compiled function
(:func:`builtin_torque`) serves every model and every sum of built-in models: the integrators
that call it are cached on disk too.

A model that is one term (not a sum) of any built-in kind runs on the kernels of the
section "one model alone" instead: they call its kind's functions directly, and the entry
points compiled with them (:mod:`attitude._core.models`) compile that kind's code only, not the
switch over every kind (a fresh install's first run compiles a third of the code).

A torque is a function of the attitude q, the body angular velocity ω (body axes; rate-dependent
models such as eddy-current damping use it), and the time t (the orbit and the environment are
functions of t, read from the model's numbers). Torques are body-frame components; they enter
Hamilton's equations through the generalised force 2 q∘(0, τ_B) (Schwab eq. 25), which is minus
the tangential part of ∂U/∂q, so |q| = 1 and q·Q = 0 stay invariants of the flow.
"""

from __future__ import annotations

import numpy as np

from orbit._layout import Field, layout
from orbit._shared_jit import jit, jit_generic
from orbit._state_kernels import MU as ORBIT_MU
from orbit._state_kernels import orbit_radial

from .environment import (
    ENV,
    drag_torque,
    eddy_torque,
    environment_vector,
    magnetic_potential,
    magnetic_torque,
    solar_torque,
)
from .quat import conj_mul, cross, rotate, rotate_inverse

KIND_TORQUE_FREE = 0
KIND_HEAVY_TOP = 1
KIND_GRAVITY_GRADIENT = 2
# Environment models (block layouts in attitude._core.environment)
KIND_MAGNETIC_DIPOLE = 3
KIND_EDDY_CURRENTS = 4
KIND_AERODYNAMIC_DRAG = 5
KIND_SOLAR_RADIATION = 6
KIND_SUM = 100
# Gravity gradient with the orbit integrated alongside (orbit–attitude coupling, issue 41): only
# the Taylor integrator's coupled runner builds such parameters (attitude._core.taylor).
KIND_GRAVITY_GRADIENT_COUPLED = 7
KIND_USER = -1  # no built-in part: the model is the user's terms only (attitude._user_kernels)

# The model's parameters: the inertia, then a single model's block (its kind, its numbers),
# or a sum's number of terms and their blocks' offsets (each block: its kind, its numbers).
_MODEL_HEAD = dict(
    inertia=Field(3, "kg m2", "principal moments of inertia"),
    kind=Field(1, "", "KIND_*: where a single model's block starts"),
)
MODEL = layout("model parameters", **_MODEL_HEAD, data=Field(0, "", "a single model's numbers"))
# Blocks of the built-in models (offsets relative to the block, which starts with its kind).
HEAVY_TOP = layout(
    "heavy top block",
    kind=1,
    weight=Field(1, "N", "M g"),
    cm=Field(3, "m", "centre of mass, body axes"),
)
GRAVITY = layout("gravity gradient block", kind=1, orbit=Field(0, "", "the orbit's kernel_data()"))
SUM = layout(
    "sum of models parameters",
    **_MODEL_HEAD,
    nterms=Field(1, "", "number of terms"),
    offsets=Field(0, "", "the terms' block offsets (n), then the blocks"),
)

# Heavy top: block [kind, weight M g, centre of mass (3, body axes)].
# Gravity gradient: block [kind, the orbit's kernel_data()] (orbit._state_kernels layout: a type
# code, μ, the valid span, then Kepler / secular-J2 elements or a Hermite table), read only
# through the dispatcher orbit_radial, so every orbit source runs in the same cached kernels.
# Magnetic dipole, eddy currents, drag, solar radiation: blocks with tables of the environment
# along the orbit, laid out and interpolated in attitude._core.environment.

ZERO3 = (0.0, 0.0, 0.0)

# The built-in kernels never allocate, keep or return arrays: they are compiled without numba's
# reference counting (``_nrt=False``), so the array views they take (a model's block of
# ``params``, an orbit's kernel data) cost nothing. With it, the atomic reference-count updates
# of such views took ~40 % of a gravity-gradient DOP853 run (perf, issue 17).


@jit(_nrt=False)
def heavy_top_torque(q, w, t, params, base=MODEL.KIND):
    # Gravity -weight s3 acts at the centre of mass c: τ_B = c × F_B, F_B = q̃∘(−W s3)∘q.
    w = params[base + HEAVY_TOP.WEIGHT]
    c = (
        params[base + HEAVY_TOP.CM],
        params[base + HEAVY_TOP.CM + 1],
        params[base + HEAVY_TOP.CM + 2],
    )
    fb = rotate_inverse(q, (0.0, 0.0, -w))
    return cross(c, fb)


@jit(_nrt=False)
def heavy_top_potential(q, t, params, base=MODEL.KIND):
    # V = W (q∘c∘q̃)·s3: the potential energy of the weight (height of the centre of mass).
    # Arribas et al. eq. 18 prints U = x^c·F with F = −Mg s3, which is −V; see docs/potentials.md.
    w = params[base + HEAVY_TOP.WEIGHT]
    c = (
        params[base + HEAVY_TOP.CM],
        params[base + HEAVY_TOP.CM + 1],
        params[base + HEAVY_TOP.CM + 2],
    )
    return w * rotate(q, c)[2]


@jit(_nrt=False)
def gravity_gradient_terms(q, t, params, base):
    """(3μ/r³, x̂_B, I x̂_B) for the gravity gradient at time t."""
    d = params[base + GRAVITY.ORBIT :]
    r, ux, uy, uz = orbit_radial(d, t)
    return gravity_gradient_terms_radial(q, r, ux, uy, uz, d[ORBIT_MU], params)


@jit(_nrt=False)
def gravity_gradient_terms_radial(q, r, ux, uy, uz, mu, params):
    """:func:`gravity_gradient_terms` from the orbit's radius r and radial unit vector."""
    k = 3.0 * mu / (r * r * r)
    xb = rotate_inverse(q, (ux, uy, uz))  # x̂_B = q̃∘x̂_S∘q
    ixb = (params[0] * xb[0], params[1] * xb[1], params[2] * xb[2])
    return k, xb, ixb


@jit(_nrt=False)
def gravity_gradient_potential_radial(q, r, ux, uy, uz, mu, params):
    """:func:`gravity_gradient_potential` from the orbit's radius and radial unit vector (for
    loops that look the orbit up once for many attitudes)."""
    k, xb, ixb = gravity_gradient_terms_radial(q, r, ux, uy, uz, mu, params)
    return 0.5 * k * (xb[0] * ixb[0] + xb[1] * ixb[1] + xb[2] * ixb[2])


@jit(_nrt=False)
def gravity_gradient_torque(q, w, t, params, base=MODEL.KIND):
    # τ_B = 3μ/r³ x̂_B × (I x̂_B): minus the derivative of eq. 20 under body rotations.
    k, xb, ixb = gravity_gradient_terms(q, t, params, base)
    c = cross(xb, ixb)
    return (k * c[0], k * c[1], k * c[2])


@jit(_nrt=False)
def gravity_gradient_potential(q, t, params, base=MODEL.KIND):
    # Arribas et al. eq. 20: U = 3μ/(2r³) x̂_B·I x̂_B (q-independent terms of eq. 19 dropped).
    k, xb, ixb = gravity_gradient_terms(q, t, params, base)
    return 0.5 * k * (xb[0] * ixb[0] + xb[1] * ixb[1] + xb[2] * ixb[2])


@jit(_nrt=False)
def gravity_gradient_potential_at(q, t, params, orb):
    """The gravity gradient alone: its potential energy given its orbit's sample ``orb``
    (``orbit._state_kernels.orbit_sample``: r, r̂ first), bit for bit
    :func:`gravity_gradient_potential`."""
    mu = params[MODEL.DATA + ORBIT_MU]
    return gravity_gradient_potential_radial(q, orb[0], orb[1], orb[2], orb[3], mu, params)


@jit(_nrt=False)
def gravity_gradient_term_torque_at(j, q, w, t, params, orb):
    """The gravity gradient alone: its torque given its orbit's sample ``orb``, bit for bit
    :func:`gravity_gradient_torque`."""
    mu = params[MODEL.DATA + ORBIT_MU]
    k, xb, ixb = gravity_gradient_terms_radial(q, orb[0], orb[1], orb[2], orb[3], mu, params)
    c = cross(xb, ixb)
    return (k * c[0], k * c[1], k * c[2])


@jit(_nrt=False)
def term_torque(q, w, t, params, base):
    """Body-frame torque of the built-in model whose block starts at ``params[base]``."""
    kind = int(params[base])
    if kind == KIND_HEAVY_TOP:
        return heavy_top_torque(q, w, t, params, base)
    if kind == KIND_GRAVITY_GRADIENT:
        return gravity_gradient_torque(q, w, t, params, base)
    if kind == KIND_MAGNETIC_DIPOLE:
        return magnetic_torque(q, t, params, base)
    if kind == KIND_EDDY_CURRENTS:
        return eddy_torque(q, w, t, params, base)
    if kind == KIND_AERODYNAMIC_DRAG:
        return drag_torque(q, t, params, base)
    if kind == KIND_SOLAR_RADIATION:
        return solar_torque(q, t, params, base)
    return ZERO3


@jit(_nrt=False)
def term_potential(q, t, params, base):
    """Potential energy of the built-in model whose block starts at ``params[base]`` (0: none)."""
    kind = int(params[base])
    if kind == KIND_HEAVY_TOP:
        return heavy_top_potential(q, t, params, base)
    if kind == KIND_GRAVITY_GRADIENT:
        return gravity_gradient_potential(q, t, params, base)
    if kind == KIND_MAGNETIC_DIPOLE:
        return magnetic_potential(q, t, params, base)
    return 0.0


@jit(inline="always")
def builtin_exerts_torque(params):
    """Whether the built-in model (or sum) may exert a torque: all but the torque-free model
    alone (a closed loop's driver, compiled for every model, skips its call)."""
    return params[MODEL.KIND] != KIND_TORQUE_FREE


@jit(_nrt=False)
def builtin_n_terms(params):
    """Number of terms of the built-in part of a model (0 for a user-only model)."""
    kind = int(params[MODEL.KIND])
    if kind == KIND_SUM:
        return int(params[SUM.NTERMS])
    if kind == KIND_USER:
        return 0
    return 1


@jit(_nrt=False)
def term_base(j, params):
    """Offset of the block of term ``j``."""
    if int(params[MODEL.KIND]) == KIND_SUM:
        return int(params[SUM.OFFSETS + j])
    return MODEL.KIND


@jit(_nrt=False)
def builtin_torque(q, w, t, params):
    """Body-frame torque of the built-in model (or sum) described by ``params``."""
    if int(params[MODEL.KIND]) != KIND_SUM:
        # int(): an int64 base, as in the sum below (a literal 3 would compile the switch twice)
        return term_torque(q, w, t, params, int(MODEL.KIND))
    tau = term_torque(q, w, t, params, int(params[SUM.OFFSETS]))
    for j in range(1, int(params[SUM.NTERMS])):
        d = term_torque(q, w, t, params, int(params[SUM.OFFSETS + j]))
        tau = (tau[0] + d[0], tau[1] + d[1], tau[2] + d[2])
    return tau


@jit(_nrt=False)
def builtin_potential(q, t, params):
    """Potential energy of the built-in model (or sum) described by ``params``."""
    if int(params[MODEL.KIND]) != KIND_SUM:
        return term_potential(q, t, params, int(MODEL.KIND))
    u = term_potential(q, t, params, int(params[SUM.OFFSETS]))
    for j in range(1, int(params[SUM.NTERMS])):
        u += term_potential(q, t, params, int(params[SUM.OFFSETS + j]))
    return u


@jit(_nrt=False)
def builtin_term_torque(j, q, w, t, params):
    """Torque of term ``j`` of the built-in part (the model itself when it is not a sum)."""
    return term_torque(q, w, t, params, term_base(j, params))


# One model alone ------------------------------------------------------------------------------
# The model of a single built-in term (not a sum): its kind's kernels called directly (their
# ``base`` defaults to the block of a single model), for the entry points compiled for that
# model alone (attitude._core.models binds them as the ``torque``/``potential``/``term_torque``/
# ``n_terms`` of attitude._core.entry_points). The gravity gradient's are further specialised
# there to the orbit (``orbit_radial`` bound to its type's kernel).


@jit
def torque_free_torque(q, w, t, params):
    """No torque (the free rigid body)."""
    return ZERO3


@jit
def torque_free_potential(q, t, params):
    """No potential energy."""
    return 0.0


MODEL_TORQUE = torque_free_torque  # bound to the model's torque by attitude._core.models


# The environment models alone: their kernels take the block offset; a single model's block is
# at MODEL.KIND, passed as int(_BASE) (an int64 like the sums' offsets, so the kernel compiles once
# for both: the global itself is typed as the literal 3, which compiled it a second time).
_BASE = MODEL.KIND


@jit(_nrt=False)
def magnetic_model_torque(q, w, t, params):
    """A magnetic dipole alone: its torque."""
    return magnetic_torque(q, t, params, int(_BASE))


@jit(_nrt=False)
def magnetic_model_potential(q, t, params):
    """A magnetic dipole alone: its potential energy −m·B."""
    return magnetic_potential(q, t, params, int(_BASE))


@jit(_nrt=False)
def eddy_model_torque(q, w, t, params):
    """Eddy currents alone: their torque."""
    return eddy_torque(q, w, t, params, int(_BASE))


@jit(_nrt=False)
def drag_model_torque(q, w, t, params):
    """Aerodynamic drag alone: its torque."""
    return drag_torque(q, t, params, int(_BASE))


@jit(_nrt=False)
def solar_model_torque(q, w, t, params):
    """Solar radiation alone: its torque."""
    return solar_torque(q, t, params, int(_BASE))


@jit
def model_term_torque(j, q, w, t, params):
    """Term j of a model that is one term: its torque."""
    return MODEL_TORQUE(q, w, t, params)


@jit
def model_n_terms(params):
    """A model alone is one term."""
    return 1


# User models ----------------------------------------------------------------------------------
# The bodies of the user kernels of attitude._user_kernels (CustomTorque, CustomPotential).
# A CustomTorque with an orbit reads the environment from a block of its own in ``params``
# (attitude._core.environment.environment_vector), one per user term that reads it. Their
# offsets, in the order of the terms, then the blocks, sit where the built-in kernels never
# look: at MODEL.DATA in a model of user terms only (kind KIND_USER), right after the term
# offsets in a sum (params[SUM.OFFSETS + n + e] is the offset of the e-th; the built-in blocks
# follow them, found through their own offsets). The end of ``params`` stays free for the
# formulations' scratch (attitude._core.formulations).


@jit(_nrt=False)
def user_env_base(params, e):
    """Offset of the environment block of the ``e``-th user term that reads the environment."""
    if int(params[MODEL.KIND]) == KIND_SUM:
        return int(params[SUM.OFFSETS + int(params[SUM.NTERMS]) + e])
    return int(params[MODEL.DATA + e])


#: Complex-step size: derivatives are exact to round-off for any h this small
#: (Squire & Trapp, SIAM Rev. 40, 110, 1998): Im U(q + i h e_k) / h = ∂U/∂q_k + O(h²).
COMPLEX_STEP = 1e-30


@jit_generic
def user_torque(tau_fn, q, w, t):
    """A user's ``tau(q, t)`` (tuple or array) as a 3-tuple of floats."""
    tau = tau_fn(q, t)
    return (float(tau[0]), float(tau[1]), float(tau[2]))


@jit_generic
def user_torque_rates(tau_fn, q, w, t):
    """A user's rate-dependent ``tau(q, omega, t)``; ``omega`` a length-3 array (body axes)."""
    tau = tau_fn(q, np.array((w[0], w[1], w[2])), t)
    return (float(tau[0]), float(tau[1]), float(tau[2]))


@jit_generic
def user_torque_env(tau_fn, q, w, t, params, e):
    """A user's ``tau(q, t, env)``: ``env`` the environment at t (:func:`environment_vector`
    on the block of the ``e``-th user term reading it), a 1-D array of ENV.SIZE floats."""
    env = np.empty(ENV.SIZE)
    environment_vector(q, t, params, user_env_base(params, e), env)
    tau = tau_fn(q, t, env)
    return (float(tau[0]), float(tau[1]), float(tau[2]))


@jit_generic
def user_torque_rates_env(tau_fn, q, w, t, params, e):
    """A user's ``tau(q, omega, t, env)`` (:func:`user_torque_rates` with the environment)."""
    env = np.empty(ENV.SIZE)
    environment_vector(q, t, params, user_env_base(params, e), env)
    tau = tau_fn(q, np.array((w[0], w[1], w[2])), t, env)
    return (float(tau[0]), float(tau[1]), float(tau[2]))


@jit_generic
def complex_step_torque(potential_fn, q, w, t):
    """τ_B = −½ vec(q̃∘∇U) of a user's ``U(q, t)``, ∇U by complex steps (exact to round-off).

    The generalised force 2 q∘(0, τ_B) (Schwab eq. 25) is then minus the tangential part of
    ∇U; a radial part (U not homogeneous of degree 0 in q) drops out.
    """
    h = COMPLEX_STEP
    qc = np.empty(4, dtype=np.complex128)
    grad = np.empty(4)
    for i in range(4):
        for j in range(4):
            qc[j] = q[j]
        qc[i] = q[i] + 1j * h
        grad[i] = potential_fn(qc, t).imag / h
    v = conj_mul(q, grad)
    return (-0.5 * v[1], -0.5 * v[2], -0.5 * v[3])

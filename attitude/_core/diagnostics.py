"""The per-sample variables of a result Dataset, in one compiled pass over the samples.

For the canonical states ``y`` (m, 8) at the times ``t`` one loop writes everything
``propagate`` returns per sample: the states, ω, g, G, the energy, the potential energy, the
norm and constraint errors (:func:`attitude._core.dynamics.diagnostic_values`), the orbit's
radius, true anomaly and orbital-frame quaternion, and the torque of every term of the model
and their sum. The orbit is looked up once per sample (one solve of Kepler's equation for a
Kepler orbit, shared with the gravity gradient alone); before, four separate passes over the
samples and three over the orbit solved it five times.

Every value is the one the separate kernels give, bit for bit (the same operations in the same
order): ``tests/test_results_fast.py`` compares them with the previous path.

Layout
------
``out`` is one flat float64 buffer of ``m * (SAMPLE.SIZE + 3 (n_terms + 1))`` values, a
contiguous C-ordered block per variable, in this order (block offsets are ``m`` times the
offsets of the SAMPLE layout):

=================  =========  ============================================
block              per sample
=================  =========  ============================================
``q``              4          attitude quaternion
``Q``              4          conjugate momenta
``omega``          3          body angular velocity
``g``              3          body angular momentum
``G``              3          space angular momentum
``energy``         1          T + U
``potential_energy`` 1        U
``norm_error``     1          |q| − 1
``qQ``             1          q·Q
``r``              1          orbit radius [km]       (with an orbit)
``f``              1          true anomaly [rad]      (with an orbit)
``p``              4          orbital-frame quaternion (with an orbit)
``torque``         3 (n + 1)  each term's body torque, then their sum
=================  =========  ============================================

The orbit blocks are left unwritten without an orbit. The orbital-frame quaternions of an
orbit other than Kepler's are made sign-continuous along the samples of one call (p and −p are
the same rotation), as the orbit's ``frame_quaternion`` method does; the true anomaly of a
tabulated orbit is NaN here (its caller fills it: ``orbit.base.OrbitBase.true_anomaly``).
"""

from __future__ import annotations

from orbit._layout import Field, layout
from orbit._shared_jit import jit, jit_generic
from orbit._state_kernels import TYPE, TYPE_KEPLER

from .dynamics import diagnostic_values

# The blocks of a sample, each stored for all m samples in turn (block offsets in units of
# m), then the torques: 3 (n_terms + 1) per sample.
SAMPLE = layout(
    "diagnostic sample",
    q=Field(4, "", "attitude quaternion"),
    p=Field(4, "", "conjugate momenta Q"),
    omega=Field(3, "rad/s", "body rate"),
    g=Field(3, "", "angular momentum, body axes"),
    gs=Field(3, "", "angular momentum, space axes"),
    energy=1,
    u=Field(1, "", "potential energy"),
    norm=Field(1, "", "| |q| − 1 |"),
    qq=Field(1, "", "q·Q"),
    r=Field(1, "km", "orbit radius"),
    f=Field(1, "rad", "true anomaly"),
    orbit_p=Field(4, "", "the orbit's frame quaternion"),
)

#: (name, offset, width) of the blocks before the torques, by the result's names.
_NAMES = "q Q omega g G energy potential_energy norm_error qQ r f p".split()
BLOCKS = tuple(
    (name, f.offset, f.size) for name, f in zip(_NAMES, SAMPLE.fields.values(), strict=True)
)

ZERO9 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def buffer_size(m: int, n_terms: int) -> int:
    """Length of ``out`` for ``m`` samples of a model of ``n_terms`` terms."""
    return m * (SAMPLE.SIZE + 3 * (n_terms + 1))


@jit
def no_orbit_sample(d, t):
    """The orbit sample of a model without an orbit (never written out)."""
    return ZERO9


@jit_generic
def samples_with(
    potential_at, term_torque_at, orbit_sample, n_terms, t, y, params, od, has_orbit, out, k0, k1
):
    """Samples ``k0 .. k1 − 1`` of the m = ``t.shape[0]`` samples into ``out`` (layout above).

    ``potential_at(q, t, params, orb)`` and ``term_torque_at(j, q, ω, t, params, orb)`` are the
    model's potential and term torques given the orbit sample ``orb`` =
    ``orbit_sample(od, t)`` (:func:`orbit._state_kernels.orbit_sample`; a model may ignore it
    and look its orbit up itself); ``has_orbit`` says whether ``od`` is an orbit.
    """
    m = t.shape[0]
    w3 = 3 * (n_terms + 1)
    o_tq = SAMPLE.SIZE * m
    continuous = has_orbit and int(od[TYPE]) != TYPE_KEPLER
    for k in range(k0, k1):
        tk = t[k]
        orb = ZERO9
        if has_orbit:
            orb = orbit_sample(od, tk)
        qv = y[k, 0:4]
        q = (y[k, 0], y[k, 1], y[k, 2], y[k, 3])
        Q = (y[k, 4], y[k, 5], y[k, 6], y[k, 7])
        U = potential_at(qv, tk, params, orb)
        d = diagnostic_values(q, Q, U, params)
        b = 4 * k
        for i in range(4):
            out[SAMPLE.Q * m + b + i] = q[i]
            out[SAMPLE.P * m + b + i] = Q[i]
        b = 3 * k
        for i in range(3):
            out[SAMPLE.OMEGA * m + b + i] = d[i]
            out[SAMPLE.G * m + b + i] = d[3 + i]
            out[SAMPLE.GS * m + b + i] = d[6 + i]
        out[SAMPLE.ENERGY * m + k] = d[9]
        out[SAMPLE.NORM * m + k] = d[10]
        out[SAMPLE.QQ * m + k] = d[11]
        out[SAMPLE.U * m + k] = d[12]
        # The torque of each term and their sum (as attitude._core.dynamics.term_torques_with).
        om = (d[0], d[1], d[2])
        b = o_tq + w3 * k
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for j in range(n_terms):
            tau = term_torque_at(j, qv, om, tk, params, orb)
            out[b + 3 * j] = tau[0]
            out[b + 3 * j + 1] = tau[1]
            out[b + 3 * j + 2] = tau[2]
            if j == 0:
                s0, s1, s2 = tau[0], tau[1], tau[2]
            else:
                s0 += tau[0]
                s1 += tau[1]
                s2 += tau[2]
        out[b + 3 * n_terms] = s0
        out[b + 3 * n_terms + 1] = s1
        out[b + 3 * n_terms + 2] = s2
        if has_orbit:
            out[SAMPLE.R * m + k] = orb[0]
            out[SAMPLE.F * m + k] = orb[4]
            p0, p1, p2, p3 = orb[5], orb[6], orb[7], orb[8]
            b = SAMPLE.ORBIT_P * m + 4 * k
            if continuous and k > 0:
                # p_k · p_{k−1} < 0 (against the stored, already continuous p_{k−1}): flip.
                if p0 * out[b - 4] + p1 * out[b - 3] + p2 * out[b - 2] + p3 * out[b - 1] < 0.0:
                    p0, p1, p2, p3 = -p0, -p1, -p2, -p3
            out[b] = p0
            out[b + 1] = p1
            out[b + 2] = p2
            out[b + 3] = p3

"""The control laws of the flight software, one kernel each, and their registry.

A law is one class (:mod:`attitude.control`), one kernel here and one line in :data:`LAWS`.
Every kernel has the same arguments, what the tick knows when it runs the law (the program
``fw``, the software's state ``fs``, the spacecraft block ``sc`` and state ``y``, the active
mode's block ``mb``, the time, the measured rate ``om`` and field ``bb``, the attitude error
``qBR`` and its MRP ``sig``, the rate error ``dw``, the reference's rate and acceleration in
body axes ``wRN``, ``dwRN``, and ``still``: a fixed reference), and returns the requested body
torque L and dipole m (N m, A m²). :func:`control_law`, which the tick calls, is generated from
the registry: a branch per law, on the law's code.

The laws (their equations in :mod:`attitude._core.fsw` and in their classes' docstrings):
MRP feedback (Basilisk's ``mrpFeedback``), quaternion feedback (Wie), rate damping and B-dot.
"""

from __future__ import annotations

import math

from orbit._shared_jit import from_source, jit

from .actuators import wheel_momentum_sum
from .fsw_layout import FS, FW, MB
from .quat import cross

__all__ = ["LAWS", "control_law"]

ZERO3 = (0.0, 0.0, 0.0)


@jit(inline="always")
def _mv(fw, o, v0, v1, v2):
    """The 3 × 3 matrix at fw[o:o+9] (row-major) times v."""
    return (
        fw[o] * v0 + fw[o + 1] * v1 + fw[o + 2] * v2,
        fw[o + 3] * v0 + fw[o + 4] * v1 + fw[o + 5] * v2,
        fw[o + 6] * v0 + fw[o + 7] * v1 + fw[o + 8] * v2,
    )


@jit(inline="always")
def _momentum(fw, sc, y, om):
    """The body's angular momentum in body axes as the software models it: I ω + Σ h a (the
    wheels' h from the state: Σ J (a·ω + Ω) a)."""
    hw = wheel_momentum_sum(sc, y)
    Iw = _mv(fw, FW.INERTIA, om[0], om[1], om[2])
    return (Iw[0] + hw[0], Iw[1] + hw[1], Iw[2] + hw[2])


@jit(inline="always")
def mrp_feedback(fw, fs, sc, y, mb, t, om, bb, qBR, sig, dw, wRN, dwRN, still):
    """MRP feedback (Schaub & Junkins Sect. 8.4; Basilisk's ``mrpFeedback``)."""
    I = FW.INERTIA
    K = fw[mb + MB.K]
    P = mb + MB.P
    Ki = fw[mb + MB.KI]
    z = (0.0, 0.0, 0.0)
    prior = fs[FS.PRIOR]
    dt = 0.0 if prior != prior else t - prior
    fs[FS.PRIOR] = t
    if Ki > 0.0:
        lim = fw[mb + MB.ILIM]
        for i in range(3):
            v = fs[FS.INT + i] + K * dt * sig[i]
            if abs(v) > lim:
                v *= lim / abs(v)
            fs[FS.INT + i] = v
        Idw = _mv(fw, I, dw[0], dw[1], dw[2])
        z = (fs[FS.INT] + Idw[0], fs[FS.INT + 1] + Idw[1], fs[FS.INT + 2] + Idw[2])
    Pd = _mv(fw, P, dw[0], dw[1], dw[2])
    lr = (K * sig[0] + Pd[0], K * sig[1] + Pd[1], K * sig[2] + Pd[2])
    law0 = fw[mb + MB.LAWTYPE] == 0.0
    # K_I z and v = ω_r + K_I z (law type 0) are zeros for a fixed reference without an
    # integral term: not computed then (tested against the full law at a fixed attitude).
    if Ki > 0.0 or not still or not law0:
        Kz = (Ki * z[0], Ki * z[1], Ki * z[2])
        PKz = _mv(fw, P, Kz[0], Kz[1], Kz[2])
        lr = (lr[0] + PKz[0], lr[1] + PKz[1], lr[2] + PKz[2])
        if law0:
            v8 = (wRN[0] + Kz[0], wRN[1] + Kz[1], wRN[2] + Kz[2])
        else:
            v8 = om
        c9 = cross(v8, _momentum(fw, sc, y, om))
        lr = (lr[0] - c9[0], lr[1] - c9[1], lr[2] - c9[2])
    if still:
        return (-lr[0], -lr[1], -lr[2]), ZERO3
    c10 = cross(om, wRN)
    ff = _mv(fw, I, c10[0] - dwRN[0], c10[1] - dwRN[1], c10[2] - dwRN[2])
    return (-(lr[0] + ff[0]), -(lr[1] + ff[1]), -(lr[2] + ff[2])), ZERO3


@jit(inline="always")
def quaternion_feedback(fw, fs, sc, y, mb, t, om, bb, qBR, sig, dw, wRN, dwRN, still):
    """Quaternion feedback (Wie, *Space Vehicle Dynamics and Control*, Sect. 7.3)."""
    K = fw[mb + MB.K]
    sgn = 1.0 if qBR[0] >= 0.0 else -1.0
    Cd = _mv(fw, mb + MB.P, dw[0], dw[1], dw[2])
    gy = cross(om, _momentum(fw, sc, y, om))
    c10 = cross(om, wRN)
    ff = _mv(fw, FW.INERTIA, c10[0] - dwRN[0], c10[1] - dwRN[1], c10[2] - dwRN[2])
    L = (
        -K * sgn * qBR[1] - Cd[0] + gy[0] - ff[0],
        -K * sgn * qBR[2] - Cd[1] + gy[1] - ff[1],
        -K * sgn * qBR[3] - Cd[2] + gy[2] - ff[2],
    )
    return L, ZERO3


@jit(inline="always")
def rate_damping(fw, fs, sc, y, mb, t, om, bb, qBR, sig, dw, wRN, dwRN, still):
    """Rate damping: L = −K_d δω."""
    Cd = _mv(fw, mb + MB.P, dw[0], dw[1], dw[2])
    return (-Cd[0], -Cd[1], -Cd[2]), ZERO3


@jit(inline="always")
def bdot(fw, fs, sc, y, mb, t, om, bb, qBR, sig, dw, wRN, dwRN, still):
    """B-dot: m = −k Ḃ (Stickler & Alfriend), or m = −(k/|B|) ḃ (Avanzini & Giulietti), Ḃ from
    this tick's field and the last's."""
    m = ZERO3
    if fs[FS.BVALID] != 0.0:
        K = fw[mb + MB.K]
        per = fw[FW.PERIOD]
        p0, p1, p2 = fs[FS.BPREV], fs[FS.BPREV + 1], fs[FS.BPREV + 2]
        if fw[mb + MB.LAWTYPE] == 0.0:  # m = −k Ḃ
            m = (-K * (bb[0] - p0) / per, -K * (bb[1] - p1) / per, -K * (bb[2] - p2) / per)
        else:  # m = −(k/|B|) ḃ, b = B/|B|
            nb = math.sqrt(bb[0] * bb[0] + bb[1] * bb[1] + bb[2] * bb[2])
            npv = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
            if nb > 0.0 and npv > 0.0:
                c = -K / (nb * per)
                m = (
                    c * (bb[0] / nb - p0 / npv),
                    c * (bb[1] / nb - p1 / npv),
                    c * (bb[2] / nb - p2 / npv),
                )
    return ZERO3, m


#: The registry: (code, name, kernel) of every law; the code is what a mode's block holds
#: (``MB.CTRL``), 0 (no law) excepted, and the class's ``_kind``.
LAWS = (
    (1, "mrp_feedback", mrp_feedback),
    (2, "quaternion_feedback", quaternion_feedback),
    (3, "rate_damping", rate_damping),
    (4, "bdot", bdot),
)

#: Law codes by name (the classes of attitude.control read theirs here).
CODES = {name: code for code, name, _ in LAWS}


def _dispatcher():
    """``control_law(code, ...)``: the law of ``code`` (zero torque and dipole for 0), a branch
    per registered law, generated from :data:`LAWS` (this file: numba's source location)."""
    args = "fw, fs, sc, y, mb, t, om, bb, qBR, sig, dw, wRN, dwRN, still"
    src = [
        f"def control_law(code, {args}):",
        '    """The torque and dipole requested by the law ``code`` (:data:`LAWS`)."""',
    ]
    for code, name, _ in LAWS:
        src.append(f"    if code == {code}:\n        return {name}({args})")
    src.append("    return ZERO3, ZERO3\n")
    ns = {name: kernel for _, name, kernel in LAWS} | {"ZERO3": ZERO3}
    return from_source("\n".join(src), ns, __name__, __file__, inline="always")["control_law"]


control_law = _dispatcher()

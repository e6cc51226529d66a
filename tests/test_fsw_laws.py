"""attitude/_core/fsw_laws.py: one kernel per control law, a registry, a generated dispatch.

Truth: the laws' closed forms on hand-made programs (rate damping L = −P δω; quaternion
feedback at a fixed reference L = −K sgn(q0) q_v − P δω + ω × Iω; B-dot m = −k ΔB/Δt), the
registry against the public classes, and the generated dispatch against each kernel called
directly. The closed-loop tests (test_software.py: Basilisk's scenario to 1e-14) check them in
the compiled tick.
"""

from __future__ import annotations

import numpy as np
import pytest

from attitude import control
from attitude._core import fsw_laws
from attitude._core.fsw_layout import FS, FW, MB
from orbit._shared_jit import interpreted

K = interpreted(fsw_laws)  # the kernels as plain Python: the same statements
MB0 = FW.SIZE + 40  # a mode block after the header and some room


def _program(k=0.3, p=(2.0, 3.0, 4.0), inertia=(5.0, 6.0, 7.0), law_type=0.0):
    fw = np.zeros(MB0 + MB.SIZE + 16)
    fw[FW.PERIOD] = 0.5
    fw[FW.INERTIA : FW.INERTIA + 9] = np.diag(inertia).ravel()
    fw[MB0 + MB.K] = k
    fw[MB0 + MB.P : MB0 + MB.P + 9] = np.diag(p).ravel()
    fw[MB0 + MB.LAWTYPE] = law_type
    fs = np.zeros(FS.SIZE)
    fs[FS.PRIOR] = np.nan
    return fw, fs


SC = np.zeros(64)  # a spacecraft block without wheels (n_w = 0 at its head)
Y = np.zeros(8)
ARGS = dict(t=1.0, om=(0.01, -0.02, 0.03), bb=(2e-5, -1e-5, 3e-5),
            qBR=(0.9, 0.1, -0.3, 0.2), sig=(0.05, -0.15, 0.1), dw=(0.01, -0.02, 0.03),
            wRN=(0.0, 0.0, 0.0), dwRN=(0.0, 0.0, 0.0), still=True)  # fmt: skip


def _call(f, fw, fs, **kw):
    a = {**ARGS, **kw}
    return f(fw, fs, SC, Y, MB0, a["t"], a["om"], a["bb"], a["qBR"], a["sig"], a["dw"],
             a["wRN"], a["dwRN"], a["still"])  # fmt: skip


def test_registry_matches_the_classes():
    codes = [c for c, _, _ in fsw_laws.LAWS]
    assert len(set(codes)) == len(codes) and 0 not in codes
    by_class = {
        control.MRPFeedback: "mrp_feedback",
        control.QuaternionFeedback: "quaternion_feedback",
        control.RateDamping: "rate_damping",
        control.BDot: "bdot",
    }
    for cls, name in by_class.items():
        assert cls._kind == fsw_laws.CODES[name]
    assert set(by_class.values()) == set(fsw_laws.CODES)


@pytest.mark.parametrize("entry", fsw_laws.LAWS, ids=[n for _, n, _ in fsw_laws.LAWS])
def test_dispatch_is_the_law(entry):
    code, name, _ = entry
    fw, fs = _program()
    fs[FS.BVALID] = 1.0
    fs[FS.BPREV : FS.BPREV + 3] = (1e-5, 1e-5, 1e-5)
    fw2, fs2 = fw.copy(), fs.copy()
    direct = _call(getattr(K, name), fw, fs)
    via = K.control_law(code, fw2, fs2, SC, Y, MB0, *ARGS.values())
    assert via == direct and np.array_equal(fs, fs2, equal_nan=True)
    assert K.control_law(0, fw, fs, SC, Y, MB0, *ARGS.values()) == ((0.0,) * 3, (0.0,) * 3)


def test_closed_forms():
    fw, fs = _program()
    dw = np.array(ARGS["dw"])
    L, m = _call(K.rate_damping, fw, fs)
    assert np.allclose(L, -np.array([2.0, 3.0, 4.0]) * dw, rtol=1e-15) and m == (0.0,) * 3

    L, _ = _call(K.quaternion_feedback, fw, fs)
    om = np.array(ARGS["om"])
    q = np.array(ARGS["qBR"])
    expect = -0.3 * q[1:] - np.array([2.0, 3.0, 4.0]) * dw + np.cross(om, [5.0, 6.0, 7.0] * om)
    assert np.allclose(L, expect, rtol=1e-14)

    fs[FS.BVALID] = 1.0
    prev = np.array([1e-5, 2e-5, -1e-5])
    fs[FS.BPREV : FS.BPREV + 3] = prev
    _, m = _call(K.bdot, fw, fs)
    assert np.allclose(m, -0.3 * (np.array(ARGS["bb"]) - prev) / 0.5, rtol=1e-15)
    fs[FS.BVALID] = 0.0  # no previous field yet: no dipole
    assert _call(K.bdot, fw, fs)[1] == (0.0,) * 3

    # MRP feedback at a fixed reference without the integral term (law type 0):
    # L = −(K σ + P δω − ω_r × h) with ω_r = 0
    fw, fs = _program()
    L, _ = _call(K.mrp_feedback, fw, fs)
    expect = -(0.3 * np.array(ARGS["sig"]) + np.array([2.0, 3.0, 4.0]) * dw)
    assert np.allclose(L, expect, rtol=1e-15) and fs[FS.PRIOR] == 1.0

"""Speed of the exact torque-free motion (attitude.exact / attitude._core.exact).

Prints the cost of one compiled free-flow step (the kernel the splitting integrators call), of
one output time of ``torque_free``, and ratios against baselines run in the same process:

* a compiled classical RK4 step of the same equations (q̇ = ½ q∘(0, ω), ġ = g × ω), the
  cheapest explicit step one could use instead (and which is not exact);
* scipy's DOP853 (rtol 1e-13) integrating the same motion to t = 100, per output time.

Run: ``python benchmarks/exact.py``.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from attitude._core.exact import free_flow
from attitude._core.quat import mul, mul_vec
from attitude.exact import torque_free
from orbit._shared_jit import jit


@jit
def _flow_loop(I1, I2, I3, q, Q, h, n):
    qq = (q[0], q[1], q[2], q[3])
    QQ = (Q[0], Q[1], Q[2], Q[3])
    for _ in range(n):
        qq, QQ = free_flow(I1, I2, I3, qq, QQ, h)
    return qq, QQ


@jit
def _rhs(I1, I2, I3, q, g):
    w = (g[0] / I1, g[1] / I2, g[2] / I3)
    dq = mul_vec(q, w)
    dg = (g[1] * w[2] - g[2] * w[1], g[2] * w[0] - g[0] * w[2], g[0] * w[1] - g[1] * w[0])
    return (0.5 * dq[0], 0.5 * dq[1], 0.5 * dq[2], 0.5 * dq[3]), dg


@jit
def _rk4_loop(I1, I2, I3, q, g, h, n):
    qq = (q[0], q[1], q[2], q[3])
    gg = (g[0], g[1], g[2])
    for _ in range(n):
        k1q, k1g = _rhs(I1, I2, I3, qq, gg)
        q2 = (
            qq[0] + 0.5 * h * k1q[0],
            qq[1] + 0.5 * h * k1q[1],
            qq[2] + 0.5 * h * k1q[2],
            qq[3] + 0.5 * h * k1q[3],
        )
        g2 = (gg[0] + 0.5 * h * k1g[0], gg[1] + 0.5 * h * k1g[1], gg[2] + 0.5 * h * k1g[2])
        k2q, k2g = _rhs(I1, I2, I3, q2, g2)
        q3 = (
            qq[0] + 0.5 * h * k2q[0],
            qq[1] + 0.5 * h * k2q[1],
            qq[2] + 0.5 * h * k2q[2],
            qq[3] + 0.5 * h * k2q[3],
        )
        g3 = (gg[0] + 0.5 * h * k2g[0], gg[1] + 0.5 * h * k2g[1], gg[2] + 0.5 * h * k2g[2])
        k3q, k3g = _rhs(I1, I2, I3, q3, g3)
        q4 = (qq[0] + h * k3q[0], qq[1] + h * k3q[1], qq[2] + h * k3q[2], qq[3] + h * k3q[3])
        g4 = (gg[0] + h * k3g[0], gg[1] + h * k3g[1], gg[2] + h * k3g[2])
        k4q, k4g = _rhs(I1, I2, I3, q4, g4)
        c = h / 6.0
        qq = (
            qq[0] + c * (k1q[0] + 2 * k2q[0] + 2 * k3q[0] + k4q[0]),
            qq[1] + c * (k1q[1] + 2 * k2q[1] + 2 * k3q[1] + k4q[1]),
            qq[2] + c * (k1q[2] + 2 * k2q[2] + 2 * k3q[2] + k4q[2]),
            qq[3] + c * (k1q[3] + 2 * k2q[3] + 2 * k3q[3] + k4q[3]),
        )
        gg = (
            gg[0] + c * (k1g[0] + 2 * k2g[0] + 2 * k3g[0] + k4g[0]),
            gg[1] + c * (k1g[1] + 2 * k2g[1] + 2 * k3g[1] + k4g[1]),
            gg[2] + c * (k1g[2] + 2 * k2g[2] + 2 * k3g[2] + k4g[2]),
        )
    return qq, gg


def _best(f, repeat=5):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    cases = {
        "generic (1, 2, 3)": ((1.0, 2.0, 3.0), (0.3, 0.2, 0.9)),
        "near separatrix 1e-8": ((3.0, 3.75, 5.0), (1.0 - 1e-8, 0.3, 1.0)),
        "axisymmetric": ((1.0, 1.0, 2.0), (0.3, 0.2, 0.9)),
    }
    q = np.array([0.5, 0.5, -0.5, 0.5])
    n = 200_000
    h = 0.05
    print(
        f"{'case':24s} {'free_flow us':>13s} {'RK4 step us':>12s} {'ratio':>6s}"
        f" {'torque_free us/t':>17s} {'DOP853 us/t':>12s} {'ratio':>7s}"
    )
    for name, (inertia, g) in cases.items():
        g = np.array(g)
        Q = 2 * np.array(mul(q, (0.0, *g)))
        _flow_loop(*inertia, q, Q, h, 10)
        _rk4_loop(*inertia, q, g, h, 10)
        t_flow = _best(lambda: _flow_loop(*inertia, q, Q, h, n)) / n  # noqa: B023
        t_rk4 = _best(lambda: _rk4_loop(*inertia, q, g, h, n)) / n  # noqa: B023
        ts = np.linspace(0.0, 100.0, 10_001)
        torque_free(inertia, q, Q, ts[:2])
        t_exact = _best(lambda: torque_free(inertia, q, Q, ts)) / ts.size  # noqa: B023

        def dop853(inertia=inertia, g=g, ts=ts):
            inv = 1.0 / np.asarray(inertia)

            def rhs(t, y):
                w = y[4:] * inv
                dq = np.array(mul_vec(y[:4], w)) * 0.5
                return np.concatenate([dq, np.cross(y[4:], w)])

            solve_ivp(rhs, (0, ts[-1]), np.r_[q, g], "DOP853", t_eval=ts, rtol=1e-13, atol=1e-15)

        t_dop = _best(dop853, repeat=1) / ts.size
        print(
            f"{name:24s} {t_flow * 1e6:13.3f} {t_rk4 * 1e6:12.3f} {t_flow / t_rk4:6.1f}"
            f" {t_exact * 1e6:17.3f} {t_dop * 1e6:12.1f} {t_dop / t_exact:7.0f}"
        )


if __name__ == "__main__":
    main()

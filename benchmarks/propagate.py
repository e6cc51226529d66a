"""Benchmark of the compiled canonical propagator (issue: canonical quaternion propagator).

For the paper's torque-free and heavy-top cases (Arribas et al. Sect. 6.1) over t in [0, 1000]:
wall time, steps and energy error of ``method="dop853"`` at rtol 1e-12, and the speed ratio
against ``scipy.integrate.solve_ivp(method="DOP853")`` on the same equations with a plain
Python (numpy) right-hand side at the same tolerances, measured in this process. Then the
time of the first ``propagate`` call in a fresh process, with the numba cache warm and cold.

Run: ``python benchmarks/propagate.py``
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.integrate import solve_ivp

from attitude.canonical import project_state
from attitude.potentials import HeavyTop, TorqueFree
from attitude.propagate import propagate

INERTIA = np.array([1.25, 1.0, 0.75])
RTOL, ATOL = 1e-12, 1e-14
T_END = 1000.0


def qmul(a, b):
    return np.array(
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    )


def python_rhs(weight, com):
    """Eq. 7 with the heavy-top torque, in plain numpy: the baseline."""
    conj = np.array([1.0, -1.0, -1.0, -1.0])

    def f(t, y):
        q, Q = y[:4], y[4:]
        w = qmul(q * conj, Q)
        om = np.array([0.0, *(0.5 * w[1:] / INERTIA)])
        fb = qmul(qmul(q * conj, np.array([0.0, 0.0, 0.0, -weight])), q)[1:]
        tau = np.array([0.0, *np.cross(com, fb)])
        return np.concatenate([0.5 * qmul(q, om), 0.5 * qmul(Q, om) + 2.0 * qmul(q, tau)])

    return f


def best_of(fn, n=3):
    best = np.inf
    out = None
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


FIRST_CALL = """
import time, numpy as np
t0 = time.perf_counter()
from attitude.propagate import propagate
from attitude.potentials import HeavyTop
t1 = time.perf_counter()
propagate([1.25, 1.0, 0.75], [0.5, -0.5**0.5, 0.0, 0.5], [0.3, -0.848528, 0.141421, -1.5],
          np.linspace(0.0, 10.0, 11), potential=HeavyTop(0.5, [1, 0, 0]))
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def first_call(env):
    out = subprocess.run(
        [sys.executable, "-W", "ignore", "-c", FIRST_CALL],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return float(out[0]), float(out[1])


def main() -> None:
    q0, Q0, _ = project_state([0.5, -(0.5**0.5), 0.0, 0.5], [0.3, -0.848528, 0.141421, -1.5])
    t = np.array([0.0, T_END])
    cases = [
        ("torque-free", TorqueFree(), 0.0, np.zeros(3)),
        ("heavy top", HeavyTop(0.5, [1.0, 0.0, 0.0]), 0.5, np.array([1.0, 0.0, 0.0])),
    ]
    propagate(INERTIA, q0, Q0, t, potential=cases[1][1])  # compile / load the cache
    print(f"paper cases, t in [0, {T_END:g}], rtol={RTOL:g}, atol={ATOL:g}")
    header = (
        f"{'case':12s} {'ours [s]':>10s} {'steps':>8s} {'|dE|/|U|max':>12s} "
        f"{'scipy [s]':>10s} {'steps':>8s} {'ratio':>8s} {'max |dq|':>10s}"
    )
    print(header)
    for name, pot, weight, com in cases:
        dt_ours, ds = best_of(
            lambda pot=pot: propagate(INERTIA, q0, Q0, t, potential=pot, rtol=RTOL, atol=ATOL)
        )
        dense = propagate(
            INERTIA, q0, Q0, np.linspace(0, T_END, 2001), potential=pot, rtol=RTOL, atol=ATOL
        )
        e = dense.energy.values
        scale = max(np.max(np.abs(dense.potential_energy.values)), abs(e[0]))
        de = np.max(np.abs(e - e[0])) / scale
        f = python_rhs(weight, com)
        dt_sp, sol = best_of(
            lambda f=f: solve_ivp(
                f, (0.0, T_END), np.concatenate([q0, Q0]), method="DOP853", rtol=RTOL, atol=ATOL
            ),
            n=1,
        )
        dq = np.max(np.abs(sol.y[:4, -1] - ds.q.values[-1]))
        print(
            f"{name:12s} {dt_ours:10.4f} {ds.attrs['n_steps']:8d} {de:12.2e} "
            f"{dt_sp:10.3f} {sol.t.size - 1:8d} {dt_sp / dt_ours:8.0f} {dq:10.2e}"
        )
    print()
    warm = first_call(dict(os.environ))
    with tempfile.TemporaryDirectory() as tmp:
        cold = first_call({**os.environ, "ATTITUDE_CACHE_DIR": tmp})
    print("fresh process: import [s], first propagate call [s]")
    print(f"  warm numba cache: import {warm[0]:.2f}  first call {warm[1]:.2f}")
    print(f"  cold numba cache: import {cold[0]:.2f}  first call {cold[1]:.2f}")


if __name__ == "__main__":
    main()

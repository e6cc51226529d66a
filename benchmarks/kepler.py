"""Kepler-solver speed: ns per solve, ours against a plain vectorised Newton iteration in numpy.

Usage::

    python benchmarks/kepler.py [--n 1000000] [--repeat 5] [--seed 0]

Both solvers run in this process on the same 10⁶ random (M, e), M uniform in [−π, π) (reduced
anyway), e uniform in [0, 0.99]. The baseline is the textbook vectorised Newton iteration
(start E = M + e sin M... see ``newton_numpy``) run until every |ΔE| < 1e-14, in-place numpy
operations. Timings are the best of ``--repeat`` runs after a warm-up call (numba compilation is
excluded; it is cached on disk after the first run). The accuracy of both results is printed
too (max residual |E − e sin E − M| in float arithmetic) so the comparison is like for like.

Also printed: the cost of the scalar kernels inside compiled code (what a right-hand side pays
per call): ``kepler_E`` and ``radius_and_frame`` in a jitted loop.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from orbit import _kernels as K
from orbit._shared_jit import jit
from orbit.kepler import solve_kepler


def newton_numpy(M: np.ndarray, e: np.ndarray, tol: float = 1e-14) -> tuple[np.ndarray, int]:
    """Plain vectorised Newton: E <- E − (E − e sin E − M)/(1 − e cos E), from E = M + e sin M
    (π-ward start for e > 0.8), until every step is below ``tol``. Returns (E, iterations)."""
    E = M + e * np.sin(M)
    hi = e > 0.8
    E[hi] = np.where(M[hi] >= 0, np.pi, -np.pi)
    d = np.empty_like(E)
    tmp = np.empty_like(E)
    for it in range(1, 100):
        np.sin(E, out=d)
        d *= e
        np.subtract(E, d, out=d)
        d -= M  # f = E − e sin E − M
        np.cos(E, out=tmp)
        tmp *= e
        np.subtract(1.0, tmp, out=tmp)  # f' = 1 − e cos E
        d /= tmp
        E -= d
        if np.max(np.abs(d)) < tol:
            return E, it
    return E, 99


@jit
def _scalar_kepler_loop(M, e):
    acc = 0.0
    for i in range(M.size):
        acc += K.kepler_E(M[i], e[i])
    return acc


@jit
def _frame_loop(el, t):
    acc = 0.0
    for i in range(t.size):
        r, p0, p1, p2, p3 = K.radius_and_frame(el, t[i])
        acc += r + p0 + p1 + p2 + p3
    return acc


def best_of(fn, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def max_residual(E: np.ndarray, M: np.ndarray, e: np.ndarray) -> float:
    return float(np.max(np.abs(E - e * np.sin(E) - M)))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    rng = np.random.default_rng(args.seed)
    n = args.n
    M = rng.uniform(-np.pi, np.pi, n)
    e = rng.uniform(0.0, 0.99, n)

    # warm-up (compiles or loads the numba cache)
    solve_kepler(M[:10], e[:10])
    out = np.empty(n)
    K.kepler_E_loop(M[:10], e[:10], out[:10])
    _scalar_kepler_loop(M[:10], e[:10])
    el = np.array([7000.0, 0.2, np.pi / 6, np.pi / 4, np.pi / 12, 0.0, 0.0, 398600.4, 0.0])
    el[K.N] = np.sqrt(el[K.MU] / el[K.A] ** 3)
    tt = np.linspace(0.0, 1e5, n)
    _frame_loop(el, tt[:10])

    t_public = best_of(lambda: solve_kepler(M, e), args.repeat)
    t_loop = best_of(lambda: K.kepler_E_loop(M, e, out), args.repeat)
    t_scalar = best_of(lambda: _scalar_kepler_loop(M, e), args.repeat)
    t_frame = best_of(lambda: _frame_loop(el, tt), args.repeat)
    t_newton = best_of(lambda: newton_numpy(M, e), args.repeat)

    E_ours = solve_kepler(M, e)
    E_newt, iters = newton_numpy(M, e)

    ns = 1e9 / n
    print(f"Kepler's equation, {n} random (M, e), e in [0, 0.99]; best of {args.repeat}")
    print(f"  orbit.solve_kepler (public, validated)   {t_public * ns:8.1f} ns/solve")
    print(f"  compiled loop over kepler_E (no checks)  {t_loop * ns:8.1f} ns/solve")
    print(f"  kepler_E scalar kernel in a jitted loop  {t_scalar * ns:8.1f} ns/solve")
    print(f"  numpy vectorised Newton ({iters} iterations)   {t_newton * ns:8.1f} ns/solve")
    print(f"  ratio numpy Newton / solve_kepler        {t_newton / t_public:8.1f} x")
    print(
        f"  max |E - e sin E - M|: ours {max_residual(E_ours, M, e):.2e}, "
        f"Newton {max_residual(E_newt, M, e):.2e}; max |E_ours - E_newton| "
        f"{np.max(np.abs(E_ours - E_newt)):.2e}"
    )
    print(f"  radius_and_frame(el, t) per call (jitted loop, e = 0.2): {t_frame * ns:6.1f} ns")


if __name__ == "__main__":
    main()

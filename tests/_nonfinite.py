"""Non-finite and overflowing states and torques, run in a child process with a deadline.

``python tests/_nonfinite.py <integrator>...`` runs the cases of each integrator in turn (one
process: one import) and prints one JSON line per case, ``{"integrator": ..., "case": ...,
"outcome": ...}``, flushing a ``{"integrator": ..., "start": case}`` line first: a
case that never returns (a compiled loop spinning on NaN) is named by the parent
(tests/test_reliability.py::test_nonfinite_inputs_end_cleanly), which kills the child at its
deadline and fails, instead of hanging the suite.

Outcomes: ``refused`` (an ``attitude``/``orbit`` error before or during the setup),
``failed`` (a PropagationError), ``ok`` (a normal return with finite results), ``nonfinite``
(a normal return with NaN or inf in the results: silent), ``status <code>`` (a compiled kernel
called directly: its status), ``raw <type>: <message>`` (any other exception).
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import attitude
from attitude.errors import AttitudeError, PropagationError
from orbit.errors import OrbitError

I = [1.25, 1.0, 0.75]
Q_UNIT = [1.0, 0.0, 0.0, 0.0]
Q0 = [0.0, 0.3, 0.2, 0.1]
T = [0.0, 0.5, 1.0]

#: Public-API cases: (name, q0, Q0, potential). States with NaN or inf are refused; a state
#: whose energy overflows (1e160) is refused; 1e150 has a finite energy and overflowing
#: derivatives; the heavy tops' torques overflow the state at once.
STATE_CASES = [
    ("nan momenta", Q_UNIT, [0.0, math.nan, 0.0, 0.0], None),
    ("inf attitude", [math.inf, 0.0, 0.0, 0.0], Q0, None),
    ("energy overflows", Q_UNIT, [0.0, 1e160, 1e158, 0.0], None),
    ("derivatives overflow", Q_UNIT, [0.0, 1e150, 1e148, 0.0], None),
]


def _torque_cases():
    return [
        ("torque 1e300", Q_UNIT, Q0, attitude.HeavyTop(1e300, [1.0, 0.0, 1.0])),
        ("torque 1e308", Q_UNIT, Q0, attitude.HeavyTop(1e308, [1.0, 0.0, 0.0])),
    ]


def _outcome(f) -> str:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = f()
    except PropagationError:
        return "failed"
    except (AttitudeError, OrbitError):
        return "refused"
    except Exception as exc:
        return f"raw {type(exc).__name__}: {exc}"
    if isinstance(r, (int, np.integer)):
        return f"status {int(r)}"
    values = [  # (detector_first_time is NaN for an event that did not occur)
        v.values for k, v in r.data_vars.items() if v.dtype.kind == "f" and "first" not in k
    ]
    if all(np.isfinite(v).all() for v in values):
        return "ok"
    return "nonfinite"


_CURRENT = [""]  # the integrator whose cases run


def _emit(case: str, outcome: str) -> None:
    print(json.dumps({"integrator": _CURRENT[0], "case": case, "outcome": outcome}), flush=True)


def _run(case: str, f) -> None:
    print(json.dumps({"integrator": _CURRENT[0], "start": case}), flush=True)
    _emit(case, _outcome(f))


def public(method: str, **kw) -> None:
    """``propagate`` with bad states and overflowing torques."""
    cases = STATE_CASES + ([] if method == "exact" else _torque_cases())
    for name, q0, Q, pot in cases:
        _run(name, lambda q0=q0, Q=Q, pot=pot: attitude.propagate(
            I, q0, Q, T, potential=pot, method=method, **kw
        ))  # fmt: skip


def _heavy_params(weight: float):
    """(entry points, params) of a heavy top whose weight is ``weight`` (NaN, inf: a
    non-finite torque, which the public API refuses at the initial state)."""
    pot = attitude.HeavyTop(0.5, [1.0, 0.0, 1.0]).bind(attitude.RigidBody(I))
    p = pot._params(np.array(I))
    assert p[4] == 0.5
    p[4] = weight
    return pot._entry_points(), p


_KERNEL_STATES = [
    ("kernel: torque NaN", math.nan, Q0),
    ("kernel: torque inf", math.inf, Q0),
    ("kernel: state overflows", 0.5, [0.0, 1e160, 1e158, 0.0]),
    ("kernel: state NaN", 0.5, [0.0, math.nan, 0.0, 0.0]),
    ("kernel: state inf", 0.5, [0.0, math.inf, 0.0, 0.0]),
]


def kernel_dop853() -> None:
    """The compiled DOP853 driver called directly: the non-finite torque and state the public
    API refuses (a NaN first derivative gave a NaN step size: the rejection loop spun)."""
    from orbit import _rk as rk

    for name, weight, Q in _KERNEL_STATES:
        entry, p = _heavy_params(weight)
        y0 = np.array([*Q_UNIT, *Q], dtype=np.float64)
        t = np.array(T)

        def call(entry=entry, p=p, y0=y0, t=t):
            work, tstate, counters = rk.new_state(8)
            st, _ = entry.dop853_canonical(
                p, y0, 0.0, t, np.empty((3, 8)), work, tstate, counters, 1e-10, 1e-12, 1.0,
                math.inf, 10**6,
            )  # fmt: skip
            return st

        _run(name, call)


def kernel_taylor() -> None:
    from attitude._core import taylor as kt

    for name, weight, Q in _KERNEL_STATES:
        _, p = _heavy_params(weight)
        y0 = np.array([*Q_UNIT, *Q], dtype=np.float64)

        def call(p=p, y0=y0):
            work, tstate, counters = kt.new_state()
            st, _ = kt.taylor_canonical_builtin(
                p, y0, 0.0, np.array(T), np.empty((3, 8)), work, tstate, counters, 1e-10,
                1e-12, 1.0, math.inf, 10**6,
            )  # fmt: skip
            return st

        _run(name, call)


def kernel_composition(name_: str) -> None:
    from attitude._core import splitting as ks

    kinds, coefs, toffs = ks.method_tables(name_, 4)
    for name, weight, Q in _KERNEL_STATES:
        entry, p = _heavy_params(weight)
        y0 = np.array([*Q_UNIT, *Q], dtype=np.float64)

        def call(entry=entry, p=p, y0=y0):
            state = np.empty(8)
            ks.canonical_to_state(y0, state)
            counters = np.zeros(ks.N_COUNTERS, dtype=np.int64)
            # one output time 1e5 steps away: the state is checked at every step, not only
            # at the output times (a finite state, 1e160, runs on: propagate refuses it)
            st, _ = entry.composition(
                p, kinds, coefs, toffs, state, 0.0, np.array([100.0]), 1e-3, np.empty((1, 8)),
                counters,
            )  # fmt: skip
            assert st == ks.SUCCESS or counters[0] <= 2, counters  # stopped at the first step
            return st

        _run(name, call)


def events_public(method: str, **kw) -> None:
    ev = [attitude.events.RateExceeds(0.5), attitude.events.RateExceeds(5.0, terminal=True)]
    for name, q0, Q, pot in STATE_CASES + _torque_cases():
        _run(
            name,
            lambda q0=q0, Q=Q, pot=pot: attitude.propagate(
                I, q0, Q, T, potential=pot, method=method, events=ev, **kw
            ),
        )


def ensemble(method: str, events: bool = False) -> None:
    """Members with overflowing states and torques beside good ones: the bad ones fail, the
    others finish (the PropagationError names the failed members)."""
    q0 = np.tile(Q_UNIT, (4, 1))
    Q = np.array([Q0, [0.0, 1e160, 1e158, 0.0], [0.0, 1e150, 1e148, 0.0], Q0])
    ev = [attitude.events.RateExceeds(0.5)] if events else None

    def call(Q=Q, pot=None):
        try:
            attitude.propagate_ensemble(I, q0, Q, T, potential=pot, method=method, events=ev)
        except PropagationError as exc:
            ds = exc.partial
            ok = ds.member_status.values == 0
            assert ok[0] and ok[3] and not ok[1] and not ok[2], ds.member_status.values
            assert np.isfinite(ds.q.values[ok]).all()
            raise
        raise AssertionError("no member failed")

    _run("members with overflowing states", call)
    heavy = attitude.HeavyTop(1e300, [1.0, 0.0, 1.0])
    _run(
        "members with an overflowing torque",
        lambda: attitude.propagate_ensemble(
            I, q0, np.tile(Q0, (4, 1)), T, potential=heavy, method=method, events=ev
        ),
    )


INTEGRATORS = {
    "dop853": lambda: (public("dop853"), kernel_dop853()),
    "taylor": lambda: (public("taylor"), kernel_taylor()),
    "exact": lambda: public("exact"),
    "splitting": lambda: (public("splitting", dt=0.01), kernel_composition("splitting")),
    "nosquish": lambda: (public("nosquish", dt=0.01), kernel_composition("nosquish")),
    "scipy:DOP853": lambda: public("scipy:DOP853"),
    "scipy:RK23": lambda: public("scipy:RK23"),
    "scipy:Radau": lambda: public("scipy:Radau"),
    "scipy:BDF": lambda: public("scipy:BDF"),
    "scipy:LSODA": lambda: public("scipy:LSODA"),
    "euler_angles": lambda: public("dop853", formulation="euler_angles"),
    "schwab": lambda: public("dop853", formulation="schwab"),
    "euler_equations": lambda: public("dop853", formulation="euler_equations"),
    "dop853 events": lambda: events_public("dop853"),
    "splitting events": lambda: events_public("splitting", dt=0.01),
    "ensemble dop853": lambda: ensemble("dop853"),
    "ensemble taylor": lambda: ensemble("taylor"),
    "ensemble events": lambda: ensemble("dop853", events=True),
}

if __name__ == "__main__":
    for name in sys.argv[1:]:
        _CURRENT[0] = name
        INTEGRATORS[name]()

"""The run-side glue of orbit and attitude in one state (:mod:`attitude._core.coupled`).

A coupled run integrates y = (q, Q, h, r, v, m). Before it, the models' copies of the
NumericalOrbit's table (found by the orbit's mark, ``NumericalOrbit.token``) are turned into
live orbits whose state the right-hand side writes; after it, into references to one table of
the run's own samples, which the diagnostics, torques and orbit variables of the Dataset read
(at the samples it is the integrated state itself).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from orbit import _state_kernels as _sk

from ._core import actuators as _ka
from ._core import coupled as _kc
from ._core import environment as _ke
from ._core import potentials as _kp
from .errors import AttitudeValueError

__all__ = [
    "N_ORBIT", "attach", "attach_events", "attach_software", "follow_path", "initial_orbit_state",
    "live_slots", "orbit_tokens", "orbit_variables", "reference_params", "run_orbit",
    "sample_orbit", "total_energy",
]  # fmt: skip

#: State variables the orbit adds: r (3), v (3), m.
N_ORBIT = 7


def initial_orbit_state(craft: Any, t0: float) -> np.ndarray:
    """(r, v, m) at the run's start (m, m/s, kg): the orbit's state at ``t0``."""
    orb = craft.orbit
    if t0 == 0.0:
        rv = orb.initial_state
    else:
        ds = orb.propagate(np.array([t0]))
        if ds.sizes["time"] != 1:
            raise AttitudeValueError(
                f"t: the orbit reaches the Earth's surface before the run's start t = {t0!r} s"
            )
        rv = np.concatenate([ds.position.values[0], ds.velocity.values[0]])
    return np.concatenate([rv, [craft.mass]]).astype(np.float64)


def live_slots(a: np.ndarray, token: float) -> list[int]:
    """Offsets in ``a`` of the copies of an orbit table marked with ``token``."""
    hits = np.flatnonzero(a == token) - (_sk.E_H + 1)
    return [int(o) for o in hits if o >= 0 and a[o + _sk.TYPE] == _sk.TYPE_EPHEMERIS]


def _make_live(a: np.ndarray, token: float) -> list[int]:
    """Turn the copies of the orbit's table in ``a`` into live orbits; their offsets."""
    slots = live_slots(a, token)
    for o in slots:
        a[o + _sk.TYPE] = _sk.TYPE_LIVE
        a[o + _sk.T_MIN] = -np.inf
        a[o + _sk.T_MAX] = np.inf
    return slots


def _attach_live(
    a: np.ndarray, sc: np.ndarray, craft: Any, tokens: Any, what: str, n_at: int, list_at: int
) -> None:
    """Turn the copies in ``a`` of the orbit tables marked with ``tokens`` (default the
    spacecraft's orbit's mark) into live orbits, listed in the spacecraft block's coupled block:
    their number at ``n_at``, their offsets from ``list_at``."""
    co = int(sc[_ka.SC.COUPLED])
    slots: list[int] = []
    for token in tokens or (craft.orbit.token,):
        slots += _make_live(a, token)
    if len(slots) > _kc.MAX_SLOTS:
        raise AttitudeValueError(
            f"{what}: {len(slots)} copies of the orbit; at most {_kc.MAX_SLOTS} in a run whose "
            "orbit is propagated with the attitude"
        )
    sc[co + n_at] = len(slots)
    sc[co + list_at : co + list_at + len(slots)] = slots


def attach_software(fw: np.ndarray, sc: np.ndarray, craft: Any) -> None:
    """Turn the flight software's copies of the orbit (guidance, sensors) into live orbits,
    which the tick writes from the state (listed in the spacecraft block)."""
    _attach_live(fw, sc, craft, None, "software", _kc.COUPLED.N_FSW, _kc.COUPLED.FSW)


def attach_events(evd: np.ndarray, sc: np.ndarray, craft: Any, tokens: Any = None) -> None:
    """Turn the event data's copies of the orbit (eclipse, the Sun's direction, the orbit's
    frames; the tables marked with ``tokens``, default the spacecraft's orbit's mark) into live
    orbits, which the events write from the state before they are evaluated (listed in the
    spacecraft block)."""
    _attach_live(evd, sc, craft, tokens, "events", _kc.COUPLED.N_EV, _kc.COUPLED.EV)


def attach(params: np.ndarray, sc: np.ndarray, craft: Any, tokens: Any = None) -> None:
    """Turn the model's orbit copies in ``params`` (the tables marked with ``tokens``, default
    the spacecraft's orbit's mark) into live orbits and list them in the spacecraft block
    ``sc`` (its coupled block); the mutual potential's force on when the model has a gravity
    gradient, the drag and radiation models' forces listed."""
    _attach_live(params, sc, craft, tokens, "potential", _kc.COUPLED.N_SLOTS, _kc.COUPLED.SLOTS)
    co = int(sc[_ka.SC.COUPLED])
    blocks = _term_blocks(params)
    gg = any(k == _kp.KIND_GRAVITY_GRADIENT for _, k in blocks)
    sc[co + _kc.COUPLED.GG] = 1.0 if gg else 0.0
    env = [(b, k) for b, k in blocks if k in _ENV_KINDS]
    if len(env) > _kc.MAX_ENV:
        raise AttitudeValueError(
            f"potential: {len(env)} drag and radiation models; at most {_kc.MAX_ENV} in a run "
            "whose orbit is propagated with the attitude"
        )
    sc[co + _kc.COUPLED.N_ENV] = len(env)
    for e, (base, kind) in enumerate(env):
        sc[co + _kc.COUPLED.ENV + e] = base
        sc[co + _kc.COUPLED.ENV_KIND + e] = _ENV_KINDS[kind]
        params[
            base + _ke.DRAG.LIVE if kind == _kp.KIND_AERODYNAMIC_DRAG else base + _ke.SRP.LIVE
        ] = 1.0


#: The environment models whose forces act on a coupled orbit.
_ENV_KINDS = {_kp.KIND_AERODYNAMIC_DRAG: _kc.FORCE_DRAG, _kp.KIND_SOLAR_RADIATION: _kc.FORCE_SOLAR}


def _term_blocks(params: np.ndarray) -> list[tuple[int, int]]:
    """(offset, kind) of each built-in term's block in a model's parameters."""
    if int(params[_kp.MODEL.KIND]) == _kp.KIND_SUM:
        n = int(params[_kp.SUM.NTERMS])
        bases = [int(params[_kp.SUM.OFFSETS + j]) for j in range(n)]
    else:
        bases = [_kp.MODEL.KIND]
    return [(b, int(params[b])) for b in bases]


def follow_path(sc: np.ndarray, orbit: Any) -> np.ndarray:
    """The spacecraft block with the path of ``orbit`` (a NumericalOrbit the model's
    environment tables were computed along, when it is not the spacecraft's own: an ensemble's
    nominal orbit) as the coupled block's path."""
    co = int(sc[_ka.SC.COUPLED])
    if orbit is None or not hasattr(orbit, "token") or co < 0:
        return sc
    path = np.array(orbit.kernel_data(), dtype=np.float64)
    path[_sk.E_H + 1] = 0.0  # (not the orbit's mark: this copy stays a table)
    out = np.concatenate([sc, path])
    out[co + _kc.COUPLED.PRED] = sc.shape[0]
    return out


def reference_params(params: np.ndarray, sc: np.ndarray, table: np.ndarray) -> np.ndarray:
    """The model's parameters for the diagnostics after a coupled run: each live orbit a
    reference to ``table`` (appended)."""
    co = int(sc[_ka.SC.COUPLED])
    out = np.concatenate([params, table])
    for k in range(int(sc[co + _kc.COUPLED.N_SLOTS])):
        o = int(sc[co + _kc.COUPLED.SLOTS + k])
        out[o + _sk.TYPE] = _sk.TYPE_REFERENCE
        out[o + _sk.HDR] = params.shape[0] - o
    return out


def run_orbit(craft: Any, t: np.ndarray, y: np.ndarray) -> Any:
    """The run's own orbit: an :class:`orbit.EphemerisOrbit` through its samples (``y`` the
    state rows; at each sample it is the sample), which the Dataset's orbit variables and the
    diagnostics read. One sample gets a second node a second on."""
    from orbit import EphemerisOrbit

    iy = 8 + len(craft.wheels)
    t = np.asarray(t, dtype=np.float64)
    r = np.asarray(y[:, iy : iy + 3], dtype=np.float64) * 1e-3
    v = np.asarray(y[:, iy + 3 : iy + 6], dtype=np.float64) * 1e-3
    if t.size == 1:
        t, r, v = np.array([t[0], t[0] + 1.0]), np.stack([r[0], r[0] + v[0]]), np.stack([v[0]] * 2)
    return EphemerisOrbit(t, r, v, craft.orbit.epoch, craft.orbit.mu,
                          source="the run's propagated orbit (its samples)")  # fmt: skip


def orbit_tokens(craft: Any, potential: Any) -> tuple[float, ...]:
    """The marks of the orbit tables a coupled spacecraft's model holds: its orbit's, and the
    model's orbit's when that is another state of the same orbit model (an ensemble member)."""
    tokens = [craft.orbit.token]
    po = getattr(potential, "orbit", None)
    if po is not None and po is not craft.orbit and hasattr(po, "token"):
        tokens.append(po.token)
    return tuple(tokens)


def orbit_variables(craft: Any, y: np.ndarray) -> dict[str, tuple]:
    """The Dataset variables of the propagated orbit, position, velocity (GCRS) and mass, as
    ``(dims, data, attrs)`` (the caller builds them: attitude.results._variable)."""
    iy = 8 + len(craft.wheels)
    frame = {"reference_frame": "GCRS"}
    return {
        "position": (("time", "axis"), np.ascontiguousarray(y[:, iy : iy + 3]),
                     {"units": "m", "long_name": "position of the centre of mass", **frame}),
        "velocity": (("time", "axis"), np.ascontiguousarray(y[:, iy + 3 : iy + 6]),
                     {"units": "m s-1", "long_name": "velocity of the centre of mass", **frame}),
        "mass": (("time",), np.ascontiguousarray(y[:, iy + 6]),
                 {"units": "kg", "long_name": "spacecraft mass"}),
    }  # fmt: skip


def total_energy(sr: Any, energy: np.ndarray, y: np.ndarray) -> tuple | None:
    """The coupled system's total energy [J] around a point-mass Earth (None with a field or
    third bodies, whose Earth turns under the orbit: no energy of the state is conserved).

    ``energy`` (m,) is the attitude's T + U; the orbit adds m (|v|²/2 − μ/|r|) and, with the
    gravity gradient, the part of the mutual potential to second order that U leaves out
    because it does not depend on the attitude, −μ tr I/(2|r|³) (MacCullagh). Conserved
    without drag, radiation, thrust or actuators doing work; ``y`` the state rows. Returns
    ``(dims, data, attrs)`` as :func:`orbit_variables`.
    """
    craft = sr.spacecraft
    o = craft.orbit
    if o.gravity is not None or o.third_bodies:
        return None
    mu = o.mu * 1e9
    iy = 8 + len(craft.wheels)
    r = y[:, iy : iy + 3]
    v = y[:, iy + 3 : iy + 6]
    rn = np.sqrt(np.einsum("ij,ij->i", r, r))
    e = energy + y[:, iy + 6] * (0.5 * np.einsum("ij,ij->i", v, v) - mu / rn)
    co = int(sr.sc[_ka.SC.COUPLED])
    if sr.sc[co + _kc.COUPLED.GG] != 0.0:
        e = e - mu * float(np.sum(craft.body.inertia)) / (2.0 * rn**3)
    attrs = {"units": "J", "long_name": "total energy of orbit and attitude (point-mass Earth)"}
    return ("time",), np.ascontiguousarray(e), attrs


def sample_orbit(crafts: list, t: np.ndarray, rows: np.ndarray) -> dict[str, np.ndarray]:
    """Each member's orbit variables from its own samples (``rows`` (C, m, width)): ``r``
    (C, m) [km], ``f`` (C, m) [rad] and ``p`` (C, m, 4); NaN after a member's last finite
    sample."""
    c, m = rows.shape[:2]
    out = {"r": np.full((c, m), np.nan), "f": np.full((c, m), np.nan),
           "p": np.full((c, m, 4), np.nan)}  # fmt: skip
    for i, craft in enumerate(crafts):
        iy = 8 + len(craft.wheels)
        ok = np.isfinite(rows[i, :, iy : iy + 6]).all(axis=1)
        ok &= np.linalg.norm(np.nan_to_num(rows[i, :, iy : iy + 3]), axis=1) > 0.0  # (a size
        # estimate's member is zeros)
        k = int(np.argmin(ok)) if not ok.all() else m
        if k == 0:
            continue
        o = run_orbit(craft, t[:k], rows[i, :k])
        out["r"][i, :k] = o.radius(t[:k])
        out["f"][i, :k] = o.true_anomaly(t[:k])
        out["p"][i, :k] = o.frame_quaternion(t[:k])
    return out

"""The ``[ensemble]`` table of a scenario with actuators, ``[commands]`` or ``[software]``.

:func:`attitude.ensemble.run_scenario` hands such a scenario here: its members are drawn from
the table's dispersions exactly as a rigid-body scenario's (:class:`Dispersions`, member i at
Philox counter 3 i) and run as a spacecraft ensemble
(:func:`attitude.ensemble.propagate_ensemble` with ``commands=``/``software=``), so that member
i is, bit for bit, ``propagate(spacecraft_i, q_i, Q_i, t, potential, software=software_i)``
with (docs/ensemble.md, "Closed-loop scenarios")

* q_i = q0∘exp(δθ_i/2) (δθ_i in body axes), ω_i = ω0 + δω_i, ω0 the nominal body rate
  (wheels at their initial speeds);
* the spacecraft's body I_i = I (1 + ε_i) per axis, its actuators the nominal ones;
* Q_i = 2 q_i∘(0, I_i ω_i + Σ J_k Ω_k a_k), the total momentum of body and wheels;
* the flight software the scenario's, its model of the inertia the nominal body's (the software
  cannot know a member's true inertia; a model given to the software is kept), its sensors
  seeded from the ensemble ``seed`` (``sensor_seed``: the scenario's sensor seeds are the
  nominal run's).
"""

from __future__ import annotations

import copy
from typing import Any

import numpy as np

from ..errors import AttitudeValueError
from .dispersions import Dispersions, dispersion_vars

__all__ = ["members_of", "run_spacecraft_scenario"]


def members_of(sc: Any, disp: Dispersions) -> tuple[Any, np.ndarray, np.ndarray, Any]:
    """(spacecraft: one or a list of N, q (N, 4), Q (N, 4), software) of the scenario's
    ensemble, drawn from ``disp`` (the nominal state projected first, as a single run does)."""
    from ..body import RigidBody
    from ..canonical import angular_velocity, momenta_from_angular_velocity, project_state
    from ..quaternion import from_rotation_vector, multiply
    from ..spacecraft import Spacecraft

    craft = sc.spacecraft
    n = disp.size
    q0, Q0, _ = project_state(sc.q0, sc.Q0)
    w0 = np.asarray(angular_velocity(q0, Q0, craft), dtype=np.float64)
    dtheta, domega, eps = disp.draws(0, n)
    q = multiply(q0, from_rotation_vector(dtheta))
    inertia = np.asarray(craft.body.inertia, dtype=np.float64)
    software = sc.software
    orbits, masses = _dispersed_orbits(craft, disp, n)
    if disp.inertia_error > 0 or disp.disperses_orbit:
        parts = (craft.wheels, craft.magnetorquers, craft.thrusters)
        where = {"center_of_mass": craft.center_of_mass, "field": craft.field}
        crafts: Any = [
            Spacecraft(
                RigidBody(inertia * (1.0 + eps[i]), units=craft.body.units),
                *parts,
                orbits[i],
                mass=masses[i],
                **where,
            )
            for i in range(n)
        ]
        Q = np.array(
            [momenta_from_angular_velocity(q[i], w0 + domega[i], crafts[i]) for i in range(n)]
        )
        if software is not None and software.inertia is None:
            software = copy.copy(software)  # its model: the nominal body
            software.inertia = np.diag(inertia)
    else:
        crafts = craft
        Q = np.asarray(momenta_from_angular_velocity(q, w0 + domega, craft), dtype=np.float64)
    return crafts, q, Q.reshape(n, 4), software


def orbit_draws(disp: Dispersions, start: int, stop: int) -> tuple:
    """The orbit errors of members start..stop−1: position (C, 3) [m] and velocity (C, 3)
    [m/s] in the GCRS, and the relative mass error (C,): normal, the mass's truncated at ±3σ.
    From their own Philox stream (key from SeedSequence(seed, spawn_key=(41,)), member i at
    counter 2 i), so the attitude draws are those of an ensemble without them."""
    from scipy.special import ndtr, ndtri

    from .dispersions import INERTIA_TRUNCATION

    key = np.random.SeedSequence(disp.seed, spawn_key=(41,)).generate_state(2, np.uint64)
    bg = np.random.Philox(key=key, counter=start * 2)
    u = np.random.Generator(bg).random((stop - start, 8)) + 2.0**-54
    lo = ndtr(-INERTIA_TRUNCATION)
    return (
        disp.position_error * ndtri(u[:, 0:3]),
        disp.velocity_error * ndtri(u[:, 3:6]),
        disp.mass_error * ndtri(lo + u[:, 6] * (1.0 - 2.0 * lo)),
    )


def member_vars(disp: Dispersions, start: int, stop: int) -> dict[str, tuple]:
    """:func:`dispersion_vars`, and the orbit errors applied when the orbit is dispersed."""
    out = dispersion_vars(disp, start, stop)
    if disp.disperses_orbit:
        dr, dv, dm = orbit_draws(disp, start, stop)
        what = "error applied at the epoch (GCRS)"
        out["dispersion_position"] = (("member", "axis"), dr, {"units": "m",
                                      "long_name": f"position {what}"})  # fmt: skip
        out["dispersion_velocity"] = (("member", "axis"), dv, {"units": "m s-1",
                                      "long_name": f"velocity {what}"})  # fmt: skip
        mass = {"units": "1", "long_name": "relative mass error: m = m_nominal (1 + eps)"}
        out["dispersion_mass"] = (("member",), dm, mass)
    return out


def _dispersed_orbits(craft: Any, disp: Dispersions, n: int) -> tuple[list, list]:
    """The members' orbits and masses: the nominal ones, or (a spacecraft carrying its orbit)
    r0 + δr, v0 + δv at the epoch and m (1 + ε) (:func:`orbit_draws`)."""
    if not disp.disperses_orbit:
        return [craft.orbit] * n, [craft.mass] * n
    if not craft.coupled:
        raise AttitudeValueError(
            "ensemble.position_error: the orbit and the mass are dispersed for a spacecraft "
            "carrying its orbit ([spacecraft] mass on an [orbit] of type 'numerical')"
        )
    dr, dv, dm = orbit_draws(disp, 0, n)
    y0 = craft.orbit.initial_state
    orbits = [craft.orbit.with_state((y0[:3] + dr[i]) * 1e-3, (y0[3:] + dv[i]) * 1e-3)
              for i in range(n)]  # fmt: skip
    return orbits, [craft.mass * (1.0 + dm[i]) for i in range(n)]


def run_spacecraft_scenario(
    sc: Any, out: Any, kw: dict[str, Any], propagate_ensemble: Any, **opts: Any
) -> dict[str, Any]:
    """:func:`attitude.ensemble.run_scenario` of a scenario with a spacecraft (its arguments:
    ``client``, ``progress``, ``chunk_size``, ``scheduler_timeout``, ``output``, ``every``,
    ``percentiles``, ``max_output_size``, ``on_estimate``; ``kw`` the numerics;
    ``propagate_ensemble`` the runner, passed in: this module is below it)."""

    disp = sc.ensemble
    attrs = _attrs(sc, disp, kw)
    output = opts["output"]
    percentiles = opts["percentiles"]
    max_size = opts["max_output_size"]
    common = dict(
        client=opts["client"],
        scheduler_timeout=opts["scheduler_timeout"],
        attrs=attrs,
        epoch=sc.epoch,
        output=disp.output if output is None else output,
        every=disp.every if opts["every"] is None else opts["every"],
        percentiles=percentiles if percentiles is not None else disp.percentiles,
        commands=sc.commands,
        events=sc.events,
        seed=disp.seed,
        _member_vars=lambda start, stop: member_vars(disp, start, stop),
        **kw,
    )
    limit = disp.max_output_size if max_size is ... else max_size
    if disp.size > PROBE_ABOVE:  # refuse too large an output before drawing every member
        _check_size(sc, disp, out, common, limit, propagate_ensemble)
    crafts, q, Q, software = members_of(sc, disp)
    ds = propagate_ensemble(
        crafts, q, Q, sc.t, sc.potential, path=out, progress=opts["progress"],
        chunk_size=opts["chunk_size"] or disp.chunk, max_output_size=limit,
        on_estimate=opts["on_estimate"], software=software, **common,
    )  # fmt: skip
    try:
        info = {"path": out, **ds.attrs}
    finally:
        ds.close()
    return info


#: Ensembles larger than this are sized (from 1- and 2-member probes) before their members are
#: drawn: the members' spacecraft and states are held in memory.
PROBE_ABOVE = 4096


class _Estimate(Exception):
    def __init__(self, nbytes: int):
        self.nbytes = nbytes


def _check_size(
    sc: Any, disp: Dispersions, out: Any, common: dict, limit: Any, propagate_ensemble: Any
) -> None:
    """Raise OutputSizeError if the ensemble's output would exceed ``limit``: its expected
    size is affine in the size N (per-member variables N times, the rest once), measured on
    ensembles of the first 1 and 2 members."""
    import dataclasses

    from . import _plan

    sizes = []
    for n in (1, 2):
        part = dataclasses.replace(disp, size=n)
        crafts, q, Q, software = members_of(sc, part)

        def stop(nbytes: int) -> None:
            raise _Estimate(nbytes)

        try:
            propagate_ensemble(crafts, q, Q, sc.t, sc.potential, path=out, software=software,
                               max_output_size=None, on_estimate=stop, **common)  # fmt: skip
        except _Estimate as est:
            sizes.append(est.nbytes)
    expected = int(sizes[0] + (sizes[1] - sizes[0]) * (disp.size - 1))
    plan = _plan.make_plan(_plan_times(sc.t), common["output"], common["every"],
                           common["percentiles"], limit)  # fmt: skip
    _plan.check_size(expected, plan, disp.size, False)


def _plan_times(t: Any) -> np.ndarray:
    from .._validation import as_times

    return as_times(t, "t")


def _attrs(sc: Any, disp: Dispersions, kw: dict[str, Any]) -> dict[str, Any]:
    attrs = {**sc.attrs(kw), **disp.attrs()}
    attrs["ensemble_sampling"] = (
        "member i: Philox(SeedSequence(seed)) at counter 3 i; q_i = q0 o exp(dtheta/2) (body "
        "axes), omega_i = omega0 + domega, I_i = I (1 + eps) (normal: truncated at 3 sigma), "
        "Q_i = 2 q_i o (0, I_i omega_i + sum_k J_k Omega_k a_k) (wheels at their initial "
        "speeds); the flight software's inertia model is the nominal body's; sensors seeded "
        "from ensemble_seed (sensor_seed)"
    )
    attrs["inertia"] = np.asarray(sc.spacecraft.body.inertia, dtype=np.float64)
    if disp.inertia_error > 0:
        attrs["inertia_note"] = "nominal; per-member moments in the variable inertia"
    return attrs

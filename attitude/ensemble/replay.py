"""Re-running one member of an ensemble from what its result stores.

Every ensemble result stores each member's inputs: ``inertia`` (member, axis), the initial
state as given or drawn before the projection onto |q| = 1, q·Q = 0 (``initial_q``,
``initial_Q``), and, for scenario dispersions, the errors applied (``dispersion_attitude``,
``dispersion_rate``, ``dispersion_inertia``) and the position of the member's draws in the
random stream (``member_draw_counter``, with the global ``ensemble_seed``). With the run's
tolerances and integration span (attrs ``rtol``, ``atol``, ``integration_start``,
``integration_stop``) that is all a member's trajectory depends on: :func:`rerun_member`
integrates it alone as a one-member ensemble, through the same projection and compiled loop,
and gives its samples bit for bit.
"""

from __future__ import annotations

import contextlib
import os
from typing import Any

import numpy as np
import xarray as xr

from ..body import SI_INERTIA, RigidBody
from ..errors import AttitudeTypeError, AttitudeValueError
from ..potentials import Potential, TorqueFree

__all__ = ["member_initial_state", "rerun_member"]


@contextlib.contextmanager
def _opened(source: Any):
    if isinstance(source, xr.Dataset):
        yield source
        return
    if not isinstance(source, (str, os.PathLike)):
        raise AttitudeTypeError(
            f"source: expected an ensemble result (xarray.Dataset) or the path of its file, got "
            f"{type(source).__name__}"
        )
    from ..io import read

    ds = read(source, load=False)
    try:
        yield ds
    finally:
        ds.close()


def _member(ds: xr.Dataset, k: Any) -> int:
    if "member" not in ds.dims:
        raise AttitudeValueError("source: not an ensemble result (no member dimension)")
    if not isinstance(k, (int, np.integer)) or isinstance(k, bool):
        raise AttitudeTypeError(f"k: expected a member index (an integer), got {k!r}")
    members = np.asarray(ds["member"].values)
    pos = np.flatnonzero(members == int(k))
    if not pos.size:
        raise AttitudeValueError(
            f"k: no member {int(k)} in this result (members {int(members[0])}..{int(members[-1])})"
        )
    if "initial_q" not in ds or "initial_Q" not in ds:
        raise AttitudeValueError(
            "source: this ensemble result does not store the members' initial states "
            "(initial_q, initial_Q: written since issue 16); run it again to re-run members"
        )
    return int(pos[0])


def _initial(ds: xr.Dataset, i: int) -> tuple[RigidBody, np.ndarray, np.ndarray]:
    inertia = np.asarray(ds["inertia"].isel(member=i).values, dtype=np.float64)
    units = str(ds["inertia"].attrs.get("units", "1"))
    body = RigidBody(inertia, units=SI_INERTIA) if units != "1" else RigidBody(inertia)
    q0 = np.asarray(ds["initial_q"].isel(member=i).values, dtype=np.float64)
    Q0 = np.asarray(ds["initial_Q"].isel(member=i).values, dtype=np.float64)
    return body, q0, Q0


def member_initial_state(source: Any, k: int) -> tuple[RigidBody, np.ndarray, np.ndarray]:
    """The body and initial state of member ``k`` of an ensemble result.

    Parameters
    ----------
    source : xarray.Dataset or str or Path
        An ensemble result (:func:`propagate_ensemble`, :func:`run_scenario`) or its file.
    k : int
        The member index (the ``member`` coordinate).

    Returns
    -------
    body : RigidBody
        The member's principal moments (dispersed, for a scenario with inertia errors).
    q0 : ndarray, shape (4,)
        Initial attitude as given or drawn (before the projection every run applies).
    Q0 : ndarray, shape (4,)
        Initial conjugate momenta, in the result's units.
    """
    with _opened(source) as ds:
        return _initial(ds, _member(ds, k))


def rerun_member(
    source: Any,
    k: int,
    potential: Potential | None = None,
    *,
    spacecraft: Any = None,
    software: Any = None,
    commands: Any = None,
) -> xr.Dataset:
    """Integrate member ``k`` of an ensemble result alone; its samples bit for bit.

    A one-member :func:`propagate_ensemble` from the member's stored body and initial state,
    with the run's method and tolerances, over its integration span (``integration_start`` ..
    ``integration_stop``), evaluated at the result's stored times.

    An ensemble of spacecraft with actuators or flight software (a result with the attr
    ``spacecraft``) stores neither the spacecraft nor the software (objects, not numbers): give
    member ``k``'s (``spacecraft=``, ``software=`` or ``commands=``, as passed to
    ``propagate_ensemble``, the member's own for per-member ones). The member is then the single
    run ``attitude.propagate(spacecraft, q0, Q0, t, potential, software=software with the
    member's sensor seeds (variable sensor_seed))``, which equals its ensemble samples and tick
    records bit for bit.

    Parameters
    ----------
    source : xarray.Dataset or str or Path
        An ensemble result or its file (any output choice: for ``"statistics"`` the times are
        those of the percentiles).
    k : int
        The member index.
    potential : Potential, optional
        The potential the ensemble ran with (member ``k``'s, for per-member potentials).
        Needed unless it was torque-free. For a file written from a scenario:
        ``attitude.scenario.loads(ds.attrs["scenario_toml"]).potential``.
    spacecraft : Spacecraft, optional
        Member ``k``'s spacecraft (spacecraft ensembles only).
    software : FlightSoftware, optional
        Member ``k``'s flight software (its sensors are reseeded with the stored seeds).
    commands : CommandSchedule, optional
        Member ``k``'s open-loop schedule.

    Returns
    -------
    xarray.Dataset
        The member's trajectory: the variables of ``propagate`` over ``time``, the member's
        statistics (``member_n_steps``...) and its index as the scalar coordinate ``member``.
    """
    import attitude.accessor  # noqa: F401 - ds.attitude (times of CF-decoded files)

    from ..propagate import propagate
    from ._run import propagate_ensemble

    with _opened(source) as ds:
        i = _member(ds, k)
        a = dict(ds.attrs)
        if "spacecraft" in a:
            software = _spacecraft_inputs(ds, i, spacecraft, software, commands)
            q0 = np.asarray(ds["initial_q"].isel(member=i).values, dtype=np.float64)
            Q0 = np.asarray(ds["initial_Q"].isel(member=i).values, dtype=np.float64)
        else:
            for name, v in (("spacecraft", spacecraft), ("software", software),
                            ("commands", commands)):  # fmt: skip
                if v is not None:
                    raise AttitudeValueError(
                        f"{name}: this ensemble ran rigid bodies without actuators or software"
                    )
            body, q0, Q0 = _initial(ds, i)
        if potential is None:
            if str(a.get("potential_name", "torque_free")) != "torque_free":
                raise AttitudeValueError(
                    f"potential: the ensemble ran with {a.get('potential', a['potential_name'])};"
                    " pass that potential (for a file written from a scenario: "
                    "attitude.scenario.loads(ds.attrs['scenario_toml']).potential)"
                )
            potential = TorqueFree()
        # the member's integration span, evaluated at the stored times
        t = np.asarray(ds.attitude.quantity("time").value, dtype=np.float64)
        span = [a["integration_start"], a["integration_stop"]] if "integration_stop" in a else []
        grid = np.unique(np.concatenate([t, np.asarray(span, dtype=np.float64)]))
        rows = np.searchsorted(grid, t)
        kw: dict[str, Any] = {
            "method": str(a.get("method", "dop853")),
            "rtol": float(a.get("rtol", 1e-10)),
            "atol": float(a.get("atol", 1e-12)),
        }
        if "max_step" in a:
            kw["max_step"] = float(a["max_step"])
        epoch = {"epoch": a["epoch"]} if a.get("epoch") else {}
        member = int(ds["member"].values[i])
    if "spacecraft" in a:  # the single run, which equals the member bit for bit
        one = propagate(spacecraft, q0, Q0, grid, potential, software=software,
                        commands=commands, **kw, **epoch)  # fmt: skip
        return one.isel(time=rows).assign_coords(member=member)
    one = propagate_ensemble(
        body,
        q0[None, :],
        Q0[None, :],
        grid,
        potential,
        chunk_size=1,
        max_output_size=None,
        attrs={"title": f"member {member} of an ensemble, re-run alone", **epoch},
        **kw,
    )
    return one.isel(member=0, time=rows).assign_coords(member=member)


def _spacecraft_inputs(ds, i, spacecraft, software, commands) -> Any:
    """Member ``i``'s spacecraft, software and commands checked against a spacecraft
    ensemble's attrs; the software with the member's stored sensor seeds."""
    from ..actuators.commands import CommandSchedule
    from ..software import FlightSoftware
    from ..spacecraft import Spacecraft

    a = ds.attrs
    if not isinstance(spacecraft, Spacecraft):
        raise AttitudeValueError(
            "spacecraft: an ensemble of spacecraft stores no spacecraft; pass member k's "
            f"attitude.Spacecraft (the run's: {a['spacecraft'][:120]})"
        )
    if "software" in a and not isinstance(software, FlightSoftware):
        raise AttitudeValueError(
            "software: this ensemble ran flight software; pass member k's attitude.FlightSoftware"
        )
    if "software" not in a and software is not None:
        raise AttitudeValueError("software: this ensemble ran without flight software")
    if commands is not None and not isinstance(commands, CommandSchedule):
        raise AttitudeTypeError("commands: expected an attitude.CommandSchedule")
    if software is not None and "sensor_seed" in ds:
        seeds = [int(s) for s in np.asarray(ds["sensor_seed"].isel(member=i).values)]
        software = software.with_sensor_seeds(seeds)
    return software

"""The validated :class:`Scenario`: running it (in memory or streamed to netCDF), invariants."""

from __future__ import annotations

import math
import os
import sys
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .._invariants import InvariantTracker
from ..body import RigidBody
from ..ensemble.dispersions import Dispersions
from ..errors import AttitudeValueError, PropagationError
from ..results import set_time_attrs

if sys.version_info >= (3, 11):
    pass
else:  # pragma: no cover - Python 3.10
    pass


@dataclass
class Scenario:
    """A validated scenario: body, initial state, potential, output times and numerics.

    Build it with :func:`load` or :func:`loads`; :meth:`run` returns the result Dataset.
    """

    name: str
    title: str
    description: str
    body: RigidBody
    q0: np.ndarray
    Q0: np.ndarray
    potential: Any
    t: Any  # output times: a TimeGrid (generated a chunk at a time) or an array
    time_unit: str
    time_scale: float = 1.0  # internal time units per unit of the [time] table
    method: str = "auto"  # taylor where the model supports it, else dop853
    rtol: float = 1e-10
    atol: float = 1e-12
    max_step: float = math.inf
    max_steps: int = 100_000_000
    dt: float | None = None  # step of the fixed-step methods (nosquish, splitting)
    order: int = 4
    formulation: str = "canonical"
    output: Path = Path("out.nc")
    epoch: str | None = None
    object_name: str = "UNKNOWN"
    object_id: str = "UNKNOWN"
    inertial_frame: str | None = None  # AEM REF_FRAME_A; None: by the run (aem.write_aem)
    source: str = ""
    path: Path | None = None
    initial_form: str = "canonical"
    extra_attrs: dict[str, Any] = field(default_factory=dict)
    ensemble: Dispersions | None = None  # from an [ensemble] table
    events: list | None = None  # from an [events] table (attitude.events)
    spacecraft: Any = None  # attitude.Spacecraft of the [spacecraft] actuator tables
    commands: Any = None  # attitude.CommandSchedule of the [commands] table
    software: Any = None  # attitude.FlightSoftware of the [software] table

    # -- running ----------------------------------------------------------------------------
    def _kwargs(self, overrides: Mapping[str, Any]) -> dict[str, Any]:
        kw = dict(
            method=self.method,
            rtol=self.rtol,
            atol=self.atol,
            max_step=self.max_step,
            max_steps=self.max_steps,
        )
        if self.dt is not None:
            kw.update(dt=self.dt, order=self.order)
        if self.formulation != "canonical":
            kw["formulation"] = self.formulation
        kw.update({k: v for k, v in overrides.items() if v is not None})
        return kw

    def attrs(self, kw: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """Global attrs describing the scenario (added to the result's attrs)."""
        a: dict[str, Any] = {
            "title": self.title or self.name,
            "scenario": self.name,
            "scenario_description": self.description,
            "scenario_file": str(self.path) if self.path else "",
            "scenario_toml": self.source,
            "initial_state_form": self.initial_form,
            "object_name": self.object_name,
            "object_id": self.object_id,
        }
        if self.inertial_frame:
            a["inertial_frame"] = self.inertial_frame
        if self.epoch:
            a["epoch"] = self.epoch
        if kw and kw.get("max_step", math.inf) != math.inf:
            a["max_step"] = float(kw["max_step"])
        a.update(self.extra_attrs)
        return a

    def _history(self, ds_attrs: Mapping[str, Any]) -> str:
        where = f" {self.path}" if self.path else ""
        return f"{ds_attrs.get('history', '')}; scenario{where}".lstrip("; ")

    def run(self, *, progress: Callable | None = None, **overrides: Any) -> xr.Dataset:
        """Propagate and return the result Dataset (in memory).

        Parameters
        ----------
        progress : callable, optional
            ``progress(n_done, n_total, t)`` (see :func:`attitude.propagate.propagate`).
        **overrides
            ``method``, ``rtol``, ``atol``, ``max_step`` replacing the scenario's.

        Raises
        ------
        PropagationError
            The integration failed; ``.partial`` holds what was computed (with scenario attrs).
        """
        from ..propagate import propagate

        kw = self._kwargs(overrides)
        try:
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", "initial state projected")
                ds = propagate(
                    self.body if self.spacecraft is None else self.spacecraft,
                    self.q0,
                    self.Q0,
                    self.t,
                    self.potential,
                    progress=progress,
                    epoch=self.epoch,
                    events=self.events,
                    commands=self.commands,
                    software=self.software,
                    **kw,
                )
        except PropagationError as exc:
            if exc.partial is not None:
                exc.partial.attrs.update(self.attrs(kw), run_status=f"failed: {exc}")
                set_time_attrs(exc.partial)
            raise
        status = "event" if ds.attrs.get("status") == "event" else "complete"
        ds.attrs.update(self.attrs(kw), run_status=status)
        set_time_attrs(ds)  # CF time units from the epoch
        ds.attrs["history"] = self._history(ds.attrs)
        return ds

    def run_to_file(
        self,
        path: str | os.PathLike | None = None,
        *,
        progress: Callable | None = None,
        chunk: int | None = None,
        **overrides: Any,
    ) -> dict[str, Any]:
        """Propagate streaming the samples to a netCDF4 file (bounded memory, atomic).

        A run that fails midway still commits the file with what was computed and
        ``run_status = "failed: ..."``, then raises the :class:`PropagationError`. An interrupt
        (KeyboardInterrupt) leaves no file under the final name.

        Returns
        -------
        dict
            ``path``, ``n_samples``, the run statistics and invariant diagnostics (the attrs).
        """
        from ..io import TIME_CHUNK, StreamWriter
        from ..propagate import propagate

        out = Path(path) if path is not None else self.output
        kw = self._kwargs(overrides)
        tracker = InvariantTracker()
        writer = StreamWriter(out)
        per_sample = 8 * (22 + (6 if getattr(self.potential, "orbit", None) else 0))
        if self.spacecraft is not None:
            nw, nm, nt = self.spacecraft.counts
            per_sample += 8 * (6 * nw + 2 * nm + 2 * nt + 9)
        writer._out.check_space(per_sample * len(self.t), f"{len(self.t)} samples")

        def sink(ds: xr.Dataset) -> None:
            tracker.update(ds)
            writer.append(ds)

        failure: PropagationError | None = None
        try:
            try:
                with warnings.catch_warnings():
                    warnings.filterwarnings("ignore", "initial state projected")
                    last = propagate(
                        self.body if self.spacecraft is None else self.spacecraft,
                        self.q0,
                        self.Q0,
                        self.t,
                        self.potential,
                        progress=progress,
                        # ~200 chunks: a smooth progress bar, bounded memory
                        chunk=chunk or max(64, min(TIME_CHUNK, len(self.t) // 200)),
                        on_chunk=sink,
                        epoch=self.epoch,
                        events=self.events,
                        commands=self.commands,
                        software=self.software,
                        **kw,
                    )
                status = "event" if last.attrs.get("status") == "event" else "complete"
                if self.events is not None or self.software is not None:
                    writer.add_static(last)
            except PropagationError as exc:
                failure = exc
                last = exc.partial
                status = f"failed: {exc}"
            if writer.n == 0:
                raise failure or AttitudeValueError("no samples computed")
            attrs = dict(last.attrs) if last is not None else dict(writer.attrs)
            attrs.update(self.attrs(kw), run_status=status, n_samples=np.int64(writer.n))
            counts = None if self.spacecraft is None else self.spacecraft.counts
            attrs.update(tracker.attrs(attrs.get("potential_name", ""), counts))
            attrs["history"] = self._history(attrs)
            writer.attrs = attrs
            writer.commit()
        except BaseException:
            writer.abort()
            raise
        if failure is not None:
            raise failure
        # the span actually computed: a terminal event ends the run at its own time
        return {"path": out, "time_span": (tracker.t_first, tracker.t_last), **attrs}

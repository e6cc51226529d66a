"""Running maxima of a result's invariant errors over streamed chunks (the attrs that
``attitude info`` prints): the scenario runner, the ensembles and the command share them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

__all__ = ["InvariantTracker"]


class InvariantTracker:
    """Running maxima of the invariant errors over streamed chunks of a result."""

    def __init__(self):
        self.max_norm = 0.0
        self.max_qQ = 0.0
        self.max_rel_qQ = 0.0
        self.t_first = self.t_last = math.nan
        self.E0: float | None = None
        self.G0: np.ndarray | None = None
        self.max_dE = 0.0
        self.max_dG = 0.0
        self.max_dGz = 0.0
        self.E_units = ""

    def update(self, ds: xr.Dataset) -> None:
        if ds.sizes.get("time", 0) == 0:  # (a chunk of the flight software's ticks)
            return
        self.max_norm = max(self.max_norm, float(np.max(np.abs(ds["norm_error"].values))))
        qQ = np.abs(ds["qQ"].values)
        self.max_qQ = max(self.max_qQ, float(np.max(qQ)))
        # q.Q relative to |Q| (q.Q is in the momenta's units: 3.7e-6 kg m^2/s of |Q| = 2e6)
        normQ = np.linalg.norm(ds["Q"].values, axis=-1)
        rel = np.divide(qQ, normQ, out=np.zeros_like(qQ), where=normQ > 0)
        self.max_rel_qQ = max(self.max_rel_qQ, float(np.max(rel)))
        t = ds["time"].values
        if math.isnan(self.t_first):
            self.t_first = float(t[0])
        self.t_last = float(t[-1])
        E = ds["energy"].values
        G = ds["G"].values
        if self.E0 is None:
            self.E0 = float(E[0])
            self.G0 = G[0].copy()
            self.E_units = str(ds["energy"].attrs.get("units", ""))
        self.max_dE = max(self.max_dE, float(np.max(np.abs(E - self.E0))))
        dG = np.linalg.norm(G - self.G0, axis=-1)
        self.max_dG = max(self.max_dG, float(np.max(dG)))
        self.max_dGz = max(self.max_dGz, float(np.max(np.abs(G[:, 2] - self.G0[2]))))

    def attrs(
        self, potential_name: str, actuators: Any = None, absolute: bool = True
    ) -> dict[str, Any]:
        """Diagnostic attrs: constraint errors always, conserved quantities where they are.

        ``actuators``: the (wheels, magnetorquers, thrusters) counts of a spacecraft: its
        motors and friction change the energy; only its wheels leave G unchanged.
        ``absolute``: where H is not conserved, also its largest change, H0 and their unit
        (not for maxima that are relative already, an ensemble's).
        """
        a: dict[str, Any] = {
            "max_abs_norm_error": self.max_norm,
            "max_abs_qQ": self.max_qQ,
            "max_rel_qQ": self.max_rel_qQ,
        }
        scaleE = max(abs(self.E0 or 0.0), np.finfo(float).tiny)
        scaleG = max(float(np.linalg.norm(self.G0)) if self.G0 is not None else 0.0, 1e-300)
        # where H is not conserved its change is a number of its own: relative to a small H0 (a
        # body starting at rest that its wheels turn) it reads as 1e+04
        changed = {}
        if absolute:  # (an ensemble's maxima are over members, each relative to its own H0)
            changed = {
                "max_abs_energy_change": self.max_dE,
                "initial_energy": self.E0 if self.E0 is not None else math.nan,
                "energy_units": self.E_units,
            }
        if actuators is not None and any(actuators):
            a["max_rel_energy_work"] = self.max_dE / scaleE
            a.update(changed)
            if potential_name == "torque_free" and not actuators[1] and not actuators[2]:
                a["max_rel_G_error"] = self.max_dG / scaleG
            return a
        if potential_name in ("torque_free", "heavy_top"):
            a["max_rel_energy_error"] = self.max_dE / scaleE
        if potential_name == "torque_free":
            a["max_rel_G_error"] = self.max_dG / scaleG
        if potential_name == "heavy_top":
            a["max_rel_Gz_error"] = self.max_dGz / scaleG
        if potential_name not in ("torque_free", "heavy_top"):
            a["max_rel_energy_variation"] = self.max_dE / scaleE
            a.update(changed)
        return a

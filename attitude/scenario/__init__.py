"""Scenarios: a propagation described in a TOML file (docs/scenarios.md).

>>> from attitude import scenario                                   # doctest: +SKIP
>>> sc = scenario.load("scenarios/paper_keplerian.toml")
>>> ds = sc.run()                         # xarray Dataset (docs/results.md)
>>> sc.run_to_file("out.nc")              # streamed to netCDF, bounded memory

Quantities carry their unit in a sibling key ``<name>_unit`` (``a = 7000.0`` with
``a_unit = "km"``), parsed by astropy. A body without ``inertia_unit`` is dimensionless (the
paper's first two cases): then every quantity except angles is a plain number in the same
consistent units, and giving a unit is an error. Every error names the key and what was
expected, before any work (:class:`ScenarioError`).

The package: ``_schema`` (tables, keys, units and the reader whose errors name the key),
``_scenario`` (the :class:`Scenario` and how it runs), ``_build`` (TOML text to a Scenario).
"""

from __future__ import annotations

import sys

from ._build import load, loads
from ._scenario import InvariantTracker, Scenario
from ._schema import ScenarioError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

__all__ = ["InvariantTracker", "Scenario", "ScenarioError", "load", "loads", "tomllib"]

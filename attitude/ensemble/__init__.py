"""Ensembles: many initial states (and bodies, potentials) through the same scenario.

:func:`propagate_ensemble` integrates N members, each with its own adaptive DOP853 steps (or
Taylor steps, ``method="taylor"``: four members per SIMD instruction), in parallel compiled
code (blocks of members on threads, the GIL released, or Dask tasks on a cluster), and returns one
Dataset with a ``member`` dimension and the variables of :func:`attitude.propagate`. Members
are processed in chunks; with ``path=`` every chunk is streamed to a netCDF4 file as soon as
it is done, so memory is bounded by one chunk whatever N.

A member's result does not depend on the chunk size, the number of threads, or on whether it
ran locally or on a Dask worker: every member runs the same compiled member body from a fresh
integrator state (tests/test_ensemble.py checks all three bit for bit).

Modules, one concern each:

========================  ===================================================================
``_run``                  :func:`propagate_ensemble`, :func:`run_scenario` (front ends)
``_spec``                 :class:`EnsembleSpec`: every argument validated once (with the single
                          run's shared checks, :mod:`attitude._run`)
``_members``              validated member inputs: rows of rigid bodies, or spacecraft with
                          actuators or flight software, each prepared as its single run
``_chunks``               one chunk in compiled code (also the body of a Dask task), rigid
                          bodies and spacecraft
``_runner``               the one chunk loop (failures, totals, output), a strategy each for
                          rigid bodies and spacecraft
``_output``               assembling chunks into Datasets, the result opened from its file
``_dask``                 Dask scheduling: connecting, task submission, lazy graphs
``_plan``                 what is stored (output choices), the time grid, the size estimate
``_percentile_store``     statistics-only output: per-member scalars, exact percentiles
``_spacecraft_scenario``  the ``[ensemble]`` table of a scenario with actuators or software
``replay``                :func:`member_initial_state`, :func:`rerun_member`
``dispersions``           :func:`disperse`, :class:`Dispersions` (Monte Carlo draws of the
                          ``[ensemble]`` table, from Python too), :func:`disperse_spacecraft`
``statistics``            :func:`pointing_error_percentiles`, :func:`rate_percentiles`,
                          :func:`event_time_percentiles`,
                          :func:`error_angle_percentiles`, :func:`settling_times`
========================  ===================================================================

The ``[ensemble]`` table of a scenario file is parsed by :mod:`attitude.scenario`; the
``attitude run`` output of an ensemble is printed by :mod:`attitude.cli`. See docs/ensemble.md.
"""

from __future__ import annotations

from ._run import propagate_ensemble, run_scenario
from .dispersions import (
    Dispersed,
    DispersedSpacecraft,
    Dispersions,
    disperse,
    disperse_spacecraft,
)
from .replay import member_initial_state, rerun_member
from .statistics import (
    error_angle_percentiles,
    event_time_percentiles,
    pointing_error_percentiles,
    rate_percentiles,
    settling_times,
)

__all__ = [
    "Dispersed",
    "DispersedSpacecraft",
    "Dispersions",
    "disperse",
    "disperse_spacecraft",
    "error_angle_percentiles",
    "event_time_percentiles",
    "member_initial_state",
    "pointing_error_percentiles",
    "propagate_ensemble",
    "rate_percentiles",
    "rerun_member",
    "run_scenario",
    "settling_times",
]

"""Which compiled entry points a built-in model runs on.

:mod:`attitude._core.entry_points` is written against a model, five global kernels
(``torque``, ``potential``, ``term_torque``, ``n_terms``, ``event``). Bound to the built-in switch
over every kind (:func:`attitude._core.potentials.builtin_torque`), one set of entry points
serves every built-in model and every sum of them, but compiling it compiles every kind: the
environment models, the heavy top, and the gravity gradient with every orbit type (Kepler,
secular J2, Hermite ephemeris), about 20 s on a fresh install before the first step.

A model that is a single term (torque-free, heavy top, gravity gradient, or one environment
model) gets the same entry points compiled with its own kernels bound instead
(:func:`orbit._shared_jit.specialise`: an in-memory copy of the module, cached on disk under
the model's tag), so its first run compiles its own code only; the gravity gradient's kernels
are specialised once more to the orbit (``orbit_radial`` bound to the kernel of its type,
:func:`orbit._state_kernels.radial_kernel`; an elliptic Kepler orbit's without the hyperbolic
solver).
The arithmetic is the same code, so the results are bit-identical to the generic entry points.
Sums of models run on the generic entry points; user models on their copies in the user
cache (:mod:`attitude._user_kernels`).

Under flight software every built-in model runs on the generic entry points: the closed-loop
drivers (the tick, sensors, estimator, integrator and diagnostics inlined: the largest compiled
functions of the package) are compiled once for every combination of models, laws, sensors and
actuators, not once per model (issue 40).
"""

from __future__ import annotations

from typing import Any

from orbit._shared_jit import specialise
from orbit._state_kernels import radial_kernel, sample_kernel

from . import diagnostics as _diagnostics
from . import entry_points as _generic
from . import potentials as _kp

__all__ = ["entry_points"]

#: The gravity-gradient kernels that read the orbit (copied per orbit type).
_GG_KERNELS = (
    "gravity_gradient_terms",
    "gravity_gradient_torque",
    "gravity_gradient_potential",
)

_CACHE: dict[str, Any] = {}

#: The environment models alone: (tag, torque, potential).
_ENVIRONMENT = {
    _kp.KIND_MAGNETIC_DIPOLE: (
        "magnetic_dipole",
        _kp.magnetic_model_torque,
        _kp.magnetic_model_potential,
    ),
    _kp.KIND_EDDY_CURRENTS: ("eddy_currents", _kp.eddy_model_torque, _kp.torque_free_potential),
    _kp.KIND_AERODYNAMIC_DRAG: (
        "aerodynamic_drag",
        _kp.drag_model_torque,
        _kp.torque_free_potential,
    ),
    _kp.KIND_SOLAR_RADIATION: (
        "solar_radiation",
        _kp.solar_model_torque,
        _kp.torque_free_potential,
    ),
}


def _model(tag: str, torque: Any, potential: Any, orbit_sample: Any, **more: Any) -> Any:
    """The entry points with ``torque``/``potential`` of one model alone (cached per process),
    ``orbit_sample`` the kernel of its orbit's type (:func:`_diagnostics.no_orbit_sample`
    without one), and ``more`` other globals bound."""
    if tag not in _CACHE:
        term = specialise(_kp, tag, names=("model_term_torque",), MODEL_TORQUE=torque)
        _CACHE[tag] = specialise(
            _generic,
            tag,
            torque=torque,
            potential=potential,
            term_torque=term.model_term_torque,
            n_terms=_kp.model_n_terms,
            orbit_sample=orbit_sample,
            **more,
        )
    return _CACHE[tag]


def entry_points(kind: int | None, orbit_data: Any = None, closed_loop: bool = False) -> Any:
    """The compiled entry points of a built-in model of kind ``kind`` (``KIND_*`` of
    :mod:`attitude._core.potentials`; a model with an orbit also gives the orbit's
    ``kernel_data()``): specialised to that model alone where there is a specialisation, else
    (and for a ``closed_loop`` run) the generic module. A specialised copy keeps the arguments
    that made it (``__entry_args__``: another process makes the same copy from them).
    """
    module = _entry_points(kind, orbit_data, closed_loop)
    if module is not _generic and "__entry_args__" not in vars(module):
        module.__entry_args__ = (kind, orbit_data, closed_loop)
    return module


def _entry_points(kind: int | None, orbit_data: Any, closed_loop: bool) -> Any:
    if closed_loop:
        return _generic
    if kind == _kp.KIND_TORQUE_FREE:
        return _model(
            "torque_free",
            _kp.torque_free_torque,
            _kp.torque_free_potential,
            _diagnostics.no_orbit_sample,
        )
    if kind == _kp.KIND_HEAVY_TOP:
        return _model(
            "heavy_top", _kp.heavy_top_torque, _kp.heavy_top_potential, _diagnostics.no_orbit_sample
        )
    if kind in _ENVIRONMENT:
        tag, torque, potential = _ENVIRONMENT[kind]
        if orbit_data is None:
            return _model(tag, torque, potential, _diagnostics.no_orbit_sample)
        orbit_tag, sample = sample_kernel(orbit_data)
        return _model(f"{tag}_{orbit_tag}", torque, potential, sample)
    if kind == _kp.KIND_GRAVITY_GRADIENT and orbit_data is not None:
        orbit_tag, radial = radial_kernel(orbit_data)
        tag = f"gravity_gradient_{orbit_tag}"
        if tag not in _CACHE:
            gg = specialise(_kp, tag, names=_GG_KERNELS, orbit_radial=radial)
            # The Dataset's orbit is the model's: its potential and torque read the orbit
            # sample that the diagnostics pass looks up anyway (one Kepler solve a sample).
            return _model(
                tag,
                gg.gravity_gradient_torque,
                gg.gravity_gradient_potential,
                sample_kernel(orbit_data)[1],
                potential_at=_kp.gravity_gradient_potential_at,
                term_torque_at=_kp.gravity_gradient_term_torque_at,
            )
        return _CACHE[tag]
    return _generic

"""Every result variable carries the unit its numbers are in, checked by physics, not by a table.

The inputs are astropy Quantities in units other than the package's (inertia in kg m², rates in
rad/s, μ in m³/s², the semi-major axis in m); every variable of the result is turned back into
a Quantity with its own ``units`` attr and compared, in SI, with what the physics says it is:

* ``time`` with the requested times, ``r`` and ``f`` with Kepler's closed form (E by bisection
  of Kepler's equation, r = a(1 − e cos E), tan f/2 = √((1+e)/(1−e)) tan E/2), ``p`` with the
  radial direction and the orbit normal of that closed form;
* ``omega`` with the initial rates, ``g`` = I ω, ``G`` = R(q) g, ``Q`` = 2 q∘(0, g) (Hamilton
  product written out here), ``qQ`` = q·Q and ``norm_error`` = |q| − 1 in the units those
  products have (astropy's dimensional analysis);
* ``potential_energy`` with the gravity-gradient energy 3μ/(2r³) x̂_B·I x̂_B (Arribas et al.
  eq. 20) and ``energy`` − ``potential_energy`` with the kinetic energy ½ Σ I_k ω_k².

A wrong unit string (rad → deg, an energy labelled as a momentum, km ↔ m, kg km² ↔ kg m²)
fails a conversion or a comparison; a variable added to the schema without a check here fails
the completeness assertion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from astropy import units as u
from scipy.optimize import brentq

import attitude
import orbit
from attitude.potentials import GravityGradient, HeavyTop

I_SI = u.Quantity([100.0, 200.0, 250.0], "kg m2")
W0 = u.Quantity([0.02, -0.01, 0.015], "rad / s")
Q0_ATT = np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
A = u.Quantity(7.0e6, "m")
ECC = 0.2
INC, RAAN, ARGP = u.Quantity([30.0, 45.0, 15.0], "deg")
MU = u.Quantity(3.986004418e14, "m3 / s2")
MOMENTUM = u.Unit("kg m2 / s")


def _mul(p, q):
    """Hamilton product, scalar first, written out (independent of attitude.quaternion)."""
    p0, p1, p2, p3 = np.moveaxis(np.asarray(p), -1, 0)
    q0, q1, q2, q3 = np.moveaxis(np.asarray(q), -1, 0)
    return np.stack(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ],
        axis=-1,
    )


def _conj(q):
    return np.asarray(q) * np.array([1.0, -1.0, -1.0, -1.0])


def _pure(v):
    v = np.asarray(v)
    return np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)


def _space_to_body(q, v):
    return _mul(_mul(_conj(q), _pure(v)), q)[..., 1:] / np.sum(q * q, axis=-1)[..., None]


def _body_to_space(q, v):
    return _mul(_mul(q, _pure(v)), _conj(q))[..., 1:] / np.sum(q * q, axis=-1)[..., None]


def _unit(ds, name):
    """The unit of the stored numbers: a CF time coordinate ("seconds since <epoch>") keeps
    the plain unit in ``elapsed_time_units``."""
    attrs = ds[name].attrs
    units = attrs.get("elapsed_time_units", attrs["units"])
    return u.dimensionless_unscaled if units in ("1", "") else u.Unit(units)


def _quantity(ds, name):
    return np.asarray(ds[name].values, dtype=np.float64) * _unit(ds, name)


def _kepler(t_s):
    """(r [m], f [rad], radial unit vector, orbit normal) of the closed form at times t_s [s]."""
    n = np.sqrt(MU / A**3).to_value(u.rad / u.s, equivalencies=u.dimensionless_angles())
    E = np.array(
        [
            brentq(lambda x, m=n * t: x - ECC * math.sin(x) - m, -10.0, n * t + 10.0, xtol=1e-15)
            for t in t_s
        ]
    )
    r = A.to_value(u.m) * (1.0 - ECC * np.cos(E))
    f = 2.0 * np.arctan2(np.sqrt(1 + ECC) * np.sin(E / 2), np.sqrt(1 - ECC) * np.cos(E / 2))
    i, O, w = (x.to_value(u.rad) for x in (INC, RAAN, ARGP))
    th = w + f
    radial = np.stack(
        [
            np.cos(O) * np.cos(th) - np.sin(O) * np.sin(th) * np.cos(i),
            np.sin(O) * np.cos(th) + np.cos(O) * np.sin(th) * np.cos(i),
            np.sin(th) * np.sin(i),
        ],
        axis=-1,
    )
    normal = np.array([np.sin(O) * np.sin(i), -np.cos(O) * np.sin(i), np.cos(i)])
    return r, f, radial, normal


@pytest.fixture(scope="module")
def gg_run():
    orb = orbit.KeplerOrbit(A, ECC, INC, RAAN, ARGP, f0=0.0 * u.rad, mu=MU)
    g0 = I_SI * W0 / u.rad  # angular momentum, body axes
    Q0 = 2.0 * _mul(Q0_ATT, _pure(g0.to_value(MOMENTUM))) * MOMENTUM  # Q = 2 q∘(0, g)
    t = np.linspace(0.0, 3000.0, 31)  # s
    body = attitude.RigidBody(I_SI)
    ds = attitude.propagate(body, Q0_ATT, Q0, t, potential=GravityGradient(orb), rtol=1e-12)
    return ds, t


def _check_gg(ds, t):
    """name -> check(ds) for every variable of a gravity-gradient run with units."""
    r_ref, f_ref, radial, normal = _kepler(t)
    q = ds.q.values
    w = _quantity(ds, "omega")

    def time(ds):
        np.testing.assert_allclose(_quantity(ds, "time").to_value(u.s), t, rtol=1e-15, atol=0)

    def q_(ds):
        assert _unit(ds, "q").to(u.one) == 1.0
        np.testing.assert_allclose(np.linalg.norm(_quantity(ds, "q").to_value(u.one), axis=1), 1)

    def omega(ds):
        wr = w.to_value(u.rad / u.s, equivalencies=u.dimensionless_angles())
        np.testing.assert_allclose(wr[0], W0.to_value(u.rad / u.s), rtol=1e-12)
        g = _quantity(ds, "g")
        np.testing.assert_allclose(
            (I_SI * w).to_value(MOMENTUM, equivalencies=u.dimensionless_angles()),
            g.to_value(MOMENTUM),
            rtol=1e-12,
        )

    def g(ds):
        g_si = _quantity(ds, "g").to_value(MOMENTUM)
        np.testing.assert_allclose(g_si[0], (I_SI * W0 / u.rad).to_value(MOMENTUM), rtol=1e-12)

    def G(ds):
        g_si = _quantity(ds, "g").to_value(MOMENTUM)
        np.testing.assert_allclose(
            _quantity(ds, "G").to_value(MOMENTUM), _body_to_space(q, g_si), rtol=1e-9
        )

    def Q(ds):
        g_si = _quantity(ds, "g").to_value(MOMENTUM)
        np.testing.assert_allclose(
            _quantity(ds, "Q").to_value(MOMENTUM),
            2.0 * _mul(q, _pure(g_si)),  # |q| = 1 to the run's 1e-11
            rtol=0,
            atol=1e-9 * np.max(np.abs(g_si)),
        )

    def qQ(ds):
        # q·Q has the unit of q times that of Q; its value is 0 to round-off
        expected = _quantity(ds, "q").unit * _quantity(ds, "Q").unit
        assert _quantity(ds, "qQ").unit.to(expected) == 1.0
        qQ = np.sum(_quantity(ds, "q") * _quantity(ds, "Q"), axis=1)
        np.testing.assert_allclose(
            _quantity(ds, "qQ").to_value(MOMENTUM), qQ.to_value(MOMENTUM), rtol=0, atol=1e-13
        )

    def norm_error(ds):
        assert _quantity(ds, "norm_error").unit.to(_quantity(ds, "q").unit) == 1.0
        np.testing.assert_allclose(
            _quantity(ds, "norm_error").to_value(u.one),
            np.linalg.norm(q, axis=1) - 1.0,
            rtol=0,
            atol=1e-15,
        )

    def potential_energy(ds):
        xb = _space_to_body(q, radial)
        U = 1.5 * MU / (r_ref * u.m) ** 3 * np.sum(I_SI * xb**2, axis=1)
        np.testing.assert_allclose(
            _quantity(ds, "potential_energy").to_value(u.J), U.to_value(u.J), rtol=1e-9
        )  # to the |q| drift of the non-canonical formulations (1e-10)

    def energy(ds):
        wr = w.to_value(u.rad / u.s, equivalencies=u.dimensionless_angles()) * u.Unit("1/s")
        T = 0.5 * np.sum(I_SI * wr**2, axis=1)
        kinetic = _quantity(ds, "energy") - _quantity(ds, "potential_energy")
        np.testing.assert_allclose(kinetic.to_value(u.J), T.to_value(u.J), rtol=1e-12)

    def r(ds):
        np.testing.assert_allclose(_quantity(ds, "r").to_value(u.m), r_ref, rtol=1e-13)

    def f(ds):
        d = _quantity(ds, "f").to_value(u.rad) - f_ref
        np.testing.assert_allclose(np.angle(np.exp(1j * d)), 0.0, atol=1e-12)

    def p(ds):
        pq = _quantity(ds, "p").to_value(u.one)
        np.testing.assert_allclose(_body_to_space(pq, [1.0, 0.0, 0.0]), radial, atol=1e-12)
        np.testing.assert_allclose(
            _body_to_space(pq, [0.0, 0.0, 1.0]), np.tile(normal, (len(t), 1)), atol=1e-12
        )

    def labels(name, letters):
        def check(ds):
            v = ds[name]
            if v.dtype.kind in "iu":  # CF index coordinate: 0, 1, ... with units "1"
                assert _unit(ds, name).to(u.one) == 1.0
                np.testing.assert_array_equal(v.values, np.arange(len(letters)))
            else:  # the letters themselves (a label coordinate)
                assert [str(x) for x in v.values] == letters

        return check

    def torque(ds):
        # body torque per model term and their sum (model_label "total"): here one term, the
        # gravity gradient 3μ/r³ x̂_B × I x̂_B (Arribas et al. eq. 20 differentiated)
        xb = _space_to_body(q, radial)
        tau = 3.0 * MU / (r_ref[:, None] * u.m) ** 3 * np.cross(xb, I_SI * xb)
        got = _quantity(ds, "torque").to_value(u.N * u.m)
        names = [str(x) for x in ds["model_label"].values]
        total = got[:, names.index("total")]
        np.testing.assert_allclose(total, tau.to_value(u.N * u.m), rtol=1e-9, atol=0)
        terms = [i for i, n in enumerate(names) if n != "total"]
        np.testing.assert_allclose(got[:, terms].sum(axis=1), total, rtol=1e-14)

    def model_label(ds):
        assert [str(x) for x in ds.model_label.values][-1] == "total"

    def model(ds):
        assert _unit(ds, "model").to(u.one) == 1.0
        np.testing.assert_array_equal(ds.model.values, np.arange(ds.sizes["model"]))

    return {
        "time": time, "q": q_, "Q": Q, "omega": omega, "g": g, "G": G, "energy": energy,
        "potential_energy": potential_energy, "norm_error": norm_error, "qQ": qQ, "r": r,
        "f": f, "p": p, "torque": torque, "model": model, "model_label": model_label,
        "component": labels("component", ["w", "x", "y", "z"]),
        "component_label": labels("component_label", ["w", "x", "y", "z"]),
        "axis": labels("axis", ["x", "y", "z"]),
        "axis_label": labels("axis_label", ["x", "y", "z"]),
    }  # fmt: skip


def test_every_unit_is_the_physical_one(gg_run):
    ds, t = gg_run
    checks = _check_gg(ds, t)
    missing = sorted(set(map(str, ds.variables)) - set(checks))
    assert not missing, f"variables without a unit check in tests/test_units.py: {missing}"
    for name in ds.variables:
        checks[str(name)](ds)


def test_every_unit_survives_the_netcdf_file(gg_run, tmp_path):
    """The same checks on the file as written by attitude.io, read without any decoding."""
    from attitude import io

    ds, t = gg_run
    path = io.write(ds, tmp_path / "gg.nc")
    back = xr.open_dataset(path, decode_times=False, decode_timedelta=False).load()
    checks = _check_gg(back, t)
    assert set(map(str, back.variables)) <= set(checks)
    for name in back.variables:
        checks[str(name)](back)


@pytest.mark.parametrize("method", ["splitting", "formulation:schwab"])
def test_other_runners_label_the_same_units(gg_run, method):
    """Every method and formulation returns the same schema: the same unit strings."""
    ds, t = gg_run
    orb = orbit.KeplerOrbit(A, ECC, INC, RAAN, ARGP, f0=0.0 * u.rad, mu=MU)
    kw = {"method": "splitting", "dt": 50.0} if method == "splitting" else {"formulation": "schwab"}
    other = attitude.propagate(
        attitude.RigidBody(I_SI), ds.q.values[0], ds.Q.values[0] * u.Unit(ds.Q.attrs["units"]),
        t[:3], potential=GravityGradient(orb), **kw
    )  # fmt: skip
    assert set(other.variables) == set(ds.variables)
    for name in ds.variables:
        assert other[name].attrs.get("units") == ds[name].attrs.get("units"), name
        assert other[name].attrs.get("elapsed_time_units") == ds[name].attrs.get(
            "elapsed_time_units"
        ), name
    checks = _check_gg(other, t[:3])
    for name in ("time", "q", "omega", "g", "Q", "potential_energy", "energy", "r", "f"):
        checks[name](other)


def test_dimensionless_run_is_dimensionless():
    """A body without units: every unit is dimensionless with scale 1 (radians allowed for
    angles and rates, which are pure numbers), so the numbers are the numbers of the run."""
    q0 = np.array([0.5, -1 / np.sqrt(2), 0.0, 0.5])
    w0 = np.array([0.3, -0.2, 0.1])
    g0 = np.array([1.25, 1.0, 0.75]) * w0
    Q0 = 2.0 * _mul(q0, _pure(g0))
    ds = attitude.propagate([1.25, 1.0, 0.75], q0, Q0, [0.0, 1.0], HeavyTop(0.5, [1, 0, 0]))
    for name, var in ds.variables.items():
        if var.dtype.kind in "USO":
            continue
        unit = _unit(ds, name)
        assert unit.to(u.one, equivalencies=u.dimensionless_angles()) == 1.0, name
    np.testing.assert_allclose(ds.omega.values[0], w0, rtol=1e-14)


def test_ensemble_members_carry_the_single_run_units(gg_run):
    """propagate_ensemble labels its variables like propagate, and its per-member inertia."""
    ds, t = gg_run
    orb = orbit.KeplerOrbit(A, ECC, INC, RAAN, ARGP, f0=0.0 * u.rad, mu=MU)
    q = np.tile(ds.q.values[0], (2, 1))
    Q = np.tile(ds.Q.values[0], (2, 1))  # plain numbers: the ensemble takes no Quantity Q0
    ens = attitude.propagate_ensemble(
        attitude.RigidBody(I_SI), q, Q, t[:3], GravityGradient(orb), rtol=1e-12
    )
    if not isinstance(ens, xr.Dataset):  # a lazily opened result
        ens = ens.load()
    for name in ds.data_vars:
        if name in ens:
            assert ens[name].attrs["units"] == ds[name].attrs["units"], name
    inertia = _quantity(ens, "inertia").to_value(u.Unit("kg m2"))
    np.testing.assert_allclose(inertia, np.tile(I_SI.value, (2, 1)), rtol=1e-15)
    np.testing.assert_allclose(
        _quantity(ens, "potential_energy").to_value(u.J)[0],
        _quantity(ds, "potential_energy").to_value(u.J)[:3],
        rtol=1e-9,
    )

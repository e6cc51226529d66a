"""Ensembles: many initial states (and bodies, potentials) through the same scenario.

:func:`propagate_ensemble` integrates N members, each with its own adaptive DOP853 steps, in
parallel compiled code (a numba ``prange`` loop over members, or Dask tasks on a cluster), and
returns one Dataset with a ``member`` dimension and the variables of
:func:`attitude.propagate`. Members are processed in chunks; with ``path=`` every chunk is
streamed to a netCDF4 file as soon as it is done, so memory is bounded by one chunk whatever N.

A member's result does not depend on the chunk size, the number of threads, or on whether it
ran locally or on a Dask worker: every member runs the same compiled member body from a fresh
integrator state (tests/test_ensemble.py checks all three bit for bit).

Statistics over members: :func:`pointing_error_percentiles`, :func:`rate_percentiles`.
Dispersed scenarios (the ``[ensemble]`` table of a scenario file): :func:`run_scenario`.
See docs/ensemble.md.
"""

from __future__ import annotations

import contextlib
import math
import os
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ._core import ensemble as _ke
from ._core import rk as _rk
from ._validation import as_float_array, as_times
from .body import RigidBody
from .errors import AttitudeTypeError, AttitudeValueError, PropagationError
from .io import COMPLEVEL, StreamWriter
from .potentials import Potential, as_potential
from .propagate import PROJECTION_WARN
from .results import build_dataset

__all__ = [
    "pointing_error_percentiles",
    "propagate_ensemble",
    "rate_percentiles",
    "run_scenario",
]

#: Output bytes per chunk the default chunk size aims at (states + diagnostics, float64).
CHUNK_BYTES = 32 * 2**20
#: Largest default chunk (members).
MAX_CHUNK = 4096
#: Seconds to wait for a Dask scheduler to answer.
SCHEDULER_TIMEOUT = 10.0
#: Largest relative defect of an initial state that is projected (as in propagate).
PROJECTION_TOL = 1e-6

_N_DIAG = 13
_STAT_VARS = ("member_n_steps", "member_n_rhs", "member_n_rejected", "member_status")


# ------------------------------------------------------------------------------------------------
# members: validated inputs, produced chunk by chunk
# ------------------------------------------------------------------------------------------------


class _Members:
    """Validated member inputs; :meth:`block` gives the compiled-kernel rows of a chunk.

    Keeps the caller's arrays (no per-member copies beyond one chunk).
    """

    def __init__(self, q, Q, inertia, params, n):
        self.q = q  # (N, 4) or (4,)
        self.Q = Q  # (N, 4) or (4,)
        self.inertia = inertia  # (N, 3) or (3,)
        self.params = params  # (N, P) or (P,): inertia columns overwritten per member
        self.n = n

    @property
    def per_member_inertia(self) -> bool:
        return self.inertia.ndim == 2

    @property
    def shared_inertia(self) -> np.ndarray | None:
        return None if self.inertia.ndim == 2 else self.inertia

    def _rows(self, a, start, stop):
        return a[start:stop] if a.ndim == 2 else np.broadcast_to(a, (stop - start, a.shape[-1]))

    def block(self, start: int, stop: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(params (C, P), y0 (C, 8), inertia (C, 3), max projection) of members start:stop."""
        q = self._rows(self.q, start, stop)
        Q = self._rows(self.Q, start, stop)
        qp, Qp, corr = _project(q, Q, start)
        inertia = np.ascontiguousarray(self._rows(self.inertia, start, stop))
        params = np.array(self._rows(self.params, start, stop), dtype=np.float64, order="C")
        params[:, 0:3] = inertia
        y0 = np.ascontiguousarray(np.concatenate([qp, Qp], axis=1))
        return params, y0, inertia, corr


def _project(q: np.ndarray, Q: np.ndarray, offset: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Members' states projected onto |q| = 1, q·Q = 0 (canonical.project_state, row-wise)."""
    nq = np.sqrt(np.sum(q * q, axis=1))
    dn = np.abs(nq - 1.0)
    if np.any(dn > PROJECTION_TOL):
        i = int(np.argmax(dn > PROJECTION_TOL))
        raise AttitudeValueError(
            f"q0: member {offset + i}: |q0| = {nq[i]!r} is not 1 (off by {dn[i]:.3g} > "
            f"{PROJECTION_TOL:g}); pass unit quaternions (attitude.quaternion.normalize)"
        )
    if np.any(np.all(q == 0.0, axis=1)):  # pragma: no cover - caught by the norm check
        raise AttitudeValueError("q0: the zero quaternion does not represent a rotation")
    qn = q / nq[:, None]
    qQ = np.sum(qn * Q, axis=1)
    nQ = np.sqrt(np.sum(Q * Q, axis=1))
    dq = np.abs(qQ) / np.maximum(nQ, 1.0)
    if np.any(dq > PROJECTION_TOL):
        i = int(np.argmax(dq > PROJECTION_TOL))
        raise AttitudeValueError(
            f"Q0: member {offset + i}: q0·Q0 = {qQ[i]:.3g} is not 0 (relative {dq[i]:.3g} > "
            f"{PROJECTION_TOL:g}); the momenta must be tangent to the unit sphere, e.g. "
            f"Q0 = 2 q0∘(0, g0) (attitude.canonical.momenta_from_body_angular_momentum)"
        )
    corr = float(max(np.max(dn, initial=0.0), np.max(dq, initial=0.0)))
    return qn, Q - qQ[:, None] * qn, corr


def _member_states(q0: Any, Q0: Any) -> tuple[np.ndarray, np.ndarray, int]:
    q = as_float_array(q0, "q0", trailing=4)
    Q = as_float_array(Q0, "Q0", trailing=4, unit=None)
    for name, a in (("q0", q), ("Q0", Q)):
        if a.ndim not in (1, 2):
            raise AttitudeValueError(
                f"{name}: expected shape (N, 4) (one row per member), got shape {a.shape}"
            )
    if q.ndim == 1 and Q.ndim == 1:
        raise AttitudeValueError(
            "q0, Q0: both have shape (4,), so the ensemble size N is unknown; give q0 or Q0 "
            "with shape (N, 4) (or use attitude.propagate for a single member)"
        )
    n = q.shape[0] if q.ndim == 2 else Q.shape[0]
    if q.ndim == 2 and Q.ndim == 2 and q.shape[0] != Q.shape[0]:
        raise AttitudeValueError(
            f"q0, Q0: q0 has {q.shape[0]} members (rows) but Q0 has {Q.shape[0]}; give one row "
            "per member in both (or a single (4,) row to share)"
        )
    if n == 0:
        raise AttitudeValueError(
            "q0, Q0: the ensemble is empty (N = 0 members); give at least one row"
        )
    return q, Q, n


def _member_inertia(body: Any, n: int) -> tuple[np.ndarray, str | None]:
    """Inertia (3,) shared or (N, 3) per member, and the unit label of the bodies."""
    if isinstance(body, RigidBody):
        return body.inertia, body.units
    if isinstance(body, (list, tuple)) and body and all(isinstance(b, RigidBody) for b in body):
        units = {b.units for b in body}
        if len(units) > 1:
            raise AttitudeValueError(
                f"body: the per-member bodies mix unit systems {sorted(map(str, units))}; give "
                "them all in one (e.g. all as astropy Quantities in kg m2)"
            )
        arr = np.stack([b.inertia for b in body])
        unit = body[0].units
    else:
        try:
            from astropy import units as u

            is_q = isinstance(body, u.Quantity)
        except ImportError:  # pragma: no cover
            is_q = False
        arr = as_float_array(body, "body", unit="kg m2" if is_q else None)
        unit = "kg m^2" if is_q else None  # SI, as RigidBody
        if arr.shape == (3,):
            return RigidBody(arr, units=unit).inertia, unit
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise AttitudeValueError(
            f"body: expected a RigidBody, the three principal moments (3,), or one row of "
            f"moments per member (N, 3), got shape {arr.shape}"
        )
    if arr.shape[0] != n:
        raise AttitudeValueError(
            f"body: {arr.shape[0]} rows of inertia for {n} members (the rows of q0/Q0); give "
            "one row per member, or a single body for all"
        )
    bad = np.any(arr <= 0, axis=1)
    if np.any(bad):
        i = int(np.argmax(bad))
        raise AttitudeValueError(
            f"body: member {i}: principal moments must be positive, got {arr[i].tolist()}"
        )
    tol = 1.0 - 1e-12  # as RigidBody
    for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        bad = arr[:, a] + arr[:, b] < arr[:, c] * tol
        if np.any(bad):
            i = int(np.argmax(bad))
            raise AttitudeValueError(
                f"body: member {i}: inertia {arr[i].tolist()} violates the triangle inequality "
                f"I{a + 1} + I{b + 1} >= I{c + 1}; no rigid body has these moments"
            )
    return arr, unit


def _member_potentials(potential: Any, n: int, inertia: np.ndarray):
    """(template Potential, params (P,) or (N, P), per-member potential list or None)."""
    if isinstance(potential, (list, tuple)):
        pots = list(potential)
        if len(pots) != n:
            raise AttitudeValueError(
                f"potential: {len(pots)} potentials for {n} members; give one per member or a "
                "single potential for all"
            )
        for i, p in enumerate(pots):
            if not isinstance(p, Potential):
                raise AttitudeTypeError(
                    f"potential[{i}]: expected an attitude.potentials.Potential, got "
                    f"{type(p).__name__}"
                )
            if p._kind is None:
                raise AttitudeTypeError(
                    f"potential[{i}]: per-member potentials must be built-in (TorqueFree, "
                    f"HeavyTop, GravityGradient); a {type(p).__name__} is compiled code, so "
                    "give one for all members (its numbers can live in the function)"
                )
            if p._kind != pots[0]._kind:
                raise AttitudeValueError(
                    f"potential[{i}]: all members need the same kind of potential; member 0 "
                    f"has {pots[0].name}, member {i} has {p.name}"
                )
        ref = inertia if inertia.ndim == 1 else inertia[0]
        rows = [p._params(ref) for p in pots]
        params = np.stack(rows)
        return pots[0], params, pots
    pot = as_potential(potential)
    if inertia.ndim == 1:
        pot = pot.bind(RigidBody(inertia))
    elif getattr(pot, "inertia", None) is not None:
        raise AttitudeValueError(
            "potential: this GravityGradient was built for one body (inertia=...), but the "
            "members have their own inertia; give GravityGradient(orbit) without inertia"
        )
    ref = inertia if inertia.ndim == 1 else inertia[0]
    return pot, pot._params(ref), None


# ------------------------------------------------------------------------------------------------
# one chunk in compiled code (also the Dask task)
# ------------------------------------------------------------------------------------------------


@dataclass
class _Setup:
    """What every chunk needs besides its members (picklable: shipped to Dask workers)."""

    t: np.ndarray
    rtol: float
    atol: float
    max_step: float
    max_steps: int
    user_potential: Any = None  # a CustomPotential/CustomTorque, or None for built-ins


def _compute_chunk(
    setup: _Setup, params: np.ndarray, y0: np.ndarray, *, parallel: bool
) -> dict[str, np.ndarray]:
    """Integrate the members of one chunk; arrays of the chunk's results."""
    c = y0.shape[0]
    t = setup.t
    m = t.shape[0]
    out = {
        "y": np.empty((c, m, 8)),
        "diag": np.empty((c, m, _N_DIAG)),
        "counters": np.empty((c, 5), dtype=np.int64),
        "status": np.empty(c, dtype=np.int64),
        "n_done": np.empty(c, dtype=np.int64),
    }
    work = np.empty((c, _rk.WORK_ROWS, 8))
    tstate = np.empty((c, 4))
    if setup.user_potential is None:
        fn = _ke.run_builtin_parallel if parallel else _ke.run_builtin_serial
    else:
        torque, potential = setup.user_potential._kernels()
        fn = _ke.make_user_drivers(torque, potential)[0 if parallel else 1]
    fn(
        params,
        y0,
        t,
        out["y"],
        out["diag"],
        work,
        tstate,
        out["counters"],
        out["status"],
        out["n_done"],
        setup.rtol,
        setup.atol,
        setup.max_step,
        setup.max_steps,
    )
    out["t_stop"] = tstate[:, 0].copy()  # time each member's integration reached
    return out


def _chunk_task(setup: _Setup, params: np.ndarray, y0: np.ndarray) -> dict[str, np.ndarray]:
    """A chunk as a Dask task: the serial (GIL-free) driver; the worker threads parallelise."""
    return _compute_chunk(setup, params, y0, parallel=False)


#: Members handed to a thread at a time by the parallel loop (dynamic scheduling: a thread that
#: gets less CPU, or slower members, does not hold the others up at the end of a chunk).
PARALLEL_CHUNK = 8


@contextlib.contextmanager
def _numba_threads(threads: int | None):
    """Run the parallel driver with ``threads`` numba threads (restored afterwards)."""
    from orbit._jit import JIT_DISABLED

    if JIT_DISABLED:
        yield
        return
    import numba

    old = numba.get_num_threads()
    old_chunk = numba.set_parallel_chunksize(PARALLEL_CHUNK)
    if threads is not None:
        numba.set_num_threads(int(threads))
    try:
        yield
    finally:
        numba.set_num_threads(old)
        numba.set_parallel_chunksize(old_chunk)


# ------------------------------------------------------------------------------------------------
# assembling chunks into Datasets
# ------------------------------------------------------------------------------------------------


class _Assembler:
    """Turns the arrays of a chunk into a Dataset with a ``member`` dimension; keeps totals."""

    def __init__(self, t, unit, pot, pots, attrs):
        self.t = t
        self.pot = pot
        self.pots = pots
        body = RigidBody(np.ones(3), units=unit) if unit else RigidBody(np.ones(3))
        m = t.shape[0]
        # The single-run schema, for the variables' names, dims, units and long names.
        # (with the run's epoch, if any: the CF time units follow it)
        epoch = {k: v for k, v in (attrs or {}).items() if k == "epoch" and v}
        tmpl = build_dataset(t, np.zeros((m, 8)), np.zeros((m, _N_DIAG)), body, pot, epoch)
        self.template = tmpl
        self.per_member_orbit = pots is not None and getattr(pot, "orbit", None) is not None
        self.attrs = {k: v for k, v in tmpl.attrs.items() if k != "inertia"}
        self.attrs["history"] = str(tmpl.attrs["history"]).replace(
            ": propagate", ": propagate_ensemble"
        )
        self.attrs.update(attrs)
        self.totals = {"n_steps": 0, "n_rhs": 0, "n_rejected": 0}
        self.max_projection = 0.0
        self.inv: dict[str, float] = {}
        self.n_members = 0

    def dataset(self, start, out, inertia, lazy: bool = False) -> xr.Dataset:
        """The chunk's Dataset; ``lazy``: ``out`` holds dask arrays, kept as they are."""

        def arr(x, dtype=None):
            if lazy:
                return x if dtype is None else x.astype(dtype)
            return np.ascontiguousarray(x, dtype=dtype)

        c = out["y"].shape[0]
        y, d = out["y"], out["diag"]
        cols = {
            "q": y[:, :, :4],
            "Q": y[:, :, 4:],
            "omega": d[:, :, 0:3],
            "g": d[:, :, 3:6],
            "G": d[:, :, 6:9],
            "energy": d[:, :, 9],
            "potential_energy": d[:, :, 12],
            "norm_error": d[:, :, 10],
            "qQ": d[:, :, 11],
        }
        tm = self.template
        data_vars: dict[str, Any] = {}
        for name, da in tm.data_vars.items():
            if name in cols:
                data_vars[name] = xr.Variable(("member", *da.dims), arr(cols[name]), da.attrs)
            elif self.per_member_orbit:  # r, f, p of each member's own orbit
                vals = [self._orbit_var(p.orbit, name) for p in self.pots[start : start + c]]
                data_vars[name] = xr.Variable(("member", *da.dims), np.stack(vals), da.attrs)
            else:
                data_vars[name] = da.variable
        inertia_units = self.template.attrs.get("inertia_units", "1")
        data_vars["inertia"] = xr.Variable(
            ("member", "axis"),
            np.ascontiguousarray(inertia),
            {"units": inertia_units, "long_name": "principal moments of inertia (I1, I2, I3)"},
        )
        cnt = out["counters"]
        for name, col, long in (
            ("member_n_steps", cnt[:, 0], "accepted integration steps"),
            ("member_n_rhs", cnt[:, 1], "right-hand side evaluations"),
            ("member_n_rejected", cnt[:, 2], "rejected integration steps"),
            ("member_status", out["status"], "integration status (0: success)"),
        ):
            data_vars[name] = xr.Variable(
                ("member",),
                arr(col, np.int64),
                {"units": "1", "long_name": long},
            )
        coords = {
            "member": (
                "member",
                np.arange(start, start + c, dtype=np.int64),
                {"long_name": "ensemble member index"},
            ),
            **{k: v.variable for k, v in tm.coords.items()},
        }
        return xr.Dataset(data_vars, coords=coords, attrs=dict(self.attrs))

    def _orbit_var(self, orbit, name):
        from .results import _plain

        if name == "r":
            return _plain(orbit.radius(self.t), "km")
        if name == "f":
            return _plain(orbit.true_anomaly(self.t), "rad")
        return _plain(orbit.frame_quaternion(self.t), None)

    def account(self, out) -> None:
        """Add a successful chunk to the totals and invariant maxima."""
        cnt = out["counters"]
        self.totals["n_steps"] += int(cnt[:, 0].sum())
        self.totals["n_rhs"] += int(cnt[:, 1].sum())
        self.totals["n_rejected"] += int(cnt[:, 2].sum())
        self.n_members += cnt.shape[0]
        d = out["diag"]
        upd = {
            "max_abs_norm_error": float(np.max(np.abs(d[:, :, 10]))),
            "max_abs_qQ": float(np.max(np.abs(d[:, :, 11]))),
        }
        # Conserved quantities per member (as scenario.InvariantTracker, maximised over members).
        E = d[:, :, 9]
        sE = np.maximum(np.abs(E[:, :1]), np.finfo(float).tiny)
        dE = float(np.max(np.abs(E - E[:, :1]) / sE))
        G = d[:, :, 6:9]
        sG = np.maximum(np.linalg.norm(G[:, :1], axis=-1), 1e-300)
        name = self.pot.name
        if name in ("torque_free", "heavy_top"):
            upd["max_rel_energy_error"] = dE
        else:
            upd["max_rel_energy_variation"] = dE
        if name == "torque_free":
            upd["max_rel_G_error"] = float(np.max(np.linalg.norm(G - G[:, :1], axis=-1) / sG))
        if name == "heavy_top":
            upd["max_rel_Gz_error"] = float(np.max(np.abs(G[:, :, 2] - G[:, :1, 2]) / sG))
        for k, v in upd.items():
            self.inv[k] = max(self.inv.get(k, 0.0), v)

    def final_attrs(self, status: str) -> dict[str, Any]:
        a = dict(self.attrs)
        a.update({k: np.int64(v) for k, v in self.totals.items()})
        a.update(self.inv)
        a["initial_projection"] = float(self.max_projection)
        a["n_members_written"] = np.int64(self.n_members)
        a["run_status"] = status
        return a


class _MemberWriter(StreamWriter):
    """:class:`attitude.io.StreamWriter` appending along ``member`` (unlimited) instead of time.

    Variables without a ``member`` dimension (time, orbit of a shared orbit) are written once.
    """

    def _create(self, ds: xr.Dataset) -> None:
        import netCDF4

        from .io import _set_attrs, _variable_attrs

        self.path.parent.mkdir(parents=True, exist_ok=True)
        nc = netCDF4.Dataset(self.tmp, "w", format="NETCDF4")
        self._nc = nc
        nc.createDimension("member", None)
        for dim, size in ds.sizes.items():
            if dim != "member":
                nc.createDimension(dim, size)
        comp = {"zlib": self.complevel > 0, "complevel": max(self.complevel, 1), "shuffle": True}
        for name in [*ds.coords, *ds.data_vars]:
            var = ds[name].variable
            if var.dtype.kind in "UO":
                v = nc.createVariable(name, str, var.dims)
                v[:] = np.asarray(var.values, dtype=object)
            elif "member" in var.dims:
                chunks = self._chunks(var)
                v = nc.createVariable(name, var.dtype, var.dims, chunksizes=chunks, **comp)
                # A chunk cache of two netCDF chunks: complete chunks are written out at once
                # instead of accumulating in HDF5's cache (memory would grow with N).
                nbytes = var.dtype.itemsize * int(np.prod(chunks))
                v.set_var_chunk_cache(size=2 * nbytes + 4096, nelems=17, preemption=1.0)
                self._vars.append(name)
            else:
                v = nc.createVariable(name, var.dtype, var.dims)
                v[:] = var.values
            _set_attrs(v, _variable_attrs(ds, name))  # CF "coordinates" of the label variables

    @staticmethod
    def _chunks(var: xr.Variable) -> list[int]:
        # About 1 MiB per netCDF chunk: all of each member's record, as many members as fit.
        rest = list(var.shape[1:])
        per = 8 * int(np.prod(rest)) if rest else 8
        while per > 2**20 and rest:  # very long records: cut the time axis
            i = int(np.argmax(rest))
            rest[i] = max(1, rest[i] // 2)
            per = 8 * int(np.prod(rest))
        members = int(max(1, min(var.shape[0], 2**20 // per)))
        return [members, *rest]

    def append(self, ds: xr.Dataset) -> None:
        if self._done:
            raise AttitudeValueError("append: the file was already committed or aborted")
        if self._nc is None:
            self._create(ds)
            self.attrs = dict(ds.attrs)
        k = ds.sizes["member"]
        for name in self._vars:
            self._nc.variables[name][self.n : self.n + k, ...] = ds[name].values
        self.n += k


# ------------------------------------------------------------------------------------------------
# Dask
# ------------------------------------------------------------------------------------------------


def _connect(client: Any, timeout: float):
    """(client, owned): a connected ``distributed.Client`` (``owned``: we must close it)."""
    try:
        import distributed
    except ImportError:
        raise AttitudeValueError(
            "client: Dask is not installed; install the optional extra "
            "(pip install 'attitude[dask]') or run without a client (local threads)"
        ) from None
    if isinstance(client, str):
        try:
            return distributed.Client(client, timeout=timeout, set_as_default=False), True
        except Exception as exc:  # OSError, TimeoutError, ValueError (bad address)...
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise AttitudeValueError(
                f"scheduler: no Dask scheduler answered at {client!r} within {timeout:g} s "
                f"({type(exc).__name__}: {msg}); check the address (e.g. tcp://host:8786) "
                "and that the scheduler is running. Nothing was written."
            ) from None
    if not isinstance(client, distributed.Client):
        raise AttitudeTypeError(
            f"client: expected a dask.distributed.Client or a scheduler address string, got "
            f"{type(client).__name__}"
        )
    if client.status not in ("running", "newly-created"):
        raise AttitudeValueError(f"client: the Dask client is {client.status}, not running")
    return client, False


def _worker_threads(client) -> int:
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # pragma: no cover - scheduler gone: the tasks will say so
        return 1


# ------------------------------------------------------------------------------------------------
# the entry point
# ------------------------------------------------------------------------------------------------


def _positive(x: Any, name: str) -> float:
    v = float(as_float_array(x, name))
    if not v > 0:
        raise AttitudeValueError(f"{name}: must be a positive number, got {v}")
    return v


def _default_chunk(n: int, m: int, threads: int) -> int:
    """Members per chunk: about 20 chunks (progress), at least 16 per thread (balance), at
    most :data:`MAX_CHUNK` and ~:data:`CHUNK_BYTES` of output (memory)."""
    per_member = m * (8 + _N_DIAG) * 8
    cap = min(MAX_CHUNK, max(1, CHUNK_BYTES // per_member))
    want = max(-(-n // 20), 16 * threads)
    return max(1, min(want, max(cap, threads)))


def propagate_ensemble(
    bodies_or_body: RigidBody | Any,
    q0: Any,
    Q0: Any,
    t: Any,
    potential: Potential | Sequence[Potential] | None = None,
    method: str = "dop853",
    rtol: float = 1e-10,
    atol: float = 1e-12,
    *,
    max_step: float = math.inf,
    max_steps: int = 100_000_000,
    chunk_size: int | None = None,
    path: str | os.PathLike | None = None,
    client: Any = None,
    threads: int | None = None,
    progress: Callable[[int, int, int], None] | None = None,
    scheduler_timeout: float | None = None,
    attrs: dict[str, Any] | None = None,
    lazy: bool = False,
    _source: Any = None,
) -> xr.Dataset:
    """Propagate an ensemble of N members in parallel compiled code.

    Each member is integrated independently by the compiled DOP853 loop of
    :func:`attitude.propagate` (Hamilton's equations in (q, Q), Arribas et al. eq. 7, with the
    torque as the generalised force of Schwab eq. 25), with its own adaptive steps.

    Parameters
    ----------
    bodies_or_body : RigidBody, array_like shape (3,) or (N, 3), or sequence of N RigidBody
        One body for all members, or one row of principal moments per member (an astropy
        Quantity is converted to kg m² (SI); plain numbers are dimensionless, as in ``propagate``).
    q0 : array_like, shape (N, 4)
        Initial attitudes (body → space, scalar first). A single (4,) row is shared by all.
    Q0 : array_like, shape (N, 4)
        Initial conjugate momenta Q0 = 2 q0∘(0, g0). A single (4,) row is shared by all.
        States within 1e-6 of |q| = 1, q·Q = 0 are projected (as in ``propagate``).
    t : array_like, shape (m,)
        Output times shared by all members, strictly monotonic; ``t[0]`` is the initial epoch.
    potential : Potential or sequence of N Potentials, optional
        One potential for all (default torque-free), or one built-in potential per member, all
        of the same kind (e.g. ``[GravityGradient(orbit_i) for ...]`` for per-member orbits,
        ``HeavyTop`` with per-member weights). ``CustomPotential``/``CustomTorque`` are
        supported as one potential for all members (their kernels are compiled per process).
    method : str
        ``"dop853"`` (the only method of the compiled ensemble loop).
    rtol, atol : float
        Tolerances of DOP853, per state component (as in ``propagate``).
    max_step : float
        Largest step.
    max_steps : int
        A member that needs more steps fails (see Raises).
    chunk_size : int, optional
        Members per chunk. Default: about N / 20 (a progress report per chunk), at least 16
        per thread, at most 4096 and ~32 MiB of output. Results do not depend on it; memory
        does (one chunk: ~2 kB of work arrays plus m × 168 bytes of output per member).
    path : str or Path, optional
        Stream each chunk to this netCDF4 file as soon as it is computed (atomic: written to a
        temporary file, renamed at the end). Memory then stays bounded by one chunk, and the
        returned Dataset reads the file lazily (close it with ``ds.close()``).
    client : dask.distributed.Client or str, optional
        Run the chunks as tasks on a Dask cluster (a Client, or a scheduler address such as
        ``"tcp://10.0.0.1:8786"``). ``None`` (default): local threads, no Dask needed.
        Workers need ``attitude`` importable; the results are gathered chunk by chunk, in
        member order, and written by this process (no shared file system needed).
    threads : int, optional
        Local run: number of numba threads of the parallel loop (default: numba's, all cores).
    progress : callable, optional
        ``progress(n_done, n_total, n_steps_done)`` after each chunk (members done so far).
    scheduler_timeout : float, optional
        Seconds to wait for a scheduler given by address (default :data:`SCHEDULER_TIMEOUT`,
        10 s).
    attrs : dict, optional
        Extra global attributes of the result.
    lazy : bool
        Return a dask-backed Dataset at once, one task per chunk, computed on access by
        Dask's current scheduler (a ``Client`` you created is it); with ``path`` it is
        written with
        ``Dataset.to_netcdf``, computed by ``client`` (on a cluster the workers write, so
        they must see ``path``: a shared file system). ``progress`` is not called. All or
        nothing: a failing member raises when computed and
        nothing is kept; totals (``n_steps``...) are not in the attrs (sum
        ``member_n_steps``). Default False: chunks are computed eagerly, in member order,
        and streamed by this process, keeping completed chunks on failure.

    Returns
    -------
    xarray.Dataset
        Dimensions ``member`` (coordinate: the member index), ``time``, ``component``,
        ``axis``. Variables of :func:`attitude.propagate` with a leading ``member`` dimension
        (``q``, ``Q``, ``omega``, ``g``, ``G``, ``energy``, ``potential_energy``,
        ``norm_error``, ``qQ``; ``r``, ``f``, ``p`` with an orbit: per member only when the
        orbits are), plus ``inertia`` (member, axis) and per-member statistics
        ``member_n_steps``, ``member_n_rhs``, ``member_n_rejected``, ``member_status``.
        Attrs: totals ``n_steps``, ``n_rhs``, ``n_rejected``, ``ensemble_size``,
        ``chunk_size``, invariant maxima over members (``max_abs_norm_error``...),
        ``run_status``.

    Raises
    ------
    AttitudeValueError, AttitudeTypeError
        Bad input (shapes of q0, Q0, body or potentials that do not match, N = 0, a method
        other than dop853, a scheduler that does not answer within ``scheduler_timeout``),
        before any work and before anything is written.
    PropagationError
        Some members of a chunk failed (non-finite state, too many steps...), or a chunk's
        task failed on the cluster. The message names the members; chunks completed before
        are kept (in ``path``, committed with ``run_status = "failed: ..."``, and in
        ``.partial``).

    Notes
    -----
    Memory without ``path`` is that of the whole result, ``N × m × 21 × 8`` bytes; with
    ``path`` it is one chunk. See docs/ensemble.md for Dask clusters and dispersions.
    """
    body = bodies_or_body
    t_start = time.perf_counter()
    if method != "dop853":
        raise AttitudeValueError(
            f"method: propagate_ensemble runs 'dop853' only (the compiled parallel loop), got "
            f"{method!r}; for other methods loop over attitude.propagate"
        )
    tt = as_times(t, "t")
    rtol = _positive(rtol, "rtol")
    atol = _positive(atol, "atol")
    if rtol < 1e-15:
        raise AttitudeValueError(
            f"rtol: {rtol:g} is below what double precision can deliver; use >= 1e-15"
        )
    if not (isinstance(max_step, (int, float)) and max_step == math.inf):
        max_step = _positive(max_step, "max_step")
    if not isinstance(max_steps, (int, np.integer)) or isinstance(max_steps, bool):
        raise AttitudeValueError(f"max_steps: expected a positive integer, got {max_steps!r}")
    if max_steps <= 0:
        raise AttitudeValueError(f"max_steps: expected a positive integer, got {max_steps!r}")
    for name, v in (("chunk_size", chunk_size), ("threads", threads)):
        if v is not None and (not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1):
            raise AttitudeValueError(f"{name}: expected a positive integer, got {v!r}")
    if progress is not None and not callable(progress):
        raise AttitudeTypeError("progress: expected a callable progress(n_done, n_total, steps)")
    if scheduler_timeout is None:
        scheduler_timeout = SCHEDULER_TIMEOUT
    timeout = _positive(scheduler_timeout, "scheduler_timeout")

    if _source is None:
        q, Q, n = _member_states(q0, Q0)
        inertia, unit = _member_inertia(body, n)
        pot, params, pots = _member_potentials(potential, n, inertia)
        members = _Members(q, Q, inertia, params, n)
        for start in range(0, n, 65536):  # validate every state before any work
            stop = min(n, start + 65536)
            _project(members._rows(q, start, stop), members._rows(Q, start, stop), start)
    else:  # a dispersion sampler (run_scenario): already validated
        members, unit, pot, pots = _source
        n = members.n
    user = pot if pot._kernels() is not None else None

    out_path = None if path is None else Path(path)
    if out_path is not None and out_path.is_dir():
        raise AttitudeValueError(f"path: {out_path} is a directory; give a file name")

    owned = False
    if lazy:
        try:
            import dask  # noqa: F401
        except ImportError:
            raise AttitudeValueError(
                "lazy: needs Dask; install the optional extra (pip install 'attitude[dask]')"
            ) from None
        if isinstance(client, str) and path is None:
            raise AttitudeValueError(
                "lazy: a lazy result without a path keeps using the cluster; pass a "
                "dask.distributed.Client (that you close), not an address"
            )
    if client is not None:
        client, owned = _connect(client, timeout)
        if user is not None:
            import cloudpickle

            try:
                cloudpickle.dumps(user)
            except Exception as exc:
                raise AttitudeTypeError(
                    f"potential: this {type(user).__name__} cannot be shipped to Dask workers "
                    f"({type(exc).__name__}: {exc}); run it locally (client=None)"
                ) from None
        n_threads = _worker_threads(client)
    else:
        from orbit._jit import JIT_DISABLED

        if threads is not None:
            n_threads = int(threads)
        elif JIT_DISABLED:
            n_threads = 1
        else:
            import numba

            n_threads = numba.get_num_threads()
    m = tt.shape[0]
    csize = int(chunk_size) if chunk_size is not None else _default_chunk(n, m, n_threads)
    csize = min(csize, n)
    setup = _Setup(tt, rtol, atol, float(max_step), int(max_steps), user)
    run_attrs: dict[str, Any] = {
        "title": "attitude ensemble propagation",
        "method": method,
        "formulation": "canonical",
        "rtol": rtol,
        "atol": atol,
        "ensemble_size": np.int64(n),
        "chunk_size": np.int64(csize),
        "execution": "dask" if client is not None else f"local threads ({n_threads})",
    }
    if pots is not None:
        run_attrs["potential"] = f"{n} per-member potentials, member 0: {pot.describe()}"
    if not math.isinf(max_step):
        run_attrs["max_step"] = float(max_step)
    if attrs:
        run_attrs.update(attrs)
    asm = _Assembler(tt, unit, pot, pots, run_attrs)
    if members.shared_inertia is not None:
        asm.attrs["inertia"] = np.asarray(members.shared_inertia, dtype=np.float64)

    bounds = [(s, min(n, s + csize)) for s in range(0, n, csize)]
    if lazy:
        asm.attrs["run_status"] = "lazy: computed on access; a failing member raises"
        try:
            ds = _lazy_result(setup, members, bounds, asm)
            ds.attrs["initial_projection"] = float(asm.max_projection)
            if out_path is None:
                return ds
            _write_lazy(ds, out_path, client)
        finally:
            if owned:
                with contextlib.suppress(Exception):
                    client.close()
        return _open_result(out_path, csize, True)

    writer = _MemberWriter(out_path, complevel=COMPLEVEL) if out_path is not None else None
    kept: list[xr.Dataset] = []
    failure: PropagationError | None = None
    try:
        try:
            if client is None:
                results = _local_results(setup, members, bounds, threads)
            else:
                results = _dask_results(client, setup, members, bounds, n_threads)
            for (start, stop), got in zip(bounds, results, strict=False):
                if isinstance(got, BaseException):
                    raise PropagationError(
                        f"chunk of members {start}..{stop - 1} failed: {type(got).__name__}: {got}"
                    ) from got
                out, inertia, corr = got
                bad = np.flatnonzero(out["status"] != _rk.SUCCESS)
                if bad.size:
                    msg, t_fail = _failure_message(out, bad, start, tt)
                    raise PropagationError(msg, time=t_fail)
                asm.max_projection = max(asm.max_projection, corr)
                asm.account(out)
                ds = asm.dataset(start, out, inertia)
                if writer is not None:
                    writer.append(ds)
                else:
                    kept.append(ds)
                if progress is not None:
                    progress(stop, n, asm.totals["n_steps"])
        except PropagationError as exc:
            failure = exc
        status = "complete" if failure is None else f"failed: {failure}"
        final = asm.final_attrs(status)
        final["wall_time"] = time.perf_counter() - t_start
        if writer is not None:
            if writer.n:
                writer.attrs = final
                writer.commit()
            else:
                writer.abort()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    finally:
        if owned:
            with contextlib.suppress(Exception):
                client.close()
    if asm.max_projection > PROJECTION_WARN:
        warnings.warn(
            f"initial states projected onto |q| = 1, q·Q = 0 (largest correction "
            f"{asm.max_projection:.2g})",
            stacklevel=2,
        )

    if writer is not None:
        result = _open_result(out_path, csize, client is not None) if writer.n else None
    else:
        result = _concat(kept, final) if kept else None
    if failure is not None:
        where = f"; members 0..{asm.n_members - 1} are in {out_path}" if writer and writer.n else ""
        raise PropagationError(
            f"{failure}{where}", time=failure.time, partial=result
        ) from failure.__cause__
    return result


def _failure_message(out, bad, start, t) -> tuple[str, float]:
    idx = [int(start + i) for i in bad]
    shown = ", ".join(map(str, idx[:10])) + (f", ... ({len(idx)} in all)" if len(idx) > 10 else "")
    first = int(bad[0])
    msg = _rk.STATUS_MESSAGES.get(int(out["status"][first]), "failed")
    k = int(out["n_done"][first])
    t_stop = float(out["t_stop"][first])
    return (
        f"member(s) {shown} failed: member {idx[0]} stopped at t = {t_stop!r}: {msg} "
        f"({k} of {t.shape[0]} output samples computed)",
        t_stop,
    )


def _local_results(setup, members, bounds, threads):
    """Chunks computed here with the parallel driver, one after the other (generator)."""
    from orbit._jit import JIT_DISABLED

    for start, stop in bounds:
        try:
            params, y0, inertia, corr = members.block(start, stop)
            with _numba_threads(threads):
                if JIT_DISABLED:
                    out = _compute_chunk(setup, params, y0, parallel=False)
                else:
                    out = _compute_chunk(setup, params, y0, parallel=True)
        except (AttitudeValueError, AttitudeTypeError):
            raise
        except Exception as exc:
            yield exc
            return
        yield out, inertia, corr


def _dask_results(client, setup, members, bounds, n_threads):
    """Chunks as Dask tasks, a bounded window in flight, results yielded in member order."""
    from collections import deque

    window = max(2, 2 * n_threads)
    setup_f = client.scatter(setup, broadcast=True, hash=False)
    pending: deque = deque()
    nxt = 0
    while pending or nxt < len(bounds):
        while nxt < len(bounds) and len(pending) < window:
            start, stop = bounds[nxt]
            params, y0, inertia, corr = members.block(start, stop)
            fut = client.submit(
                _chunk_task, setup_f, params, y0, pure=False, priority=-nxt, retries=0
            )
            pending.append((fut, inertia, corr))
            nxt += 1
        fut, inertia, corr = pending.popleft()
        try:
            out = fut.result()
        except Exception as exc:
            for f, _, _ in pending:
                f.cancel()
            yield exc
            return
        finally:
            fut.release()
        yield out, inertia, corr


def _lazy_task(setup: _Setup, params: np.ndarray, y0: np.ndarray, start: int):
    """A chunk as a task of the lazy graph: raises if a member failed (naming it)."""
    out = _compute_chunk(setup, params, y0, parallel=False)
    bad = np.flatnonzero(out["status"] != _rk.SUCCESS)
    if bad.size:
        msg, t_fail = _failure_message(out, bad, start, setup.t)
        raise PropagationError(msg, time=t_fail)
    return out


def _lazy_result(setup, members, bounds, asm) -> xr.Dataset:
    """The ensemble as a dask-backed Dataset: one task per chunk, nothing computed yet."""
    import dask
    import dask.array as dsa

    m = setup.t.shape[0]
    setup_d = dask.delayed(setup, traverse=False)
    parts = []
    for start, stop in bounds:
        params, y0, inertia, corr = members.block(start, stop)
        asm.max_projection = max(asm.max_projection, corr)
        c = stop - start
        task = dask.delayed(_lazy_task, pure=True)(setup_d, params, y0, start)
        out = {
            "y": dsa.from_delayed(task["y"], (c, m, 8), np.float64),
            "diag": dsa.from_delayed(task["diag"], (c, m, _N_DIAG), np.float64),
            "counters": dsa.from_delayed(task["counters"], (c, 5), np.int64),
            "status": dsa.from_delayed(task["status"], (c,), np.int64),
        }
        parts.append(asm.dataset(start, out, inertia, lazy=True))
    if len(parts) == 1:
        return parts[0]
    return xr.concat(parts, dim="member", data_vars="minimal", coords="minimal", compat="override")


def _write_lazy(ds: xr.Dataset, path: Path, client: Any) -> None:
    """``ds.to_netcdf`` to a temporary name, computed by ``client`` (or dask), then renamed."""
    from .io import _attr_value, _tmp_path

    ds = ds.copy()
    ds.attrs = {k: _attr_value(k, v) for k, v in ds.attrs.items() if v is not None}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _tmp_path(path)
    try:
        # CF: coordinate variables have no _FillValue (xarray adds NaN to floats by default)
        enc = {c: {"_FillValue": None} for c in ds.coords if ds[c].dtype.kind == "f"}
        job = ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", compute=False, encoding=enc)
        if client is not None:
            client.compute(job).result()
        else:
            job.compute()
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        raise


def _concat(parts: list[xr.Dataset], attrs: dict[str, Any]) -> xr.Dataset:
    if len(parts) == 1:
        ds = parts[0]
    else:
        data_vars = {}
        first = parts[0]
        for name, da in first.data_vars.items():
            if "member" in da.dims:
                data_vars[name] = xr.Variable(
                    da.dims, np.concatenate([p[name].values for p in parts]), da.attrs
                )
            else:
                data_vars[name] = da.variable
        coords: dict[str, Any] = {
            k: v.variable for k, v in first.coords.items() if "member" not in v.dims
        }
        coords["member"] = (
            "member",
            np.concatenate([p["member"].values for p in parts]),
            first["member"].attrs,
        )
        ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs = dict(attrs)
    return ds


def _open_result(path: Path, chunk: int, dask: bool) -> xr.Dataset:
    from .io import read

    ds = read(path, load=False)
    if dask:
        ds = ds.chunk({"member": chunk})
    return ds


# ------------------------------------------------------------------------------------------------
# dispersions: the [ensemble] table of a scenario
# ------------------------------------------------------------------------------------------------

_DISTRIBUTIONS = ("normal", "uniform")
#: Normal inertia errors are truncated at this many standard deviations (so every member is
#: a rigid body; checked for the worst case before any work).
INERTIA_TRUNCATION = 3.0
#: Uniform draws per member (3 attitude, 3 rate, 3 inertia; padded to whole Philox blocks).
_DRAWS = 12


@dataclass
class Dispersions:
    """Monte Carlo dispersions about a scenario's nominal initial state.

    Member ``i`` (0-based) of the ensemble is

    * attitude ``q_i = q0 ∘ exp(δθ_i / 2)``: a small rotation ``δθ_i`` (rotation vector, body
      axes, rad) applied in the body frame;
    * body rate ``ω_i = ω0 + δω_i`` with ω0 = g0 / I the nominal body angular velocity and
      ``δω_i`` per body axis (rad per time unit);
    * inertia ``I_i = I ∘ (1 + ε_i)``, per axis, relative;
    * momenta ``Q_i = 2 q_i ∘ (0, I_i ω_i)``.

    Each error has a distribution per axis: ``"normal"`` (the value is the standard
    deviation; inertia errors truncated at ±3σ) or ``"uniform"`` (the value is the
    half-width). The draws of member ``i`` come from a counter-based generator (Philox) at
    position ``i``: they do not depend on the ensemble size or on the chunking, so the first
    1000 members of a 10⁶-member run are those of a 1000-member run with the same seed.
    """

    size: int
    seed: int = 0
    chunk: int | None = None
    attitude_error: float = 0.0
    attitude_distribution: str = "normal"
    rate_error: float = 0.0
    rate_distribution: str = "normal"
    inertia_error: float = 0.0
    inertia_distribution: str = "normal"
    key: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self.key = np.random.SeedSequence(self.seed).generate_state(2, np.uint64)

    def uniforms(self, start: int, stop: int) -> np.ndarray:
        """The (stop − start, 12) uniform draws in (0, 1) of members start..stop−1."""
        bg = np.random.Philox(key=self.key, counter=start * (_DRAWS // 4))
        u = np.random.Generator(bg).random((stop - start, _DRAWS))
        return u + 2.0**-54  # k 2⁻⁵³ + 2⁻⁵⁴: strictly inside (0, 1), symmetric about ½

    @staticmethod
    def _transform(u: np.ndarray, width: float, dist: str, truncate: float | None = None):
        if width == 0.0:
            return np.zeros_like(u)
        if dist == "uniform":
            return width * (2.0 * u - 1.0)
        from scipy.special import ndtr, ndtri

        if truncate is None:
            return width * ndtri(u)
        lo = ndtr(-truncate)
        return width * ndtri(lo + u * (1.0 - 2.0 * lo))

    def max_inertia_error(self) -> float:
        """Largest relative inertia error any member can get."""
        if self.inertia_distribution == "uniform":
            return self.inertia_error
        return INERTIA_TRUNCATION * self.inertia_error

    def check_body(self, inertia: np.ndarray, where: str = "ensemble.inertia_error") -> None:
        """Raise unless every dispersed inertia is a rigid body (worst case, before any work)."""
        eps = self.max_inertia_error()
        if eps >= 1.0:
            raise AttitudeValueError(
                f"{where}: a relative error up to {eps:g} can make a moment of inertia zero or "
                "negative; use a smaller error"
            )
        for a, b, c in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            if (inertia[a] + inertia[b]) * (1.0 - eps) < inertia[c] * (1.0 + eps):
                raise AttitudeValueError(
                    f"{where}: with relative errors up to {eps:g} some members would violate "
                    f"the triangle inequality I{a + 1} + I{b + 1} >= I{c + 1} (the body "
                    f"{inertia.tolist()} is too close to it); use a smaller error"
                    + (" or inertia_distribution = 'uniform'" if eps > self.inertia_error else "")
                )

    def sample(
        self, q0: np.ndarray, Q0: np.ndarray, inertia: np.ndarray, start: int, stop: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Initial states and inertia of members start..stop−1 about the nominal (q0, Q0, I).

        Returns
        -------
        q : ndarray, shape (C, 4)
        Q : ndarray, shape (C, 4)
        inertia : ndarray, shape (C, 3)
        """
        from .quaternion import from_rotation_vector, multiply

        u = self.uniforms(start, stop)
        dtheta = self._transform(u[:, 0:3], self.attitude_error, self.attitude_distribution)
        domega = self._transform(u[:, 3:6], self.rate_error, self.rate_distribution)
        eps = self._transform(
            u[:, 6:9], self.inertia_error, self.inertia_distribution, INERTIA_TRUNCATION
        )
        # Nominal body rate ω0 = g0 / I, g0 = ½ vec(q̃0∘Q0) (Arribas et al. eq. 17).
        w = multiply(q0 * np.array([1.0, -1.0, -1.0, -1.0]), Q0)
        omega0 = 0.5 * w[1:] / inertia
        q = multiply(q0, from_rotation_vector(dtheta))
        inert = inertia * (1.0 + eps)
        g = inert * (omega0 + domega)
        Q = 2.0 * multiply(q, np.concatenate([np.zeros((g.shape[0], 1)), g], axis=1))
        return q, Q, inert

    def attrs(self) -> dict[str, Any]:
        """Global attrs recording the dispersions (internal units: rad, rad per time unit)."""
        return {
            "ensemble_seed": np.int64(self.seed),
            "ensemble_attitude_error": float(self.attitude_error),
            "ensemble_attitude_distribution": self.attitude_distribution,
            "ensemble_rate_error": float(self.rate_error),
            "ensemble_rate_distribution": self.rate_distribution,
            "ensemble_inertia_error": float(self.inertia_error),
            "ensemble_inertia_distribution": self.inertia_distribution,
            "ensemble_sampling": (
                "member i: Philox(SeedSequence(seed)) at counter 3 i; q_i = q0 o exp(dtheta/2) "
                "(body axes), omega_i = omega0 + domega, I_i = I (1 + eps) (normal: truncated "
                "at 3 sigma), Q_i = 2 q_i o (0, I_i omega_i)"
            ),
        }


#: Keys of the ``[ensemble]`` table and the kind of quantity of their ``_unit`` (scenario.py).
ENSEMBLE_KEYS: dict[str, str | None] = {
    "size": None,
    "seed": None,
    "chunk": None,
    "attitude_error": "angle",
    "attitude_distribution": None,
    "rate_error": "rate",
    "rate_distribution": None,
    "inertia_error": None,
    "inertia_distribution": None,
}


def parse_dispersions(r: Any, table: dict[str, Any], body: RigidBody) -> Dispersions:
    """The ``[ensemble]`` table (scenario ``_Reader`` ``r``) as :class:`Dispersions`.

    Errors name the key (``ScenarioError`` is raised by the caller from AttitudeValueError).
    """
    from .scenario import ScenarioError

    def fail(key, msg):
        return ScenarioError(f"ensemble.{key}: {msg}")

    def integer(key, default, low):
        v = table.get(key, default)
        if v is None:
            return None
        if not isinstance(v, int) or isinstance(v, bool) or v < low:
            raise fail(key, f"expected an integer >= {low}, got {v!r}")
        return v

    if "size" not in table:
        raise fail("size", "missing: the number of members (an integer >= 1)")
    size = integer("size", None, 1)
    seed = integer("seed", 0, 0)
    chunk = integer("chunk", None, 1)
    values = {}
    for key, kind in (("attitude_error", "angle"), ("rate_error", "rate")):
        v = r.value(table, key, "ensemble", kind, default=0.0)
        if not v >= 0:
            raise fail(key, f"must be >= 0 (a standard deviation or half-width), got {v!r}")
        values[key] = float(v)
    ie = r.number(table, "inertia_error", "ensemble", 0.0)
    if not ie >= 0:
        raise fail("inertia_error", f"must be >= 0 (relative, e.g. 0.02 for 2 %), got {ie!r}")
    dists = {}
    for q in ("attitude", "rate", "inertia"):
        key = f"{q}_distribution"
        d = r.string(table, key, "ensemble", "normal")
        if d not in _DISTRIBUTIONS:
            raise fail(key, f"expected one of {', '.join(map(repr, _DISTRIBUTIONS))}, got {d!r}")
        dists[key] = d
    disp = Dispersions(
        size=size,
        seed=seed,
        chunk=chunk,
        attitude_error=values["attitude_error"],
        rate_error=values["rate_error"],
        inertia_error=ie,
        **dists,
    )
    try:
        disp.check_body(body.inertia)
    except AttitudeValueError as exc:
        raise ScenarioError(str(exc)) from None
    return disp


class _Sampled:
    """Members drawn chunk by chunk from :class:`Dispersions` (memory: one chunk)."""

    def __init__(self, disp: Dispersions, q0, Q0, inertia, params):
        self.disp = disp
        self.q0 = q0
        self.Q0 = Q0
        self.inertia0 = inertia
        self.params = params
        self.n = disp.size
        self.shared_inertia = inertia if disp.inertia_error == 0 else None

    def block(self, start: int, stop: int):
        q, Q, inert = self.disp.sample(self.q0, self.Q0, self.inertia0, start, stop)
        qp, Qp, corr = _project(q, Q, start)
        params = np.array(np.broadcast_to(self.params, (stop - start, self.params.shape[0])))
        params[:, 0:3] = inert
        y0 = np.ascontiguousarray(np.concatenate([qp, Qp], axis=1))
        return params, y0, inert, corr


def run_scenario(
    sc: Any,
    path: str | os.PathLike | None = None,
    *,
    client: Any = None,
    progress: Callable[[int, int, int], None] | None = None,
    chunk_size: int | None = None,
    scheduler_timeout: float | None = None,
    **overrides: Any,
) -> dict[str, Any]:
    """Run the dispersed ensemble of a scenario with an ``[ensemble]`` table, streamed to netCDF.

    Parameters
    ----------
    sc : attitude.scenario.Scenario
        A scenario whose ``ensemble`` (:class:`Dispersions`) is set.
    path : str or Path, optional
        Output file (default: the scenario's output path).
    client : dask.distributed.Client or str, optional
        Dask client or scheduler address (see :func:`propagate_ensemble`).
    progress : callable, optional
        ``progress(n_done, n_total, n_steps)`` after each chunk.
    chunk_size : int, optional
        Members per chunk (default: ``ensemble.chunk``, else automatic).
    **overrides
        ``method``, ``rtol``, ``atol``, ``max_step`` replacing the scenario's.

    Returns
    -------
    dict
        ``path`` and the file's global attrs.

    Raises
    ------
    PropagationError
        As :func:`propagate_ensemble`; the file keeps the chunks done before the failure.
    """
    from .canonical import project_state

    disp = sc.ensemble
    if disp is None:
        raise AttitudeValueError("scenario: no [ensemble] table; use Scenario.run_to_file")
    kw = sc._kwargs(overrides)
    for key in ("dt", "order", "formulation"):
        if key in kw:
            raise AttitudeValueError(
                f"integrator.{key}: ensembles run the canonical equations with method 'dop853' "
                f"only; remove {key} from the [integrator] table of an [ensemble] scenario"
            )
    out = Path(path) if path is not None else sc.output
    q0, Q0, _ = project_state(sc.q0, sc.Q0)
    pot = sc.potential.bind(sc.body)
    inertia = np.asarray(sc.body.inertia, dtype=np.float64)
    params = pot._params(inertia)
    source = _Sampled(disp, q0, Q0, inertia, params)
    attrs = {**sc.attrs(kw), **disp.attrs()}
    if disp.inertia_error > 0:
        attrs["inertia"] = inertia  # the nominal body; each member's is the variable inertia
        attrs["inertia_note"] = "nominal; per-member moments in the variable inertia"
    ds = propagate_ensemble(
        sc.body,
        None,
        None,
        sc.t,
        pot,
        path=out,
        client=client,
        progress=progress,
        chunk_size=chunk_size or disp.chunk,
        scheduler_timeout=scheduler_timeout,
        attrs=attrs,
        _source=(source, sc.body.units, pot, None),
        **kw,
    )
    try:
        info = {"path": out, **ds.attrs}
    finally:
        ds.close()
    return info


def summary_lines(sc: Any, info: dict[str, Any], wall: float) -> list[str]:
    """The ``attitude run`` summary of an ensemble run."""
    p = Path(info["path"])
    size = p.stat().st_size / 1e6 if p.exists() else 0.0
    n = int(info.get("n_members_written", 0))
    steps = int(info.get("n_steps", 0))
    unit = "" if sc.body.is_dimensionless else " s"
    lines = [
        f"scenario    {info.get('scenario')}: {info.get('title', '')}",
        f"ensemble    {n} members (seed {info.get('ensemble_seed')}), chunks of "
        f"{info.get('chunk_size')}, {info.get('execution')}",
        f"time span   {float(sc.t[0]):g} .. {float(sc.t[-1]):g}{unit} ({len(sc.t)} samples)",
        f"method      {info.get('method')}, rtol {info.get('rtol')}, atol {info.get('atol')}: "
        f"{steps} steps ({steps / max(n, 1):.1f} per member), {info.get('n_rejected')} rejected",
        f"speed       {steps / max(wall, 1e-9):.3g} member-steps/s",
    ]
    from .cli import _invariant_lines

    inv = _invariant_lines(info)
    lines.append(
        "invariants  "
        + ("\n            ".join(inv) if inv else "-")
        + ("\n            (maxima over members)" if inv else "")
    )
    lines.append(f"output      {p} ({size:.2f} MB) in {wall:.2f} s")
    return lines


def cli_run(sc: Any, out: Path, args: Any) -> None:
    """``attitude run`` of a scenario with an ``[ensemble]`` table (progress per chunk)."""
    import sys

    # As the single-run progress bar: "auto" reports when stderr is a terminal.
    mode = getattr(args, "progress", "auto")
    tty = bool(getattr(sys.stderr, "isatty", lambda: False)())
    show = mode == "always" or (mode == "auto" and tty and not getattr(args, "quiet", False))
    t0 = time.monotonic()
    chunks = [0]

    def report(done: int, total: int, steps: int) -> None:
        chunks[0] += 1
        if not show:
            return
        el = time.monotonic() - t0
        left = el * (total - done) / done if done else math.inf
        sys.stderr.write(
            f"ensemble chunk {chunks[0]}: {done}/{total} members done, {steps} steps, "
            f"{el:.1f} s elapsed, ~{left:.0f} s left\n"
        )
        sys.stderr.flush()

    info = run_scenario(
        sc,
        out,
        client=getattr(args, "scheduler", None),
        progress=report,
        method=args.method,
        rtol=args.rtol,
        atol=args.atol,
    )
    if not getattr(args, "quiet", False):
        print("\n".join(summary_lines(sc, info, time.monotonic() - t0)))


# ------------------------------------------------------------------------------------------------
# statistics over members
# ------------------------------------------------------------------------------------------------


def _check_ensemble(ds: Any, var: str) -> xr.DataArray:
    if not isinstance(ds, xr.Dataset):
        raise AttitudeTypeError(f"ds: expected an xarray.Dataset, got {type(ds).__name__}")
    if var not in ds or "member" not in ds[var].dims:
        raise AttitudeValueError(
            f"ds: expected an ensemble result with a variable {var!r} over 'member' "
            "(from attitude.propagate_ensemble)"
        )
    return ds[var]


def _percentiles(percentiles: Any) -> np.ndarray:
    p = as_float_array(percentiles, "percentiles")
    p = np.atleast_1d(p)
    if p.ndim != 1 or p.size == 0 or np.any((p < 0) | (p > 100)):
        raise AttitudeValueError(
            f"percentiles: expected numbers in [0, 100], e.g. (5, 50, 95), got {p.tolist()}"
        )
    return p


def _over_members(err: xr.DataArray, p: np.ndarray) -> xr.DataArray:
    if err.chunks is not None:  # dask: quantiles need every member of a time in one block
        err = err.chunk({"member": -1})
    out = err.quantile(p / 100.0, dim="member")
    return out.rename(quantile="percentile").assign_coords(percentile=p)


def _mean_attitude(q: xr.DataArray) -> np.ndarray:
    """Average attitude per time: the dominant eigenvector of Σ q qᵀ over members.

    Markley, Cheng, Crassidis & Oshman, J. Guid. Control Dyn. 30, 1193 (2007), eq. 12: it
    maximises Σ (q·q̄)², the chordal mean, and is insensitive to the sign of each q.
    """
    q2 = q.rename(component="component_b")
    M = xr.dot(q, q2, dim="member").transpose("time", "component", "component_b").values
    _, vecs = np.linalg.eigh(M)
    qm = vecs[..., :, -1]
    return qm * np.where(qm[..., :1] < 0, -1.0, 1.0)


def _reference(ds: xr.Dataset, q: xr.DataArray, reference: Any) -> xr.DataArray:
    m = ds.sizes["time"]
    if isinstance(reference, str):
        if reference != "mean":
            raise AttitudeValueError(
                f"reference: expected 'mean', a member index, a Dataset with q (a nominal "
                f"run) or quaternions (4,) / (time, 4), got {reference!r}"
            )
        ref = _mean_attitude(q)
    elif isinstance(reference, (int, np.integer)) and not isinstance(reference, bool):
        if int(reference) not in set(ds["member"].values.tolist()):
            raise AttitudeValueError(f"reference: no member {reference} in ds")
        ref = np.asarray(q.sel(member=int(reference)).transpose("time", "component").values)
    elif isinstance(reference, xr.Dataset):
        if "q" not in reference or "member" in reference["q"].dims:
            raise AttitudeValueError("reference: a Dataset must be one run with q (time, 4)")
        rt = reference["time"].values
        if rt.shape != (m,) or not np.array_equal(rt, ds["time"].values):
            raise AttitudeValueError(
                "reference: the nominal run must have the ensemble's output times exactly "
                "(propagate it with the same t)"
            )
        ref = np.asarray(reference["q"].transpose("time", "component").values)
    else:
        ref = as_float_array(reference, "reference", trailing=4)
        if ref.shape not in ((4,), (m, 4)):
            raise AttitudeValueError(
                f"reference: expected shape (4,) or (time, 4) = ({m}, 4), got {ref.shape}"
            )
        ref = np.broadcast_to(ref, (m, 4))
    nr = np.linalg.norm(ref, axis=-1)
    if np.any(np.abs(nr - 1.0) > 1e-6):
        raise AttitudeValueError("reference: quaternions must be unit quaternions")
    return xr.DataArray(ref / nr[:, None], dims=("time", "component"))


def _error_angles(q, r, axis):
    """Angle between attitudes q (..., 4) and r (..., 4), or between q b and r b (rad)."""
    from .quaternion import multiply, rotate

    if axis is None:
        w = multiply(r * np.array([1.0, -1.0, -1.0, -1.0]), q)
        return 2.0 * np.arctan2(np.linalg.norm(w[..., 1:], axis=-1), np.abs(w[..., 0]))
    u = rotate(q, axis)
    v = rotate(r, axis)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def pointing_error_percentiles(
    ds: xr.Dataset,
    reference: Any = "mean",
    percentiles: Any = (5.0, 50.0, 95.0),
    *,
    axis: Any = None,
    degrees: bool = False,
) -> xr.DataArray:
    """Percentiles over members of the attitude (or boresight) error against time.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result (:func:`propagate_ensemble`), in memory or lazy (dask).
    reference : "mean", int, Dataset or array_like shape (4,) or (time, 4)
        What the error is measured from: ``"mean"`` (default), the average attitude of the
        members at each time (Markley et al. 2007); a member index; a nominal
        ``propagate`` result with the same times; or reference quaternions.
    percentiles : sequence of float
        Percentiles in [0, 100] (linear interpolation between members, as ``np.percentile``).
    axis : array_like, shape (3,), optional
        A body axis (boresight). Given, the error is the angle between the directions this
        axis points to in space, q b q̃ and q_ref b q̃_ref; otherwise the total rotation
        angle 2 atan2(|vec(q̃_ref∘q)|, |scalar(q̃_ref∘q)|) in [0, π].
    degrees : bool
        Degrees instead of radians.

    Returns
    -------
    xarray.DataArray, dims (percentile, time)
    """
    q = _check_ensemble(ds, "q")
    p = _percentiles(percentiles)
    b = None
    if axis is not None:
        b = as_float_array(axis, "axis", trailing=3, ndim=1)
        nb = float(np.linalg.norm(b))
        if nb == 0.0:
            raise AttitudeValueError("axis: the zero vector is not a direction")
        b = b / nb
    ref = _reference(ds, q, reference)
    err = xr.apply_ufunc(
        _error_angles,
        q,
        ref,
        kwargs={"axis": b},
        input_core_dims=[["component"], ["component"]],
        dask="parallelized",
        output_dtypes=[np.float64],
    )
    if degrees:
        err = np.degrees(err)
    out = _over_members(err.transpose("member", "time"), p)
    kind = "boresight pointing error" if b is not None else "attitude error angle"
    out.attrs = {
        "units": "deg" if degrees else "rad",
        "long_name": f"percentiles over members of the {kind}",
        "reference": reference if isinstance(reference, str) else "given",
    }
    return out.rename("pointing_error")


def rate_percentiles(
    ds: xr.Dataset,
    percentiles: Any = (5.0, 50.0, 95.0),
    *,
    norm: bool = True,
    variable: str = "omega",
) -> xr.DataArray:
    """Percentiles over members of the body angular velocity against time.

    Parameters
    ----------
    ds : xarray.Dataset
        An ensemble result (:func:`propagate_ensemble`).
    percentiles : sequence of float
        Percentiles in [0, 100].
    norm : bool
        True (default): of the magnitude |ω|; False: of each body-axis component.
    variable : str
        ``"omega"`` (default) or another (member, time, axis) variable (``"g"``, ``"G"``).

    Returns
    -------
    xarray.DataArray, dims (percentile, time) or (percentile, time, axis)
        In the variable's units.
    """
    w = _check_ensemble(ds, variable)
    if "axis" not in w.dims:
        raise AttitudeValueError(f"variable: {variable!r} is not a (member, time, axis) vector")
    p = _percentiles(percentiles)
    val = np.sqrt((w * w).sum("axis")) if norm else w
    out = _over_members(val, p)
    what = f"|{variable}|" if norm else f"{variable} components"
    out.attrs = {
        "units": w.attrs.get("units", ""),
        "long_name": f"percentiles over members of {what}",
    }
    return out.rename(f"{variable}_percentiles")

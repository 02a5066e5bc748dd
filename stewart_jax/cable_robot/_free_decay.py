"""Free-decay records of the FAST cabin: the cabin is displaced (and possibly pushed), released,
and its pose sampled as a tracker would, with noise. The records are what the discrepancy
workflow's cabin-record model is tested on (``stewart-jax fast --free-decay``), so they are
simulated by the time integrators, never by the modal superposition that model uses:

- **quasi-static cables** (Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a
  cable-driven parallel robot with a Stewart platform for use in FAST*, §2, §5): the cabin
  assembly as one rigid body (legs held) under the six elastic catenaries' forces, solved at
  every step at the current pose with the unstretched lengths fixed (eqs. 11–13; Newton, warm
  started), and its weight; velocity Verlet in ``lax.scan``;
- **lumped-mass cables** (Hall M., Goupee A., *Validation of a lumped-mass mooring line model
  with DeepCwind semisubmersible model test data*, Ocean Engineering 104 (2015), MoorDyn's
  discretisation): :func:`~stewart_jax.cable_robot.simulate_lumped`, the cables' nodes started in
  the quasi-static shape of the displaced cabin (``x = G q0`` with ``G = −K_nn⁻¹ K_nc``, the
  nodes settled around the held cabin), at rest unless ``velocity`` is given.

The structural damping is modal, as in :mod:`._lumped_time`: ``C = M Φ diag(2 ζ_m ω_m) Φᵀ M``
with the M-orthonormal modes of the static pose; on quasi-static cables each of the 6 modes may
take its own ratio through the mode groups of :mod:`._cabin_modal` (``ζ_m = ζ + Σ_g δζ_g s_g(m)``).

NOTE (rotation coordinate): the quasi-static integrator's rotational coordinate is the rotation
vector ``δφ`` of ``exp([δφ]×) R`` and its generalised force is taken as the moment about C's
origin; the exact one differs by a term of relative size ``|δφ|`` times the moment, which is
itself first order in the motion: second order in all, as the constant mass matrix (the same
approximation as :mod:`._lumped_time`'s, ≲ 1e-3 at the millimetre and 10⁻⁴ rad motions of a
record).
"""

from __future__ import annotations

import csv
import io
import os
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from .._memory import most_that_fit
from ._cabin_modal import DAMPING_GROUPS, damping_group_shares
from ._catenary import solve_catenary
from ._lumped import lumped_modes
from ._lumped_time import simulate_lumped
from ._modes import _exp, cabin_mass_matrix, cabin_stiffness, modes_from_matrices, static_wrench
from ._statics import static_equilibrium_jit
from ._system import FastParams, cable_deltas, check_position

RECORD_COLUMNS = ("time", "x", "y", "z", "rx", "ry", "rz")
"""Columns of a cabin record: s; mm (C's origin in G from its static position); degrees
(rotation-vector components in G)."""


class FreeDecay(NamedTuple):
    """A simulated free decay (numpy; :func:`quasi_static_free_decay`, :func:`lumped_free_decay`).

    - ``time``: ``(T+1,)`` s; ``cabin``: ``(T+1, 6)``, the cabin's offset from its static pose,
      ``(δt (m), δφ (rad))`` in G.
    - ``cables``: ``"quasi-static"`` or ``"lumped"``; ``segments``: N (0 for quasi-static).
    - ``frequencies_hz``: the simulated system's modes about the static pose (6 on quasi-static
      cables; every mode of cabin and nodes on lumped ones).
    - ``damping_ratios``: the modal damping ratio of each of those modes.
    - ``failed_solves``: catenary solves that missed their tolerance (0 for a trustworthy run);
      ``max_strain``: the largest segment strain met (lumped; 0 otherwise).
    """

    time: np.ndarray
    cabin: np.ndarray
    cables: str
    segments: int
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    failed_solves: int
    max_strain: float

    def sample(self, rate_hz: float, *, sigma_mm: float = 1.0, sigma_deg: float = 0.01, seed: int = 0) -> CabinRecord:
        """The decay as a tracker records it (:func:`sample_record`)."""
        return sample_record(self, rate_hz, sigma_mm=sigma_mm, sigma_deg=sigma_deg, seed=seed)


def _check_common(position, duration, dt, displacement, velocity, damping_ratio):
    check_position(position)
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive time in s, got {duration}")
    if dt is not None and not (np.isfinite(dt) and 0 < dt <= duration):
        raise ValueError(f"dt must be a time step in s with 0 < dt <= duration, got {dt}")
    for name, v in (("displacement", displacement), ("velocity", velocity)):
        a = np.asarray(v, dtype=np.float64)
        if a.shape != (6,) or not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be 6 finite numbers (m, m, m, rad, rad, rad[/s]), got {v!r}")
    if not (np.isfinite(damping_ratio) and 0 <= damping_ratio < 1):
        raise ValueError(f"damping_ratio must be in [0, 1), got {damping_ratio}")


BYTES_PER_STEP = 6 * 8 * 8
"""Memory one integrator step of a free decay takes (bytes): the cabin's six coordinates in
float64, kept for the record, and the copies the scan's output and the sampling make of them."""


def check_steps(n_steps: int, dt: float) -> None:
    """Refuse, before the integration, a free decay of ``n_steps`` steps of ``dt`` whose record
    would not fit in :data:`~stewart_jax._memory.MEMORY_SHARE` of this machine's memory, saying
    how long a decay it can take."""
    fit = most_that_fit(BYTES_PER_STEP)
    if fit is None:
        return
    most, available = fit
    if n_steps > most:
        raise ValueError(f"{n_steps} integrator steps of {dt:.3g} s need about {n_steps * BYTES_PER_STEP / 1e9:.3g} GB "
                         f"and this machine has {available / 1e9:.1f} GB available: it can simulate up to "
                         f"{most * dt:.4g} s at this step; shorten the duration")


def _qs_run(params, pos, R, s0, F0, M, C, q0, v0, dt, n_steps):
    Minv = jnp.linalg.inv(M)

    def acc(q, v, guess):
        Rq = _exp(q[3:]) @ R
        cab = solve_catenary(params.cable, cable_deltas(params, pos + q[:3], Rq), s0, guess)
        w = static_wrench(params, pos, R, cab.force, q)
        return Minv @ (w - C @ v), cab.force, jnp.sum(~cab.converged)

    def step(carry, _):
        q, v, a, (g1, g0), nf = carry
        q1 = q + v * dt + 0.5 * a * dt**2
        a1, g, f = acc(q1, v + a * dt, 2.0 * g1 - g0)
        v1 = v + 0.5 * (a + a1) * dt
        return (q1, v1, a1, (g, g1), nf + f), q1

    a0, g0, f0 = acc(q0, v0, F0)
    (_, _, _, _, nf), qs = jax.lax.scan(step, (q0, v0, a0, (g0, g0), f0), None, length=n_steps)
    return jnp.concatenate([q0[None], qs]), nf


_qs_run_jit = jax.jit(_qs_run, static_argnames=("n_steps",))


def quasi_static_free_decay(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    duration: float,
    dt: float,
    *,
    displacement: Float[ArrayLike, "6"],
    velocity: Float[ArrayLike, "6"] = (0.0,) * 6,
    damping_ratio: float = 0.005,
    damping_change: Float[ArrayLike, "3"] = (0.0, 0.0, 0.0),
    R: Float[ArrayLike, "3 3"] | None = None,
) -> FreeDecay:
    """Free decay of the cabin on quasi-static elastic catenaries (see the module docstring)
    from ``displacement`` (m, rad) and ``velocity`` (m/s, rad/s) at ``t = 0``, for ``duration``
    seconds in steps of ``dt``; mode m damped at ``damping_ratio + Σ_g damping_change[g]
    s_g(m)`` (groups :data:`~stewart_jax.cable_robot._cabin_modal.DAMPING_GROUPS`). ``params`` may carry a
    changed EA or cabin mass (:func:`~stewart_jax.cable_robot._cabin_modal.scaled_params`): the statics are
    solved for them at ``position``."""
    _check_common(position, duration, dt, displacement, velocity, damping_ratio)
    dz = np.asarray(damping_change, dtype=np.float64)
    if dz.shape != (len(DAMPING_GROUPS),) or not np.all(np.isfinite(dz)):
        raise ValueError(f"damping_change must be {len(DAMPING_GROUPS)} finite numbers, one per group "
                         f"{DAMPING_GROUPS}, got {damping_change!r}")
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    st = static_equilibrium_jit(params, pos, R)
    if not bool(st.converged):
        raise ValueError(f"no static equilibrium of the elastic catenaries at {np.asarray(position).tolist()} m")
    K = cabin_stiffness(params, pos, R, st.s0, st.force)
    M = cabin_mass_matrix(params, R)
    freq, shapes, stable = modes_from_matrices(0.5 * (K + K.T), M)
    if not bool(stable):
        raise ValueError(f"the cabin's static pose at {np.asarray(position).tolist()} m is unstable")
    zeta = damping_ratio + np.asarray(damping_group_shares(shapes, jnp.diagonal(M))) @ dz
    if np.any(zeta < 0) or np.any(zeta >= 1):
        raise ValueError(f"the modal damping ratios {np.round(zeta, 5).tolist()} must lie in [0, 1)")
    w = 2.0 * np.pi * np.asarray(freq)
    C = M @ shapes @ jnp.diag(2.0 * zeta * w) @ shapes.T @ M
    n = int(round(duration / dt))
    check_steps(n, dt)
    q, nf = _qs_run_jit(params, pos, R, st.s0, st.force, M, C, jnp.asarray(displacement, jnp.float64),
                        jnp.asarray(velocity, jnp.float64), jnp.asarray(dt, jnp.float64), n)
    return FreeDecay(np.arange(n + 1) * dt, np.asarray(q), "quasi-static", 0, np.asarray(freq), zeta,
                     int(nf), 0.0)


def lumped_free_decay(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    n_segments: int,
    duration: float,
    dt: float | None = None,
    *,
    displacement: Float[ArrayLike, "6"],
    velocity: Float[ArrayLike, "6"] = (0.0,) * 6,
    damping_ratio: float = 0.005,
    R: Float[ArrayLike, "3 3"] | None = None,
    cable_nodes: str = "equilibrium",
) -> FreeDecay:
    """Free decay of the cabin on ``n_segments`` lumped-mass segments per cable (see the module
    docstring): the cabin at ``displacement`` (m, rad) from the lumped statics' pose, moving at
    ``velocity``; the nodes in the quasi-static shape and velocity this imposes
    (``cable_nodes="equilibrium"``: released from a static offset under a load) or at rest in the
    static pose (``"rest"``: the cabin displaced or struck faster than the cables follow); every
    mode of cabin and nodes damped at ``damping_ratio``. ``dt`` defaults to half the explicit
    integrator's stability limit."""
    _check_common(position, duration, dt, displacement, velocity, damping_ratio)
    if cable_nodes not in ("equilibrium", "rest"):
        raise ValueError(f"cable_nodes must be 'equilibrium' or 'rest', got {cable_nodes!r}")
    pos = jnp.asarray(position, jnp.float64)
    modes = lumped_modes(params, pos, n_segments, R)
    if dt is None:
        dt = 0.95 / (2.0 * np.pi * float(np.max(np.asarray(modes.frequencies_hz))))
    K = np.asarray(modes.stiffness)
    G = -np.linalg.solve(K[6:, 6:], K[6:, :6]) * (1.0 if cable_nodes == "equilibrium" else 0.0)
    q0 = np.asarray(displacement, dtype=np.float64)
    v0 = np.asarray(velocity, dtype=np.float64)
    n = int(round(duration / dt))
    check_steps(n, dt)
    tr = simulate_lumped(params, modes, dt, n, displacement=np.concatenate([q0, G @ q0]),
                         velocity=np.concatenate([v0, G @ v0]), damping_ratio=damping_ratio)
    f = np.asarray(modes.frequencies_hz)
    return FreeDecay(np.asarray(tr.time), np.asarray(tr.cabin), "lumped", int(n_segments), f,
                     np.full(f.shape, float(damping_ratio)), 0, float(tr.max_stretch))


class CabinRecord(NamedTuple):
    """A record of the cabin's pose (numpy): ``time`` ``(m,)`` s; ``position_mm`` ``(m, 3)``, C's
    origin in G relative to its static position; ``rotation_deg`` ``(m, 3)``, the rotation
    vector of the cabin's small rotation in G, degrees."""

    time: np.ndarray
    position_mm: np.ndarray
    rotation_deg: np.ndarray


def sample_record(
    decay: FreeDecay, rate_hz: float, *, sigma_mm: float = 1.0, sigma_deg: float = 0.01, seed: int = 0
) -> CabinRecord:
    """The free decay sampled at ``rate_hz`` (every k-th step of the integrator, ``k dt`` the
    nearest multiple of the step to ``1/rate_hz``) as a tracker reports it: white Gaussian
    noise of σ ``sigma_mm`` on each position coordinate and ``sigma_deg`` on each rotation
    component, independent between samples (seeded)."""
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be a positive sampling rate in Hz, got {rate_hz}")
    for name, s in (("sigma_mm", sigma_mm), ("sigma_deg", sigma_deg)):
        if not (np.isfinite(s) and s >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {s}")
    dt = float(decay.time[1] - decay.time[0])
    k = max(1, int(round(1.0 / (rate_hz * dt))))
    idx = np.arange(0, len(decay.time), k)
    rng = np.random.default_rng(seed)
    pos = decay.cabin[idx, :3] * 1e3 + rng.normal(0.0, sigma_mm, (len(idx), 3))
    rot = np.rad2deg(decay.cabin[idx, 3:]) + rng.normal(0.0, sigma_deg, (len(idx), 3))
    return CabinRecord(decay.time[idx], pos, rot)


def write_record(path: str | os.PathLike[str], record: CabinRecord) -> None:
    """Write a cabin record as CSV (:data:`RECORD_COLUMNS`, full float64 precision),
    atomically."""
    from .._files import write_text_atomic

    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(RECORD_COLUMNS)
    for t, p, r in zip(record.time, record.position_mm, record.rotation_deg, strict=True):
        w.writerow([repr(float(v)) for v in (t, *p, *r)])
    write_text_atomic(path, buf.getvalue())


def check_record(time: ArrayLike, values: ArrayLike, source: str = "record") -> None:
    """Clear errors for a record the cabin-record model cannot read: non-finite values, fewer
    than 3 samples, a time that does not increase strictly (naming the first row that does not)."""
    t = np.asarray(time, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if t.ndim != 1 or v.shape != (t.shape[0], 6):
        raise ValueError(f"{source}: a record has one time and 6 pose values per row, got {t.shape} and {v.shape}")
    if t.shape[0] < 3:
        raise ValueError(f"{source}: {t.shape[0]} samples; a record needs at least 3")
    bad = np.flatnonzero(~np.isfinite(t) | ~np.all(np.isfinite(v), axis=1))
    if bad.size:
        raise ValueError(f"{source}: data row {bad[0] + 1} has a value that is not a finite number")
    step = np.diff(t)
    if np.any(step <= 0):
        i = int(np.flatnonzero(step <= 0)[0])
        raise ValueError(f"{source}: time does not increase at data row {i + 2} ({t[i + 1]!r} s after {t[i]!r} s); "
                         "sort the record by time and drop repeated samples")

"""Simulated measurements of a mechanism with one hidden effect, to test and benchmark the
discrepancy workflow: by default the "actual" 6-PSS of Wang et al. 2018, "Improved cuckoo
calibration method of space telescope secondary mirror adjusting mechanism", Infrared and Laser
Engineering 47(5); any mechanism whose family has a discrepancy model (a 6-UPS strut hexapod,
e.g.) otherwise.

The simulator is registry-driven: the true mechanism is the family's discrepancy model
(:func:`~stewart_jax.discrepancy.model_for`) extended by the hidden effect's registered
``apply`` at its true parameters — the same function the workflow fits — so every registered
effect of every family can be hidden without editing this module. The effect's
``random_direction`` (default: standard normal × ``scale``) draws the direction of the true
parameters and ``requires`` names the conditions it needs.

Protocol: the noise-free measured poses = the 120-pose plan (Wang et al. 2018, §3) scaled to
the mechanism's reachable travel plus ``n_random`` uniform poses in that travel (for the paper's
mechanism: ±1 mm / ±1°), visited in random order every 20–40 s (``time``); each actuator
approaches from a random side (``dir``); the temperature is uniform in 20 ± 3 °C, independent
of time and pose. The readings are those of the true mechanism at the true poses (the measured
poses mapped by a measurement-side effect, e.g. a misaligned instrument); the measured poses
get Gaussian noise σ (µm, ″). The effect's parameters are scaled so that the part of its
reading-residual signature the geometric parameters (36 for the 6-PSS, 42 for the 6-UPS)
cannot absorb has the requested RMS relative to the noise (whitened units: ``magnitude = 3``
means the unabsorbable signature is 3× the noise per residual).
"""

from __future__ import annotations

import dataclasses
import os

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from .._units import ARCSEC, UM
from ..calibration._csv import write_csv
from ..calibration._identifiability import reading_noise_covariance
from ..calibration._problem import CalibrationData, make_calibration_data, reading_residuals
from ..calibration._simulation import reachable_travel, sampling_plan_120
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._pss import actual_geometry
from ._effects import T_REF_C
from ._families import model_for
from ._registry import Effect, effect_names, get_effect

CONDITION_COLUMNS = ("directions", "temperature", "time")
"""The data columns the simulator provides (an effect requiring another cannot be simulated)."""
_PROBE = 1e-3
"""Fraction of the drawn direction used to measure the effect's signature (linear regime)."""


@dataclasses.dataclass(frozen=True)
class Conditions:
    """Per-pose conditions of a move: ``directions`` (m, 6) ±1, ``temperature`` (m,) °C,
    ``time`` (m,) s."""

    directions: np.ndarray
    temperature: np.ndarray
    time: np.ndarray

    def data(
        self, poses: Float[np.ndarray, "m 6"], readings: Float[np.ndarray, "m 6"] | None = None
    ) -> CalibrationData:
        """:class:`CalibrationData` with these conditions (readings 0 unless given)."""
        q = np.zeros_like(np.asarray(poses, dtype=float)) if readings is None else readings
        return make_calibration_data(q, poses, self.directions, self.temperature, self.time)


@eqx.filter_jit
def _predict(model, effects, thetas, data, control):
    return model.predict(model.base_initial, effects, thetas, data, control=control)


@eqx.filter_jit
def _true_poses(model, effects, thetas, data):
    state = model.initial_state(model.base_initial, data, False)
    for e, t in zip(effects, thetas, strict=True):
        state = e(t, data, state)
    return state.poses


@eqx.filter_jit
def _newton_terms(model, effects, thetas, data, target):
    """Residual ``f(P) = readings(P) − target`` of the true mechanism (control side) and its
    per-pose Jacobians ``(m, 6, 6)``.

    NOTE: each row's readings depend on that row's pose only, so the Jacobian of the readings
    with respect to one shift δ added to every pose is the block diagonal of the full one."""

    def readings(delta):
        return model.predict(model.base_initial, effects, thetas, data._replace(poses=data.poses + delta), control=True)

    return readings(jnp.zeros(6)) - target, jax.jacfwd(readings)(jnp.zeros(6))


@dataclasses.dataclass(frozen=True)
class HiddenTruth:
    """The true mechanism: its geometry (any family with a discrepancy model), the hidden
    effect (``None``: none; an effect of the family's model) and its parameters in library
    units (mm, rad, 1/K, mm/s; the order of the registered effect), and the achieved size of
    its signature (``magnitude``: unabsorbable RMS / noise; ``raw_magnitude``: total RMS /
    noise, whitened)."""

    geometry: AbstractMechanism
    effect: str | None
    theta: np.ndarray
    magnitude: float
    raw_magnitude: float

    def _parts(self) -> tuple[object, tuple[Effect, ...], tuple[jnp.ndarray, ...]]:
        model = model_for(self.geometry)
        if self.effect is None:
            return model, (), ()
        return model, (get_effect(model.name, self.effect),), (jnp.asarray(self.theta, jnp.float64),)

    def readings(self, measured: Float[np.ndarray, "m 6"], cond: Conditions) -> np.ndarray:
        """Encoder readings of the true mechanism when the (noise-free) instrument measures
        ``measured`` (mm, rad)."""
        return np.asarray(_predict(*self._parts(), cond.data(measured), False))

    def true_poses(self, measured: Float[np.ndarray, "m 6"], cond: Conditions) -> np.ndarray:
        """The poses in B that the instrument sees as ``measured``."""
        return np.asarray(_true_poses(*self._parts(), cond.data(measured)))

    def commanded_readings(self, poses: Float[np.ndarray, "m 6"], cond: Conditions) -> np.ndarray:
        """Readings that put the true mechanism at ``poses`` (in B)."""
        return np.asarray(_predict(*self._parts(), cond.data(poses), True))

    def forward(self, readings: np.ndarray, cond: Conditions, initial: np.ndarray) -> np.ndarray:
        """Poses (in B) the true mechanism reaches for ``readings`` (Newton from ``initial``)."""
        model, effects, thetas = self._parts()
        p = np.array(initial, dtype=float)
        target = jnp.asarray(readings, jnp.float64)
        for _ in range(20):
            f, jac = _newton_terms(model, effects, thetas, cond.data(p), target)
            f, jac = np.asarray(f), np.asarray(jac)
            if np.max(np.abs(f)) < 1e-13:
                break
            p = p - np.linalg.solve(jac, f[..., None])[..., 0]
        return p


@dataclasses.dataclass(frozen=True)
class HiddenEffectData:
    """Simulated measured ``data`` (with ``dir``, ``temperature``, ``time``), the
    ``true_poses`` (in B) and the ``truth``."""

    data: CalibrationData
    true_poses: np.ndarray
    truth: HiddenTruth


def random_conditions(rng: np.random.Generator, m: int, step_s: tuple[float, float] = (20.0, 40.0)) -> Conditions:
    """Approach directions ±1, temperature uniform in 20 ± 3 °C, times of a run at 20–40 s a
    pose."""
    return Conditions(
        rng.choice([-1.0, 1.0], size=(m, 6)),
        T_REF_C + rng.uniform(-3.0, 3.0, m),
        np.cumsum(rng.uniform(*step_s, m)),
    )


def hidden_pose_set(
    rng: np.random.Generator, n_random: int = 60, plan: bool = True, half: np.ndarray | None = None
) -> np.ndarray:
    """The 120-pose plan (optional) plus ``n_random`` uniform poses in ``±half`` (six
    half-widths, mm and rad; default the paper's ±1 mm / ±1°), in random order; the plan is
    scaled to ``half`` as :func:`~stewart_jax.sampling_plan_120` does."""
    half = np.array([1.0] * 3 + [np.deg2rad(1.0)] * 3) if half is None else np.asarray(half, dtype=np.float64)
    parts = [np.asarray(sampling_plan_120(half=half))] if plan else []
    parts.append(rng.uniform(-half, half, (n_random, 6)))
    p = np.concatenate(parts)
    return p[rng.permutation(len(p))]


_res_jac = jax.jit(jax.jacfwd(reading_residuals))


def _whitened_projector(geometry: AbstractMechanism, poses: np.ndarray, sigma: np.ndarray):
    """Per-pose whiteners of the reading residuals and an orthonormal basis of the whitened
    geometric-parameter Jacobian's span."""
    cov = np.asarray(reading_noise_covariance(geometry, jnp.asarray(poses), jnp.diag(jnp.asarray(sigma**2))))
    w = np.linalg.inv(np.linalg.cholesky(cov))
    data = CalibrationData(jnp.zeros_like(jnp.asarray(poses)), jnp.asarray(poses))
    n = geometry.n_params
    g = np.asarray(_res_jac(geometry.params, data, geometry)).reshape(len(poses), 6, n)
    gw = np.einsum("mij,mjk->mik", w, g).reshape(-1, n)
    u, s, _ = np.linalg.svd(gw / np.linalg.norm(gw, axis=0), full_matrices=False)
    q = u[:, s > 1e-9 * s[0]]
    return w, q


def simulate_hidden_effect(
    seed: int,
    effect: str | None,
    magnitude: float,
    *,
    n_random: int = 60,
    plan: bool = True,
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    geometry: AbstractMechanism | None = None,
    noise: bool = True,
    half: np.ndarray | None = None,
) -> HiddenEffectData:
    """Measured data of a true mechanism ``geometry`` (default: the "actual" 6-PSS of
    :func:`~stewart_jax.actual_geometry`; any family with a discrepancy model) with one hidden
    ``effect`` registered for its family's model (``None`` for none) whose unabsorbable
    signature is ``magnitude`` × the noise. Poses lie in ``±half`` (six half-widths, mm and
    rad; default the mechanism's :func:`~stewart_jax.calibration.reachable_travel`).
    ``noise=False`` leaves the noise out of the measured poses (the effect is still scaled to
    the noise level σ)."""
    geometry = actual_geometry() if geometry is None else geometry
    model_name = model_for(geometry).name
    names = effect_names(model_name)
    if effect is not None and effect not in names:
        raise ValueError(f"unknown effect {effect!r} for a {geometry.family}; choose from {names} or None")
    if not magnitude >= 0:
        raise ValueError(f"magnitude must be ≥ 0, got {magnitude}")
    rng = np.random.default_rng(seed)
    half = reachable_travel(geometry) if half is None else half
    poses = hidden_pose_set(rng, n_random, plan, half)
    m = len(poses)
    cond = random_conditions(rng, m)
    sigma = np.array([sigma_um * UM] * 3 + [sigma_arcsec * ARCSEC] * 3)
    theta = np.zeros(0)
    achieved = raw = 0.0
    if effect is not None:
        e = get_effect(model_name, effect)
        unknown = [c for c in e.requires if c not in CONDITION_COLUMNS]
        if unknown:
            raise ValueError(f"effect {effect!r} needs column(s) {unknown}, which the simulator does not provide")
        direction = e.random_direction(rng)
        # Signature of the direction, linear regime: residuals of the true geometry's
        # base model on noise-free data, whitened, then the part the geometry absorbs removed.
        base = HiddenTruth(geometry, None, np.zeros(0), 0.0, 0.0).readings(poses, cond)
        probe = HiddenTruth(geometry, effect, direction * _PROBE, 0.0, 0.0).readings(poses, cond)
        w, basis = _whitened_projector(geometry, poses, sigma)
        sig_w = np.einsum("mij,mj->mi", w, probe - base).reshape(-1) / _PROBE
        orth = sig_w - basis @ (basis.T @ sig_w)
        orth_rms, raw_rms = np.sqrt(np.mean(orth**2)), np.sqrt(np.mean(sig_w**2))
        factor = magnitude / orth_rms if orth_rms > 1e-6 * raw_rms else magnitude / raw_rms
        theta = direction * factor
        achieved, raw = orth_rms * factor, raw_rms * factor
    truth = HiddenTruth(geometry, effect, theta, float(achieved), float(raw))
    q = truth.readings(poses, cond)
    measured = poses + float(noise) * sigma * rng.standard_normal((m, 6))
    data = make_calibration_data(q, measured, cond.directions, cond.temperature, cond.time)
    return HiddenEffectData(data, truth.true_poses(poses, cond), truth)


def write_hidden_csv(path: str | os.PathLike[str], sim: HiddenEffectData) -> None:
    """Measurement CSV (the columns of :func:`~stewart_jax.write_csv`, with ``dir1..dir6``,
    ``temperature``, ``time``) plus ``true_*`` pose columns, readable by
    ``stewart-jax diagnose``."""
    p = np.array(sim.true_poses)
    p[:, 3:] = np.degrees(p[:, 3:])
    write_csv(path, sim.data, {",".join(f"true_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")): p},
              reading_unit=sim.truth.geometry.reading_unit)


def true_control_error(
    truth: HiddenTruth, commanded: np.ndarray, targets: np.ndarray, cond: Conditions
) -> np.ndarray:
    """Pose error (mm, rad; ``n 6``) of the true mechanism driven to ``commanded`` readings
    for ``targets`` under conditions ``cond``."""
    return truth.forward(np.asarray(commanded), cond, targets) - targets

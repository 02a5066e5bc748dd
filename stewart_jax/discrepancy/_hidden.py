"""Simulated measurements with one hidden effect, to test and benchmark the workflow.

The true mechanism is simulated here *independently of the model code* (``_pss.py``,
``_effects.py``): plain NumPy, the leg constraint solved by the textbook quadratic formula,
each effect written from the mechanism's side (reading → true stroke → pose → measured pose).
Only the effects' typical scales are taken from the registry, to draw random parameters.

Protocol: true poses = the 120-pose plan of Wang et al. (2018), §4 plus ``n_random`` uniform poses in the
travel, visited in random order every 20–40 s (``time``); each slider approaches from a random
side (``dir``); the temperature is uniform in 20 ± 3 °C, independent of time and pose. The
measured pose is the true pose seen by the (possibly misaligned) instrument plus Gaussian
noise σ (µm, ″). The effect's parameters are random per leg, scaled so that the part of its
stroke-residual signature the 36 geometric parameters cannot absorb has the requested RMS
relative to the noise (whitened units: ``magnitude = 3`` means the unabsorbable signature is
3× the noise per residual).
"""

from __future__ import annotations

import dataclasses
import os

import jax
import jax.numpy as jnp
import numpy as np

from ..calibration._problem import ARCSEC, UM, CalibrationData, make_calibration_data, stroke_residuals
from ..mechanism._pss import Geometry, actual_geometry
from ..calibration._csv import write_csv
from ..mechanism._kinematics import solve_inverse_kinematics
from ..calibration._simulation import sampling_plan_120
from ._effects import T_REF_C
from ._registry import get_effect

MODEL = "6-pss"
EFFECT_NAMES = (
    "zero_offset",
    "stroke_scale",
    "actuator_tilt",
    "backlash",
    "thermal_expansion",
    "drift",
    "tracker_misalignment",
)


def _rot(angles: np.ndarray) -> np.ndarray:
    """``Rz(ψ)·Ry(θ)·Rx(φ)`` from the elementary rotations (Wang et al. 2018, eq. 1), batched."""
    a = np.asarray(angles, dtype=float)
    f, t, p = a[..., 0], a[..., 1], a[..., 2]
    o, z = np.ones_like(f), np.zeros_like(f)
    rx = np.stack([o, z, z, z, np.cos(f), -np.sin(f), z, np.sin(f), np.cos(f)], -1).reshape(*f.shape, 3, 3)
    ry = np.stack([np.cos(t), z, np.sin(t), z, o, z, -np.sin(t), z, np.cos(t)], -1).reshape(*f.shape, 3, 3)
    rz = np.stack([np.cos(p), -np.sin(p), z, np.sin(p), np.cos(p), z, z, z, o], -1).reshape(*f.shape, 3, 3)
    return rz @ ry @ rx


def _angles(r: np.ndarray) -> np.ndarray:
    phi = np.arctan2(r[..., 2, 1], r[..., 2, 2])
    return np.stack([phi, -np.arcsin(r[..., 2, 0]), np.arctan2(r[..., 1, 0], r[..., 0, 0])], -1)


@dataclasses.dataclass(frozen=True)
class Conditions:
    """Per-pose conditions of a move: ``directions`` (m, 6) ±1, ``temperature`` (m,) °C,
    ``time`` (m,) s."""

    directions: np.ndarray
    temperature: np.ndarray
    time: np.ndarray


@dataclasses.dataclass(frozen=True)
class HiddenTruth:
    """The true mechanism: geometry, the hidden effect (``None``: none) and its parameters in
    library units (mm, rad, 1/K, mm/s; the order of the registered effect), and the achieved
    size of its signature (``magnitude``: unabsorbable RMS / noise; ``raw_magnitude``: total
    RMS / noise, whitened)."""

    geometry: Geometry
    effect: str | None
    theta: np.ndarray
    magnitude: float
    raw_magnitude: float

    def axes(self) -> np.ndarray:
        if self.effect != "actuator_tilt":
            return np.tile([0.0, 0.0, 1.0], (6, 1))
        a, b = self.theta[:6], self.theta[6:]
        ez = np.array([0.0, 0.0, 1.0])
        rx = _rot(np.stack([a, 0 * a, 0 * a], -1))
        ry = _rot(np.stack([0 * b, b, 0 * b], -1))
        return np.einsum("lij,ljk,k->li", ry, rx, ez)

    def rod_lengths(self, temperature: np.ndarray) -> np.ndarray:
        g = self.geometry
        l0 = np.linalg.norm(np.asarray(g.upper) + np.asarray(g.v0) - np.asarray(g.lower), axis=-1)
        if self.effect != "thermal_expansion":
            return np.broadcast_to(l0, (len(temperature), 6))
        return l0 * (1.0 + self.theta * (np.asarray(temperature)[:, None] - T_REF_C))

    def true_strokes(self, poses: np.ndarray, cond: Conditions) -> np.ndarray:
        """Slider strokes that put the true mechanism at ``poses`` (m, 6)."""
        g = self.geometry
        a = np.einsum("mij,lj->mli", _rot(poses[:, 3:]), np.asarray(g.upper)) + poses[:, None, :3] + np.asarray(g.v0)
        w = a - np.asarray(g.lower)
        n = self.axes()
        nw = np.einsum("li,mli->ml", n, w)
        disc = nw**2 - np.sum(w**2, -1) + self.rod_lengths(cond.temperature) ** 2
        if np.any(disc < 0):
            raise ValueError("a pose is out of reach of the true mechanism")
        return nw - np.sqrt(disc)

    def readings(self, strokes: np.ndarray, cond: Conditions) -> np.ndarray:
        """Encoder readings for true strokes."""
        e, t = self.effect, self.theta
        if e == "zero_offset":
            return strokes + t
        if e == "stroke_scale":
            return strokes / (1.0 + t)
        if e == "backlash":
            return strokes + 0.5 * t * cond.directions
        if e == "drift":
            return strokes + t * cond.time[:, None]
        return strokes

    def strokes_from_readings(self, readings: np.ndarray, cond: Conditions) -> np.ndarray:
        e, t = self.effect, self.theta
        if e == "zero_offset":
            return readings - t
        if e == "stroke_scale":
            return readings * (1.0 + t)
        if e == "backlash":
            return readings - 0.5 * t * cond.directions
        if e == "drift":
            return readings - t * cond.time[:, None]
        return readings

    def measure(self, poses: np.ndarray) -> np.ndarray:
        """Noise-free measured poses: the true poses expressed in the instrument frame."""
        if self.effect != "tracker_misalignment":
            return poses.copy()
        rho, tau = _rot(self.theta[:3]), self.theta[3:]
        v0 = np.asarray(self.geometry.v0)
        r = np.einsum("ji,mjk->mik", rho, _rot(poses[:, 3:]))
        d = (poses[:, :3] + v0 - tau) @ rho - v0
        return np.concatenate([d, _angles(r)], -1)

    def forward(self, readings: np.ndarray, cond: Conditions, initial: np.ndarray) -> np.ndarray:
        """Poses the true mechanism reaches for ``readings`` (Newton, finite-difference
        Jacobian)."""
        target = self.strokes_from_readings(readings, cond)
        p = np.array(initial, dtype=float)
        h = 1e-7
        for _ in range(20):
            f = self.true_strokes(p, cond) - target
            if np.max(np.abs(f)) < 1e-13:
                break
            step = h * np.eye(6)
            diffs = [self.true_strokes(p + step[k], cond) - self.true_strokes(p - step[k], cond) for k in range(6)]
            jac = np.stack(diffs, axis=-1) / (2 * h)
            p = p - np.linalg.solve(jac, f[..., None])[..., 0]
        return p


@dataclasses.dataclass(frozen=True)
class HiddenEffectData:
    """Simulated measured ``data`` (with ``dir``, ``temperature``, ``time``), the
    ``true_poses`` and the ``truth``."""

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


def hidden_pose_set(rng: np.random.Generator, n_random: int = 60, plan: bool = True) -> np.ndarray:
    """The 120-pose plan (optional) plus ``n_random`` uniform poses in ±1 mm / ±1°, in random
    order."""
    half = np.array([1.0] * 3 + [np.deg2rad(1.0)] * 3)
    parts = [np.asarray(sampling_plan_120())] if plan else []
    parts.append(rng.uniform(-half, half, (n_random, 6)))
    p = np.concatenate(parts)
    return p[rng.permutation(len(p))]


_res_jac = jax.jit(jax.jacfwd(stroke_residuals))
_pose_jac = jax.jit(
    jax.vmap(jax.jacfwd(lambda g, p: solve_inverse_kinematics(g, p).strokes, argnums=1), in_axes=(None, 0))
)


def _whitened_projector(geometry: Geometry, poses: np.ndarray, sigma: np.ndarray):
    jp = np.asarray(_pose_jac(geometry, jnp.asarray(poses)))
    cov = np.einsum("mik,k,mjk->mij", jp, sigma**2, jp)
    w = np.linalg.inv(np.linalg.cholesky(cov))
    data = CalibrationData(jnp.zeros_like(jnp.asarray(poses)), jnp.asarray(poses))
    g = np.asarray(_res_jac(geometry.params, data, geometry)).reshape(len(poses), 6, 36)
    gw = np.einsum("mij,mjk->mik", w, g).reshape(-1, 36)
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
    geometry: Geometry | None = None,
    noise: bool = True,
) -> HiddenEffectData:
    """Measured data of a true mechanism (default: Wang et al.'s (2018) Table 1 actual geometry) with one hidden
    ``effect`` (``None`` for none) whose unabsorbable signature is ``magnitude`` × the noise.
    ``noise=False`` leaves the noise out of the measured poses (the effect is still scaled to
    the noise level σ)."""
    if effect is not None and effect not in EFFECT_NAMES:
        raise ValueError(f"unknown effect {effect!r}; choose from {EFFECT_NAMES} or None")
    if not magnitude >= 0:
        raise ValueError(f"magnitude must be ≥ 0, got {magnitude}")
    rng = np.random.default_rng(seed)
    geometry = actual_geometry() if geometry is None else geometry
    poses = hidden_pose_set(rng, n_random, plan)
    m = len(poses)
    cond = random_conditions(rng, m)
    sigma = np.array([sigma_um * UM] * 3 + [sigma_arcsec * ARCSEC] * 3)
    theta = np.zeros(0)
    achieved = raw = 0.0
    if effect is not None:
        e = get_effect(MODEL, effect)
        direction = rng.standard_normal(e.n_params) * np.asarray(e.scale)
        # Signature of the direction, linear regime: residuals of the true geometry's
        # 36-parameter model on noise-free data, whitened, then the part the geometry absorbs
        # removed.
        probe = HiddenTruth(geometry, effect, direction * 1e-3, 0.0, 0.0)
        meas = probe.measure(poses)
        q = probe.readings(probe.true_strokes(poses, cond), cond)
        noise_free = CalibrationData(jnp.asarray(q), jnp.asarray(meas))
        sig = np.asarray(stroke_residuals(geometry.params, noise_free, geometry))
        w, basis = _whitened_projector(geometry, meas, sigma)
        sig_w = np.einsum("mij,mj->mi", w, sig.reshape(m, 6)).reshape(-1) / 1e-3
        orth = sig_w - basis @ (basis.T @ sig_w)
        orth_rms, raw_rms = np.sqrt(np.mean(orth**2)), np.sqrt(np.mean(sig_w**2))
        factor = magnitude / orth_rms if orth_rms > 1e-6 * raw_rms else magnitude / raw_rms
        theta = direction * factor
        achieved, raw = orth_rms * factor, raw_rms * factor
    truth = HiddenTruth(geometry, effect, theta, float(achieved), float(raw))
    q = truth.readings(truth.true_strokes(poses, cond), cond)
    measured = truth.measure(poses) + float(noise) * sigma * rng.standard_normal((m, 6))
    data = make_calibration_data(q, measured, cond.directions, cond.temperature, cond.time)
    return HiddenEffectData(data, poses, truth)


def write_hidden_csv(path: str | os.PathLike[str], sim: HiddenEffectData) -> None:
    """measurement CSV (``docs/conventions.md``) (with ``dir1..dir6``, ``temperature``, ``time``) plus ``true_*`` pose
    columns, readable by ``stewart-jax diagnose``."""
    p = np.array(sim.true_poses)
    p[:, 3:] = np.degrees(p[:, 3:])
    write_csv(path, sim.data, {",".join(f"true_{c}" for c in ("x", "y", "z", "rx", "ry", "rz")): p})


def true_control_error(
    truth: HiddenTruth, commanded: np.ndarray, targets: np.ndarray, cond: Conditions
) -> np.ndarray:
    """Pose error (mm, rad; ``n 6``) of the true mechanism driven to ``commanded`` readings
    for ``targets`` under conditions ``cond``."""
    return truth.forward(np.asarray(commanded), cond, targets) - targets

"""The FAST feed-support dynamics (Yin, Jiang, Chen, Yao, "Dynamic modeling of a cable-driven
parallel robot with a Stewart platform for use in FAST", received 2021; simulated by
:mod:`stewart_jax.cable_robot`) as a discrepancy model.

**Rows** are time samples of the paper's §6 scenario (eq. 62: the lower platform moves
``B x_P(t) = (A sin 2πft, 0, 0)`` relative to the cabin, A = 10 mm, f = 5 Hz). **Observations**
are the lower platform's position ``x, y, z`` in the ground frame G, relative to its nominal
rest position, in **mm** (library units; residuals are reported in µm). The **base model**
holds the cabin still: the platform follows the planned trajectory exactly, up to an unknown
constant offset of the measuring frame (3 base parameters, mm). The noise is white, isotropic
Gaussian with σ per coordinate (:func:`fast_model`, default 10 µm).

The effects (registered under ``"fast"``; ``theta = 0`` is the cabin held still):

- ``cabin_coupling`` (1 parameter κ, dimensionless): the cabin moves in reaction to the
  platform (the coupled simulation of :mod:`stewart_jax.cable_robot`); κ scales the nominal coupled
  response (κ = 1: the paper's masses and inertias).
- ``cable_elasticity`` (3 parameters, mm/s): the cabin swings freely on its elastic cables — the
  response of the cabin, platform held still, to an initial velocity ``v`` of the cabin in G
  (what an impulsive start or a gust excites; the cable springs act, the 5 Hz forcing does not).
- ``actuator_gain`` (1 parameter, dimensionless): the platform's stroke is ``(1 + k)`` × the
  planned one.
- ``actuator_delay`` (1 parameter τ, ms): the platform lags its plan, ``x(t − τ) ≈ x − τ ẋ``.

NOTE (why scaled precomputed responses are enough): all responses come from ONE batched run of
the full nonlinear coupled simulation (:func:`fast_responses`). The cabin's response is linear
in the platform's motion at these amplitudes — halving A halves the x extra error to 1.3e-7
relative, and the sub-µm y, z signals (asymmetries) to within 0.15 µm — so κ·(nominal
response) is the coupled response of a system whose reaction is κ times the nominal one (to
first order, a moving-to-total mass ratio κ·μ); likewise the free swing is linear in the
initial velocity. Every effect is therefore linear in its parameters, cheap (a gather and a
multiply-add), and exact at κ = 1, v = 0.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ..cable_robot import paper_fast_params
from ..cable_robot._coupled import CabinState, matrix_to_quat, simulate
from ..cable_robot._scenario import scenario_outputs, sine_motion, system_momentum
from ..cable_robot._statics import static_equilibrium
from ..cable_robot._system import FastParams
from ._registry import AbstractDiscrepancyModel, register_effect

MODEL_NAME = "fast"
MM = 1e-3
"""One millimetre in metres (the simulation is SI; the discrepancy model works in mm)."""
KICK_MM_S = 1.0
"""Initial cabin velocity (mm/s) of the free-swing runs behind ``cable_elasticity``."""


class FastResponses(NamedTuple):
    """The simulated responses the FAST discrepancy model is built from (one batched run of the
    coupled simulation, :func:`fast_responses`); time axis ``n``, everything in **mm**, G frame.

    - ``time``: ``Float[np.ndarray, "n"]`` (s).
    - ``planned``: ``Float[np.ndarray, "n 3"]``, planned platform displacement (cabin held still).
    - ``planned_rate``: ``Float[np.ndarray, "n 3"]``, its time derivative (mm/s).
    - ``coupled``: ``Float[np.ndarray, "n 3"]``, extra error of the coupled simulation
      (actual − planned, eq. 66; momentum start).
    - ``free``: ``Float[np.ndarray, "3 n 3"]``, platform displacement when the cabin, platform
      held still, starts with velocity 1 mm/s along G's x, y, z.
    - ``n_failed``: catenary solves that missed their tolerance in the runs (0 for trustworthy
      responses); ``static_ok``: the static equilibrium converged.
    """

    time: np.ndarray
    planned: np.ndarray
    planned_rate: np.ndarray
    coupled: np.ndarray
    free: np.ndarray
    n_failed: int
    static_ok: bool


def _batched_runs(params: FastParams, position, amplitude, frequency, dt: float, n_steps: int):
    I3 = jnp.eye(3, dtype=jnp.float64)
    static = static_equilibrium(params, position, I3)
    lower0 = sine_motion(params.h, amplitude, frequency)(jnp.asarray(0.0))
    # Momentum start of the forced run (as run_scenario's default).
    m0, lin = jax.linearize(lambda v: system_momentum(params, I3, v[:3], v[3:], lower0), jnp.zeros(6))
    v_mom = jnp.linalg.solve(jax.vmap(lin)(jnp.eye(6)).T, -m0)
    amps = jnp.array([1.0, 0.0, 0.0, 0.0]) * amplitude
    vel0 = jnp.concatenate([v_mom[None, :3], KICK_MM_S * MM * jnp.eye(3)])
    omega0 = jnp.concatenate([v_mom[None, 3:], jnp.zeros((3, 3))])

    def one(a, v, w):
        motion = sine_motion(params.h, a, frequency)
        state0 = CabinState(position, matrix_to_quat(I3), v, w)
        traj = simulate(params, static.s0, state0, static.force, motion, dt, n_steps, "verlet")
        out = scenario_outputs(params, traj, static, motion)
        rate = jax.vmap(motion)(traj.time).vel @ (traj.R[0] @ params.C_R_B).T
        return out.time, out.planned, rate, out.actual, out.extra_error, traj.n_failed

    t, planned, rate, actual, extra, n_failed = jax.vmap(one)(amps, vel0, omega0)
    return t[0], planned[0], rate[0], extra[0], actual[1:], jnp.sum(n_failed), static.converged


_batched_runs_jit = jax.jit(_batched_runs, static_argnames=("dt", "n_steps"))


def fast_responses(
    params: FastParams | None = None,
    position=(0.0, 0.0, 140.0),
    *,
    duration: float = 1.0,
    dt: float = 2e-3,
    amplitude: float = 0.01,
    frequency: float = 5.0,
) -> FastResponses:
    """Run the coupled FAST simulation once (four trajectories batched in one compiled call):
    the paper's §6 scenario with the momentum start, and three free swings of the cabin (platform
    held still) from an initial velocity of :data:`KICK_MM_S` along G's x, y, z.

    ``params`` default to :func:`~stewart_jax.cable_robot.paper_fast_params`; ``position`` is
    ``G t_C(0)`` (m); ``amplitude`` (m) and ``frequency`` (Hz) of the platform's motion;
    ``duration`` and ``dt`` in s (velocity Verlet). Compiles in ~15–25 s on 2 CPU cores.
    """
    params = paper_fast_params() if params is None else params
    n_steps = int(round(duration / dt))
    if n_steps < 2:
        raise ValueError(f"duration {duration} s at dt {dt} s gives fewer than 2 steps")
    t, planned, rate, extra, free, n_failed, ok = jax.device_get(
        _batched_runs_jit(params, jnp.asarray(position, jnp.float64), jnp.asarray(amplitude, jnp.float64),
                          jnp.asarray(frequency, jnp.float64), dt=float(dt), n_steps=n_steps)
    )
    mm = 1.0 / MM
    return FastResponses(
        np.asarray(t), np.asarray(planned) * mm, np.asarray(rate) * mm, np.asarray(extra) * mm,
        np.asarray(free) * mm / KICK_MM_S, int(n_failed), bool(ok),
    )


class FastData(NamedTuple):
    """Measured lower-platform positions at sample times.

    - ``index``: ``Int[Array, "m"]``, the rows' samples on the simulation grid of
      :class:`FastResponses` (``time = responses.time[index]``).
    - ``time``: ``Float[Array, "m"]`` (s).
    - ``position``: ``Float[Array, "m 3"]``, platform position in G relative to its nominal rest
      position (mm).
    """

    index: Int[Array, " m"]
    time: Float[Array, " m"]
    position: Float[Array, "m 3"]

    def take(self, index) -> FastData:
        index = np.asarray(index)
        return FastData(self.index[index], self.time[index], self.position[index])


class FastState(NamedTuple):
    """What the FAST effects may change; per row (``m``), mm and mm/s, G frame.

    - ``offset``: ``Float[Array, "3"]``, measuring-frame offset (base parameters).
    - ``displacement``: ``Float[Array, "m 3"]``, the platform's predicted displacement (the
      planned one in the base model).
    - ``planned``, ``planned_rate``, ``coupled``: the :class:`FastResponses` series at the rows.
    - ``free``: ``Float[Array, "3 m 3"]``, free swings per mm/s of initial cabin velocity.
    """

    offset: Float[Array, "3"]
    displacement: Float[Array, "m 3"]
    planned: Float[Array, "m 3"]
    planned_rate: Float[Array, "m 3"]
    coupled: Float[Array, "m 3"]
    free: Float[Array, "3 m 3"]


class FastModel(AbstractDiscrepancyModel):
    """The FAST lower-platform trajectory with the cabin held still (base) and the simulated
    responses its effects draw on.

    **Fields:** the :class:`FastResponses` series as arrays (mm, mm/s) and ``sigma_mm``, the
    measurement noise σ per coordinate (mm).
    """

    time: Float[Array, " n"]
    planned: Float[Array, "n 3"]
    planned_rate: Float[Array, "n 3"]
    coupled: Float[Array, "n 3"]
    free: Float[Array, "3 n 3"]
    sigma_mm: float | Array

    name: ClassVar[str] = MODEL_NAME
    output_names: ClassVar[tuple[str, ...]] = ("x", "y", "z")
    report_unit: ClassVar[str] = "µm"
    report_factor: ClassVar[float] = 1e3

    @property
    def base_initial(self) -> Float[Array, "3"]:
        return jnp.zeros(3)

    @property
    def base_scale(self) -> Float[Array, "3"]:
        return jnp.full(3, 1.0)

    def observed(self, data: FastData) -> Float[Array, "m 3"]:
        return data.position

    def initial_state(self, base: Float[Array, "3"], data: FastData, control: bool) -> FastState:
        i = data.index
        planned = self.planned[i]
        return FastState(base, planned, planned, self.planned_rate[i], self.coupled[i], self.free[:, i])

    def finish(self, state: FastState, data: FastData) -> Float[Array, "m 3"]:
        return state.offset + state.displacement

    def whitener(self, base: Float[Array, "3"], data: FastData) -> Float[Array, "m 3 3"]:
        m = data.index.shape[0]
        return jnp.broadcast_to(jnp.eye(3) / self.sigma_mm, (m, 3, 3))

    def columns(self, data: FastData) -> frozenset[str]:
        return frozenset({"time"})

    def n_rows(self, data: FastData) -> int:
        return int(data.index.shape[0])

    def take(self, data: FastData, index) -> FastData:
        return data.take(index)

    def factors(self, data: FastData) -> dict[str, np.ndarray]:
        """Time, and the planned displacement and velocity along x (the 5 Hz phase)."""
        m = self.n_rows(data)
        i = np.asarray(data.index)
        return {
            "time_s": np.broadcast_to(np.asarray(data.time)[:, None], (m, 3)),
            "planned_x_mm": np.broadcast_to(np.asarray(self.planned)[i, :1], (m, 3)),
            "planned_rate_x_mm_s": np.broadcast_to(np.asarray(self.planned_rate)[i, :1], (m, 3)),
        }


def fast_model(responses: FastResponses, sigma_um: float = 10.0) -> FastModel:
    """:class:`FastModel` from :func:`fast_responses`, with measurement noise σ (µm) per
    coordinate."""
    if not (np.isfinite(sigma_um) and sigma_um > 0):
        raise ValueError(f"sigma_um must be a finite number > 0, got {sigma_um}")
    r = responses
    return FastModel(
        jnp.asarray(r.time), jnp.asarray(r.planned), jnp.asarray(r.planned_rate), jnp.asarray(r.coupled),
        jnp.asarray(r.free), jnp.asarray(float(sigma_um) * 1e-3),
    )


# ---------------------------------------------------------------------------- effects


@register_effect(MODEL_NAME, "cabin_coupling", n_params=1, scale=1.0, unit="× nominal")
def cabin_coupling(theta: Float[Array, "1"], data: FastData, state: FastState) -> FastState:
    """The cabin is not held still: it recoils and pitches in reaction to the platform's
    motion (cables, legs and platform coupled, :func:`~stewart_jax.cable_robot.run_scenario`). The extra
    displacement is κ × the coupled simulation's extra error (κ = 1: the paper's masses; κ
    scales the moving-to-total mass ratio, to first order)."""
    return state._replace(displacement=state.displacement + theta[0] * state.coupled)


@register_effect(MODEL_NAME, "cable_elasticity", n_params=3, scale=1.0, unit="mm/s")
def cable_elasticity(theta: Float[Array, "3"], data: FastData, state: FastState) -> FastState:
    """The cabin swings freely on its elastic cables (its slow cable modes; the platform's
    5 Hz forcing not involved): the platform moves with the cabin's free response to an
    initial cabin velocity ``v`` (mm/s, G) — what an impulsive start or a gust excites."""
    return state._replace(displacement=state.displacement + jnp.einsum("j,jmk->mk", theta, state.free))


@register_effect(MODEL_NAME, "actuator_gain", n_params=1, scale=1e-2, unit="%", report_factor=100.0)
def actuator_gain(theta: Float[Array, "1"], data: FastData, state: FastState) -> FastState:
    """The platform's actuators scale its stroke: displacement ``(1 + k)`` × planned."""
    return state._replace(displacement=state.displacement + theta[0] * state.planned)


@register_effect(MODEL_NAME, "actuator_delay", n_params=1, scale=1e-3, unit="ms", report_factor=1e3)
def actuator_delay(theta: Float[Array, "1"], data: FastData, state: FastState) -> FastState:
    """The platform lags its plan by τ (s): ``x(t − τ) ≈ x(t) − τ ẋ(t)`` (τ ≪ 1/(2πf))."""
    return state._replace(displacement=state.displacement - theta[0] * state.planned_rate)



# ---------------------------------------------------------------------------- measurements


def simulate_fast_measurement(
    responses: FastResponses,
    *,
    effect: str = "cabin_coupling",
    theta=None,
    sigma_um: float = 10.0,
    stride: int = 1,
    offset_mm=(0.0, 0.0, 0.0),
    seed: int = 0,
) -> FastData:
    """"Measured" lower-platform positions (mm, G, relative to the nominal rest position):
    the planned trajectory + ``offset_mm`` + the hidden effect + Gaussian noise σ (µm) on each
    coordinate, at every ``stride``-th sample of the simulation grid.

    ``effect="cabin_coupling"`` with the default ``theta = [1]`` is the coupled simulation's
    own lower-platform trajectory (actual = planned + extra error); ``effect="none"`` holds the
    cabin still; any registered FAST effect may be hidden with its ``theta`` (library units).
    """
    from ._registry import get_effect

    if not (np.isfinite(sigma_um) and sigma_um >= 0):
        raise ValueError(f"sigma_um must be a finite number ≥ 0, got {sigma_um}")
    model = fast_model(responses, max(sigma_um, 1e-12))
    index = np.arange(0, len(responses.time), int(stride))
    data = FastData(jnp.asarray(index), jnp.asarray(responses.time[index]), jnp.zeros((len(index), 3)))
    base = jnp.asarray(offset_mm, jnp.float64)
    if effect == "none":
        clean = model.predict(base, (), (), data)
    else:
        e = get_effect(MODEL_NAME, effect)
        theta = jnp.ones(e.n_params) if theta is None and effect == "cabin_coupling" else theta
        if theta is None:
            raise ValueError(f"give theta ({e.n_params} values, library units) for effect {effect!r}")
        theta = jnp.broadcast_to(jnp.asarray(theta, jnp.float64), (e.n_params,))
        clean = model.predict(base, (e,), (theta,), data)
    noise = np.random.default_rng(seed).normal(0.0, sigma_um * 1e-3, (len(index), 3))
    return data._replace(position=clean + jnp.asarray(noise))

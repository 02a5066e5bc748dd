"""The simulation study of Wang et al. (2018) §3 (Table 2), as a Monte Carlo over seeds.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018.

Each trial: draw target poses (the paper's 8 random poses, or the 120-pose plan), simulate the
measured data (readings from the nominal model, poses from the true model plus noise),
calibrate with each method from the nominal parameters, and evaluate the control error
(command with the calibrated model, move the true mechanism) at the calibration poses and at
42 fresh validation poses. Report per component the median and 90th percentile over trials of
the maximum absolute error — the paper's Table 2 reports one run's maximum.

Every trial's randomness comes from its own key, ``jax.random.fold_in(key(seed), i)``, so a
trial's data and starting point do not depend on how the trials are chunked, split over devices
or hosts (``first_trial``), or resumed. Its numbers are the same to rounding: XLA compiles a
batch of another size to other vector loops (fused multiply–adds in a remainder loop), and
rounding differences amplified through an optimiser's iterations can change the last digits
and, rarely, an iteration count (measured: ≤ 1e-5 µm / ″ between batches of 8, 4 and 2).
Long runs go in chunks, report progress, and can write a checkpoint after every chunk. The
checkpoint holds each trial's result under its trial index, so a run restarted with the same
checkpoint computes exactly the trials it lacks — whatever the chunk size or the number of
trials of the earlier run — and never counts one twice.
"""

from __future__ import annotations

import functools
import json
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from ..calibration._assessment import GROSS_MISFIT_RATIO
from ..calibration._methods import METHOD_LABELS as METHOD_LABELS, method_label
from ..calibration._problem import (
    COMPONENTS,
    CalibrationProblem,
    calibration_problem,
    error_in_report_units,
)
from ..calibration._simulation import (
    random_poses,
    reachable_travel,
    sampling_plan_120,
    simulate_measurements,
    tracker_for,
    validation_poses,
)
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ..mechanism._pss import actual_geometry, nominal_geometry
from ..optimise._result import STATUS_NAMES, status_code
from ._checkpoint import (
    PER_TRIAL_KEYS,
    _load_checkpoint,
    _save_checkpoint,
)

PAPER_TABLE2: dict[str, list[float]] = {
    "Before calibration": [532.07, 189.03, 174.38, 250.10, 374.02, 354.99],
    "SMCS": [1.39, 3.18, 0.76, 2.76, 3.16, 4.99],
    "VSA-SMCS": [0.29, 0.24, 0.12, 0.36, 0.49, 0.29],
}
"""Wang et al. (2018), Table 2: maximum control error of one simulated calibration, dx/dy/dz in µm,
φ/θ/ψ in ″ (8 random poses)."""

BEFORE = "before"
"""Pseudo-method: the nominal parameters, uncalibrated."""


def _batch_calibrator(method: str, options: dict[str, Any]) -> Callable:
    """``(problems, keys) -> OptimiseResult`` vmapped over the trial axis, compiled once."""
    if method == BEFORE:

        def before(problems, keys):
            from ..optimise._result import RESULTS, OptimiseResult

            n = keys.shape[0]
            cost = jax.vmap(lambda p: p.cost(p.initial))(problems)
            zeros = jnp.zeros((n, 1), jnp.int32)
            status = jax.vmap(lambda _: RESULTS.successful)(zeros[:, 0])
            return OptimiseResult(problems.initial, cost, zeros[:, 0], status, cost[:, None], zeros)

        return before
    from ..calibration._methods import calibrate_batch

    return lambda problems, keys: calibrate_batch(problems, method, keys, **options)


def trial_keys(seed: int, n_trials: int, first: int = 0) -> jax.Array:
    """Keys of trials ``first … first + n_trials − 1``; trial ``i``'s key depends on ``seed`` and
    ``i`` only."""
    if first < 0:
        raise ValueError(f"first trial must be >= 0, got {first}")
    if first + n_trials > 2**32:
        raise ValueError(f"trial indices reach {first + n_trials - 1}, past 2^32 - 1: a trial's key folds its index "
                         "in as 32 bits, so trial i and i + 2^32 would be the same trial; use another seed instead")
    return jax.vmap(lambda i: jax.random.fold_in(jax.random.key(seed), i))(jnp.arange(first, first + n_trials))


def simulate_trials(
    keys: jax.Array,
    nominal: AbstractMechanism,
    actual: AbstractMechanism,
    plan: str = "paper8",
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    tracker: bool = False,
    half_width: float = 10.0,
    travel: tuple[float, ...] | None = None,
) -> tuple[CalibrationProblem, jax.Array, jax.Array, jax.Array]:
    """Independent simulated calibrations, one per key. Returns the batched problems, the
    calibration targets ``(trials, m, 6)``, validation targets ``(trials, 42, 6)`` and one
    key per trial for stochastic optimisers.

    Poses lie in the nominal mechanism's :func:`~stewart_jax.calibration.reachable_travel`
    (the paper's ±1 mm / ±1° for its mechanism) unless ``travel`` (six half-widths) is given;
    the tracker is :func:`~stewart_jax.calibration.tracker_for` the nominal mechanism."""
    if plan not in ("paper8", "plan120"):
        raise ValueError(f"the study runs plan 'paper8' or 'plan120', got {plan!r}")
    half = tuple(float(h) for h in (reachable_travel(nominal) if travel is None else travel))
    trk = tracker_for(nominal) if tracker else None
    sims, targets, validation, opt_keys = _simulate_batch(keys, nominal, actual, plan, sigma_um, sigma_arcsec,
                                                          trk, half)
    if not bool(jnp.all(sims.converged)):
        raise RuntimeError("forward kinematics of the true mechanism failed for a target pose")
    problems = jax.vmap(lambda d: calibration_problem(d, nominal, half_width))(sims.data)
    return problems, targets, validation, opt_keys


@functools.partial(jax.jit, static_argnames=("plan", "half"))
def _simulate_batch(keys, nominal, actual, plan, sigma_um, sigma_arcsec, trk, half):
    def one(key):
        k_targets, k_noise, k_val, k_opt = jax.random.split(key, 4)
        targets = random_poses(k_targets, 8, half=half) if plan == "paper8" else sampling_plan_120(half=half)
        sim = simulate_measurements(k_noise, nominal, actual, targets, sigma_um, sigma_arcsec, trk)
        return sim, targets, random_poses(k_val, 42, half=half), k_opt

    return jax.vmap(one)(keys)


def _max_errors_local(params, nominal, actual, targets, validation):
    """Max |control error| per component at the calibration and validation poses.

    :func:`~stewart_jax.calibration.control_error` of every trial, with the forward kinematics
    of the true mechanism run once over every trial's poses together (so that it is solved in
    cache-sized chunks, not trial by trial under a ``vmap``)."""
    m = targets.shape[1]
    poses = jnp.concatenate([targets, validation], axis=1)  # (trials, m + 42, 6)
    commands = jax.vmap(lambda p, t: nominal.with_params(p).solve_inverse_kinematics(t))(params, poses)
    fk = forward_kinematics(actual, commands.readings, poses)
    errors = jnp.abs(fk.poses - poses)
    ok = jnp.all(fk.converged & commands.reachable, axis=1)
    return jnp.max(errors[:, :m], axis=1), jnp.max(errors[:, m:], axis=1), ok


def _per_device(fn: Callable, n_devices: int, replicated: tuple[int, ...] = ()) -> Callable:
    """``fn`` (vmapped over the leading trial axis of its arguments) run by each of the first
    ``n_devices`` local devices on its own contiguous block of trials; the outputs are
    concatenated back in trial order (NumPy arrays). Arguments at the positions in
    ``replicated`` are copied whole to every device instead of split.

    Each block is an independent single-device program, dispatched asynchronously, so the
    devices run concurrently with no collective between them. (Placing the trial axis with a
    ``NamedSharding`` and letting ``jit`` partition the program instead turns the batched
    ``while_loop`` predicates of the solvers — "is any trial still running" — into
    cross-device all-reduces; with 2 host devices on a 2-core CPU, LM hung for good at ≥ 3
    trials per device, XLA reporting an all-reduce rendezvous that only one device joined.
    ``shard_map``, which would avoid the collectives, rejects optimistix's loops under its
    varying-axis checks, and breaks lineax's structure checks without them.)
    The block length must divide by ``n_devices``: the caller pads. Build it once per
    method so that all chunks reuse the compilation (one per device and block shape).
    """
    jitted = jax.jit(fn)
    if n_devices <= 1:
        return jitted
    devices = jax.local_devices()[:n_devices]

    def run(*args):
        n = jax.tree.leaves(args[0])[0].shape[0]
        if n % n_devices:
            raise ValueError(f"{n} trials do not split evenly over {n_devices} devices")
        size = n // n_devices
        outs = []
        for d, device in enumerate(devices):
            block = [
                a if i in replicated else jax.tree.map(lambda x, d=d: x[d * size:(d + 1) * size], a)
                for i, a in enumerate(args)
            ]
            outs.append(jitted(*jax.device_put(block, device)))
        return jax.tree.map(lambda *xs: np.concatenate([np.asarray(x) for x in xs]), *outs)

    return run


@functools.cache
def _calibrator(method: str, options_json: str, n_devices: int) -> Callable:
    """The batch calibrator of ``method`` over ``n_devices``, cached so that repeated studies
    with the same settings reuse its compilation."""
    return _per_device(_batch_calibrator(method, json.loads(options_json)), n_devices)


@functools.cache
def _max_errors_fn(n_devices: int) -> Callable:
    return _per_device(_max_errors_local, n_devices, replicated=(1, 2))


def _run_chunk(method, calibrate, keys, nominal, actual, travel, config, n_devices):
    """One chunk of trials for one method → per-trial numbers (NumPy, JSON-ready)."""
    n = keys.shape[0]
    pad = (-n) % max(n_devices, 1)
    if pad:
        keys = jnp.concatenate([keys, jnp.repeat(keys[-1:], pad, axis=0)])
    problems, targets, validation, opt_keys = simulate_trials(
        keys, nominal, actual, config["plan"], config["sigma_um"], config["sigma_arcsec"],
        config["tracker"], config["half_width_mm"], travel,
    )
    t0 = time.perf_counter()
    res = jax.block_until_ready(calibrate(problems, opt_keys))
    seconds = time.perf_counter() - t0
    errors = _max_errors_fn(n_devices)(res.params, nominal, actual, targets, validation)
    cal, val, ok = (np.asarray(x)[:n] for x in errors)
    return {
        "calibration": error_in_report_units(cal).tolist(),
        "validation": error_in_report_units(val).tolist(),
        "fk_ok": ok.tolist(),
        "cost": np.asarray(res.cost)[:n].tolist(),
        "n_evaluations": np.asarray(res.n_evaluations)[:n].tolist(),
        "status": status_code(res.status)[:n].tolist(),
        "history_cost": np.asarray(res.history_cost)[:n].tolist(),
        "history_evaluations": np.asarray(res.history_evaluations)[:n].tolist(),
        "seconds": seconds,
    }


def _check_study_args(methods, n_trials, plan, sigma_um, sigma_arcsec, half_width, chunk_size, n_devices,
                      first_trial) -> None:
    """Every setting of :func:`run_study` checked before any work, each error naming the setting."""
    from ..calibration._methods import METHOD_REGISTRY

    def whole(name, value, least):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
            raise ValueError(f"{name} must be an integer >= {least}, got {value!r}")

    whole("n_trials", n_trials, 1)
    whole("n_devices", n_devices, 1)
    whole("first_trial", first_trial, 0)
    if chunk_size is not None:
        whole("chunk_size", chunk_size, 1)
    if isinstance(methods, str) or not methods:
        raise ValueError(f"methods must be a non-empty sequence of method names from {tuple(METHOD_REGISTRY)}, "
                         f"got {methods!r}")
    unknown = [m for m in methods if m not in METHOD_REGISTRY]
    if unknown:
        raise ValueError(f"unknown method(s) {unknown}; choose from {tuple(METHOD_REGISTRY)}")
    if plan not in ("paper8", "plan120"):
        raise ValueError(f"the study runs plan 'paper8' or 'plan120', got {plan!r}")
    for name, value in (("sigma_um", sigma_um), ("sigma_arcsec", sigma_arcsec)):
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    if not (np.isfinite(half_width) and half_width > 0):
        raise ValueError(f"half_width must be a positive number (mm), got {half_width!r}")


def run_study(
    methods: Sequence[str] = ("lm-batched",),
    n_trials: int = 5,
    seed: int = 0,
    plan: str = "paper8",
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    tracker: bool = False,
    half_width: float = 10.0,
    method_options: dict[str, dict[str, Any]] | None = None,
    chunk_size: int | None = None,
    checkpoint: str | None = None,
    n_devices: int = 1,
    keep_trials: bool = False,
    log: Callable[[str], None] | None = None,
    first_trial: int = 0,
    nominal: AbstractMechanism | None = None,
    actual: AbstractMechanism | None = None,
) -> dict[str, Any]:
    """Run the Monte Carlo study; returns a JSON-ready dict (errors in µm and ″).

    ``result["rows"][label]`` holds, for the calibration poses (``"calibration"``) and the
    validation poses (``"validation"``), the median and 90th percentile over trials of the
    per-trial max error (and the per-trial values with ``keep_trials``), plus the method's
    cost, evaluation count, status counts, wall time and median convergence history, and for
    every method the median over trials of the RMS stroke residual over the stroke noise the
    stated pose noise causes (``residual_to_noise_median``; ≈ 1 or below when the nominal model
    can explain the data) and ``gross_misfit_trials``, the trials above
    :data:`~stewart_jax.calibration._assessment.GROSS_MISFIT_RATIO` (not with ``tracker``);
    ``result["warnings"]`` says which methods had any.

    ``chunk_size`` trials are computed at a time (default: all at once); with ``checkpoint``
    each finished trial is saved under its index after every chunk, and a repeated run
    computes only the trials the file lacks (any chunk size; more trials extend the study).
    Processes sharing one checkpoint merge their trials into it under a file lock; a damaged
    trial record is refused, naming the trial.
    ``n_devices > 1`` splits each chunk's trials into one block per local JAX device (the
    chunk is padded to a multiple of ``n_devices``); the blocks run concurrently.

    ``first_trial`` runs trials ``first_trial … first_trial + n_trials − 1`` of the seed's
    sequence, so that several processes or hosts can share one study: on a cluster, call
    ``jax.distributed.initialize()`` in every process, run ``run_study(..., n_trials=k,
    first_trial=jax.process_index() * k, n_devices=jax.local_device_count(),
    keep_trials=True)`` and concatenate the ``per_trial_max`` lists in process order.

    ``nominal`` and ``actual`` (default: the paper's Table 1) may be any mechanism of one
    family: the study calibrates ``nominal``'s parameters against data from ``actual``.
    """
    log = log or (lambda s: print(s, file=sys.stderr, flush=True))
    _check_study_args(methods, n_trials, plan, sigma_um, sigma_arcsec, half_width, chunk_size, n_devices, first_trial)
    if n_devices > len(jax.local_devices()):
        raise ValueError(f"n_devices={n_devices} but JAX sees {len(jax.local_devices())} local device(s)")
    nominal, actual, paper = _study_mechanisms(nominal, actual)
    options = method_options or {}
    config = {
        "nominal": nominal.to_dict(), "actual": actual.to_dict(),
        "plan": plan, "n_trials": n_trials, "seed": seed, "sigma_um": sigma_um,
        "sigma_arcsec": sigma_arcsec, "tracker": tracker, "half_width_mm": half_width,
        "method_options": options, "first_trial": first_trial,
    }
    rows, warnings = _study_rows(methods, options, config, nominal, actual, chunk_size or n_trials, n_devices,
                                 checkpoint, keep_trials, log)
    return {**config, "components": list(COMPONENTS), "units": ["um", "um", "um", "arcsec", "arcsec", "arcsec"],
            "cost_unit": f"{nominal.reading_unit}^2", "n_devices": n_devices, "rows": rows, "warnings": warnings,
            "paper_table2": PAPER_TABLE2 if paper else None}


def _study_mechanisms(nominal: AbstractMechanism | None, actual: AbstractMechanism | None
                      ) -> tuple[AbstractMechanism, AbstractMechanism, bool]:
    """The study's nominal and actual mechanisms (both given, of one family, or neither: the
    paper's Table 1) and whether they are the paper's."""
    if (nominal is None) != (actual is None):
        raise ValueError("give both nominal and actual mechanisms, or neither (the paper's Table 1)")
    if nominal is None:
        nominal, actual = nominal_geometry(), actual_geometry()
    paper = nominal.to_dict() == nominal_geometry().to_dict() and actual.to_dict() == actual_geometry().to_dict()
    if type(nominal) is not type(actual):
        raise ValueError(f"nominal ({type(nominal).__name__}) and actual ({type(actual).__name__}) "
                         "must be the same mechanism family")
    return nominal, actual, paper


def _study_rows(methods, options, config, nominal, actual, chunk, n_devices, checkpoint, keep_trials, log
                ) -> tuple[dict[str, Any], list[str]]:
    """The rows of :func:`run_study`'s result, one per method (the uncalibrated nominal first)
    under its label, over the trials of ``config``, and the warnings of gross misfits; the
    trials the checkpoint holds are kept, the others computed."""
    n_trials, first_trial = config["n_trials"], config["first_trial"]
    travel = tuple(float(h) for h in reachable_travel(nominal))  # once, not per chunk and method
    keys = trial_keys(config["seed"], n_trials, first_trial)
    state = _load_checkpoint(checkpoint, config)
    wanted = {str(i) for i in range(first_trial, first_trial + n_trials)}
    kept = {m: len(wanted & set(t)) for m, t in state["trials"].items() if m != BEFORE}
    if checkpoint and any(kept.values()):
        log(f"resuming from checkpoint {checkpoint}: kept " + ", ".join(
            f"{n}/{n_trials} trials of {m}" for m, n in kept.items() if n) + "; computing the rest")
    unsaved: dict[str, list[float]] = {}
    indices = [str(first_trial + i) for i in range(n_trials)]
    rows: dict[str, Any] = {}
    warnings: list[str] = []
    noise_mm = (0.0 if config["tracker"] else
                _reading_noise_rms_mm(nominal, config["sigma_um"], config["sigma_arcsec"]))
    representable = _truth_representable(nominal, actual, travel)
    n_poses = 8 if config["plan"] == "paper8" else 120
    for method in [BEFORE, *methods]:
        calibrate = _calibrator(method, json.dumps(options.get(method, {}), sort_keys=True), n_devices)
        seconds = _compute_trials(method, calibrate, keys, indices, chunk, state, unsaved, nominal, actual, travel,
                                  config, n_devices, checkpoint, log)
        done = state["trials"].get(method, {})
        merged = {k: [done[i][k] for i in indices] for k in PER_TRIAL_KEYS}
        label = "Before calibration" if method == BEFORE else method_label(method)
        all_seconds = state["seconds"].get(method, []) if checkpoint else seconds
        rows[label] = _row(method, options.get(method, {}), merged, all_seconds, keep_trials)
        if method != BEFORE and noise_mm > 0:
            ratio = np.sqrt(np.asarray(merged["cost"], np.float64) / (6 * n_poses)) / noise_mm
            gross = int(np.sum(~(ratio <= GROSS_MISFIT_RATIO)))
            rows[label].update(residual_to_noise_median=float(np.median(ratio)), gross_misfit_trials=gross)
            if gross:
                warnings.append(_misfit_warning(method, merged, ratio, representable))
                log(f"WARNING: {warnings[-1]}")
    return rows, warnings


def _compute_trials(method, calibrate, keys, indices, chunk, state, unsaved, nominal, actual, travel, config,
                    n_devices, checkpoint, log) -> list[float]:
    """The trials of ``method`` (``indices``, their ``keys``) that the checkpoint ``state`` lacks,
    ``chunk`` at a time: each trial's numbers stored in ``state`` under its index, each chunk's
    seconds added to ``unsaved``, the checkpoint saved after every chunk. Returns the seconds of
    the chunks computed."""
    n_trials = len(indices)
    seconds: list[float] = []
    for start in range(0, n_trials, chunk):
        stop = min(start + chunk, n_trials)
        todo = [i for i in range(start, stop) if indices[i] not in state["trials"].get(method, {})]
        if not todo:
            continue
        out = _run_chunk(method, calibrate, keys[np.asarray(todo)], nominal, actual, travel, config, n_devices)
        done = state["trials"].setdefault(method, {})
        for j, i in enumerate(todo):
            done[indices[i]] = {k: out[k][j] for k in PER_TRIAL_KEYS}
        seconds.append(out["seconds"])
        unsaved.setdefault(method, []).append(out["seconds"])
        _save_checkpoint(checkpoint, config, state, unsaved)
        if method != BEFORE:
            log(f"  {method}: trials {stop}/{n_trials} ({out['seconds']:.1f} s for {len(todo)} trials)")
    return seconds


def _reading_noise_rms_mm(nominal: AbstractMechanism, sigma_um: float, sigma_arcsec: float) -> float:
    """RMS (the reading unit: mm, or rad for a rotary family) of the reading noise the pose noise
    causes at the zero pose: the scale against
    which a trial's RMS residual ``sqrt(S / 6m)`` is a gross misfit (0 without noise)."""
    from ..calibration._identifiability import pose_noise_covariance, reading_noise_covariance

    cov = reading_noise_covariance(nominal, jnp.zeros((1, 6)), pose_noise_covariance(sigma_um, sigma_arcsec))
    return float(np.sqrt(np.trace(np.asarray(cov)[0]) / 6))


def _truth_representable(nominal: AbstractMechanism, actual: AbstractMechanism, travel: tuple[float, ...]) -> bool:
    """Whether the model ``nominal.with_params(u)`` reproduces the true mechanism exactly at
    ``u = actual.params`` (its readings at the validation poses to 1 nm or 1 nrad): then the
    simulated data are explained by construction, and a misfit is the method's, not the
    geometry's."""
    poses = validation_poses(jax.random.key(0), 12, half=np.asarray(travel))
    model = nominal.with_params(actual.params).solve_inverse_kinematics(poses).readings
    truth = actual.solve_inverse_kinematics(poses).readings
    return bool(np.all(np.isfinite(np.asarray(truth))) and np.max(np.abs(np.asarray(model - truth))) <= 1e-6)


def _misfit_warning(method: str, merged: dict[str, list], ratio: np.ndarray, representable: bool) -> str:
    """The study's warning for trials whose residuals exceed :data:`GROSS_MISFIT_RATIO` × the
    noise, its likeliest cause first: in a simulation study the budget, unless the model cannot
    represent the simulated truth."""
    bad = ~(ratio <= GROSS_MISFIT_RATIO)
    n_evals = np.asarray(merged["n_evaluations"])[bad]
    budget_codes = [STATUS_NAMES.index("max_steps"), STATUS_NAMES.index("stall")]
    on_budget = int(np.isin(np.asarray(merged["status"])[bad], budget_codes).sum())
    head = (f"{method}: {int(bad.sum())} of {len(ratio)} trials end with stroke residuals above "
            f"{GROSS_MISFIT_RATIO:g}× the stated noise (median {np.median(ratio):.3g}×)")
    budget = (f"not converged within the budget ({int(np.median(n_evals))} evaluations, median; "
              f"{on_budget} of them ended by the budget, not by the method's own convergence test): "
              "a larger --max-evaluations or a least-squares method (lm) reaches the noise floor")
    if representable:
        return (f"{head}: {budget}. The true mechanism is one the model represents exactly, so the geometry "
                "and its units are not the cause")
    return (f"{head}: most likely {budget}; if a larger budget does not close it, the nominal geometry cannot "
            "explain the true mechanism's data (the wrong geometry or parameter set, a unit slip in a geometry "
            "file)")


def _row(method, options, merged, seconds, keep_trials) -> dict[str, Any]:
    out: dict[str, Any] = {"method": method, "options": options,
                           "fk_failures": int(np.sum(~np.asarray(merged["fk_ok"])))}
    for name in ("calibration", "validation"):
        e = np.asarray(merged[name])
        out[name] = {"median": np.median(e, axis=0).tolist(), "p90": np.percentile(e, 90, axis=0).tolist()}
        if keep_trials:
            out[name]["per_trial_max"] = e.tolist()
    status, counts = np.unique(np.asarray(merged["status"]), return_counts=True)
    hist_c, hist_n = np.asarray(merged["history_cost"]), np.asarray(merged["history_evaluations"])
    out.update(
        cost_median=float(np.median(merged["cost"])),
        cost_p90=float(np.percentile(merged["cost"], 90)),
        n_evaluations_median=float(np.median(merged["n_evaluations"])),
        status_counts={int(s): int(c) for s, c in zip(status, counts, strict=True)},
        seconds_per_chunk_including_compile=seconds,
        history={
            "evaluations_median": np.median(hist_n, axis=0).tolist(),
            "cost_median": np.median(hist_c, axis=0).tolist(),
            "cost_p10": np.percentile(hist_c, 10, axis=0).tolist(),
            "cost_p90": np.percentile(hist_c, 90, axis=0).tolist(),
        },
    )
    return out


def format_study_table(result: dict[str, Any], where: str = "calibration") -> str:
    """Markdown table: median [90th percentile] over trials of the max control error."""
    units = {"um": "µm", "arcsec": "″"}
    cost_unit = result.get("cost_unit", "mm^2").replace("^2", "²")
    head = "| method | " + " | ".join(
        f"{c} ({units[u]})" for c, u in zip(result["components"], result["units"], strict=True)
    ) + f" | median S ({cost_unit}) | median evaluations |"
    lines = [head, "|" + "---|" * 9]
    for label, row in result["rows"].items():
        med, p90 = row[where]["median"], row[where]["p90"]
        cells = " | ".join(f"{m:.3g} [{p:.3g}]" for m, p in zip(med, p90, strict=True))
        lines.append(f"| {label} | {cells} | {row['cost_median']:.3g} | {row['n_evaluations_median']:.0f} |")
    if where == "calibration" and result["plan"] == "paper8" and result.get("paper_table2"):
        for label, vals in result["paper_table2"].items():
            lines.append(f"| paper: {label} | " + " | ".join(f"{v:g}" for v in vals) + " | | |")
    return "\n".join(lines)

"""The simulation study of seed 000 §3 (Table 2), as a Monte Carlo over seeds.

Each trial: draw target poses (the paper's 8 random poses, or the 120-pose plan), simulate the
measured data (strokes from the nominal model, poses from the true model plus noise),
calibrate with each method from the nominal parameters, and evaluate the control error
(command with the calibrated model, move the true mechanism) at the calibration poses and at
42 fresh validation poses. Report per component the median and 90th percentile over trials of
the maximum absolute error — the paper's Table 2 reports one run's maximum.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from ._calibration import (
    COMPONENTS,
    CalibrationProblem,
    calibration_problem,
    control_error,
    error_in_report_units,
)
from ._geometry import Geometry, actual_geometry, geometry_from_params, nominal_geometry
from ._simulation import default_tracker, random_poses, sampling_plan_120, simulate_measurements

PAPER_TABLE2: dict[str, list[float]] = {
    "Before calibration": [532.07, 189.03, 174.38, 250.10, 374.02, 354.99],
    "SMCS": [1.39, 3.18, 0.76, 2.76, 3.16, 4.99],
    "VSA-SMCS": [0.29, 0.24, 0.12, 0.36, 0.49, 0.29],
}
"""Seed 000, Table 2: maximum control error of one simulated calibration, dx/dy/dz in µm,
φ/θ/ψ in ″ (8 random poses)."""

METHOD_LABELS = {
    "lm": "LM (optimistix)",
    "lm-jaxopt": "LM (jaxopt)",
    "cs": "CS",
    "smcs": "SMCS",
    "vsa-smcs": "VSA-SMCS",
    "vsa-smcs+lm": "VSA-SMCS+LM",
    "nelder-mead": "Nelder-Mead (bounded)",
}


def _batch_calibrator(method: str, options: dict[str, Any]) -> Callable:
    """A jitted ``(problems, keys) -> OptimiseResult`` vmapped over the trial axis."""
    if method == "lm":
        from ._solver.levenberg_marquardt import LevenbergMarquardt

        solver = LevenbergMarquardt(**options)
        return jax.jit(jax.vmap(lambda p, k: solver.run(p)))
    from ._solver.calibrate import calibrate_batch

    return lambda problems, keys: calibrate_batch(problems, method, keys, **options)


def simulate_trials(
    key: jax.Array,
    n_trials: int,
    nominal: Geometry,
    actual: Geometry,
    plan: str = "paper8",
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    tracker: bool = False,
    half_width: float = 10.0,
) -> tuple[CalibrationProblem, jax.Array, jax.Array, jax.Array]:
    """``n_trials`` independent simulated calibrations. Returns the batched problems, the
    calibration targets ``(trials, m, 6)``, validation targets ``(trials, 42, 6)`` and the
    per-trial keys for stochastic optimisers."""
    k_targets, k_noise, k_val, k_opt = jax.random.split(key, 4)
    if plan == "paper8":
        targets = jax.vmap(lambda k: random_poses(k, 8))(jax.random.split(k_targets, n_trials))
    elif plan == "plan120":
        targets = jnp.broadcast_to(sampling_plan_120(), (n_trials, 120, 6))
    else:
        raise ValueError(f"the study runs plan 'paper8' or 'plan120', got {plan!r}")
    trk = default_tracker() if tracker else None
    sims = jax.vmap(
        lambda k, t: simulate_measurements(k, nominal, actual, t, sigma_um, sigma_arcsec, trk)
    )(jax.random.split(k_noise, n_trials), targets)
    if not bool(jnp.all(sims.converged)):
        raise RuntimeError("forward kinematics of the true mechanism failed for a target pose")
    problems = jax.vmap(lambda d: calibration_problem(d, nominal, half_width))(sims.data)
    validation = jax.vmap(lambda k: random_poses(k, 42))(jax.random.split(k_val, n_trials))
    return problems, targets, validation, jax.random.split(k_opt, n_trials)


@jax.jit
def _max_errors(params, actual, targets, validation):
    """Max |control error| per component at the calibration and validation poses."""

    def one(p, t, v):
        cal = geometry_from_params(p, actual.v0)
        et = control_error(cal, actual, t)
        ev = control_error(cal, actual, v)
        ok = jnp.all(et.converged) & jnp.all(ev.converged)
        return jnp.max(jnp.abs(et.errors), 0), jnp.max(jnp.abs(ev.errors), 0), ok

    return jax.vmap(one)(params, targets, validation)


def run_study(
    methods: Sequence[str] = ("lm",),
    n_trials: int = 5,
    seed: int = 0,
    plan: str = "paper8",
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    tracker: bool = False,
    half_width: float = 10.0,
    method_options: dict[str, dict[str, Any]] | None = None,
    log: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run the Monte Carlo study; returns a JSON-ready dict (errors in µm and ″).

    ``result["rows"][label]`` holds, for the calibration poses (``"calibration"``) and the
    validation poses (``"validation"``), the per-trial max errors and their median and 90th
    percentile, plus the method's cost, evaluation count, status and wall time.
    """
    log = log or (lambda s: print(s, file=sys.stderr, flush=True))
    nominal, actual = nominal_geometry(), actual_geometry()
    problems, targets, validation, keys = simulate_trials(
        jax.random.key(seed), n_trials, nominal, actual, plan, sigma_um, sigma_arcsec, tracker,
        half_width,
    )
    rows: dict[str, Any] = {}
    nominal_params = jnp.broadcast_to(nominal.params, (n_trials, 36))
    rows["Before calibration"] = _row(_max_errors(nominal_params, actual, targets, validation))
    for method in methods:
        opts = (method_options or {}).get(method, {})
        calibrate = _batch_calibrator(method, opts)
        t0 = time.perf_counter()
        res = jax.block_until_ready(calibrate(problems, keys))
        seconds = time.perf_counter() - t0
        row = _row(_max_errors(res.params, actual, targets, validation))
        row.update(
            method=method,
            options=opts,
            cost_median=float(np.median(res.cost)),
            n_evaluations_median=float(np.median(res.n_evaluations)),
            status_counts={int(s): int(c) for s, c in zip(*np.unique(res.status, return_counts=True), strict=True)},
            seconds_total_including_compile=seconds,
        )
        rows[METHOD_LABELS.get(method, method)] = row
        log(f"  {method}: {n_trials} trials in {seconds:.1f} s (incl. compile), "
            f"median S = {row['cost_median']:.3g} mm²")
    return {
        "plan": plan,
        "n_trials": n_trials,
        "seed": seed,
        "sigma_um": sigma_um,
        "sigma_arcsec": sigma_arcsec,
        "tracker": tracker,
        "half_width_mm": half_width,
        "components": list(COMPONENTS),
        "units": ["um", "um", "um", "arcsec", "arcsec", "arcsec"],
        "rows": rows,
        "paper_table2": PAPER_TABLE2,
    }


def _row(max_errors) -> dict[str, Any]:
    cal, val, ok = (np.asarray(x) for x in max_errors)
    cal, val = error_in_report_units(cal), error_in_report_units(val)
    out: dict[str, Any] = {"fk_failures": int(np.sum(~ok))}
    for name, e in (("calibration", cal), ("validation", val)):
        out[name] = {
            "per_trial_max": e.tolist(),
            "median": np.median(e, axis=0).tolist(),
            "p90": np.percentile(e, 90, axis=0).tolist(),
        }
    return out


def format_study_table(result: dict[str, Any], where: str = "calibration") -> str:
    """Markdown table: median [90th percentile] over trials of the max control error."""
    head = "| method | " + " | ".join(
        f"{c} ({u.replace('um', 'µm').replace('arcsec', '″')})"
        for c, u in zip(result["components"], result["units"], strict=True)
    ) + " |"
    lines = [head, "|" + "---|" * 7]
    for label, row in result["rows"].items():
        med, p90 = row[where]["median"], row[where]["p90"]
        cells = " | ".join(f"{m:.3g} [{p:.3g}]" for m, p in zip(med, p90, strict=True))
        lines.append(f"| {label} | {cells} |")
    if where == "calibration" and result["plan"] == "paper8":
        for label, vals in result["paper_table2"].items():
            lines.append(f"| paper: {label} | " + " | ".join(f"{v:g}" for v in vals) + " |")
    return "\n".join(lines)

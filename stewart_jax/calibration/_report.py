"""The calibration report an engineer files with a hexapod's acceptance record (Markdown).

Before/after pose errors implied by the readings at the calibration poses and at held-out poses
(calibrated without them), residuals against the stated noise, identifiability, each parameter's
change with its uncertainty, and every warning of :func:`assess_calibration`.
"""

from __future__ import annotations

import datetime
from typing import Any

import numpy as np

from .._units import COMPONENTS, ascii_unit, report_factor, report_unit
from ..mechanism._abstract import AbstractMechanism
from ._assessment import CalibrationAssessment

_UNITS = ("µm",) * 3 + ("″",) * 3


def _error_table(rows: dict[str, np.ndarray]) -> list[str]:
    head = "| | " + " | ".join(f"{c} ({u})" for c, u in zip(COMPONENTS, _UNITS, strict=True)) + " |"
    out = [head, "|---" * 7 + "|"]
    for label, e in rows.items():
        e = np.asarray(e)
        rms = np.sqrt(np.mean(e**2, axis=0))
        mx = np.max(np.abs(e), axis=0)
        out.append(f"| {label} | " + " | ".join(f"{r:.3g} / {m:.3g}" for r, m in zip(rms, mx, strict=True)) + " |")
    return out


def calibration_report(
    *,
    source: dict[str, str],
    nominal: AbstractMechanism,
    calibrated: AbstractMechanism,
    result: dict[str, Any],
    assessment: CalibrationAssessment,
    pose_errors: dict[str, np.ndarray],
    heldout: dict[str, Any] | None,
) -> str:
    """Markdown text of the report.

    ``source``: what was calibrated (``data``, ``geometry``, ``method`` …); ``result``: the
    calibrate command's JSON; ``pose_errors``: label → ``(m, 6)`` implied pose errors (µm, ″) at the
    calibration poses; ``heldout``: ``{"rows": [...], "errors": {label: (k, 6)}}`` or ``None``.
    """
    a = assessment
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [f"# Calibration report — {nominal.family} hexapod", "", f"Written {now} by stewart-jax.", ""]
    lines += [f"- **{k}**: `{v}`" for k, v in source.items()]
    lines += ["", "## Verdict", ""]
    verdict = {
        "ok": "The data identify every parameter and the residuals match the stated noise.",
        "poor_fit": "**The residuals exceed what the stated noise explains** — see the warnings before using "
                    "the result.",
        "rank_deficient": "**The data do not identify every parameter** — see the warnings; the unidentified "
                          "parameters kept arbitrary values.",
        "partly_determined": "The residuals match the stated noise; the parameter directions the data do not "
                             "determine are held at nominal (see the warnings), and each std includes the prior's "
                             "share on them.",
        "nonfinite": "**The calibration failed** (non-finite residuals).",
    }[a.status]
    lines += [f"Solver status: `{result['status']}`; data status: `{a.status}`. {verdict}", ""]
    if a.warnings:
        lines += ["### Warnings", ""] + [f"- {w}" for w in a.warnings] + [""]
    reading = report_unit(nominal.reading_unit)
    lines += ["## Fit", "",
              f"- poses: {result['n_poses']}; parameters: {a.n_params}",
              f"- cost S = {result['cost']:.6g} {nominal.reading_unit}², RMS reading residual "
              f"{result[f'rms_residual_{ascii_unit(reading)}']:.4g} {reading}",
              f"- χ² = {a.chi2:.4g} on {a.dof} degrees of freedom (p = {a.p_value:.3g}); residuals "
              f"{a.rms_ratio:.3g}× the stated noise",
              f"- identification rank {a.rank} of {a.n_params}, condition number {a.condition_number:.3g}",
              ""]
    lines += ["## Pose error implied by the readings (RMS / max)", "",
              "At each measured pose, `J⁻¹·(q' − IK(P'))`: how far the model's pose for the readings lies from the "
              "measured pose — the control error to first order, measurement noise included.", "",
              "### At the calibration poses", ""] + _error_table(pose_errors) + [""]
    if heldout is not None:
        lines += [f"### At {len(heldout['rows'])} held-out poses (calibrated without them)", ""]
        lines += _error_table(heldout["errors"]) + [""]
    lines += ["## Parameters", "", "| parameter | unit | nominal | calibrated | change | std |",
              "|---|---|---|---|---|---|"]
    u0, u1 = np.asarray(nominal.params), np.asarray(calibrated.params)
    for name, unit, a0, a1, s in zip(nominal.param_names, nominal.param_units, u0, u1, a.param_std, strict=True):
        f, small = report_factor(unit), report_unit(unit)
        std = "not identifiable" if not np.isfinite(s) else f"{s * f:.3g} {small}"
        lines.append(f"| {name} | {unit} | {a0:.6f} | {a1:.6f} | {(a1 - a0) * f:+.4g} {small} | {std} |")
    lines += ["", "Each parameter in its unit (mm for lengths, rad or mrad for angles); the change and the std in "
              "µm or µrad; std from the stated pose noise, linearised at the calibrated parameters."]
    return "\n".join(lines) + "\n"

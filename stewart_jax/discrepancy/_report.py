"""Result types of the discrepancy workflow: the fitted (augmented) model, one candidate's
scores, a skipped candidate, and the diagnosis report with its JSON form (the contract of
``stewart-jax diagnose --json``).

The statistics behind the fields are those of :mod:`~stewart_jax.discrepancy._statistics`
(χ²/F tests of nested models, BIC, the predictive held-out χ²) and the absorption of
:mod:`~stewart_jax.discrepancy._subspace`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, NamedTuple

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from ._registry import AbstractDiscrepancyModel, Effect
from ._statistics import WhereAnalysis


class FittedModel(eqx.Module):
    """A calibrated model, possibly augmented by effects (the workflow's step 3).

    - ``model``: the :class:`AbstractDiscrepancyModel` (its base parameters are replaced by
      ``base`` here).
    - ``effects``: the effects added (static).
    - ``base``: ``Float[Array, "p"]``, fitted base parameters (library units).
    - ``thetas``: per effect ``Float[Array, "k_e"]``, fitted effect parameters (library units).
    """

    model: AbstractDiscrepancyModel
    effects: tuple[Effect, ...] = eqx.field(static=True)
    base: Float[Array, " p"]
    thetas: tuple[Float[Array, " _"], ...]

    def predict(self, data: Any) -> Float[Array, "m k"]:
        """Predicted observations for measured data (all effects)."""
        return self.model.predict(self.base, self.effects, self.thetas, data)

    def commanded(self, data: Any) -> Float[Array, "m k"]:
        """What to command to reach the rows of ``data`` (6-PSS: readings for target poses in
        ``data.poses``, with the approach directions / temperature / time the effects need).
        Measurement-side effects are dropped."""
        have = self.model.columns(data)
        for e in self.effects:
            missing = [c for c in e.requires if c not in have] if e.acts_on == "mechanism" else []
            if missing:
                raise ValueError(f"the model includes {e.name!r}, which needs {missing} to command a move")
        return self.model.predict(self.base, self.effects, self.thetas, data, control=True)

    def effect_report(self) -> list[dict[str, Any]]:
        """Per effect: name, parameters in report units, unit, side, and for discovered terms their
        definition (``terms``) (JSON form)."""
        return [
            {
                "effect": e.name,
                "params": (np.asarray(t) * np.asarray(e.report_factor)).tolist(),
                "unit": e.unit,
                "acts_on": e.acts_on,
            }
            | ({"terms": e.terms.to_dict()} if e.terms is not None else {})  # the open search's
            for e, t in zip(self.effects, self.thetas, strict=True)
        ]


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One candidate effect's scores on one data set.

    - ``effect``: its name.
    - ``score``: ``BIC(base) − BIC(base + effect)`` (higher is better; > 0 favours the effect).
    - ``bic``: BIC of base + effect.
    - ``delta_chi2``: drop of the whitened training χ² from the base fit.
    - ``dof``: degrees of freedom of the likelihood-ratio test (= ``identifiable_rank``).
    - ``p_value``: p of "the effect explains nothing" (χ², or F with σ estimated).
    - ``significant``: ``p_value`` below ``alpha / K`` (Bonferroni over the testable candidates).
    - ``heldout_chi2``, ``heldout_p``: predictive χ² of the held-out residuals of base + effect,
      and its p-value.
    - ``heldout_rms``: held-out residual RMS of base + effect (the model's report unit).
    - ``absorbed_fraction``, ``identifiable_rank``, ``sines``: see :class:`Absorption`.
    - ``converged``: the fit converged.
    - ``params``: fitted effect parameters in report units (``unit``).
    - ``explains``: significant, and base + effect passes the held-out test at the detection's
      ``alpha`` (closes the gap to the noise floor): only such a candidate can be named.
    - ``gap_share``: the share of the held-out gap it removes,
      ``(gap_before² − heldout_rms²) / (gap_before² − noise_floor_predictive²)`` (1: all of the
      excess over the noise; ≤ 0: none, or the gap grew).
    """

    effect: str
    score: float
    bic: float
    delta_chi2: float
    dof: int
    p_value: float
    significant: bool
    heldout_chi2: float
    heldout_p: float
    heldout_rms: float
    absorbed_fraction: float
    identifiable_rank: int
    sines: tuple[float, ...]
    converged: bool
    params: list[float]
    unit: str
    explains: bool = False
    gap_share: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["sines"] = list(self.sines)
        d["min_sine"] = min(self.sines) if self.sines else 0.0
        return d


class SkippedEffect(NamedTuple):
    """A candidate left out of the analysis and why (a missing data column, too few rows)."""

    effect: str
    reason: str

    def to_dict(self) -> dict[str, str]:
        return {"effect": self.effect, "reason": self.reason}


def _distinct(a: float, b: float) -> tuple[str, str]:
    """``a`` and ``b`` to 3 significant digits, or to as many more (up to 6) as tell them apart."""
    for digits in range(3, 7):
        sa, sb = f"{a:.{digits}g}", f"{b:.{digits}g}"
        if sa != sb:
            break
    return sa, sb


QUIET_FACTOR = 0.5
"""Held-out residuals whose RMS is below this fraction of the noise floor, with the noise given
(not estimated), contradict the noise model: at the hundreds of residuals of a held-out set the
ratio of RMS to floor stays within a few per cent of 1 when the stated noise is right."""

MIN_PARTIAL_SHARE = 0.01
"""The share of the held-out gap (above the noise floor) a candidate must remove to be called a
partial explanation; less is reported as barely shrinking the gap, not as "removes 0 %"."""


@dataclasses.dataclass(frozen=True)
class DiagnosisReport:
    """Result of :func:`~stewart_jax.discrepancy.diagnose`; ``to_dict()`` gives the JSON of
    ``stewart-jax diagnose``. Residual sizes are in the model's report unit
    (``fitted.model.report_unit``; µm for the 6-PSS model).

    - ``model``: the model's registry name.
    - ``detected``, ``detect_statistic``, ``detect_dof``, ``detect_p_value``: the held-out test
      of the base model against the noise alone.
    - ``named_effect``: the named candidate, one that explains the discrepancy with no further
      effect (``None`` unless ``explained``); the summary names it as the single cause only when
      ``indistinguishable_from`` (candidates the data cannot reject against it) is empty;
      ``additional_effects``: candidates that explain more on top of it.
    - ``explained``: a candidate (or, with ``discovered``, a set of discovered terms) closes the
      held-out gap to the noise floor.
    - ``partial``: significant candidates that do not close the gap, each a dict with
      ``effect``, ``gap_share`` (see :class:`Candidate`), ``heldout_rms``, ``heldout_p``; and a
      candidate that closes it only with further effects (``needs``: those effects).
    - ``equivalences``: per other identifiable candidate, how much of its fitted signature lies
      outside base + the named one and of the named one's outside base + it, and whether each
      reproduces the other (``_equivalence.py``).
    - ``separated_by``: when the named effect is indistinguishable from others, per member of
      the set the measurement that would tell it apart.
    - ``absorbed_by``: per completely absorbed candidate, the base parameters a change of which
      reproduces it.
    - ``discovered``: terms found by the open search when no candidate explains (dicts, see
      the open term search of ``_discovery.py``); empty if none was run or found.
    - ``ranking``: every :class:`Candidate`, identifiable ones first, by score.
    - ``absorbed``: candidates the base parameters absorb completely; ``skipped``: the
      :class:`SkippedEffect` list.
    - ``gap_before``, ``gap_after``: held-out residual RMS of the base and the augmented model.
    - ``noise_floor``: RMS of the noise alone; ``noise_floor_predictive``: including the
      prediction error of the fitted base parameters.
    - ``derived_before``, ``derived_after``: RMS of the model's derived errors (6-PSS: pose
      errors, µm and ″) by name.
    - ``where_before``, ``where_after``: :class:`WhereAnalysis` of the held-out residuals.
    - ``base_chi2``, ``base_dof``: the base fit's training χ² and residual dof.
    - ``noise_estimated``, ``noise_scale``: σ taken from the base fit, and the fitted σ / model σ.
    - ``alpha``: false-alarm level; ``n_train``, ``n_test``: rows.
    - ``fitted``, ``base_fitted``: the augmented and the base :class:`FittedModel`.
    - ``residuals_before``, ``residuals_after``: ``(m_te, k)`` held-out residuals (report unit).
    - ``test_factors``: the held-out rows' factors (name → ``(m_te, k)``).
    - ``notes``: warnings (non-converged base fit, rank-deficient base).
    """

    model: str
    detected: bool
    detect_statistic: float
    detect_dof: float
    detect_p_value: float
    named_effect: str | None
    indistinguishable_from: list[str]
    additional_effects: list[str]
    ranking: list[Candidate]
    absorbed: list[str]
    skipped: list[SkippedEffect]
    gap_before: float
    gap_after: float
    noise_floor: float
    noise_floor_predictive: float
    derived_before: dict[str, float]
    derived_after: dict[str, float]
    where_before: WhereAnalysis
    where_after: WhereAnalysis
    base_chi2: float
    base_dof: int
    noise_estimated: bool
    noise_scale: float
    alpha: float
    n_train: int
    n_test: int
    fitted: FittedModel
    base_fitted: FittedModel
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    test_factors: dict[str, np.ndarray]
    notes: list[str] = dataclasses.field(default_factory=list)
    explained: bool = False
    partial: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    absorbed_by: dict[str, list[str]] = dataclasses.field(default_factory=dict)
    discovered: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    equivalences: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    separated_by: dict[str, str] = dataclasses.field(default_factory=dict)

    def summary(self) -> list[str]:
        """The verdict in plain sentences (what ``stewart-jax diagnose`` prints)."""
        unit = self.fitted.model.report_unit
        gap = f"held-out RMS {self.gap_before:.3g} → {self.gap_after:.3g} {unit}, noise floor {self.noise_floor:.3g}"
        lines = []
        claimed = self.named_effect is not None or (self.explained and self.discovered)
        refuted = self.detected and claimed and not self.gap_after < self.gap_before
        if refuted:
            lines.append(f"not explained: the {'named effect' if self.named_effect else 'discovered terms'} fit the "
                         f"training rows but the held-out gap did not shrink ({gap}); check the record's units "
                         "(mm and degrees) and that the model applies")
        elif not self.detected:
            lines.append(f"no discrepancy detected (held-out p = {self.detect_p_value:.3g}); {gap}")
        elif self.named_effect is not None and self.indistinguishable_from:
            names = ", ".join([self.named_effect, *self.indistinguishable_from])
            lines.append(f"explained, but by any of {names}: indistinguishable for these data, no single cause; "
                         f"{gap}")
            lines += [f"to tell {n} apart: {how}" for n, how in self.separated_by.items()]
        elif self.named_effect is not None:
            lines.append(f"named: {self.named_effect}; it closes the gap and nothing else explains as well: {gap}")
        elif self.explained and self.discovered:
            lines.append(f"no candidate explains the discrepancy; discovered terms close the gap: {gap}")
        else:
            lines.append(f"a discrepancy is present that no candidate explains (held-out p = "
                         f"{self.detect_p_value:.3g}); {gap}")
        if not self.noise_estimated and self.gap_before < QUIET_FACTOR * self.noise_floor:
            ratio = self.noise_floor / self.gap_before if self.gap_before > 0 else math.inf
            lines.append(
                f"the held-out residuals (RMS {self.gap_before:.3g} {unit}) are {ratio:.3g}× "
                f"below the noise floor ({self.noise_floor:.3g} {unit}): the stated noise is far too large for these "
                "data, or the data are not in the units the model reads (metres for mm, radians for degrees?); at "
                "this noise no discrepancy can be detected")
        for p in self.partial:
            if p.get("needs"):
                lines.append(f"partial explanation: {p['effect']} passes the held-out test, but "
                             f"{', '.join(p['needs'])} explain(s) significantly more on top of it")
                continue
            if p["gap_share"] >= MIN_PARTIAL_SHARE:
                lines.append(f"partial explanation: {p['effect']} removes {100 * p['gap_share']:.0f} % of the gap "
                             f"(held-out RMS {p['heldout_rms']:.3g} {unit}); the rest is unexplained")
            else:  # significant on the training rows, but the held-out gap does not (or barely) shrink
                how = ("widens" if p["heldout_rms"] > self.gap_before else
                       "barely shrinks" if p["gap_share"] > 0 else "does not shrink")
                before, after = _distinct(self.gap_before, p["heldout_rms"])
                sliver = f"; less than {100 * MIN_PARTIAL_SHARE:.0f} % of the gap" if how == "barely shrinks" else ""
                lines.append(f"not an explanation: {p['effect']} {how} the held-out gap "
                             f"(RMS {before} → {after} {unit}{sliver})")
        for t in self.discovered:
            if refuted:  # the search's own (linearised) figure, which the refitted model does not bear out
                lines.append(f"discovered, not an explanation: {t['description']} (held-out RMS {t['gap_after']:.3g} "
                             f"{unit} in the term search; the refitted model's is {self.gap_after:.3g} {unit})")
            else:
                lines.append(f"discovered: {t['description']} (held-out RMS after it {t['gap_after']:.3g} {unit})")
        for name, params in self.absorbed_by.items():
            shown = ", ".join(params[:8]) + (", …" if len(params) > 8 else "")
            lines.append(f"{name}: absorbed by the geometry (indistinguishable from a change of parameters {shown})")
        return lines + list(self.notes)

    def to_dict(self) -> dict[str, Any]:
        unit = self.fitted.model.report_unit
        return _jsonable(
            {
                "model": self.model,
                "detected": self.detected,
                "explained": self.explained,
                "named_effect": self.named_effect,
                "partial": self.partial,
                "discovered": self.discovered,
                "absorbed_by": self.absorbed_by,
                "summary": self.summary(),
                "indistinguishable_from": self.indistinguishable_from,
                "equivalences": self.equivalences,
                "separated_by": self.separated_by,
                "ranking": [c.to_dict() for c in self.ranking],
                "gap_before": self.gap_before,
                "gap_after": self.gap_after,
                "noise_floor": self.noise_floor,
                "noise_floor_predictive": self.noise_floor_predictive,
                "gap_unit": unit,
                "additional_effects": self.additional_effects,
                "absorbed": self.absorbed,
                "skipped": [s.to_dict() for s in self.skipped],
                "detection": {
                    "test": "F (σ estimated)" if self.noise_estimated else "chi2 (σ given)",
                    "statistic": self.detect_statistic,
                    "dof": self.detect_dof,
                    "p_value": self.detect_p_value,
                    "alpha": self.alpha,
                },
                "base_fit": {"chi2": self.base_chi2, "dof": self.base_dof, "noise_scale": self.noise_scale},
                "derived_error_rms_before": self.derived_before,
                "derived_error_rms_after": self.derived_after,
                "where_before": self.where_before.to_dict(),
                "where_after": self.where_after.to_dict(),
                "augmented_model": {
                    "base_params": np.asarray(self.fitted.base).tolist(),
                    "effects": self.fitted.effect_report(),
                },
                "n_train": self.n_train,
                "n_test": self.n_test,
                "notes": self.notes,
            }
        )


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, float | np.floating):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer | np.bool_):
        return x.item()
    return x

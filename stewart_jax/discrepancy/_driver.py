"""Detect, name, add, show: the driver of the model-discrepancy workflow, for any
:class:`~stewart_jax.discrepancy.AbstractDiscrepancyModel`.

1. **Detect.** Fit the base model on a training part (weighted least squares with the model's
   whitener); test the held-out residuals against the noise alone (a χ² test that includes the
   uncertainty of the fitted parameters) at false-alarm level ``alpha``; report per factor and
   output how the held-out residuals depend on the factors ("where").
2. **Name.** Fit base + each candidate effect on the training part; per candidate:
   likelihood-ratio test against the base model with the effect's *identifiable* degrees of
   freedom, BIC, held-out χ², and how much of its signature the base parameters absorb. A
   candidate *explains* the discrepancy when it is significant and the augmented model passes
   the same held-out test that detected the discrepancy, at the same ``alpha``; only such a
   candidate is named (the best by BIC). A significant candidate that does not pass is a
   *partial* explanation, reported with the share of the gap it removes; a candidate the base
   parameters absorb completely is reported with the base parameters that absorb it.
   Candidates that the data cannot reject against the named one (encompassing test, Mizon and
   Richard 1986, "The encompassing principle and its application to testing non-nested
   hypotheses", Econometrica 54) are ``indistinguishable_from``.
3. **Add.** The named effect's fit is the augmented model (:class:`FittedModel`), usable for
   control (:meth:`FittedModel.commanded`). When nothing explains the gap, the base model stays
   the fitted one (an open search of terms is in ``_discovery.py``).
4. **Show.** Held-out residual RMS before/after against the noise floor, derived errors
   (6-PSS: pose errors) before/after, the "where" analysis after the fix.

The tests on one data set (detect, name) are in ``_naming.py``, the statistics in
``_statistics.py``, the subspace algebra in ``_subspace.py``, the fits in ``_fits.py``, the result
types in ``_report.py``.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._discovery import challenge, describe, supports_discovery, term_units
from ._equivalence import equivalences, separated_by
from ._fits import effect_slices, fit_candidates, fit_pairs, unpack
from ._naming import DataSet, Decision, decide, pair_tests
from ._registry import AbstractDiscrepancyModel, Effect, effects_for
from ._report import Candidate, DiagnosisReport, FittedModel, SkippedEffect
from ._statistics import where_analysis
from ._subspace import absorbing_params, base_param_names, prediction_factor
from ._term_ensemble import TermInputs, earn_place, reproduced_by


@eqx.filter_jit
def _raw_base_residual(model: AbstractDiscrepancyModel, base: Any, data: Any) -> Any:
    return model.observed(data) - model.predict(base, (), (), data)


MIN_DOF = 6
"""Fewest residual degrees of freedom a fit must keep (data rows × outputs − parameters)."""


def split_rows(n: int, holdout_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A seeded random train/held-out split of ``n`` rows: sorted ``(train, held_out)`` indices."""
    if not 0 < holdout_fraction < 1:
        raise ValueError(f"holdout_fraction must be in (0, 1), got {holdout_fraction}")
    perm = np.random.default_rng(seed).permutation(n)
    n_te = int(round(n * holdout_fraction))
    return np.sort(perm[n_te:]), np.sort(perm[:n_te])


def select_effects(
    model: AbstractDiscrepancyModel, data: Any, n_train: int, names: Sequence[str] | None = None
) -> tuple[tuple[Effect, ...], list[SkippedEffect]]:
    """The candidates that can be fitted to ``data`` (``n_train`` training rows), and the
    skipped ones with the reason (a missing column, too few rows for the parameters)."""
    registered = {e.name: e for e in effects_for(model.name)}
    if names is None:
        names = list(registered)
    unknown = [n for n in names if n not in registered]
    if unknown:
        raise ValueError(f"unknown effect(s) {unknown} for model {model.name!r}; known: {sorted(registered)}")
    have = model.columns(data)
    n_obs = n_train * len(model.output_names)
    nb = model.base_initial.shape[0]
    chosen, skipped = [], []
    for n in names:
        e = registered[n]
        missing = [c for c in e.requires if c not in have]
        if missing:
            cols = ", ".join(model.file_columns.get(c, c) for c in missing)
            skipped.append(SkippedEffect(n, f"needs the column(s) {cols}, which the data lack"))
        elif n_obs - nb - e.n_params < MIN_DOF:
            skipped.append(
                SkippedEffect(
                    n,
                    f"{n_train} training rows give {n_obs} observations, too few for "
                    f"{nb} + {e.n_params} parameters (need {nb + e.n_params + MIN_DOF})",
                )
            )
        else:
            chosen.append(e)
    return tuple(chosen), skipped


def check_sizes(model: AbstractDiscrepancyModel, n_rows: int, n_train: int, n_test: int) -> None:
    """Clear errors for data that cannot support the question."""
    k = len(model.output_names)
    nb = model.base_initial.shape[0]
    if n_train * k - nb < MIN_DOF:
        need = math.ceil((nb + MIN_DOF) / k)
        raise ValueError(
            f"{n_rows} rows split into {n_train} training rows ({n_train * k} observations) cannot "
            f"calibrate {nb} base parameters with ≥ {MIN_DOF} residual degrees of freedom: at least "
            f"{need} training rows are needed (lower holdout_fraction or measure more poses)"
        )
    if n_test < 2:
        raise ValueError(f"{n_rows} rows leave {n_test} held-out row(s); at least 2 are needed for the test")


def diagnose(
    data: Any,
    model: AbstractDiscrepancyModel,
    *,
    effects: Sequence[str] | None = None,
    holdout_fraction: float = 0.3,
    seed: int = 0,
    alpha: float = 0.05,
    estimate_noise: bool = False,
    discover: bool = True,
    temperature_std_k: float = 0.0,
    progress: Callable[[str], None] | None = None,
) -> DiagnosisReport:
    """Run the discrepancy workflow on one data set (see the module docstring).

    ``effects``: candidate names (default: every effect registered for the model; those whose
    column is missing are skipped and reported). ``alpha``: false-alarm level of the detection
    test; candidates are tested at ``alpha / K`` (Bonferroni over the ``K`` candidates).
    ``estimate_noise``: take the noise scale from the base fit's training residuals (F tests)
    instead of trusting the model's σ (χ² tests). ``discover``: when a discrepancy is detected
    that no candidate explains, search the open library of terms (``_discovery.py``).
    ``temperature_std_k``: standard deviation of the recorded temperature (K); a candidate that
    reads it is tested with that error in its prediction (``_errors_in_variables.py``).
    ``progress``: called with a line of text as each stage starts and ends (the fits, the tests
    and naming, with their times).
    """
    if not temperature_std_k >= 0:
        raise ValueError(f"temperature_std_k must be ≥ 0 K, got {temperature_std_k}")
    n = model.n_rows(data)
    train_idx, test_idx = split_rows(n, holdout_fraction, seed)
    check_sizes(model, n, len(train_idx), len(test_idx))
    chosen, skipped = select_effects(model, data, len(train_idx), effects)
    if not chosen:
        raise ValueError(f"no candidate effect can be fitted to these data: {[s.to_dict() for s in skipped]}")
    train, test = model.take(data, train_idx), model.take(data, test_idx)
    return diagnose_many(model, chosen, [train], [test], alpha=alpha, estimate_noise=estimate_noise, skipped=skipped,
                         discover=discover, temperature_std_k=temperature_std_k, progress=progress)[0]


def _stack(items):
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *items)


def diagnose_many(
    model: AbstractDiscrepancyModel,
    effects: Sequence[Effect],
    trains: Sequence[Any],
    tests: Sequence[Any],
    *,
    alpha: float = 0.05,
    estimate_noise: bool = False,
    skipped: Sequence[SkippedEffect] | None = None,
    discover: bool = True,
    temperature_std_k: float = 0.0,
    progress: Callable[[str], None] | None = None,
) -> list[DiagnosisReport]:
    """:func:`diagnose` on many train/held-out pairs at once (same shapes and columns; all
    fits batched). ``effects`` must be applicable to every data set."""
    say = progress or (lambda text: None)
    effects = tuple(effects)
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    for e in effects:
        if e.model != model.name:
            raise ValueError(f"effect {e.name!r} belongs to model {e.model!r}, not {model.name!r}")
    if len(trains) > 1 and not model.batched_fits:
        # NOTE: one data set at a time (the same compiled kernels): see the model's
        # ``batched_fits``.
        return [diagnose_many(model, effects, [tr], [te], alpha=alpha, estimate_noise=estimate_noise,
                              skipped=skipped, discover=discover, temperature_std_k=temperature_std_k,
                              progress=progress)[0]
                for tr, te in zip(trains, tests, strict=True)]
    train_b, test_b = _stack(trains), _stack(tests)
    t0 = time.perf_counter()
    say(f"fitting the base model and {len(effects)} candidate(s) ({', '.join(e.name for e in effects)}) on "
        f"{model.n_rows(trains[0])} training rows …")
    fits = fit_candidates(model, effects, train_b, test_b)
    say(f"fits done in {time.perf_counter() - t0:.1f} s; testing, naming"
        + (" and, if nothing is named, searching the open library of terms …" if discover else " …"))
    t0 = time.perf_counter()
    nb = model.base_initial.shape[0]
    slices = effect_slices(model, effects)
    known = not estimate_noise

    sets = [DataSet(b, fits, model, effects, slices, nb, alpha, known, trains[b], tests[b], temperature_std_k)
            for b in range(len(trains))]
    decisions = _compare_named(sets, [decide(ds) for ds in sets], train_b, test_b)
    reports = [_finish(ds, dec, list(skipped or []), discover) for ds, dec in zip(sets, decisions, strict=True)]
    say(f"naming done in {time.perf_counter() - t0:.1f} s")
    return reports


def _compare_named(sets: list[DataSet], decisions: list[Decision], train_b, test_b) -> list[Decision]:
    """The decisions after the named candidate of each data set is compared with every other
    significant one (``train_b``, ``test_b``: the data sets stacked).

    NOTE: the named candidate is compared with every other significant one by fitting both
    together (encompassing tests). If the named one is rejected against the pair while the
    other is not, the other explains everything the named one does and more: it is named
    instead and compared again (at most once per candidate)."""
    decisions = list(decisions)
    ds0 = sets[0]
    model, effects, fits, k = ds0.model, ds0.effects, ds0.fits, len(ds0.effects)
    visited = [{d.named_index} for d in decisions]
    pending = [b for b, d in enumerate(decisions) if d.named_index is not None and len(d.significant) > 1]
    while pending:
        masks = np.zeros((len(sets), k + 1, k))
        jobs = []
        for b in pending:
            a = decisions[b].named_index
            others = [c for c in decisions[b].significant if c != a]
            for j, c in enumerate(others):
                masks[b, j, [a, c]] = 1.0
                jobs.append((b, j, c))
        chi2_pairs = fit_pairs(model, effects, masks, train_b, test_b, fits)
        again = []
        for b in pending:
            dec = decisions[b]
            dec = dataclasses.replace(dec, pairs={c: float(chi2_pairs[b, j]) for bb, j, c in jobs if bb == b})
            outcome = pair_tests(dec, np.asarray(fits.jac_tr[b]), ds0.slices, ds0.nb, ds0.known)
            dominating = [
                c for c, (p_c, p_a) in outcome.items()
                if p_c >= ds0.alpha and p_a < dec.level and dec.cands[c].explains
            ]
            dominating = [c for c in dominating if c not in visited[b]]
            if dominating:
                dec = dataclasses.replace(dec, named_index=max(dominating, key=lambda c: dec.cands[c].score))
                visited[b].add(dec.named_index)
                again.append(b)
            else:
                dec = dataclasses.replace(dec, outcome=outcome)
            decisions[b] = dec
        pending = again
    return decisions


def _fitted(ds: DataSet, i: int | None) -> FittedModel:
    """The base fit (``i`` ``None``) or the fit of base + candidate ``i`` of data set ``ds``."""
    mask = np.zeros(len(ds.effects))
    effs = ()
    if i is not None:
        mask[i] = 1.0
        effs = (ds.effects[i],)
    z = np.asarray(ds.fits.z[ds.b])
    base, thetas = unpack(ds.model, ds.effects, jnp.asarray(z[0 if i is None else i + 1]), jnp.asarray(mask))
    return FittedModel(ds.model, effs, base, tuple(thetas[j] for j in range(len(ds.effects)) if mask[j]))


class _Naming(NamedTuple):
    """The name that stands after the pair tests and the open search's challenge: the named
    candidate's index (``None``: none), the candidates indistinguishable from it and those that
    add to it, the candidates (a contested one no longer explains) and the notes on why."""

    named: int | None
    indistinguishable: list[str]
    additional: list[str]
    cands: tuple[Candidate, ...]
    notes: list[str]
    demoted: int | None = None
    equivalences: list[dict[str, Any]] = []


def _settle_name(ds: DataSet, dec: Decision, discover: bool) -> _Naming:
    """The pair tests' verdicts on the named candidate, then the open search's challenge to it."""
    effects, model = ds.effects, ds.model
    a, cands = dec.named_index, dec.cands
    indist, additional, notes = [], [], []
    # NOTE: "c explains all that a ∪ c does" is tested against every other significant candidate
    # at once; a wrong rejection turns "indistinguishable" into a confident wrong name, so it is
    # rejected at the candidates' Bonferroni level, not at alpha (measured: a hidden instrument
    # misalignment on the 6-PSS at 3× noise named zero_offset alone at p = 0.022, 1 of 20 runs).
    for c, (p_c, p_a) in dec.outcome.items():
        if p_c >= dec.level:
            indist.append(effects[c].name)
        elif p_a < dec.level:
            additional.append(effects[c].name)
    # NOTE: the challenge compares the named candidate's *linearised* columns at the base fit with
    # the open terms'. A model whose effects need an effect grid of starting points (the cabin
    # record: a frequency change over a long record) is far from linear there, so its candidates
    # are not contested: their own (nonlinear) fits passed the held-out test.
    if a is None or not discover or not supports_discovery(model, ds.train) or model.effect_grid(effects) is not None:
        return _one_cause(ds, dec, _Naming(a, indist, additional, cands, notes))
    jac_tr, w_tr = np.asarray(ds.fits.jac_tr[ds.b]), np.asarray(ds.fits.w_tr[ds.b])
    # NOTE: terms of a reading are evaluated at the base fit's predicted reading, not the
    # measured one: the difference is the residual itself, which a term would then fit.
    raw_tr0 = np.asarray(_raw_base_residual(model, _fitted(ds, None).base, ds.train))
    order = [a] + sorted((i for i in dec.significant if i != a and cands[i].explains), key=lambda i: -cands[i].score)
    named = None
    for i in order:
        contest = challenge(
            model=model, train=ds.train, reading_tr=np.asarray(model.observed(ds.train)) - raw_tr0,
            white_tr=np.einsum("mij,mj->mi", w_tr, raw_tr0).reshape(-1), w_tr=w_tr,
            jac_base=jac_tr[:, :ds.nb], jac_effect=jac_tr[:, ds.slices[i]], dof0=dec.dof0, known=ds.known,
            alpha=ds.alpha,
        )
        if contest is None:
            named = i
            break
        how, spec = contest
        why = ("explains significantly more on top of it" if how == "adds"
               else "fits better by the information criterion and it adds nothing on top of it")
        notes.append(f"{effects[i].name} passes the held-out test but is not named: an open term, "
                     f"{describe(spec, term_units(model))}, {why}")
        cands = tuple(dataclasses.replace(c, explains=False) if j == i else c for j, c in enumerate(cands))
    if named != a:  # the pair tests were against the contested one
        return _Naming(named, [], [], cands, notes)
    return _one_cause(ds, dec, _Naming(a, indist, additional, cands, notes))


def _one_cause(ds: DataSet, dec: Decision, name: _Naming) -> _Naming:
    """One name only when nothing else explains as well: a name that needs further effects is
    partial (``demoted``); a candidate that reproduces the named one's signature within the noise
    and passes the held-out test joins ``indistinguishable`` (``_equivalence.py``)."""
    a, effects = name.named, ds.effects
    if a is not None and name.additional:
        # NOTE: a name whose fit needs further effects to close the gap is one part of the
        # cause, not the cause: a near-equivalent outside effect fitted by the nearest
        # registered one leaves exactly this (and more noise hides the rest of the gap).
        note = (f"{effects[a].name} passes the held-out test, but {', '.join(name.additional)} explain(s) "
                f"significantly more on top of it: a partial explanation, no single cause is named")
        return name._replace(named=None, indistinguishable=[], notes=[*name.notes, note], demoted=a)
    if a is None:
        return name
    others = [i for i, c in enumerate(name.cands) if i != a and c.identifiable_rank > 0]
    equiv = equivalences(a, others, [e.name for e in effects], np.asarray(ds.fits.jac_tr[ds.b]), ds.nb, ds.slices,
                         np.asarray(ds.fits.z[ds.b]), dec.level, dec.scale2)
    by_name = {c.effect: c for c in name.cands}
    indist = list(name.indistinguishable) + [
        r["effect"] for r in equiv if r["named_outside_reproduced"] and r["effect"] not in name.indistinguishable
        and by_name[r["effect"]].heldout_p >= ds.alpha]
    return name._replace(indistinguishable=indist, equivalences=equiv)


def _noise_floors(ds: DataSet, scale2: float) -> tuple[float, float]:
    """The held-out residuals' noise floor (report units): the noise alone, and the noise plus
    the base fit's prediction error at the held-out rows (``noise_floor_predictive``)."""
    rf = ds.model.report_factor
    w_te = np.asarray(ds.fits.w_te[ds.b])
    raw_te = np.asarray(ds.fits.raw_te[ds.b])
    jac_tr, jac_te = np.asarray(ds.fits.jac_tr[ds.b]), np.asarray(ds.fits.jac_te[ds.b])
    cov = np.einsum("mij,mkj->mik", *(2 * [np.linalg.inv(w_te)]))
    floor = float(np.sqrt(np.mean(np.diagonal(cov, axis1=1, axis2=2))) * rf * math.sqrt(scale2))
    lw = np.linalg.inv(w_te)
    n_te_rows, kk = raw_te.shape[1], raw_te.shape[2]
    pred = prediction_factor(jac_tr[:, :ds.nb], jac_te[:, :ds.nb]).reshape(n_te_rows, kk, -1)
    pred_raw = np.einsum("mij,mjn->min", lw, pred)
    extra = np.sum(pred_raw**2) / (n_te_rows * kk)
    floor_pred = float(np.sqrt(np.mean(np.diagonal(cov, axis1=1, axis2=2)) + extra) * rf * math.sqrt(scale2))
    return floor, floor_pred


class _Discovered(NamedTuple):
    """The open search on one data set: the discovered terms' report rows, and, where they pass
    the held-out test, the augmented fit and its held-out residuals (library units)."""

    discovered: list[dict[str, Any]]
    fitted: FittedModel | None
    residuals_te: np.ndarray | None
    notes: tuple[str, ...] = ()


def _open_search(ds: DataSet, dec: Decision, base_fm: FittedModel) -> _Discovered:
    """The open term search on the base fit's residuals, when no candidate is named."""
    model, b, fits = ds.model, ds.b, ds.fits
    w_tr, w_te, raw_te = np.asarray(fits.w_tr[b]), np.asarray(fits.w_te[b]), np.asarray(fits.raw_te[b])
    raw_tr = np.asarray(_raw_base_residual(model, base_fm.base, ds.train))
    jac_tr = np.asarray(fits.jac_tr[b])
    gap_before = float(np.sqrt(np.mean(raw_te[0] ** 2)) * model.report_factor)
    inp = TermInputs(
        model=model, train=ds.train, test=ds.test,
        reading_tr=np.asarray(model.observed(ds.train)) - raw_tr,
        reading_te=np.asarray(model.observed(ds.test)) - raw_te[0],
        white_tr=np.einsum("mij,mj->mi", w_tr, raw_tr).reshape(-1),
        white_te=np.einsum("mij,mj->mi", w_te, raw_te[0]).reshape(-1),
        raw_te=raw_te[0], w_tr=w_tr, w_te=w_te, jac_tr=jac_tr[:, :ds.nb],
        jac_te=np.asarray(fits.jac_te[b])[:, :ds.nb], dof0=dec.dof0, scale2=dec.scale2, known=ds.known,
        alpha=ds.alpha,
    )
    terms, discovered, term_fit, passed = earn_place(inp, gap_before)
    registered = [(c.effect, jac_tr[:, ds.slices[i]]) for i, c in enumerate(dec.cands) if c.identifiable_rank > 0]
    again = reproduced_by(terms, term_fit, inp, registered)
    if again is not None:
        return _Discovered([], None, None, (
            f"the open search's terms ({'; '.join(d['description'] for d in discovered)}) are {again} again (its "
            "fit reproduces them within the noise), which the candidates' tests above decided: not a discovery",))
    delta, coef = term_fit.delta, term_fit.coef
    if not passed:
        return _Discovered(discovered, None, None)
    fm = FittedModel(model, (terms.effect(model),), base_fm.base + model.base_scale * jnp.asarray(delta),
                     (jnp.asarray(coef),))
    return _Discovered(discovered, fm, np.asarray(model.observed(ds.test) - fm.predict(ds.test)))


def _absorbed_by(ds: DataSet, cands: tuple[Candidate, ...]) -> dict[str, list[str]]:
    """Per candidate the base parameters absorb completely, the parameters that absorb it."""
    jac_tr, names = np.asarray(ds.fits.jac_tr[ds.b]), base_param_names(ds.model)
    return {
        ds.effects[i].name: absorbing_params(jac_tr[:, :ds.nb], jac_tr[:, ds.slices[i]], names)
        for i, c in enumerate(cands)
        if c.identifiable_rank == 0
    }


def _gap_shares(ds: DataSet, dec: Decision, name: _Naming, gap_before: float, floor_pred: float
                ) -> tuple[tuple[Candidate, ...], list[dict[str, Any]]]:
    """The candidates of ``name`` with their share of the gap (``gap_share``: the held-out mean
    square a candidate removes over the gap's excess above the predictive noise floor, 0
    without excess), and the partial explanations of a detected gap that nothing names: the
    significant candidates that do not explain it and a demoted name (with the effects it
    needs), largest share first."""
    a = name.named
    excess = gap_before**2 - floor_pred**2
    cands = tuple(
        dataclasses.replace(c, gap_share=float((gap_before**2 - c.heldout_rms**2) / excess) if excess > 0 else 0.0)
        for c in name.cands
    )
    demoted = None if name.demoted is None else ds.effects[name.demoted].name
    partial = [
        {"effect": c.effect, "gap_share": c.gap_share, "heldout_rms": c.heldout_rms, "heldout_p": c.heldout_p}
        | ({"needs": list(name.additional)} if c.effect == demoted else {})
        for c in sorted(cands, key=lambda c: -c.gap_share)
        if dec.detected and a is None and c.significant and (not c.explains or c.effect == demoted)
    ]
    return cands, partial


def _fit_notes(ds: DataSet, dec: Decision) -> list[str]:
    """The report's notes on the base fit: a Levenberg–Marquardt fit that did not converge, base
    parameter directions the data do not determine."""
    notes = []
    if not bool(ds.fits.base_ok[ds.b]):
        notes.append("the base Levenberg–Marquardt fit did not converge within the step budget")
    if dec.rank_g < ds.nb:
        notes.append(f"the data determine only {dec.rank_g} of the {ds.nb} base parameter directions")
    return notes


def _derived_rms(ds: DataSet, fm: FittedModel, res: np.ndarray) -> dict[str, float]:
    """The RMS of each derived error (6-PSS: pose errors, report units) of the fit ``fm`` at the
    held-out rows of ``ds``, from its held-out residuals ``res`` ``(m_te, k)`` (library units)."""
    d = ds.model.derived_errors(fm.base, ds.test, res)
    return {kname: float(np.sqrt(np.mean(v**2))) for kname, v in d.items()}


def _finish(ds: DataSet, dec: Decision, skipped: list[SkippedEffect], discover: bool) -> DiagnosisReport:
    """Show: the report of one data set — the name that stands, the gap before and after against
    the noise floors, each candidate's share of the gap, the open search where nothing is named,
    the derived errors and the "where" analysis."""
    model, rf, known = ds.model, ds.model.report_factor, ds.known
    name = _settle_name(ds, dec, discover)
    a, notes = name.named, list(name.notes)
    base_fm, aug_fm = _fitted(ds, None), _fitted(ds, a)
    raw_te = np.asarray(ds.fits.raw_te[ds.b])
    before = raw_te[0] * rf
    res_after_lib = raw_te[0 if a is None else a + 1]
    after = res_after_lib * rf
    floor, floor_pred = _noise_floors(ds, dec.scale2)
    gap_before = float(np.sqrt(np.mean(before**2)))
    cands, partial = _gap_shares(ds, dec, name, gap_before, floor_pred)
    found = _Discovered([], None, None)
    if dec.detected and a is None and discover and supports_discovery(model, ds.train):
        found = _open_search(ds, dec, base_fm)
        notes += found.notes
        if found.fitted is not None:
            aug_fm, after = found.fitted, found.residuals_te * rf
            res_after_lib = after / rf
    notes += _fit_notes(ds, dec)
    factors = model.factors(ds.test)
    return DiagnosisReport(
        model=model.name,
        detected=bool(dec.detected),
        detect_statistic=float(dec.t0),
        detect_dof=float(dec.n_te),
        detect_p_value=float(dec.p_detect),
        named_effect=None if a is None else ds.effects[a].name,
        explained=a is not None or found.fitted is not None,
        discovered=found.discovered,
        partial=partial,
        absorbed_by=_absorbed_by(ds, cands),
        indistinguishable_from=name.indistinguishable,
        equivalences=name.equivalences,
        separated_by={n: separated_by(n) for n in ([ds.effects[a].name, *name.indistinguishable]
                                                   if a is not None and name.indistinguishable else [])},
        additional_effects=name.additional,
        ranking=sorted(cands, key=lambda c: (c.identifiable_rank > 0, c.score), reverse=True),
        absorbed=[c.effect for c in cands if c.identifiable_rank == 0],
        skipped=list(skipped),
        gap_before=gap_before,
        gap_after=float(np.sqrt(np.mean(after**2))),
        noise_floor=floor,
        noise_floor_predictive=floor_pred,
        derived_before=_derived_rms(ds, base_fm, raw_te[0]),
        derived_after=_derived_rms(ds, aug_fm, res_after_lib),
        where_before=where_analysis(before, factors, model.output_names, ds.alpha),
        where_after=where_analysis(after, factors, model.output_names, ds.alpha),
        base_chi2=float(dec.chi2[0]),
        base_dof=int(dec.dof0),
        noise_estimated=not known,
        noise_scale=float(math.sqrt(dec.scale2)),
        alpha=ds.alpha,
        n_train=model.n_rows(ds.train),
        n_test=model.n_rows(ds.test),
        fitted=aug_fm,
        base_fitted=base_fm,
        residuals_before=before,
        residuals_after=after,
        test_factors=factors,
        notes=notes,
    )

"""The discrepancy workflow on sessions simulated outside the library (``_numpy_session.py``:
random pose order over two hours, approach directions from the moves, a drifting temperature):
every registered effect is named (or reported absorbed by the geometry), effects the registry
lacks are never named — a cyclic screw error is discovered with its period — and nothing is
found in the null case. Two seeds per case here; the rates over 20 seeds at two noise levels
are in ``benchmarks/discrepancy_session.py``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _numpy_session import REGISTERED, UNREGISTERED, session

import stewart_jax as sj
from stewart_jax import discrepancy as dc
from stewart_jax.calibration import make_calibration_data

# The batched engine of the discrepancy benchmarks (private): many train/held-out pairs in one
# compile; dc.diagnose is the same workflow on one data set.
from stewart_jax.discrepancy._driver import diagnose_many, select_effects, split_rows

# NOTE: skipped until a deadlock is understood. On these 180-pose sessions the batched base fit
# (``fit_candidates`` → ``_base_fits``, the batched LM's refill loop) waits forever inside XLA's CPU
# runtime in some runs: the main thread in ``BlockUntilReady``, every pool thread idle, 0 % CPU;
# with ``--xla_cpu_use_xnnpack=false`` and with ``--xla_cpu_use_thunk_runtime=false`` alike. Measured:
# 3 of 3 runs hung with the machine's load average at 10–13 (other jobs running), 0 of 4 at 3–4
# (default settings, without async CPU dispatch, with EQX_ON_ERROR=nan), so a race, not yet found.
# A test that can hang must not run in CI; the rates are measured by
# ``benchmarks/discrepancy_session.py``, which has not stalled.
pytestmark = pytest.mark.skip(reason="the batched base fit can deadlock in XLA's CPU runtime on these sessions")

SEEDS = (0, 1)
N_POSES = 180


def _setup(family):
    if family == "6-UPS":
        mech = sj.mechanism.preset("rubin_camera")
        geo = dict(base=mech.base, platform=mech.platform, v0=mech.v0, lengths0=mech.lengths0)
        return mech, geo, sj.calibration.reachable_travel(mech)
    a = sj.actual_geometry()
    return sj.nominal_geometry(), dict(upper=a.upper, lower=a.lower, v0=a.v0), np.array([1.0] * 3 + [0.01745] * 3)


@pytest.fixture(scope="module", params=["6-UPS", "6-PSS"])
def runs(request):
    """Per family: ``(model, [(seed, effect, truth, train, test, report), …])``, all diagnosed in
    one batch (one compile)."""
    family = request.param
    mech, geo, half = _setup(family)
    model = dc.model_for(mech)
    cases = [None, *REGISTERED[family], *UNREGISTERED]
    meta, trains, tests = [], [], []
    for s in SEEDS:
        for c, eff in enumerate(cases):
            ses = session(family, geo, eff, np.random.default_rng([s, c, 77]), half=half, n=N_POSES)
            data = make_calibration_data(ses.strokes, ses.poses, ses.directions, ses.temperature, ses.time)
            tr, te = split_rows(N_POSES, 0.3, s)
            trains.append(data.take(tr))
            tests.append(data.take(te))
            meta.append((s, eff, ses.truth))
    effects, _ = select_effects(model, trains[0], len(tr))
    # one batch per seed: the same compiled kernels (batches of 20 data sets stall XLA's CPU runtime here)
    n = len(cases)
    reps = [r for i in range(0, len(trains), n) for r in diagnose_many(model, effects, trains[i:i + n],
                                                                           tests[i:i + n])]
    return family, model, [(*m, tr, te, r) for m, tr, te, r in zip(meta, trains, tests, reps, strict=True)]


def test_no_wrong_name_and_registered_effects_are_named(runs):
    family, _, rows = runs
    wrong = [(eff, r.named_effect) for _, eff, _, _, _, r in rows
             if r.named_effect is not None and eff not in [r.named_effect, *r.indistinguishable_from]]
    assert wrong == []
    named = [r.named_effect == eff or eff in r.indistinguishable_from or (not r.detected and eff in r.absorbed_by)
             for _, eff, _, _, _, r in rows if eff in REGISTERED[family]]
    # 20-seed rates (benchmark): ≥ 90 % per registered effect; two misses of 12–14 allowed here.
    assert sum(named) >= len(named) - 2, named
    for *_, r in rows:
        if r.named_effect is not None:
            c = next(c for c in r.ranking if c.effect == r.named_effect)
            assert c.explains and c.heldout_p >= r.alpha and r.explained


def test_null_case_raises_no_alarm(runs):
    _, _, rows = runs
    alarms = [r.detected for _, eff, _, _, _, r in rows if eff is None]
    assert sum(alarms) <= 1  # α = 0.05 per run


def test_unregistered_effects_are_never_named_and_the_report_says_so(runs):
    _, _, rows = runs
    for _, eff, _, _, _, r in rows:
        if eff not in UNREGISTERED or not r.detected:
            continue
        assert r.named_effect is None
        d = r.to_dict()
        assert d["named_effect"] is None and isinstance(d["explained"], bool)
        assert all(0 <= i < 1e9 for i in [len(d["partial"]), len(d["discovered"])])
        json.dumps(d)
        if not r.explained:
            assert "a discrepancy is present that no candidate explains" in " ".join(r.summary())
        for p in r.partial:  # a partial explanation leaves a gap the held-out test still rejects
            assert p["heldout_p"] < r.alpha


def test_cyclic_screw_error_is_discovered_with_its_period_and_amplitude(runs):
    _, _, rows = runs
    for _, eff, truth, _, _, r in rows:
        if eff != "cyclic_screw":
            continue
        assert r.detected and r.named_effect is None and r.explained
        t = r.discovered[0]
        assert (t["factor"], t["form"], t["leg"]) == ("reading", "periodic", None)
        assert abs(t["period"] / truth["period_mm"] - 1) < 0.05
        # sin(2πq/P + φ) = cos φ · sin(2πq/P) + sin φ · cos(2πq/P): compare with the hidden phases
        c = {(x["leg"], x["basis"]): x for x in t["coefficients"]}
        amp_um = truth["amp"] * 1e3
        for leg in range(1, 7):
            for basis, want in (("sin", np.cos(truth["phase"][leg - 1])), ("cos", np.sin(truth["phase"][leg - 1]))):
                x = c[(leg, basis)]
                assert x["unit"] == "µm"
                assert abs(x["value"] - amp_um * want) < 5 * x["std"] + 0.05 * amp_um
        # closed to the noise by the held-out test; the RMS itself within its sampling spread
        assert t["heldout_p"] >= r.alpha
        assert r.gap_after < 1.25 * r.noise_floor_predictive < r.gap_before


def test_discovered_model_predicts_as_the_search_did_and_round_trips(runs, tmp_path):
    _, model, rows = runs
    _, _, _, _, test, r = next(x for x in rows if x[1] == "cyclic_screw")
    # the augmented model (nonlinear prediction) reproduces the linearised search's held-out gap
    assert r.gap_after == pytest.approx(r.discovered[-1]["gap_after"], rel=2e-3)
    path = tmp_path / "aug.json"
    dc.save_fitted_model(r.fitted, path)
    back = dc.load_fitted_model(path)
    np.testing.assert_allclose(np.asarray(back.commanded(test)), np.asarray(r.fitted.commanded(test)), atol=1e-12)
    # the commanded readings move by the discovered cyclic error (a reading error: command it)
    base_cmd = np.asarray(r.base_fitted.commanded(test))
    delta_um = (np.asarray(r.fitted.commanded(test)) - base_cmd) * 1e3
    assert 0.5 < np.sqrt(np.mean(delta_um**2)) < 1.2


def test_strut_hexapod_absorbed_effect_names_the_absorbing_parameters(runs):
    family, _, rows = runs
    if family != "6-UPS":
        pytest.skip("the 6-UPS base joints absorb a misaligned instrument frame")
    r = next(x[-1] for x in rows if x[1] == "tracker_misalignment")
    params = r.absorbed_by["tracker_misalignment"]
    assert params and all(p.startswith(("base", "platform", "lengths0")) for p in params)
    assert any("absorbed by the geometry (indistinguishable from a change of parameters" in s for s in r.summary())

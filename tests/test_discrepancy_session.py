"""The discrepancy workflow on sessions simulated outside the library (``_numpy_session.py``:
random pose order over two hours, approach directions from the moves, a drifting temperature):
registered effects are named (or reported absorbed by the geometry), effects the registry lacks
are never named — a cyclic screw error (a cyclic crank error on the rotary hexapod) is
discovered with its period and amplitude — and nothing is found in the null case. One seed per
case and family here, all cases of a family in one batch; the rates over 20 seeds at two noise
levels are in ``benchmarks/discrepancy_session.py``.

These 180-pose batches are also where jaxlib 0.10's batched LAPACK kernels deadlocked XLA's CPU
thread pool (see ``stewart_jax/_linalg.py``): the last test checks that the workflow's compiled
kernels hold no batched LAPACK call."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _numpy_session import NEAR_EQUIVALENT, REGISTERED, crank_angles, rotation, session, unregistered
from test_linalg import batched_lapack_calls

import stewart_jax as sj
from stewart_jax import discrepancy as dc
from stewart_jax.calibration import make_calibration_data

# The batched engine of the discrepancy benchmarks (private): many train/held-out pairs in one
# compile; dc.diagnose is the same workflow on one data set.
from stewart_jax.discrepancy._driver import _stack, diagnose_many, select_effects, split_rows
from stewart_jax.discrepancy._fits import _base_fits, _prepare_many, fit_candidates, fit_masks_many

# The slow tier (make test-all runs it, make test does not): the naming rule's rates over seeds for every family
# (8 min on 2 cores).
pytestmark = pytest.mark.slow

SEED = 0
N_POSES = 180
ABSORBED = {"6-UPS": ("tracker_misalignment", ("base", "platform", "lengths0")),
            "6-RUS": ("crank_offset", ("crank_zero",))}
"""Per family, an effect its base parameters absorb completely, and the parameters that do: the
6-UPS base and platform joints absorb a misaligned instrument frame, the 6-RUS crank zeros an
encoder offset."""


def _setup(family):
    if family == "6-UPS":
        mech = sj.mechanism.preset("rubin_camera")
        geo = dict(base=mech.base, platform=mech.platform, v0=mech.v0, lengths0=mech.lengths0)
        return mech, geo, sj.calibration.reachable_travel(mech)
    if family == "6-RUS":
        mech = sj.mechanism.preset("rotary_stewart")
        geo = dict(base=mech.base, platform=mech.platform, v0=mech.v0, crank_lengths=mech.crank_lengths,
                   rod_lengths=mech.rod_lengths, azimuth=mech.azimuth, crank_zero=mech.crank_zero)
        return mech, geo, sj.calibration.reachable_travel(mech)
    a = sj.actual_geometry()
    return sj.nominal_geometry(), dict(upper=a.upper, lower=a.lower, v0=a.v0), np.array([1.0] * 3 + [0.01745] * 3)


@pytest.fixture(scope="module", params=["6-UPS", "6-PSS", "6-RUS"])
def runs(request):
    """Per family: ``(family, model, effects, trains, tests, [(effect, truth, test, report), …])``,
    every case diagnosed in one batch (one compilation per family)."""
    family = request.param
    mech, geo, half = _setup(family)
    model = dc.model_for(mech)
    meta, trains, tests = [], [], []
    cases = (None, *REGISTERED[family], *unregistered(family), *(NEAR_EQUIVALENT if family == "6-UPS" else ()))
    for c, eff in enumerate(cases):
        ses = session(family, geo, eff, np.random.default_rng([SEED, c, 77]), half=half, n=N_POSES)
        data = make_calibration_data(ses.readings, ses.poses, ses.directions, ses.temperature, ses.time)
        tr, te = split_rows(N_POSES, 0.3, SEED)
        trains.append(data.take(tr))
        tests.append(data.take(te))
        meta.append((eff, ses.truth))
    effects, _ = select_effects(model, trains[0], len(tr))
    reps = diagnose_many(model, effects, trains, tests)
    rows = [(eff, truth, te, r) for (eff, truth), te, r in zip(meta, tests, reps, strict=True)]
    return family, model, effects, trains, tests, rows


def test_the_simulators_crank_angles_are_the_mechanisms():
    """The simulator's closed-form crank angle (its own derivation) against the library's 6-RUS
    inverse kinematics, over the travel box the sessions use."""
    mech = sj.mechanism.preset("rotary_stewart")
    half = sj.calibration.reachable_travel(mech)
    poses = np.random.default_rng(5).uniform(-half, half, (400, 6))
    joints = (np.einsum("mjk,ik->mij", rotation(poses[:, 3:]), np.asarray(mech.platform)) + poses[:, None, :3]
              + np.asarray(mech.v0))
    alpha = crank_angles(joints - np.asarray(mech.base), np.asarray(mech.azimuth), np.asarray(mech.crank_lengths),
                         np.asarray(mech.rod_lengths))
    q = np.asarray(mech.solve_inverse_kinematics(poses).readings)
    assert np.ptp(q) > 0.5  # the cranks sweep ~30° of the box, so the branch is tested away from zero
    np.testing.assert_allclose(alpha - np.asarray(mech.crank_zero), q, rtol=0, atol=1e-12)


PHYSICS = {"load_compliance": "gravity_sag"}
"""The simulator's effects that a registered effect's physics includes: a payload's load off A's
origin at an elevation is the generalised ``gravity_sag``."""


def test_no_wrong_name_and_registered_effects_are_named(runs):
    family, *_, rows = runs
    wrong = [(eff, r.named_effect) for eff, _, _, r in rows
             if r.named_effect is not None and PHYSICS.get(eff, eff) not in [r.named_effect, *r.indistinguishable_from]]
    assert wrong == []
    named = [r.named_effect == eff or eff in r.indistinguishable_from or (not r.detected and eff in r.absorbed_by)
             for eff, _, _, r in rows if eff in REGISTERED[family]]
    # Measured over 20 seeds at this noise (benchmark): each registered effect named (or absorbed)
    # in 85–100 % of the runs (the true effect's augmented model fails the held-out test in a
    # fraction α of runs: 33 of 640 detected runs, 5.2 %, at α = 5 %); per seed and family, at
    # most 2 misses of 6–7 in 39 of 40 (one 6-PSS seed had 3; at 5 % per run, 3 or more of 7
    # happens in 0.4 % of seeds).
    assert sum(named) >= len(named) - 2, named
    for *_, r in rows:
        if r.named_effect is not None:
            c = next(c for c in r.ranking if c.effect == r.named_effect)
            assert c.explains and c.heldout_p >= r.alpha and r.explained


def test_null_case_raises_no_alarm(runs):
    *_, rows = runs
    r = next(r for eff, _, _, r in rows if eff is None)
    # the held-out test fires in 5 % of null runs (α); even then nothing may be named or found
    assert r.named_effect is None and not r.discovered and not r.partial


def test_unregistered_effects_are_never_named_and_the_report_says_so(runs):
    family, *_, rows = runs
    for eff, _, _, r in rows:
        if eff not in unregistered(family) or not r.detected:
            continue
        assert r.named_effect is None
        d = json.loads(json.dumps(r.to_dict()))
        assert d["named_effect"] is None and d["explained"] is r.explained
        if not r.explained:
            assert "a discrepancy is present that no candidate explains" in " ".join(r.summary())
        for p in r.partial:  # a partial explanation leaves a gap the held-out test still rejects
            assert p["heldout_p"] < r.alpha


def _cyclic(family):
    """The cyclic error's name, its period's key in the truth and unit in the report, and the
    report unit (µm per mm of a screw, µrad per rad of a crank)."""
    if family == "6-RUS":
        return "cyclic_crank", "period_deg", "deg", "µrad", 1e6
    return "cyclic_screw", "period_mm", "mm", "µm", 1e3


def test_cyclic_screw_error_is_discovered_with_its_period_and_amplitude(runs):
    family, *_, rows = runs
    name, period_key, period_unit, unit, per_library_unit = _cyclic(family)
    _, truth, _, r = next(x for x in rows if x[0] == name)
    assert r.detected and r.named_effect is None and r.discovered
    t = r.discovered[0]
    assert (t["factor"], t["form"], t["leg"], t["period_unit"]) == ("reading", "periodic", None, period_unit)
    assert abs(t["period"] / truth[period_key] - 1) < 0.05
    # sin(2πq/P + φ) = cos φ · sin(2πq/P) + sin φ · cos(2πq/P): compare with the hidden phases
    # (for a crank the simulator's q counts from the true zero, the library's from its fitted
    # one: they differ by ~1 µrad, a phase shift of ~1e-4 rad)
    c = {(x["leg"], x["basis"]): x for x in t["coefficients"]}
    amp = truth["amp"] * per_library_unit
    for leg in range(1, 7):
        for basis, want in (("sin", np.cos(truth["phase"][leg - 1])), ("cos", np.sin(truth["phase"][leg - 1]))):
            x = c[(leg, basis)]
            assert x["unit"] == unit
            assert abs(x["value"] - amp * want) < 5 * x["std"] + 0.05 * amp
    # the gap closes towards the noise floor (the term passes the held-out test in 39 of the
    # benchmark's 40 runs at this noise; the RMS itself is compared with its sampling spread)
    assert r.gap_after < 1.25 * r.noise_floor_predictive < r.gap_before


def test_discovered_model_predicts_as_the_search_did_and_round_trips(runs, tmp_path):
    family, *_, rows = runs
    name, *_, per_library_unit = _cyclic(family)
    _, truth, test, r = next(x for x in rows if x[0] == name)
    if not r.explained:
        pytest.skip("this seed's discovered term did not pass the held-out test (1 of the benchmark's 40 runs)")
    # the augmented model (nonlinear prediction) reproduces the linearised search's held-out gap
    assert r.gap_after == pytest.approx(r.discovered[-1]["gap_after"], rel=2e-3)
    path = tmp_path / "aug.json"
    dc.save_fitted_model(r.fitted, path)
    back = dc.load_fitted_model(path)
    np.testing.assert_allclose(np.asarray(back.commanded(test)), np.asarray(r.fitted.commanded(test)), atol=1e-12)
    # the commanded readings move by the discovered cyclic error (a reading error: command it):
    # RMS amplitude/√2 = 0.71 of the amplitude
    base_cmd = np.asarray(r.base_fitted.commanded(test))
    delta = (np.asarray(r.fitted.commanded(test)) - base_cmd) / truth["amp"]
    assert 0.5 < np.sqrt(np.mean(delta**2)) < 1.2


def test_an_absorbed_effect_names_the_absorbing_parameters(runs):
    family, *_, rows = runs
    if family not in ABSORBED:
        pytest.skip("no registered 6-PSS effect is absorbed completely by its 36 parameters")
    effect, prefixes = ABSORBED[family]
    r = next(x[-1] for x in rows if x[0] == effect)
    params = r.absorbed_by[effect]
    assert params and all(p.startswith(prefixes) for p in params), params
    assert any("absorbed by the geometry (indistinguishable from a change of parameters" in s for s in r.summary())


def test_the_batched_fits_hold_no_batched_lapack_call(runs):
    """jaxlib 0.10 splits a batched LAPACK call over XLA's thread pool and blocks a pool thread
    on it; two at once deadlocked these very fits (see ``stewart_jax/_linalg.py``)."""
    _, model, effects, trains, tests, _ = runs
    tr, te = _stack(trains), _stack(tests)
    fits = fit_candidates(model, effects, tr, te)
    k = len(effects)
    masks = np.zeros((len(trains), k + 1, k))
    for lowered in (_base_fits.lower(model, effects, tr),
                    _prepare_many.lower(model, effects, tr, te, fits.z[:, 0]),
                    fit_masks_many.lower(model, effects, masks, tr, fits.w_tr, te, fits.z[:, 0], fits.jac_tr)):
        assert batched_lapack_calls(lowered.as_text()) == []


def test_a_tracker_scale_is_a_common_strut_scale_of_a_scaled_geometry():
    """The exact equivalence the docs state, three ways: the NumPy simulator's readings of a
    hexapod measured by a tracker whose distances are 270 ppm long, the library's
    ``tracker_scale`` on the true geometry, and the library's ``strut_scale`` (equal on every
    strut) on the geometry whose joints and zero-reading lengths are scaled by 1 + s."""
    mech, geo, half = _setup("6-UPS")
    ses = session("6-UPS", geo, "tracker_scale", np.random.default_rng(3), half=half, n=12, perturb_um=0.0,
                  sigma_um=0.0, sigma_arcsec=0.0)
    data = make_calibration_data(ses.readings, ses.poses, ses.directions, ses.temperature, ses.time)
    s = ses.truth["s"]
    model = dc.model_for(mech)
    by_tracker = model.predict(model.base_initial, (dc.get_effect("6-ups", "tracker_scale"),),
                               (np.array([s]),), data)
    scaled = sj.mechanism.UPSMechanism(mech.base * (1 + s), mech.platform * (1 + s), mech.v0, mech.lengths0 * (1 + s))
    m2 = dc.model_for(scaled)
    by_struts = m2.predict(m2.base_initial, (dc.get_effect("6-ups", "strut_scale"),), (np.full(6, s),), data)
    np.testing.assert_allclose(np.asarray(by_tracker), ses.readings, rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.asarray(by_struts), ses.readings, rtol=0, atol=1e-10)
    assert np.max(np.abs(ses.readings - np.asarray(sj.inverse_kinematics(mech, ses.poses)))) > 0.05  # ≥ 50 µm


def test_near_equivalent_and_instrument_effects_get_no_confident_wrong_name(runs):
    """A 270 ppm tracker scale is exactly a common strut scale + geometry: when named, both are in
    the set, the summary names no single cause and says what separates them. A payload's load
    off A's origin at an elevation (near ``gravity_sag``, not it) gets no name without it."""
    family, *_, rows = runs
    if family != "6-UPS":
        pytest.skip("the near-equivalent effects are simulated for the strut hexapod")
    r = next(x[-1] for x in rows if x[0] == "tracker_scale")
    assert r.detected
    if r.named_effect is not None:
        assert {"tracker_scale", "strut_scale"} <= {r.named_effect, *r.indistinguishable_from}
        text = " ".join(r.summary())
        assert "no single cause" in text and "reference length measured by the instrument" in text
        eq = next(e for e in r.equivalences if {e["effect"], e["with"]} == {"tracker_scale", "strut_scale"})
        assert eq["named_outside_share"] < 1e-3 or eq["outside_named_share"] < 1e-3
    r = next(x[-1] for x in rows if x[0] == "load_compliance")
    assert r.named_effect is None or "gravity_sag" in [r.named_effect, *r.indistinguishable_from]


def test_listed_discovered_terms_shrink_the_gap_and_recur(runs):
    *_, rows = runs
    for *_, r in rows:
        for t in r.discovered:
            assert t["gap_after"] < t["gap_before"] and t["inclusion_frequency"] >= 0.6, t
        if r.discovered:
            assert r.discovered[0]["gap_before"] == pytest.approx(r.gap_before, rel=1e-6)

"""The discrepancy workflow on a record of the FAST cabin's free vibration: the modal model
against the time integrators it replaces (quasi-static catenaries, lumped-mass cables), the
record file and its bad inputs, and the workflow on records with each effect hidden.

Every record is simulated ONCE per module by a time integrator (never by the modal
superposition the workflow fits) at the centre, N = 3 segments per cable, 20 s sampled at
5 Hz; the tracker noise is drawn per seed. All ``diagnose`` calls share one compiled kernel
(same record length, one modal model) and run once per module (the ``runs`` fixture).
"""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax  # noqa: F401
from stewart_jax._cli import main
from stewart_jax.cable_robot import (
    CabinVariation,
    cabin_modal_model,
    cabin_modes,
    lumped_free_decay,
    lumped_modes,
    paper_fast_params,
    quasi_static_free_decay,
)

# private building blocks tested on their own: the modal sum the workflow fits, the EA and mass
# scaling behind its stiffness tables, the damping groups, the record writer and the modes the
# CLI reports
from stewart_jax.cable_robot._cabin_modal import DAMPING_GROUPS, free_response, scaled_params
from stewart_jax.cable_robot._free_decay import write_record
from stewart_jax.discrepancy import cabin_record_model, diagnose, effect_names, read_cabin_record
from stewart_jax.discrepancy._cabin_record import fitted_modes

# The slow tier (make test-all runs it, make test does not): the cabin-record diagnosis's rates over seeds, each
# a diagnosis of 20 s records (12 min on 2 cores).
pytestmark = pytest.mark.slow

cabin_modes_jit = jax.jit(cabin_modes)

PARAMS = paper_fast_params()
POS = (0.0, 0.0, 140.0)
N = 3
T_S, RATE_HZ, DT_S = 20.0, 5.0, 5e-3  # 5 Hz: above twice the highest cabin mode (1.3 Hz)
# 20 mm of swing: the pendulum's second-order rise (z ≈ x²/2L, ~0.06 mm here) stays far below
# the noise; the modal model is linear.
Q0 = np.array([0.02, 0.01, 0.005, *np.deg2rad([0.01, 0.01, 0.02])])
SIGMA_MM, SIGMA_DEG = 1.0, 0.01
ZETA = 0.005
HIDDEN = {  # the effect and how the record hides it
    "cable_inertia": dict(cables="lumped"),
    "cable_stiffness": dict(params=scaled_params(PARAMS, 0.85, 1.0)),
    "cabin_mass": dict(params=scaled_params(PARAMS, 1.0, 1.1)),
    # heave damped at 0.035, the rotations at 0.015, the swing at 0.005; released with 20 mm of
    # heave, so that the held-out test sees the contrast on a 20 s record (with 5 mm of heave the
    # candidate is significant on the training rows but the base model passes the held-out test)
    "damping": dict(damping_change=(0.0, 0.03, 0.01), q0=Q0 * np.array([1.0, 1.0, 4.0, 1.0, 1.0, 1.0])),
}


@pytest.fixture(scope="module")
def modal():
    return cabin_modal_model(PARAMS, POS, N)


@pytest.fixture(scope="module")
def decays():
    out = {"none": quasi_static_free_decay(PARAMS, POS, T_S, DT_S, displacement=Q0, damping_ratio=ZETA)}
    for name, how in HIDDEN.items():
        if how.get("cables") == "lumped":
            out[name] = lumped_free_decay(PARAMS, POS, N, T_S, DT_S, displacement=Q0, damping_ratio=ZETA)
        else:
            out[name] = quasi_static_free_decay(how.get("params", PARAMS), POS, T_S, DT_S,
                                                displacement=how.get("q0", Q0), damping_ratio=ZETA,
                                                damping_change=how.get("damping_change", (0.0, 0.0, 0.0)))
    return out


def _data(decay, seed):
    r = decay.sample(RATE_HZ, sigma_mm=SIGMA_MM, sigma_deg=SIGMA_DEG, seed=seed)
    return read_cabin_record(r)


# ------------------------------------------------------------------------ the modal model


def test_the_modal_model_is_the_quasi_static_model_at_zero_and_the_lumped_model_at_one(modal):
    cm = cabin_modes_jit(PARAMS, jnp.asarray(POS))
    qs = np.asarray(cm.frequencies_hz)
    f0 = np.asarray(modal.modes().frequencies_hz)
    # (the string modes' coupling, evaluated at a mass share of 1e-4 near 0, moves them by ~1e-6)
    np.testing.assert_allclose(f0[:6], qs, rtol=5e-6)
    # the string modes leave for ≥ 100 × their frequency; the response is the six quasi-static
    # modes' damped oscillations (their closed form, undamped here)
    assert f0[6] > 10.0
    t = np.linspace(0.0, 20.0, 81)
    phi, M = np.asarray(cm.shapes), np.asarray(cm.mass)
    w = 2 * np.pi * qs
    exact = (np.cos(np.outer(t, w)) * (phi.T @ M @ Q0)) @ phi.T
    got = np.asarray(free_response(modal, CabinVariation(), 0.0, Q0, np.zeros(6), t))
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-4 * np.max(np.abs(exact)))
    lm = np.asarray(lumped_modes(PARAMS, POS, N).frequencies_hz)
    np.testing.assert_allclose(np.asarray(modal.modes(CabinVariation(1.0)).frequencies_hz), lm,
                               rtol=1e-6)


@pytest.mark.parametrize("ea, mass", [(1.23, 1.0), (0.62, 1.0), (1.0, 1.17), (1.0, 0.81)])
def test_the_stiffness_tables_match_the_statics_solved_again(modal, ea, mass):
    # between the Chebyshev points: the quasi-static modes of the changed machine, solved anew
    # (the tables hold K to 1e-6; the string modes' coupling near μ = 0 adds ~1e-6)
    direct = np.asarray(cabin_modes_jit(scaled_params(PARAMS, ea, mass), jnp.asarray(POS)).frequencies_hz)
    var = CabinVariation(ea_change=ea - 1.0, mass_change=mass - 1.0)
    np.testing.assert_allclose(np.asarray(modal.modes(var).frequencies_hz)[:6], direct, rtol=5e-6)


def test_the_mass_share_derivative_at_zero_is_the_cables_added_mass(modal):
    t = np.linspace(0.0, 20.0, 41)

    def f(mu):
        return free_response(modal, CabinVariation(mu), ZETA, Q0, np.zeros(6), t)

    g = jax.jacfwd(f)(0.0)
    h = 1e-6
    np.testing.assert_allclose(g, (f(h) - f(0.0)) / h, rtol=0, atol=2e-4 * float(jnp.max(jnp.abs(g))))


def test_damping_group_shares_partition_each_cabin_mode(modal):
    s = np.asarray(modal.modes().group_share)[:6]
    np.testing.assert_allclose(s.sum(axis=1), 1.0, rtol=1e-12)
    assert len(DAMPING_GROUPS) == 3


@pytest.mark.parametrize("case", ["none", "cable_inertia", "cable_stiffness", "cabin_mass", "damping"])
def test_the_modal_superposition_reproduces_the_time_integrators(modal, decays, case):
    how = HIDDEN.get(case, {})
    var = CabinVariation(
        cable_mass_share=1.0 if case == "cable_inertia" else 0.0,
        ea_change=-0.15 if case == "cable_stiffness" else 0.0,
        mass_change=0.1 if case == "cabin_mass" else 0.0,
        damping_change=jnp.asarray(how.get("damping_change", (0.0, 0.0, 0.0))),
    )
    d = decays[case]
    assert d.failed_solves == 0
    pred = np.asarray(free_response(modal, var, ZETA, how.get("q0", Q0), np.zeros(6), d.time))
    err = np.sqrt(np.mean((d.cabin - pred) ** 2, axis=0))
    size = np.sqrt(np.mean(d.cabin**2, axis=0))
    # The swing to 2 % (measured ≤ 1.1 %). What the linear model leaves is the integrators'
    # nonlinear forces: above all the pendulum's second-order rise in z, 0.1-0.2 mm RMS at 20 mm of
    # swing (it grows as the swing squared) — a quarter of the tracker's σ at most.
    assert np.all(err[:2] < 0.02 * size[:2]), err / size
    noise = np.r_[[SIGMA_MM * 1e-3] * 3, [np.deg2rad(SIGMA_DEG)] * 3]
    assert np.all(err < 0.25 * noise), err / noise


# ------------------------------------------------------------------------ the record and bad input


def test_a_record_file_round_trips(tmp_path, decays):
    r = decays["none"].sample(RATE_HZ, sigma_mm=SIGMA_MM, sigma_deg=SIGMA_DEG, seed=3)
    path = tmp_path / "record.csv"
    write_record(path, r)
    d = read_cabin_record(path)
    np.testing.assert_array_equal(np.asarray(d.time), r.time - r.time[0])
    np.testing.assert_array_equal(np.asarray(d.pose[:, :3]), r.position_mm)
    np.testing.assert_allclose(np.asarray(d.pose[:, 3:]), np.deg2rad(r.rotation_deg) * 1e3, rtol=1e-15)


def _write(path, rows, header="time,x,y,z,rx,ry,rz"):
    path.write_text(header + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in rows) + "\n")
    return path


def _swinging(t):
    """``(len(t), 6)``: a cabin swinging 10 mm and 0.05° at 0.2 Hz (mm, degrees), a size the record's
    checks accept, so that each bad record below is refused for its own fault."""
    s = np.sin(2 * np.pi * 0.2 * np.asarray(t))[:, None]
    return s * np.array([10.0, 10.0, 5.0, 0.05, 0.05, 0.05])


def test_bad_records_are_refused_by_name(tmp_path, modal):
    t = np.arange(0.0, 20.0, 0.1)
    rows = np.column_stack([t, _swinging(t)])
    with pytest.raises(ValueError, match=r"missing \['rz'\]"):
        read_cabin_record(_write(tmp_path / "a.csv", rows[:, :6], "time,x,y,z,rx,ry"))
    back = rows.copy()
    back[50, 0] = back[49, 0]
    with pytest.raises(ValueError, match="time does not increase at data row 51"):
        read_cabin_record(_write(tmp_path / "b.csv", back))
    gap = rows[np.r_[0:100, 110:200]]
    with pytest.raises(ValueError, match="uneven sampling"):
        cabin_record_model(read_cabin_record(_write(tmp_path / "c.csv", gap)), POS, modal=modal)
    with pytest.raises(ValueError, match="too short to resolve the lowest mode"):
        cabin_record_model(read_cabin_record(_write(tmp_path / "d.csv", rows[:50])), POS, modal=modal)
    slow = np.column_stack([np.arange(0.0, 20.0, 0.5), _swinging(np.arange(0.0, 20.0, 0.5))])
    with pytest.raises(ValueError, match="Nyquist"):
        cabin_record_model(read_cabin_record(_write(tmp_path / "e.csv", slow)), POS, modal=modal)
    nan = rows.copy()
    nan[7, 3] = np.nan
    with pytest.raises(ValueError, match="data row 8"):
        read_cabin_record(_write(tmp_path / "f.csv", nan))
    # small jitter is accepted, and said
    jit = rows.copy()
    jit[1:-1, 0] += np.random.default_rng(0).uniform(-0.002, 0.002, t.size - 2)
    model = cabin_record_model(read_cabin_record(_write(tmp_path / "g.csv", jit)), POS, modal=modal)
    assert any("nothing resampled" in n for n in model.notes)


# ------------------------------------------------------------------------ the workflow

# Rates over the tracker noise's seeds (each simulation is deterministic): SEEDS runs per hidden
# effect, NULL_SEEDS on the paper's own model. Every run is one `diagnose` (one compiled kernel
# for all, the command line's included: the same record length and rate, one modal model).
SEEDS, NULL_SEEDS = 3, 4


@pytest.fixture(scope="module")
def runs(modal, decays):
    """``{case: [(report, model), ...]}`` for every hidden effect and the paper's model."""
    out = {}
    for case in (*HIDDEN, "none"):
        out[case] = []
        for s in range(NULL_SEEDS if case == "none" else SEEDS):
            data = _data(decays[case], s)
            model = cabin_record_model(data, POS, modal=modal)
            out[case].append((diagnose(data, model, seed=s), model))
    return out


@pytest.mark.parametrize("case", list(HIDDEN))
def test_each_hidden_effect_is_named(runs, case):
    # Measured: 3 of 3 named for each effect; 2 of 3 allows one miss (the held-out test rejects a
    # right model at α = 5 % per run), never a wrong name. On 12 s records cable_stiffness was once
    # named cabin_mass and damping once missed: 20 s it is. The rates of cable_inertia over record
    # length and noise are benchmarks/fast_cabin_record.py's.
    reps = [r for r, _ in runs[case]]
    named = [r.named_effect for r in reps]
    assert all(r.detected for r in reps)
    assert named.count(case) >= SEEDS - 1, named
    assert all(n in (case, None) for n in named), named  # never a wrong name
    g = np.array([(r.gap_before, r.gap_after, r.noise_floor) for r in reps])
    assert np.all(g[:, 0] > 1.1 * g[:, 2]) and np.median(g[:, 1] / g[:, 2]) < 1.1


def test_no_false_alarm_on_a_quasi_static_record(runs):
    # The paper's own model made the record: nothing may be named. The held-out test fires at
    # α = 5 % by construction (measured: 0 of 4 here, 0 of 36 in the benchmark); 1 of 4 allowed.
    reps = [r for r, _ in runs["none"]]
    assert sum(r.detected for r in reps) <= 1
    assert all(r.named_effect is None for r in reps)


def test_the_fitted_mass_share_is_the_lumped_models(runs):
    lm = np.asarray(lumped_modes(PARAMS, POS, N).frequencies_hz)
    for rep, _ in runs["cable_inertia"]:
        mu = next(c for c in rep.ranking if c.effect == "cable_inertia").params[0]
        assert abs(mu - 1.0) < 0.02
    rep, model = runs["cable_inertia"][0]
    modes = fitted_modes(model, rep.fitted.effects, rep.fitted.thetas)
    # the augmented model's lowest cabin mode is the lumped model's (to the fitted μ), the
    # quasi-static model's far above it
    assert abs(modes["frequencies_hz"][0] - lm[0]) < 0.01 * lm[0]
    assert fitted_modes(model)["frequencies_hz"][0] > 1.5 * lm[0]


# ------------------------------------------------- effects the registry lacks: the open search

# Added to the quasi-static record here, in NumPy (the workflow's candidates cannot express
# either): a vibration the model has no mode for (3 mm on x at a period of 2.5–6 s) and a
# tracker drifting on one position coordinate (0.3–0.6 mm/s). UNREG_SEEDS runs each; the rates
# over 20 seeds are benchmarks/fast_cabin_discovery.py's.
UNREG_SEEDS = 2


def _unregistered(case, t, pos, rng):
    pos = pos.copy()
    if case == "missing_vibration":
        period = rng.uniform(2.5, 6.0)
        pos[:, 0] += 3.0 * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
        return pos, {"output": "x", "period_s": period}
    j = int(rng.integers(3))
    pos[:, j] += rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.6) * t
    return pos, {"output": "xyz"[j]}




@pytest.fixture(scope="module")
def unregistered_runs(modal, decays):
    out = {}
    for case in ("missing_vibration", "tracker_drift"):
        out[case] = []
        for s in range(UNREG_SEEDS):
            r = decays["none"].sample(RATE_HZ, sigma_mm=SIGMA_MM, sigma_deg=SIGMA_DEG, seed=s)
            pos, truth = _unregistered(case, r.time, r.position_mm, np.random.default_rng([s, 28]))
            data = read_cabin_record(r._replace(position_mm=pos))
            out[case].append((diagnose(data, cabin_record_model(data, POS, modal=modal), seed=s), truth, data))
    return out


def test_a_missing_vibration_is_found_in_time_not_named(unregistered_runs):
    # Measured (benchmark, 20 seeds at this noise): found 20 of 20, on x, the period within 2.2 %
    # (the criterion, 5 %, is asserted); never a registered name (a vibration the model
    # has no mode for is not a change of its modes' frequencies). One run of UNREG_SEEDS may
    # miss: the augmented model fails the held-out test at α = 5 % by construction.
    found = 0
    for rep, truth, _ in unregistered_runs["missing_vibration"]:
        d = rep.to_dict()
        assert d["detected"] and d["named_effect"] is None, d["summary"]
        if not d["explained"]:
            continue
        term = d["discovered"][0]
        assert (term["factor"], term["form"], term["period_unit"]) == ("time", "periodic", "s")
        assert term["output"] in ("x", None) and abs(term["period"] / truth["period_s"] - 1) < 0.05
        # its amplitude on x is the 3 mm added (µm): σ = 1 mm over 70 training samples leaves
        # ~0.17 mm of standard error per coefficient; 0.6 mm is 3.5 of them
        amp = term["amplitude"][0]  # x: the term on x alone, or the first of every coordinate's
        assert term["amplitude_unit"] in ("µm", "µm, µrad") and abs(amp - 3000.0) < 600.0
        assert d["gap_after"] < 1.1 * d["noise_floor"] < d["gap_before"]
        found += 1
    assert found >= UNREG_SEEDS - 1


def test_a_drifting_tracker_is_found_in_time_not_named(unregistered_runs):
    # A drift of 6–12 mm over 20 s on one coordinate, against 1 mm of noise. Measured (benchmark,
    # 20 seeds at this noise): found 20 of 20 as a polynomial in time on the drifting coordinate
    # (degree 1 in 19); never a registered name. One miss allowed, as above.
    found = 0
    for rep, truth, _ in unregistered_runs["tracker_drift"]:
        assert rep.named_effect is None
        if rep.explained:
            t = rep.discovered[0]
            assert t["factor"] == "time" and t["form"] == "polynomial" and t["output"] in (truth["output"], None)
            found += 1
    assert found >= UNREG_SEEDS - 1


# ------------------------------------------------------------------------ the command line


def test_the_command_line_writes_and_diagnoses_a_record(tmp_path, capsys):
    rec, js, out = tmp_path / "r.csv", tmp_path / "fd.json", tmp_path / "report.json"
    # One run of the plumbing (the rates are tested above): the settings of the `runs` fixture's
    # first cable_inertia record (noise seed 0, split seed 0), which is named there.
    assert main(["fast", "--free-decay", "--cables", "lumped", "--segments", str(N), "--duration", str(T_S),
                 "--dt", str(DT_S), "--rate-hz", str(RATE_HZ), "--out", str(rec), "--json", str(js),
                 "--seed", "0"]) == 0
    fd = json.loads(js.read_text())
    assert fd["status"] == "ok" and fd["rows"] == int(T_S * RATE_HZ) + 1 and fd["cables"]["segments"] == N
    plots, model = tmp_path / "plots", tmp_path / "model.json"
    assert main(["diagnose", str(rec), "--geometry", "fast", "--segments", str(N), "--json", str(out),
                 "--plot", str(plots), "--out-model", str(model)]) == 0
    d = json.loads(out.read_text())
    assert {p.name for p in plots.iterdir()} == {"residuals_time_s.png", "record_fit.png"}
    m = json.loads(model.read_text())
    assert m["effects"][0]["effect"] == "cable_inertia" and abs(m["effects"][0]["params"][0] - 1.0) < 0.02
    assert d["model"] == "fast-cabin" and d["named_effect"] == "cable_inertia" and d["explained"]
    assert d["gap_after"] < 1.2 * d["noise_floor"] < d["gap_before"]
    assert d["modes"]["after"]["frequencies_hz"][0] < d["modes"]["before"]["frequencies_hz"][0]
    assert set(effect_names("fast-cabin")) == {"cable_inertia", "cable_stiffness", "cabin_mass", "damping"}
    err = capsys.readouterr().err
    assert "named: cable_inertia" in err and "0.12–0.2 Hz" in err
    # each stage says when it starts and ends, with its time, before the verdict
    stages = [line for line in err.splitlines() if line.startswith("diagnose: ") and " s" in line]
    assert [s.split(" in ")[0] for s in stages if " done in " in s or " built in " in s] == [
        "diagnose: model built", "diagnose: fits done", "diagnose: naming done"], err
    assert err.index("naming done") < err.index("named: cable_inertia")


@pytest.mark.parametrize("argv, says", [
    (["--free-decay"], "--out"),
    (["--free-decay", "--out", "X.csv", "--cables", "lumped", "--damping", "0.01,0.02,0.03"], "quasi-static"),
    (["--free-decay", "--out", "X.csv", "--damping", "1.5"], "[0, 1)"),
    (["--free-decay", "--out", "X.csv", "--attitude", "auto"], "level attitude"),
    (["--out", "X.csv"], "add --free-decay"),
])
def test_bad_free_decay_options_are_refused_before_work(tmp_path, argv, says, capsys):
    argv = [a.replace("X.csv", str(tmp_path / "x.csv")) for a in argv]
    assert main(["fast", *argv]) == 2
    assert says in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()

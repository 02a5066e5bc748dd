"""The mechanism abstraction, checked for every registered family through its presets.

A new family registered with a preset is tested here without editing this file.
"""

import json
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax.mechanism import AbstractMechanism, families, preset, presets


def travel(seed: int, n: int, m: AbstractMechanism | None = None) -> np.ndarray:
    """``n`` reachable poses uniform in ``m``'s travel (default ±1 mm, ±1°). Some travels are
    not a box of reachable poses (the Rubin camera hexapod's corners exceed its strut
    limits): unreachable draws are dropped."""
    rng = np.random.default_rng(seed)
    half = np.array([1.0, 1.0, 1.0] + [np.deg2rad(1.0)] * 3)
    if m is not None and m.travel_half_widths is not None:
        half = np.asarray(m.travel_half_widths)
    if m is None:
        return rng.uniform(-half, half, (n, 6))
    out = np.zeros((0, 6))
    while len(out) < n:
        p = rng.uniform(-half, half, (8 * n, 6))
        out = np.concatenate([out, p[np.asarray(m.solve_inverse_kinematics(jnp.asarray(p)).reachable)]])
    return out[:n]


PRESETS = presets()


def test_every_family_has_a_preset():
    assert {preset(name).family for name in PRESETS} == set(families())


@pytest.mark.parametrize("name", PRESETS)
def test_params_round_trip_and_file_round_trip(name, tmp_path):
    m = preset(name)
    assert isinstance(m, AbstractMechanism)
    u = np.asarray(m.params)
    assert u.shape == (m.n_params,) and len(m.param_names) == m.n_params
    np.testing.assert_array_equal(m.with_params(jnp.asarray(u)).params, u)
    path = tmp_path / "g.json"
    sj.save_mechanism(m, path)
    assert json.loads(path.read_text())["mechanism"] == m.family
    back = sj.load_mechanism(path)
    assert type(back) is type(m)
    np.testing.assert_array_equal(back.params, u)
    np.testing.assert_array_equal(back.v0, m.v0)
    assert [p.name for p in tmp_path.iterdir()] == ["g.json"]  # the atomic write left no temporary


def overrides(m: AbstractMechanism, method: str) -> bool:
    """Whether ``m``'s family replaces the abstraction's automatic-differentiation default."""
    return getattr(type(m), method) is not getattr(AbstractMechanism, method)


@jax.jit
def _readings(m, poses):
    return m.solve_inverse_kinematics(poses).readings


@pytest.mark.parametrize("name", PRESETS)
def test_pose_jacobian_matches_central_differences(name):
    # Every family, closed form or the forward-mode default: against the readings themselves.
    m = preset(name)
    poses = travel(1, 5, m)
    _, _, jac = m.ik_and_jacobian(jnp.asarray(poses))
    h = np.array([1e-4] * 3 + [1e-6] * 3)  # mm, rad
    steps = np.concatenate([np.diag(h), -np.diag(h)])  # (12, 6): +h_k, then −h_k
    q = np.asarray(_readings(m, jnp.asarray(poses[None] + steps[:, None]))).reshape(2, 6, *poses.shape)
    fd = np.moveaxis((q[0] - q[1]) / (2 * h[:, None, None]), 0, -1)  # (5, 6 legs, 6 components)
    # central differences of the readings: truncation ~h² times the third derivative and rounding
    # ~1e-16/h; 1e-7 of the largest entry is above both and far below any real entry
    np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-7 * np.max(np.abs(fd)))


@pytest.mark.parametrize("name", [n for n in PRESETS if overrides(preset(n), "ik_and_jacobian")])
def test_closed_form_pose_jacobian_matches_autodiff_default(name):
    m = preset(name)
    poses = jnp.asarray(travel(1, 5, m))
    _, _, jac = m.ik_and_jacobian(poses)
    _, _, ad = AbstractMechanism.ik_and_jacobian(m, poses)  # the abstraction's forward-mode default
    np.testing.assert_allclose(jac, ad, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", [n for n in PRESETS if overrides(preset(n), "parameter_jacobian")])
def test_parameter_jacobian_matches_autodiff_default(name):
    m = preset(name)
    poses = jnp.asarray(travel(4, 7, m))
    jac = m.parameter_jacobian(poses)
    ad = AbstractMechanism.parameter_jacobian(m, poses)  # forward-mode AD through with_params
    # entries are O(1e-2..1); the closed forms are cancellation-free, so rounding stays ~1e-16
    np.testing.assert_allclose(jac, ad, rtol=0, atol=1e-14)


@pytest.mark.parametrize("name", PRESETS)
def test_parameter_jacobian_matches_central_differences(name):
    m = preset(name)
    poses = jnp.asarray(travel(2, 3, m))
    jac = np.asarray(m.parameter_jacobian(poses))
    u, h = np.asarray(m.params), 1e-4
    us = jnp.asarray(np.concatenate([u + h * np.eye(len(u)), u - h * np.eye(len(u))]))
    q = np.asarray(jax.jit(jax.vmap(lambda v: m.with_params(v).solve_inverse_kinematics(poses).readings))(us))
    fd = ((q[:len(u)] - q[len(u):]).reshape(len(u), -1) / (2 * h)).T
    # central differences of a smooth ~200 mm-scale function: truncation ~h² and rounding
    # ~1e-13/h; 1e-8 (mm or rad per parameter unit) is above both and far below any real entry
    np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-8)


@pytest.mark.parametrize("name", PRESETS)
def test_forward_kinematics_inverts_inverse_kinematics(name):
    m = preset(name)
    poses = travel(3, 16, m)
    fk = sj.forward_kinematics(m, sj.inverse_kinematics(m, poses))
    assert bool(np.all(fk.converged))
    np.testing.assert_allclose(fk.poses[:, :3], poses[:, :3], rtol=0, atol=1e-10)
    np.testing.assert_allclose(fk.poses[:, 3:], poses[:, 3:], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", PRESETS)
def test_vmap_over_mechanisms_matches_a_loop(name):
    m = preset(name)
    rng = np.random.default_rng(4)
    us = np.asarray(m.params) + rng.normal(0, 0.1, (4, m.n_params))
    poses = jnp.asarray(travel(5, 6, m))
    batched = jax.vmap(lambda u: m.with_params(u).solve_inverse_kinematics(poses).readings)(jnp.asarray(us))
    for u, b in zip(us, batched, strict=True):
        np.testing.assert_array_equal(m.with_params(jnp.asarray(u)).solve_inverse_kinematics(poses).readings, b)


def test_file_without_family_key_is_the_paper_6pss(tmp_path):
    g = sj.nominal_geometry()
    d = g.to_dict()
    del d["mechanism"]
    (tmp_path / "old.json").write_text(json.dumps(d))
    back = sj.load_mechanism(tmp_path / "old.json")
    assert isinstance(back, sj.mechanism.PSSMechanism)
    np.testing.assert_array_equal(back.params, g.params)


def test_bad_geometry_files_name_the_problem(tmp_path):
    (tmp_path / "fam.json").write_text(json.dumps({"mechanism": "7-XYZ"}))
    with pytest.raises(ValueError, match="unknown mechanism family '7-XYZ'"):
        sj.load_mechanism(tmp_path / "fam.json")
    (tmp_path / "broken.json").write_text("{ not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        sj.load_mechanism(tmp_path / "broken.json")
    with pytest.raises(FileNotFoundError, match="neither a preset"):
        sj.load_mechanism(tmp_path / "missing.json")
    with pytest.raises(ValueError, match="unknown geometry preset"):
        preset("true")


@pytest.mark.parametrize("name", sorted(presets()))
def test_a_parameter_vector_of_the_wrong_length_is_refused_naming_the_family(name):
    m = preset(name)
    with pytest.raises(ValueError, match=rf"^{re.escape(m.family)}.* params must have a last axis of {m.n_params}"):
        m.with_params(np.zeros(m.n_params + 1))
    if m.family == "6-PSS":
        with pytest.raises(ValueError, match=r"\(54-parameter set\)"):
            m.with_param_set("54").with_params(np.zeros(5))

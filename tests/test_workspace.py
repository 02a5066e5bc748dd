"""The reachable workspace along rays: extents are reachable just inside and not just outside,
agree with a dense scan, name the limit that binds, reach ``max_extent`` without limits, and
the jit/vmap paths and the figure work. Registry-driven over the mechanism presets."""

from __future__ import annotations

from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax import mechanism as M, plotting

PRESETS = M.presets()
MAX_MM = 300.0  # beyond every preset's limits where it has any
MAX_RAD = 0.5
REL = 1e-6


N = 12  # rays per call everywhere, so that each mechanism compiles once per kind of call


@jax.jit
def _jit_reachable(m, poses):
    return m.solve_inverse_kinematics(poses).reachable


def _reachable(m, poses) -> np.ndarray:
    return np.asarray(_jit_reachable(m, jnp.asarray(poses, dtype=jnp.float64)))


def _check_inside_outside(m, r) -> None:
    d = np.asarray(r.directions)
    s = np.asarray(r.extent)
    c = np.asarray(r.centre)
    hit = np.asarray(r.hit_max)
    assert np.all(np.asarray(r.converged))
    assert np.all(_reachable(m, c + (s * (1 - REL))[:, None] * d))
    assert np.all(_reachable(m, c + s[:, None] * d))
    out = _reachable(m, c + (s * (1 + REL))[:, None] * d)
    assert not np.any(out[~hit]), "just outside a bounded ray must be unreachable"
    np.testing.assert_array_equal(s[hit], np.asarray(r.max_extent)[hit])
    assert np.all(np.asarray(r.binding_leg)[hit] == -1)
    assert np.all((np.asarray(r.binding_leg)[~hit] >= 0) & (np.asarray(r.binding_leg)[~hit] < 6))
    assert np.all(np.asarray(r.margin) >= 0)


@pytest.fixture(scope="module", params=PRESETS)
def travel(request):
    m = M.preset(request.param)
    return request.param, m, M.max_travel(m, max_extent_mm=MAX_MM, max_extent_rad=MAX_RAD)


# ---- (a) just inside reachable, just outside not -----------------------------------------------


def test_max_travel_inside_outside(travel):
    _, m, mt = travel
    _check_inside_outside(m, mt.rays)
    np.testing.assert_array_equal(np.asarray(mt.plus), np.asarray(mt.rays.extent)[0::2])
    np.testing.assert_array_equal(np.asarray(mt.minus), np.asarray(mt.rays.extent)[1::2])
    np.testing.assert_array_equal(np.asarray(mt.half_widths), np.minimum(mt.plus, mt.minus))


@pytest.mark.parametrize("name", PRESETS)
def test_envelopes_inside_outside(name):
    m = M.preset(name)
    _check_inside_outside(m, M.translation_envelope(m, N, max_extent=MAX_MM))
    _check_inside_outside(m, M.orientation_envelope(m, N - 2, max_extent=MAX_RAD))
    # away from the zero pose too
    _check_inside_outside(
        m, M.translation_envelope(m, N, orientation=(1e-3, -2e-3, 1e-3), translation=(0.5, 0.0, -0.5),
                                  max_extent=MAX_MM)
    )


@pytest.mark.parametrize("name", PRESETS)
def test_published_travel_lies_inside_the_workspace(name):
    """Default search range (4× the published travel): each axis reaches at least its
    published half-width."""
    m = M.preset(name)
    hw = m.travel_half_widths
    if hw is None:
        pytest.skip("no published travel")
    mt = M.max_travel(m)
    assert np.all(np.asarray(mt.half_widths) >= hw * (1 - 1e-12))


# ---- (b) a dense scan along the same rays --------------------------------------------------------


def test_agrees_with_dense_scan(travel):
    _, m, mt = travel
    r = mt.rays
    d = np.asarray(r.directions)
    for i in range(d.shape[0]):
        e = float(r.max_extent[i])
        t = np.linspace(0.0, e, 4001)
        ok = _reachable(m, t[:, None] * d[i])
        if ok.all():
            assert bool(r.hit_max[i]) and float(r.extent[i]) == e
            continue
        k = int(np.argmin(ok))
        assert k > 0 and not bool(r.hit_max[i])
        lo, hi = t[k - 1], t[k]
        assert lo - 1e-9 * e <= float(r.extent[i]) <= hi + 1e-9 * e, (i, lo, hi, r.extent[i])


class _Gap(M.AbstractMechanism):
    """A toy mechanism reachable for x ∈ [0, 2] ∪ [3, 5]: its first exit along +x is at 2."""

    family: ClassVar[str] = "toy-gap"
    reading_unit: ClassVar[str] = "mm"
    v0: Any

    def __init__(self):
        self.v0 = jnp.zeros(3)

    @property
    def params(self):
        return jnp.zeros(1)

    @property
    def param_units(self):
        return ("mm",)

    def moving_joints(self, poses):
        return jnp.zeros((*poses.shape[:-1], 6, 3))

    def with_params(self, params):
        return self

    def solve_inverse_kinematics(self, poses):
        x = poses[..., 0]
        gap = jnp.maximum(2.0 - x, x - 3.0)
        margin = jnp.stack([gap, 5.0 - jnp.abs(x)] + [jnp.ones_like(x)] * 4, axis=-1)
        return M.IKSolution(poses, margin, jnp.all(margin >= 0, axis=-1))

    def to_dict(self):
        return {"mechanism": self.family}

    @classmethod
    def from_dict(cls, d):
        return cls()


def test_first_exit_of_a_ray_that_re_enters():
    r = M.workspace_along_rays(_Gap(), np.eye(6)[:1], max_extent=10.0)
    assert abs(float(r.extent[0]) - 2.0) < 1e-8
    assert int(r.binding_leg[0]) == 0 and bool(r.converged[0]) and not bool(r.hit_max[0])
    r = M.workspace_along_rays(_Gap(), -np.eye(6)[:1], max_extent=10.0)
    assert abs(float(r.extent[0]) - 5.0) < 1e-8 and int(r.binding_leg[0]) == 1


# ---- (c) rubin_camera: ±x ends at the stroke limits ----------------------------------------------


def test_rubin_camera_x_is_limited_by_stroke():
    m = M.preset("rubin_camera")
    lo_lim, hi_lim = m.stroke_limits[0]
    mt = M.max_travel(m, max_extent_mm=MAX_MM, max_extent_rad=MAX_RAD)
    r = mt.rays
    d = m.to_dict()
    base, platform, v0 = (np.asarray(d[k]) for k in ("base", "platform", "v0"))
    lengths0 = np.asarray(d["lengths0"])
    for i in (0, 1):  # +x, −x
        assert not bool(r.hit_max[i])
        leg = int(r.binding_leg[i])
        q = float(r.readings[i, leg])
        assert min(abs(q - lo_lim), abs(q - hi_lim)) < 1e-6, q
        # the same reading from the strut ends, independently of the library's kinematics
        pose_x = float(r.extent[i]) * (1.0 if i == 0 else -1.0)
        q_np = np.linalg.norm(platform + v0 + [pose_x, 0.0, 0.0] - base, axis=1) - lengths0
        assert np.max(np.abs(q_np)) == pytest.approx(14.1, abs=1e-6)
        assert abs(q_np[leg]) == pytest.approx(14.1, abs=1e-6)
    # the published ±11.4 mm lies inside, the stroke limit is met a little beyond
    assert 11.4 < float(mt.half_widths[0]) < MAX_MM


def test_joint_angle_limit_binds():
    m = M.preset("rubin_camera")
    d = m.to_dict()
    tight = M.UPSMechanism(d["base"], d["platform"], d["v0"], joint_angle_limit=np.deg2rad(0.5))
    r = M.max_travel(tight, max_extent_mm=MAX_MM, max_extent_rad=MAX_RAD).rays
    _check_inside_outside(tight, r)
    assert not np.any(np.asarray(r.hit_max)[:6])
    np.testing.assert_allclose(np.asarray(r.margin)[np.arange(12), np.maximum(r.binding_leg, 0)][:6], 0.0,
                               atol=1e-6)


# ---- (d) no limits: every ray reaches max_extent ---------------------------------------------------


def test_ups_without_limits_reaches_max_extent():
    d = M.preset("rubin_camera").to_dict()
    free = M.UPSMechanism(d["base"], d["platform"], d["v0"])
    for r in (M.translation_envelope(free, N, max_extent=80.0), M.orientation_envelope(free, N - 2, max_extent=0.3)):
        np.testing.assert_array_equal(np.asarray(r.extent), np.asarray(r.max_extent))
        assert np.all(np.asarray(r.hit_max)) and np.all(np.asarray(r.binding_leg) == -1)
        assert np.all(np.asarray(r.converged))


# ---- (e) jit and vmap ------------------------------------------------------------------------------

_DIRS = np.concatenate([np.eye(6), -np.eye(6)])
_EXT = np.array(([40.0] * 3 + [0.1] * 3) * 2)


def test_jit_matches_eager():
    m = M.preset("rubin_camera")
    eager = M.workspace_along_rays(m, _DIRS, max_extent=_EXT)
    jitted = jax.jit(lambda mech, d, e: M.workspace_along_rays(mech, d, max_extent=e))(m, _DIRS, _EXT)
    np.testing.assert_allclose(np.asarray(jitted.extent), np.asarray(eager.extent), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(jitted.binding_leg), np.asarray(eager.binding_leg))


def test_vmap_over_mechanisms_and_centres():
    m = M.preset("rubin_camera")
    shifted = m.with_params(m.params + jnp.concatenate([jnp.zeros(36), jnp.full(6, 0.5)]))
    batch = jax.tree_util.tree_map(lambda a, b: jnp.stack([a, b]), m, shifted)
    out = jax.vmap(lambda mech: M.workspace_along_rays(mech, _DIRS, max_extent=_EXT).extent)(batch)
    for k, one in enumerate((m, shifted)):
        np.testing.assert_allclose(np.asarray(out[k]),
                                   np.asarray(M.workspace_along_rays(one, _DIRS, max_extent=_EXT).extent), atol=1e-12)
    centres = jnp.array([[0.0] * 6, [1.0, -1.0, 0.5, 0.0, 0.0, 0.0]])
    outc = jax.vmap(lambda c: M.workspace_along_rays(m, _DIRS, centre=c, max_extent=_EXT).extent)(centres)
    ref = M.workspace_along_rays(m, _DIRS, centre=np.asarray(centres[1]), max_extent=_EXT).extent
    np.testing.assert_allclose(np.asarray(outc[1]), np.asarray(ref), atol=1e-12)


def test_unreachable_centre_reports_zero():
    m = M.preset("rubin_camera")
    r = M.workspace_along_rays(m, _DIRS, centre=[60.0, 0, 0, 0, 0, 0], max_extent=10.0)
    assert np.all(np.asarray(r.extent) == 0.0)
    assert not np.any(np.asarray(r.converged)) and np.all(np.asarray(r.binding_leg) == -1)


# ---- input checks ----------------------------------------------------------------------------------


def test_input_errors():
    m = M.preset("rubin_camera")
    with pytest.raises(ValueError, match="shape"):
        M.workspace_along_rays(m, np.ones(6) / np.sqrt(6), max_extent=1.0)
    with pytest.raises(ValueError, match="unit"):
        M.workspace_along_rays(m, 2 * np.eye(6), max_extent=1.0)
    with pytest.raises(ValueError, match="positive"):
        M.workspace_along_rays(m, np.eye(6), max_extent=0.0)
    with pytest.raises(ValueError, match="positive"):
        M.workspace_along_rays(m, np.eye(6), max_extent=-np.ones(6))
    with pytest.raises(ValueError, match="one per direction"):
        M.workspace_along_rays(m, np.eye(6), max_extent=np.ones(5))
    with pytest.raises(ValueError, match="degrees"):
        M.orientation_envelope(m, 4, max_extent=10.0)
    with pytest.raises(ValueError, match="plane"):
        M.translation_envelope(m, 4, plane="xq")
    with pytest.raises(ValueError, match="n_directions"):
        M.translation_envelope(m, 0)
    with pytest.raises(ValueError, match="travel"):
        M.max_travel(M.UPSMechanism(m.base, m.platform, m.v0))


# ---- (f) the figure --------------------------------------------------------------------------------


def test_plot_workspace_builds():
    m = M.preset("rubin_camera")
    env = M.translation_envelope(m, 48, max_extent=40.0)
    secs = {p: M.translation_envelope(m, N, plane=p, max_extent=40.0) for p in ("xy", "yz")}
    for fig in (plotting.plot_workspace(env, sections=secs, travel=m.travel_half_widths, title="rubin_camera"),
                plotting.plot_workspace(env)):
        axes = fig.axes
        assert len(axes) == 3
        for ax in axes:
            assert ax.get_xlabel() and ax.get_ylabel() and ax.get_legend() is not None
        plt.close(fig)
    with pytest.raises(ValueError, match="translation"):
        plotting.plot_workspace(M.orientation_envelope(m, N - 2, max_extent=0.1))


def test_core_import_stays_light():
    assert hasattr(sj, "mechanism") and callable(sj.mechanism.workspace_along_rays)

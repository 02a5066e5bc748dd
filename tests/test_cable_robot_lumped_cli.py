"""``stewart-jax fast --modes --cables lumped``: the JSON's modes, shares and statics, the
quasi-static default untouched, and the refused inputs (the model itself is tested in
test_cable_robot_lumped.py)."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax  # noqa: F401
from stewart_jax._cli import build_parser, main
from stewart_jax.cable_robot import cabin_modes, paper_fast_params, static_equilibrium

static_equilibrium_jit, cabin_modes_jit = jax.jit(static_equilibrium), jax.jit(cabin_modes)


def test_quasi_static_stays_the_default():
    args = build_parser().parse_args(["fast", "--modes"])
    assert args.cables == "quasi-static" and args.segments == 20


@pytest.mark.parametrize("extra, message", [
    (["--segments", "1"], "--segments: the number of cable segments must be at least 2"),
    (["--segments", "3", "--cutoff-hz", "-1"], "--cutoff-hz"),
])
def test_bad_lumped_options_are_refused(extra, message, capsys):
    assert main(["fast", "--modes", "--cables", "lumped", *extra]) == 2
    assert message in capsys.readouterr().err


def test_lumped_needs_modes(capsys):
    assert main(["fast", "--cables", "lumped"]) == 2
    assert "--modes" in capsys.readouterr().err


@pytest.mark.slow  # the 8-segment lumped modes through the command line: 19 s
def test_lumped_modes_json(tmp_path):
    out = tmp_path / "lumped.json"
    assert main(["fast", "--position", "0,0,140", "--modes", "--cables", "lumped", "--segments", "8",
                 "--cutoff-hz", "1.0", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    m, c = d["modes"], d["cables"]
    assert d["status"] == "ok" and m["status"] == "ok" and c["segments"] == 8
    assert c["degrees_of_freedom"] == 6 + 18 * 7
    f = np.array(m["frequencies_hz"])
    assert len(f) > 6 and np.all(np.diff(f) >= 0) and f[-1] < 1.0
    assert len(m["kind"]) == len(f) == len(m["cabin_energy_share"])
    assert set(m["kind"]) == {"cabin", "string"}
    for name in ("swing_x", "swing_y", "heave", "roll", "pitch", "yaw"):
        share = np.array(m["compliance_share"][name])
        assert share.shape == f.shape and np.all(share >= -1e-12) and share.sum() <= 1 + 1e-9
        assert 0 < m["dominant"][name]["compliance_share"] <= 1
    # the six equal tensions at the centre within the discretisation (O(1/N²)) of the catenary's
    st = static_equilibrium_jit(paper_fast_params(), jnp.array([0.0, 0.0, 140.0]), jnp.eye(3))
    T = np.linalg.norm(np.asarray(st.force), axis=-1)
    np.testing.assert_allclose(c["anchor_tension_n"], T, rtol=2e-2)
    # cable inertia lowers the bounce below the quasi-static cables' frequency
    qs = np.asarray(cabin_modes_jit(paper_fast_params(), jnp.array([0.0, 0.0, 140.0]), jnp.eye(3), st)
                    .frequencies_hz)
    heave = m["dominant"]["heave"]["frequency_hz"]
    assert heave < 0.9 * qs[np.argmin(np.abs(qs - 0.28))]

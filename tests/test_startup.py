"""Start-up: ``import stewart_jax`` and the command line's ``--help``, ``--version`` and argument
errors load no JAX (each subcommand loads what it needs when it runs), the float64 and cache
settings still apply whichever of JAX and stewart_jax is imported first, and a misspelt
subcommand, option or choice gets the nearest name."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from stewart_jax._cli import COMMANDS, build_parser

LOADED = ("import sys, json; "
          "print(json.dumps(sorted(m for m in ('jax', 'numpy', 'stewart_jax.calibration') if m in sys.modules)))")


def python(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def loaded_after(code: str) -> list[str]:
    out = python(f"{code}\n{LOADED}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_importing_the_package_loads_no_jax():
    assert loaded_after("import stewart_jax") == []


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["calibrat", "data.csv"], []])
def test_the_command_line_answers_without_jax(argv):
    code = f"""
from stewart_jax._cli import main
try:
    main({argv!r})
except SystemExit as e:
    print("exit", e.code)
"""
    out = python(f"{code}\n{LOADED}")
    exit_line, loaded = out.stdout.strip().splitlines()[-2:]
    assert json.loads(loaded) == [] and exit_line == ("exit 0" if argv[:1] in (["--help"], ["--version"]) else "exit 2")
    assert ("usage: stewart-jax" in out.stdout + out.stderr) or "stewart-jax 0" in out.stdout


@pytest.mark.parametrize("first", ["import jax", "import stewart_jax", "import stewart_jax.mechanism"])
def test_float64_and_the_cache_apply_whichever_is_imported_first(first, tmp_path):
    code = (f"{first}\nimport jax, stewart_jax.mechanism as m\nimport jax.numpy as jnp\n"
            "print(jnp.asarray(1.0).dtype, m.preset('nominal').upper.dtype, jax.config.jax_compilation_cache_dir)")
    env_code = f"import os; os.environ['STEWART_JAX_CACHE_DIR'] = {str(tmp_path)!r}\n{code}"
    out = python(env_code)
    assert out.returncode == 0, out.stderr
    dtype, upper_dtype, folder = out.stdout.split()
    assert dtype == upper_dtype == "float64" and folder.startswith(str(tmp_path))


def test_every_subcommand_is_listed_with_its_modules_help_line():
    import argparse
    import importlib

    for name, (module, adder, line) in COMMANDS.items():
        scratch = argparse.ArgumentParser(prog="stewart-jax").add_subparsers()
        getattr(importlib.import_module(f"stewart_jax._cli.{module}"), adder)(scratch)
        helps = {a.dest: a.help for a in scratch._choices_actions}
        assert helps[name] == line, name
        assert build_parser().parse_args([name, *_minimal_args(name)]).func is not None


def _minimal_args(name: str) -> list[str]:
    return {"simulate": ["--out", "x.csv"], "calibrate": ["x.csv"], "diagnose": ["x.csv"],
            "simulate-effect": ["--out", "x.csv"], "export": ["nominal"], "lut": ["check", "x.yaml"]}.get(name, [])


@pytest.mark.parametrize(("argv", "hint"), [
    (["calibrat", "x.csv"], "did you mean 'calibrate'?"),
    (["simulate-efect"], "did you mean 'simulate-effect'"),
    (["calibrate", "x.csv", "--methd", "lm"], "did you mean --method for --methd?"),
    (["calibrate", "x.csv", "--method", "lm-batchd"], "did you mean 'lm-batched'?"),
    (["export", "nominal", "--formt", "json"], "did you mean --format for --formt?"),
])
def test_a_misspelt_name_gets_a_suggestion(argv, hint, capsys):
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2 and hint in err, err


def test_a_word_far_from_every_name_gets_no_suggestion(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["calibrate", "x.csv", "--zzzzzz"])
    assert "did you mean" not in capsys.readouterr().err


def test_the_latency_benchmark_runs_at_a_small_size(tmp_path):
    """``benchmarks/latency.py --quick``: the start-up commands cold and warm, with the verdict
    on ``--help`` against a bare ``import numpy``."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, str(root / "benchmarks" / "latency.py"), "--quick", "--warm-repeats", "1",
                          "--out", str(tmp_path / "latency")], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads((tmp_path / "latency.json").read_text())
    assert [r["command"] for r in result["rows"]] == ["--help", "--version", "export (json)"]
    assert all(r["cold"]["exit"] == 0 and r["warm"]["exit"] == 0 for r in result["rows"])
    assert [t["target"] for t in result["targets"]] == ["--help / import numpy, CPU"]
    assert "| target |" in (tmp_path / "latency.md").read_text()


@pytest.mark.parametrize("seed", [0, 1, 12345, 2**31, 2**32 - 1, 2**32, 2**40 + 7])
def test_the_command_lines_key_is_jax_random_key_of_the_seed(seed):
    """The command line builds its key without running JAX's seeding program; it must be the
    very key ``jax.random.key(seed)`` makes (else every stochastic result would move)."""
    import jax

    from stewart_jax._cli._common import seed_key

    np_equal = (jax.random.key_data(seed_key(seed)) == jax.random.key_data(jax.random.key(seed))).all()
    assert bool(np_equal)
    assert jax.random.key_impl(seed_key(seed)) == jax.random.key_impl(jax.random.key(seed))


def test_a_command_line_process_freezes_its_start_up_objects(tmp_path):
    """``main()`` of a process imports with the collector off and freezes what the imports built;
    an in-process call with an explicit argv leaves the collector as it found it."""
    script = (
        "import gc, sys\n"
        "from stewart_jax._cli import main\n"
        "out = sys.argv[1]\n"
        "sys.argv = ['stewart-jax', 'export', 'nominal', '--format', 'json', '--out', out]\n"
        "before = gc.get_freeze_count()\n"
        "assert main() == 0 and gc.isenabled() and gc.get_freeze_count() > before + 10_000\n"
        "assert gc.get_threshold()[0] == 20_000\n"
        "frozen = gc.get_freeze_count()\n"
        "gc.set_threshold(700, 10, 10)\n"
        "assert main(['export', 'nominal', '--format', 'json', '--out', out + '2']) == 0\n"
        "assert gc.isenabled() and gc.get_freeze_count() == frozen and gc.get_threshold() == (700, 10, 10)\n"
    )
    out = subprocess.run([sys.executable, "-c", script, str(tmp_path / "n.json")], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]

"""Every ``stewart-jax`` command line that the README and the docs show, checked against the real
command line, so that a documented command cannot rot unnoticed:

- each concrete command (not a usage synopsis with ``[…]`` or ``{…}``) parses with the real
  parser: its subcommand, its flags and their values exist;
- each subcommand the parser offers is documented, and is run end to end by some test of the suite
  (``main(["<subcommand>", …])``; ``simulate-effect`` by this file);
- the documented ``simulate-effect`` example runs as shown.

The notebooks are executed in quick mode by ``tests/test_docs.py`` (the strict site build).
"""

from __future__ import annotations

import pathlib
import re
import shlex

import numpy as np
import pytest

from stewart_jax._cli import build_parser, main

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def _documented_commands() -> list[tuple[str, str]]:
    """``(where, command)`` for every ``stewart-jax`` line inside a fenced block, continuations joined."""
    found = []
    for path in DOCS:
        in_block, pending, start = False, "", 0
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if line.lstrip().startswith("```"):
                in_block, pending = not in_block, ""
                continue
            if not in_block:
                continue
            text = line.strip().removeprefix("$ ")
            if pending:
                text = pending + " " + text
            elif not text.startswith("stewart-jax "):
                continue
            else:
                start = number
            if text.endswith("\\"):
                pending = text[:-1].strip()
                continue
            pending = ""
            found.append((f"{path.relative_to(ROOT)}:{start}", text))
    return found


COMMANDS = _documented_commands()
CONCRETE = [(where, cmd) for where, cmd in COMMANDS if not re.search(r"[\[{]", cmd)]


def _argv(command: str) -> list[str]:
    command = re.sub(r"\$\(\([^)]*\)\)", "0", command)  # shell arithmetic in a cluster recipe
    words = shlex.split(command, comments=True)
    return words[1:]


def test_the_docs_show_commands():
    # the collector itself: a change of the docs' fences that hid every command would pass vacuously
    assert len(CONCRETE) >= 30, len(CONCRETE)


@pytest.mark.parametrize(("where", "command"), CONCRETE, ids=[w for w, _ in CONCRETE])
def test_every_documented_command_parses(where, command):
    parser = build_parser()
    try:
        parser.parse_args(_argv(command))
    except SystemExit as e:  # argparse's way to refuse
        pytest.fail(f"{where}: the documented command does not parse ({e}): {command}")


def _subcommands() -> list[str]:
    parser = build_parser()
    (action,) = [a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction"]
    return sorted(action.choices)


@pytest.mark.parametrize("name", _subcommands())
def test_every_subcommand_is_documented_and_run_by_a_test(name):
    assert any(_argv(cmd)[:1] == [name] for _, cmd in COMMANDS), f"`stewart-jax {name}` is in no README/docs example"
    runs = re.compile(rf"""main\(\[\s*["']{re.escape(name)}["']""")
    users = [p.name for p in (ROOT / "tests").glob("test_*.py") if runs.search(p.read_text(encoding="utf-8"))]
    run_here = name == "simulate-effect"  # test_simulate_effect_as_documented below
    assert users or run_here, f"no test runs `stewart-jax {name}`"


def test_simulate_effect_as_documented(tmp_path, monkeypatch):
    # docs/discrepancy.md: `stewart-jax simulate-effect --out d.csv --effect backlash --magnitude 3 --seed 1`
    (command,) = [cmd for _, cmd in COMMANDS if cmd.startswith("stewart-jax simulate-effect --out d.csv")]
    monkeypatch.chdir(tmp_path)
    assert main(_argv(command)) == 0
    header, *rows = (tmp_path / "d.csv").read_text().strip().splitlines()
    columns = header.split(",")
    for name in ("q1", "q6", "x", "rz"):
        assert name in columns, columns
    values = np.array([[float(v) for v in row.split(",")] for row in rows])
    assert values.shape[0] >= 8 and np.all(np.isfinite(values))

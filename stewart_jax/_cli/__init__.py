"""The ``stewart-jax`` command line: one module per subcommand (``add_parser``, ``run``).

``docs/conventions.md`` lists the files and JSON keys each subcommand reads and writes. This
package is the only place in stewart_jax that uses argparse.

A subcommand's module (and with it JAX) is imported only when that subcommand is named: the
top-level parser knows each subcommand by the one line of :data:`COMMANDS`, so that
``stewart-jax --help``, ``--version`` and a misspelt subcommand answer in the time of a bare
Python start. A misspelt subcommand, option or choice gets the closest names as a suggestion.
"""

from __future__ import annotations

import argparse
import ast
import difflib
import gc
import importlib
import re
import sys
from collections.abc import Sequence

COMMANDS: dict[str, tuple[str, str, str]] = {
    "simulate": ("simulate", "add_parser",
                 "write simulated measured data of any mechanism as CSV (poses in its travel)"),
    "calibrate": ("calibrate", "add_parser", "calibrate a mechanism's parameters from a measured CSV"),
    "study": ("study", "add_parser", "the Table 2 simulation study of Wang et al. (2018) over many seeds"),
    "diagnose": ("diagnose", "add_diagnose_parser", "model-discrepancy workflow: detect, name, add, show"),
    "simulate-effect": ("diagnose", "add_diagnose_parser", "simulated measured data with one hidden effect (CSV)"),
    "fast": ("fast", "add_fast_parser",
             "FAST feed support: cable + Stewart coupled vibration scenario (Yin et al., Table 2)"),
    "export": ("export", "add_parser", "write a geometry as JSON or as LinuxCNC genhexkins settings"),
    "lut": ("lut", "add_parser", "compensation look-up tables (controller YAML): apply, fit, check, diff"),
}
"""``{subcommand: (module in stewart_jax._cli, its function that adds the parser, one line of help)}``."""

EPILOG = """\
compilation cache:
  JAX compiles each numerical program once and keeps it on disk, so that later runs start in
  seconds: by default in ~/.cache/stewart_jax/jax-<version>-jaxlib-<version> (the platform's
  user cache folder), bounded to STEWART_JAX_CACHE_MAX_MB (default 1024). Environment:
    STEWART_JAX_CACHE_DIR=<folder>   keep the cache there instead
    STEWART_JAX_CACHE_DIR=off        no cache (every run compiles)
  A cache you configured for JAX itself (JAX_COMPILATION_CACHE_DIR) is used as configured.
"""


class _Parser(argparse.ArgumentParser):
    """argparse, with "did you mean" for a misspelt subcommand, option or choice."""

    def error(self, message):
        super().error(message + _suggestion(message, self))


class _LazyParsers(dict):
    """The subcommand parsers by name, each built (its module imported) on first access."""

    def __init__(self, prog: str):
        super().__init__()
        self.prog = prog
        self.built: list[argparse.ArgumentParser] = []

    def __getitem__(self, name: str) -> argparse.ArgumentParser:
        parser = super().__getitem__(name)
        if parser is None:
            module, adder, _ = COMMANDS[name]
            scratch = _Parser(prog=self.prog).add_subparsers(parser_class=_Parser)
            getattr(importlib.import_module(f".{module}", __name__), adder)(scratch)
            parser = scratch.choices[name]
            self[name] = parser
            self.built.append(parser)
        return parser


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = _Parser(prog="stewart-jax", epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
                     description="Hexapod (Stewart-platform) kinematics, calibration and dynamics (JAX).")
    parser.add_argument("--version", action="version", version=f"stewart-jax {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub._name_parser_map = sub.choices = _LazyParsers(parser.prog)
    for name, (_, _, line) in COMMANDS.items():
        sub._choices_actions.append(sub._ChoicesPseudoAction(name, (), line))
        dict.__setitem__(sub.choices, name, None)
    return parser


def _suggestion(message: str, parser: argparse.ArgumentParser) -> str:
    """``" (did you mean …?)"`` for a misspelt choice or option named in an argparse message."""
    if m := re.search(r"invalid choice: (.+?) \(choose from (.*)\)$", message):
        try:
            value, choices = ast.literal_eval(m.group(1)), ast.literal_eval(f"[{m.group(2)}]")
        except (ValueError, SyntaxError):
            return ""
        close = difflib.get_close_matches(str(value), [str(c) for c in choices], n=3, cutoff=0.6)
        return f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""
    if m := re.search(r"unrecognized arguments: (.*)$", message):
        options = [s for p in _parsers(parser) for a in p._actions for s in a.option_strings]
        hints = []
        for token in m.group(1).split():
            if token.startswith("-"):
                close = difflib.get_close_matches(token.split("=")[0], options, n=1, cutoff=0.75)
                hints += [f"{close[0]} for {token}"] if close else []
        return f" (did you mean {'; '.join(hints)}?)" if hints else ""
    return ""


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """The parser and the subcommand parsers built so far (those named on the command line)."""
    subs = [a.choices for a in parser._actions if isinstance(a.choices, _LazyParsers)]
    return [parser] + [p for s in subs for p in s.built]


YOUNG_COLLECTION_ALLOCATIONS = 20_000
"""How many allocations a command-line process lets pass between collections of the youngest
generation (Python's default: 700); :func:`main`."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line on ``argv`` (default: the process's own arguments) and return the exit
    status.

    NOTE: a process's command line (``argv`` None) imports JAX and the subcommand with the cyclic
    garbage collector off, then freezes what the imports built (``gc.freeze``) and collects the
    youngest generation every 20 000 allocations instead of 700: the collector then never walks
    JAX's start-up objects again and runs less often while JAX traces. Measured on a warm 8-pose
    ``calibrate``: 2.6 s of CPU with Python's defaults, 2.0 s so. The work runs with the collector
    on. An in-process call with an explicit ``argv`` (the tests, a notebook) leaves the collector
    alone."""
    own_process = argv is None
    if own_process:
        gc.disable()
    try:
        args = build_parser().parse_args(argv)
    finally:
        if own_process:
            gc.freeze()
            gc.set_threshold(YOUNG_COLLECTION_ALLOCATIONS, 20, 20)
            gc.enable()
    try:
        return args.func(args)
    except (ValueError, OSError, TypeError) as e:  # bad input or an unreadable/unwritable file: a message
        print(f"stewart-jax {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"stewart-jax {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())

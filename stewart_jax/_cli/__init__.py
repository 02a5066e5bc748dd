"""The ``stewart-jax`` command line: one module per subcommand (``add_parser``, ``run``).

``docs/conventions.md`` lists the files and JSON keys each subcommand reads and writes. This
package is the only place in stewart_jax that uses argparse.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from . import calibrate, diagnose, export, fast, lut, simulate, study


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stewart-jax", description="Hexapod (Stewart-platform) kinematics, calibration and dynamics (JAX)."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    simulate.add_parser(sub)
    calibrate.add_parser(sub)
    study.add_parser(sub)
    diagnose.add_diagnose_parser(sub)
    fast.add_fast_parser(sub)
    export.add_parser(sub)
    lut.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    import stewart_jax  # noqa: F401  (enables float64)

    args = build_parser().parse_args(argv)
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

"""``stewart-jax export``: a geometry as a complete geometry file or as LinuxCNC genhexkins settings."""

from __future__ import annotations

import argparse
import sys


def run(args: argparse.Namespace) -> int:
    from .._files import write_text_atomic
    from ..mechanism._genhexkins import to_genhexkins
    from ..mechanism._registry import load_mechanism, mechanism_json
    from ._common import check_outputs

    check_outputs(args, out="--out")
    mechanism = load_mechanism(args.geometry)
    text = to_genhexkins(mechanism) if args.format == "genhexkins" else mechanism_json(mechanism)
    if args.out is None:
        sys.stdout.write(text)
        return 0
    write_text_atomic(args.out, text)
    print(f"wrote {args.format} of {mechanism.family} geometry {args.geometry!r} to {args.out}", file=sys.stderr)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("export", help="write a geometry as JSON or as LinuxCNC genhexkins settings")
    p.add_argument("geometry", help="a preset name or a JSON/TOML geometry file")
    p.add_argument("--format", choices=("json", "genhexkins"), default="json")
    p.add_argument("--out", help="output file (default: standard output)")
    p.set_defaults(func=run)
    return p

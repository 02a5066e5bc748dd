"""``stewart-jax export``: a geometry as a complete geometry file or as LinuxCNC genhexkins settings."""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile


def run(args: argparse.Namespace) -> int:
    from ..mechanism._genhexkins import to_genhexkins
    from ..mechanism._registry import load_mechanism

    mechanism = load_mechanism(args.geometry)
    if args.format == "genhexkins":
        text = to_genhexkins(mechanism)
    else:
        text = json.dumps(mechanism.to_dict(), indent=2) + "\n"
    if args.out is None:
        sys.stdout.write(text)
        return 0
    directory = os.path.dirname(os.path.abspath(args.out))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".export-")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, args.out)
    print(f"wrote {args.format} of {mechanism.family} geometry {args.geometry!r} to {args.out}", file=sys.stderr)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("export", help="write a geometry as JSON or as LinuxCNC genhexkins settings")
    p.add_argument("geometry", help="a preset name or a JSON/TOML geometry file")
    p.add_argument("--format", choices=("json", "genhexkins"), default="json")
    p.add_argument("--out", help="output file (default: standard output)")
    p.set_defaults(func=run)
    return p

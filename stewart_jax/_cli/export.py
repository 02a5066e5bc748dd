"""``stewart-jax export``: a geometry as a complete geometry file or as LinuxCNC genhexkins settings."""

from __future__ import annotations

import argparse
import sys


def run(args: argparse.Namespace) -> int:
    from .._files import write_text_atomic
    from ..mechanism._genhexkins import to_genhexkins
    from ..mechanism._registry import load_mechanism, mechanism_json
    from ._common import check_outputs

    if args.format == "linuxcnc":
        return _run_linuxcnc(args)
    check_outputs(args, out="--out")
    mechanism = load_mechanism(args.geometry)
    text = to_genhexkins(mechanism) if args.format == "genhexkins" else mechanism_json(mechanism)
    if args.out is None:
        sys.stdout.write(text)
        return 0
    write_text_atomic(args.out, text)
    print(f"wrote {args.format} of {mechanism.family} geometry {args.geometry!r} to {args.out}", file=sys.stderr)
    return 0


def _run_linuxcnc(args: argparse.Namespace) -> int:
    import os

    from .._files import check_writable, write_text_atomic
    from ..mechanism._linuxcnc import to_linuxcnc
    from ..mechanism._registry import load_mechanism

    if args.out is None:
        raise ValueError("--format linuxcnc writes three files (INI, HAL, tool table): give the folder with --out DIR")
    limits = None
    if args.stroke_limits_mm is not None:
        try:
            limits = tuple(float(x) for x in args.stroke_limits_mm.split(","))
        except ValueError:
            limits = ()
        if len(limits) != 2:
            raise ValueError(f"--stroke-limits-mm takes MIN,MAX (mm of reading), got {args.stroke_limits_mm!r}")
    config = to_linuxcnc(load_mechanism(args.geometry), stroke_limits_mm=limits, name=args.name)
    paths = [os.path.join(args.out, f"{args.name}.{ext}") for ext in ("ini", "hal", "tbl")]
    os.makedirs(args.out, exist_ok=True)
    for path in paths:
        check_writable(path, "--out")
    for path, text in zip(paths, (config.ini, config.hal, config.tool_table), strict=True):
        write_text_atomic(path, text)
    print(f"wrote LinuxCNC genhexkins configuration of {args.geometry!r} to {', '.join(paths)}", file=sys.stderr)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("export", help="write a geometry as JSON or as LinuxCNC genhexkins settings")
    p.add_argument("geometry", help="a preset name or a JSON/TOML geometry file")
    p.add_argument("--format", choices=("json", "genhexkins", "linuxcnc"), default="json",
                   help="linuxcnc: an INI and a HAL file for genhexkins, in the directory --out")
    p.add_argument("--out", help="output file (default: standard output); for linuxcnc, a directory")
    p.add_argument("--name", default="hexapod", help="linuxcnc: the files' stem (NAME.ini, NAME.hal, NAME.tbl)")
    p.add_argument("--stroke-limits-mm", help="linuxcnc: MIN,MAX of the reading (mm) for a geometry without them")
    p.set_defaults(func=run)
    return p

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
    ignored = [flag for flag, given in (("--stroke-limits-mm", args.stroke_limits_mm is not None),
                                        ("--name", args.name != "hexapod"),
                                        ("--replace-edited", args.replace_edited)) if given]
    if ignored:
        raise ValueError(f"{', '.join(ignored)} apply to --format linuxcnc only; --format {args.format} would "
                         "ignore them")
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

    from .._files import check_writable, generated_state, keep_backup, stamp_generated, write_text_atomic
    from ..mechanism._linuxcnc import to_linuxcnc
    from ..mechanism._registry import load_mechanism

    if args.out is None:
        raise ValueError("--format linuxcnc writes three files (INI, HAL, tool table): give the folder with --out DIR")
    parent = os.path.dirname(os.path.abspath(args.out))
    if not os.path.isdir(parent):
        raise ValueError(f"--out {args.out}: the folder {parent} does not exist (the export creates the "
                         "configuration folder itself, never its parents, as every command refuses a missing folder)")
    limits = None
    if args.stroke_limits_mm is not None:
        try:
            limits = tuple(float(x) for x in args.stroke_limits_mm.split(","))
        except ValueError:
            limits = ()
        if len(limits) != 2:
            raise ValueError(f"--stroke-limits-mm takes MIN,MAX (mm of reading), got {args.stroke_limits_mm!r}")
    config = to_linuxcnc(load_mechanism(args.geometry), stroke_limits_mm=limits, name=args.name)
    files = {os.path.join(args.out, f"{args.name}.{ext}"): stamp_generated(text, comment)
             for ext, text, comment in (("ini", config.ini, "#"), ("hal", config.hal, "#"),
                                        ("tbl", config.tool_table, ";"))}
    user_hal = os.path.join(args.out, f"{args.name}_user.hal")
    states = {path: generated_state(path) for path in files}
    kept = [p for p, st in states.items() if st in ("edited", "foreign")]
    if kept and not args.replace_edited:
        why = {"edited": "edited since the export", "foreign": "not written by stewart_jax"}
        raise ValueError(
            "refusing to replace " + ", ".join(f"{p} ({why[states[p]]})" for p in kept)
            + f": put the machine's own wiring in {user_hal} (never replaced), or pass --replace-edited to "
            "replace them, keeping each as a .bak copy")
    os.makedirs(args.out, exist_ok=True)
    for path in [*files, user_hal]:
        check_writable(path, "--out")
    for path in kept:
        print(f"kept {path} (edited) as {keep_backup(path)}", file=sys.stderr)
    for path, text in files.items():
        write_text_atomic(path, text)
    written = list(files)
    if not os.path.exists(user_hal):
        write_text_atomic(user_hal, config.user_hal)
        written.append(user_hal)
    else:
        print(f"kept the user's HAL file {user_hal} as it is", file=sys.stderr)
    print(f"wrote LinuxCNC genhexkins configuration of {args.geometry!r} to {', '.join(written)}", file=sys.stderr)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("export", help="write a geometry as JSON or as LinuxCNC genhexkins settings")
    p.add_argument("geometry", help="a preset name or a JSON/TOML geometry file")
    p.add_argument("--format", choices=("json", "genhexkins", "linuxcnc"), default="json",
                   help="linuxcnc: an INI and a HAL file for genhexkins, in the directory --out")
    p.add_argument("--out", help="output file (default: standard output); for linuxcnc, a directory")
    p.add_argument("--name", default="hexapod", help="linuxcnc: the files' stem (NAME.ini, NAME.hal, NAME.tbl)")
    p.add_argument("--replace-edited", action="store_true",
                   help="linuxcnc: replace generated files edited since the export (or not written by it), "
                        "keeping each as NAME.bak")
    p.add_argument("--stroke-limits-mm", help="linuxcnc: MIN,MAX of the reading (mm) for a geometry without them")
    p.set_defaults(func=run)
    return p

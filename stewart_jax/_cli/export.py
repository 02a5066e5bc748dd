"""``stewart-jax export``: a geometry as a complete geometry file or as LinuxCNC genhexkins settings."""

from __future__ import annotations

import argparse
import sys


def run(args: argparse.Namespace) -> int:
    from .._files import write_text_atomic
    from ..mechanism._genhexkins import to_genhexkins
    from ..mechanism._registry import load_mechanism, mechanism_json
    from ._common import check_outputs

    _check_supported(args)
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


def unsupported_moves(path: str) -> list[str]:
    """The parameters a calibrated geometry file (with the ``_calibration`` record ``calibrate
    --out-geometry`` writes) moves further from nominal than its data support: moved more than a
    tenth of its prior scale where the data give it no standard deviation, or more than its prior
    scale where its standard deviation exceeds that scale. One phrase per parameter."""
    import json
    import os

    import numpy as np

    from ..mechanism._registry import load_mechanism
    from ._common import CALIBRATION_KEY

    if not (os.path.isfile(path) and path.endswith(".json")):
        return []
    with open(path, encoding="utf-8-sig") as f:
        record = json.load(f).get(CALIBRATION_KEY)
    if not isinstance(record, dict):
        return []
    params = np.asarray(load_mechanism(path).params)
    out = []
    for name, unit, p, p0, s, prior in zip(record["param_names"], record["param_units"], params,
                                           record["nominal_params"], record["param_std"], record["prior_scale"],
                                           strict=True):
        move = abs(float(p) - p0)
        std = np.inf if s is None else s
        if (s is None and move > 0.1 * prior) or (std > prior and move > prior):
            shown = "no std (not determined)" if s is None else f"std {s:.3g} {unit}"
            out.append(f"{name} moved {move:.3g} {unit} from nominal with {shown} against a prior scale of "
                       f"{prior:.3g} {unit}")
    return out


def _check_supported(args: argparse.Namespace) -> None:
    bad = unsupported_moves(args.geometry)
    if not bad:
        return
    text = (f"{args.geometry!r} moves {len(bad)} parameter(s) further than its calibration data support: "
            f"{'; '.join(bad[:6])}{' …' if len(bad) > 6 else ''}. A controller built on it is right only near the "
            "calibration poses; recalibrate holding the undetermined directions at nominal (stewart-jax calibrate "
            "does), or pass --allow-unsupported to export it anyway")
    if not args.allow_unsupported:
        raise ValueError(text)
    print(f"WARNING: {text}", file=sys.stderr)


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
    p.add_argument("--allow-unsupported", action="store_true",
                   help="export a calibrated geometry even where it moves a parameter further than its data "
                        "support (a warning instead of a refusal)")
    p.set_defaults(func=run)
    return p

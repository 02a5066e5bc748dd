"""``stewart-jax lut``: compensation look-up tables in the controller's YAML (apply, fit, check,
diff), and ``simulate --campaign``."""

from __future__ import annotations

import argparse
import csv
import io
import sys

from ._common import check_outputs, seed_key, write_json

_GEOMETRY = {"camera": "rubin_camera", "m2": "rubin_m2"}


def _pair(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected MIN,MAX, got {text!r}") from None
    return lo, hi


def _values(text: str) -> list[float]:
    """``A:B:STEP`` (inclusive) or ``V1,V2,…``."""
    try:
        if ":" in text:
            a, b, step = (float(x) for x in text.split(":"))
            if step <= 0 or b < a:
                raise ValueError
            return [a + i * step for i in range(int((b - a) / step + 1e-9) + 1)]
        return [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP:STEP or V1,V2,…, got {text!r}") from None


def _campaign(path: str, args):
    """A campaign CSV, or a points campaign (a points file with attitudes; ``--targets``)."""
    from ..calibration._csv import csv_rows
    from ..compensation._campaign import read_campaign

    if "target" not in csv_rows(path)[1]:
        return read_campaign(path)
    from ..calibration._points_io import read_targets
    from ..compensation._points import read_points_campaign
    from ..mechanism._registry import load_mechanism

    if not args.targets:
        raise ValueError(f"{path} is a points file (it has a 'target' column): give the targets' nominal coordinates "
                         "with --targets T.json")
    camp, dropped = read_points_campaign(path, read_targets(args.targets),
                                         load_mechanism(args.geometry or _GEOMETRY[args.hexapod]))
    if dropped:
        print(f"{path}: {len(dropped)} pose(s) with fewer than three targets seen left out: {', '.join(dropped[:10])}",
              file=sys.stderr)
    return camp


def _check_outputs(args, **outputs: str) -> None:
    """:func:`check_outputs`, ``--json`` included unless it names standard output."""
    from .._files import check_distinct_paths

    json_path = getattr(args, "json", None)
    if json_path and json_path != "-":
        outputs["json"] = "--json"
    check_outputs(args, **outputs)
    tables = [*(getattr(args, "files", None) or []), *(getattr(args, "base", None) or []),
              *(getattr(args, "truth", None) or [])]
    inputs = {f"table {p}": p for p in tables}
    for attr in ("a", "b", "campaign", "attitudes", "targets"):
        if isinstance(getattr(args, attr, None), str):  # simulate's --campaign is a flag
            inputs[attr] = getattr(args, attr)
    check_distinct_paths({what: getattr(args, attr, None) for attr, what in outputs.items()}, inputs)


def _emit_json(args, obj) -> None:
    if args.json == "-":
        from .._files import json_text

        sys.stdout.write(json_text(obj))
    elif args.json:
        write_json(args.json, obj)


def _attitudes(args) -> dict:
    """``--attitudes`` CSV or the one attitude of the options, as arrays (and filter names)."""
    import numpy as np

    if args.attitudes is not None and (args.elevation_deg is not None or args.rotation_deg is not None):
        raise ValueError("give one attitude (--elevation-deg, --rotation-deg) or --attitudes ATT.csv, not both")
    if args.attitudes is None:
        if args.elevation_deg is None or args.rotation_deg is None:
            raise ValueError("give --elevation-deg and --rotation-deg, or --attitudes ATT.csv")
        return {"elevation_deg": np.array([args.elevation_deg]), "rotation_deg": np.array([args.rotation_deg]),
                "azimuth_deg": np.array([args.azimuth_deg]), "temperature_degC": np.array([args.temperature_degC]),
                "filter": [args.filter]}
    with open(args.attitudes, encoding="utf-8", newline="") as f:
        rows = [r for r in csv.reader(ln for ln in f if not ln.lstrip().startswith("#")) if r]
    if len(rows) < 2:
        raise ValueError(f"{args.attitudes}: no header and rows")
    header = [h.strip() for h in rows[0]]
    for need in ("elevation_deg", "rotation_deg"):
        if need not in header:
            raise ValueError(f"{args.attitudes}: missing column {need!r} (columns: elevation_deg, rotation_deg, "
                             f"[azimuth_deg, temperature_degC, filter])")
    out: dict = {}
    for name, default in (("elevation_deg", None), ("rotation_deg", None), ("azimuth_deg", 0.0),
                          ("temperature_degC", 0.0)):
        if name not in header:
            out[name] = np.full(len(rows) - 1, default)
            continue
        j = header.index(name)
        try:
            out[name] = np.array([float(r[j]) for r in rows[1:]])
        except (ValueError, IndexError):
            raise ValueError(f"{args.attitudes}: column {name} has a missing or non-numeric cell") from None
    j = header.index("filter") if "filter" in header else None
    out["filter"] = [(r[j].strip() or None) if j is not None and j < len(r) else None for r in rows[1:]]
    return out


def _run_apply(args) -> int:
    import numpy as np

    from ..compensation._apply import strut_changes
    from ..compensation._table import OFFSET_COLUMNS
    from ..compensation._yaml import load_table
    from ..mechanism._registry import load_mechanism

    _check_outputs(args, out="--out")
    table = load_table(args.files, args.hexapod)
    mechanism = load_mechanism(args.geometry) if args.geometry else None
    att = _attitudes(args)
    off = np.asarray(table.offsets(att["elevation_deg"], att["rotation_deg"], att["azimuth_deg"],
                                   att["temperature_degC"], att["filter"]))
    cols = list(OFFSET_COLUMNS)
    rows = off
    if mechanism is not None:
        dq, _, ok = strut_changes(mechanism, off)
        if not ok.all():
            bad = int(np.flatnonzero(~ok)[0])
            raise ValueError(f"the compensated pose of attitude {bad + 1} is beyond the geometry's limits "
                             f"({args.geometry}): offsets {off[bad].tolist()}")
        cols += [f"strut{i}_um" for i in range(1, 7)]
        rows = np.concatenate([off, dq], axis=1)
    text = io.StringIO()  # one row per attitude, in the attitudes' order (the JSON repeats the attitude)
    text.write(",".join(cols) + "\n")
    for k in range(len(rows)):
        text.write(",".join(repr(float(v)) for v in rows[k]) + "\n")
    if args.out:
        from .._files import write_text_atomic

        write_text_atomic(args.out, text.getvalue())
    elif not args.json:
        sys.stdout.write(text.getvalue())
    _emit_json(args, {"hexapod": args.hexapod, "files": args.files, "geometry": args.geometry,
                      "rows": [dict(zip(("elevation_deg", "rotation_deg", "azimuth_deg", "temperature_degC"),
                                        (float(att[c][k]) for c in ("elevation_deg", "rotation_deg", "azimuth_deg",
                                                                    "temperature_degC")), strict=True))
                               | {"filter": att["filter"][k]} | dict(zip(cols, map(float, rows[k]), strict=True))
                               for k in range(len(rows))]})
    return 0


def _run_fit(args) -> int:
    from ..compensation._fit import fit_table
    from ..compensation._yaml import save_table

    _check_outputs(args, out="--out")
    campaign = _campaign(args.campaign, args)
    fit = fit_table(campaign, args.hexapod, max_degrees=tuple(args.max_degrees), folds=args.folds, seed=args.seed,
                    drop=not args.keep_all)
    report = fit.report()
    comments = [f"stewart-jax lut fit {args.campaign}: {fit.n_attitudes} attitudes, degrees by {fit.folds}-fold "
                "cross-validation"]
    for a in fit.axes:
        kept = sum(x.kept for x in a.terms)
        comments.append(f"{a.axis}: degrees (elevation, rotation, temperature) {a.degrees}, {kept} of {len(a.terms)} "
                        f"coefficients kept, held-out RMS {a.cv_rms:.4g} {a.unit}, prediction σ ≤ "
                        f"{a.prediction_std_max:.3g} {a.unit}")
    save_table(fit.table, args.out, comments)
    for c in comments:
        print(c, file=sys.stderr)
    for a in fit.axes:
        dropped = [f"E^{x.elevation_power}R^{x.rotation_power}T^{x.temperature_power}" for x in a.terms if not x.kept]
        labels = {lab: sum(x.label == lab for x in a.terms if x.kept) for lab in ("solid", "marginal", "noise")}
        print(f"  {a.axis}: kept {labels}; dropped as noise: {', '.join(dropped) or 'none'}", file=sys.stderr)
    _emit_json(args, {"campaign": args.campaign, "out": args.out, **report})
    return 0


def _domain(args):
    from ..compensation._check import Domain

    return Domain(args.elevation_range_deg, args.rotation_range_deg, args.temperature_range_degC)


def _run_check(args) -> int:
    import numpy as np

    from ..compensation._check import check_table
    from ..compensation._yaml import load_table
    from ..mechanism._registry import load_mechanism

    _check_outputs(args)
    table = load_table(args.files, args.hexapod)
    geometry = args.geometry or _GEOMETRY[args.hexapod]
    campaign = _campaign(args.campaign, args) if args.campaign else None
    result = check_table(table, load_mechanism(geometry), campaign=campaign, domain=_domain(args),
                         strut_limit_um=args.strut_limit_um)
    for axis, entry in result.offsets.items():
        unit = "um" if axis in "xyz" else "deg"
        print(f"{axis}: max |offset| {entry[f'max_abs_{unit}']:.6g} {unit} ({100 * entry.get('ratio', np.nan):.1f} % "
              f"of travel) at {entry['at']}", file=sys.stderr)
    if result.struts:
        s = result.struts
        print(f"struts: max |change| {s['max_abs_change_um']:.6g} µm (strut {s['strut']}) at {s['at']}; smallest "
              f"margin {s['min_margin_mm']:.6g} mm (strut {s['min_margin_strut']})", file=sys.stderr)
    for axis, entry in (result.campaign or {}).items():
        unit = "um" if axis in "xyz" else "deg"
        print(f"{axis}: campaign RMS {entry[f'rms_measured_{unit}']:.4g} → {entry[f'rms_after_table_{unit}']:.4g} "
              f"{unit}{'  MADE WORSE' if entry['worse'] else ''}", file=sys.stderr)
    for p in result.problems:
        print(f"problem: {p}", file=sys.stderr)
    print("lut check: " + ("passed" if result.passed else f"FAILED ({len(result.problems)} problem(s))"),
          file=sys.stderr)
    _emit_json(args, {"files": args.files, "hexapod": args.hexapod, "geometry": geometry, "passed": result.passed,
                      "problems": list(result.problems), "offsets": result.offsets, "struts": result.struts,
                      "campaign": result.campaign})
    return 0 if result.passed else 1


def _run_diff(args) -> int:
    from ..compensation._check import diff_tables
    from ..compensation._yaml import load_table
    from ..mechanism._registry import load_mechanism

    _check_outputs(args, plot="--plot")
    a = load_table([*args.base, args.a], args.hexapod)
    b = load_table([*args.base, args.b], args.hexapod)
    mechanism = load_mechanism(args.geometry) if args.geometry else None
    d = diff_tables(a, b, mechanism, domain=_domain(args))
    for axis, entry in d.offsets.items():
        unit = "um" if axis in "xyz" else "deg"
        print(f"{axis}: max |A − B| {entry[f'max_abs_diff_{unit}']:.6g} {unit} at {entry['at']}", file=sys.stderr)
    for strut, entry in (d.struts or {}).items():
        print(f"{strut}: max |A − B| {entry['max_abs_diff_um']:.6g} µm at {entry['at']}", file=sys.stderr)
    if args.plot:
        from ..plotting import plot_table_offsets, show
        from ._common import file_backend

        file_backend()
        show(plot_table_offsets({f"A ({args.a})": a, f"B ({args.b})": b}), args.plot)
    _emit_json(args, {"a": args.a, "b": args.b, "base": args.base, "hexapod": args.hexapod, "offsets": d.offsets,
                      "struts": d.struts, "plot": args.plot})
    return 0


def run(args: argparse.Namespace) -> int:
    return {"apply": _run_apply, "fit": _run_fit, "check": _run_check, "diff": _run_diff}[args.lut_command](args)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--hexapod", choices=("camera", "m2"), default="camera",
                   help="which table: camera_config or m2_config")
    p.add_argument("--json", nargs="?", const="-", default=None, metavar="OUT.json",
                   help="write the result as JSON to OUT.json (standard output without a name)")


def _domain_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--elevation-range-deg", type=_pair, default=(0.0, 90.0), metavar="MIN,MAX")
    p.add_argument("--rotation-range-deg", type=_pair, default=(-90.0, 90.0), metavar="MIN,MAX")
    p.add_argument("--temperature-range-degC", type=_pair, default=None, metavar="MIN,MAX",
                   help="default: the table's [min_temperature, max_temperature] where it has a temperature term")


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("lut", help="compensation look-up tables (controller YAML): apply, fit, check, diff")
    sub = p.add_subparsers(dest="lut_command", required=True)
    a = sub.add_parser("apply", help="offsets (and strut changes) of a table at attitudes")
    a.add_argument("files", nargs="+", help="YAML files merged in order, later wins (_init.yaml, overrides …)")
    a.add_argument("--elevation-deg", type=float)
    a.add_argument("--rotation-deg", type=float)
    a.add_argument("--azimuth-deg", type=float, default=0.0)
    a.add_argument("--temperature-degC", type=float, default=0.0,
                   help="default 0 °C, the controller's value when it has no temperature")
    a.add_argument("--filter", default=None, help="a filter name of the table's filter_offsets (adds its z_offset)")
    a.add_argument("--attitudes", metavar="ATT.csv",
                   help="columns elevation_deg, rotation_deg [, azimuth_deg, temperature_degC, filter]")
    a.add_argument("--out", metavar="OFF.csv", help="x_um … w_deg (and strut1_um … strut6_um) per attitude")
    a.add_argument("--geometry", help="a preset or geometry file: add the struts' length changes (µm)")
    _common(a)
    f = sub.add_parser("fit", help="fit a table (v7 YAML) to a campaign, with uncertainty")
    f.add_argument("campaign", help="campaign CSV (a '# sign: correction|error' header line), or a points file "
                                    "with attitude columns (with --targets)")
    f.add_argument("--targets", metavar="T.json", help="a points campaign: the targets' nominal coordinates")
    f.add_argument("--geometry", help="a points campaign: the hexapod's geometry (default rubin_camera / rubin_m2)")
    f.add_argument("--out", required=True, metavar="LUT.yaml")
    f.add_argument("--max-degrees", type=int, nargs=3, default=(5, 6, 2), metavar=("E", "R", "T"),
                   help="largest degrees tried in elevation, rotation, temperature (default 5 6 2)")
    f.add_argument("--folds", type=int, default=5, help="cross-validation folds (default 5)")
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--keep-all", action="store_true", help="deploy every coefficient, significant or not")
    _common(f)
    c = sub.add_parser("check", help="scan the domain for limits; compare with a campaign")
    c.add_argument("files", nargs="+", help="YAML files merged in order")
    c.add_argument("--geometry", help="preset or geometry file (default rubin_camera / rubin_m2)")
    c.add_argument("--campaign", metavar="CAMPAIGN.csv", help="a campaign CSV, or a points campaign (with --targets)")
    c.add_argument("--targets", metavar="T.json", help="a points campaign: the targets' nominal coordinates")
    c.add_argument("--strut-limit-um", type=float, default=None,
                   help="|strut length change| limit (µm); default: the geometry's own limits")
    _domain_args(c)
    _common(c)
    d = sub.add_parser("diff", help="largest difference of two tables over the domain (pose and struts)")
    d.add_argument("a", metavar="A.yaml")
    d.add_argument("b", metavar="B.yaml")
    d.add_argument("--base", action="append", default=[], metavar="_init.yaml",
                   help="a file merged under both A and B (repeatable)")
    d.add_argument("--geometry", help="preset or geometry file: also compare strut length changes")
    d.add_argument("--plot", metavar="FIG.png", help="offsets against elevation at several rotator angles")
    _domain_args(d)
    _common(d)
    p.set_defaults(func=run)
    return p


def campaign_args(p: argparse.ArgumentParser) -> None:
    """The options of ``simulate --campaign``."""
    p.add_argument("--campaign", action="store_true",
                   help="write a compensation campaign CSV (offsets per attitude) instead of measurements")
    p.add_argument("--truth", nargs="+", metavar="LUT.yaml",
                   help="--campaign: the true table (files merged in order); default: a gravity/thermal flexure model")
    p.add_argument("--hexapod", choices=("camera", "m2"), default="camera")
    p.add_argument("--elevations-deg", type=_values, default="0:90:5", metavar="A:B:STEP",
                   help="--campaign: elevations, START:STOP:STEP (inclusive) or V1,V2,… (default 0:90:5)")
    p.add_argument("--rotations-deg", type=_values, default="-90:90:10", metavar="A:B:STEP",
                   help="--campaign: rotator angles (default -90:90:10; write --rotations-deg=-90:90:10)")
    p.add_argument("--temperatures-degC", type=_values, default=None, metavar="A:B:STEP")


def run_campaign(args: argparse.Namespace) -> int:
    """``simulate --campaign``: pose noise ``--sigma-um``, ``--sigma-arcsec``."""

    from ..compensation._campaign import camera_flexure, simulate_campaign, write_campaign
    from ..compensation._yaml import load_table

    _check_outputs(args, out="--out")
    if args.points:
        return _simulate_points_campaign(args)
    truth = load_table(args.truth, args.hexapod) if args.truth else camera_flexure()
    c = simulate_campaign(seed_key(args.seed), truth, args.elevations_deg, args.rotations_deg,
                          args.temperatures_degC, sigma_um=args.sigma_um, sigma_arcsec=args.sigma_arcsec)
    what = f"table {' + '.join(args.truth)} ({args.hexapod})" if args.truth else "a flexure model"
    write_campaign(c, args.out, (f"stewart-jax simulate --campaign: truth {what}, σ {args.sigma_um} µm, "
                                 f"{args.sigma_arcsec}″, seed {args.seed}",))
    print(f"wrote a campaign of {len(c.elevation_deg)} attitudes to {args.out}", file=sys.stderr)
    return 0


def _simulate_points_campaign(args: argparse.Namespace) -> int:
    """``simulate --campaign --points``: the targets measured at every attitude, hexapod at zero."""

    from .._files import write_text_atomic
    from ..calibration._points_io import read_targets, write_targets
    from ..calibration._points_simulation import default_registration, default_targets
    from ..compensation._points import points_campaign_csv, simulate_points_campaign
    from ..compensation._yaml import load_table
    from ..mechanism._registry import load_mechanism
    from ._points import tracker_sigma

    if not args.truth:
        raise ValueError("simulate --campaign --points draws from a table: give it with --truth FILE.yaml")
    if args.targets is None:
        raise ValueError("--points needs --targets T.json (add --default-targets to write a default set there)")
    if args.default_targets:
        check_outputs(args, targets="--targets")
    mechanism = load_mechanism(_GEOMETRY[args.hexapod] if args.geometry == "nominal" else args.geometry)
    targets = default_targets(mechanism) if args.default_targets else read_targets(args.targets)
    range_um, across = tracker_sigma(args)
    data, att = simulate_points_campaign(seed_key(args.seed), load_table(args.truth, args.hexapod), mechanism,
                                         targets, default_registration(mechanism), args.elevations_deg,
                                         args.rotations_deg, args.temperatures_degC, range_um=range_um,
                                         across_um_per_m=across)
    if args.default_targets:
        write_targets(args.targets, targets)
    write_text_atomic(args.out, points_campaign_csv(data, targets, att))
    print(f"wrote a points campaign of {data.n_poses} attitudes ({len(data.points)} target points) to {args.out}",
          file=sys.stderr)
    return 0

"""Our own audit of bad and edge inputs: command-line probes, one or more per class of slip and
per surface, each run as a user runs it (a fresh ``stewart-jax`` process) and judged against the
answer it must give.

    python benchmarks/audit.py                 # every probe (about 5 minutes on 2 cores)
    python benchmarks/audit.py --only cabin    # the probes whose name contains "cabin"

Verdicts:

- **good**: the expected answer — a refusal (exit 2) whose message has the expected words, a
  warning with the words beside a finished run, or a right result;
- **unclear**: refused, but the message lacks the words (or a Python traceback shows);
- **silent**: a slip accepted with no word about it (exit 0 where a refusal or warning was due);
- **lost**: a file the user made changed without a backup named;
- **hang**: no answer within the probe's time limit.

The classes: unit slips in both directions (files, columns, fields, options), valid edges of the
contract, what a command may write over, options against the format, inputs against what they
describe (limits, sampling), argument errors before the work, scale. The library-level edges
(the optimiser's float32 inputs, fixed coordinates, targets at the start; a study's kill -9, two
processes, changed options) are probed in the test suite (``tests/test_optimiser_edges.py``,
``tests/test_checkpoint_safety.py``, ``tests/test_bad_inputs_round4.py``).

Results: ``benchmarks/results/audit.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import write_results  # noqa: E402

EXE = os.path.join(os.path.dirname(sys.executable), "stewart-jax")
V7 = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "tests", "data", "compensation_v7.yaml")


@dataclass
class Probe:
    """One probe: ``argv`` after ``stewart-jax`` (``{d}`` is the work folder), what it must do
    (``refuse``: exit 2 with ``words`` in stderr; ``warn``: exit 0 with ``words``; ``ok``: exit 0,
    and ``words`` in stderr where given), and files the user made that must survive (``keep``:
    path → text, unless a backup is named)."""

    name: str
    cls: str
    surface: str
    argv: list[str]
    expect: str
    words: tuple[str, ...] = ()
    keep: dict[str, str] = field(default_factory=dict)
    timeout_s: float = 300.0
    setup: tuple[tuple[str, str], ...] = ()


def _geometry_files(d: str) -> None:
    from stewart_jax.mechanism import preset
    from stewart_jax.mechanism._registry import mechanism_json

    def write(name, obj):
        with open(os.path.join(d, name), "w") as f:
            json.dump(obj, f)

    def scaled(obj, keys, factor):
        return {**obj, **{k: (np.asarray(obj[k]) * factor).tolist() for k in keys}}

    ups = json.loads(mechanism_json(preset("rubin_m2")))
    rus = json.loads(mechanism_json(preset("rotary_stewart")))
    pss = json.loads(mechanism_json(preset("nominal")))
    write("m2.json", ups)
    write("m2_metres.json", scaled(ups, ("base", "platform", "v0", "lengths0"), 1e-3))
    write("m2_um.json", scaled(ups, ("base", "platform", "v0", "lengths0"), 1e3))
    write("m2_jal_rad.json", {**ups, "joint_angle_limits": 0.3})
    write("rus_deg.json", {**rus, "crank_zero_rad": np.degrees(rus["crank_zero_rad"]).tolist()})
    write("rus_limits_rad.json", {**rus, "crank_limits_deg": [-1.5, 1.5]})
    pss_keys = [k for k, v in pss.items() if isinstance(v, list) and k not in ("mechanism",)]
    write("pss_metres.json", scaled(pss, [k for k in pss_keys if "rad" not in k and "deg" not in k], 1e-3))


def _record(path: str, pos_scale: float, rot_scale: float, rate_hz: float = 10.0, duration_s: float = 60.0):
    rng = np.random.default_rng(0)
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    swing = np.exp(-0.005 * 2 * np.pi * 0.15 * t) * np.cos(2 * np.pi * 0.15 * t)
    pos = np.outer(swing, [20.0, 10.0, 5.0]) + rng.standard_normal((t.size, 3))
    rot = np.outer(swing, [0.02, 0.01, 0.02]) + 0.01 * rng.standard_normal((t.size, 3))
    np.savetxt(path, np.column_stack([t, pos * pos_scale, rot * rot_scale]), delimiter=",",
               header="time,x,y,z,rx,ry,rz", comments="")


def _data_files(d: str) -> None:
    """Pose CSVs (rubin_m2, paper8 and 10⁴ random poses of the 6-PSS) and their unit slips; the
    cabin records."""
    subprocess.run([EXE, "simulate", "--geometry", "rubin_m2", "--plan", "plan120", "--out",
                    os.path.join(d, "m2.csv")], check=True, capture_output=True)
    subprocess.run([EXE, "simulate", "--points", "--targets", os.path.join(d, "T.json"), "--default-targets",
                    "--geometry", "rubin_m2", "--plan", "paper8", "--out", os.path.join(d, "pts.csv")],
                   check=True, capture_output=True)
    cols = np.genfromtxt(os.path.join(d, "m2.csv"), delimiter=",", names=True)
    names = list(cols.dtype.names)

    def write_scaled(name, which, factor):
        table = np.column_stack([cols[n] * (factor if n in which else 1.0) for n in names])
        np.savetxt(os.path.join(d, name), table, delimiter=",", header=",".join(names), comments="")

    write_scaled("m2_xyz_metres.csv", ("x", "y", "z"), 1e-3)
    write_scaled("m2_angles_rad.csv", ("rx", "ry", "rz"), np.pi / 180)
    write_scaled("m2_q_metres.csv", tuple(f"q{i}" for i in range(1, 7)), 1e-3)
    with open(os.path.join(d, "m2_text.csv"), "w") as f:
        lines = open(os.path.join(d, "m2.csv")).read().splitlines()
        lines[3] = lines[3].replace(lines[3].split(",")[1], "n/a", 1)
        f.write("\n".join(lines) + "\n")
    raw = json.load(open(os.path.join(d, "T.json")))
    with open(os.path.join(d, "T_metres.json"), "w") as f:
        json.dump({k: {n: (np.asarray(v) * 1e-3).tolist() for n, v in g.items()} for k, g in raw.items()}, f)
    lines = open(os.path.join(d, "pts.csv")).read().splitlines()
    with open(os.path.join(d, "pts_metres.csv"), "w") as f:
        f.write("\n".join([lines[0]] + [",".join(c[:8] + [repr(float(x) / 1000) for x in c[8:]])
                                         for c in (x.split(",") for x in lines[1:])]) + "\n")
    from scale import write_data

    write_data(os.path.join(d, "p10000.csv"), 10_000)
    _record(os.path.join(d, "rec_metres.csv"), 1e-3, 1.0)
    _record(os.path.join(d, "rec_radians.csv"), 1.0, np.pi / 180)
    _record(os.path.join(d, "rec_um.csv"), 1e3, 1.0)
    _record(os.path.join(d, "rec_1hz.csv"), 1.0, 1.0, rate_hz=1.0)
    _record(os.path.join(d, "rec_5s.csv"), 1.0, 1.0, duration_s=5.0)
    with open(os.path.join(d, "notes.txt"), "w") as f:
        f.write("my own notes\n")


def probes() -> list[Probe]:
    d = "{d}"
    return [
        # ---- unit slips: geometry files, both directions, every family
        Probe("geometry 6-UPS in metres, calibrate", "unit slip", "geometry file",
              ["calibrate", f"{d}/m2.csv", "--geometry", f"{d}/m2_metres.json", "--json", f"{d}/c1.json"],
              "warn", ("metres",)),
        Probe("geometry 6-UPS in µm, export", "unit slip", "geometry file",
              ["export", f"{d}/m2_um.json", "--out", f"{d}/e1.json"], "warn", ("µm",)),
        Probe("geometry joint_angle_limits in radians", "unit slip", "geometry file",
              ["export", f"{d}/m2_jal_rad.json", "--out", f"{d}/e2.json"], "warn", ("radians",)),
        Probe("geometry 6-RUS crank zeros in degrees", "unit slip", "geometry file",
              ["export", f"{d}/rus_deg.json", "--out", f"{d}/e3.json"], "warn", ("degrees",)),
        Probe("geometry 6-RUS crank limits in radians", "unit slip", "geometry file",
              ["export", f"{d}/rus_limits_rad.json", "--out", f"{d}/e4.json"], "refuse", ("not reachable",)),
        Probe("geometry 6-PSS in metres", "unit slip", "geometry file",
              ["export", f"{d}/pss_metres.json", "--out", f"{d}/e5.json"], "warn", ("metres",)),
        # ---- unit slips: data columns
        Probe("pose CSV positions in metres", "unit slip", "pose CSV",
              ["calibrate", f"{d}/m2_xyz_metres.csv", "--geometry", "rubin_m2", "--json", f"{d}/c2.json"],
              "warn", ("units",)),
        Probe("pose CSV angles in radians", "unit slip", "pose CSV",
              ["calibrate", f"{d}/m2_angles_rad.csv", "--geometry", "rubin_m2", "--json", f"{d}/c3.json"],
              "warn", ("units",)),
        Probe("pose CSV readings in metres", "unit slip", "pose CSV",
              ["calibrate", f"{d}/m2_q_metres.csv", "--geometry", "rubin_m2", "--json", f"{d}/c4.json"],
              "warn", ("units",)),
        Probe("pose CSV with a cell that is not a number", "bad file", "pose CSV",
              ["calibrate", f"{d}/m2_text.csv", "--geometry", "rubin_m2"], "refuse", ("line 4", "n/a")),
        Probe("targets file in metres", "unit slip", "targets file",
              ["calibrate", f"{d}/pts.csv", "--geometry", "rubin_m2", "--targets", f"{d}/T_metres.json"],
              "refuse", ("targets file's coordinates are in metres",)),
        Probe("points file in metres", "unit slip", "points file",
              ["calibrate", f"{d}/pts_metres.csv", "--geometry", "rubin_m2", "--targets", f"{d}/T.json"],
              "refuse", ("tracker file is in metres",)),
        Probe("cabin record in metres", "unit slip", "cabin record",
              ["diagnose", f"{d}/rec_metres.csv", "--geometry", "fast"], "refuse", ("metres",)),
        Probe("cabin record in radians", "unit slip", "cabin record",
              ["diagnose", f"{d}/rec_radians.csv", "--geometry", "fast"], "refuse", ("radians",)),
        Probe("cabin record in µm", "unit slip", "cabin record",
              ["diagnose", f"{d}/rec_um.csv", "--geometry", "fast"], "refuse", ("µm",)),
        # ---- unit slips: options
        Probe("pose noise σ given in mm to --sigma-um", "unit slip", "options",
              ["simulate", "--geometry", "rubin_m2", "--sigma-um", "-0.1", "--out", f"{d}/s1.csv"],
              "refuse", ("sigma",)),
        Probe("fast position in mm", "unit slip", "options",
              ["fast", "--position", "0,0,140000"], "refuse", ("m",)),
        Probe("compensation temperature in kelvin", "unit slip", "lut",
              ["lut", "apply", V7, "--elevation-deg", "45", "--rotation-deg", "0", "--temperature-degC", "293.15"],
              "refuse", ("kelvin",)),
        Probe("compensation elevation past the zenith", "against the domain", "lut",
              ["lut", "apply", V7, "--elevation-deg", "120", "--rotation-deg", "0"], "refuse", ("[0, 90]",)),
        Probe("compensation rotation of a full turn more", "valid edge", "lut",
              ["lut", "apply", V7, "--elevation-deg", "45", "--rotation-deg", "400"], "ok"),
        # ---- inputs against what they describe
        Probe("cabin record sampled below its modes", "against the physics", "cabin record",
              ["diagnose", f"{d}/rec_1hz.csv", "--geometry", "fast"], "refuse", ("Nyquist",)),
        Probe("cabin record shorter than two periods", "against the physics", "cabin record",
              ["diagnose", f"{d}/rec_5s.csv", "--geometry", "fast"], "refuse", ("too short",)),
        Probe("LinuxCNC limits beyond the struts' travel", "against the geometry", "export",
              ["export", "rubin_m2", "--format", "linuxcnc", "--stroke-limits-mm=-900,900", "--out", f"{d}/lc1"],
              "refuse", ("stroke",)),
        Probe("an option genhexkins ignores", "options against the format", "export",
              ["export", "rubin_m2", "--format", "genhexkins", "--name", "m2", "--out", f"{d}/g.hal"],
              "refuse", ("linuxcnc only",)),
        Probe("a points option on a pose file", "options against the data", "calibrate",
              ["calibrate", f"{d}/m2.csv", "--geometry", "rubin_m2", "--targets", f"{d}/T.json"],
              "refuse", ("points file", "without --targets")),
        Probe("a cabin option on pose data", "options against the data", "diagnose",
              ["diagnose", f"{d}/m2.csv", "--geometry", "rubin_m2", "--segments", "20"], "refuse", ("fast",)),
        # ---- what a command may write over
        Probe("export over a file the user made", "overwrite", "export",
              ["export", "rubin_m2", "--out", f"{d}/notes.txt"], "ok", ("kept it as",),
              keep={"notes.txt": "my own notes\n"}),
        Probe("simulate into a missing folder", "overwrite", "simulate",
              ["simulate", "--geometry", "rubin_m2", "--out", f"{d}/missing/s.csv"], "refuse", ("does not exist",)),
        Probe("LinuxCNC export into a missing folder", "overwrite", "export",
              ["export", "rubin_m2", "--format", "linuxcnc", "--out", f"{d}/missing/lc"], "refuse",
              ("does not exist",)),
        # ---- argument errors before the work
        Probe("a misspelt flag", "argument error", "command line", ["study", "--trails", "3"], "refuse",
              ("--trials",), timeout_s=20.0),
        Probe("a misspelt command", "argument error", "command line", ["calibarte", "x.csv"], "refuse",
              ("calibrate",), timeout_s=20.0),
        Probe("a missing data file", "argument error", "command line", ["calibrate", f"{d}/none.csv"], "refuse",
              ("none.csv",)),
        Probe("study of zero trials", "valid edge", "study", ["study", "--trials", "0"], "refuse", ("trials",)),
        Probe("study trial index past 2^32", "valid edge", "study",
              ["study", "--trials", "2", "--first-trial", str(2**32)], "refuse", ("2^32",)),
        # ---- valid edges that must work
        Probe("study of one trial", "valid edge", "study",
              ["study", "--trials", "1", "--methods", "lm-batched", "--json", f"{d}/st.json"], "ok"),
        Probe("calibrate data in the right units", "valid edge", "calibrate",
              ["calibrate", f"{d}/m2.csv", "--geometry", "rubin_m2", "--json", f"{d}/c5.json"], "ok"),
        # ---- scale
        Probe("calibrate 10⁴ poses", "scale", "calibrate",
              ["calibrate", f"{d}/p10000.csv", "--json", f"{d}/c10k.json"], "ok", ("assessment done",)),
        Probe("diagnose 10⁴ poses", "scale", "diagnose",
              ["diagnose", f"{d}/p10000.csv", "--json", f"{d}/d10k.json"], "ok", ("naming done",)),
    ]


def judge(p: Probe, d: str) -> dict:
    argv = [a.replace("{d}", d) for a in p.argv]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([EXE, *argv], capture_output=True, text=True, timeout=p.timeout_s, cwd=d)
        rc, err = proc.returncode, proc.stderr
    except subprocess.TimeoutExpired:
        rc, err = None, ""
    wall = time.perf_counter() - t0
    has_words = all(w in err for w in p.words)
    changed = [k for k, v in p.keep.items() if open(os.path.join(d, k)).read() != v]
    backed_up = "kept it as" in err
    if rc is None:
        verdict = "hang"
    elif changed and not backed_up:
        verdict = "lost"
    elif p.expect == "refuse":
        verdict = "good" if rc == 2 and has_words and "Traceback" not in err else ("silent" if rc == 0 else "unclear")
    elif p.expect == "warn":
        verdict = "good" if has_words and "Traceback" not in err else ("silent" if rc == 0 else "unclear")
    else:
        verdict = "good" if rc == 0 and has_words else "unclear"
    return {"name": p.name, "class": p.cls, "surface": p.surface, "argv": argv, "expect": p.expect,
            "words": list(p.words), "exit_status": rc, "wall_s": round(wall, 2), "verdict": verdict,
            "stderr_tail": err[-500:]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", default="", help="run the probes whose name contains this text")
    args = ap.parse_args()
    chosen = [p for p in probes() if args.only in p.name]
    rows = []
    with tempfile.TemporaryDirectory() as d:
        _geometry_files(d)
        _data_files(d)
        for p in chosen:
            rows.append(judge(p, d))
            r = rows[-1]
            print(f"{r['verdict']:8s} {r['wall_s']:6.1f} s  {p.surface}: {p.name}", flush=True)
    tally = {v: sum(r["verdict"] == v for r in rows) for v in ("good", "unclear", "silent", "lost", "hang")}
    md = [f"{len(rows)} probes: " + ", ".join(f"{v} {n}" for v, n in tally.items()), "",
          "| surface | class | probe | expected | exit | verdict | time (s) |", "|---|---|---|---|---|---|---|"]
    md += [f"| {r['surface']} | {r['class']} | {r['name']} | {r['expect']} {', '.join(r['words'])} | "
           f"{r['exit_status']} | {r['verdict']} | {r['wall_s']} |" for r in rows]
    write_results("audit" + ("_" + args.only.replace(" ", "_") if args.only else ""),
                  {"tally": tally, "probes": rows}, "\n".join(md))


if __name__ == "__main__":
    main()

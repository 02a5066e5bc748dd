"""Start the exported configuration on a real LinuxCNC (headless) and move the hexapod.

For each geometry: ``stewart-jax export GEOMETRY --format linuxcnc --out DIR`` writes the INI, HAL
and tool table; the only edit is ``[DISPLAY]DISPLAY``, which names the headless display
``benchmarks/_linuxcnc_ui.py`` instead of ``axis``. ``linuxcnc DIR/hexapod.ini`` then starts
LinuxCNC (task, I/O, motion with ``genhexkins``, the exported HAL file). The display takes the
machine out of E-stop, turns it on, homes every joint and reads the world position that
genhexkins' forward kinematics gives at the joint homes (it must be ``[TRAJ]HOME``, the pivot
pose). It then commands poses of the library, shifted as the how-to says (``G0 X Y Z = d + v0``,
``A B C`` = the angles in degrees), and reads back the joint positions (strut lengths, mm), which
are compared with ``lengths0 +`` the library's inverse kinematics; and one pose commanded without
the shift (``X Y Z = d``), which LinuxCNC must refuse.

Needs LinuxCNC (Debian bookworm: ``apt-get install linuxcnc-uspace``) and its ``linuxcnc`` Python
module for ``/usr/bin/python3``. As root, LinuxCNC's ``rtapi_app`` runs with a fallback user
(``RTAPI_UID``, the user ``nobody``).

    python benchmarks/linuxcnc_start.py [--geometries rubin_camera,rubin_m2,fast_stewart,calibrated]
"""

from __future__ import annotations

import argparse
import configparser
import json
import os
import pwd
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
UI = os.path.join(HERE, "_linuxcnc_ui.py")
SYSTEM_PYTHON = "/usr/bin/python3"
STROKE_LIMITS_MM = {"rubin_m2": (-10.0, 10.0), "fast_stewart": (-50.0, 50.0)}
"""For the presets without stroke limits of their own (as the how-to gives them)."""
MOVE_FRACTIONS = np.array([
    [0.25, -0.15, 0.2, 0.2, -0.25, 0.3],
    [-0.2, 0.25, -0.15, -0.3, 0.2, -0.2],
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
])
"""The commanded library poses, as fractions of the mechanism's travel half-widths."""


def unavailable() -> str | None:
    """Why LinuxCNC cannot be started here (``None``: it can)."""
    if shutil.which("linuxcnc") is None:
        return "LinuxCNC is not installed (Debian: apt-get install linuxcnc-uspace)"
    if not os.path.exists(SYSTEM_PYTHON):
        return f"{SYSTEM_PYTHON}, the Python of LinuxCNC's module, is missing"
    probe = subprocess.run([SYSTEM_PYTHON, "-c", "import linuxcnc"], capture_output=True)
    if probe.returncode != 0:
        return "LinuxCNC's Python module does not import in /usr/bin/python3"
    return None


def gcode(pose_lib: np.ndarray, v0: np.ndarray, *, shifted: bool = True) -> str:
    """``G0`` to a library pose (mm, rad): ``X Y Z = d + v0`` (or ``d`` unshifted), degrees."""
    xyz = pose_lib[:3] + (v0 if shifted else 0.0)
    abc = np.degrees(pose_lib[3:])
    return "G0 " + " ".join(f"{ax}{x:.12f}" for ax, x in zip("XYZABC", np.concatenate([xyz, abc]), strict=True))


def run_session(geometry_file: str, workdir: str, moves: list[str], *, stroke_limits=None,
                timeout_s: float = 150.0) -> dict:
    """Export ``geometry_file``'s configuration into ``workdir``, start LinuxCNC on it with the
    headless display, run ``moves`` (MDI lines) and return what the display saw (its JSON) with
    the seconds the session took."""
    from stewart_jax._cli import main as cli_main

    cfg = os.path.join(workdir, "config")
    argv = ["export", geometry_file, "--format", "linuxcnc", "--out", cfg]
    if stroke_limits is not None:
        argv.append(f"--stroke-limits-mm={stroke_limits[0]},{stroke_limits[1]}")
    if cli_main(argv) != 0:
        raise RuntimeError(f"export failed: {argv}")
    ini_path = os.path.join(cfg, "hexapod.ini")
    with open(ini_path) as f:
        text = f.read()
    with open(ini_path, "w") as f:
        f.write(text.replace("DISPLAY = axis", f"DISPLAY = {UI}", 1))
    out_json = os.path.join(workdir, "ui.json")
    env = dict(os.environ, STEWART_JAX_LINUXCNC_MOVES=json.dumps(moves), STEWART_JAX_LINUXCNC_OUT=out_json,
               STEWART_JAX_LINUXCNC_TIMEOUT=str(int(timeout_s - 30)))
    fifo = None
    if os.geteuid() == 0:  # rtapi_app refuses to run as root without a fallback user, who needs the fifo's folder
        fifo = tempfile.mkdtemp(prefix="stewart-jax-rtapi-")
        os.chmod(fifo, 0o1777)
        env.update(RTAPI_UID=str(pwd.getpwnam("nobody").pw_uid), RTAPI_FIFO_PATH=os.path.join(fifo, "fifo"))
    try:
        return _start(ini_path, cfg, env, out_json, timeout_s)
    finally:
        if fifo is not None:
            shutil.rmtree(fifo, ignore_errors=True)


def _start(ini_path: str, cfg: str, env: dict, out_json: str, timeout_s: float) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.Popen(["linuxcnc", ini_path], cwd=cfg, env=env, stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        log, _ = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        log, _ = proc.communicate()
        raise RuntimeError(f"LinuxCNC did not finish in {timeout_s} s: {log[-2000:]}") from None
    seconds = time.perf_counter() - t0
    if not os.path.exists(out_json):
        raise RuntimeError(f"LinuxCNC exited ({proc.returncode}) before its display wrote a result: {log[-2000:]}")
    with open(out_json) as f:
        seen = json.load(f)
    ini = configparser.ConfigParser(comment_prefixes=("#",), inline_comment_prefixes=None)
    ini.read(ini_path)
    seen.update(seconds=seconds, returncode=proc.returncode,
                home=[float(x) for x in ini["TRAJ"]["HOME"].split()],
                joint_home_mm=[float(ini[f"JOINT_{n}"]["HOME"]) for n in range(6)])
    return seen


def check_session(mechanism, seen: dict, poses_lib: np.ndarray) -> dict:
    """Compare a session with the library: world position at the joint homes against
    ``[TRAJ]HOME``; per shifted move, joints against ``lengths0 + IK`` and the world position
    against the command; the unshifted move refused."""
    v0 = np.asarray(mechanism.v0)
    lengths0 = np.asarray(mechanism.lengths0)
    out = {
        "ok": bool(seen.get("ok")),
        "failure": seen.get("failure"),
        "seconds": seen["seconds"],
        "homed_position_minus_home": (np.asarray(seen["homed_position"]) - seen["home"]).tolist()
        if "homed_position" in seen else None,
        "homed_joints_minus_joint_home_mm": (np.asarray(seen["homed_joints_mm"]) - seen["joint_home_mm"]).tolist()
        if "homed_joints_mm" in seen else None,
        "moves": [],
    }
    for pose, move in zip(poses_lib, seen.get("moves", [])[: len(poses_lib)], strict=False):
        ik = lengths0 + np.asarray(mechanism.solve_inverse_kinematics(pose).readings)
        commanded = np.concatenate([pose[:3] + v0, np.degrees(pose[3:])])
        reached = np.asarray(move["position"][:6])
        out["moves"].append({
            "mdi": move["mdi"],
            "max_abs_joint_minus_library_ik_mm": float(np.max(np.abs(np.asarray(move["joints_mm"]) - ik))),
            "max_abs_position_minus_command_mm": float(np.max(np.abs(reached[:3] - commanded[:3]))),
            "max_abs_angle_minus_command_deg": float(np.max(np.abs(reached[3:] - commanded[3:]))),
            "errors": move["errors"],
        })
    if len(seen.get("moves", [])) > len(poses_lib):
        unshifted = seen["moves"][len(poses_lib)]
        out["unshifted"] = {"mdi": unshifted["mdi"], "errors": unshifted["errors"],
                            "joints_moved_mm": float(np.max(np.abs(np.asarray(unshifted["joints_mm"])
                                                                   - np.asarray(seen["moves"][-2]["joints_mm"]))))}
    return out


def session_for(name: str, workdir: str, *, n_moves: int = len(MOVE_FRACTIONS), unshifted: bool = True) -> dict:
    """Export and start one geometry (a preset, or ``calibrated``: rubin_camera with every
    parameter moved by N(0, 0.5 mm)) and check it (:func:`check_session`)."""
    import stewart_jax as sj
    from stewart_jax.mechanism import preset

    if name == "calibrated":
        m = preset("rubin_camera")
        m = m.with_params(m.params + np.random.default_rng(5).normal(0, 0.5, m.n_params))
    else:
        m = preset(name)
    geometry = os.path.join(workdir, f"{name}.json")
    sj.save_mechanism(m, geometry)
    half = np.asarray(m.travel_half_widths)
    poses = MOVE_FRACTIONS[:n_moves] * half
    moves = [gcode(p, np.asarray(m.v0)) for p in poses]
    if unshifted:
        moves.append(gcode(poses[0], np.asarray(m.v0), shifted=False))
    seen = run_session(geometry, workdir, moves, stroke_limits=STROKE_LIMITS_MM.get(name))
    return {"geometry": name, "v0_mm": np.asarray(m.v0).tolist(), **check_session(m, seen, poses)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--geometries", default="rubin_camera,rubin_m2,fast_stewart,calibrated")
    args = parser.parse_args()
    why = unavailable()
    if why:
        sys.exit(f"cannot run: {why}")
    from _common import write_results

    version = subprocess.run(["dpkg-query", "-W", "-f=${Version}", "linuxcnc-uspace"], capture_output=True,
                             text=True).stdout or "unknown"
    rows = []
    for name in args.geometries.split(","):
        with tempfile.TemporaryDirectory(prefix="linuxcnc-") as work:
            rows.append(session_for(name, work))
        print(json.dumps(rows[-1]), flush=True)
    lines = [
        f"LinuxCNC {version} (Debian's `linuxcnc-uspace`, POSIX non-realtime), started headless on the exported "
        "configuration (the display replaced by `benchmarks/_linuxcnc_ui.py`; nothing else edited).",
        "",
        "| geometry | started, homed | world at joint homes − HOME (max) | moves | joints − lengths0 − IK (max, mm) "
        "| position − command (max, mm / °) | unshifted command | seconds |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        hp = r["homed_position_minus_home"]
        mv = r["moves"]
        refused = r.get("unshifted", {}).get("errors") or []
        lines.append(
            f"| {r['geometry']} | {'yes' if r['ok'] else 'NO: ' + str(r['failure'])} | "
            f"{max(abs(x) for x in hp):.2g} | {len(mv)} | "
            f"{max((m['max_abs_joint_minus_library_ik_mm'] for m in mv), default=float('nan')):.2g} | "
            f"{max((m['max_abs_position_minus_command_mm'] for m in mv), default=float('nan')):.2g} / "
            f"{max((m['max_abs_angle_minus_command_deg'] for m in mv), default=float('nan')):.2g} | "
            f"{'refused: ' + refused[0] if refused else 'NOT refused'} | {r['seconds']:.0f} |"
        )
    write_results("linuxcnc_start", {"linuxcnc_version": version, "sessions": rows}, "\n".join(lines))


if __name__ == "__main__":
    main()

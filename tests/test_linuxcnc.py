"""The LinuxCNC configuration: genhexkins' forward kinematics starts from the exported ``[TRAJ]HOME``.

Two forward solvers read the exported files: LinuxCNC's own ``genhexkins.c`` compiled with gcc, when
``STEWART_JAX_LINUXCNC_SRC`` names a LinuxCNC source tree (its licence keeps it out of this
repository), and always an independent NumPy transcription of its Newton–Raphson iteration
(its ``InverseJacobian`` rows ``[u_i, (R·a_i) × u_i]``, the update ``pose -= J⁻¹·(l(pose) − joints)``
on roll/pitch/yaw in radians, convergence when every strut is within 1e-9 mm, failure (−2) when the
summed strut error exceeds 500 mm, (−5) after 120 iterations).
"""

import configparser
import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from stewart_jax._cli import main as cli_main
from stewart_jax.mechanism import preset, to_linuxcnc

PRESETS = {"rubin_camera": None, "rubin_m2": (-10.0, 10.0), "fast_stewart": (-50.0, 50.0), "calibrated": None}


def _mechanism(name):
    if name != "calibrated":
        return preset(name)
    m = preset("rubin_camera")  # a calibrated geometry: every parameter moved by N(0, 0.5 mm)
    return m.with_params(m.params + np.random.default_rng(5).normal(0, 0.5, m.n_params))


def read_config(ini_text, hal_text):
    ini = configparser.ConfigParser(inline_comment_prefixes=None, comment_prefixes=("#",))
    ini.read_string(ini_text)
    pins = {}
    for line in hal_text.splitlines():
        hit = re.fullmatch(r"setp (genhexkins\.\S+) (\S+)", line)
        if hit:
            pins[hit.group(1)] = float(hit.group(2))
    base = np.array([[pins[f"genhexkins.base.{n}.{a}"] for a in "xyz"] for n in range(6)])
    platform = np.array([[pins[f"genhexkins.platform.{n}.{a}"] for a in "xyz"] for n in range(6)])
    return ini, pins, base, platform


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def genhexkins_forward(base, platform, joints, start, *, criterion=1e-9, max_error=500.0, limit=120):
    """(rc, pose X Y Z A B C in mm and degrees, iterations), as genhexKinematicsForward."""
    if np.any(np.asarray(joints) <= 0):
        return -1, np.asarray(start, float), 0
    trans = np.array(start[:3], float)
    rpy = np.radians(np.array(start[3:], float))
    conv_err, iteration = 1.0, 0
    while True:
        if abs(conv_err) > max_error:
            return -2, np.concatenate([trans, np.degrees(rpy)]), iteration
        iteration += 1
        if iteration > limit:
            return -5, np.concatenate([trans, np.degrees(rpy)]), iteration
        rot = rpy_matrix(*rpy)
        ra = platform @ rot.T
        strut = trans + ra - base
        length = np.linalg.norm(strut, axis=1)
        unit = strut / length[:, None]
        diff = length - joints
        inv_jac = np.hstack([unit, np.cross(ra, unit)])
        try:
            delta = np.linalg.solve(inv_jac, diff)
        except np.linalg.LinAlgError:  # genhexkins' Gauss–Jordan divides by zero: NaN, compared as false
            delta = np.full(6, np.nan)
        trans -= delta[:3]
        rpy -= delta[3:]
        conv_err = np.sum(np.abs(diff))
        if not np.any(np.abs(diff) > criterion):
            return 0, np.concatenate([trans, np.degrees(rpy)]), iteration


@pytest.fixture(scope="module")
def configs():
    out = {}
    for name, limits in PRESETS.items():
        m = _mechanism(name)
        out[name] = (m, to_linuxcnc(m, stroke_limits_mm=limits))
    return out


@pytest.mark.parametrize("name", list(PRESETS))
def test_forward_kinematics_starts_at_the_exported_home(configs, name):
    m, config = configs[name]
    ini, pins, base, platform = read_config(config.ini, config.hal)
    assert ini["KINS"]["KINEMATICS"] == "genhexkins" and ini["KINS"]["JOINTS"] == "6"
    assert ini["TRAJ"]["LINEAR_UNITS"] == "mm" and ini["TRAJ"]["ANGULAR_UNITS"] == "degree"
    home = np.array(ini["TRAJ"]["HOME"].split(), float)
    np.testing.assert_array_equal(home, np.concatenate([np.asarray(m.v0), np.zeros(3)]))
    joint_home = np.array([float(ini[f"JOINT_{n}"]["HOME"]) for n in range(6)])
    # the library's strut lengths at its zero pose are the joint homes
    lib = np.asarray(m.lengths0 + m.solve_inverse_kinematics(np.zeros(6)).readings)
    np.testing.assert_allclose(joint_home, lib, rtol=0, atol=1e-9)
    rc, pose, iterations = genhexkins_forward(base, platform, joint_home, home)
    assert rc == 0 and iterations <= 3
    np.testing.assert_allclose(pose, home, rtol=0, atol=1e-9)
    # LinuxCNC's default HOME of zero is hundreds of mm away: the iteration fails there
    rc, pose, _ = genhexkins_forward(base, platform, joint_home, np.zeros(6))
    assert rc != 0 or not np.allclose(pose, home, atol=1.0)
    # and a pose in the travel is found from HOME, in the controller's shifted coordinates
    pose_lib = np.array([0.3, -0.2, 0.25, 1e-4, -2e-4, 3e-4]) * np.asarray(m.travel_half_widths) / np.array(
        [1, 1, 1, 1e-3, 1e-3, 1e-3]
    )
    joints = np.asarray(m.lengths0 + m.solve_inverse_kinematics(pose_lib).readings)
    rc, pose, _ = genhexkins_forward(base, platform, joints, home)
    assert rc == 0
    np.testing.assert_allclose(pose[:3], pose_lib[:3] + np.asarray(m.v0), rtol=0, atol=1e-8)
    np.testing.assert_allclose(pose[3:], np.degrees(pose_lib[3:]), rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", list(PRESETS))
def test_limits_offsets_and_units(configs, name):
    m, config = configs[name]
    ini, pins, _, _ = read_config(config.ini, config.hal)
    limits = np.asarray(m.stroke_limits if m.stroke_limits is not None else [PRESETS[name]] * 6)
    for n in range(6):
        joint = ini[f"JOINT_{n}"]
        assert float(joint["MIN_LIMIT"]) == pytest.approx(float(m.lengths0[n]) + limits[n, 0], abs=1e-12)
        assert float(joint["MAX_LIMIT"]) == pytest.approx(float(m.lengths0[n]) + limits[n, 1], abs=1e-12)
        assert float(joint["MIN_LIMIT"]) < float(joint["HOME"]) < float(joint["MAX_LIMIT"])
    # an axis limit, shifted back to the library's pose, puts one strut at its stroke limit
    for k, axis in enumerate("XYZABC"):
        if "search's cap" in config.ini.split(f"[AXIS_{axis}]")[1].split("\n")[1]:
            continue
        for bound in ("MIN_LIMIT", "MAX_LIMIT"):
            pose = np.zeros(6)
            value = float(ini[f"AXIS_{axis}"][bound])
            pose[k] = value - float(m.v0[k]) if k < 3 else np.radians(value)
            readings = np.asarray(m.solve_inverse_kinematics(pose).readings)
            gap = np.min(np.concatenate([readings - limits[:, 0], limits[:, 1] - readings]))
            assert abs(gap) < 1e-6, (axis, bound, gap)
    for pin in ("tool-offset", "spindle-offset", "screw-lead"):
        assert pins[f"genhexkins.{pin}"] == 0.0
    assert "motion.tooloffset" not in "\n".join(x for x in config.hal.splitlines() if not x.startswith("#"))
    assert ini["HAL"]["HALFILE"] == "hexapod.hal"


@pytest.mark.parametrize("name", list(PRESETS))
def test_the_unshifted_command_is_stated(configs, name):
    """The INI states how far an unshifted command (X Y Z = the library's d) is from the pivot
    pose: |v0| and the largest strut-length change, recomputed here from the HAL's joints."""
    m, config = configs[name]
    ini, _, base, platform = read_config(config.ini, config.hal)
    home = np.array(ini["TRAJ"]["HOME"].split(), float)
    unshifted = np.linalg.norm(platform - base, axis=1)  # X Y Z = 0: the library's zero pose sent as is
    change = np.max(np.abs(unshifted - np.linalg.norm(platform + home[:3] - base, axis=1)))
    stated = re.search(r"moves the platform \|v0\| = (\S+) mm\n"
                       r"# from it and changes a strut's length by up to (\S+) mm", config.ini)
    assert stated is not None
    assert float(stated.group(1)) == pytest.approx(np.linalg.norm(home[:3]), rel=1e-6)
    assert float(stated.group(2)) == pytest.approx(change, rel=1e-6)
    # the figures a user reads in the how-to (mm, rounded)
    published = {"rubin_camera": 1879, "rubin_m2": 366, "fast_stewart": 760}
    if name in published:
        assert round(change) == published[name]
    assert change > 10 * np.max(np.asarray(config.joint_limits_mm)[:, 1] - np.asarray(config.joint_home_mm))


def test_refusals():
    with pytest.raises(ValueError, match="stroke_limits"):
        to_linuxcnc(preset("rubin_m2"))
    with pytest.raises(TypeError, match="struts"):
        to_linuxcnc(preset("nominal"))


def _strut_condition(mech) -> float:
    """Condition number of the strut Jacobian at the zero pose by central differences of the
    strut lengths (rotations scaled by the platform radius): independent of the export's check."""
    import jax.numpy as jnp

    h = 1e-6
    q = lambda p: np.asarray(mech.solve_inverse_kinematics(jnp.asarray(p)).readings)  # noqa: E731
    jac = np.stack([(q(h * e) - q(-h * e)) / (2 * h) for e in np.eye(6)], axis=1)
    jac[:, 3:] /= np.max(np.linalg.norm(np.asarray(mech.platform), axis=1))
    s = np.linalg.svd(jac, compute_uv=False)
    return s[0] / s[-1]


def test_a_near_singular_geometry_is_refused_before_any_file():
    """Struts all but parallel (every base joint under its platform joint) hold neither sideways
    motion nor a turn about z: the export refuses, naming the condition number and a direction;
    the same platform on base joints spread out and turned 25° (struts with a tangential lean, as
    every real hexapod's) passes, as every preset does."""
    from stewart_jax.mechanism import UPSMechanism
    from stewart_jax.mechanism._genhexkins import SINGULAR_CONDITION, to_genhexkins

    m = preset("rubin_m2")
    base, platform = np.asarray(m.base), np.asarray(m.platform)
    for name in ("rubin_camera", "rubin_m2", "fast_stewart"):
        assert _strut_condition(preset(name)) < 10.0
    for spread, turn_deg, refused in ((1.0001, 0.0, True), (1.2, 25.0, False)):
        c, s_ = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
        b = platform @ np.array([[c, s_, 0.0], [-s_, c, 0.0], [0.0, 0.0, 1.0]]) * np.array([spread, spread, 1.0])
        b[:, 2] = base[:, 2]
        mech = UPSMechanism(b, platform, m.v0, np.linalg.norm(platform + np.asarray(m.v0) - b, axis=1),
                            stroke_limits=(-10.0, 10.0))
        assert (_strut_condition(mech) > SINGULAR_CONDITION) == refused
        if refused:
            named = r"singular at its zero pose.*condition number.*[+-]\d\.\d\d·(x|y|rz)\b"
            for export in (to_linuxcnc, to_genhexkins):
                with pytest.raises(ValueError, match=named):
                    export(mech)
        else:
            assert to_linuxcnc(mech).ini


def test_cli_writes_both_files(tmp_path, capsys):
    out = tmp_path / "cfg"
    assert cli_main(["export", "rubin_m2", "--format", "linuxcnc", "--out", str(out)]) == 2
    assert "stroke_limits" in capsys.readouterr().err and not out.exists()
    assert cli_main(["export", "rubin_m2", "--format", "linuxcnc", "--out", str(out),
                     "--stroke-limits-mm=-10,10"]) == 0
    ini, _, base, _ = read_config((out / "hexapod.ini").read_text(), (out / "hexapod.hal").read_text())
    np.testing.assert_array_equal(base, np.asarray(preset("rubin_m2").base))


# ---- LinuxCNC's own genhexkins.c, when its source is at hand ------------------------------------

SHIM_HAL = r"""
#ifndef SHIM_HAL_H
#define SHIM_HAL_H
#include <stdlib.h>
#include <stdarg.h>
typedef double rtapi_real;
typedef struct { double v; } hal_real_t;
typedef struct { unsigned v; } hal_uint_t;
typedef struct { int v; } hal_bool_t;
enum { HAL_IN = 16, HAL_OUT = 32 };
#define hal_get_real(p) ((p).v)
#define hal_set_real(p, x) ((p).v = (x))
#define hal_get_ui32(p) ((p).v)
#define hal_set_ui32(p, x) ((p).v = (x))
#define hal_set_bool(p, x) ((p).v = (x))
void *hal_malloc(long size);
int hal_pin_new_real(int comp_id, int dir, hal_real_t *p, double init, const char *fmt, ...);
int hal_pin_new_ui32(int comp_id, int dir, hal_uint_t *p, unsigned init, const char *fmt, ...);
int hal_pin_new_bool(int comp_id, int dir, hal_bool_t *p, int init, const char *fmt, ...);
#endif
"""

HARNESS = r"""
#include <stdio.h>
#include <string.h>
#include "hal.h"
#include "switchkins.h"
static struct { char name[64]; double *real; unsigned *ui; } pins[256];
static int npins;
void *hal_malloc(long size) { return calloc(1, size); }
static void reg(double *r, unsigned *u, const char *fmt, va_list ap) {
  vsnprintf(pins[npins].name, 64, fmt, ap); pins[npins].real = r; pins[npins].ui = u; npins++; }
int hal_pin_new_real(int c, int d, hal_real_t *p, double init, const char *fmt, ...) {
  va_list ap; va_start(ap, fmt); p->v = init; reg(&p->v, 0, fmt, ap); va_end(ap); return 0; }
int hal_pin_new_ui32(int c, int d, hal_uint_t *p, unsigned init, const char *fmt, ...) {
  va_list ap; va_start(ap, fmt); p->v = init; reg(0, &p->v, fmt, ap); va_end(ap); return 0; }
int hal_pin_new_bool(int c, int d, hal_bool_t *p, int init, const char *fmt, ...) { p->v = init; return 0; }
#define KARGS const double *j, EmcPose *p, const KINEMATICS_FORWARD_FLAGS *f, KINEMATICS_INVERSE_FLAGS *i
#define IARGS const EmcPose *p, double *j, const KINEMATICS_INVERSE_FLAGS *i, KINEMATICS_FORWARD_FLAGS *f
int identityKinematicsSetup(const int c, const char *s, kparms *k) { return 0; }
int identityKinematicsForward(KARGS) { return 0; }
int identityKinematicsInverse(IARGS) { return 0; }
int userkKinematicsSetup(const int c, const char *s, kparms *k) { return 0; }
int userkKinematicsForward(KARGS) { return 0; }
int userkKinematicsInverse(IARGS) { return 0; }
int main(void) {
  kparms kp; KS s0, s1, s2; KF f0, f1, f2; KI i0, i1, i2; char word[64]; double v;
  memset(&kp, 0, sizeof kp);
  switchkinsSetup(&kp, &s0, &s1, &s2, &f0, &f1, &f2, &i0, &i1, &i2);
  if (s0(0, "xyzabc", &kp)) return 3;
  while (scanf("%63s", word) == 1) {
    if (strcmp(word, "fwd") == 0) {
      double j[6]; EmcPose p; KINEMATICS_FORWARD_FLAGS ff = 0; KINEMATICS_INVERSE_FLAGS fi = 0; int rc, n;
      memset(&p, 0, sizeof p);
      for (n = 0; n < 6; n++) if (scanf("%lf", &j[n]) != 1) return 4;
      if (scanf("%lf %lf %lf %lf %lf %lf", &p.tran.x, &p.tran.y, &p.tran.z, &p.a, &p.b, &p.c) != 6) return 4;
      rc = f0(j, &p, &ff, &fi);
      printf("%d %.17g %.17g %.17g %.17g %.17g %.17g\n", rc, p.tran.x, p.tran.y, p.tran.z, p.a, p.b, p.c);
    } else {
      int n, found = 0;
      if (scanf("%lf", &v) != 1) return 4;
      for (n = 0; n < npins; n++) if (strcmp(pins[n].name, word) == 0) {
        if (pins[n].real) *pins[n].real = v; else *pins[n].ui = (unsigned)v; found = 1; }
      if (!found) { fprintf(stderr, "unknown pin %s\n", word); return 5; }
    }
  }
  return 0;
}
"""

SOURCES = ("src/emc/kinematics/genhexkins.c", "src/libposemath/_posemath.c", "src/libposemath/emcpose.c")
INCLUDES = ("src/emc/kinematics", "src/emc/nml_intf", "src/libposemath")


@pytest.fixture(scope="module")
def genhexkins_c(tmp_path_factory):
    src = os.environ.get("STEWART_JAX_LINUXCNC_SRC")
    if not src:
        pytest.skip("set STEWART_JAX_LINUXCNC_SRC to a LinuxCNC source tree to run its genhexkins.c")
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed")
    work = tmp_path_factory.mktemp("genhexkins")
    shim = work / "shim"
    shim.mkdir()
    (shim / "hal.h").write_text(SHIM_HAL)
    (shim / "rtapi.h").write_text(
        "#include <stdio.h>\n#define RTAPI_MSG_ERR 1\n#define rtapi_print_msg(l, ...) fprintf(stderr, __VA_ARGS__)\n"
    )
    (shim / "rtapi_math.h").write_text("#include <math.h>\n#include <stddef.h>\n")
    (shim / "rtapi_string.h").write_text("#include <string.h>\n")
    (shim / "rtapi_bool.h").write_text("#include <stdbool.h>\n")
    (shim / "emcmotcfg.h").write_text("")
    (work / "harness.c").write_text(HARNESS)
    exe = work / "genhexkins"
    cmd = ["gcc", "-O1", "-std=gnu99", "-w", f"-I{shim}", *(f"-I{os.path.join(src, d)}" for d in INCLUDES),
           "-o", str(exe), str(work / "harness.c"), *(os.path.join(src, s) for s in SOURCES), "-lm"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


@pytest.mark.parametrize("name", list(PRESETS))
def test_linuxcnc_genhexkins_converges_from_the_exported_home(configs, genhexkins_c, name):
    m, config = configs[name]
    ini, pins, base, platform = read_config(config.ini, config.hal)
    home = np.array(ini["TRAJ"]["HOME"].split(), float)
    joint_home = [float(ini[f"JOINT_{n}"]["HOME"]) for n in range(6)]
    setp = "".join(f"{k} {v!r}\n" for k, v in pins.items())
    query = " ".join(repr(float(x)) for x in (*joint_home, *home))
    out = subprocess.run([str(genhexkins_c)], input=f"{setp}fwd {query}\nfwd {' '.join(map(repr, joint_home))} "
                         "0 0 0 0 0 0\n", capture_output=True, text=True, check=True).stdout.split("\n")
    from_home = np.array(out[0].split(), float)
    assert from_home[0] == 0
    np.testing.assert_allclose(from_home[1:], home, rtol=0, atol=1e-9)
    from_zero = np.array(out[1].split(), float)  # from LinuxCNC's default HOME of zero it fails
    assert from_zero[0] != 0 or not np.allclose(from_zero[1:], home, atol=1.0)


# ---- a real LinuxCNC, when it is installed --------------------------------------------------------


def test_a_real_linuxcnc_starts_the_exported_configuration(tmp_path):
    """``linuxcnc hexapod.ini`` on the exported files (headless display): out of E-stop, homed,
    the world position at the joint homes is ``[TRAJ]HOME``, a shifted command reaches the
    library's pose (joints recomputed here in NumPy from the HAL's joints), and the unshifted
    one is refused. About 20 s; skipped where LinuxCNC is not installed."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import linuxcnc_start as lc

    why = lc.unavailable()
    if why:
        pytest.skip(why)
    m = preset("rubin_camera")
    geometry = tmp_path / "camera.json"
    from stewart_jax import save_mechanism

    save_mechanism(m, geometry)
    pose = lc.MOVE_FRACTIONS[0] * np.asarray(m.travel_half_widths)
    seen = lc.run_session(str(geometry), str(tmp_path), [lc.gcode(pose, np.asarray(m.v0)),
                                                           lc.gcode(pose, np.asarray(m.v0), shifted=False)])
    assert seen["ok"], seen.get("failure")
    cfg = tmp_path / "config"
    _, _, base, platform = read_config((cfg / "hexapod.ini").read_text(), (cfg / "hexapod.hal").read_text())
    np.testing.assert_allclose(seen["homed_position"], seen["home"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(seen["homed_joints_mm"], seen["joint_home_mm"], rtol=0, atol=1e-9)
    shifted, unshifted = seen["moves"]
    xyz = pose[:3] + np.asarray(m.v0)
    joints = np.linalg.norm(platform @ rpy_matrix(*pose[3:]).T + xyz - base, axis=1)
    assert not shifted["errors"]
    np.testing.assert_allclose(shifted["joints_mm"], joints, rtol=0, atol=1e-9)
    np.testing.assert_allclose(shifted["position"][:3], xyz, rtol=0, atol=1e-9)
    np.testing.assert_allclose(shifted["position"][3:], np.degrees(pose[3:]), rtol=0, atol=1e-9)
    assert any("limit" in e for e in unshifted["errors"])
    np.testing.assert_array_equal(unshifted["joints_mm"], shifted["joints_mm"])  # refused: nothing moved

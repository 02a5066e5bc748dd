"""Batched IK / FK throughput on this machine's CPU (float64), against NumPy.

Run from the repository root:

    .venv/bin/python benchmarks/kinematics.py            # full (about 1–2 minutes)
    .venv/bin/python benchmarks/kinematics.py --quick    # small N, seconds

Writes ``benchmarks/results/kinematics.json`` and ``benchmarks/results/kinematics.md``
(``--out DIR`` to change; ``--no-write`` to only print).

Method: every timed function is compiled ahead of time (``jit(...).lower(...).compile()``,
reported as "compile s"), called once more as a warm-up, then timed ``--repeats`` times with
``time.perf_counter`` around a call ending in ``block_until_ready``; the table gives the best
(minimum) time, the JSON also the median and the process CPU time of the best run. Inputs
live on the device before timing (host→device transfer excluded). Other programs running on
the 2 cores inflate wall times: the JSON records the load average and the CPU time the rest
of the machine used during each row ("background cores"), so a noisy run can be recognised.

Before any timing the NumPy reference, the public JAX path and the fast paths are checked to
agree to 1e-9 mm on the same poses (asserted).

The host is split into ``--cpu-devices`` XLA CPU devices (default 2, set before JAX
initialises) so that the sharded rows can put one shard on each core; unsharded rows run on
device 0 as usual.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import shlex
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small N (seconds)")
    ap.add_argument("--repeats", type=int, default=None, help="timed calls per row (default 7, quick 3)")
    ap.add_argument("--cpu-devices", type=int, default=2, help="XLA host devices (default 2)")
    ap.add_argument("--out", default=str(REPO / "benchmarks" / "results"), help="output folder")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--tag", default="", help="write kinematics-TAG.{json,md} instead")
    ap.add_argument("--seed", type=int, default=0)
    return ap.parse_args(argv)


ARGS = _parse_args() if __name__ == "__main__" else _parse_args([])

import jax  # noqa: E402

jax.config.update("jax_num_cpu_devices", ARGS.cpu_devices)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from jax.sharding import (  # noqa: E402
    Mesh,
    NamedSharding,
    PartitionSpec as P,  # noqa: E402
)

sys.path.insert(0, str(REPO))
import stewart_jax as sj  # noqa: E402
import stewart_jax.mechanism as kb  # noqa: E402

# The layout ablation and the FK step/chunk sweep below time internal variants of the fast paths;
# they are the one place a benchmark reaches private functions.
from stewart_jax.mechanism._batched import (  # noqa: E402
    _fk_newton_jit,
    _ik_rows,
    _rotation_rows,
    _sincos_exact,
    _sincos_poly,
)

# --------------------------------------------------------------------------------------------
# NumPy references (vectorised over poses; the same equations as the library)
# --------------------------------------------------------------------------------------------


def numpy_rotation(angles):
    """(N, 3) → (N, 3, 3), T = Rz(ψ)·Ry(θ)·Rx(φ)."""
    cf, sf = np.cos(angles[:, 0]), np.sin(angles[:, 0])
    ct, st = np.cos(angles[:, 1]), np.sin(angles[:, 1])
    cp, sp = np.cos(angles[:, 2]), np.sin(angles[:, 2])
    rot = np.empty((len(angles), 3, 3))
    rot[:, 0, 0] = cp * ct
    rot[:, 0, 1] = cp * st * sf - sp * cf
    rot[:, 0, 2] = cp * st * cf + sp * sf
    rot[:, 1, 0] = sp * ct
    rot[:, 1, 1] = sp * st * sf + cp * cf
    rot[:, 1, 2] = sp * st * cf - cp * sf
    rot[:, 2, 0] = -st
    rot[:, 2, 1] = ct * sf
    rot[:, 2, 2] = ct * cf
    return rot


def numpy_ik(upper, lower, v0, poses):
    """Eq. 4, cancellation-free form, for poses (N, 6) → (readings (N, 6), margin (N, 6))."""
    rot = numpy_rotation(poses[:, 3:])
    w = rot @ upper.T  # (N, 3, 6): T·Ac_i
    delta = w - upper.T + poses[:, :3, None]  # (N, 3, 6)
    e = (upper + v0 - lower).T  # (3, 6)
    growth = delta * (2.0 * e + delta)
    margin = e[2] ** 2 - growth[:, 0] - growth[:, 1]
    root = np.sqrt(np.maximum(margin, 0.0))
    lz = e[2] + delta[:, 2]
    denom = lz + root
    ok = denom > 0
    readings = np.where(ok, growth.sum(axis=1) / np.where(ok, denom, 1.0), lz - root)
    return readings, margin


def numpy_ik_jacobian(upper, lower, v0, poses):
    """Readings (N, 6) and the analytic Jacobian ∂q/∂P (N, 6, 6) (see stewart_jax/mechanism/_batched.py)."""
    rot = numpy_rotation(poses[:, 3:])
    w = rot @ upper.T  # (N, 3, 6)
    delta = w - upper.T + poses[:, :3, None]
    e = (upper + v0 - lower).T
    growth = delta * (2.0 * e + delta)
    margin = e[2] ** 2 - growth[:, 0] - growth[:, 1]
    h = np.sqrt(np.maximum(margin, 0.0))
    ell = e + delta
    readings = growth.sum(axis=1) / (ell[:, 2] + h)
    ax, ay = ell[:, 0] / h, ell[:, 1] / h  # (N, 6)
    dphi = -upper[:, 2] * rot[:, :, 1, None] + upper[:, 1] * rot[:, :, 2, None]  # (N, 3, 6)
    cp, sp = np.cos(poses[:, 5])[:, None], np.sin(poses[:, 5])[:, None]
    dth = np.stack([cp * w[:, 2], sp * w[:, 2], -sp * w[:, 1] - cp * w[:, 0]], axis=1)
    jac = np.empty((len(poses), 6, 6))
    jac[:, :, 0], jac[:, :, 1], jac[:, :, 2] = ax, ay, 1.0
    for k, d in ((3, dphi), (4, dth)):
        jac[:, :, k] = d[:, 2] + ax * d[:, 0] + ay * d[:, 1]
    jac[:, :, 5] = -ax * w[:, 1] + ay * w[:, 0]
    return readings, margin, jac


def numpy_fk(upper, lower, v0, readings, steps=4):
    """Fixed-step Newton, batched ``np.linalg.solve``; returns poses and max residual."""
    p = np.zeros_like(readings)
    for _ in range(steps):
        q, _, jac = numpy_ik_jacobian(upper, lower, v0, p)
        p = p - np.linalg.solve(jac, (q - readings)[..., None])[..., 0]
    q, margin = numpy_ik(upper, lower, v0, p)
    return p, np.max(np.abs(q - readings), axis=1)


# --------------------------------------------------------------------------------------------
# Measurement helpers
# --------------------------------------------------------------------------------------------


def _cpu_jiffies():
    """(busy jiffies of the whole machine, jiffies of this process) from /proc."""
    try:
        with open("/proc/stat") as f:
            vals = [int(v) for v in f.readline().split()[1:]]
        busy = sum(vals) - vals[3] - (vals[4] if len(vals) > 4 else 0)
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        mine = int(fields[11]) + int(fields[12])
        return busy, mine
    except OSError:
        return None


def _block(x):
    return jax.block_until_ready(x)


def measure(fn, args, repeats):
    """Warm-up once, then ``repeats`` timed calls. Returns wall/CPU/page-fault statistics."""
    _block(fn(*args))
    calls = []
    j0, t0 = _cpu_jiffies(), time.perf_counter()
    for _ in range(repeats):
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        t = time.perf_counter()
        _block(fn(*args))
        wall = time.perf_counter() - t
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        calls.append((wall, r1.ru_utime - r0.ru_utime, r1.ru_stime - r0.ru_stime,
                      r1.ru_minflt - r0.ru_minflt))  # fmt: skip
    j1, t1 = _cpu_jiffies(), time.perf_counter()
    background = None
    if j0 and j1:
        hz = os.sysconf("SC_CLK_TCK")
        background = max(0.0, ((j1[0] - j0[0]) - (j1[1] - j0[1])) / hz / (t1 - t0))
    walls = [c[0] for c in calls]
    best = calls[int(np.argmin(walls))]
    return {
        "run_s": best[0],
        "run_median_s": float(np.median(walls)),
        "user_s_at_best": best[1],
        "sys_s_at_best": best[2],
        "page_faults_at_best": best[3],
        "background_cores": background,
        "repeats": repeats,
    }


def compile_jit(fn, args, **jit_kw):
    """AOT-compile ``jax.jit(fn)`` for ``args``; returns (compiled, seconds).

    Caches are cleared first so that an identical computation compiled earlier (e.g. by the
    correctness checks) does not make the compile time look like zero."""
    jax.clear_caches()
    t = time.perf_counter()
    compiled = jax.jit(fn, **jit_kw).lower(*args).compile()
    return compiled, time.perf_counter() - t


def random_poses(rng, n):
    """Uniform in the ±1 mm, ±1° travel; (N, 6) [dx, dy, dz, φ, θ, ψ] (mm, rad)."""
    return np.concatenate(
        [rng.uniform(-1.0, 1.0, (n, 3)), np.deg2rad(rng.uniform(-1.0, 1.0, (n, 3)))], axis=1
    )


# --------------------------------------------------------------------------------------------
# Benchmarks
# --------------------------------------------------------------------------------------------


def ik_rows(geometry, n, repeats, rng, mesh, sweep):
    upper, lower, v0 = (np.asarray(a) for a in (geometry.upper, geometry.lower, geometry.v0))
    poses = random_poses(rng, n)
    poses_j = jnp.asarray(poses)
    poses_soa = jnp.asarray(np.ascontiguousarray(poses.T))
    rows = []

    def add(method, note, compile_s, stats, n=n):
        legs = 6 * n
        rows.append(
            {"kind": "IK", "method": method, "note": note, "N": n, "compile_s": compile_s,
             "rate": legs / stats["run_s"], "rate_median": legs / stats["run_median_s"],
             "unit": "leg-IK/s", **stats}
        )  # fmt: skip

    # --- correctness first (asserted) ---
    q_np, m_np = numpy_ik(upper, lower, v0, poses)
    pub = jax.jit(lambda g, p: g.solve_inverse_kinematics(p))(geometry, poses_j)
    fast = jax.jit(kb.inverse_kinematics_soa)(geometry, poses_soa)
    checks = {
        "numpy_vs_public_mm": float(np.max(np.abs(q_np - np.asarray(pub.readings)))),
        "fast_vs_public_mm": float(np.max(np.abs(np.asarray(fast.readings).T - np.asarray(pub.readings)))),
        "fast_vs_numpy_mm": float(np.max(np.abs(np.asarray(fast.readings).T - q_np))),
    }
    if mesh is not None:
        shd = jax.jit(kb.inverse_kinematics_sharded)(geometry, poses_soa)
        checks["sharded_vs_public_mm"] = float(
            np.max(np.abs(np.asarray(shd.readings).T - np.asarray(pub.readings)))
        )
        assert np.array_equal(np.asarray(shd.reachable), np.asarray(pub.reachable))
    for k, v in checks.items():
        assert v < 1e-9, f"IK disagreement {k} = {v}"
    assert np.array_equal(np.asarray(fast.reachable), np.asarray(pub.reachable))
    del pub, fast

    # --- NumPy ---
    add("NumPy vectorised (N, 6)", "np.sin/np.cos once per pose, broadcasting over 6 legs", 0.0,
        measure(lambda: numpy_ik(upper, lower, v0, poses), (), repeats))

    # --- public path ---
    f, c = compile_jit(lambda g, p: g.solve_inverse_kinematics(p), (geometry, poses_j))
    add("jit(solve_inverse_kinematics) (N, 6)", "public path; readings, margin, reachable", c,
        measure(f, (geometry, poses_j), repeats))
    f, c = compile_jit(lambda g, p: g.solve_inverse_kinematics(p).readings, (geometry, poses_j))
    add("jit(solve_inverse_kinematics).readings (N, 6)", "public path, readings only", c,
        measure(f, (geometry, poses_j), repeats))

    # --- ablations ---
    def soa_exact(g, p):
        return jnp.stack(_ik_rows(g, p, _sincos_exact)[0])

    f, c = compile_jit(soa_exact, (geometry, poses_soa))
    add("SoA (6, N) with jnp.sin/cos, readings", "ablation: layout change only", c,
        measure(f, (geometry, poses_soa), repeats))
    f, c = compile_jit(lambda g, p: kb.inverse_kinematics_soa(g, p.T).readings.T, (geometry, poses_j))
    add("inverse_kinematics_soa(g, poses.T).readings.T (N, 6)",
        "ablation: polynomial sin/cos, public layout (transposes fused)", c,
        measure(f, (geometry, poses_j), repeats))

    # --- fast path, one device ---
    f, c = compile_jit(kb.inverse_kinematics_soa, (geometry, poses_soa))
    add("jit(inverse_kinematics_soa) (6, N)", "readings, margin, reachable", c,
        measure(f, (geometry, poses_soa), repeats))

    def readings_only(g, p):
        return kb.inverse_kinematics_soa(g, p).readings

    f, c = compile_jit(readings_only, (geometry, poses_soa))
    add("jit(inverse_kinematics_soa).readings (6, N)", "readings only", c,
        measure(f, (geometry, poses_soa), repeats))

    # --- split across the host devices ---
    def sharded_readings(g, p):
        return kb.inverse_kinematics_sharded(g, p).readings

    if mesh is not None:
        sharded = jax.device_put(poses_soa, NamedSharding(mesh, P(None, "batch")))
        f, c = compile_jit(kb.inverse_kinematics_sharded, (geometry, sharded))
        add(f"jit(inverse_kinematics_sharded) × {mesh.size} devices", "readings, margin, reachable",
            c, measure(f, (geometry, sharded), repeats))
        f, c = compile_jit(sharded_readings, (geometry, sharded))
        add(f"jit(inverse_kinematics_sharded).readings × {mesh.size} devices", "readings only", c,
            measure(f, (geometry, sharded), repeats))

    # --- batch-size sweep of the fastest variants (output-buffer page faults, caches) ---
    for m in sweep:
        p_m = jnp.asarray(np.ascontiguousarray(random_poses(rng, m).T))
        f, c = compile_jit(readings_only, (geometry, p_m))
        add("jit(inverse_kinematics_soa).readings (6, N)", "size sweep", c,
            measure(f, (geometry, p_m), repeats), n=m)
        if mesh is not None:
            p_m = jax.device_put(p_m, NamedSharding(mesh, P(None, "batch")))
            f, c = compile_jit(sharded_readings, (geometry, p_m))
            add(f"jit(inverse_kinematics_sharded).readings × {mesh.size} devices", "size sweep", c,
                measure(f, (geometry, p_m), repeats), n=m)
    return rows, checks


def fk_rows(geometry, n, repeats, rng):
    upper, lower, v0 = (np.asarray(a) for a in (geometry.upper, geometry.lower, geometry.v0))
    poses = random_poses(rng, n)
    readings = np.asarray(geometry.solve_inverse_kinematics(poses).readings)
    readings_j = jnp.asarray(readings)
    rows = []

    def add(method, note, compile_s, stats):
        rows.append(
            {"kind": "FK", "method": method, "note": note, "N": n, "compile_s": compile_s,
             "rate": n / stats["run_s"], "rate_median": n / stats["run_median_s"],
             "unit": "poses/s", **stats}
        )  # fmt: skip

    p_np, res_np = numpy_fk(upper, lower, v0, readings)
    pub = sj.forward_kinematics(geometry, readings_j)
    new = kb.forward_kinematics_newton(geometry, readings_j)
    checks = {
        "numpy_fk_pose_err": float(np.max(np.abs(p_np - poses))),
        "public_fk_pose_err": float(np.max(np.abs(np.asarray(pub.poses) - poses))),
        "newton_fk_pose_err": float(np.max(np.abs(np.asarray(new.poses) - poses))),
        "newton_vs_public": float(np.max(np.abs(np.asarray(new.poses) - np.asarray(pub.poses)))),
        "public_converged": float(np.mean(np.asarray(pub.converged))),
        "newton_converged": float(np.mean(np.asarray(new.converged))),
        "public_steps_max": int(np.max(np.asarray(pub.steps))),
    }
    for k in ("numpy_fk_pose_err", "public_fk_pose_err", "newton_fk_pose_err", "newton_vs_public"):
        assert checks[k] < 1e-9, f"FK disagreement {k} = {checks[k]}"
    assert checks["public_converged"] == 1.0 and checks["newton_converged"] == 1.0

    add("NumPy Newton ×4, np.linalg.solve", "analytic Jacobian, batched LAPACK", 0.0,
        measure(lambda: numpy_fk(upper, lower, v0, readings), (), repeats))

    # public: compile time = first call minus a steady-state call
    jax.clear_caches()
    t = time.perf_counter()
    _block(sj.forward_kinematics(geometry, readings_j))
    first = time.perf_counter() - t
    stats = measure(lambda: sj.forward_kinematics(geometry, readings_j), (), repeats)
    add("forward_kinematics (public)", "while_loop, jacfwd, line search; input checks", 
        max(0.0, first - stats["run_median_s"]), stats)

    for steps, chunk in ((4, 1024), (3, 1024), (4, 4096), (4, 16384)):
        if chunk > n and (steps, chunk) != (4, 1024):
            continue
        fn = _fk_newton_jit
        jax.clear_caches()
        t = time.perf_counter()
        compiled = jax.jit(fn, static_argnums=(3, 4, 5)).lower(
            geometry, readings_j, jnp.zeros(6), steps, 1e-11, chunk).compile()
        c = time.perf_counter() - t
        out = compiled(geometry, readings_j, jnp.zeros(6))
        assert bool(np.all(np.asarray(out.converged))), (steps, chunk)
        add(f"forward_kinematics_newton steps={steps} chunk={chunk}",
            "fixed Newton, analytic J, J0-preconditioned elimination, lax.map chunks", c,
            measure(compiled, (geometry, readings_j, jnp.zeros(6)), repeats))
    return rows, checks


def ceilings(n, repeats):
    """Arithmetic and memory microbenchmarks on the same (N,) float64 vectors."""
    x = jnp.asarray(np.random.default_rng(1).uniform(-0.02, 0.02, n))
    out = {}

    def chain(v, k=64):
        for _ in range(k):
            v = v * 1.0000001 + 1e-9
        return v

    def chain4(v, k=64):  # four independent chains: hides FMA latency
        a, b, c, d = v, v + 1, v + 2, v + 3
        for _ in range(k // 4):
            a, b, c, d = (a * 1.0000001 + 1e-9, b * 1.0000001 + 1e-9,
                          c * 1.0000001 + 1e-9, d * 1.0000001 + 1e-9)  # fmt: skip
        return a + b + c + d

    for name, fn, ops in (
        ("copy (x + 1)", lambda v: v + 1.0, 1),
        ("sin", jnp.sin, 1),
        ("sqrt", jnp.sqrt, 1),
        ("divide", lambda v: 1.0 / (v + 3.0), 1),
        ("64 mul+add chain", chain, 128),
        ("4 × 16 mul+add chains", chain4, 128 + 3),
    ):
        f, _ = compile_jit(fn, (x,))
        st = measure(f, (x,), repeats)
        out[name] = {"elements_per_s": n / st["run_s"], "flops_per_s": ops * n / st["run_s"],
                     "run_s": st["run_s"], "page_faults": st["page_faults_at_best"]}  # fmt: skip
    t = time.perf_counter()
    for _ in range(repeats):
        np.add(np.asarray(x), 1.0)
    out["numpy copy (x + 1)"] = {"elements_per_s": n * repeats / (time.perf_counter() - t)}
    return out


def count_ops():
    """Elementwise operations per leg of the fast path (from its jaxpr, one pose)."""
    g = sj.nominal_geometry()
    p = jnp.zeros((6, 1))

    def n_eqns(fn):
        jaxpr = jax.make_jaxpr(fn)(p)
        return sum(1 for e in jaxpr.eqns if e.outvars and e.outvars[0].aval.shape == (1,))

    rot = n_eqns(lambda p: _rotation_rows(p[3:6], _sincos_poly))
    full = n_eqns(lambda p: _ik_rows(g, p, _sincos_poly)[0])
    per_leg = (full - rot) / 6
    return {"rotation_ops_per_pose": rot, "leg_ops": per_leg,
            "ops_per_leg_if_rotation_shared": per_leg + rot / 6,
            "ops_per_leg_if_rotation_recomputed": per_leg + rot}  # fmt: skip


# --------------------------------------------------------------------------------------------


def machine_info():
    import jaxlib

    info = {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "numpy": np.__version__,
        "jax_devices": [str(d) for d in jax.devices()],
        "XLA_FLAGS": os.environ.get("XLA_FLAGS", ""),
        "MALLOC_env": {k: v for k, v in os.environ.items() if k.startswith("MALLOC_")},
    }
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    info["cpu_model"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return info


def fmt_rate(x):
    return f"{x:.3g}"


def table(rows, numpy_rate):
    head = ("| kind | method | N | compile s | run s (best) | rate (best) | rate (median) "
            "| × NumPy | CPU s user+sys | page faults | note |")  # fmt: skip
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        ratio = r["rate"] / numpy_rate[r["kind"]]
        lines.append(
            f"| {r['kind']} | {r['method']} | {r['N']} | {r['compile_s']:.2f} | {r['run_s']:.4g} "
            f"| {fmt_rate(r['rate'])} {r['unit']} | {fmt_rate(r['rate_median'])} | {ratio:.2f} "
            f"| {r['user_s_at_best']:.3f}+{r['sys_s_at_best']:.3f} | {r['page_faults_at_best']} "
            f"| {r['note']} |"
        )
    return "\n".join(lines)


def main():
    args = ARGS
    repeats = args.repeats or (3 if args.quick else 7)
    n_ik = 2**16 if args.quick else 2**20
    sweep = () if args.quick else (2**16, 2**19)
    n_fk = 2**12 if args.quick else 2**16
    rng = np.random.default_rng(args.seed)
    geometry = sj.nominal_geometry()
    devices = jax.devices()
    mesh = Mesh(np.array(devices), ("batch",)) if len(devices) > 1 else None

    started = datetime.datetime.now(datetime.UTC)
    load_before = os.getloadavg()
    t_all = time.perf_counter()
    rows_ik, checks_ik = ik_rows(geometry, n_ik, repeats, rng, mesh, sweep)
    rows_fk, checks_fk = fk_rows(geometry, n_fk, repeats, rng)
    ceil = ceilings(n_ik, repeats)
    ops = count_ops()
    elapsed = time.perf_counter() - t_all
    rows = rows_ik + rows_fk
    numpy_rate = {r["kind"]: r["rate"] for r in rows if r["method"].startswith("NumPy")}
    for r in rows:
        r["ratio_vs_numpy"] = r["rate"] / numpy_rate[r["kind"]]

    best_ik = max((r for r in rows_ik), key=lambda r: r["rate"])
    fma = ceil["4 × 16 mul+add chains"]["flops_per_s"]
    analysis = {
        "best_ik_method": best_ik["method"],
        "best_ik_rate": best_ik["rate"],
        "ik_target": 1e8,
        "ik_target_met": best_ik["rate"] >= 1e8,
        "fk_target": 1e5,
        "best_fk_rate": max(r["rate"] for r in rows_fk),
        "elementwise_ops_per_s_single_kernel": fma,
        **ops,
        "ik_ceiling_if_rotation_recomputed": fma / ops["ops_per_leg_if_rotation_recomputed"],
        "ik_ceiling_if_rotation_shared": fma / ops["ops_per_leg_if_rotation_shared"],
    }

    env = [f"{k}={shlex.quote(v)}" for k, v in sorted(os.environ.items())
           if k.startswith("MALLOC_") or k == "XLA_FLAGS"]  # fmt: skip
    cmd = " ".join([*env, shlex.join(getattr(sys, "orig_argv", [sys.executable, *sys.argv]))])
    result = {
        "benchmark": "stewart_jax kinematics throughput",
        "command": cmd,
        "date_utc": started.isoformat(timespec="seconds"),
        "mode": "quick" if args.quick else "full",
        "seconds_total": elapsed,
        "load_average_before": load_before,
        "load_average_after": os.getloadavg(),
        "machine": machine_info(),
        "dtype": "float64",
        "poses": f"uniform in ±1 mm, ±1° (seed {args.seed}), nominal geometry",
        "checks": {**checks_ik, **checks_fk},
        "rows": rows,
        "microbenchmarks": ceil,
        "analysis": analysis,
    }

    md = [
        "# Kinematics throughput",
        "",
        f"- command: `{cmd}`",
        f"- date (UTC): {result['date_utc']}; total {elapsed:.1f} s; load average before "
        f"{load_before[0]:.2f}, after {result['load_average_after'][0]:.2f}",
        f"- machine: {result['machine'].get('cpu_model', result['machine']['processor'])}, "
        f"{result['machine']['cpu_count']} CPUs, {result['machine']['platform']}",
        f"- versions: python {result['machine']['python']}, jax {jax.__version__}, "
        f"jaxlib {result['machine']['jaxlib']}, numpy {np.__version__}; float64; "
        f"{len(devices)} XLA CPU device(s)",
        f"- checks (max |Δ| mm): {json.dumps({k: float(f'{v:.3g}') for k, v in result['checks'].items()})}",
        "",
        table(rows, numpy_rate),
        "",
        "Microbenchmarks (same N, float64, one jitted kernel each):",
        "",
        "| kernel | elements/s | flop/s |",
        "|---|---|---|",
        *[
            f"| {k} | {v['elements_per_s']:.3g} | {v.get('flops_per_s', float('nan')):.3g} |"
            for k, v in ceil.items()
        ],
        "",
        f"Fast-path operation count: {ops['rotation_ops_per_pose']} elementwise ops for the "
        f"rotation (polynomial sin/cos) per pose, {ops['leg_ops']:.0f} per leg. XLA evaluates "
        f"each output element independently, so the rotation is redone for every leg: "
        f"{ops['ops_per_leg_if_rotation_recomputed']:.0f} ops per leg; at the measured "
        f"{fma:.3g} op/s of independent mul+add chains that bounds one kernel at "
        f"{analysis['ik_ceiling_if_rotation_recomputed']:.3g} leg-IK/s "
        f"({analysis['ik_ceiling_if_rotation_shared']:.3g} if the rotation were shared).",
        "",
        "Notes. *rate (best)* is the minimum wall time of the repeats, *rate (median)* the "
        "median; *CPU s* is this process's user+system time during the best call (user ≈ wall "
        "means one busy core) and *page faults* its minor page faults. Outputs larger than "
        "glibc's mmap threshold (32 MiB at most, e.g. (6, 2²⁰) float64 = 48 MiB) are "
        "fresh mappings on every call, so the kernel zero-fills and faults them in (system "
        "time); setting `MALLOC_MMAP_THRESHOLD_` and `MALLOC_TRIM_THRESHOLD_` (e.g. 2³⁰ and "
        "2³¹) before starting Python makes those buffers reusable. Other programs on the "
        "machine show up in the JSON as `background_cores`.",
        "",
        f"Best IK: {best_ik['method']} (N={best_ik['N']}) at {best_ik['rate']:.3g} leg-IK/s "
        f"(target 1e8: {'met' if analysis['ik_target_met'] else 'NOT met'}); "
        f"best FK {analysis['best_fk_rate']:.3g} poses/s (target 1e5).",
        "",
    ]
    text = "\n".join(md)
    print(text)
    if not args.no_write:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        stem = "kinematics" + (f"-{args.tag}" if args.tag else "")
        (out / f"{stem}.json").write_text(json.dumps(result, indent=2) + "\n")
        (out / f"{stem}.md").write_text(text)
        print(f"wrote {out / (stem + '.json')} and {out / (stem + '.md')}")


if __name__ == "__main__":
    main()

"""The 24 noiseless BBOB functions (COCO's ``bbob`` suite) in JAX, float64, one point at a time.

Hansen, Finck, Ros & Auger (2009), "Real-parameter black-box optimization benchmarking 2009:
noiseless functions definitions" (INRIA RR-6829), and the COCO platform's C implementation
(Hansen, Auger, Ros, Mersmann, Tušar & Brockhoff 2021, "COCO: a platform for comparing continuous
optimizers in a black-box setting"), whose legacy instance generator is ported here exactly:
the Park–Miller generator with Bays–Durham shuffle (``_unif``), Box–Muller normals (``_gauss``),
Gram–Schmidt rotations (``_rotation``), ``x_opt`` and ``f_opt`` per (function, instance).

Every (function, instance) of one dimension is a :class:`Instance` of arrays with the same
shapes, so a stack of them is one pytree: :func:`evaluate` (``lax.switch`` on the function
number) under ``vmap`` evaluates any mixture of problems in one call. The transformations
follow COCO's composition order (the last transformation wrapped in C is the first applied
to ``x``); the names are those of the C files (``T_osz`` = ``transform_vars_oscillate``, ...).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

N_FUNCTIONS = 24
N_PEAKS = 101  # Gallagher's 101 peaks (f21); f22's 21 are padded with zero-height peaks.

FUNCTION_NAMES = {
    1: "sphere", 2: "ellipsoid (separable)", 3: "Rastrigin (separable)", 4: "Büche-Rastrigin",
    5: "linear slope", 6: "attractive sector", 7: "step ellipsoid", 8: "Rosenbrock",
    9: "Rosenbrock (rotated)", 10: "ellipsoid", 11: "discus", 12: "bent cigar", 13: "sharp ridge",
    14: "different powers", 15: "Rastrigin", 16: "Weierstrass", 17: "Schaffer F7",
    18: "Schaffer F7 (ill-conditioned)", 19: "Griewank-Rosenbrock", 20: "Schwefel",
    21: "Gallagher 101 peaks", 22: "Gallagher 21 peaks", 23: "Katsuura", 24: "Lunacek bi-Rastrigin",
}
# COCO's function groups (cocopp's ECDF per group).
GROUPS = {
    "separable": (1, 2, 3, 4, 5), "moderate": (6, 7, 8, 9), "ill-conditioned": (10, 11, 12, 13, 14),
    "multi-modal": (15, 16, 17, 18, 19), "weakly structured": (20, 21, 22, 23, 24),
}


class Instance(NamedTuple):
    """One BBOB problem (function ``fid``, one instance) in ``dim`` variables.

    ``fid`` () int; ``xopt`` (dim,) the legacy ``x_opt`` (its sign pattern for f5, f20, f24);
    ``fopt`` (); ``r1``, ``r2`` (dim, dim) the rotations ``R`` (seed + 10^6) and ``Q`` (seed);
    ``m`` (dim, dim) the function's affine matrix (``R Λ Q`` and variants); ``aux`` (dim,) a
    per-function vector (f20's sign flips); ``x_local`` (dim, 101), ``scales`` (101, dim),
    ``peaks`` (101,) Gallagher's peaks (zero elsewhere).
    """

    fid: np.ndarray
    xopt: np.ndarray
    fopt: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    m: np.ndarray
    aux: np.ndarray
    x_local: np.ndarray
    scales: np.ndarray
    peaks: np.ndarray


# ---------------------------------------------------------------------------------------------
# The legacy instance generator (suite_bbob_legacy_code.c), in exact integer/float arithmetic.


def _unif(n: int, seed: int) -> np.ndarray:
    """``bbob2009_unif``: ``n`` uniform numbers in (0, 1)."""
    seed = abs(int(seed))
    seed = max(seed, 1)
    akt = seed
    table = [0] * 32
    for i in range(39, -1, -1):
        tmp = math.floor(akt / 127773.0)
        akt = 16807 * (akt - tmp * 127773) - 2836 * tmp
        if akt < 0:
            akt += 2147483647
        if i < 32:
            table[i] = akt
    aktrand = table[0]
    out = np.empty(n)
    for i in range(n):
        tmp = math.floor(akt / 127773.0)
        akt = 16807 * (akt - tmp * 127773) - 2836 * tmp
        if akt < 0:
            akt += 2147483647
        tmp = math.floor(aktrand / 67108865.0)
        aktrand = table[tmp]
        table[tmp] = akt
        out[i] = aktrand / 2.147483647e9
        if out[i] == 0.0:
            out[i] = 1e-99
    return out


def _gauss(n: int, seed: int) -> np.ndarray:
    """``bbob2009_gauss``: Box–Muller on ``2 n`` uniforms."""
    u = _unif(2 * n, seed)
    g = np.sqrt(-2.0 * np.log(u[:n])) * np.cos(2.0 * math.pi * u[n:])
    g[g == 0.0] = 1e-99
    return g


def _rotation(seed: int, dim: int) -> np.ndarray:
    """``bbob2009_compute_rotation``: Gram–Schmidt on a column-major Gaussian matrix."""
    b = _gauss(dim * dim, seed).reshape(dim, dim).T.copy()  # B[i][j] = g[j*dim + i]
    for i in range(dim):
        for j in range(i):
            b[:, i] -= np.dot(b[:, i], b[:, j]) * b[:, j]
        b[:, i] /= math.sqrt(np.dot(b[:, i], b[:, i]))
    return b


def _xopt(seed: int, dim: int) -> np.ndarray:
    x = 8.0 * np.floor(1e4 * _unif(dim, seed)) / 1e4 - 4.0
    x[x == 0.0] = -1e-5
    return x


def _fopt(function: int, instance: int) -> float:
    rseed = {4: 3, 18: 17}.get(function, function) + 10000 * instance
    g1 = _gauss(1, rseed)[0]
    g2 = _gauss(1, rseed + 1)[0]
    return float(min(1000.0, max(-1000.0, math.floor(100.0 * 100.0 * g1 / g2 + 0.5) / 100.0)))


def _lambda_rotation(r1: np.ndarray, r2: np.ndarray, base: float) -> np.ndarray:
    """``R diag(base^(k/(D-1))) Q`` summed in COCO's order."""
    dim = r1.shape[0]
    scale = np.array([base ** (k / (dim - 1.0)) for k in range(dim)])
    m = np.zeros((dim, dim))
    for k in range(dim):
        m += np.outer(r1[:, k] * scale[k], r2[k, :])
    return m


def make_instance(function: int, instance: int, dim: int) -> Instance:
    """The arrays of BBOB problem ``function`` (1..24), ``instance`` in ``dim`` (>= 2) variables."""
    if not 1 <= function <= N_FUNCTIONS:
        raise ValueError(f"function must be 1..24, got {function}")
    if dim < 2:
        raise ValueError(f"dimension must be at least 2, got {dim}")
    rseed = {4: 3, 18: 17}.get(function, function) + 10000 * instance
    xopt = _xopt(rseed + 1000000 if function == 12 else rseed, dim)
    fopt = _fopt(function, instance)
    eye = np.eye(dim)
    r1, r2, m = eye, eye, eye
    aux = np.zeros(dim)
    x_local = np.zeros((dim, N_PEAKS))
    scales = np.zeros((N_PEAKS, dim))
    peaks = np.zeros(N_PEAKS)
    if function in (6, 7, 10, 11, 12, 13, 14, 15, 16, 17, 18, 23, 24):
        r1 = _rotation(rseed + 1000000, dim)
    if function in (6, 7, 13, 15, 16, 17, 18, 23, 24):
        r2 = _rotation(rseed, dim)
    if function == 4:
        xopt[::2] = np.abs(xopt[::2])
    elif function in (6, 13, 15, 16, 23):
        base = {6: math.sqrt(10.0), 13: math.sqrt(10), 15: math.sqrt(10), 16: 1.0 / math.sqrt(100.0),
                23: math.sqrt(100)}[function]
        m = _lambda_rotation(r1, r2, base)
    elif function in (9, 19):
        r1 = _rotation(rseed, dim)
        m = max(1.0, math.sqrt(dim) / 8.0) * r1
    elif function in (17, 18):
        cond = 10.0 if function == 17 else 1000.0
        m = r2 * np.array([math.sqrt(cond) ** (i / (dim - 1.0)) for i in range(dim)])[:, None]
    elif function == 20:
        u = _unif(dim, rseed)
        xopt = np.where(u - 0.5 < 0, -0.5 * 4.2096874637, 0.5 * 4.2096874637)
        aux = np.where(u < 0.5, -1.0, 1.0)
    elif function in (21, 22):
        m, x_local, scales, peaks, xopt = _gallagher(rseed, dim, 101 if function == 21 else 21)
    if function == 24:
        xopt = np.where(_gauss(dim, rseed) < 0.0, -1.25, 1.25)
    return Instance(np.asarray(function, np.int32), xopt, np.asarray(fopt), r1, r2, m, aux, x_local, scales, peaks)


def _gallagher(rseed: int, dim: int, n_peaks: int):
    rotation = _rotation(rseed, dim)
    if n_peaks == 101:
        max_condition_1, b, c = math.sqrt(1000.0), 10.0, 5.0
    else:
        max_condition_1, b, c = 1000.0, 9.8, 4.9
    order = np.argsort(_unif(n_peaks - 1, rseed), kind="stable")
    condition = np.empty(n_peaks)
    condition[0] = max_condition_1
    peaks = np.zeros(N_PEAKS)
    peaks[0] = 10.0
    for i in range(1, n_peaks):
        condition[i] = 1000.0 ** (order[i - 1] / (n_peaks - 2.0))
        peaks[i] = (i - 1) / (n_peaks - 2.0) * (9.1 - 1.1) + 1.1
    scales = np.zeros((N_PEAKS, dim))
    for i in range(n_peaks):
        order_i = np.argsort(_unif(dim, rseed + 1000 * i), kind="stable")
        scales[i] = condition[i] ** (order_i / (dim - 1.0) - 0.5)
    u = _unif(dim * n_peaks, rseed)
    xopt = 0.8 * (b * u[:dim] - c)
    centres = (b * u.reshape(n_peaks, dim) - c)  # centres[j, k] = b u[j dim + k] - c
    x_local = np.zeros((dim, N_PEAKS))
    for k in range(dim):  # C's summation order (BLAS would round differently)
        x_local[:, :n_peaks] += rotation[:, k:k + 1] * centres[None, :, k]
    x_local[:, 0] *= 0.8
    return rotation, x_local, scales, peaks, xopt


def make_instances(functions, instances, dim: int) -> Instance:
    """A stacked :class:`Instance` (leading axis: function-major, then instance)."""
    items = [make_instance(f, i, dim) for f in functions for i in instances]
    return Instance(*(np.stack(leaves) for leaves in zip(*items, strict=True)))


# ---------------------------------------------------------------------------------------------
# Transformations (transform_vars_*.c, transform_obj_*.c).


def _t_osz(x):
    """``transform_vars_oscillate`` (and ``transform_obj_oscillate``), COCO's exact formula."""
    alpha = 0.1
    safe = jnp.where(x == 0.0, 1.0, jnp.abs(x))
    t = jnp.log(safe) / alpha
    pos = jnp.power(jnp.exp(t + 0.49 * (jnp.sin(t) + jnp.sin(0.79 * t))), alpha)
    neg = -jnp.power(jnp.exp(t + 0.49 * (jnp.sin(0.55 * t) + jnp.sin(0.31 * t))), alpha)
    return jnp.where(x > 0.0, pos, jnp.where(x < 0.0, neg, 0.0))


def _ratio(dim):
    return jnp.arange(dim, dtype=jnp.float64) / (dim - 1.0)


def _t_asy(x, beta):
    """``transform_vars_asymmetric``."""
    dim = x.shape[0]
    safe = jnp.where(x > 0.0, x, 1.0)
    exponent = 1.0 + beta * jnp.arange(dim, dtype=jnp.float64) / (dim - 1.0) * jnp.sqrt(safe)
    return jnp.where(x > 0.0, jnp.power(safe, exponent), x)


def _conditioning(x, alpha):
    return jnp.power(alpha, 0.5 * _ratio(x.shape[0])) * x


def _penalty(x):
    """``transform_obj_penalize`` before its factor: sum of squared excess over [-5, 5]."""
    return _sum(jnp.maximum(jnp.abs(x) - 5.0, 0.0) ** 2)


def _round(x):
    """``coco_double_round``: floor(x + 0.5)."""
    return jnp.floor(x + 0.5)


def _sum(v, axis=-1):
    """Left-to-right sum along ``axis``, the C loops' order (XLA's tree reductions round differently)."""
    v = jnp.moveaxis(v, axis, 0)
    acc = v[0]
    for k in range(1, v.shape[0]):
        acc = acc + v[k]
    return acc


def _mv(m, x, b=0.0):
    """``transform_vars_affine``: ``b + sum_j M[:, j] x[j]`` accumulated from ``b`` in C's order."""
    acc = b + m[:, 0] * x[0]
    for j in range(1, x.shape[0]):
        acc = acc + m[:, j] * x[j]
    return acc


# ---------------------------------------------------------------------------------------------
# The functions: each ``(x, p) -> f(x)`` with ``p`` one :class:`Instance`.


def _ellipsoid_raw(z):
    return _sum(jnp.power(1.0e6, _ratio(z.shape[0])) * z * z)


def _rastrigin_raw(z):
    return 10.0 * (z.shape[0] - _sum(jnp.cos(2.0 * jnp.pi * z))) + _sum(z * z)


def _rosenbrock_raw(z):
    return 100.0 * _sum((z[:-1] ** 2 - z[1:]) ** 2) + _sum((z[:-1] - 1.0) ** 2)


def _f1(x, p):
    z = x - p.xopt
    return _sum(z * z) + p.fopt


def _f2(x, p):
    return _ellipsoid_raw(_t_osz(x - p.xopt)) + p.fopt


def _f3(x, p):
    z = _conditioning(_t_asy(_t_osz(x - p.xopt), 0.2), 10.0)
    return _rastrigin_raw(z) + p.fopt


def _f4(x, p):
    z = _t_osz(x - p.xopt)
    dim = x.shape[0]
    factor = jnp.power(jnp.sqrt(10.0), _ratio(dim))
    even = (jnp.arange(dim) % 2) == 0
    factor = jnp.where((z > 0.0) & even, factor * 10.0, factor)
    return _rastrigin_raw(factor * z) + p.fopt + 100.0 * _penalty(x)


def _f5(x, p):
    dim = x.shape[0]
    s = jnp.where(p.xopt > 0.0, 1.0, -1.0) * jnp.power(jnp.sqrt(100.0), _ratio(dim))
    z = jnp.where(x * jnp.sign(s) < 5.0, x, 5.0 * jnp.sign(s))
    return _sum(5.0 * jnp.abs(s) - s * z) + p.fopt


def _f6(x, p):
    z = _mv(p.m, x - p.xopt)
    raw = _sum(jnp.where(p.xopt * z > 0.0, 100.0 * 100.0, 1.0) * z * z)
    return jnp.power(_t_osz(raw), 0.9) + p.fopt


def _f7(x, p):
    dim = x.shape[0]
    c1 = jnp.sqrt(jnp.power(100.0 / 10.0, _ratio(dim)))
    z = _mv(c1[:, None] * p.r2, x - p.xopt)
    x1 = z[0]
    z = jnp.where(jnp.abs(z) > 0.5, _round(z), _round(10.0 * z) / 10.0)
    zz = _mv(p.r1, z)
    core = _sum(jnp.power(100.0, _ratio(dim)) * zz * zz)
    return 0.1 * jnp.maximum(jnp.abs(x1) * 1.0e-4, core) + _penalty(x) + p.fopt


def _f8(x, p):
    factor = max(1.0, math.sqrt(x.shape[0]) / 8.0)
    z = factor * (x - 0.75 * p.xopt) + 1.0
    return _rosenbrock_raw(z) + p.fopt


def _f9(x, p):
    return _rosenbrock_raw(_mv(p.m, x, 0.5)) + p.fopt


def _f10(x, p):
    return _ellipsoid_raw(_t_osz(_mv(p.r1, x - p.xopt))) + p.fopt


def _f11(x, p):
    z = _t_osz(_mv(p.r1, x - p.xopt))
    return _sum(jnp.concatenate([1.0e6 * z[:1] * z[:1], z[1:] * z[1:]])) + p.fopt


def _f12(x, p):
    z = _mv(p.r1, _t_asy(_mv(p.r1, x - p.xopt), 0.5))
    return _sum(jnp.concatenate([z[:1] * z[:1], 1.0e6 * z[1:] * z[1:]])) + p.fopt


def _f13(x, p):
    z = _mv(p.m, x - p.xopt)
    return 100.0 * jnp.sqrt(_sum(z[1:] ** 2)) + z[0] ** 2 + p.fopt


def _f14(x, p):
    z = _mv(p.r1, x - p.xopt)
    exponent = 2.0 + 4.0 * _ratio(x.shape[0])
    return jnp.sqrt(_sum(jnp.power(jnp.abs(z), exponent))) + p.fopt


def _f15(x, p):
    z = _mv(p.m, _t_asy(_t_osz(_mv(p.r1, x - p.xopt)), 0.2))
    return _rastrigin_raw(z) + p.fopt


_WEIERSTRASS_K = np.arange(12)
_WEIERSTRASS_A = 0.5 ** _WEIERSTRASS_K
_WEIERSTRASS_B = 3.0 ** _WEIERSTRASS_K
_WEIERSTRASS_F0 = float(sum(a * math.cos(2 * math.pi * b * 0.5) for a, b in zip(_WEIERSTRASS_A, _WEIERSTRASS_B,
                                                                                  strict=True)))


def _f16(x, p):
    z = _mv(p.m, _t_osz(_mv(p.r1, x - p.xopt)))
    terms = jnp.cos(2.0 * jnp.pi * (z[:, None] + 0.5) * _WEIERSTRASS_B[None, :]) * _WEIERSTRASS_A[None, :]
    total = _sum(terms.reshape(-1))
    dim = x.shape[0]
    return 10.0 * (total / dim - _WEIERSTRASS_F0) ** 3 + p.fopt + 10.0 / dim * _penalty(x)


def _schaffers(x, p):
    z = _mv(p.m, _t_asy(_mv(p.r1, x - p.xopt), 0.5))
    s = z[:-1] ** 2 + z[1:] ** 2
    total = _sum(jnp.power(s, 0.25) * (1.0 + jnp.sin(50.0 * jnp.power(s, 0.1)) ** 2))
    return (total / (x.shape[0] - 1.0)) ** 2 + p.fopt + 10.0 * _penalty(x)


def _f19(x, p):
    z = _mv(p.m, x, 0.5)
    s = 100.0 * (z[:-1] ** 2 - z[1:]) ** 2 + (1.0 - z[:-1]) ** 2
    total = _sum(s / 4000.0 - jnp.cos(s))
    return 10.0 + 10.0 * total / (x.shape[0] - 1.0) + p.fopt


def _f20(x, p):
    dim = x.shape[0]
    xhat = 2.0 * p.aux * x
    shifted = jnp.concatenate([xhat[:1], xhat[1:] + 0.25 * (xhat[:-1] - 2.0 * jnp.abs(p.xopt[:-1]))])
    z = jnp.power(jnp.sqrt(10.0), _ratio(dim)) * (shifted - 2.0 * jnp.abs(p.xopt)) + 2.0 * jnp.abs(p.xopt)
    z = 100.0 * z
    penalty = _sum(jnp.maximum(jnp.abs(z) - 500.0, 0.0) ** 2)
    total = _sum(z * jnp.sin(jnp.sqrt(jnp.abs(z))))
    return 0.01 * (penalty + 418.9828872724339 - total / dim) + p.fopt


def _gallagher_value(x, p):
    dim = x.shape[0]
    tmx = _mv(p.m, x)
    d = tmx[:, None] - p.x_local  # (dim, peaks)
    q = _sum(p.scales.T * d * d, axis=0)
    f = jnp.max(jnp.maximum(p.peaks * jnp.exp(-0.5 / dim * q), 0.0))
    f = 10.0 - f
    a = 0.1
    safe = jnp.where(f == 0.0, 1.0, jnp.abs(f))
    t = jnp.log(safe) / a
    pos = jnp.power(jnp.exp(t + 0.49 * (jnp.sin(t) + jnp.sin(0.79 * t))), a)
    neg = -jnp.power(jnp.exp(t + 0.49 * (jnp.sin(0.55 * t) + jnp.sin(0.31 * t))), a)
    f_true = jnp.where(f > 0.0, pos, jnp.where(f < 0.0, neg, f))
    return f_true * f_true + _penalty(x) + p.fopt


def _f23(x, p):
    z = _mv(p.m, x - p.xopt)
    dim = x.shape[0]
    powers = 2.0 ** jnp.arange(1, 33, dtype=jnp.float64)
    t = powers[None, :] * z[:, None]
    inner = _sum(jnp.abs(t - _round(t)) / powers[None, :], axis=1)
    factors = 1.0 + jnp.arange(1, dim + 1, dtype=jnp.float64) * inner
    prod = 1.0
    for i in range(dim):
        prod = prod * factors[i]
    value = 10.0 / dim / dim * (-1.0 + jnp.power(prod, 10.0 / dim ** 1.2))
    return value + p.fopt + _penalty(x)


def _f24(x, p):
    dim = x.shape[0]
    mu0, d = 2.5, 1.0
    s = 1.0 - 0.5 / (math.sqrt(dim + 20.0) - 4.1)
    mu1 = -math.sqrt((mu0 * mu0 - d) / s)
    xhat = jnp.where(p.xopt < 0.0, -2.0 * x, 2.0 * x)
    c1 = jnp.power(jnp.sqrt(100.0), _ratio(dim))
    z = _mv(p.r1, _mv(c1[:, None] * p.r2, xhat - mu0))
    sum1 = _sum((xhat - mu0) ** 2)
    sum2 = _sum((xhat - mu1) ** 2)
    sum3 = _sum(jnp.cos(2.0 * jnp.pi * z))
    return jnp.minimum(sum1, d * dim + s * sum2) + 10.0 * (dim - sum3) + 1e4 * _penalty(x) + p.fopt


BRANCHES = (_f1, _f2, _f3, _f4, _f5, _f6, _f7, _f8, _f9, _f10, _f11, _f12, _f13, _f14, _f15, _f16,
             _schaffers, _schaffers, _f19, _f20, _gallagher_value, _gallagher_value, _f23, _f24)


def evaluate(x, p: Instance):
    """``f(x)`` of the BBOB problem ``p`` at one point ``x`` (dim,); jit/vmap freely."""
    return jax.lax.switch(p.fid - 1, BRANCHES, x, p)


def evaluate_one(function: int, x, p: Instance):
    """The same without the switch (``function`` static): one branch compiled."""
    return BRANCHES[function - 1](x, p)

"""The random numbers of one optimiser generation: a counter-based SplitMix64 stream.

Steele G. L., Lea D., Flood C. H., "Fast splittable pseudorandom number generators",
OOPSLA 2014, 453–472 (SplitMix64: output ``mix64(seed + i·γ)``, ``γ = 0x9E3779B97F4A7C15``,
with the finaliser constants of Vigna's reference ``splitmix64.c``). Giles M. B.,
"Approximating the erfinv function", GPU Computing Gems Jade (2011) — the single-precision
inverse error function that ``jax.scipy.special.erfinv`` evaluates for float32.

NOTE: why not ``jax.random`` for every number. A CS generation with 37 nests in 36
dimensions needs ~5 400 random numbers for 74 objective calls; with threefry-2x32 and
float64 ``erfinv`` drawing them cost ~2.4 µs per objective call on a CPU core, five times
the objective itself (0.5 µs). Here the generation's key is turned into one 64-bit seed by
threefry (so that keys are still split and folded in the JAX way, and the stream is
deterministic for a given key, under ``jit`` and under ``vmap`` alike), and the numbers are
SplitMix64 outputs at counters ``1 … n`` of that seed: an element-wise hash that XLA
vectorises (~0.3 µs per objective call including the normals).

Each 64-bit output gives two float32 uniforms from its top and its low 24-bit halves,
``(k + ½)·2⁻²⁴``, strictly inside (0, 1) and symmetric about ½; normals are
``√2·erfinv(2u − 1)`` in float32 (|z| ≤ 5.4, a truncation of probability 7e-8). A random
*direction* or *threshold* quantised at 2⁻²⁴ is still a valid random draw, while every point
the optimisers build from them is float64. Uniforms are returned as float64 (exactly);
normals stay float32 so that what is computed from them alone (Mantegna's ``|v|^(1/β)``,
whose float64 ``pow`` does not vectorise on CPU) stays float32 too.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, PRNGKeyArray, UInt

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_LOW24 = np.uint64(0xFFFFFF)


def splitmix64(seed: UInt[Array, ""], n: int) -> UInt[Array, " n"]:
    """Outputs ``1 … n`` of the SplitMix64 sequence that starts at ``seed`` (uint64)."""
    z = seed + jnp.arange(1, n + 1, dtype=jnp.uint64) * _GAMMA
    z = (z ^ (z >> np.uint64(30))) * _M1
    z = (z ^ (z >> np.uint64(27))) * _M2
    return z ^ (z >> np.uint64(31))


def centred_uniforms(key: PRNGKeyArray, n: int) -> Array:
    """``n`` float32 values ``w = 2u − 1`` with ``u = (k + ½)·2⁻²⁴``, ``k`` uniform on
    ``0 … 2²⁴−1``: exactly representable, in (−1, 1), symmetric about 0."""
    seed = jax.random.bits(key, (), jnp.uint64)
    z = splitmix64(seed, (n + 1) // 2)
    k = jnp.concatenate([z >> np.uint64(40), (z >> np.uint64(8)) & _LOW24])[:n]
    k = k.astype(jnp.int32)
    return (2 * k + 1 - 2**24).astype(jnp.float32) * jnp.float32(2.0**-24)


def draw(key: PRNGKeyArray, **specs: tuple[str, tuple[int, ...]]) -> dict[str, Array]:
    """All the random numbers of one step from ONE generator call, carved into named arrays:
    ``draw(key, z=("normal", (n, d)), r=("uniform", (n,)))``. Uniforms (float64) lie in
    (0, 1); normals (float32: see the module note) are standard."""
    sizes = {name: math.prod(shape) for name, (_, shape) in specs.items()}
    for name, (kind, _) in specs.items():
        if kind not in ("normal", "uniform"):
            raise ValueError(f"unknown kind {kind!r} for {name!r}: 'normal' or 'uniform'")
    w = centred_uniforms(key, sum(sizes.values()))
    out, start = {}, 0
    for name, (kind, shape) in specs.items():
        chunk = w[start:start + sizes[name]].reshape(shape)
        start += sizes[name]
        if kind == "normal":
            out[name] = np.float32(np.sqrt(2.0)) * jax.scipy.special.erfinv(chunk)
        else:  # exact in float64 (not in float32: 2k + 1 needs 25 bits)
            out[name] = 0.5 * (chunk.astype(jnp.float64) + 1.0)
    return out

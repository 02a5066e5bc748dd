"""Lévy-flight steps by Mantegna's algorithm.

Mantegna R. N., "Fast, accurate algorithm for numerical simulation of Lévy stable stochastic
processes", Phys. Rev. E 49(5) (1994) 4677–4683 — as used by Yang & Deb's cuckoo search and
by Wang et al. (2018), eq. 10 ("Improved cuckoo calibration method of space telescope secondary
mirror adjusting mechanism", Infrared and Laser Engineering 47(5)).

``sp = u / |v|^(1/β)`` with ``u ~ N(0, σ_u²)``, ``v ~ N(0, 1)`` and

    σ_u = { Γ(1+β) sin(πβ/2) / ( Γ((1+β)/2) β 2^((β−1)/2) ) }^(1/β).

(Eq. 10 as printed reads ``sp = u v |v|^{1/β}``; the fraction bar was lost in typesetting —
Mantegna's step, cited there as ref. [11], is the ratio.) For ``0 < β < 2`` the density of
``sp`` has a power-law tail ``P(|sp| > x) ∝ x^(−β)``: the tail index is ``β``.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
from jaxtyping import Array, Float, PRNGKeyArray

from ._random import draw

BETA = 1.5
"""The Lévy exponent of Wang et al. (2018) (and of Yang & Deb 2009)."""


def mantegna_sigma(beta: float = BETA) -> float:
    """``σ_u`` of Mantegna's algorithm (a Python float; ``beta`` is a static setting)."""
    if not 0.0 < beta < 2.0:
        raise ValueError(f"the Lévy exponent beta must lie in (0, 2), got {beta}")
    num = math.gamma(1.0 + beta) * math.sin(math.pi * beta / 2.0)
    den = math.gamma((1.0 + beta) / 2.0) * beta * 2.0 ** ((beta - 1.0) / 2.0)
    return (num / den) ** (1.0 / beta)


def mantegna_step(key: PRNGKeyArray, shape: tuple[int, ...], beta: float = BETA) -> Float[Array, "..."]:
    """Independent Lévy steps ``u / |v|^(1/β)`` of the given shape (Wang et al. 2018, eq. 10), from the
    optimisers' generator (:func:`~stewart_jax.optimise._random.draw`; float32)."""
    rnd = draw(key, zu=("normal", shape), zv=("normal", shape))
    return mantegna_from_normals(rnd["zu"], rnd["zv"], beta)


def mantegna_from_normals(z_u, z_v, beta: float = BETA):
    """Mantegna steps from two arrays of standard normals (``u = σ_u·z_u``, ``v = z_v``)."""
    return mantegna_sigma(beta) * z_u / jnp.abs(z_v) ** (1.0 / beta)


def hill_tail_index(samples: Float[Array, " n"], k: int) -> Float[Array, ""]:
    """Hill's estimator of the tail index from the ``k`` largest ``|samples|`` (a diagnostic
    for :func:`mantegna_step`: it should come out near ``β``)."""
    x = jnp.sort(jnp.abs(jnp.ravel(samples)))[::-1]
    top = x[: k + 1]
    return 1.0 / jnp.mean(jnp.log(top[:k]) - jnp.log(top[k]))

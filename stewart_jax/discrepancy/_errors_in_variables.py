"""Errors in a recorded variable: a recorded temperature with a stated standard deviation.

A candidate that reads the temperature (``thermal_expansion``) predicts the readings from the
*recorded* temperature; with sensor noise ``σ_T`` the prediction of row ``j`` carries the extra
error ``g_j·ε_j`` (``g_j = ∂prediction/∂T`` at the candidate's fit, ``ε_j ~ N(0, σ_T²)``), which
the held-out test would count as lack of fit. Its covariance is added to the row's noise
covariance: in the base whitener's units ``C_j = s·I + u_j u_jᵀ`` (``u_j = W_j g_j σ_T``, ``s`` the
noise variance factor), whose inverse is rank-one (Sherman and Morrison 1950, "Adjustment of an
inverse matrix corresponding to a change in one element of a given matrix", Ann. Math. Statist.
21), so the row's χ² drops by ``(u_j·r_j)² / (s + |u_j|²)``. This is the structural
errors-in-variables model of a regression with a noisy regressor (Fuller 1987, "Measurement Error
Models", §1.2) at the fitted coefficient: the fit's attenuation (a share σ_T² / var(T) of the
coefficient, ~1e-5 for 0.01 K over a few kelvin) is left as it is.

NOTE: the correction is applied to the held-out χ² only (the test that decides whether the
candidate closes the gap); the training χ² of the significance tests is dominated by the
effect, not by ``σ_T``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._fits import unpack
from ._registry import AbstractDiscrepancyModel, Effect


@eqx.filter_jit
def temperature_slope(
    model: AbstractDiscrepancyModel, base: Float[Array, " p"], effect: Effect, theta: Float[Array, " k"], data: Any
) -> Float[Array, "m k"]:
    """``∂prediction/∂T`` per row and output (library units per K) of base + ``effect``."""

    def predict(temp):
        return model.predict(base, (effect,), (theta,), data._replace(temperature=temp))

    return jax.jvp(predict, (data.temperature,), (jnp.ones_like(data.temperature),))[1]


def heldout_corrections(
    model: AbstractDiscrepancyModel,
    effects: Sequence[Effect],
    z: np.ndarray,
    w_te: np.ndarray,
    white_te: np.ndarray,
    test: Any,
    temperature_std_k: float,
    scale2: float,
) -> np.ndarray:
    """Per candidate, the drop of its held-out χ² when the recorded temperature carries noise of
    σ ``temperature_std_k`` (K); 0 for a candidate that does not read the temperature.

    ``z``: ``(K+1, n)`` scaled unknowns of the base and single-candidate fits; ``w_te``: ``(m, k,
    k)`` held-out whiteners; ``white_te``: ``(K+1, m·k)`` whitened held-out residuals."""
    out = np.zeros(len(effects))
    if not temperature_std_k > 0:
        return out
    m, k = w_te.shape[0], w_te.shape[1]
    for i, e in enumerate(effects):
        if "temperature" not in e.requires:
            continue
        mask = np.zeros(len(effects))
        mask[i] = 1.0
        base, thetas = unpack(model, effects, jnp.asarray(z[i + 1]), jnp.asarray(mask))
        g = np.asarray(temperature_slope(model, base, e, thetas[i], test))
        u = np.einsum("mij,mj->mi", w_te, g) * temperature_std_k
        r = white_te[i + 1].reshape(m, k)
        out[i] = float(np.sum(np.einsum("mi,mi->m", u, r) ** 2 / (scale2 + np.sum(u**2, axis=1))))
    return out

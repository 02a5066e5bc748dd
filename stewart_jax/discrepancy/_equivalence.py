"""Which candidates the data at hand cannot tell apart, and what measurement would.

After the base fit, candidate ``c``'s *signature* is its fitted change of the whitened training
residuals with the base directions projected out, ``s_c = (I − P_G) J_c θ_c``. The part of it
outside the span of another candidate's augmented model ``[G, J_a]`` is what the data could use
to tell ``c`` from ``a``: its squared norm ``χ²_out`` is the training χ² a fit of base + ``a``
leaves of ``c``'s signature, and ``share = χ²_out / |s_c|²`` is the share of the signature
outside. ``a`` *reproduces* ``c`` when ``χ²_out`` is below the χ² critical value at the
candidates' level with the degrees of freedom of ``c`` not spanned by base + ``a``: the data
then cannot reject ``a`` as the cause of what ``c`` fitted (an exact equivalence has
``share = 0``; a near-equivalence a share below the noise). This is the encompassing principle
(Mizon and Richard 1986, "The encompassing principle and its application to testing non-nested
hypotheses", Econometrica 54) evaluated at the fitted signatures.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import stats

from ._subspace import basis, n_identifiable

SEPARATED_BY = {
    "strut_scale": "a reference length measured by the struts (a strut against a length standard)",
    "stroke_scale": "a reference length measured by the sliders (a stroke against a length standard)",
    "gear_ratio": "a reference angle measured by the cranks (a crank against an angle standard)",
    "tracker_scale": "a reference length measured by the instrument (a calibrated scale bar)",
    "tracker_misalignment": "the base's reference points measured by the instrument (its registration)",
    "thermal_expansion": "a temperature step (the same poses measured again at another temperature)",
    "gravity_sag": "another telescope elevation or payload (the load changes, the geometry does not)",
    "drift": "the same poses repeated at the start and the end of the session",
    "backlash": "the same poses approached from both directions",
    "zero_offset": "a reading at a reference (home) position of each actuator",
    "crank_offset": "a reading at a reference (home) position of each crank",
    "actuator_tilt": "the slider axes measured directly (a straightedge along each rail)",
}
"""Per registered effect, a measurement that changes its signature and not the others'."""


def separated_by(name: str) -> str:
    """The measurement that separates effect ``name`` from the others (:data:`SEPARATED_BY`)."""
    return SEPARATED_BY.get(name, f"a measurement that varies the factor of {name} and not the others'")


def signature(jac_tr: np.ndarray, nb: int, cols: np.ndarray, z_effect: np.ndarray) -> np.ndarray:
    """``(I − P_G) J_c θ_c``: the whitened training signature of an effect's fit (``cols`` its
    columns of the whitened Jacobian, ``z_effect`` its scaled unknowns) outside the base span."""
    q_g = basis(jac_tr[:, :nb])
    s = jac_tr[:, cols] @ z_effect
    return s - q_g @ (q_g.T @ s)


def encompassed(base: np.ndarray, other: np.ndarray, sig: np.ndarray, own: np.ndarray, level: float,
                scale2: float) -> tuple[float, bool]:
    """``(χ²_out, reproduced)``: the squared norm of the signature ``sig`` outside the span of the
    ``base`` and ``other`` columns (whitened), and whether ``other`` reproduces it — ``χ²_out``
    over the noise variance factor ``scale2`` below the χ² critical value at ``level``, with the
    degrees of freedom of ``own`` (the columns behind ``sig``, base projected out) outside that
    span (module docstring)."""
    q = basis(np.concatenate([base, other], axis=1))
    r = sig - q @ (q.T @ sig)
    chi2_out = float(r @ r)
    df = max(n_identifiable(q, own), 1)
    return chi2_out, bool(chi2_out / scale2 < stats.chi2.ppf(1 - level, df))


def equivalences(
    named: int, others: list[int], names: list[str], jac_tr: np.ndarray, nb: int, slices: list[np.ndarray],
    z: np.ndarray, level: float, scale2: float,
) -> list[dict[str, Any]]:
    """Per other identifiable candidate ``c`` (index into ``names``), in both directions: the
    share of ``c``'s fitted signature outside base + named and of the named one's outside base
    + ``c``, and whether each reproduces the other (module docstring). ``z``: per candidate
    (``1 + index``) the fit's scaled unknowns; ``scale2``: the noise variance factor."""
    out = []
    sig_a = signature(jac_tr, nb, slices[named], z[named + 1][slices[named]])
    q_g = basis(jac_tr[:, :nb])
    for c in others:
        sig_c = signature(jac_tr, nb, slices[c], z[c + 1][slices[c]])
        row: dict[str, Any] = {"effect": names[c], "with": names[named]}
        for key, s, cols_other, cols_own in (("outside_named", sig_c, slices[named], slices[c]),
                                             ("named_outside", sig_a, slices[c], slices[named])):
            size = float(s @ s)
            own = jac_tr[:, cols_own] - q_g @ (q_g.T @ jac_tr[:, cols_own])
            chi2_out, reproduced = encompassed(jac_tr[:, :nb], jac_tr[:, cols_other], s, own, level, scale2)
            row[f"{key}_share"] = chi2_out / size if size > 0 else 0.0
            row[f"{key}_chi2"] = chi2_out / scale2
            row[f"{key}_reproduced"] = reproduced
        row["equivalent"] = row["outside_named_reproduced"] and row["named_outside_reproduced"]
        out.append(row)
    return out

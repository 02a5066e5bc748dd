"""The encompassing test behind the equivalences and the open search's reproduced terms, against a
closed form: a signature in the span of base + other is reproduced; one with a part orthogonal
to that span is reproduced exactly when that part's squared norm (over the noise variance) is
below the χ² critical value with the own columns' degrees of freedom outside the span."""

import numpy as np
import pytest
from scipy import stats

from stewart_jax.discrepancy._equivalence import encompassed


@pytest.mark.parametrize("scale2", [1.0, 4.0])
def test_a_signature_is_reproduced_exactly_below_the_chi2_critical_value(scale2):
    rng = np.random.default_rng(7)
    q, _ = np.linalg.qr(rng.normal(size=(200, 12)))
    base, other, own = q[:, :4], q[:, 4:7], q[:, 7:9]  # own: 2 directions outside base + other
    inside = base @ rng.normal(size=4) + other @ rng.normal(size=3)
    chi2_out, reproduced = encompassed(base, other, inside, own, 0.05, scale2)
    assert chi2_out < 1e-20 and reproduced
    crit = stats.chi2.ppf(0.95, 2) * scale2
    for size2, expected in ((0.9 * crit, True), (1.1 * crit, False)):
        sig = inside + np.sqrt(size2) * own[:, 0]
        chi2_out, reproduced = encompassed(base, other, sig, own, 0.05, scale2)
        np.testing.assert_allclose(chi2_out, size2, rtol=1e-9)
        assert reproduced is expected

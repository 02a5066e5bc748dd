"""The regularized incomplete gamma functions on the host, for the χ² tail probabilities of a
report.

Press W. H., Teukolsky S. A., Vetterling W. T., Flannery B. P., *Numerical Recipes: The Art of
Scientific Computing*, 3rd ed., Cambridge University Press, 2007, §6.2: the series of γ(a, x)
for ``x < a + 1`` and the continued fraction of Γ(a, x) (modified Lentz) otherwise; each tail is
summed directly where it is the small one, so a p-value of 1e-30 keeps its digits.

NOTE: these run in Python (a few microseconds): ``jax.scipy.special.gammainc`` called on two
scalars compiles an XLA program each (0.8 s apiece on the benchmark machine), longer than the
rest of a calibration's report.
"""

from __future__ import annotations

import math
import sys

_EPS = sys.float_info.epsilon
_TINY = 1e-300
_MAX_TERMS = 10_000


def regularized_gamma(a: float, x: float) -> tuple[float, float]:
    """``(P(a, x), Q(a, x))``: the lower and upper regularized incomplete gamma functions
    (``P + Q = 1``), ``a > 0``, ``x >= 0``. The χ² tail of ``c`` on ``k`` degrees of freedom is
    ``Q(k/2, c/2)``."""
    a, x = float(a), float(x)
    if not (a > 0 and x >= 0) or math.isinf(a):
        raise ValueError(f"regularized_gamma needs a > 0 (finite) and x >= 0, got a={a}, x={x}")
    if x == 0:
        return 0.0, 1.0
    if math.isinf(x):
        return 1.0, 0.0
    front = math.exp(-x + a * math.log(x) - math.lgamma(a))
    if x < a + 1.0:
        term = total = 1.0 / a
        ap = a
        for _ in range(_MAX_TERMS):
            ap += 1.0
            term *= x / ap
            total += term
            if abs(term) < abs(total) * _EPS:
                break
        p = min(total * front, 1.0)
        return p, 1.0 - p
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, _MAX_TERMS):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < _EPS:
            break
    q = min(front * h, 1.0)
    return 1.0 - q, q

"""The open term search scores a family of groups in chunks (memory linear in the rows, whatever
the number of periods): the same drops as one stack, and each the drop of χ² that a least-squares
fit with the group's columns gives (an independent computation)."""

import numpy as np
import pytest

from stewart_jax.discrepancy import _discovery as disc
from stewart_jax.discrepancy._cabin_record import CabinRecordData


@pytest.mark.parametrize("leg", [None, 2])
def test_chunked_family_drops_equal_one_stack_and_least_squares(monkeypatch, leg):
    rng = np.random.default_rng(0)
    m, k = 240, 6
    data = CabinRecordData(np.arange(m) * 0.1, rng.standard_normal((m, 6)))
    reading = rng.standard_normal((m, k))
    w = np.broadcast_to(np.diag(rng.uniform(0.5, 2.0, k)), (m, k, k)).copy()
    q, _ = np.linalg.qr(rng.standard_normal((m * k, 7)))
    r = rng.standard_normal(m * k)
    r -= q @ (q.T @ r)
    fam = [disc.TermSpec("time", "periodic", float(p), None, "", leg) for p in np.geomspace(0.3, 15.0, 37)]
    whole = disc._drops(q, r, disc._stack_columns(fam, reading, data, w))
    monkeypatch.setattr(disc, "CHUNK_BYTES", 8 * r.size * 14 * 4)  # four groups per chunk
    chunked = disc._family_drops(fam, q, r, reading, data, w)
    np.testing.assert_allclose(chunked, whole, rtol=1e-12, atol=1e-9)
    for i in (0, 18, 36):
        cols = disc._stack_columns([fam[i]], reading, data, w)[0]
        a = np.concatenate([q, cols], axis=1)
        fit = a @ np.linalg.lstsq(a, r, rcond=None)[0]
        # rcond of the search's pseudo-inverse (1e-9) against lstsq's: agree to 1e-8 relative
        assert chunked[i] == pytest.approx(r @ r - (r - fit) @ (r - fit), rel=1e-8)

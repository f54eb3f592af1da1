"""NEES of particle clouds: a collapsed cloud (singular covariance) gives an undefined NEES at its epochs, not a crash
(found by the 200-files-per-kind reader property, docs/particles.md)."""

import numpy as np

from sarnav.simulation.fusion_records import filter_nees


def test_a_singular_cloud_covariance_gives_nan_only_where_it_is_singular():
    rng = np.random.default_rng(3)
    e = rng.standard_normal((2, 3, 4, 3))
    A = rng.standard_normal((2, 3, 4, 3, 3))
    P = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(3)
    full = filter_nees(e, P)
    want = np.einsum("frki,frki->frk", e, np.linalg.solve(P, e[..., None])[..., 0])
    assert np.array_equal(full, want)
    P[1, 2, 3] = 0.0  # every particle in one place
    got = filter_nees(e, P)
    assert np.isnan(got[1, 2, 3])
    mask = np.ones(got.shape, dtype=bool)
    mask[1, 2, 3] = False
    np.testing.assert_allclose(got[mask], want[mask], rtol=1e-12)

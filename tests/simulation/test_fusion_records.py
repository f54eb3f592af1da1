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


def test_run_records_give_each_run_its_slice_and_meet_the_record_contract():
    """``run_records``: run i of the batch becomes the record numbered ``run_ids[i]``: its filters' errors and
    1-sigma (sqrt of the covariance diagonal), the stacked NEES (sum of the per-filter e^T P^-1 e, computed here
    independently), the sources' errors and mean squares after ``settle``, and its slice of every extra."""
    from sarnav.simulation.fusion_records import run_records, source_records

    rng = np.random.default_rng(5)
    R, K = 2, 6
    times = np.arange(K, dtype=float)
    errors = {n: rng.standard_normal((R, K, 3)) for n in ("a", "b", "mean")}
    A = rng.standard_normal((2, R, K, 3, 3))
    covs = {n: A[i] @ np.swapaxes(A[i], -1, -2) + 0.5 * np.eye(3) for i, n in enumerate(("a", "b"))}
    rec = source_records(times, errors, covs, ["a", "b"], ["a", "b", "mean"], settle=2.0)
    extra = rng.standard_normal((R, 4))
    out = run_records(rec, [5, 7], {"x": (("aperture",), extra)})
    assert [r.run for r in out] == [5, 7]
    for i, r in enumerate(out):
        r.check(6, 0)  # 3 states per filter, no measurement residuals
        np.testing.assert_array_equal(r.error, np.concatenate([errors["a"][i], errors["b"][i]], -1))
        np.testing.assert_allclose(r.sigma[:, 3:], np.sqrt(np.diagonal(covs["b"][i], axis1=-2, axis2=-1)))
        nees = sum(np.einsum("ki,ki->k", errors[n][i], np.linalg.solve(covs[n][i], errors[n][i][..., None])[..., 0])
                   for n in ("a", "b"))
        np.testing.assert_allclose(r.nees, nees, rtol=1e-12)
        np.testing.assert_allclose(r.extras["source_ms"][1][2], np.mean(np.sum(errors["mean"][i, 2:] ** 2, -1)))
        assert r.extras["source_error"][1].shape == (K, 3, 3) and r.extras["filter_nees"][1].shape == (K, 2)
        np.testing.assert_array_equal(r.extras["x"][1], extra[i])
    assert "source_error" not in run_records(rec, [0, 1], sources=False)[0].extras

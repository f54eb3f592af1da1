"""``imaging.feature_registration`` on images of known geometry: a textured scene shifted by a known sub-pixel amount
(Fourier shift theorem) and warped by a known affine map (scikit-image's warp, an independent resampler)."""

import numpy as np
import pytest
from scipy import ndimage

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.feature_registration import correlation_shift, feature_affine, to_gray


@pytest.fixture(scope="module")
def scene():
    """A speckle-free scene of bright blobs of several sizes on a smooth background (features for ORB)."""
    rng = np.random.default_rng(12)
    img = ndimage.gaussian_filter(rng.random((256, 256)), 8.0) * 0.5
    for _ in range(120):
        r, c = rng.integers(10, 246, 2)
        img[r - 2:r + 3, c - 2:c + 3] += rng.uniform(0.5, 2.0)
    return ndimage.gaussian_filter(img, 1.0)


def test_correlation_shift_recovers_a_known_subpixel_shift(scene):
    d = (3.4, -7.65)
    moved = np.real(np.fft.ifft2(ndimage.fourier_shift(np.fft.fft2(scene), d)))  # moved(x) = scene(x - d)
    dr, dc, _ = correlation_shift(scene, moved, upsample=20)
    assert dr == pytest.approx(d[0], abs=0.06) and dc == pytest.approx(d[1], abs=0.06)


def test_feature_affine_recovers_a_known_affine(scene):
    from skimage.transform import AffineTransform, warp

    # reference (row, col) = M (image row, col, 1): a 4 degree rotation, 3 % scale and a shift
    a, s = np.radians(4.0), 1.03
    M = np.array([[s * np.cos(a), -s * np.sin(a), 6.0], [s * np.sin(a), s * np.cos(a), -4.0], [0, 0, 1]])
    P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # skimage works in (x, y) = (col, row)
    # reference(q) = image(M^-1 q): warp takes the map output -> input coordinates
    reference = warp(scene, AffineTransform(matrix=P @ np.linalg.inv(M) @ P), order=3, preserve_range=True)
    match = feature_affine(scene, reference, min_inliers=8)
    assert match is not None and match.n_inliers >= 8
    probe = np.array([[64.0, 64.0], [128.0, 128.0], [190.0, 80.0]])
    got = np.stack(match.apply(probe[:, 0], probe[:, 1]), axis=1)
    want = (M @ np.c_[probe, np.ones(3)].T).T[:, :2]
    np.testing.assert_allclose(got, want, atol=1.0)


def test_featureless_images_give_no_match_and_bad_inputs_are_named(scene):
    flat = np.ones((64, 64))
    assert feature_affine(flat, flat) is None
    with pytest.raises(ConfigError, match="registration.min_inliers"):
        feature_affine(scene, scene, min_inliers=2)
    with pytest.raises(ConfigError, match="registration.features"):
        feature_affine(scene, scene, method="surf")
    with pytest.raises(InputDataError, match="image"):
        feature_affine(scene[:16, :16], scene)
    with pytest.raises(InputDataError, match="image"):
        correlation_shift(scene, scene[:100])
    g = to_gray(scene)
    assert g.max() == 1.0 and g.min() >= 0.0

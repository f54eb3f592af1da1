"""Registration of a formed amplitude image against a geocoded reference (Pogorelsky et al. 2022 §IV, gap G16).

* :func:`feature_affine`: feature-based, the paper's method with open tools: ORB (or SIFT) keypoints and descriptors
  from scikit-image on both images, putative matches (mutual nearest neighbours with a ratio test), and an affine
  fit with RANSAC (``skimage.measure.ransac``; the paper used SURF + MLESAC in MATLAB). The fit needs at least
  ``min_inliers`` (>= 3, paper L193) inliers, otherwise there is no match (None): the caller skips the update.
* :func:`correlation_shift`: the area-correlation alternative (paper L205, offset tracking): the translation between
  two images of the same geometry by phase correlation with sub-pixel upsampling
  (``skimage.registration.phase_cross_correlation``).

Coordinates are (row, col) pixels; the affine ``matrix`` (3, 3) maps image (row, col, 1) to reference (row, col, 1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError, require_extra

__all__ = ["AffineMatch", "feature_affine", "correlation_shift", "FEATURES", "to_gray"]

FEATURES = ("orb", "sift")


@dataclass
class AffineMatch:
    """An affine registration: ``matrix`` image -> reference (row, col); matched keypoints ``src`` (image) and
    ``dst`` (reference) (M, 2) (row, col); ``inliers`` (M,) bool."""

    matrix: np.ndarray
    src: np.ndarray
    dst: np.ndarray
    inliers: np.ndarray

    @property
    def n_inliers(self) -> int:
        return int(np.sum(self.inliers))

    def apply(self, rows, cols):
        """Reference (row, col) of image (row, col)."""
        q = self.matrix @ np.vstack([np.ravel(rows), np.ravel(cols), np.ones(np.size(rows))])
        return q[0].reshape(np.shape(rows)), q[1].reshape(np.shape(cols))


def to_gray(amplitude, clip_percentile: float = 99.5) -> np.ndarray:
    """Amplitude -> float image in [0, 1] (scaled to the ``clip_percentile`` percentile, clipped)."""
    a = np.abs(np.asarray(amplitude, float))
    top = np.percentile(a, clip_percentile) if a.size else 0.0
    return np.clip(a / top, 0.0, 1.0) if top > 0 else np.zeros_like(a)


def _detector(method: str, n_keypoints: int):
    from skimage.feature import ORB, SIFT

    if method == "orb":
        return ORB(n_keypoints=n_keypoints, fast_threshold=0.05, harris_k=0.04)
    if method == "sift":
        return SIFT(n_octaves=3, n_scales=3)
    raise ConfigError("registration.features", f"must be one of {FEATURES}, got {method!r}")


def _features(det, img):
    try:
        det.detect_and_extract(img)
    except (RuntimeError, ValueError, IndexError):  # no keypoints at all (featureless image)
        return np.empty((0, 2)), None
    return np.asarray(det.keypoints, float), det.descriptors


def feature_affine(image, reference, method: str = "orb", min_inliers: int = 3, n_keypoints: int = 600,
                   residual_threshold: float = 2.0, max_trials: int = 2000, seed: int = 0) -> AffineMatch | None:
    """Affine image -> reference from features + RANSAC (module docstring); None when fewer than ``min_inliers``
    inliers (or matches) are found. ``image``, ``reference``: amplitudes (2-D). RANSAC draws from ``seed``."""
    require_extra("feature_affine", "registration", "skimage", "scikit-image")
    from skimage.feature import match_descriptors
    from skimage.measure import ransac
    from skimage.transform import AffineTransform

    if not (isinstance(min_inliers, int) and min_inliers >= 3):
        raise ConfigError("registration.min_inliers", f"must be an integer >= 3 (an affine has 6 unknowns), got "
                          f"{min_inliers!r}")
    a, b = to_gray(image), to_gray(reference)
    if a.ndim != 2 or b.ndim != 2 or min(a.shape + b.shape) < 32:
        raise InputDataError("image", f"need 2-D images of at least 32 x 32 pixels, got {a.shape}, {b.shape}")
    ka, da = _features(_detector(method, n_keypoints), a)
    kb, db = _features(_detector(method, n_keypoints), b)
    if da is None or db is None or len(ka) < min_inliers or len(kb) < min_inliers:
        return None
    pairs = match_descriptors(da, db, cross_check=True, max_ratio=0.9)
    if len(pairs) < min_inliers:
        return None
    src, dst = ka[pairs[:, 0]], kb[pairs[:, 1]]
    model, inl = ransac((src[:, ::-1], dst[:, ::-1]), AffineTransform, min_samples=3,
                        residual_threshold=residual_threshold, max_trials=max_trials, rng=seed)
    if model is None or inl is None or int(np.sum(inl)) < min_inliers:
        return None
    M = np.asarray(model.params)  # (x, y) = (col, row) convention: swap to (row, col)
    P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    return AffineMatch(P @ M @ P, src, dst, np.asarray(inl, bool))


def correlation_shift(moving, reference, upsample: int = 20):
    """(d_row, d_col, error): the shift that maps ``moving`` onto ``reference`` (reference(x) ~ moving(x - d)), by
    phase correlation of the amplitudes with ``upsample``-fold sub-pixel refinement."""
    require_extra("correlation_shift", "registration", "skimage", "scikit-image")
    from skimage.registration import phase_cross_correlation

    a, b = np.abs(np.asarray(moving, float)), np.abs(np.asarray(reference, float))
    if a.shape != b.shape or a.ndim != 2:
        raise InputDataError("image", f"need two 2-D images of one shape, got {a.shape}, {b.shape}")
    shift, err, _ = phase_cross_correlation(b, a, upsample_factor=upsample, normalization=None)
    return float(shift[0]), float(shift[1]), float(err)

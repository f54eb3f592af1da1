"""Scene-independent image-quality (focus) scores: kurtosis, histogram entropy, contrast.

Sources
-------
* Hathaway (2023) thesis, extraction ``notes/seed-004-image-quality-gpsd.md`` §2.3–2.4:
  complex kurtosis, eq. (3.5) — the *raw* fourth cumulant (no normalisation, which is **not** an
  "excess kurtosis" of a normalised variable, but for a circular complex Gaussian it is 0, the same
  reference point); Shannon entropy of an N-bin histogram, eq. (3.6), in bits, of the pixel
  magnitudes ("entropy magnitude") or of Re + Im ("entropy sum").
* Lindstrom (2020) thesis App. D.2, eqs. (D.11)–(D.12): contrast metrics (notes/seed-000 §10.2).
* Spacecraft SAR-TRN paper, eq. (3) (Groen et al.): normalised variance sharpness
  (notes/seed-002 §2.9).
* Minimum-entropy autofocus (Wang & Liu; Kragh): the Shannon entropy of the intensity-normalised
  image, ``E = -sum p ln p`` with ``p_i = |y_i|^2 / sum |y|^2``, in nats (anchors-wave2 §3.2).

Conventions fixed here (docs/quality.md, tests/imaging/test_quality.py pins each to a closed form):

============================ ================================================ =================== ==========
measure                      definition                                       circular speckle     sense
============================ ================================================ =================== ==========
complex_kurtosis             m4 - 2 m2^2 - |mean y^2|^2 (eq. 3.5, raw)        0                    maximise
normalised_complex_kurtosis  eq. 3.5 / m2^2                                   0                    maximise
normalised_fourth_moment     m4 / m2^2                                        2                    maximise
entropy_magnitude            eq. 3.6 on an N-bin histogram of |y|, bits       (depends on N)       minimise
entropy_sum                  eq. 3.6 on an N-bin histogram of Re y + Im y     (depends on N)       minimise
intensity_entropy            -sum p ln p, p = |y|^2 / sum |y|^2, nats         ln P - (1 - gamma_E) minimise
============================ ================================================ =================== ==========

with m2 = mean |y|^2, m4 = mean |y|^4 over all P pixels. Kurtosis is maximised by a well-focused
image; entropy is minimised; contrast and normalised variance are maximised.

Bad input (``InputDataError`` naming ``image``): an empty image, NaN/inf pixels, and for the image
measures of the table an image of constant value (zero variance: it carries no focus information and
the normalised measures are 0/0). ``n_bins`` must be an integer >= 2 (``ConfigError``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from sarnav.errors import ConfigError, InputDataError

#: Euler-Mascheroni constant (speckle intensity entropy ln P - (1 - gamma_E))
EULER_GAMMA = 0.5772156649015329

__all__ = [
    "QUALITY_MEASURES",
    "QualityMeasure",
    "quality_measure",
    "quality_score",
    "complex_kurtosis",
    "normalised_fourth_moment",
    "intensity_entropy",
    "normalised_complex_kurtosis",
    "entropy_bits",
    "histogram_entropy",
    "entropy_magnitude",
    "entropy_sum",
    "normalised_variance",
    "intensity_contrast",
    "std_to_mean_contrast",
    "quality_summary",
]


def _pixels(image, field: str = "image") -> np.ndarray:
    """Flattened pixel array of an ndarray or a ``SarImage``; rejects empty or non-finite input."""
    data = getattr(image, "data", image)
    y = np.asarray(data).ravel()
    if y.size == 0:
        raise InputDataError(field, "is empty; need at least one pixel")
    if not np.all(np.isfinite(y)):
        raise InputDataError(field, "contains NaN or inf; all pixels must be finite")
    return y


def _image_pixels(image, remove_mean: bool = False) -> np.ndarray:
    """complex128 pixels of an image measure's input; rejects a constant (zero-variance) image."""
    y = _pixels(image).astype(np.complex128, copy=False)
    mean = y.mean()
    if np.all(y == y[0]):
        raise InputDataError("image", f"has constant value {complex(y[0])!r} (zero variance) over all {y.size} "
                             "pixels; a focus measure needs a non-constant image")
    return y - mean if remove_mean else y


def complex_kurtosis(image, *, remove_mean: bool = False) -> float:
    """Sample fourth cumulant of complex pixels, Hathaway eq. (3.5).

    ``K = mean(|y|^4) - 2 mean(|y|^2)^2 - |mean(y^2)|^2``, over all pixels. Zero for circular
    complex Gaussian noise (eq. 3.3); positive (super-Gaussian) for a focused scene of point-like
    scatterers. Not normalised: it scales as amplitude^4 (see :func:`normalised_complex_kurtosis`).

    Parameters
    ----------
    image : complex ndarray or SarImage
    remove_mean : subtract the pixel mean first (the thesis' "mean-removed kurtosis", L598).

    Returns
    -------
    float
    """
    y = _image_pixels(image, remove_mean)
    p = (y.real**2 + y.imag**2)
    return float(np.mean(p * p) - 2.0 * np.mean(p) ** 2 - np.abs(np.mean(y * y)) ** 2)


def normalised_complex_kurtosis(image, *, remove_mean: bool = False) -> float:
    """Eq. (3.5) divided by ``mean(|y|^2)^2`` (scale-invariant variant, seed-004 §2.3 [decision]).

    For circular complex Gaussian noise this is 0; for a single real spike among P pixels it is P − 3.
    """
    y = _image_pixels(image, remove_mean)
    p = y.real**2 + y.imag**2
    m2 = float(np.mean(p))
    return float(np.mean(p * p) - 2.0 * m2**2 - np.abs(np.mean(y * y)) ** 2) / m2**2


def normalised_fourth_moment(image, *, remove_mean: bool = False) -> float:
    """``mean(|y|^4) / mean(|y|^2)^2``: 2 for circular complex Gaussian speckle, P for one bright pixel
    among P, 1 for a constant-modulus image (Cumming & Wong's intensity contrast + 1).

    Equals :func:`normalised_complex_kurtosis` + 2 + ``|mean y^2|^2 / m2^2`` (eq. 3.5 rearranged).
    """
    y = _image_pixels(image, remove_mean)
    p = y.real**2 + y.imag**2
    return float(np.mean(p * p) / np.mean(p) ** 2)


def intensity_entropy(image) -> float:
    """Shannon entropy of the intensity-normalised image, in nats (minimum-entropy autofocus).

    ``E = -sum_i p_i ln p_i`` with ``p_i = |y_i|^2 / sum_j |y_j|^2`` and ``0 ln 0 = 0``. Limits: one
    bright pixel 0; a constant-modulus image ln P (the maximum); circular complex Gaussian speckle
    ``ln P - (1 - gamma_E)`` = ln P - 0.4228 for large P (E[x ln x] = 1 - gamma_E for x ~ Exp(1)).
    """
    y = _image_pixels(image)
    p = y.real**2 + y.imag**2
    total = float(p.sum())
    if total == 0.0:  # pragma: no cover - a non-constant image has a non-zero pixel
        raise InputDataError("image", "is identically zero; intensity entropy undefined")
    p = p[p > 0] / total
    return float(-np.sum(p * np.log(p)))


def entropy_bits(probabilities) -> float:
    """Shannon entropy ``-sum p log2 p`` in bits, eq. (3.6), with ``0 log 0 = 0``.

    Parameters
    ----------
    probabilities : array of non-negative numbers summing to 1 (within 1e-9).
    """
    p = np.asarray(probabilities, dtype=np.float64).ravel()
    if p.size == 0 or np.any(~np.isfinite(p)) or np.any(p < 0):
        raise InputDataError("probabilities", "must be a non-empty array of finite values >= 0")
    if abs(p.sum() - 1.0) > 1e-9:
        raise InputDataError("probabilities", f"must sum to 1, got {p.sum()!r}")
    nz = p[p > 0]
    return float(-np.sum(nz * np.log2(nz)))


def histogram_entropy(values, n_bins: int) -> float:
    """Entropy in bits of the N-bin equal-width histogram of ``values`` over [min, max].

    PMF estimate of Hathaway §3.2.2 (L337): ``p_k = count_k / number of values``, bins of equal
    width between the minimum and maximum value (numpy.histogram semantics: the last bin is
    closed). A constant input puts everything in one bin and gives 0.

    Parameters
    ----------
    values : real array (any shape)
    n_bins : number of bins N >= 2 (the thesis uses 10, 100, 1000)
    """
    if isinstance(n_bins, bool) or not isinstance(n_bins, (int, np.integer)) or n_bins < 2:
        raise ConfigError("n_bins", f"must be an integer >= 2 (a histogram of one bin has entropy 0), got {n_bins!r}")
    v = _pixels(values, "values")
    if np.iscomplexobj(v):
        raise InputDataError("values", "must be real; use entropy_magnitude or entropy_sum for complex images")
    v = v.astype(np.float64, copy=False)
    lo, hi = float(v.min()), float(v.max())
    if lo == hi:
        return 0.0
    counts, _ = np.histogram(v, bins=int(n_bins), range=(lo, hi))
    return entropy_bits(counts / v.size)


def entropy_magnitude(image, n_bins: int = 1000) -> float:
    """Histogram entropy in bits of the pixel magnitudes |I| (Hathaway eq. 3.6, "entropy magnitude").

    At most log2 N, so values for different N are not comparable.
    """
    return histogram_entropy(np.abs(_image_pixels(image)), n_bins)


def entropy_sum(image, n_bins: int = 1000) -> float:
    """Histogram entropy in bits of Re I + Im I (Hathaway eq. 3.6, "entropy sum", L489)."""
    y = _image_pixels(image)
    return histogram_entropy(y.real + y.imag, n_bins)


def normalised_variance(image, *, quantity: str = "intensity") -> float:
    """Normalised-variance sharpness, spacecraft SAR-TRN eq. (3) (Groen et al.).

    ``S = mean((g - mean g)^2) / mean(g)^2`` with ``g`` the pixel intensity. The source does not say
    whether g is amplitude or power; ``quantity`` chooses ("intensity" = |I|^2, "amplitude" = |I|).
    With g = |I| (``quantity="amplitude"``) this equals (D.11) minus 1; with g = |I|^2 it is
    E[|I|^4]/E[|I|^2]^2 minus 1 (Cumming & Wong's contrast of the intensity image).
    """
    y = _pixels(image)
    if quantity == "intensity":
        g = np.abs(y) ** 2
    elif quantity == "amplitude":
        g = np.abs(y)
    else:
        raise ConfigError("quantity", f"must be 'intensity' or 'amplitude', got {quantity!r}")
    m = float(g.mean())
    if m == 0.0:
        raise InputDataError("image", "is identically zero; normalised variance undefined")
    return float(np.mean((g - m) ** 2) / m**2)


def intensity_contrast(image) -> float:
    """Lindstrom (D.11): ``E[|I|^2] / E[|I|]^2`` (Cumming & Wong's intensity-to-power ratio)."""
    a = np.abs(_pixels(image))
    m = float(a.mean())
    if m == 0.0:
        raise InputDataError("image", "is identically zero; contrast undefined")
    return float(np.mean(a * a) / m**2)


def std_to_mean_contrast(image) -> float:
    """Lindstrom (D.12) (Berizzi & Corsini): ``sqrt(E[|I|^2] - E[|I|]^2) / E[|I|]``."""
    a = np.abs(_pixels(image))
    m = float(a.mean())
    if m == 0.0:
        raise InputDataError("image", "is identically zero; contrast undefined")
    return float(np.sqrt(max(np.mean(a * a) - m**2, 0.0)) / m)


# ---------------------------------------------------------------------------------------------
# named measures (what sweeps, searches and scenarios refer to by name)

@dataclass(frozen=True)
class QualityMeasure:
    """A focus measure by name: ``function(image) -> float`` and whether larger is better."""

    name: str
    function: Callable[..., float]
    maximise: bool
    uses_bins: bool = False

    def __call__(self, image, n_bins: int = 1000) -> float:
        return self.function(image, n_bins) if self.uses_bins else self.function(image)

    def better(self, image, n_bins: int = 1000) -> float:
        """The score oriented so that larger is better (entropy negated)."""
        v = self(image, n_bins)
        return v if self.maximise else -v


def _kurt_mean_removed(image):
    return complex_kurtosis(image, remove_mean=True)


#: every measure of the module by the name used in sweeps, searches and configuration files
QUALITY_MEASURES = {
    "kurtosis": QualityMeasure("kurtosis", complex_kurtosis, True),
    "kurtosis_mean_removed": QualityMeasure("kurtosis_mean_removed", _kurt_mean_removed, True),
    "normalised_kurtosis": QualityMeasure("normalised_kurtosis", normalised_complex_kurtosis, True),
    "fourth_moment": QualityMeasure("fourth_moment", normalised_fourth_moment, True),
    "entropy_magnitude": QualityMeasure("entropy_magnitude", entropy_magnitude, False, True),
    "entropy_sum": QualityMeasure("entropy_sum", entropy_sum, False, True),
    "intensity_entropy": QualityMeasure("intensity_entropy", intensity_entropy, False),
}


def quality_measure(name: str, field: str = "measure") -> QualityMeasure:
    """The :class:`QualityMeasure` called ``name``; ConfigError naming ``field`` for an unknown name."""
    try:
        return QUALITY_MEASURES[name]
    except (KeyError, TypeError):
        raise ConfigError(field, f"must be one of {sorted(QUALITY_MEASURES)}, got {name!r}") from None


def quality_score(image, measure: str = "kurtosis", n_bins: int = 1000) -> float:
    """Score of ``image`` by the named measure (raw value; see :data:`QUALITY_MEASURES` for its sense)."""
    return quality_measure(measure)(image, n_bins)


def quality_summary(image) -> dict:
    """The figures an image's ``metrics.json`` records (``sarnav image``): normalised complex kurtosis, entropy of the
    magnitude on 100 bins, normalised intensity variance."""
    return {"normalised_kurtosis": normalised_complex_kurtosis(image),
            "entropy_magnitude_100": entropy_magnitude(image, 100),
            "normalised_variance": normalised_variance(image)}

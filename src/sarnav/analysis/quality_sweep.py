"""Image-quality score versus velocity error: the data of Hathaway (2023) Figs. 4.1-4.8 and claims T3, T7-T17.

Thesis §3.4.2 (L395): images are back-projected along the true track and along tracks with a constant
along-track or cross-track velocity error; each is scored with kurtosis (eq. 3.5) and histogram entropy
(eq. 3.6); the curves are read for a maximum (kurtosis) or minimum (entropy) at zero error
(notes/seed-004 §3.2, §4.2, T3, T7-T17).

Velocity error (gap 7, faithful reading, pivot = first pulse n0, which shifts the image as in Fig. 4.1b):

* along-track, relative error ``eps`` (0.002 = 0.2 %): ``p_eps(n) = p(n) + eps ((p(n) - p(n0)) . e) e``;
* cross-track, ``eta`` metres per metre: ``p_eta(n) = p(n) + eta ((p(n) - p(n0)) . e) c``,

with e the along-track and c the cross-track unit vector. On flat ground a cross-track error of this form
is a rotation of the track about the vertical through p(n0), so it shifts (by ~eta x ground range) and
rotates the image without defocusing it (docs/quality.md, "cross-track").

Everything returns numpy arrays or an ``xarray.Dataset`` (dims ``size``, ``bins``, ``error``); figures are
drawn elsewhere. Grids keep the ground extent of the geometry and vary the pixel count (gap 4). The experiment of
the ``quality-sweep`` scenario is :func:`run` (:class:`QualitySweepParams`): the sweeps, the T3 example, the claims
and the T16 reliability study.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import xarray as xr

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.quality import QUALITY_MEASURES, quality_measure
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.registration import register
from sarnav.radar.quality_scenes import QualityGeometry, point_clutter_scene, simulate_pulses, textured_clutter_scene
from sarnav.simulation.quality_scene import QualitySceneSpec, make_scene

__all__ = ["DIRECTIONS", "FIGURES", "DEFAULT_MEASURES", "compressed_pulses", "image_grid", "velocity_error_positions",
           "focus_depth", "error_grid", "score_images", "quality_sweep", "figure_data", "extremum_error",
           "count_local_extrema", "local_minimum_near", "curve_correlation", "reliability_study", "t3_example",
           "SOURCE_CLAIMS", "trough_depth", "monotone_steps", "along_claims", "cross_claims", "reliability_claims",
           "mean_to_rms", "ReliabilitySpec", "RELIABILITY_SCENES", "reliability_scenes", "QualitySweepParams", "run"]

DIRECTIONS = ("along", "cross")
#: the measures of the thesis' USU study (Figs. 4.2-4.8) plus the mean-removed kurtosis (Figs. 4.11, 4.17)
DEFAULT_MEASURES = ("kurtosis", "kurtosis_mean_removed", "entropy_magnitude", "entropy_sum")

#: what each figure of the thesis shows (direction, image sizes, histogram bins); thesis 300^2 -> 200^2 here
FIGURES = {
    "4.2": {"direction": "along", "sizes": (100,), "bins": (10,)},
    "4.3-4.6": {"direction": "along", "sizes": (10, 50, 100, 200), "bins": (1000,)},
    "4.7": {"direction": "along", "sizes": (100,), "bins": (10, 100, 1000)},
    "4.8": {"direction": "cross", "sizes": (100,), "bins": (10, 100, 1000)},
}


def compressed_pulses(geometry: QualityGeometry, scene, snr_db: float | None = None, rng=None):
    """Range-compressed echoes of ``scene`` along the geometry's true track."""
    return range_compress(simulate_pulses(geometry, scene, snr_db, rng))


def image_grid(geometry: QualityGeometry, n: int) -> GroundGrid:
    """n x n ground grid over the geometry's square scene (rows north = along-track, columns east)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
        raise ConfigError("sizes", f"image sizes must be integers >= 2, got {n!r}")
    c = geometry.scene_center
    return GroundGrid.centered(float(c[0]), float(c[1]), geometry.grid_spacing(n), (int(n), int(n)))


def velocity_error_positions(positions, error: float, direction: str, along, cross, pivot: int = 0) -> np.ndarray:
    """(P, 3) positions with a constant velocity error (module docstring; gap 7, pivot = first pulse)."""
    if direction not in DIRECTIONS:
        raise ConfigError("direction", f"must be one of {DIRECTIONS}, got {direction!r}")
    p = np.asarray(positions, dtype=np.float64)
    e = np.asarray(along, dtype=np.float64)
    d = (p - p[pivot]) @ e
    u = e if direction == "along" else np.asarray(cross, dtype=np.float64)
    return p + (float(error) * d)[:, None] * u[None, :]


def focus_depth(geometry: QualityGeometry) -> float:
    """Relative along-track speed error giving a quadratic phase error of pi/2 at the aperture ends.

    Azimuth FM rate K_a = 2 V^2 / (lambda R0); a relative speed error eps changes it by 2 eps K_a, a
    quadratic phase pi 2 eps K_a (T/2)^2 at the ends of an aperture of T seconds.
    """
    lam = geometry.radar().wavelength
    r0 = math.hypot(geometry.altitude, geometry.ground_range)
    k_a = 2.0 * geometry.speed**2 / (lam * r0)
    half = 0.5 * (geometry.n_pulses - 1) / geometry.prf
    return 1.0 / (4.0 * k_a * half * half)


def error_grid(geometry: QualityGeometry, direction: str = "along", steps: int = 20, span: float = 6.0) -> np.ndarray:
    """Symmetric error grid of 2 ``steps`` + 1 values over +- ``span`` focus depths (gap 8).

    Along-track in relative units. Cross-track in m/m, up to the error that shifts the image by a quarter of the
    scene (eta x ground range = extent / 4; the thesis' 0.002 m/m shifts it by 3.5 m here).
    """
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ConfigError("steps", f"must be an integer >= 1, got {steps!r}")
    if direction == "along":
        top = span * focus_depth(geometry)
    elif direction == "cross":
        top = 0.25 * geometry.scene_extent / geometry.ground_range
    else:
        raise ConfigError("direction", f"must be one of {DIRECTIONS}, got {direction!r}")
    return np.linspace(-top, top, 2 * int(steps) + 1)


def score_images(images, measures: Sequence[str] = DEFAULT_MEASURES, bins: Sequence[int] = (1000,)) -> dict:
    """Scores of a stack of images: {measure: (n,) or (len(bins), n) for histogram measures}."""
    imgs = np.asarray(images)
    out = {}
    for name in measures:
        m = quality_measure(name, "measures")
        if m.uses_bins:
            out[name] = np.array([[m(im, b) for im in imgs] for b in bins])
        else:
            out[name] = np.array([m(im) for im in imgs])
    return out


PIVOTS = ("first", "centre")


def _pivot_index(pivot: str, n_pulses: int) -> int:
    if pivot not in PIVOTS:
        raise ConfigError("pivot", f"must be one of {PIVOTS}, got {pivot!r}")
    return 0 if pivot == "first" else n_pulses // 2


def _images_for_errors(rc, grid, geometry, errors, direction, pivot="first") -> np.ndarray:
    pos = np.asarray(rc.positions)
    k = _pivot_index(pivot, pos.shape[0])
    imgs = [backproject(rc, grid, positions=velocity_error_positions(pos, err, direction, geometry.along_track,
                                                                   geometry.cross_track, k)).data for err in errors]
    return np.stack(imgs)


def quality_sweep(rc, geometry: QualityGeometry, errors, direction: str = "along", sizes: Sequence[int] = (100,),
                  bins: Sequence[int] = (1000,), measures: Sequence[str] = DEFAULT_MEASURES,
                  pivot: str = "first") -> xr.Dataset:
    """Score of every measure versus velocity error for each image size (one BPA image per size and error).

    Parameters
    ----------
    rc : range-compressed pulses (true positions in ``rc.positions``).
    geometry : the :class:`QualityGeometry` that produced them (directions, scene square).
    errors : (E,) along-track relative errors or cross-track errors [m/m].
    direction : "along" or "cross".
    sizes : image sizes n (n x n pixels over the fixed extent); bins : histogram bin counts N.
    measures : names in :data:`sarnav.imaging.quality.QUALITY_MEASURES`.
    pivot : pulse about which the error grows: "first" (the thesis' reading, shifts the image) or "centre".

    Returns
    -------
    xarray.Dataset with coordinates ``size``, ``bins``, ``error`` and one variable per measure: (size, error),
    or (size, bins, error) for histogram entropies; attribute ``maximise_<measure>`` gives each one's sense.
    """
    err = np.asarray(errors, dtype=np.float64)
    if err.ndim != 1 or err.size < 3 or not np.all(np.isfinite(err)) or np.any(np.diff(err) <= 0):
        raise ConfigError("errors", "must be >= 3 finite, strictly increasing values")
    bins = [int(b) for b in bins]
    data = {name: [] for name in measures}
    for n in sizes:
        imgs = _images_for_errors(rc, image_grid(geometry, n), geometry, err, direction, pivot)
        scores = score_images(imgs, measures, bins)
        for name in measures:
            data[name].append(scores[name])
    ds = xr.Dataset(coords={"size": list(sizes), "bins": bins, "error": err})
    for name in measures:
        dims = ("size", "bins", "error") if QUALITY_MEASURES[name].uses_bins else ("size", "error")
        ds[name] = (dims, np.array(data[name]))
        ds.attrs[f"maximise_{name}"] = int(QUALITY_MEASURES[name].maximise)
    ds.attrs["direction"] = direction
    ds.attrs["pivot"] = pivot
    ds.attrs["error_unit"] = "relative" if direction == "along" else "m/m"
    return ds


def figure_data(figure: str, rc, geometry: QualityGeometry, errors=None,
                measures: Sequence[str] = DEFAULT_MEASURES) -> xr.Dataset:
    """The data of one of the thesis' figures (:data:`FIGURES`: "4.2", "4.3-4.6", "4.7", "4.8")."""
    if figure not in FIGURES:
        raise ConfigError("figure", f"must be one of {sorted(FIGURES)}, got {figure!r}")
    spec = FIGURES[figure]
    if errors is None:
        errors = error_grid(geometry, spec["direction"])
    return quality_sweep(rc, geometry, errors, spec["direction"], spec["sizes"], spec["bins"], measures)


# ---------------------------------------------------------------------------------------------
# reading the curves (claims T7-T17)

def extremum_error(errors, scores, maximise: bool) -> float:
    """The error at the best score (arg max if ``maximise`` else arg min)."""
    s = np.asarray(scores, dtype=np.float64)
    return float(np.asarray(errors)[np.argmax(s) if maximise else np.argmin(s)])


def count_local_extrema(scores) -> int:
    """Number of interior strict local maxima and minima of a curve (its roughness, T10)."""
    d = np.sign(np.diff(np.asarray(scores, dtype=np.float64)))
    d = d[d != 0]
    return int(np.sum(d[1:] != d[:-1]))


def local_minimum_near(errors, scores, zero_window: int = 1) -> bool:
    """True when a local minimum of the curve lies within ``zero_window`` steps of the error closest to 0 (T11)."""
    s = np.asarray(scores, dtype=np.float64)
    i0 = int(np.argmin(np.abs(np.asarray(errors))))
    lo, hi = max(1, i0 - zero_window), min(s.size - 2, i0 + zero_window)
    return any(s[i] <= s[i - 1] and s[i] <= s[i + 1] for i in range(lo, hi + 1))


def curve_correlation(a, b) -> float:
    """Pearson correlation of two score curves (T17: mean-removed vs zero-mean kurtosis)."""
    return float(np.corrcoef(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))[0, 1])


def reliability_study(geometry: QualityGeometry, scenes, errors, size: int = 100, n_bins: int = 100,
                      measures: Sequence[str] = ("kurtosis", "entropy_magnitude")) -> np.ndarray:
    """(n_scenes, n_measures) error at each measure's extremum, along-track, one curve per scene (T16)."""
    out = np.empty((len(scenes), len(measures)))
    for k, scene in enumerate(scenes):
        ds = quality_sweep(compressed_pulses(geometry, scene), geometry, errors, "along", (size,), (n_bins,), measures)
        for j, name in enumerate(measures):
            curve = ds[name].sel(size=size)
            if "bins" in curve.dims:
                curve = curve.sel(bins=n_bins)
            out[k, j] = extremum_error(errors, curve.values, bool(ds.attrs[f"maximise_{name}"]))
    return out


def t3_example(rc, geometry: QualityGeometry, size: int = 100, along_error: float = 0.002,
               cross_error: float = 0.002) -> dict:
    """Fig. 4.1 / T3: the reference image and the images with 0.2 % along-track and 0.002 m/m cross-track error.

    Returns {"reference", "along", "cross": (n, n) complex images; "<dir>_correlation": magnitude correlation
    peak with the reference; "<dir>_shift_m": (along-track, east) shift [m]; "<dir>_sharpness": normalised
    fourth moment relative to the reference's}.
    """
    grid = image_grid(geometry, size)
    pos = np.asarray(rc.positions)
    ref = backproject(rc, grid).data
    out = {"reference": ref}
    m4 = QUALITY_MEASURES["fourth_moment"]
    for name, err, direction in (("along", along_error, "along"), ("cross", cross_error, "cross")):
        img = backproject(rc, grid, positions=velocity_error_positions(pos, err, direction, geometry.along_track,
                                                                     geometry.cross_track)).data
        reg = register(ref, img, spacing=(geometry.grid_spacing(size),) * 2)
        out[name] = img
        out[f"{name}_correlation"] = float(reg.peak)
        out[f"{name}_shift_m"] = tuple(float(v) for v in reg.shift_m)
        out[f"{name}_sharpness"] = m4(img) / m4(ref)
    if out["along_correlation"] > 1.0 + 1e-9:  # pragma: no cover - a normalised correlation
        raise InputDataError("registration", "correlation above 1")
    return out


# ---------------------------------------------------------------------------------------------
# the claims of a sweep, as numbers (scenario quality-sweep: claims.json; docs/quality.md §3)

#: what the thesis says of each claim (notes/seed-004 §7)
SOURCE_CLAIMS = {
    "T3": "0.2 % along-track error blurs and shifts a 100x100 image; 0.002 m/m cross-track error blurs it (Fig. 4.1)",
    "T7": "kurtosis peaks very close to 0 along-track error at >= 50x50 (Figs. 4.2a, 4.4-4.6)",
    "T8": "the same for cross-track error (L513, L590)",
    "T9": "smaller deviation, higher kurtosis near 0; local maxima at large deviations (L505, L586)",
    "T10": "10x10 no trend; 50x50 a detectable peak; larger images smoother curves (L546-548)",
    "T11": "entropy magnitude (N = 10, 100x100): a trough near 0, scattered, not the global minimum (Fig. 4.2b)",
    "T12": "entropy sum: no trend at N = 10, a trough at N = 100, nothing more at 1000 (Figs. 4.2c, 4.7)",
    "T13": "entropy magnitude: a distinct trough at N = 10 already; N = 100 small gain; N > 100 none (Fig. 4.7)",
    "T14": "cross-track entropy has no trough at zero (Fig. 4.8)",
    "T15": "entropy sum is never better than entropy magnitude (L588)",
    "T16": "kurtosis is a more reliable measure than entropy (L469, L590, L636, L720)",
    "T17": "mean-removed kurtosis ~ zero-mean kurtosis; pixel mean ~ 1e-3 of the pixels (L302, Figs. 4.11, 4.17)",
}


def _curve(ds, measure, size, n_bins=None) -> np.ndarray:
    c = ds[measure].sel(size=size)
    if "bins" in c.dims:
        c = c.sel(bins=n_bins if n_bins is not None else int(ds["bins"].values[0]))
    return np.asarray(c.values, dtype=np.float64)


def _best_step(ds, measure, size, n_bins=None) -> int:
    e = ds["error"].values
    best = extremum_error(e, _curve(ds, measure, size, n_bins), bool(ds.attrs[f"maximise_{measure}"]))
    return int(round(best / (e[1] - e[0])))


def trough_depth(scores) -> float:
    """(median - min) / std of a curve: how distinct its minimum is (T13)."""
    s = np.asarray(scores, dtype=np.float64)
    sd = float(np.std(s))
    return float((np.median(s) - np.min(s)) / sd) if sd > 0 else 0.0


def monotone_steps(scores) -> int:
    """Largest k such that the curve rises strictly over the k steps before its maximum and falls over the k after (T9)."""
    s = np.asarray(scores, dtype=np.float64)
    i = int(np.argmax(s))
    k = 0
    while i - k - 1 >= 0 and i + k + 1 < s.size and s[i - k - 1] < s[i - k] and s[i + k + 1] < s[i + k]:
        k += 1
    return k


def along_claims(ds: xr.Dataset, figure_size: int = 100) -> dict:
    """T7, T9-T13, T15, T17 from an along-track sweep (:func:`quality_sweep`): grid steps of the extrema, curve
    roughness, trough depths. ``figure_size``: the size of Figs. 4.2 and 4.7 (the nearest one swept is used)."""
    sizes = [int(v) for v in ds["size"].values]
    bins = [int(v) for v in ds["bins"].values]
    fig = min(sizes, key=lambda n: abs(n - figure_size))
    big = max(sizes)
    names = set(ds.data_vars)
    out = {"sizes": sizes, "bins": bins, "figure_size": fig}
    if "kurtosis" in names:
        out["T7"] = {"kurtosis_max_step": {n: _best_step(ds, "kurtosis", n) for n in sizes}}
        out["T9"] = {"size": big, "monotone_steps": monotone_steps(_curve(ds, "kurtosis", big))}
        out["T10"] = {"kurtosis_local_extrema": {n: count_local_extrema(_curve(ds, "kurtosis", n)) for n in sizes}}
    e = ds["error"].values
    for name, claim in (("entropy_magnitude", "T13"), ("entropy_sum", "T12")):
        if name in names:
            out[claim] = {f"{name}_min_step": {b: _best_step(ds, name, fig, b) for b in bins},
                          "trough_within_one_step": {b: local_minimum_near(e, _curve(ds, name, fig, b), 1) for b in bins},
                          "trough_depth": {b: trough_depth(_curve(ds, name, fig, b)) for b in bins}}
    if "entropy_magnitude" in names:
        b0 = min(bins)
        c = _curve(ds, "entropy_magnitude", fig, b0)
        out["T11"] = {"size": fig, "bins": b0, "trough_within_one_step": local_minimum_near(e, c, 1),
                      "global_min_step": _best_step(ds, "entropy_magnitude", fig, b0),
                      "local_extrema": count_local_extrema(c)}
    if {"entropy_magnitude", "entropy_sum"} <= names:
        out["T15"] = {"local_extrema_sum_magnitude": {b: [count_local_extrema(_curve(ds, "entropy_sum", fig, b)),
                                                          count_local_extrema(_curve(ds, "entropy_magnitude", fig, b))]
                                                      for b in bins}}
    if {"kurtosis", "kurtosis_mean_removed"} <= names:
        out["T17"] = {"curve_correlation": {n: curve_correlation(_curve(ds, "kurtosis", n),
                                                                _curve(ds, "kurtosis_mean_removed", n)) for n in sizes}}
    return out


def cross_claims(ds: xr.Dataset, figure_size: int = 100) -> dict:
    """T8 and T14 from a cross-track sweep: kurtosis arg-max steps per size; the rank of the zero-error entropy
    among all errors (0 = the smallest, i.e. a trough at zero; n - 1 = the largest) and whether zero error is a local
    minimum (the thesis: "no trough at zero deviation", L584)."""
    sizes = [int(v) for v in ds["size"].values]
    bins = [int(v) for v in ds["bins"].values]
    fig = min(sizes, key=lambda n: abs(n - figure_size))
    e = ds["error"].values
    i0 = int(np.argmin(np.abs(e)))
    out = {"sizes": sizes, "bins": bins, "figure_size": fig}
    if "kurtosis" in ds:
        out["T8"] = {"kurtosis_max_step": {n: _best_step(ds, "kurtosis", n) for n in sizes}}
    if "entropy_magnitude" in ds:
        curves = {b: _curve(ds, "entropy_magnitude", fig, b) for b in bins}
        out["T14"] = {"size": fig, "rank_of_zero": {b: int(np.sum(c < c[i0])) for b, c in curves.items()},
                      "trough_at_zero": {b: local_minimum_near(e, c, 0) for b, c in curves.items()},
                      "errors": int(e.size)}
    return out


def reliability_claims(best, errors, measures) -> dict:
    """T16 from :func:`reliability_study`: per measure, the fraction of scenes whose extremum is exactly at zero
    error, within one step, and the mean distance in steps."""
    steps = np.abs(np.round(np.asarray(best) / (errors[1] - errors[0])))
    return {"scenes": int(steps.shape[0]),
            "exactly_at_zero": {m: float(np.mean(steps[:, j] == 0)) for j, m in enumerate(measures)},
            "within_one_step": {m: float(np.mean(steps[:, j] <= 1)) for j, m in enumerate(measures)},
            "mean_distance_steps": {m: float(np.mean(steps[:, j])) for j, m in enumerate(measures)}}


def mean_to_rms(image) -> float:
    """|mean pixel| / rms pixel of an image (T17: the thesis' 'three orders of magnitude smaller')."""
    y = np.asarray(getattr(image, "data", image)).ravel()
    return float(abs(y.mean()) / np.sqrt(np.mean(np.abs(y) ** 2)))


# ---------------------------------------------------------------------------------------------
# the experiment of scenario quality-sweep

@dataclass(frozen=True)
class ReliabilitySpec:
    """The T16 study: ``scenes`` scenes (0: none) drawn from ``seed``, each swept along-track at ``size`` x ``size``
    pixels and ``bins`` histogram bins, scored by ``measures``. ``scene``: ``"point-clutter"`` (bright points 20 dB
    over Rayleigh clutter of ``clutter_density`` [1/m^2]) or ``"textured"`` (no dominant scatterer:
    ``radar.quality_scenes.textured_clutter_scene`` of ``contrast_db``, ``correlation_m``, ``texture_density``).
    ``span_depths``: the errors' half-span in focus depths (None: the sweep's; small: the thesis' zoomed-in view)."""

    scenes: int
    size: int
    bins: int
    seed: int
    clutter_density: float
    measures: tuple[str, ...]
    scene: str = "point-clutter"
    contrast_db: float = 3.0
    correlation_m: float = 1.0
    texture_density: float = 32.0
    span_depths: float | None = None


#: the scenes of the T16 study (ReliabilitySpec.scene)
RELIABILITY_SCENES = ("point-clutter", "textured")


def reliability_scenes(rel: ReliabilitySpec, geo: QualityGeometry) -> list:
    """The ``rel.scenes`` scenes of the T16 study, one generator per scene spawned from ``rel.seed``."""
    if rel.scene not in RELIABILITY_SCENES:
        raise ConfigError("scene", f"must be one of {RELIABILITY_SCENES}, got {rel.scene!r}")
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(rel.seed).spawn(rel.scenes)]
    if rel.scene == "textured":
        return [textured_clutter_scene(r, geo.scene_center, geo.scene_extent, rel.contrast_db, rel.correlation_m,
                                       rel.texture_density) for r in rngs]
    return [point_clutter_scene(r, geo.scene_center, geo.scene_extent, clutter_density=rel.clutter_density)
            for r in rngs]


@dataclass(frozen=True)
class QualitySweepParams:
    """The sweep of scenario ``quality-sweep``: the geometry and scene; per direction (:data:`DIRECTIONS`) the
    images of ``sizes`` pixels scored by ``measures`` (``bins`` histogram bins) at 2 ``steps`` + 1 errors over
    +- ``span_depths`` focus depths about ``pivot``; the figures' image size ``figure_size``; the T16 study."""

    geometry: QualityGeometry
    scene: QualitySceneSpec
    directions: tuple[str, ...]
    sizes: tuple[int, ...]
    bins: tuple[int, ...]
    measures: tuple[str, ...]
    steps: int
    span_depths: float
    figure_size: int
    pivot: str
    reliability: ReliabilitySpec


def _reliability(prm: QualitySweepParams) -> tuple[dict, np.ndarray, np.ndarray] | None:
    """(T16 claims, extremum errors in steps (scenes, measures), errors) of the reliability study, or None."""
    rel, geo = prm.reliability, prm.geometry
    if rel.scenes == 0:
        return None
    span = prm.span_depths if rel.span_depths is None else rel.span_depths
    errors = error_grid(geo, "along", prm.steps, span)
    best = reliability_study(geo, reliability_scenes(rel, geo), errors, rel.size, rel.bins, tuple(rel.measures))
    claims = reliability_claims(best, errors, rel.measures)
    claims["conditions"] = {"scene": rel.scene, "span_depths": span, "step": float(errors[1] - errors[0]),
                            **({"contrast_db": rel.contrast_db, "correlation_m": rel.correlation_m,
                                "texture_density": rel.texture_density} if rel.scene == "textured"
                               else {"clutter_density": rel.clutter_density})}
    return claims, best / (errors[1] - errors[0]), errors


def run(prm: QualitySweepParams, progress=None) -> dict:
    """The sweeps ({direction: :func:`quality_sweep` Dataset}), the claims (T3, T7-T17 beside
    :data:`SOURCE_CLAIMS`), the T3 example (:func:`t3_example`) and the reliability study (or None).
    ``progress(text)``, when given, is told each stage as it starts."""
    say = progress or (lambda text: None)
    geo = prm.geometry
    scene, rng, snr = make_scene(prm.scene, geo)
    say("echoes")
    rc = compressed_pulses(geo, scene, snr, rng)
    sweeps = {}
    for k, d in enumerate(prm.directions):
        say(f"{d}-track sweep ({k + 1} of {len(prm.directions)}: sizes {list(prm.sizes)}, {2 * prm.steps + 1} errors)")
        sweeps[d] = quality_sweep(rc, geo, error_grid(geo, d, prm.steps, prm.span_depths), d, prm.sizes, prm.bins,
                                  prm.measures, prm.pivot)
    claims = {"source": SOURCE_CLAIMS, "focus_depth": focus_depth(geo),
              "step": {d: float(ds["error"].values[1] - ds["error"].values[0]) for d, ds in sweeps.items()}}
    if "along" in sweeps:
        claims.update(along_claims(sweeps["along"], prm.figure_size))
    if "cross" in sweeps:
        claims.update(cross_claims(sweeps["cross"], prm.figure_size))
    say("T3 example")
    t3 = t3_example(rc, geo, prm.figure_size)
    claims["T3"] = {k: v for k, v in t3.items() if not isinstance(v, np.ndarray)}
    claims.setdefault("T17", {})["mean_over_rms"] = mean_to_rms(t3["reference"])
    if prm.reliability.scenes:
        say(f"reliability over {prm.reliability.scenes} scenes")
    rel = _reliability(prm)
    if rel is not None:
        claims["T16"] = rel[0]
    return {"sweeps": sweeps, "claims": claims, "t3": t3, "reliability": rel}

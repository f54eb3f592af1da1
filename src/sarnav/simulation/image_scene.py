"""The ``image`` experiment: one block of echoes of a simulated scene focused into one image, and its metrics.

The antenna flies straight and level, north, through ``start_ned`` at t = 0 (pulse times centred on 0, so the
aperture centre is at north = start_ned[0] and the image's along-track axis is measured from it). The scene is one
point target (the point-target checks of the thesis ch. 5 / anchors-sar §3: IRW, PSLR, ISLR against theory) or a
homogeneous Poisson field of point scatterers on the flat ground (seeded). Echoes: ``radar.echoes.simulate_echoes``
along the true track, range compression ``imaging.range_compression``; focusing ``imaging.straight_block`` along the
true straight track flown at the true speed plus ``speed_error`` (a navigation speed error, to exercise autofocus).
``run(params)`` returns the :class:`ImageSceneResult`; the scenario kind (``scenarios.imaging``) only parses the
TOML into :class:`ImageSceneParams`, and ``report.image_files`` writes the files.

Random draws: the scatterer field from ``SeedSequence(seed)``, the receiver noise from ``SeedSequence([seed, 1])``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError
from sarnav.imaging import quality
from sarnav.imaging.grid import PlaneGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.straight_block import focus_straight_block
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import Scene, point_targets, random_scatterers
from sarnav.signal.data import PulseData, SarImage
from sarnav.signal.metrics import point_target_report

__all__ = ["ImageSceneParams", "ImageSceneResult", "run", "pulse_track", "scene", "scene_centre", "build_pulses",
           "form_image", "image_metrics", "sicd_geometry"]


@dataclass(frozen=True)
class ImageSceneParams:
    """The validated, SI content of an image scenario (``scenarios.imaging.parse``)."""

    radar: RadarParams  # its receive window spans the imaged slant ranges; look_side, range_window are the scene's
    start_ned: tuple[float, float, float]  # antenna position at t = 0 (the aperture centre) [m], NED
    speed: float  # true speed, north [m/s]
    duration: float  # block length [s]: round(duration x prf) pulses
    scene: str = "point"  # "point" | "random"
    seed: int = 0
    target_along_track: float = 0.0  # point: along-track offset from the aperture centre [m]
    target_slant_range: float = 2000.0  # point: slant range of closest approach [m]
    along_track_extent: float = 40.0  # random: along-track size of the patch [m]
    slant_range_min: float = 1985.0  # random: slant-range limits of the patch [m]
    slant_range_max: float = 2020.0
    density: float = 0.01  # random: scatterers per m^2 of flat ground
    amplitude_law: str = "rayleigh"  # random: "rayleigh" | "constant"
    snr_db: float | None = None  # per-sample SNR of the echoes; None: no receiver noise
    antenna_pattern: bool = False  # weight the echoes by the two-way azimuth pattern
    algorithm: str = "rda"  # imaging.straight_block.ALGORITHMS
    window: object = "none"  # azimuth window (a signal.windows specification)
    rcmc_kernel: str = "sinc8"
    azimuth_model: str = "parabolic"
    autofocus: str = "none"  # imaging.straight_block.AUTOFOCUS
    bpa_interpolation: str = "upsample"
    speed_error: float = 0.0  # added to ``speed`` for focusing [m/s]
    origin_llh: tuple[float, float, float] = (58.4, 15.6, 100.0)  # NED origin on WGS-84 [deg, deg, m] (files)
    name: str = ""  # the scenario's name (metrics)

    @property
    def altitude(self) -> float:
        return -float(self.start_ned[2])

    @property
    def focus_speed(self) -> float:
        """The processor's speed estimate [m/s]: the true speed plus ``speed_error``."""
        return float(self.speed) + float(self.speed_error)

    def check_doppler_band(self) -> None:
        """The scene's azimuth band must fit in the PRF (the RDA azimuth FFT is circular); ConfigError naming ``prf``.

        A scatterer at along-track y seen by pulses t in [-T/2, T/2] has Doppler -K_a (t - y/V) (paper eq. 8), so the
        scene occupies K_a (T + 2 max|y| / V) Hz at its nearest range (largest K_a); with the antenna pattern the band
        is at most the beam's Doppler bandwidth ``RadarParams.doppler_bandwidth(V)`` (about 0.886 * 2V / L_a).
        """
        v = float(self.speed)
        point = self.scene == "point"
        r_min = float(self.target_slant_range if point else self.slant_range_min)
        half = abs(self.target_along_track) if point else 0.5 * self.along_track_extent
        band = 2.0 * v**2 / (self.radar.wavelength * r_min) * (self.duration + 2.0 * half / v)
        if self.antenna_pattern:
            band = min(band, self.radar.doppler_bandwidth(v))
        if band > self.radar.prf:
            raise ConfigError("prf", f"must be >= the scene's azimuth bandwidth {band:.4g} Hz (K_a (T + 2 max|y|/V) "
                              f"at the nearest range), got {self.radar.prf:g}")


@dataclass(frozen=True)
class ImageSceneResult:
    """What :func:`run` returns: the image, its metrics (``metrics.json``) and what made it."""

    image: SarImage
    metrics: dict
    pulses: PulseData  # range-compressed, along the true track
    scene: Scene
    autofocus: dict | None


def _ground(r0, h, side):
    return (1.0 if side == "right" else -1.0) * math.sqrt(r0**2 - h**2)


def pulse_track(p: ImageSceneParams) -> tuple[np.ndarray, np.ndarray]:
    """(pulse_times (P,), positions (P, 3) NED): straight and level, north, times centred on 0."""
    n = int(round(p.duration * p.radar.prf))
    t = p.radar.pulse_times(n, 0.0, n // 2)  # the radar's clock, pulse n // 2 at t = 0
    start = np.asarray(p.start_ned, dtype=np.float64)
    pos = np.zeros((n, 3))
    pos[:, 0] = start[0] + float(p.speed) * t
    pos[:, 1] = start[1]
    pos[:, 2] = start[2]
    return t, pos


def _ground_span(p: ImageSceneParams) -> list[float]:
    """Sorted east coordinates of the random patch's slant-range limits on the flat ground [m]."""
    e0, h, side = float(p.start_ned[1]), p.altitude, p.radar.look_side
    return sorted(e0 + _ground(float(r), h, side) for r in (p.slant_range_min, p.slant_range_max))


def _point(p: ImageSceneParams) -> np.ndarray:
    n0, e0 = (float(v) for v in p.start_ned[:2])
    return np.array([n0 + float(p.target_along_track),
                     e0 + _ground(p.target_slant_range, p.altitude, p.radar.look_side), 0.0])


def scene(p: ImageSceneParams) -> Scene:
    """The :class:`~sarnav.radar.scene.Scene` (random fields drawn from ``seed``)."""
    if p.scene == "point":
        return point_targets(list(_point(p)))
    rng = np.random.default_rng(np.random.SeedSequence(int(p.seed)))
    n0 = float(p.start_ned[0])
    half = 0.5 * float(p.along_track_extent)
    # homogeneous Poisson field on the flat ground (density per m^2 of ground)
    return random_scatterers(rng, ((n0 - half, n0 + half), tuple(_ground_span(p))), float(p.density), p.amplitude_law)


def scene_centre(p: ImageSceneParams) -> tuple[np.ndarray, tuple[float, float]]:
    """(NED centre of the imaged scene on the ground, (north, east) half sizes [m]) — the CPHD's scene reference
    point and image area (a point target: +-10 m about it)."""
    if p.scene == "point":
        return _point(p), (10.0, 10.0)
    g = _ground_span(p)
    return (np.array([float(p.start_ned[0]), 0.5 * (g[0] + g[1]), 0.0]),
            (0.5 * float(p.along_track_extent) + 5.0, 0.5 * (g[1] - g[0]) + 5.0))


def build_pulses(p: ImageSceneParams) -> tuple[PulseData, Scene]:
    """Simulate and range-compress the echoes: (range-compressed pulses along the true track, scene)."""
    t, pos = pulse_track(p)
    sc = scene(p)
    noisy = p.snr_db is not None
    rng = np.random.default_rng(np.random.SeedSequence([int(p.seed), 1])) if noisy else None
    raw = simulate_echoes(p.radar, pos, t, sc, snr_db=float(p.snr_db) if noisy else None, rng=rng,
                          pattern=bool(p.antenna_pattern))
    return range_compress(raw), sc


def form_image(p: ImageSceneParams, rc: PulseData) -> tuple[SarImage, dict | None]:
    """(SarImage, autofocus report or None): ``rc`` focused along the true straight track flown at the
    processor's speed :attr:`ImageSceneParams.focus_speed`."""
    return focus_straight_block(rc, p.focus_speed, np.asarray(p.start_ned, dtype=np.float64),
                                look_side=p.radar.look_side, algorithm=p.algorithm, window=p.window,
                                rcmc_kernel=p.rcmc_kernel, azimuth_model=p.azimuth_model, autofocus=p.autofocus,
                                bpa_interpolation=p.bpa_interpolation)


def image_metrics(p: ImageSceneParams, img: SarImage, sc: Scene, af: dict | None) -> dict:
    """The content of ``metrics.json``: image size and spacing, quality, autofocus, point-target figures against
    theory (``signal.metrics.point_target_report``)."""
    report = {"scenario": p.name, "algorithm": p.algorithm,
              "n_targets": int(sc.n_targets), "image_shape": list(img.shape),
              "pixel_spacing_m": {"along_track": img.dy, "slant_range": img.dx},
              "quality": quality.quality_summary(img.data)}
    if af is not None:
        report["autofocus"] = dict(af, speed_true=float(p.speed))
    if p.scene == "point":
        aperture = float(p.speed) * float(p.duration)
        report["point_target"] = point_target_report(
            img, float(p.target_along_track), float(p.target_slant_range), p.radar.bandwidth,
            p.radar.wavelength, aperture, p.radar.range_window, p.window)
    return report


def run(p: ImageSceneParams) -> ImageSceneResult:
    """Simulate the echoes, focus them and measure the image (module docstring)."""
    rc, sc = build_pulses(p)
    img, af = form_image(p, rc)
    return ImageSceneResult(img, image_metrics(p, img, sc, af), rc, sc, af)


def sicd_geometry(p: ImageSceneParams, img: SarImage, rc: PulseData):
    """The SICD geometry of a back-projected image (slant plane of the processor's straight track): its grid and the
    processor's antenna positions mapped from NED to ECEF at ``origin_llh``."""
    from sarnav.io.frames import grid_to_ecef, ned_to_ecef  # sarkit, imported when a file needs it
    from sarnav.io.sicd import SicdGeometry

    ref = [float(x) for x in p.origin_llh]
    m = img.metadata
    grid = grid_to_ecef(PlaneGrid(m["grid_origin"], m["grid_direction"], m["grid_normal"], img.y, img.x,
                                  img.y_name, img.x_name), ref)
    track = np.asarray(p.start_ned, dtype=np.float64) + rc.pulse_times[:, None] * [p.focus_speed, 0, 0]
    return SicdGeometry(grid, ned_to_ecef(track, ref), rc.pulse_times, p.radar.wavelength, p.radar.bandwidth)

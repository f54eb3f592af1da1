"""Scenes and geometry of the image-quality study (Hathaway 2023; notes/seed-004 §3.1, §4.6, §5, gaps 3-4, 18).

The thesis' simulated "USU" data set is raw echoes of a black-and-white picture whose black pixels are
unit scatterers (L375-381); neither the picture (Fig. 3.5) nor the radar parameters are published. Its real
data set (SDL, a FlexSAR flight near Logan, UT) gives only PRF = 1667 Hz (L650). Decisions (docs/quality.md):

* radar: the FlexSAR preset of this project (9.75 GHz, 500 MHz, fs = 500 MHz, PRF 5000/3 Hz, right-looking,
  0.0756 m antenna: 20 deg beam) with a 0.2 us chirp and a receive window around the scene;
* flight: 60 m/s north at 1000 m altitude (FlexSAR, NAVIGATION paper Table 6), scene centre 1760 m east
  of the track (slant 2024 m) abeam the middle pulse;
* picture: :func:`usu_picture`, the letters "USU" in a frame with a bar and a block, every black pixel a
  scatterer of amplitude 1 at its cell centre (no phase randomisation, no noise: gap 18 faithful reading);
* the image grid keeps the ground extent (``scene_extent``) fixed and varies the pixel count (gap 4).

All positions NED [m], float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError, InputDataError, require_positive
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams, pulse_clock, window_over
from sarnav.radar.presets import flexsar
from sarnav.radar.scene import Scene, random_scatterers

#: pulse repetition frequency of the thesis' SDL data (L650) and of the FlexSAR preset [Hz]
SOURCE_PRF = 5000.0 / 3.0

__all__ = ["SOURCE_PRF", "QualityGeometry", "usu_picture", "binary_scene", "point_clutter_scene",
           "textured_clutter_scene", "MAX_SCATTERERS", "simulate_pulses"]

# 5 x 7 glyphs of the picture ('#' black)
_GLYPHS = {
    "U": ("#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."),
    "S": (".####", "#....", "#....", ".###.", "....#", "....#", "####."),
}


def usu_picture(shape: tuple[int, int] = (24, 24)) -> np.ndarray:
    """(Ny, Nx) bool picture, True = black (illuminated): "USU" in a frame, a bar and a solid block below.

    Drawn on a 24 x 24 lattice and enlarged by nearest neighbour to ``shape`` (each >= 24).
    """
    ny, nx = (int(v) for v in shape)
    if ny < 24 or nx < 24:
        raise ConfigError("picture.shape", f"must be at least (24, 24), got {shape!r}")
    base = np.zeros((24, 24), dtype=bool)
    base[0, :] = base[-1, :] = base[:, 0] = base[:, -1] = True          # frame
    for i, letter in enumerate("USU"):
        glyph = np.array([[c == "#" for c in row] for row in _GLYPHS[letter]])
        base[3:10, 3 + 6 * i:8 + 6 * i] = glyph
    base[13, 3:21] = True                                                 # bar
    base[16:21, 4:9] = True                                               # solid block
    base[16:21, 12] = True                                                # vertical line
    base[np.arange(16, 21), np.arange(15, 20)] = True                     # diagonal
    rows = (np.arange(ny) * 24) // ny
    cols = (np.arange(nx) * 24) // nx
    return base[np.ix_(rows, cols)]


@dataclass(frozen=True)
class QualityGeometry:
    """Straight, level stripmap flight past a square scene (module docstring).

    Parameters
    ----------
    speed : platform speed [m/s]; altitude : [m]; ground_range : scene-centre ground range [m].
    n_pulses : number of pulses; the middle pulse is abeam the scene centre.
    scene_extent : side of the square imaged area [m].
    pulse_length : chirp length [s]; range_margin : receive window beyond the scene's ranges [m].
    """

    speed: float = 60.0
    altitude: float = 1000.0
    ground_range: float = 1760.0
    n_pulses: int = 4000
    scene_extent: float = 25.0
    pulse_length: float = 0.2e-6
    range_margin: float = 10.0

    def __post_init__(self):
        for name in ("speed", "altitude", "ground_range", "scene_extent", "pulse_length"):
            require_positive(f"geometry.{name}", getattr(self, name))
        if not math.isfinite(self.range_margin) or self.range_margin < 0:
            raise ConfigError("geometry.range_margin", f"must be finite and >= 0 m, got {self.range_margin!r}")
        n = self.n_pulses
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ConfigError("geometry.n_pulses", f"must be an integer >= 2, got {n!r}")
        if self.scene_extent >= self.ground_range:
            raise ConfigError("geometry.scene_extent", "must be smaller than the ground range")

    @property
    def prf(self) -> float:
        return SOURCE_PRF

    @property
    def along_track(self) -> np.ndarray:
        """Unit along-track direction e (north)."""
        return np.array([1.0, 0.0, 0.0])

    @property
    def cross_track(self) -> np.ndarray:
        """Unit horizontal cross-track direction towards the scene (east: right-looking, northbound)."""
        return np.array([0.0, 1.0, 0.0])

    @property
    def scene_center(self) -> np.ndarray:
        return np.array([0.0, self.ground_range, 0.0])

    def pulse_times(self) -> np.ndarray:
        """(P,) slow times [s], 0 at the first pulse."""
        return pulse_clock(self.n_pulses, SOURCE_PRF)

    def positions(self) -> np.ndarray:
        """(P, 3) true antenna positions, the middle pulse abeam the scene centre (north 0)."""
        t = self.pulse_times()
        p = np.zeros((t.size, 3))
        p[:, 0] = self.speed * (t - 0.5 * (t[0] + t[-1]))
        p[:, 2] = -self.altitude
        return p

    def grid_spacing(self, n: int) -> float:
        """Pixel spacing [m] of an n x n grid over the fixed extent (pixel centres inside the square)."""
        return self.scene_extent / int(n)

    def _slant_limits(self) -> tuple[float, float]:
        h = 0.5 * self.scene_extent
        half_track = 0.5 * self.speed * (self.n_pulses - 1) / SOURCE_PRF
        near = math.hypot(self.altitude, self.ground_range - h)
        far = math.sqrt(self.altitude**2 + (self.ground_range + h) ** 2 + (half_track + h) ** 2)
        return near, far

    def radar(self) -> RadarParams:
        """FlexSAR radar (PRF 5000/3 Hz) with the receive window around the scene for the whole track."""
        window = window_over(self._slant_limits(), self.pulse_length, 500e6, self.range_margin)  # flexsar's fs
        return flexsar(pulse_length=self.pulse_length, prf=SOURCE_PRF, **window)


def binary_scene(picture, center, extent: float, amplitude: complex = 1.0, down: float = 0.0) -> Scene:
    """One scatterer of ``amplitude`` at the centre of every True cell of ``picture`` (USU generation, L381).

    Row 0 of the picture is the northern edge; columns run west to east; the picture covers a square of
    side ``extent`` [m] centred on ``center`` (north, east[, down]).
    """
    pic = np.asarray(picture)
    if pic.ndim != 2 or pic.dtype != bool:
        raise InputDataError("picture", f"must be a 2-D bool array, got {pic.dtype} {pic.shape}")
    if not pic.any():
        raise InputDataError("picture", "has no black (True) pixel: the scene would be empty")
    extent = require_positive("extent", extent, "m")
    c = np.asarray(center, dtype=np.float64).ravel()
    if c.size < 2 or not np.all(np.isfinite(c)):
        raise InputDataError("center", f"must be a finite (north, east[, down]), got {center!r}")
    ny, nx = pic.shape
    cell_n, cell_e = extent / ny, extent / nx
    rows, cols = np.nonzero(pic)
    north = c[0] + 0.5 * extent - (rows + 0.5) * cell_n
    east = c[1] - 0.5 * extent + (cols + 0.5) * cell_e
    pos = np.column_stack([north, east, np.full(rows.size, float(down))])
    return Scene(pos, np.full(rows.size, complex(amplitude)))


def point_clutter_scene(rng: np.random.Generator, center, extent: float, n_points: int = 12,
                        point_to_clutter_db: float = 20.0, clutter_density: float = 1.0, down: float = 0.0) -> Scene:
    """Bright points (constant amplitude, random phase) over Rayleigh clutter, uniform over a square.

    Parameters
    ----------
    rng : Generator (one per scene); center : (north, east) [m]; extent : square side [m].
    n_points : number of bright points; point_to_clutter_db : |a_point|^2 over the clutter's mean power.
    clutter_density : clutter scatterers per m^2 (unit mean power, :func:`random_scatterers`).
    """
    if not isinstance(rng, np.random.Generator):
        raise ConfigError("rng", f"must be a numpy.random.Generator, got {type(rng).__name__}")
    extent = require_positive("extent", extent, "m")
    if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)) or n_points < 0:
        raise ConfigError("n_points", f"must be an integer >= 0, got {n_points!r}")
    c = np.asarray(center, dtype=np.float64).ravel()
    ext = ((c[0] - 0.5 * extent, c[0] + 0.5 * extent), (c[1] - 0.5 * extent, c[1] + 0.5 * extent))
    clutter = random_scatterers(rng, ext, clutter_density, "rayleigh", 1.0, down)
    u = rng.random((n_points, 2))
    pos = np.column_stack([ext[0][0] + 0.1 * extent + 0.8 * extent * u[:, 0],
                           ext[1][0] + 0.1 * extent + 0.8 * extent * u[:, 1], np.full(n_points, float(down))])
    amp = 10.0 ** (point_to_clutter_db / 20.0) * np.exp(2j * np.pi * rng.random(n_points))
    return Scene(pos, amp) + clutter


#: the most scatterers a generated scene may draw (memory and echo time stay bounded whatever the density asked)
MAX_SCATTERERS = 1_000_000


def textured_clutter_scene(rng: np.random.Generator, center, extent: float, contrast_db: float = 3.0,
                           correlation_m: float = 1.0, density: float = 32.0, down: float = 0.0) -> Scene:
    """Distributed clutter with a low-contrast texture and no dominant scatterer, like the sea ice of the BYU data
    where Hathaway (2023, L388, L636) saw entropy fail (claim T16).

    Poisson(``density`` x area) scatterers, uniform over the square, each circular Gaussian with mean power
    ``10^(contrast_db g / 10)`` at its position: g a white Gaussian field smoothed by a Gaussian kernel of std
    ``correlation_m`` and scaled to unit std, sampled on cells of ``correlation_m`` / 4 (a log-normal texture whose
    log-power has a std of ``contrast_db`` dB). ``contrast_db`` = 0: fully developed speckle over a uniform surface.
    The default 32 per m^2 puts 2.4 scatterers in the quality geometry's 0.22 m x 0.35 m resolution cell: each pixel
    is circular Gaussian, but the Poisson count per cell is a fine texture of its own that a focused image resolves
    (docs/quality.md "T16 on distributed scenes"); ~128 per m^2 (9.5 a cell) leaves the speckle without it.

    Parameters
    ----------
    rng : Generator (one per scene); center : (north, east) [m]; extent : square side [m].
    contrast_db : std of the texture's log-power [dB] (>= 0); correlation_m : its correlation length [m] (> 0).
    density : scatterers per m^2 (> 0; at most :data:`MAX_SCATTERERS` in the square).
    """
    from scipy import ndimage

    if not isinstance(rng, np.random.Generator):
        raise ConfigError("rng", f"must be a numpy.random.Generator, got {type(rng).__name__}")
    extent = require_positive("extent", extent, "m")
    if isinstance(contrast_db, bool) or not isinstance(contrast_db, (int, float, np.integer, np.floating)) \
            or not (math.isfinite(contrast_db) and contrast_db >= 0):
        raise ConfigError("contrast_db", f"must be a finite number >= 0 dB, got {contrast_db!r}")
    correlation_m = require_positive("correlation_m", correlation_m, "m")
    density = require_positive("density", density, "per m^2")
    if density * extent * extent > MAX_SCATTERERS:
        raise ConfigError("density", f"asks for {density * extent * extent:.3g} scatterers over the "
                          f"{extent:g} m square; at most {MAX_SCATTERERS} (density <= {MAX_SCATTERERS / extent**2:.3g} per m^2)")
    c = np.asarray(center, dtype=np.float64).ravel()
    if c.size < 2 or not np.all(np.isfinite(c[:2])):
        raise InputDataError("center", f"must be a finite (north, east[, down]), got {center!r}")
    n_cells = max(1, int(math.ceil(4.0 * extent / correlation_m)))
    if n_cells > 4096:
        raise ConfigError("correlation_m", f"must be >= extent / 1024 = {extent / 1024:g} m (a texture grid of at "
                          f"most 4096 cells a side), got {correlation_m!r}")
    g = ndimage.gaussian_filter(rng.standard_normal((n_cells, n_cells)), n_cells * correlation_m / extent, mode="wrap")
    g = (g - g.mean()) / g.std() if g.std() > 0 else np.zeros_like(g)
    power = 10.0 ** (float(contrast_db) * g / 10.0)
    n = int(rng.poisson(density * extent * extent))
    u = rng.random((n, 2))
    pw = power[np.minimum((u[:, 0] * n_cells).astype(int), n_cells - 1),
               np.minimum((u[:, 1] * n_cells).astype(int), n_cells - 1)]
    amp = np.sqrt(0.5 * pw) * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    pos = np.column_stack([c[0] + (u[:, 0] - 0.5) * extent, c[1] + (u[:, 1] - 0.5) * extent, np.full(n, float(down))])
    return Scene(pos, amp)


def simulate_pulses(geometry: QualityGeometry, scene: Scene, snr_db: float | None = None,
                    rng: np.random.Generator | None = None):
    """Raw echoes (``PulseData``, uncompressed) of ``scene`` along the geometry's true track (radar.echoes)."""
    return simulate_echoes(geometry.radar(), geometry.positions(), geometry.pulse_times(), scene, snr_db=snr_db,
                           rng=rng)

"""The spacecraft SAR measurement made from simulated raw echoes (issue 11 closed loop; Pogorelsky et al. 2022
§III-IV with ALOS-like L-band data simulated instead of the paper's real PALSAR data).

Per update k at the image time t_m (zero-Doppler time of the centre azimuth line), shared by every run (one world,
one true orbit):

1. **Chip** (:meth:`SpacecraftImager.chip`): the true antenna boresight (zero-Doppler steering, gap G3/G9) meets the
   synthetic terrain (``radar.terrain``: DEM + clutter + bright scatterers) at r_b; the receive window is centred on
   its slant range rho_c (the instrument's timing; this realises the paper's premise that the centre pixel lies on
   the boresight, L311); noise-free raw echoes (``radar.echoes``, numba) along the **true** orbit (RK4 at the PRF) of
   this pass and of an earlier pass (the reference: clutter with coherence ``coherence``, its own receiver noise;
   over the same track, or across it with an off-nadir angle ``reference_look_offset`` larger at the scene centre,
   :func:`reference_shift`, its clutter's backscatter from its own look), the reference focused with its true
   effective velocity and geocoded onto a map grid with its true orbit and the DEM (``imaging.geocode``).
2. **Image** (:meth:`SpacecraftImager.measure`, per run): receiver noise from the run's generator, range compression,
   RDA (hyperbolic, zero squint) with the processor velocity; the hill-climbing autofocus (``imaging.hill_climb``,
   Algorithm 1 with step 1 m/s then refined) starts from the **estimated** effective velocity V_r(r^, v^; r^_f)
   (``measurements.spacecraft.effective_velocity``, G9) and maximises the normalised variance (eq. 3) of the focused
   chip: v_ic = the best velocity.
3. **Geolocation**: the focused amplitude (2 azimuth looks) is registered to the reference by ORB/SIFT + RANSAC affine
   (``imaging.feature_registration``; >= 3 inliers or no update, T11) or by area correlation of the image geocoded
   with the navigation estimate; the centre pixel maps to a reference cell -> (lat, lon), height from the DEM
   (bilinear) -> r_f (ECEF). The slant range is rho_c from the receive window plus N(0, sigma_range^2) (the paper adds
   Gaussian noise to its ranges, L476).

Truth enters only the simulated world (terrain, true orbit, the instrument's window); the measurement is what the
image gives. The errors against the truth (v_ic - V_r, r_f - r_b) are returned for the records, never to the filter.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage
from scipy.optimize import brentq

from sarnav.errors import ConfigError, InputDataError
from sarnav.frames.earth import ecef_to_eci, eci_to_ecef, ecef_to_geodetic, geodetic_to_ecef
from sarnav.frames.gravity import local_gravity
from sarnav.frames.wgs84 import ned_to_ecef_dcm
from sarnav.imaging.feature_registration import correlation_shift, feature_affine
from sarnav.imaging.geocode import OrbitArc, geocode, image_coordinates
from sarnav.imaging.hill_climb import hill_climb
from sarnav.imaging.quality import normalised_variance
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.rda import range_doppler
from sarnav.measurements.spacecraft import boresight_intersection, effective_velocity
from sarnav.radar.echoes import add_receiver_noise, simulate_echoes
from sarnav.radar.params import RadarParams, pulse_clock
from sarnav.radar.scene import Scene
from sarnav.radar.terrain import TerrainScene, map_grid_around, synthetic_terrain, terrain_scene
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory.orbit import body_dcm, propagate_rk4_eci
from sarnav.units import C

__all__ = ["ImagingConfig", "Chip", "ImageMeasurement", "SpacecraftImager", "terrain_intersection", "STAGES",
           "REGISTRATIONS", "reference_shift"]

STAGES = ("echoes", "focusing", "autofocus", "registration")
#: area correlation: accept the shift when the phase-correlation error 1 - |peak|^2 / (|a| |b|) is below this
CORRELATION_MAX_ERROR = 0.9
#: footprint speed used to size the image rows kept [m/s] (|v| R_e / |r| at 691 km)
GROUND_SPEED = 6.86e3
REGISTRATIONS = ("orb", "sift", "correlation")


@dataclass(frozen=True)
class ImagingConfig:
    """Radar, scene, autofocus and registration settings (SI units; defaults = the scenario's, docs/spacecraft.md)."""

    carrier_frequency: float = 1.27e9
    bandwidth: float = 28e6
    pulse_length: float = 1e-6
    sample_rate: float = 32e6
    prf: float = 2200.0
    range_samples: int = 384
    antenna_length: float = 8.9
    block: float = 2.0
    snr_db: float = -15.0
    seed: int = 11
    relief: float = 60.0
    clutter_spacing: float = 40.0
    n_bright: int = 15
    bright_amplitude: float = 8.0
    coherence: float = 0.7
    half_along: float = 900.0
    half_range: float = 650.0
    map_spacing: float = 7.5
    step: float = 1.0
    max_iter: int = 60
    refine: tuple = (0.5, 0.25)
    registration: str = "orb"
    min_inliers: int = 6
    smoothing: float = 1.0
    residual_px: float = 2.0
    reference_look_offset: float = 0.0

    def __post_init__(self):
        if self.registration not in REGISTRATIONS:
            raise ConfigError("registration.method", f"must be one of {REGISTRATIONS}, got {self.registration!r}")
        if not (isinstance(self.range_samples, int) and 128 <= self.range_samples <= 4096):
            raise ConfigError("radar.range_samples", f"must be an integer in [128, 4096], got {self.range_samples!r}")

    @property
    def pulses(self) -> int:
        return 2 * int(round(self.block * self.prf / 2))

    @property
    def dr(self) -> float:
        return C / (2.0 * self.sample_rate)


@dataclass
class Chip:
    """The world of one update: true r, v at t_m, block times and ECEF antenna positions, terrain and scene, true
    centre pixel r_b and its range rho_c, radar parameters, noise-free echoes of this pass, the reference map, the
    true effective velocity V_r, the seconds spent."""

    t_m: float
    r: np.ndarray
    v: np.ndarray
    t: np.ndarray
    positions: np.ndarray
    terrain: object
    scene: TerrainScene
    r_b: np.ndarray
    rho_c: float
    params: RadarParams
    raw: object
    reference: np.ndarray
    v_r: float
    seconds: float


@dataclass
class ImageMeasurement:
    """One image's measurement: ok (False: no update, e.g. < min_inliers), v_ic [m/s], r_f (3,) [m], rho [m] (before
    the added range noise), n_inliers, seconds per stage (STAGES), the autofocus evaluations, v0 [m/s]."""

    ok: bool
    v_ic: float
    r_f: np.ndarray
    rho: float
    n_inliers: int
    seconds: np.ndarray
    visited: list = field(default_factory=list)
    v0: float = float("nan")
    capture: dict | None = None


def _height_above_terrain(r, u, terrain, s: float) -> tuple[float, np.ndarray]:
    """(h_geodetic - h_DEM at r + s u [m], the local up unit vector (3,))."""
    lat, lon, h = ecef_to_geodetic(r + s * u)
    return float(h - terrain.height(lat, lon)), ned_to_ecef_dcm(lat, lon)[:, 2] * -1.0


def terrain_intersection(r, u, terrain, iterations: int = 12, tolerance: float = 1e-6):
    """First point (3,) where the ray r + s u (ECEF, |u| = 1) meets the terrain surface (DEM over WGS-84): from the
    ellipsoid intersection, Newton on s for f(s) = h_geodetic(p) - h_DEM(p) = 0 with the ray's height rate u . up
    (the DEM's slope left out: exact on flat ground, converging on gentle slopes); when that has not reached
    ``tolerance`` [m] after ``iterations`` (slopes beyond ~45 deg), the secant method on f, which takes the slope
    in, from the last two iterates. Raises ``InputDataError`` if neither converges."""
    r, u = np.asarray(r, float), np.asarray(u, float)
    p = boresight_intersection(r[None], np.asarray([[0, 0, 0], [0, 0, 0], u], float)[None])[0]
    s = float(np.linalg.norm(p - r))
    prev = None
    for _ in range(iterations):
        f, up = _height_above_terrain(r, u, terrain, s)
        prev, s = (s, f), s - f / float(u @ up)
        if abs(f) < tolerance:  # the step that found it converged is kept (the point moves by < tolerance)
            return r + s * u
    f, _ = _height_above_terrain(r, u, terrain, s)
    for _ in range(4 * iterations):  # secant continuation
        if abs(f) < tolerance:
            return r + s * u
        (s0, f0), prev = prev, (s, f)
        if f == f0:
            break
        s = s - f * (s - s0) / (f - f0)
        f, _ = _height_above_terrain(r, u, terrain, s)
    if abs(f) < tolerance:
        return r + s * u
    raise InputDataError("terrain", f"the line of sight does not meet the terrain to {tolerance:g} m "
                         f"(|h - h_DEM| = {abs(f):.3g} m after {5 * iterations} iterations)")


def reference_shift(r, v, r_b, look_offset: float) -> np.ndarray:
    """(3,) ECEF displacement of the reference pass from this one, across the track (the horizontal direction
    from r towards the scene point r_b, normal to v), so that the reference sees r_b at an off-nadir angle
    ``look_offset`` [rad] larger than this pass does (0: the same track, zero vector). A rigid shift of a 2-s arc
    stands for a neighbouring orbit (issue 29: a repeat pass with a different look angle)."""
    if look_offset == 0.0:
        return np.zeros(3)
    r, v, r_b = (np.asarray(x, float) for x in (r, v, r_b))
    basis = np.linalg.qr(np.stack([r, v], axis=1))[0]  # orthonormal span of r and v
    n = (r_b - r) - basis @ (basis.T @ (r_b - r))
    d = float(np.linalg.norm(n))  # horizontal distance from the track to the scene
    n /= d

    def off_nadir(s):
        p = r + s * n
        los = r_b - p
        return math.acos(float(-p @ los) / (np.linalg.norm(p) * np.linalg.norm(los)))

    want = off_nadir(0.0) + look_offset
    if not off_nadir(0.9 * d) < want < off_nadir(-d):
        raise ConfigError("terrain.reference_look_offset_deg", f"an off-nadir angle of {math.degrees(want):.1f} deg is "
                          f"beyond this geometry's reach ({math.degrees(off_nadir(0.9 * d)):.1f} to "
                          f"{math.degrees(off_nadir(-d)):.1f} deg)")
    return brentq(lambda s: off_nadir(s) - want, -d, 0.9 * d, xtol=1e-3) * n


class SpacecraftImager:
    """The closed loop's image chain (module docstring). ``orbit``: ``trajectory.orbit.OrbitTruth`` (ECEF on its
    grid); ``T_bs``: body -> nominal antenna; ``steering``: the body attitude law."""

    def __init__(self, cfg: ImagingConfig, orbit, T_bs, steering: str = "zero-doppler"):
        self.cfg, self.orbit, self.T_bs, self.steering = cfg, orbit, np.asarray(T_bs, float), steering
        self._chips: dict = {}

    def _block(self, t_m: float):
        k = int(self.orbit.index(t_m))
        r, v = self.orbit.r[k], self.orbit.v[k]
        P, prf = self.cfg.pulses, self.cfg.prf
        ri, vi = ecef_to_eci(t_m, r, v)  # the ECI frame of t = 0: propagate both ways at the PRF
        fwd = propagate_rk4_eci(ri, vi, 1.0 / prf, P // 2)
        bwd = propagate_rk4_eci(ri, vi, -1.0 / prf, P // 2)
        r_i = np.concatenate([bwd[0][:0:-1], fwd[0][:-1]])
        v_i = np.concatenate([bwd[1][:0:-1], fwd[1][:-1]])
        t = pulse_clock(P, prf, t_m, P // 2)
        pos, _ = eci_to_ecef(t, r_i, v_i)
        return r, v, t, pos

    def chip(self, update: int, t_m: float) -> Chip:
        """The shared world of update ``update`` at t_m (cached)."""
        if update not in self._chips:
            self._chips[update] = self._make_chip(update, t_m)
        return self._chips[update]

    def _make_chip(self, update: int, t_m: float) -> Chip:
        t0 = time.perf_counter()
        c = self.cfg
        r, v, t, pos = self._block(t_m)
        T_es = self.T_bs @ body_dcm(r, v, self.steering)  # true misalignment = identity (G17)
        rng = np.random.default_rng(np.random.SeedSequence([c.seed, 1, update]))
        lat0, lon0, _ = ecef_to_geodetic(boresight_intersection(r[None], T_es[None])[0])
        grid = map_grid_around(float(lat0), float(lon0), c.half_along + 900.0, c.half_range / 0.55 + 900.0,
                               c.map_spacing)
        terrain = synthetic_terrain(grid, rng, c.relief)
        r_b = terrain_intersection(r, T_es[2], terrain)
        rho = float(np.linalg.norm(r_b - r))
        shift = reference_shift(r, v, r_b, c.reference_look_offset)
        scene = self._scene(terrain, rng, r, v, r_b, rho, r + shift if c.reference_look_offset else None)
        params = RadarParams(c.carrier_frequency, c.bandwidth, c.pulse_length, c.sample_rate, c.prf,
                             rho - (c.range_samples // 2) * c.dr, c.range_samples, antenna_length=c.antenna_length,
                             look_side="right")
        lat, lon, _ = ecef_to_geodetic(r_b)
        Cn = ned_to_ecef_dcm(lat, lon)
        pos_ned = (pos - r_b) @ Cn
        raw = simulate_echoes(params, pos_ned, t, Scene(scene.local(r_b, lat, lon), scene.amplitude))
        v_r = float(effective_velocity(r[None], v[None], r_b[None])[0][0])
        reference = self._reference(update, t, pos + shift, r + shift, v, r_b, (lat, lon, Cn), scene, grid, terrain)
        return Chip(t_m, r, v, t, pos, terrain, scene, r_b, rho, params, raw, reference, v_r,
                    time.perf_counter() - t0)

    def _reference(self, update, t, pos_ref, r_ref, v, r_b, local, scene, grid, terrain) -> np.ndarray:
        """The reference map: the earlier pass (antenna positions ``pos_ref`` (P, 3) ECEF, ``r_ref`` at t_m, its
        receive window centred on its own range to r_b; ``local`` = (lat, lon, C_n^e) of r_b) echoes the scene's
        reference amplitudes, is focused with its true effective velocity and geocoded with its true orbit arc and
        the DEM."""
        c = self.cfg
        lat, lon, Cn = local
        params = RadarParams(c.carrier_frequency, c.bandwidth, c.pulse_length, c.sample_rate, c.prf,
                             float(np.linalg.norm(r_b - r_ref)) - (c.range_samples // 2) * c.dr, c.range_samples,
                             antenna_length=c.antenna_length, look_side="right")
        try:
            raw = simulate_echoes(params, (pos_ref - r_b) @ Cn, t, Scene(scene.local(r_b, lat, lon), scene.reference))
        except ConfigError as err:  # a shallower look spreads the scene over more slant range
            raise ConfigError("terrain.reference_look_offset_deg", f"the reference pass's receive window cannot hold "
                              f"the scene from {math.degrees(c.reference_look_offset):+g} deg ({err.message})") from None
        v_r = float(effective_velocity(r_ref[None], v[None], r_b[None])[0][0])
        noisy = add_receiver_noise(raw, 1.0, c.snr_db, np.random.default_rng([c.seed, 2, update]))
        img = np.abs(range_doppler(range_compress(noisy), speed=v_r, azimuth_model="hyperbolic").data)
        return geocode(img, t[0], c.prf, params.near_range, c.dr, OrbitArc.fit(t, pos_ref, t[len(t) // 2]), grid,
                       terrain)

    def _scene(self, terrain, rng, r, v, r_b, rho, r_ref) -> TerrainScene:
        c = self.cfg
        g = terrain.grid
        sc = terrain_scene(terrain, rng, r, c.clutter_spacing, (0, g.shape[0] - 1, 0, g.shape[1] - 1), 4 * c.n_bright,
                           c.bright_amplitude, c.coherence, reference_ecef=r_ref)
        along = (sc.positions - r_b) @ (v / np.linalg.norm(v))
        keep = (np.abs(np.linalg.norm(sc.positions - r, axis=1) - rho) < c.half_range) & (np.abs(along) < c.half_along)
        keep_b = np.flatnonzero(keep & sc.bright)[: c.n_bright]
        keep = keep & ~sc.bright
        keep[keep_b] = True
        return TerrainScene(sc.positions[keep], sc.amplitude[keep], sc.reference[keep], sc.bright[keep])

    # --- per run ------------------------------------------------------------------------------------------
    def initial_velocity(self, chip: Chip, r_hat, v_hat, q_mu_hat) -> float:
        """The processor's starting velocity: V_r of the estimate at its own predicted centre pixel (the estimated
        boresight, T^_mu T_b^s T_e^b, on the ellipsoid)."""
        T_es = quat_to_dcm(q_mu_hat) @ self.T_bs @ body_dcm(chip.r, chip.v, self.steering)  # ADS attitude (perfect)
        rf_hat = boresight_intersection(np.asarray(r_hat)[None], T_es[None])
        return float(effective_velocity(np.asarray(r_hat)[None], np.asarray(v_hat)[None], rf_hat)[0][0])

    def focus(self, chip: Chip, rng: np.random.Generator):
        """Range-compressed pulses of this run's acquisition (receiver noise from ``rng``)."""
        return range_compress(add_receiver_noise(chip.raw, 1.0, self.cfg.snr_db, rng))

    def image(self, rc, speed: float, crop_range: bool = False):
        """|RDA image| rows of the scene (t_m +- the scene's along-track half-length), all or the central half of the
        range bins."""
        c = self.cfg
        if crop_range:
            a, b = c.range_samples // 4, 3 * c.range_samples // 4
            rc = replace(rc, data=rc.data[:, a:b], slant_range=rc.slant_range[a:b])
        img = range_doppler(rc, speed=speed, azimuth_model="hyperbolic").data
        h = self.rows_half()
        P = c.pulses
        return np.abs(img[P // 2 - h:P // 2 + h])

    def rows_half(self) -> int:
        c = self.cfg
        return 2 * int(math.ceil((c.half_along + 150.0) / GROUND_SPEED * c.prf / 2))

    def measure(self, chip: Chip, r_hat, v_hat, q_mu_hat, rng, capture: bool = False) -> ImageMeasurement:
        """One run's image measurement from the estimate (module docstring); ``rng``: receiver noise + RANSAC."""
        sec = np.zeros(len(STAGES))
        sec[0] = chip.seconds  # the shared world (echoes of both passes, reference) of this update
        t0 = time.perf_counter()
        rc = self.focus(chip, rng)
        sec[1] += time.perf_counter() - t0
        v0 = self.initial_velocity(chip, r_hat, v_hat, q_mu_hat)
        t0 = time.perf_counter()
        hc = hill_climb(lambda s: normalised_variance(self.image(rc, s, crop_range=True)), v0, self.cfg.step,
                        self.cfg.max_iter, self.cfg.refine)
        sec[2] = time.perf_counter() - t0
        t0 = time.perf_counter()
        amp = self.image(rc, hc.best)
        sec[1] += time.perf_counter() - t0
        t0 = time.perf_counter()
        r_f, n_in, cap = self._geolocate(chip, amp, r_hat, v_hat, int(rng.integers(2**31)))
        sec[3] = time.perf_counter() - t0
        cap = (dict(cap, amplitude=amp, visited=hc.visited) if capture and cap is not None else None)
        return ImageMeasurement(r_f is not None, hc.best, np.full(3, np.nan) if r_f is None else r_f, chip.rho_c,
                                n_in, sec, hc.visited, v0, cap)

    def _geolocate(self, chip: Chip, amp, r_hat, v_hat, seed: int):
        """(r_f or None, inliers, capture) of the centre pixel from the focused amplitude ``amp`` (scene rows)."""
        c = self.cfg
        h = self.rows_half()
        looks = amp.reshape(h, 2, amp.shape[1]).mean(axis=1)  # 2 azimuth looks: ~6 m x 7.7 m ground cells
        centre = ((h - 0.5) / 2.0, c.range_samples / 2.0)  # full row h (t_m) -> look row (h - 0.5) / 2; bin N/2
        if c.registration == "correlation":
            ref_rc, n_in, cap = self._correlate(chip, amp, r_hat, v_hat)
        else:
            a = ndimage.gaussian_filter(looks, c.smoothing) if c.smoothing > 0 else looks
            b = ndimage.gaussian_filter(chip.reference, c.smoothing) if c.smoothing > 0 else chip.reference
            m = feature_affine(a, b, c.registration, c.min_inliers, residual_threshold=c.residual_px, seed=seed)
            if m is None:
                return None, 0, None
            ref_rc = m.apply(np.array([centre[0]]), np.array([centre[1]]))
            n_in = m.n_inliers
            cap = {"looks": looks, "reference": chip.reference, "src": m.src, "dst": m.dst, "inliers": m.inliers,
                   "centre": centre, "centre_reference": (float(ref_rc[0][0]), float(ref_rc[1][0]))}
        if ref_rc is None:
            return None, n_in, None
        lat, lon = chip.terrain.grid.latlon(ref_rc[0], ref_rc[1])
        return geodetic_to_ecef(lat, lon, chip.terrain.height(lat, lon)).reshape(3), n_in, cap

    def _correlate(self, chip: Chip, amp, r_hat, v_hat):
        """Area correlation: geocode the image with the estimated orbit arc, phase-correlate with the reference, move
        the estimate's centre-pixel cell by the shift."""
        c = self.cfg
        h = self.rows_half()
        t_first = chip.t_m - h / c.prf
        a_hat = local_gravity(np.asarray(r_hat)[None])[0] - 2.0 * np.cross([0.0, 0.0, 7.292115e-5], v_hat)
        arc = OrbitArc.from_state(chip.t_m, r_hat, v_hat, a_hat)
        grid, terrain = chip.terrain.grid, chip.terrain
        est = geocode(amp, t_first, c.prf, chip.params.near_range, c.dr, arc, grid, terrain)
        if not np.any(est > 0):
            return None, 0, None
        d_row, d_col, err = correlation_shift(est, chip.reference)
        i, j = np.meshgrid(np.arange(0, grid.shape[0], 8), np.arange(0, grid.shape[1], 8), indexing="ij")
        lat, lon = grid.latlon(i, j)
        p = geodetic_to_ecef(lat, lon, terrain.height(lat, lon)).reshape(-1, 3)
        row, col = image_coordinates(arc, p, t_first, c.prf, chip.params.near_range, c.dr)
        A = np.column_stack([row, col, np.ones(row.size)])  # cell (i, j) as an affine function of image (row, col)
        coef, *_ = np.linalg.lstsq(A, np.column_stack([i.ravel(), j.ravel()]), rcond=None)
        ci, cj = np.array([h, c.range_samples / 2.0, 1.0]) @ coef
        cap = {"looks": est, "reference": chip.reference, "src": np.empty((0, 2)), "dst": np.empty((0, 2)),
               "inliers": np.empty(0, bool), "centre": (ci, cj), "centre_reference": (ci + d_row, cj + d_col)}
        if not err < CORRELATION_MAX_ERROR:  # no correlation peak: no update
            return None, 0, None
        return (np.array([ci + d_row]), np.array([cj + d_col])), 1, cap


"""Image-derived SAR measurements: from echoes to the time and range of closest approach of a reference target.

The extractor of the image-aided flight (NAVIGATION paper §3-4; docs/scenarios/rda-nav.md §1-§2), typed to nothing
but radar parameters, a truth trajectory to fly the echoes along, the reference targets, a scene factory and seeds.

Per sub-aperture u (pulses ``u + k / prf``, k < round(prf), i.e. one second of pulses):
  the scene (``scene_for(u, clutter_seed)``) is imaged by noise-free echoes along the *true* track; two
  acquisitions of it differ only in their receiver noise (``snr_db``: per-sample SNR of a scatterer of amplitude
  ``reflector_amplitude``, ``radar.echoes.add_receiver_noise``): the *reference pass*, an RDA image focused with
  the true track of which a chip around the reference target is kept with the target's position inside the chip
  (its geolocation), and the *in-flight pass*, with the run's own noise. Only the chip's pattern and that anchor
  are used: the in-flight time axis is never taken from the reference.
Per run:
  range compression of the in-flight pass; RDA + mapdrift (paper eqs. 14-16) with the *estimated* speed, restricted
  to a slant-range window around the range the estimate predicts (thesis eq. 4.41); the chip is searched in that
  image by 2-D correlation (paper eq. 46, magnitudes, sub-pixel); the anchor lands at the measured TOC eta0
  (row -> pulse time) and range R0 (column -> slant range). Both come from radar timing only.

Seeds (keys of ``SeedSequence``): clutter drawn per run (``clutter_seeds`` given) or once for all runs
(``reference_seed``, cached); reference-pass noise ``[clutter seed or reference_seed, 3, u]``; in-flight noise
``[noise_seeds[r], 4, u]``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from sarnav.errors import InputDataError
from sarnav.imaging.autofocus import mapdrift
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.rda import range_doppler
from sarnav.imaging.registration import register
from sarnav.radar.echoes import add_receiver_noise, simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import Scene
from sarnav.trajectory.base import Trajectory
from sarnav.trajectory.sampled import closest_approach, closest_sample_is_inside

__all__ = ["STAGES", "ImagingSettings", "ApertureMeasurements", "SubApertureImager"]

#: stages timed per image (seconds per run and aperture, ``ApertureMeasurements.seconds``)
STAGES = ("echoes", "rda", "autofocus", "registration")


@dataclass(frozen=True)
class ImagingSettings:
    """Chip, search window, autofocus and registration settings (defaults: docs/scenarios/rda-nav.md §1).

    chip_half_az_cells : chip half-size along track in azimuth resolution cells (lambda R / (2 V T)).
    chip_half_range_m : chip half-size in slant range [m].
    search_half_range_m : slant-range half-window of the in-flight image around the predicted range [m].
    mapdrift_iterations : look correlations of mapdrift (the paper's single pass, G12).
    mapdrift_gate_sigma, mapdrift_gate_floor : a mapdrift correction implying a speed change beyond this many
        filter sigmas of the forward speed (or the floor [m/s]) is rejected and the image focused with the
        estimated speed is used (a sparse scene's look correlation can be biased by scatterers seen in one look).
    subpixel : sub-pixel method of the chip registration ("parabola": the upsampled-DFT refinement costs 25-60 ms
        per call on 2 cores when OpenBLAS runs multi-threaded small complex matmuls).
    """

    chip_half_az_cells: float = 1.5
    chip_half_range_m: float = 4.0
    search_half_range_m: float = 12.0
    mapdrift_iterations: int = 1
    mapdrift_gate_sigma: float = 3.0
    mapdrift_gate_floor: float = 0.02
    subpixel: str = "parabola"


@dataclass
class ApertureMeasurements:
    """What one sub-aperture gives for R runs.

    toc : (R,) measured time of closest approach [s]; range : (R,) measured range of closest approach [m];
    autofocus_dk : (R,) mapdrift FM-rate correction [Hz/s]; seconds : (R, len(STAGES)) time per stage;
    capture : images of the first run when asked (reference, before / after autofocus, correlation surface).
    """

    toc: np.ndarray
    range: np.ndarray
    autofocus_dk: np.ndarray
    seconds: np.ndarray
    capture: dict | None = None


def _crop_range(rc, r_lo, r_hi):
    r = rc.slant_range
    a = max(int(np.searchsorted(r, r_lo)), 0)
    b = min(int(np.searchsorted(r, r_hi)), r.size)
    if b - a < 16:
        raise InputDataError("sar", f"predicted range window [{r_lo:.1f}, {r_hi:.1f}] m lies outside the receive window")
    return replace(rc, data=rc.data[:, a:b], slant_range=r[a:b])


@dataclass
class SubApertureImager:
    """Makes the image-derived TOC and range of each sub-aperture's reference target for a batch of runs.

    Parameters
    ----------
    radar : the radar (its PRF sets the pulses of a one-second sub-aperture).
    truth : the true trajectory, along which the echoes are simulated (the sensor, not the filter).
    speed : the true ground speed [m/s] (reference pass focusing).
    targets : (U, 3) reference target of each sub-aperture (NED, m).
    scene_for : ``(u, clutter_seed or None) -> Scene`` of sub-aperture u (reference target included).
    reflector_amplitude, snr_db : receiver noise definition (``radar.echoes``).
    reference_seed : key of the shared scene's noise when the clutter is the same for every run.
    clutter_seeds : one per run (clutter redrawn per run) or None (one scene for all runs, cached).
    noise_seeds : one per run (in-flight receiver noise).
    settings : :class:`ImagingSettings`.
    capture_aperture : keep the images of this sub-aperture of the first run (figures), or None.
    """

    radar: RadarParams
    truth: Trajectory
    speed: float
    targets: np.ndarray
    scene_for: Callable[[int, int | None], Scene]
    reflector_amplitude: float
    snr_db: float
    reference_seed: int
    noise_seeds: list
    clutter_seeds: list | None = None
    settings: ImagingSettings = field(default_factory=ImagingSettings)
    capture_aperture: int | None = None

    def __post_init__(self):
        self.targets = np.asarray(self.targets, dtype=np.float64)
        self.n_pulses = int(round(self.radar.prf))
        self.noise_seeds = [int(s) for s in self.noise_seeds]
        self.clutter_seeds = None if self.clutter_seeds is None else [int(s) for s in self.clutter_seeds]
        if self.clutter_seeds is not None and len(self.clutter_seeds) != len(self.noise_seeds):
            raise InputDataError("clutter_seeds", f"need one per run: {len(self.clutter_seeds)} for "
                                 f"{len(self.noise_seeds)} runs")
        self._cache: dict[tuple, dict] = {}

    def _noisy(self, raw, key):
        """Range-compressed copy of the noise-free echoes ``raw`` with receiver noise from ``key``: one acquisition."""
        rng = np.random.default_rng(np.random.SeedSequence(key))
        return range_compress(add_receiver_noise(raw, self.reflector_amplitude, self.snr_db, rng))

    def aperture(self, u: int, clutter_seed: int | None = None) -> dict:
        """Noise-free echoes of sub-aperture u and its reference chip (cached when the scene is shared)."""
        if (u, clutter_seed) in self._cache:
            return self._cache[(u, clutter_seed)]
        t0 = time.perf_counter()
        st = self.settings
        times = u + np.arange(self.n_pulses) / self.radar.prf
        truth = self.truth.state(times)
        raw = simulate_echoes(self.radar, truth.position, times, self.scene_for(u, clutter_seed))
        key = [self.reference_seed, 3, u] if clutter_seed is None else [clutter_seed, 3, u]
        rc_ref = self._noisy(raw, key)
        targ = self.targets[u]
        eta_ref, r_ref, _ = closest_approach(targ, times, truth.position)
        ref = range_doppler(_crop_range(rc_ref, r_ref - st.search_half_range_m, r_ref + st.search_half_range_m),
                            self.speed)
        prf = self.radar.prf
        fi = (eta_ref - times[0]) * prf
        fj = (r_ref - ref.x[0]) / ref.dx
        i0, j0 = int(round(fi)), int(round(fj))
        res_az = self.radar.wavelength * r_ref / (2 * self.speed * self.n_pulses / prf)
        hi = min(self.n_pulses // 4, max(4, int(math.ceil(st.chip_half_az_cells * res_az / (self.speed / prf)))))
        hj = int(math.ceil(st.chip_half_range_m / ref.dx))
        rows = np.arange(i0 - hi, i0 + hi + 1) % self.n_pulses  # RDA blocks are circular in azimuth
        cols = np.arange(j0 - hj, j0 + hj + 1)
        if cols[0] < 0 or cols[-1] >= ref.shape[1]:
            raise InputDataError("scene.ground_range_max", "reference chip leaves the reference image")
        chip = np.abs(ref.data[np.ix_(rows, cols)])
        entry = {"times": times, "raw": raw, "chip": chip, "anchor": (fi - i0, fj - j0),
                 "seconds": time.perf_counter() - t0, "reference": ref}
        if clutter_seed is None:  # per-run scenes are used once: do not keep them
            self._cache[(u, clutter_seed)] = entry
        return entry

    def measure(self, u: int, ap_t, ap_p, ap_v, speed_sigma=None) -> ApertureMeasurements:
        """Measured TOC, range and mapdrift correction of sub-aperture u for every run.

        ``ap_t`` (K,), ``ap_p`` / ``ap_v`` (R, K, 3): the estimated trajectory over the aperture (INS output);
        ``speed_sigma`` (R,): the filter's 1-sigma of the forward speed (mapdrift gate, :class:`ImagingSettings`).
        """
        R = ap_p.shape[0]
        if len(self.noise_seeds) != R:
            raise InputDataError("noise_seeds", f"need one per run for {R} runs, got {len(self.noise_seeds)}")
        out = ApertureMeasurements(np.empty(R), np.empty(R), np.empty(R), np.zeros((R, len(STAGES))))
        for r in range(R):
            if self.clutter_seeds is None:
                ap = self.aperture(u)
                out.seconds[r, 0] += ap["seconds"] / R
            else:
                ap = self.aperture(u, self.clutter_seeds[r])
                out.seconds[r, 0] += ap["seconds"]
            sigma = None if speed_sigma is None else speed_sigma[r]
            self._measure_run(u, r, ap, ap_t, ap_p[r], ap_v[r], sigma, out)
        return out

    def _measure_run(self, u, r, ap, ap_t, p_run, v_run, speed_sigma, out) -> None:
        st, prf = self.settings, self.radar.prf
        t0 = time.perf_counter()
        times, chip = ap["times"], ap["chip"]
        rc = self._noisy(ap["raw"], [self.noise_seeds[r], 4, u])  # the in-flight acquisition
        out.seconds[r, 0] += time.perf_counter() - t0
        t0 = time.perf_counter()
        targ = self.targets[u]
        p_hat = np.stack([np.interp(times, ap_t, p_run[:, i]) for i in range(3)], axis=1)
        speed_hat = float(np.linalg.norm(np.mean(v_run, axis=0)))
        if closest_sample_is_inside(targ, times, p_hat):
            r_hat = closest_approach(targ, times, p_hat)[1]
        else:
            r_hat = float(np.linalg.norm(targ - p_hat[len(times) // 2]))
        sub = _crop_range(rc, r_hat - st.search_half_range_m, r_hat + st.search_half_range_m).with_positions(p_hat)
        t1 = time.perf_counter()
        af = mapdrift(sub, speed_hat, max_iterations=st.mapdrift_iterations)
        gate = max(st.mapdrift_gate_floor, st.mapdrift_gate_sigma * (0.0 if speed_sigma is None else speed_sigma))
        image = af.image if abs(af.speed - speed_hat) <= gate else range_doppler(sub, speed_hat)
        t2 = time.perf_counter()
        row, col, coarse = self._register(np.abs(image.data), chip, ap["anchor"])
        out.toc[r] = times[0] + (row % self.n_pulses) / prf
        out.range[r] = image.x[0] + col * image.dx
        out.autofocus_dk[r] = af.fm_rate_error
        t3 = time.perf_counter()
        if r == 0 and u == self.capture_aperture and out.capture is None:
            out.capture = dict(reference=ap["reference"], before=range_doppler(sub, speed_hat), after=af.image,
                               correlation=(coarse.surface, coarse.lags_y, coarse.lags_x), speed_hat=speed_hat,
                               autofocus_speed=float(af.speed), used="mapdrift" if image is af.image else "estimate",
                               run=0, aperture=u)
        out.seconds[r, 1:] += (t1 - t0, t2 - t1, t3 - t2)

    def _register(self, img, chip, anchor):
        """(row, col) of the anchor in ``img`` (fractional pixels) and the coarse registration.

        Coarse: the chip at the centre of a canvas the size of the image, integer correlation peak; fine: the chip
        against the image cut (circularly in azimuth) around that peak, sub-pixel."""
        hi, hj = chip.shape[0] // 2, chip.shape[1] // 2
        canvas = np.zeros_like(img)
        ci, cj = img.shape[0] // 2, img.shape[1] // 2
        canvas[ci - hi:ci + hi + 1, cj - hj:cj + hj + 1] = chip
        coarse = register(canvas, img, use_magnitude=True, subpixel="none")
        i1 = ci + int(coarse.shift_pixels[0])
        j1 = min(max(cj + int(coarse.shift_pixels[1]), hj), img.shape[1] - hj - 1)
        cut = img[np.ix_(np.arange(i1 - hi, i1 + hi + 1) % img.shape[0], np.arange(j1 - hj, j1 + hj + 1))]
        fine = register(chip, cut, use_magnitude=True, subpixel=self.settings.subpixel)
        return i1 + fine.shift_pixels[0] + anchor[0], j1 + fine.shift_pixels[1] + anchor[1], coarse

"""Image mode of ``rda-nav``: from echoes to the measured time and range of closest approach of the
reference target in each 1-s sub-aperture (docs/scenarios/rda-nav.md §1-§2).

Per aperture: scene = reference reflector (fixed geolocation, from ``scene.seed``) + clutter scatterers whose
  TOC lies in the aperture, drawn per run (``scene.clutter_per_run = true``, from the run's seed, so that the
  registration errors of different runs are independent) or once for all runs (cached); noise-free echoes
  along the *true* antenna positions. Two acquisitions of that scene differ only in their receiver noise
  (``scene.snr_db``, per-sample SNR of the reflector): the *reference pass*, an RDA image focused with the
  true track, of which a chip around the reflector is kept together with the reflector's position inside the
  chip (its geolocation); and the *in-flight pass*, with the run's own noise. Only the chip's pattern and
  that internal anchor are used: the in-flight time axis is never taken from the reference.
Per run:
  range compression of the in-flight pass; RDA + mapdrift (paper eqs. 14-16) with the *estimated* speed,
  restricted to a slant-range window around the range R0_hat the estimate predicts (thesis eq. 4.41); the
  chip is searched in that image by 2-D correlation (paper eq. 46, magnitudes, sub-pixel); the anchor lands
  at the measured TOC eta0 (row -> pulse time) and range R0 (column -> slant range). Both come from radar
  timing only.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from sarnav.errors import InputDataError
from sarnav.imaging.autofocus import mapdrift
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.rda import range_doppler
from sarnav.imaging.registration import register
from sarnav.measurements.image_shift import closest_approach
from sarnav.radar.echoes import add_receiver_noise, simulate_echoes
from sarnav.radar.presets import flexsar, nav_paper_sim
from sarnav.radar.scene import Scene

#: chip half-sizes: azimuth in resolution cells (lambda R / (2 V T)), range in metres
CHIP_HALF_AZ_CELLS = 1.5
CHIP_HALF_RANGE_M = 4.0
#: slant-range half-window of the in-flight image around the predicted R0_hat [m]
SEARCH_HALF_RANGE_M = 12.0
#: look correlations of mapdrift: the paper's single pass (G12)
MAPDRIFT_ITERATIONS = 1
#: gate on the speed change a mapdrift correction implies: n-sigma of the filter's speed and a floor [m/s]
MAPDRIFT_GATE_SIGMA = 3.0
MAPDRIFT_GATE_FLOOR = 0.02
#: sub-pixel method of the chip registration: "parabola" (the upsampled-DFT refinement costs 25-60 ms per
#: call on 2 cores when OpenBLAS runs multi-threaded small complex matmuls; 3 ms single-threaded)
REGISTRATION_SUBPIXEL = "parabola"
STAGE_INDEX = {"echoes": 0, "rda": 1, "autofocus": 2, "registration": 3}

#: set by :func:`capture_images`: the images of one sub-aperture of the batch's first run are kept here
_CAPTURE: dict | None = None


class capture_images:
    """Context manager that keeps the images of sub-aperture ``aperture`` of the first run of the batch
    simulated inside it (reference, in-flight before/after mapdrift, correlation surface) for figures.
    Nothing else changes: the run's numbers are the same with or without it.

    >>> with capture_images(10) as cap:            # doctest: +SKIP
    ...     RdaNavKind().simulate(cfg, [0], [seed0])
    >>> cap["before"], cap["after"], cap["correlation"]   # doctest: +SKIP
    """

    def __init__(self, aperture: int):
        self.store = {"aperture": int(aperture), "run": 0}

    def __enter__(self) -> dict:
        global _CAPTURE
        _CAPTURE = self.store
        return self.store

    def __exit__(self, *exc) -> bool:
        global _CAPTURE
        _CAPTURE = None
        return False


def radar_for(preset: str):
    return nav_paper_sim() if preset == "nav-paper-sim" else flexsar()


def _crop_range(rc, r_lo, r_hi):
    r = rc.slant_range
    a = max(int(np.searchsorted(r, r_lo)), 0)
    b = min(int(np.searchsorted(r, r_hi)), r.size)
    if b - a < 16:
        raise InputDataError("sar", f"predicted range window [{r_lo:.1f}, {r_hi:.1f}] m lies outside the receive window")
    return replace(rc, data=rc.data[:, a:b], slant_range=r[a:b])


class ApertureImager:
    """Makes the image-derived TOC and range of each sub-aperture's reference target for a batch of runs.

    Parameters
    ----------
    prm : :class:`sarnav.scenarios.rda_nav.RdaNavParams`.
    targets : (U, 3) reference targets (``rda_nav.reference_targets``).
    """

    def __init__(self, prm, targets, clutter_seeds=None, noise_seeds=None):
        self.prm = prm
        self.targets = np.asarray(targets, dtype=np.float64)
        self.params = radar_for(prm.radar_preset)
        self.n_pulses = int(round(self.params.prf))
        self.clutter_seeds = None if clutter_seeds is None else [int(s) for s in clutter_seeds]
        self.noise_seeds = None if noise_seeds is None else [int(s) for s in noise_seeds]
        self._cache: dict[tuple, dict] = {}

    # --- per aperture (and per run when the clutter is drawn per run) -------------------------
    def _scene(self, u: int, clutter_seed: int | None) -> Scene:
        prm = self.prm
        key = [prm.scene["seed"], 1, u] if clutter_seed is None else [clutter_seed, 2, u]
        rng = np.random.default_rng(np.random.SeedSequence(key))
        n = prm.scene["clutter"]
        traj = prm.trajectory
        uvec = np.array([math.cos(traj.heading), math.sin(traj.heading), 0.0])
        w = np.array([-math.sin(traj.heading), math.cos(traj.heading), 0.0])
        start = traj.state(np.array([0.0])).position[0]
        ground = np.array([start[0], start[1], 0.0])
        toc = u + rng.uniform(0.1, 0.9, n)
        gr = rng.uniform(*prm.scene["ground_range"], n)
        clutter = ground + (traj.speed * toc)[:, None] * uvec + gr[:, None] * w
        amp = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / math.sqrt(2.0)  # Rayleigh, unit mean power
        refl = prm.scene["reflector_amplitude"]
        return Scene(np.vstack([self.targets[u][None, :], clutter]), np.concatenate([[refl], amp]))

    def _noisy(self, raw, key) -> object:
        """Range-compressed copy of the noise-free echoes ``raw`` with receiver noise from ``key``
        (``scene.snr_db`` of the reflector): one acquisition."""
        rng = np.random.default_rng(np.random.SeedSequence(key))
        return range_compress(add_receiver_noise(raw, self.prm.scene["reflector_amplitude"],
                                                 self.prm.scene["snr_db"], rng))

    def aperture(self, u: int, clutter_seed: int | None = None) -> dict:
        """Noise-free echoes of aperture u and its reference chip (cached per clutter draw).

        The reference product is a separate acquisition of the same scene along the true track (its own
        receiver noise, keyed by the clutter draw): the reference map and the in-flight image share the
        ground, not the noise."""
        if (u, clutter_seed) in self._cache:
            return self._cache[(u, clutter_seed)]
        t0 = time.perf_counter()
        prm = self.prm
        times = u + np.arange(self.n_pulses) / self.params.prf
        truth = prm.trajectory.state(times)
        raw = simulate_echoes(self.params, truth.position, times, self._scene(u, clutter_seed))
        key = [prm.scene["seed"], 3, u] if clutter_seed is None else [clutter_seed, 3, u]
        rc_ref = self._noisy(raw, key)
        # reference product: focused with the true track; keep a chip around the reflector + its anchor
        targ = self.targets[u]
        eta_ref, r_ref, _ = closest_approach(targ, times, truth.position)
        ref = range_doppler(_crop_range(rc_ref, r_ref - SEARCH_HALF_RANGE_M, r_ref + SEARCH_HALF_RANGE_M),
                            prm.trajectory.speed)
        prf = self.params.prf
        fi = (eta_ref - times[0]) * prf
        fj = (r_ref - ref.x[0]) / ref.dx
        i0, j0 = int(round(fi)), int(round(fj))
        res_az = self.params.wavelength * r_ref / (2 * prm.trajectory.speed * self.n_pulses / prf)
        hi = min(self.n_pulses // 4, max(4, int(math.ceil(CHIP_HALF_AZ_CELLS * res_az / (prm.trajectory.speed / prf)))))
        hj = int(math.ceil(CHIP_HALF_RANGE_M / ref.dx))
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

    # --- per run -------------------------------------------------------------------------------
    def measure(self, u: int, ap_t, ap_p, ap_v, stage_seconds, speed_sigma=None) -> dict:
        """Measured TOC (R,), range of closest approach (R,) and mapdrift Delta_K (R,) for aperture u.

        ``ap_t`` (K,), ``ap_p``/``ap_v`` (R, K, 3): the estimated trajectory over the aperture (INS output);
        ``stage_seconds`` (R, n_stages) is incremented with the time per stage; ``speed_sigma`` (R,) the
        filter's 1-sigma of the forward speed: a mapdrift correction implying a speed change beyond
        ``MAPDRIFT_GATE_SIGMA`` of it (or ``MAPDRIFT_GATE_FLOOR``) is rejected and the image focused with the
        estimated speed is used (the look correlation of a sparse scene can be biased by scatterers seen
        in only one look).
        """
        R = ap_p.shape[0]
        if self.clutter_seeds is not None and len(self.clutter_seeds) != R:
            raise InputDataError("clutter_seeds", f"need one per run: {len(self.clutter_seeds)} for {R} runs")
        if self.noise_seeds is None or len(self.noise_seeds) != R:
            raise InputDataError("noise_seeds", f"need one per run for {R} runs")
        prf = self.params.prf
        out = {"toc": np.empty(R), "range": np.empty(R), "autofocus_dk": np.empty(R)}
        targ = self.targets[u]
        for r in range(R):
            if self.clutter_seeds is None:
                ap = self.aperture(u)
                stage_seconds[r, STAGE_INDEX["echoes"]] += ap["seconds"] / R
            else:
                ap = self.aperture(u, self.clutter_seeds[r])
                stage_seconds[r, STAGE_INDEX["echoes"]] += ap["seconds"]
            t0 = time.perf_counter()
            times, chip = ap["times"], ap["chip"]
            rc = self._noisy(ap["raw"], [self.noise_seeds[r], 4, u])  # the in-flight acquisition
            stage_seconds[r, STAGE_INDEX["echoes"]] += time.perf_counter() - t0
            hi, hj = chip.shape[0] // 2, chip.shape[1] // 2
            t0 = time.perf_counter()
            p_hat = np.stack([np.interp(times, ap_t, ap_p[r, :, i]) for i in range(3)], axis=1)
            v_mean = np.mean(ap_v[r], axis=0)
            speed_hat = float(np.linalg.norm(v_mean))
            eta_hat, r_hat, _ = closest_approach(targ, times, p_hat) if _inside(targ, times, p_hat) else \
                (None, float(np.linalg.norm(targ - p_hat[len(times) // 2])), None)
            sub = _crop_range(rc, r_hat - SEARCH_HALF_RANGE_M, r_hat + SEARCH_HALF_RANGE_M).with_positions(p_hat)
            t1 = time.perf_counter()
            af = mapdrift(sub, speed_hat, max_iterations=MAPDRIFT_ITERATIONS)
            gate = max(MAPDRIFT_GATE_FLOOR, MAPDRIFT_GATE_SIGMA * (0.0 if speed_sigma is None else speed_sigma[r]))
            image = af.image if abs(af.speed - speed_hat) <= gate else range_doppler(sub, speed_hat)
            t2 = time.perf_counter()
            img = np.abs(image.data)
            # coarse: the chip at the centre of a canvas the size of the image, integer correlation peak;
            # fine: the chip against the image cut (circularly in azimuth) around that peak, sub-pixel
            canvas = np.zeros_like(img)
            ci, cj = img.shape[0] // 2, img.shape[1] // 2
            canvas[ci - hi:ci + hi + 1, cj - hj:cj + hj + 1] = chip
            coarse = register(canvas, img, use_magnitude=True, subpixel="none")
            i1 = ci + int(coarse.shift_pixels[0])
            j1 = min(max(cj + int(coarse.shift_pixels[1]), hj), img.shape[1] - hj - 1)
            cut = img[np.ix_(np.arange(i1 - hi, i1 + hi + 1) % img.shape[0], np.arange(j1 - hj, j1 + hj + 1))]
            fine = register(chip, cut, use_magnitude=True, subpixel=REGISTRATION_SUBPIXEL)
            row = i1 + fine.shift_pixels[0] + ap["anchor"][0]
            col = j1 + fine.shift_pixels[1] + ap["anchor"][1]
            out["toc"][r] = times[0] + (row % self.n_pulses) / prf
            out["range"][r] = image.x[0] + col * image.dx
            out["autofocus_dk"][r] = af.fm_rate_error
            t3 = time.perf_counter()
            if _CAPTURE is not None and r == 0 and u == _CAPTURE["aperture"] and "before" not in _CAPTURE:
                _CAPTURE.update(reference=ap["reference"], before=range_doppler(sub, speed_hat), after=af.image,
                                correlation=(coarse.surface, coarse.lags_y, coarse.lags_x), speed_hat=speed_hat,
                                autofocus_speed=float(af.speed), used="mapdrift" if image is af.image else "estimate")
            stage_seconds[r, STAGE_INDEX["rda"]] += t1 - t0
            stage_seconds[r, STAGE_INDEX["autofocus"]] += t2 - t1
            stage_seconds[r, STAGE_INDEX["registration"]] += t3 - t2
        return out


def _inside(targ, times, positions) -> bool:
    d = np.sum((positions - targ) ** 2, axis=1)
    k = int(np.argmin(d))
    return 0 < k < len(times) - 1

"""Image-derived SAR measurements: from echoes to the time and range of closest approach of reference targets.

The extractor of the image-aided flight (NAVIGATION paper §3-4; docs/scenarios/rda-nav.md §1-§3), typed to nothing
but radar parameters, the reference product's geolocated targets, an :class:`ApertureSource` of pulses and seeds.
It never sees a truth trajectory or a scene: the source hands it, per sub-aperture u and run, the range-compressed
pulses of the in-flight acquisition and of the reference pass with the reference pass's trusted positions
(:class:`ReferencePulses`). The simulated world is one source (``simulation.sar_echoes.SimulatedApertures``: the
scene's echoes along the true track and along the reference pass's track, each acquisition with its own receiver
noise); a recorded flight is another.

Per sub-aperture u (one second of pulses): the reference product is an image of the reference pass focused with its
trusted track (RDA, or BPA on a ground grid); of it a chip around each reference target is kept, with the target's
position inside the chip (its geolocation in the product). Only the chip's pattern and that anchor are used: the
in-flight time axis is never taken from the reference.
Per run:
  range compression of the in-flight pass; per target an image focused with the *estimated* trajectory around the
  place the estimate and the map predict the target: RDA (straight tracks, the paper's processor; ``algorithm =
  "rda"``) on a slant-range window, or back-projection (any track; ``"bpa"``) on a ground grid; the chip is searched
  in it by 2-D correlation (paper eq. 46, magnitudes), refined by least squares; the anchor lands at the measured TOC
  eta0 and range R0 of the target (RDA: row -> pulse time, column -> slant range; BPA: the matched ground point,
  whose closest approach to the estimated track gives eta0 and R0). Both come from radar timing only.
  Each match comes with its predicted 1-sigma (``imaging.registration.magnitude_shift_precision`` with the noise
  model of the chain, ``SeparableNoise``; docs §3), its normalised correlation and its ambiguity (the best other
  match); a failed image or registration, a weak or an ambiguous match gives a status instead of a number.

Seeds (keys of ``SeedSequence``): noise model ``[reference_seed, 5, u, target, realisation]`` (the simulated
source's own seeds: ``simulation.sar_echoes``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.imaging.autofocus import mapdrift
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.range_compression import compression_reach, range_compress
from sarnav.imaging.rda import range_doppler
from sarnav.imaging.registration import SeparableNoise, distinctness, magnitude_shift_precision, refine_shift, register
from sarnav.radar.params import RadarParams
from sarnav.measurements.sar_aperture import (ALGORITHMS, FAILURES, FOCUS, STAGES, ApertureMeasurements,
                                             AperturePasses, ApertureSource, ImagingSettings, ReferencePulses)
from sarnav.measurements.ground_grid import BpaGrid, focusing_track, ground_frame
from sarnav.measurements.read_ahead import ReadAhead
from sarnav.measurements.sar_product import (ProductReference, closest_approaches, predicted_amplitude,
                                             product_noise_power, rda_pixels, reference_in_flight)
from sarnav.signal.data import SarImage
from sarnav.trajectory.sampled import along_offset, closest_approach, closest_sample_is_inside

__all__ = ["STAGES", "FAILURES", "ALGORITHMS", "FOCUS", "ImagingSettings", "AperturePasses", "ApertureMeasurements",
           "ReferencePulses", "ApertureSource", "SubApertureImager", "focusing_track", "one_blas_thread"]

#: smallest relative step of the focusing speed for the focus sensitivity (SubApertureImager._focus_sensitivity)
FOCUS_STEP = 0.003
#: realisations of unit noise through the image-formation chain for the noise model (SubApertureImager._noise_model)
NOISE_REALISATIONS = 4
#: largest along-track half-size of a BPA search grid [m] (3 sigma of the filter's along-track uncertainty + chip)
MAX_BPA_HALF_ALONG_M = 200.0
#: the process's threadpoolctl controller, made on first use (one_blas_thread)
_BLAS: list = []


def one_blas_thread():
    """A context in which BLAS runs on one thread (``threadpoolctl``). The extractor's matrix products are small
    (the noise model's quadratic forms: 51 x 55 by 55 x 55 complex): on two threads each waits for the other, and
    on a loaded 2-core machine that wait was 14-17 ms per product against 0.5 ms on one thread (measured; the
    Monte Carlo workers limit their threads for the same reason, ``montecarlo.executors``). It also makes the
    extractor's numbers the same in every process: a product on two threads can differ from one thread's in its last
    bit (seen once: one registration sigma of 20 in a 2-run, 5-s rda-nav campaign on the serial executor, 2e-16
    relative), and the process workers run BLAS on one thread, so the serial executor, the workers and ``sarnav
    navigate`` now agree bit for bit."""
    if not _BLAS:
        from threadpoolctl import ThreadpoolController

        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1, user_api="blas")


def _crop_range(rc, r_lo, r_hi):
    r = rc.slant_range
    a = max(int(np.searchsorted(r, r_lo)), 0)
    b = min(int(np.searchsorted(r, r_hi)), r.size)
    if b - a < 16:
        raise InputDataError("sar", f"predicted range window [{r_lo:.1f}, {r_hi:.1f}] m lies outside the receive window")
    return replace(rc, data=rc.data[:, a:b], slant_range=r[a:b])


@dataclass
class SubApertureImager:
    """Makes the image-derived TOC and range of each sub-aperture's reference targets for a batch of runs.

    Parameters
    ----------
    radar : the radar (its PRF sets the pulses of a one-second sub-aperture; its look side the ground frame).
    targets : (U, T, 3) the reference product's geolocated targets of each sub-aperture (NED, m): the chips are cut
        around them in the reference image.
    source : the :class:`ApertureSource` of the pulses (``simulation.sar_echoes.SimulatedApertures``, or a
        recording); ``source.runs`` runs.
    reference_seed : key of the noise model's unit-noise realisations.
    settings : :class:`ImagingSettings`.
    capture_aperture : keep the images of this sub-aperture of the first run (figures), or None.
    """

    radar: RadarParams
    targets: np.ndarray
    source: ApertureSource
    reference_seed: int
    settings: ImagingSettings = field(default_factory=ImagingSettings)
    capture_aperture: int | None = None
    keep_images: bool = False  # keep every in-flight image of the first run registered (ApertureMeasurements.keep)

    def __post_init__(self):
        self.targets = np.asarray(self.targets, dtype=np.float64)
        if self.targets.ndim == 2:
            self.targets = self.targets[:, None, :]
        if self.targets.ndim != 3 or self.targets.shape[2] != 3:
            raise InputDataError("targets", f"must be (U, T, 3), got {self.targets.shape}")
        self.n_pulses = int(round(self.radar.prf))
        self._cache: dict = {}
        self._noise_cache: dict[tuple, SeparableNoise] = {}
        self._along_sigma = self._q_run = None
        self._ahead: dict[tuple[int, int], ReadAhead] = {}  # (aperture, run) -> its read-ahead, under way or done

    def share_noise_models(self, store: dict) -> None:
        """Keep the receiver-noise models (``_noise_model``, ~45 ms a chip) in ``store``, a dict the caller keeps
        (a campaign's worker across its chunks): a model depends on the parameters, the sub-aperture and the target,
        never on the runs, so sharing it changes no number. (The reference chips are not shared: hundreds of MB.)"""
        self._noise_cache = store

    # --- the reference product --------------------------------------------------------------------
    def aperture(self, u: int, run: int) -> dict:
        """The reference chips of sub-aperture u for run ``run`` (cached under the source's key) and the seconds spent
        on the reference pass."""
        ref = self.source.reference(u, run)  # its own seconds in ref.seconds
        if isinstance(ref, ProductReference):  # reference (b): the chips are predicted along each run's track
            return {"times": ref.times, "chips": [None] * self.targets.shape[1], "product": ref,
                    "seconds": ref.seconds, "shared": False}
        if ref.key is not None and ref.key in self._cache:
            return self._cache[ref.key]
        t0 = time.perf_counter()
        chips = [self._reference_chip(u, k, ref) for k in range(self.targets.shape[1])]
        entry = {"times": ref.times, "chips": chips, "seconds": ref.seconds + time.perf_counter() - t0,
                 "shared": ref.key is not None}
        if ref.key is not None:  # a scene used once is not kept
            self._cache[ref.key] = entry
        return entry

    def _az_resolution(self, r0: float, speed: float) -> float:
        return self.radar.wavelength * r0 / (2 * speed * self.n_pulses / self.radar.prf)

    def _reference_chip(self, u, k, ref: ReferencePulses) -> dict:
        st, times, rc_ref, raw_ref = self.settings, ref.times, ref.pulses, ref.raw
        targ = self.targets[u, k]
        eta, r0, _ = closest_approach(targ, times, ref.positions)
        v_ref = np.linalg.norm(ref.velocities[len(times) // 2])
        if st.algorithm == "bpa":
            return self._reference_chip_bpa(u, k, ref, targ, eta, r0, v_ref)
        win = (r0 - st.search_half_range_m, r0 + st.search_half_range_m)  # the search window's slant ranges
        image, prf = range_doppler(_crop_range(rc_ref, *win), v_ref), self.radar.prf
        fi, fj = (eta - times[0]) * prf, (r0 - image.x[0]) / image.dx
        i0, j0 = int(round(fi)), int(round(fj))
        hi = min(self.n_pulses // 4, max(4, int(math.ceil(st.chip_half_az_cells * self._az_resolution(r0, v_ref)
                                                            / (v_ref / prf)))))
        hj = int(math.ceil(st.chip_half_range_m / image.dx))
        rows = np.arange(i0 - hi, i0 + hi + 1) % self.n_pulses  # RDA blocks are circular in azimuth
        cols = np.arange(j0 - hj, j0 + hj + 1)
        if cols[0] < 0 or cols[-1] >= image.shape[1]:
            raise InputDataError("scene.ground_range_max", "reference chip leaves the reference image")
        if (u, k) not in self._noise_cache:  # the same for every run's scene: cached
            self._noise_cache[(u, k)] = self._noise_model(
                u, k, raw_ref, ref, lambda rc: range_doppler(_crop_range(rc, *win), v_ref).data, cols.size, win)
        return {"chip": image.data[np.ix_(rows, cols)], "anchor": (fi - i0, fj - j0), "rows": rows,
                "noise": self._noise_cache[(u, k)], "reference": image, "speed": v_ref,
                "lattice": (np.arange(i0 - hi, i0 + hi + 1), cols), "target": targ, "track": ref.positions,
                "surface": ref.surface}

    def _bpa_spacing(self, r0: float, g0: float, speed: float) -> tuple[float, float]:
        """(along, ground-range) pixel spacing [m] of BPA grids: a twentieth of the azimuth resolution (at most the
        pulse spacing), and one slant-range bin projected on the ground."""
        da = min(speed / self.radar.prf, self._az_resolution(r0, speed) / 20.0)
        return da, self.radar.range_bin_spacing * r0 / g0

    def _reference_chip_bpa(self, u, k, ref: ReferencePulses, targ, eta, r0, v_ref) -> dict:
        st, times = self.settings, ref.times
        i_c = int(np.argmin(np.abs(times - eta)))
        along, across = ground_frame(ref.velocities[i_c], self.radar.look_side)
        g0 = float(np.hypot(*(targ - ref.positions[i_c])[:2]))
        da, dg = self._bpa_spacing(r0, g0, v_ref)
        hi = int(math.ceil(st.chip_half_az_cells * self._az_resolution(r0, v_ref) / da))
        hj = int(math.ceil(st.chip_half_range_m * r0 / g0 / dg))
        grid = BpaGrid(targ, along, across, da, dg, (2 * hi + 1, 2 * hj + 1))
        image = backproject(ref.pulses, grid.points(), positions=ref.positions)
        if (u, k) not in self._noise_cache:
            wide = replace(grid, shape=(2 * hi + 1, 4 * (2 * hj + 1)))
            self._noise_cache[(u, k)] = self._noise_model(u, k, ref.raw, ref, lambda rc: backproject(
                rc, wide.points(), positions=ref.positions).data, 2 * hj + 1)
        return {"chip": image.data, "anchor": (0.0, 0.0), "rows": np.arange(2 * hi + 1),
                "noise": self._noise_cache[(u, k)], "reference": image, "speed": v_ref, "grid": grid}

    def _noise_model(self, u, k, raw, ref, form, chip_columns: int, window=None) -> SeparableNoise:
        """Receiver noise of a formed image (``imaging.registration.SeparableNoise``): the chain ``form(range-compressed
        pulses) -> image`` applied to NOISE_REALISATIONS realisations of unit white noise, scaled to the source's raw
        noise power per sample, ``amplitude^2 / 10^(snr/10)`` (``radar.echoes``); known from the radar and the processor,
        not fitted (docs/scenarios/rda-nav.md §3). ``window`` (r_lo, r_hi) [m]: the ranges ``form`` crops to."""
        cols = None if window is None else tuple(int(np.searchsorted(raw.slant_range, w)) for w in window)
        # only the samples the compression of `cols` reads (compression_reach) are copied: the same values
        lo, hi = (0, raw.data.shape[1]) if cols is None else compression_reach(raw, cols)
        ranges, cols = np.asarray(raw.slant_range)[lo:hi], None if cols is None else (cols[0] - lo, cols[1] - lo)
        draws, imgs = np.empty((2,) + raw.data.shape), []  # the real then the imaginary parts of the whole swath
        for t in range(NOISE_REALISATIONS):
            rng = np.random.default_rng(np.random.SeedSequence([self.reference_seed, 5, u, k, t]))
            rng.standard_normal(out=draws)
            unit = np.empty((raw.data.shape[0], hi - lo), dtype=np.complex128)  # a + j b: its 1/sqrt 2 is in `power`
            unit.real, unit.imag = draws[0][:, lo:hi], draws[1][:, lo:hi]
            imgs.append(form(range_compress(replace(raw, data=unit, slant_range=ranges), columns=cols)))
        model = SeparableNoise.from_images(np.stack(imgs), chip_columns)
        return replace(model, power=0.5 * model.power * ref.amplitude**2 / 10.0 ** (ref.snr_db / 10.0))

    def _product_chip(self, u, k, ref: ProductReference, rc, p_hat, speed: float) -> dict:
        """The chip of target k predicted from a geocoded product along the estimated track ``p_hat``
        (``measurements.sar_product``): RDA on the in-flight image's (time, slant range) lattice, BPA on the ground
        grid the in-flight image is formed on. Its noise: the product's power with the in-flight chain's correlation."""
        st, times, targ, look = self.settings, ref.times, self.targets[u, k], self.radar.look_side
        eta_a, r_a = (float(x) for x in closest_approaches(targ, times, p_hat))
        raw = ref.raw.with_positions(p_hat)
        if st.algorithm == "bpa":
            i_c = int(np.argmin(np.abs(times - eta_a)))
            along, across = ground_frame(p_hat[-1] - p_hat[0], look)
            g0 = float(np.hypot(*(targ - p_hat[i_c])[:2]))
            da, dg = self._bpa_spacing(r_a, g0, speed)
            hi = int(math.ceil(st.chip_half_az_cells * self._az_resolution(r_a, speed) / da))
            hj = int(math.ceil(st.chip_half_range_m * r_a / g0 / dg))
            grid = BpaGrid(np.asarray(targ, dtype=np.float64), along, across, da, dg, (2 * hi + 1, 2 * hj + 1))
            eta, rng = closest_approaches(grid.points(), times, p_hat)
            rows, anchor, extra, window = np.arange(2 * hi + 1), (0.0, 0.0), {"grid": grid}, None
            wide = replace(grid, shape=(2 * hi + 1, 4 * (2 * hj + 1)))
            form = lambda pc: backproject(pc, wide.points(), positions=p_hat).data  # noqa: E731
        else:
            hi = min(self.n_pulses // 4, max(4, int(math.ceil(st.chip_half_az_cells * self._az_resolution(r_a, speed)
                                                              / (speed / self.radar.prf)))))
            hj = int(math.ceil(st.chip_half_range_m / self.radar.range_bin_spacing))
            eta, rng, rows, anchor = rda_pixels(times, self.radar.prf, rc.slant_range, eta_a, r_a, hi, hj)
            extra, window = {}, (r_a - st.search_half_range_m, r_a + st.search_half_range_m)
            form = lambda pc: range_doppler(_crop_range(pc, *window), speed).data  # noqa: E731
        chip = predicted_amplitude(ref.product, times, p_hat, eta, rng, look, targ[2])
        if (u, k) not in self._noise_cache:
            self._noise_cache[(u, k)] = self._noise_model(u, k, raw, ref, form, 2 * hj + 1, window)
        noise = self._noise_cache[(u, k)]
        image = SarImage(chip.astype(np.complex128), np.arange(chip.shape[0]) * speed / self.radar.prf,
                         np.arange(chip.shape[1]) * self.radar.range_bin_spacing, "predicted_row", "predicted_column")
        return {"chip": chip.astype(np.complex128), "anchor": anchor, "rows": rows, "noise": noise,
                "chip_noise": replace(noise, power=product_noise_power(ref.product)), "reference": image,
                "speed": speed, **extra}

    # --- the in-flight images ---------------------------------------------------------------------
    def measure(self, u: int, ap_t, ap_p, ap_v, speed_sigma=None, map_targets=None,
                along_sigma=None, ap_q=None) -> ApertureMeasurements:
        """Measured TOC, range and their predicted sigma of each reference target of sub-aperture u, every run.

        ``ap_t`` (K,), ``ap_p`` / ``ap_v`` (R, K, 3): the estimated trajectory over the aperture (INS output);
        ``speed_sigma`` (R,): the filter's 1-sigma of the forward speed (mapdrift gate); ``map_targets`` (R, T, 3):
        where the reference product (the map) puts the targets, by which the images are centred (default: the
        true positions ``targets[u]``); ``along_sigma`` (R,): the filter's 1-sigma of the target's along-track
        position in an image focused with the estimate (the zero-Doppler cross-range; sizes the BPA search grid);
        ``ap_q`` (R, K, 4): the estimated attitude (BPA: the focusing track follows its heading, :func:`focusing_track`).
        """
        R, T = ap_p.shape[0], self.targets.shape[1]
        runs = getattr(self.source, "runs", R)
        if runs != R:
            raise InputDataError("source", f"gives pulses of {runs} runs, the estimate has {R}")
        if map_targets is None:
            map_targets = np.broadcast_to(self.targets[u], (R, T, 3))
        out = ApertureMeasurements.empty(R, T)
        with one_blas_thread():
            for r in range(R):
                ap, flight = self._fetch(u, r)
                if r == R - 1:
                    self._read_ahead_from(u)
                out.seconds[r, 0] += ap["seconds"] / (R if ap["shared"] else 1)  # a shared reference: once for all
                sigma = None if speed_sigma is None else speed_sigma[r]
                self._along_sigma = along_sigma
                self._q_run = None if ap_q is None else ap_q[r]
                self._measure_run(u, r, ap, flight, ap_t, ap_p[r], ap_v[r], sigma, map_targets[r], out)
        return out

    # --- reading ahead (measurements.read_ahead) --------------------------------------------------
    def _prepare(self, u: int, r: int):
        """What aperture u needs before the estimate: (reference entry, (in-flight pulses, their seconds))."""
        ap = self.aperture(u, r)
        return ap, self.source.flight(u, r)  # the in-flight acquisition

    def _reads_ahead(self) -> int:
        """How many apertures are prepared ahead, each on a thread of its own: the source's ``read_ahead`` (a
        recording's files: 2; 0 or absent: none) when the chain is the RDA's (back-projection's numba kernels run
        threads of their own)."""
        return max(int(getattr(self.source, "read_ahead", 0)), 0) if self.settings.algorithm == "rda" else 0

    def _read_ahead_from(self, u: int) -> None:
        """Start the read-aheads of apertures u + 1 .. u + depth not under way yet."""
        for v in range(u + 1, min(u + 1 + self._reads_ahead(), self.targets.shape[0])):
            if (v, 0) not in self._ahead:
                self._ahead[(v, 0)] = ReadAhead(self._prepare, v, 0)

    def _fetch(self, u: int, r: int):
        """``_prepare(u, r)``, from the read-ahead when one prepared that aperture; read-aheads of apertures at or
        before u that are not asked for (the navigator skipped them) are waited for and dropped."""
        job = self._ahead.pop((u, r), None)
        for key in [k for k in self._ahead if k[0] <= u]:
            self._ahead.pop(key).join()
        if job is not None:
            return job.take()
        return self._prepare(u, r)

    def _measure_run(self, u, r, ap, flight, ap_t, p_run, v_run, speed_sigma, map_targets, out) -> None:
        times = ap["times"]
        rc, seconds = flight
        out.seconds[r, 0] += seconds
        if self.settings.algorithm == "bpa":
            p_hat = focusing_track(times, ap_t, p_run, v_run, self._q_run)
        else:
            p_hat = np.stack([np.interp(times, ap_t, p_run[:, i]) for i in range(3)], axis=1)
        speed_hat = float(np.linalg.norm(np.mean(v_run, axis=0)))
        out.speed[r] = speed_hat
        for k in range(self.targets.shape[1]):
            try:
                if "product" in ap:
                    ap["chips"][k] = self._product_chip(u, k, ap["product"], rc, p_hat, speed_hat)
                if self.settings.algorithm == "bpa":
                    self._measure_bpa(u, r, k, ap, rc, p_hat, speed_hat, speed_sigma, map_targets[k], out)
                else:
                    self._measure_rda(u, r, k, ap, rc, p_hat, speed_hat, speed_sigma, map_targets[k], out)
            except (InputDataError, ConfigError, np.linalg.LinAlgError) as err:  # one bad image never aborts a campaign
                out.status[r, k] = 1 if getattr(err, "field", "") in ("rc", "sar", "speed") else 2
                out.toc[r, k] = out.range[r, k] = np.nan

    def _judge(self, r, k, quality, coarse, ch, out) -> None:
        """The match's normalised correlation and ambiguity (the best other match of the coarse surface) and, when
        either is out of bounds, the failure status."""
        ambiguity = distinctness(coarse.surface, (ch["chip"].shape[0] // 2, ch["chip"].shape[1] // 2))
        out.quality[r, k], out.ambiguity[r, k] = quality, ambiguity
        if not quality >= self.settings.min_correlation:
            out.status[r, k] = FAILURES.index("weak match (correlation)")
        elif not ambiguity <= self.settings.max_ambiguity:
            out.status[r, k] = FAILURES.index("ambiguous match")

    def _measure_rda(self, u, r, k, ap, rc, p_hat, speed_hat, speed_sigma, targ, out) -> None:
        st, prf, times, ch = self.settings, self.radar.prf, ap["times"], ap["chips"][k]
        t0 = time.perf_counter()
        if st.terrain_correction and ch.get("surface") is not None:  # the chip in this image's geometry, by the DEM
            chip, turn = reference_in_flight(ch["reference"], *ch["lattice"], ch["target"], times, prf, p_hat,
                                             ch["track"], ch["surface"], self.radar.look_side, self.radar.wavelength)
            ch = {**ch, "chip": chip, "phase_turn": turn}
        if closest_sample_is_inside(targ, times, p_hat):
            r_hat = closest_approach(targ, times, p_hat)[1]
        else:
            r_hat = float(np.linalg.norm(targ - p_hat[len(times) // 2]))
        sub = _crop_range(rc, r_hat - st.search_half_range_m, r_hat + st.search_half_range_m).with_positions(p_hat)
        image = range_doppler(sub, speed_hat)
        t1 = time.perf_counter()
        af = None
        if st.autofocus and k == 0:
            try:
                af = mapdrift(sub, speed_hat, max_iterations=st.mapdrift_iterations)
            except InputDataError:  # a failed autofocus: the image focused with the estimate is still measured
                if st.focus == "mapdrift":
                    raise
                af = None
        if af is not None:
            out.autofocus_dk[r] = af.fm_rate_error
            gate = max(st.mapdrift_gate_floor, st.mapdrift_gate_sigma * (0.0 if speed_sigma is None else speed_sigma))
            if st.focus == "mapdrift" and abs(af.speed - speed_hat) <= gate:
                image = af.image
                out.speed[r] = float(af.speed)
        t2 = time.perf_counter()
        out.keep(self.keep_images and r == 0, k, image, sub)
        coarse, i1, j1 = self._coarse(np.abs(image.data), np.abs(ch["chip"]))
        row, col, info = self._fine(image.data, ch, i1, j1)
        out.toc[r, k] = times[0] + (row % self.n_pulses) / prf
        out.range[r, k] = image.x[0] + col * image.dx
        out.sigma[r, k] = (info["sigma_px"][1] * image.dx, info["sigma_px"][0] / prf * speed_hat)
        out.lever[r, k] = out.toc[r, k] - 0.5 * (times[0] + times[-1])
        if st.focus == "estimate":
            refocus = lambda dv: range_doppler(sub, speed_hat + dv).data  # noqa: E731
            n_p = self.n_pulses
            slope, offset, spread = self._focus_sensitivity(  # RDA rows are pulse times (circular): a row is a TOC
                refocus, ch, speed_hat, speed_sigma, i1, j1,
                lambda rc_, dv: ((rc_[0] - row + n_p / 2) % n_p - n_p / 2) / prf * speed_hat)
            self._take_focus(r, k, slope, offset, spread, out)
        self._judge(r, k, info["quality"], coarse, ch, out)
        t3 = time.perf_counter()
        if r == 0 and k == 0 and u == self.capture_aperture and out.capture is None:
            out.capture = dict(reference=ch["reference"], before=range_doppler(sub, speed_hat),
                               after=image if af is None else af.image,
                               correlation=(coarse.surface, coarse.lags_y, coarse.lags_x), speed_hat=speed_hat,
                               autofocus_speed=float(speed_hat if af is None else af.speed),
                               used="mapdrift" if (af is not None and image is af.image) else "estimate",
                               run=0, aperture=u)
        out.seconds[r, 1:] += (t1 - t0, t2 - t1, t3 - t2)

    def _measure_bpa(self, u, r, k, ap, rc, p_hat, speed_hat, speed_sigma, targ, out) -> None:
        st, times, ch = self.settings, ap["times"], ap["chips"][k]
        t0 = time.perf_counter()
        ref_grid = ch["grid"]
        i_c = len(times) // 2
        along, across = ground_frame(p_hat[-1] - p_hat[0], self.radar.look_side)
        r0 = float(np.linalg.norm(targ - p_hat[i_c]))
        g0 = float(np.hypot(*(targ - p_hat[i_c])[:2]))
        # the target appears where its range history matches the estimated track's: moved along track by the
        # navigation's zero-Doppler lever (thesis §4.3.2), so the grid spans the filter's along-track uncertainty
        chip_half = (ch["chip"].shape[0] // 2) * ref_grid.da
        half_along = chip_half + st.search_half_along_m + 3.0 * float(self._along_sigma[r] if self._along_sigma is not None
                                                                    else 0.0)
        if half_along > MAX_BPA_HALF_ALONG_M:
            raise InputDataError("sar", f"the along-track search ({half_along:.0f} m) exceeds {MAX_BPA_HALF_ALONG_M} m")
        shape = (2 * int(math.ceil(half_along / ref_grid.da)) + 1,
                 2 * int(math.ceil(st.search_half_range_m * r0 / g0 / ref_grid.dg)) + 1)
        grid = BpaGrid(np.asarray(targ, dtype=np.float64), along, across, ref_grid.da, ref_grid.dg, shape)
        data = backproject(rc, grid.points(), positions=p_hat).data
        t1 = time.perf_counter()
        out.keep(self.keep_images and r == 0, k, data, rc, grid, p_hat)
        coarse, i1, j1 = self._coarse(np.abs(data), np.abs(ch["chip"]), circular=False)
        row, col, _ = self._fine(data, ch, i1, j1, precision=False, circular=False)
        # formed again on the chip's lattice centred at the match, so that the final registration shift is a small
        # fraction of a pixel: ground range is sampled near Nyquist (one slant bin), where a spline shift of the
        # magnitude (or of the complex chip) misplaces a fractional shift and leaves a residual that reads as a
        # scene mismatch (kappa up to 13 at half a pixel; docs/scenarios/rda-nav.md §6)
        q_hat, info = self._on_lattices(rc, p_hat, ch, replace(grid, centre=grid.point(row, col), shape=ch["chip"].shape))
        eta, rng_ = self._closest(q_hat, times, p_hat)
        out.toc[r, k], out.range[r, k] = eta, rng_
        out.sigma[r, k] = (info["sigma_px"][1] * grid.dg * g0 / r0, info["sigma_px"][0] * grid.da)
        out.lever[r, k] = eta - 0.5 * (times[0] + times[-1])
        if st.focus == "estimate":  # refocus a neighbourhood of the match with the track stretched along itself
            m, n = ch["chip"].shape[0] + 20, ch["chip"].shape[1] + 10
            local = replace(grid, centre=grid.point(i1, j1), shape=(m, n))
            centre = p_hat[i_c]
            # the measurement is the TOC on the focusing track (the along-track offset of the match from the track
            # is zero then), and a stretched track is elsewhere at that time: an image point moved by -eps x0
            # (eps = dv / V, x0 the target's offset from the aperture centre) has an along-track offset of
            # -2 eps x0 at the TOC (docs/scenarios/rda-nav.md §6). So each refocused match is taken to its offset
            # from its own track at the TOC eta0 (trajectory.sampled.along_offset; on a turn that also carries the
            # rate of the offset, along_rate)
            stretched = lambda dv: centre + (1.0 + dv / speed_hat) * (p_hat - centre)  # noqa: E731
            eta0 = self._closest(local.point(row - i1 + (m - 1) / 2, col - j1 + (n - 1) / 2), times, p_hat)[0]
            k0 = min(max(int(np.searchsorted(times, eta0)), 1), len(times) - 1)  # the pulse interval holding eta0
            w = (eta0 - times[k0 - 1]) / (times[k0] - times[k0 - 1])

            def along(rc_, dv):
                track = stretched(dv)[k0 - 1:k0 + 1]
                return float(along_offset(local.point(*rc_), (1.0 - w) * track[0] + w * track[1],
                                          (track[1] - track[0]) / (times[k0] - times[k0 - 1])))

            refocus = lambda dv: backproject(rc, local.points(), positions=stretched(dv)).data  # noqa: E731
            slope, offset, spread = self._focus_sensitivity(refocus, ch, speed_hat, speed_sigma, (m - 1) // 2,
                                                            (n - 1) // 2, along, circular=False)
            self._take_focus(r, k, slope, offset, spread, out)
        self._judge(r, k, info["quality"], coarse, ch, out)
        t2 = time.perf_counter()
        if r == 0 and k == 0 and u == self.capture_aperture and out.capture is None:
            img = SarImage(data, (np.arange(shape[0]) - (shape[0] - 1) / 2) * grid.da,
                           (np.arange(shape[1]) - (shape[1] - 1) / 2) * grid.dg, "along_track", "ground_range")
            out.capture = dict(reference=ch["reference"], before=img, after=img,
                               correlation=(coarse.surface, coarse.lags_y, coarse.lags_x), speed_hat=speed_hat,
                               autofocus_speed=speed_hat, used="estimate", run=0, aperture=u)
        out.seconds[r, 1:] += (t1 - t0, 0.0, t2 - t1)

    def _on_lattices(self, rc, p_hat, ch, chip_grid: BpaGrid):
        """(matched ground point (3,), the first lattice's registration info): the chip formed again by back-projection
        on ``settings.range_lattices`` = N lattices of the reference chip's spacing centred at the coarse match and
        offset across track by j / N of a ground-range pixel (j = 0 .. N - 1), registered on each; the mean point.

        Why: ground range is sampled at one slant bin (near Nyquist), and the least-squares shift of the magnitude
        then depends on where the target falls between two nodes (the spline and the Gauss-Newton's sample gradient
        misplace a fractional shift: a bias periodic in the fraction, "pixel locking"). Registrations half a pixel
        apart differ by 1.0 mm rms on the turning flight (range sigma 1.5 mm); the mean over N lattices cancels every
        harmonic of that bias that is not a multiple of N (N = 2: the odd ones; docs/scenarios/rda-nav.md §6). The noise is the same field sampled elsewhere, so the predicted
        sigma is the first lattice's."""
        hi, hj = ch["chip"].shape[0] // 2, ch["chip"].shape[1] // 2
        n = self.settings.range_lattices
        points, info = [], None
        for j in range(n):
            lattice = replace(chip_grid, centre=chip_grid.point(hi, hj + j / n))
            row, col, found = self._fine(backproject(rc, lattice.points(), positions=p_hat).data, ch, hi, hj,
                                         precision=j == 0, circular=False)
            points.append(lattice.point(row, col))
            info = found if info is None else info
        return np.mean(points, axis=0), info

    @staticmethod
    def _closest(q, times, p_hat):
        """(TOC, range of closest approach) of the estimated track ``p_hat`` to the ground point ``q``."""
        if not closest_sample_is_inside(q, times, p_hat):
            raise InputDataError("sar", "the matched point's closest approach lies outside the aperture")
        eta, rng_, _ = closest_approach(q, times, p_hat)
        return float(eta), float(rng_)

    # --- registration -----------------------------------------------------------------------------
    def _coarse(self, img, chip, circular: bool = True):
        """Integer registration of the chip: the chip at the centre of a canvas the size of the image, correlation
        peak; (registration, row, column of the chip centre in ``img``)."""
        hi, hj = chip.shape[0] // 2, chip.shape[1] // 2
        if img.shape[0] < chip.shape[0] or img.shape[1] < chip.shape[1]:
            raise InputDataError("sar", f"the image {img.shape} is smaller than the reference chip {chip.shape}")
        canvas = np.zeros_like(img)
        ci, cj = img.shape[0] // 2, img.shape[1] // 2
        canvas[ci - hi:ci + hi + 1, cj - hj:cj + hj + 1] = chip
        coarse = register(canvas, img, use_magnitude=True, subpixel="none")
        i1 = ci + int(coarse.shift_pixels[0])
        if not circular:
            i1 = min(max(i1, hi), img.shape[0] - hi - 1)
        j1 = min(max(cj + int(coarse.shift_pixels[1]), hj), img.shape[1] - hj - 1)
        return coarse, i1, j1

    def _fine(self, image, ch, i1, j1, precision: bool = True, circular: bool = True):
        """(row, col) of the anchor in ``image`` (fractional pixels) from the chip against the image cut around
        (i1, j1) (circularly in azimuth for RDA blocks): correlation peak, refined by least squares
        (``imaging.registration.refine_shift``); its predicted 1-sigma in pixels from the receiver-noise model
        (``magnitude_shift_precision``, docs/scenarios/rda-nav.md §3) and the normalised correlation of the match."""
        chip_c, anchor = ch["chip"], ch["anchor"]
        chip = np.abs(chip_c)
        hi, hj = chip.shape[0] // 2, chip.shape[1] // 2
        rows = np.arange(i1 - hi, i1 + hi + 1)
        rows = rows % image.shape[0] if circular else rows
        window = np.ix_(rows, np.arange(j1 - hj, j1 + hj + 1))
        cut = np.abs(image[window])
        fine = register(chip, cut, use_magnitude=True, subpixel=self.settings.subpixel)
        shift = refine_shift(chip, cut, fine.shift_pixels)
        noise_rows = rows if circular else ch["rows"]
        sigma = (magnitude_shift_precision(chip_c, image[window], shift, (ch.get("chip_noise", ch["noise"]), ch["rows"]),
                                           (ch["noise"], noise_rows), phase_turn=ch.get("phase_turn"))
                 if precision else (np.nan, np.nan))
        return i1 + shift[0] + anchor[0], j1 + shift[1] + anchor[1], {"sigma_px": sigma, "quality": fine.peak}

    @staticmethod
    def _take_focus(r, k, slope, offset, spread, out) -> None:
        """The focusing-shift model of the match (``_focus_sensitivity``), its spread added to the along-track sigma."""
        out.sensitivity[r, k], out.focus_offset[r, k] = slope, offset
        out.sigma[r, k, 1] = math.hypot(out.sigma[r, k, 1], spread)

    def _focus_sensitivity(self, refocus, ch, speed_hat, speed_sigma, i1, j1, along_m,
                           circular: bool = True) -> tuple[float, float, float]:
        """How the along-track registration [m] depends on the focusing speed, statistically linearised over the
        filter's uncertainty of the speed (docs/scenarios/rda-nav.md §2).

        The same data are focused at ``V_i = speed_hat + x_i`` with x in (-h, 0, +h), h = sqrt(3) sigma_V (at least
        ``FOCUS_STEP`` speed_hat) (``refocus(x)``: RDA with that speed; BPA with the estimated positions stretched
        along track by 1 + x / speed_hat) and registered at the same place (the cut around i1, j1): g_i
        (``along_m((row, col), x)``: the along-track metres of the TOC of a match in the image focused at x, relative
        to g_0). The unscented weights (1/6, 2/3, 1/6) of V ~ N(speed_hat, sigma_V^2) give the regression
        g(V) = mean + slope (V - speed_hat) + e with slope = (g_+ - g_-) / 2h, and with q = (g_+ + g_-) / 2 - g_0:
        mean - g_0 = q / 3, var(e) = 2 q^2 / 9. An image focused with a wrong speed moves a target whose TOC is off
        the aperture centre (about 2 (eta0 - eta_c) (V - speed_hat) for a strong azimuth chirp; irregular for weak
        ones, K T^2 of a few), so the measured along-track registration is ``slope (speed_hat - V) - q/3 + e``.
        Returns (slope [s], -q/3 [m], sqrt(var e) [m])."""
        step = max(FOCUS_STEP * speed_hat, math.sqrt(3.0) * (0.0 if speed_sigma is None else float(speed_sigma)))
        g = []
        for sgn in (1.0, -1.0):
            r_i, c_i, _ = self._fine(refocus(sgn * step), ch, i1, j1, precision=False, circular=circular)
            g.append(along_m((r_i, c_i), sgn * step))
        q = 0.5 * (g[0] + g[1])
        return (g[0] - g[1]) / (2.0 * step), -q / 3.0, math.sqrt(2.0 / 9.0) * abs(q)

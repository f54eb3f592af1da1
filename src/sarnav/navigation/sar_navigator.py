"""The SAR-aided navigator's update of one interval: INS + altimeter + image-derived range / cross-range pairs.

One filter loop for every source of measurements: the simulated campaign (``simulation.rda_nav``) and a recorded
flight (``recording.navigate``) both hand :class:`SarNavigator` the interval the navigator flew
(``Navigator.propagate``), the altimeter value and the SAR pairs, and it does the rest the same way (Lindstrom et
al., NAVIGATION 69(3) eqs. 48-57; docs/scenarios/rda-nav.md §2-§3):

* the images: the extractor (``measurements.sar_image.SubApertureImager``) focuses the aperture's pulses along the
  navigator's *own* estimated track of the interval (its positions, velocities and attitudes at the step epochs),
  with the filter's 1-sigma of the forward speed (mapdrift gate) and of the target's along-track position (BPA
  search grid); :meth:`SarNavigator.measure_images` -> ``SarAiding.take`` (R of each pair, focusing-shift model,
  which pairs were measured);
* the pairs: z = (image range of closest approach + range offset, cross-range offset): cross-range is 0 at zero
  Doppler; the offsets are what a simulated world adds (its truth biases and any white noise), zero for a real
  flight; each pair referred to its measured time of closest approach (TOC), or the aperture centre where the image
  gave none (:meth:`SarNavigator.image_pairs`);
* the update (:meth:`SarNavigator.update`): the altimeter's prediction and every pair's (``SarAiding.predict``:
  models at the TOC, map noise, delayed state, second order) stacked, with the cross-covariance C of the
  delayed-state events; the pairs screened (``SarAiding.screen``: the image's own failures, then the chi-square
  gate); ``Navigator.update`` with the rejected pairs left out.

The navigator never sees truth here: the measurements come from the caller. The oracle mode of the campaign makes
its pairs from truth itself and hands them in the same way.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from sarnav.filters import ErrorStateLayout
from sarnav.filters.ekf import directional_sigma
from sarnav.filters.prediction import stack_predictions
from sarnav.filters.update import Fused
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.navigation.navigator import Interval, Navigator
from sarnav.navigation.sar_aiding import SarAiding, SarUpdateSettings

__all__ = ["SarNavigator", "AidedUpdate", "STATE_LAYOUT", "COV_STEP", "UPDATE_SECONDS"]

#: the error state: p, v, attitude, accelerometer and gyro biases, and the altimeter, SAR range and SAR cross-range
#: biases (first-order Gauss-Markov)
STATE_LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_cross"), scalar_units=("m", "m", "m"))
#: covariance-propagation step [s] (F held constant over a step); also the INS history spacing of an aperture
COV_STEP = 0.1
#: the update interval [s]: one aperture (one second of the radar's pulses) and one altimeter value per update
UPDATE_SECONDS = 1.0


@dataclass
class AidedUpdate:
    """What one update did, per run (R runs, T pairs): ``fused`` (residual, residual_sigma (R, m), NIS, dof: the
    navigator's ``Fused``), ``z`` (R, m) the measurements (altimeter first, then range, cross-range of each pair),
    ``status`` (R, T) why each pair was not fused (``sar_aiding.REJECTIONS`` index, 0: fused; None without pairs),
    ``rejected`` (R,) the first non-zero code among the pairs (0: all fused), ``pairs_fused`` (R,), ``seconds`` the wall time
    of the prediction per run."""

    fused: Fused
    z: np.ndarray
    status: np.ndarray | None
    rejected: np.ndarray
    pairs_fused: np.ndarray
    seconds: float


class SarNavigator:
    """The update loop of the INS + altimeter + SAR navigator around a :class:`Navigator` (module docstring).

    navigator : the filter (its estimate, covariance and error model); alt_sigma : the altimeter's white-noise
    1-sigma [m] (None: no altimeter); sar : how the SAR pairs are modelled and screened (None: no SAR);
    targets : reference points (pairs) per aperture; image : the pairs come from images (R from each image), else
    from an oracle (R from ``sar.sar_sigma``)."""

    def __init__(self, navigator: Navigator, alt_sigma: float | None, sar: SarUpdateSettings | None = None,
                 targets: int = 1, image: bool = True):
        self.navigator, self.layout = navigator, navigator.layout
        self.alt = None if alt_sigma is None else AltimeterMeasurement(alt_sigma, self.layout)
        self.aid = None if sar is None else SarAiding(sar, self.layout, navigator.runs, targets, image=image)

    def measure_images(self, imager, aperture: int, iv: Interval, map_targets):
        """``imager.measure`` of ``aperture`` along the navigator's estimated track ``iv``, the images centred where
        the map puts the targets (``map_targets`` (R, T, 3)); the aiding takes each pair's R and focus model.
        Returns the ``ApertureMeasurements``."""
        nv, aid = self.navigator, self.aid
        speed_sigma = directional_sigma(nv.P, self.layout.slice("v"), nv.nav.v)
        am = imager.measure(aperture, iv.t, iv.p, iv.v, speed_sigma, map_targets=map_targets,
                            along_sigma=aid.along_sigma(nv, iv, map_targets[:, 0]), ap_q=iv.q)
        aid.take(am)
        return am

    def image_pairs(self, am, iv: Interval, offsets) -> tuple[np.ndarray, np.ndarray]:
        """(z (R, 2T): range, cross-range of each pair, TOC each refers to (R, T)) of the image measurements ``am``:
        range = image range + ``offsets[..., 0]``, cross-range = ``offsets[..., 1]`` (0 at zero Doppler;
        ``offsets`` (R, T, 2) [m], what a simulated world adds, zeros for a real flight); the TOC measured by the
        image, or the aperture centre where it gave no measurement."""
        offsets = np.broadcast_to(offsets, am.range.shape + (2,))
        z = np.stack([am.range + offsets[..., 0], offsets[..., 1]], axis=2)
        centre = 0.5 * (iv.t[0] + iv.t[-1])
        return z.reshape(z.shape[0], -1), np.where(self.aid.status == 0, am.toc, centre)

    def update(self, iv: Interval, z_alt=None, z_sar=None, eta=None, map_targets=None,
               map_sigma=None) -> AidedUpdate | None:
        """Fuse the altimeter value ``z_alt`` (R, 1) and the SAR pairs ``z_sar`` (R, 2T) referred to their TOC ``eta``
        (R, T) of the map's targets ``map_targets`` (R, T, 3) (1-sigma ``map_sigma`` (T, 3), default the settings')
        at the end of interval ``iv``; the rejected pairs are left out. None when there is nothing to fuse."""
        nv, R, n = self.navigator, self.navigator.runs, self.layout.n
        if z_alt is None and z_sar is None:
            return None
        pred = z = status = None
        seconds = 0.0
        if z_alt is not None:
            pred = self.alt.predict(nv.nav).replace(hessians=None, C=np.zeros((R, n, 1)))
            z = z_alt
        if z_sar is not None:
            t0 = _time.perf_counter()
            sar = self.aid.predict(nv, iv, eta, map_targets, map_sigma)
            pred = sar if pred is None else stack_predictions([pred.replace(C=None), sar])
            if pred.C is None:
                pred = pred.replace(C=np.zeros((R, n, pred.dim)))
            z = z_sar if z is None else np.concatenate([z, z_sar], axis=1)
            seconds = (_time.perf_counter() - t0) / R
            first = 0 if z_alt is None else 1
            status = self.aid.screen(nv, pred, z, first=first)
        keep = np.ones(pred.z_hat.shape, dtype=bool)
        if status is not None:
            keep[:, first:] = np.repeat(status == 0, 2, axis=1)
            rejected = np.array([next((int(c) for c in row if c), 0) for row in status], dtype=np.int64)
            pairs = np.sum(status == 0, axis=1)
        else:
            rejected, pairs = np.zeros(R, dtype=np.int64), np.zeros(R, dtype=np.int64)
        fused = nv.update(pred, z, keep)
        return AidedUpdate(fused, z, status, rejected, pairs, seconds)

"""SAR range / cross-range events of the navigator: what it predicts for an image's measurement and how it screens it.

Lindstrom et al., NAVIGATION 69(3), eqs. 48-57; docs/scenarios/rda-nav.md §2-§3. One sub-aperture gives, per
reference target of the map, a (range, cross-range) pair referred to the target's time of closest approach (TOC).
The navigator's side of it, with no truth anywhere:

* the models (``measurements.sar``) at the INS state interpolated to each run's TOC in the aperture's estimated
  track, the map's geolocation covariance mapped into R (``target_position_noise``), the delayed-state mapping from
  the TOC to the update epoch (``filters.delayed``, eq. 57) and the Gaussian second-order terms under the TOC
  covariance (``filters.second_order``);
* R from each image's own predicted registration 1-sigma (``SubApertureImager``), or constants
  (``registration_sigma``), plus the white noise the oracle mode adds;
* the screening of each pair: the image's own failure codes (``measurements.sar_image.FAILURES``), then the
  chi-square innovation gate (``gate_probability``).

The source of the images (the simulated world's echoes, or a recording's pulses) and the comparison of the
measurement with the geometric truth live outside (``sarnav.simulation.rda_nav``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters import delayed, second_order, update
from sarnav.filters.prediction import Prediction, stack_predictions
from sarnav.ins import NavState
from sarnav.measurements.sar import SarCrossRangeMeasurement, SarRangeMeasurement, target_position_noise
from sarnav.measurements.sar_image import FAILURES
from sarnav.navigation.navigator import Interval, Navigator
from sarnav.rotations import quat_to_dcm
from sarnav.trajectory.sampled import interpolate_state

__all__ = ["SarUpdateSettings", "SarAiding", "REJECTIONS", "measurement_sigma", "toc_state"]

#: why a SAR pair was not fused (``update_rejected``): the image's own failures, then the innovation gate
REJECTIONS = FAILURES + ("innovation gate",)


@dataclass(frozen=True)
class SarUpdateSettings:
    """How the navigator models and screens SAR pairs (the ``[sar]`` keys of an rda-nav scenario, SI)."""

    sar_sigma: np.ndarray  # (2,) Table 2 white noise 1-sigma: range, cross [m] (the oracle's noise; added on request)
    cross_model: str = "zero-doppler"
    delayed_state: bool = True
    second_order: bool = True
    gate_probability: float = 1e-4
    registration_sigma: np.ndarray | None = None  # (2,) constant R of image pairs: range, along-track [m]
    image_added_noise: bool = False
    geolocation_sigma: np.ndarray = field(default_factory=lambda: np.zeros(3))  # (3,) the map's 1-sigma N E D [m]
    focus: str = "estimate"  # the images are focused with the estimate: the focusing shift is modelled


def measurement_sigma(settings: SarUpdateSettings, image: bool):
    """(sigma (2,) [range, cross] of R before the images are made, 0/1 factor of Table 2's white noise added to z).

    Oracle: Table 2's noise is the measurement's only error and R = its variance. Image: R comes from each image's
    predicted registration sigma (``registration_sigma`` replaces it with constants); ``image_added_noise`` adds
    Table 2's noise on top (and to R).
    """
    if not image:
        return settings.sar_sigma.copy(), 1.0
    reg = np.ones(2) if settings.registration_sigma is None else settings.registration_sigma  # replaced by each image's
    if settings.image_added_noise:
        return np.hypot(settings.sar_sigma, reg), 1.0
    return reg.copy(), 0.0


def toc_state(nav: NavState, iv: Interval, eta) -> NavState:
    """The INS estimate at each run's TOC ``eta`` (R,): position and velocity interpolated in the aperture's
    history, the bias estimates of the update epoch."""
    p = np.stack([interpolate_state(iv.t, iv.p[r], eta[r]) for r in range(len(eta))])
    v = np.stack([interpolate_state(iv.t, iv.v[r], eta[r]) for r in range(len(eta))])
    return NavState(p=p, v=v, q=nav.q, ba=nav.ba, bg=nav.bg, bm=nav.bm)


class SarAiding:
    """The navigator's SAR pairs of one sub-aperture at a time, for R runs and T targets per image (module
    docstring). ``sigma`` (R, T, 2) the R of each pair, ``status`` (R, T) the image's failure codes (0: measured),
    ``sensitivity`` / ``focus_offset`` (R, T) the focusing shift model of each image (None before the first)."""

    def __init__(self, settings: SarUpdateSettings, layout, runs: int, targets: int, image: bool):
        self.settings, self.layout, self.T = settings, layout, int(targets)
        sig, self.add_white = measurement_sigma(settings, image)
        self.sigma = np.broadcast_to(sig, (runs, self.T, 2)).copy()
        self.sensitivity = self.focus_offset = None
        self.status = np.zeros((runs, self.T), dtype=np.int64)
        self.D = np.diag(np.asarray(settings.geolocation_sigma, dtype=np.float64) ** 2)

    def models(self, targets, iv: Interval, k: int):
        """The (range, cross-range) models of target k at the map's ``targets`` (R, 3)."""
        kw, s = {}, self.settings
        if s.cross_model == "paper":  # eq. 49: u_c and r_orig from each run's estimated aperture
            kw = dict(u_c=iv.p[:, -1] - iv.p[:, 0], r_orig=iv.p[:, 0])
        elif self.sensitivity is not None:
            kw = dict(focus_sensitivity=self.sensitivity[:, k], focus_offset=self.focus_offset[:, k])
        return (SarRangeMeasurement(targets, self.sigma[:, k, 0], self.layout),
                SarCrossRangeMeasurement(targets, self.sigma[:, k, 1], self.layout, model=s.cross_model, **kw))

    def predict(self, navigator: Navigator, iv: Interval, eta, map_targets, map_sigma=None) -> Prediction:
        """The stacked prediction of every target's pair (``map_targets`` (R, T, 3) what the map says, with its 1-sigma
        ``map_sigma`` (T, 3) N E D [m], default the settings' ``geolocation_sigma`` for every target), each referred
        to its own TOC ``eta[:, k]`` and mapped to the update epoch (the process noise shared between two targets' TOC
        intervals is not correlated across pairs: docs §3)."""
        if map_sigma is not None and not np.all(np.isfinite(np.asarray(map_sigma, dtype=np.float64))):
            raise InputDataError("map_sigma", "the map's geolocation 1-sigma must be finite [m] (NaN would switch "
                                 "its noise off)")
        D = ([self.D] * self.T if map_sigma is None
             else [np.diag(np.asarray(s, dtype=np.float64) ** 2) for s in np.asarray(map_sigma).reshape(self.T, 3)])
        return stack_predictions([self._predict_one(navigator, iv, eta[:, k], map_targets[:, k], k, D[k])
                                  for k in range(self.T)])

    def _predict_one(self, nv: Navigator, iv: Interval, eta, targets, k, D) -> Prediction:
        s = self.settings
        pred = stack_predictions([m.predict(toc_state(nv.nav, iv, eta)) for m in self.models(targets, iv, k)])
        if np.any(D > 0):
            pred = target_position_noise(pred, self.layout, D, (0, 1))
        if s.delayed_state:
            Phi_inv, Qd = delayed.back_transition(nv.model, quat_to_dcm(nv.nav.q), iv.f_mean, iv.t[-1] - eta)
            if s.second_order:
                pred = second_order.with_second_order(pred, delayed.covariance_at(nv.P, Phi_inv, Qd))
            return delayed.map_to_update_epoch(pred, Phi_inv, Qd)
        if s.second_order:
            pred = second_order.with_second_order(pred, nv.P)
        return pred.replace(hessians=None)

    def along_sigma(self, navigator: Navigator, iv: Interval, targets) -> np.ndarray:
        """(R,) the filter's 1-sigma of the zero-Doppler cross-range of the map's ``targets`` (R, 3) at the aperture
        centre: how far along track an image focused with the estimate may put it (sizes the BPA search grid)."""
        nav_now = navigator.nav
        mid = iv.p.shape[1] // 2
        nav = NavState(p=iv.p[:, mid], v=iv.v[:, mid], q=nav_now.q, ba=nav_now.ba, bg=nav_now.bg, bm=nav_now.bm)
        pred = self.models(targets, iv, 0)[1].predict(nav)
        S = update.innovation_covariance(navigator.P, pred.replace(R=np.zeros_like(pred.R), C=None))
        return np.sqrt(np.maximum(S[:, 0, 0], 0.0))

    def take(self, am) -> None:
        """From one aperture's ``ApertureMeasurements``, per run and target: the noise the filter assumes (the image's
        own prediction, or the configured constants, plus the added white noise where asked), the focusing shift
        model, which pairs have a measurement."""
        s = self.settings
        self.status = am.status.copy()
        ok = self.status == 0
        sigma = am.sigma if s.registration_sigma is None else np.broadcast_to(s.registration_sigma, am.sigma.shape)
        sigma = np.where(ok[..., None] & np.isfinite(sigma) & (sigma > 0), sigma, 1.0)
        if s.image_added_noise:
            sigma = np.hypot(s.sar_sigma, sigma)
        self.sigma = sigma
        if s.focus == "estimate":
            self.sensitivity = np.where(ok, np.nan_to_num(am.sensitivity), 0.0)
            self.focus_offset = np.where(ok, np.nan_to_num(am.focus_offset), 0.0)

    def screen(self, navigator: Navigator, pred: Prediction, z, first: int = 1) -> np.ndarray:
        """(R, T) rejection code of each run's SAR pairs (components ``first + 2k``, ``first + 2k + 1`` of ``pred``):
        the image's own (``status``), else the chi-square innovation gate of the pair, else 0 (fused)."""
        code = np.asarray(self.status, dtype=np.int64).copy()
        if self.settings.gate_probability > 0:
            ok = np.repeat(code == 0, 2, axis=1)
            present = np.concatenate([np.ones((z.shape[0], first), bool), ok], axis=1)
            zz = np.where(present, z, pred.z_hat)
            groups = [[first + 2 * k, first + 2 * k + 1] for k in range(self.T)]
            accepted = navigator.gate(pred, zz, groups, self.settings.gate_probability)
            code[(code == 0) & ~accepted] = REJECTIONS.index("innovation gate")
        return code

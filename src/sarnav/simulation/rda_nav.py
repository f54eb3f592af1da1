"""The ``rda-nav`` experiment: an INS + altimeter + SAR range/cross-range navigator flown through a simulated world.

Lindstrom et al., NAVIGATION 69(3) (extraction seed-001) and thesis ch. 5; design and gap decisions in
docs/scenarios/rda-nav.md. ``run(prm, seeds)`` flies a batch of runs and returns their records; the scenario kind
(``scenarios.rda_nav``) only parses the TOML into :class:`RdaNavParams` and calls it.

* the world (truth, truth IMU, initial error, measurement biases, error record): ``simulation.flight``; the scene of
  each sub-aperture and the reference pass: ``simulation.rda_nav_world``;
* the navigator (INS + covariance, one update path): ``navigation.Navigator``; its update of each interval
  (altimeter + SAR pairs: the images along its own track, the pairs' models at the TOC, delayed state, second order,
  map noise, gate, the fusion): ``navigation.sar_navigator.SarNavigator``, the loop ``sarnav navigate`` runs on a
  recorded flight;
* the measurements: the altimeter (``measurements.telemetry``) and the SAR pairs, made from images by
  ``measurements.sar_image.SubApertureImager`` (echoes simulated along the true track, imaged along the navigator's
  track; ``sar.measurement = "image"``) or synthesised from truth (``"oracle"``, the only mode in which truth enters a
  measurement: the truth state at the true TOC plus the truth FOGM bias and Table 2's white noise).

``sar.enabled = false`` flies with the altimeter only.

Random draws, per run from its own Generator, in this order: IMU biases (6), measurement biases (3), initial error
(18), measurement-bias drive (cov steps x 3), the clutter seed (1 integer), IMU sample 0; then per update the IMU
block, the altimeter noise and (SAR enabled) the two SAR noises. Run i depends only on prm and seeds[i]; the
reference targets are drawn from ``scene.seed`` (the same world for every run), the clutter from the run's clutter
seed (``scene.clutter_per_run``, default) or from ``scene.seed``.
"""

from __future__ import annotations

import hashlib
import math
import pickle
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from sarnav.ins import NavState
from sarnav.measurements.sar import SarCrossRangeMeasurement, SarRangeMeasurement
from sarnav.measurements.sar_image import ImagingSettings
from sarnav.measurements.sar_image import STAGES as IMAGE_STAGES
from sarnav.measurements.telemetry import AltimeterMeasurement
from sarnav.navigation import Interval
from sarnav.navigation.sar_aiding import REJECTIONS, SarUpdateSettings
from sarnav.navigation.sar_aiding import measurement_sigma as _aiding_sigma
from sarnav.navigation.sar_navigator import COV_STEP, STATE_LAYOUT, AidedUpdate, SarNavigator  # noqa: F401 (re-exported)
from sarnav.record import RunRecord
from sarnav.radar.params import RadarParams
from sarnav.simulation import rda_nav_world as world
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec
from sarnav.trajectory.base import Trajectory
from sarnav.trajectory.sampled import along_rate, closest_approach

__all__ = ["RdaNavParams", "run", "simulate_runs", "run_capture_images", "reference_targets",
           "measurement_sigma", "meas_names", "extra_attrs", "STATE_LAYOUT", "COV_STEP", "STAGES", "REJECTIONS",
           "MEASUREMENT_MODES", "MAX_TARGETS_PER_IMAGE", "MEAS_NAMES", "EXTRA_ATTRS"]

MEASUREMENT_MODES = ("oracle", "image")
STAGES = IMAGE_STAGES + ("update",)


def meas_names(targets: int) -> list[str]:
    """``alt, range, cross`` and, for several reference targets per image, ``range2, cross2, ...``."""
    out = ["alt"]
    for k in range(targets):
        out += [f"range{k + 1 if k else ''}", f"cross{k + 1 if k else ''}"]
    return out


def extra_attrs() -> dict:
    """Units and descriptions of the extra results.nc variables."""
    reasons = "; ".join(f"{i}: {r}" for i, r in enumerate(REJECTIONS) if i)
    return {
        "toc": {"units": "s", "description": "time of closest approach of the (first) reference target each SAR "
                                             "update refers to: measured from the image (image mode) or the truth"},
        "registration_error": {"units": "m", "description": "image-derived minus geometric truth: range of closest "
                                                            "approach (range), along-track TOC error x the rate of "
                                                            "the along-track offset (V on a straight track: "
                                                            "trajectory.sampled.along_rate) less the modelled focusing shift "
                                                            "(cross); NaN for the altimeter"},
        "registration_sigma": {"units": "m", "description": "1-sigma of the registration predicted from each image "
                                                            "(imaging.registration.magnitude_shift_precision and the "
                                                            "focus sensitivity): range, along-track; the R of the update"},
        "autofocus_dk": {"units": "Hz/s", "description": "mapdrift correction of the azimuth FM rate, K_a - K_amf"},
        "stage_seconds": {"units": "s", "description": "wall time per stage of each image and update (per run)"},
        "update_rejected": {"units": "1", "description": "0 when every SAR pair of the update was fused, else why "
                                                         f"the first one was not: {reasons}",
                            "flag_values": list(range(len(REJECTIONS))), "flag_meanings": " ".join(
                                r.replace(" ", "_").replace("(", "").replace(")", "") or "fused" for r in REJECTIONS)},
        "pairs_fused": {"units": "1", "description": "SAR (range, cross-range) pairs fused in the update"},
    }


#: the most reference targets per image (``scene.targets_per_image``)
MAX_TARGETS_PER_IMAGE = 8
#: the measurement names of an update with the most targets: an update of T targets has the first 1 + 2 T
MEAS_NAMES = tuple(meas_names(MAX_TARGETS_PER_IMAGE))
#: units and descriptions of the extra results.nc variables (:func:`extra_attrs`)
EXTRA_ATTRS = extra_attrs()


@dataclass(frozen=True)
class RdaNavParams:
    """Validated, SI-converted content of an rda-nav scenario."""

    runs: int
    trajectory: Trajectory
    altitude: float
    imu: ImuSpec  # the truth sensor
    imu_filter: ImuSpec  # the filter's model of it
    imu_rate: float
    alt_sigma: float
    sar_enabled: bool
    measurement: str
    cross_model: str
    delayed_state: bool
    second_order: bool
    sar_sigma: np.ndarray  # (2,) range, cross [m]
    registration_sigma: np.ndarray | None  # (2,) image mode override of the predicted 1-sigma: range, along-track [m]
    image_added_noise: bool
    gate_probability: float
    imaging: ImagingSettings
    bias_sigma: np.ndarray  # (3,) b_alt, b_range, b_cross steady-state sigma [m]
    bias_tau: np.ndarray  # (3,)
    radar: RadarParams
    snr_db: float  # receiver noise: per-sample SNR of the reflector [dB]
    scene: dict
    p0_sigma: np.ndarray  # (18,)
    earth_rate: np.ndarray | None = None  # [earth]: omega_ie^t when earth.rotation, else None
    filter_earth_rate: np.ndarray | None = None  # what the INS / filter assume (None unless earth.modelled)

    @property
    def n_updates(self) -> int:
        return int(math.floor(self.trajectory.duration + 1e-9))

    @staticmethod
    def receive_window(trajectory: Trajectory, scene: dict, look_side: str, pulse_length: float, sample_rate: float,
                       margin: float) -> dict:
        """``near_range`` and ``n_range_samples`` of the receive window that follows the geometry, before the radar
        exists (for the parser): the slant ranges of every scatterer the sub-apertures may image on the flight over
        ``scene`` (``rda_nav_world.slant_range_span``, widened by ``margin`` [m]) plus the pulse's half-extent cT/4."""
        flight = world.WorldFlight(trajectory, scene, SimpleNamespace(look_side=look_side),
                                   int(math.floor(trajectory.duration + 1e-9)))
        return world.receive_window({"pulse_length": pulse_length, "sample_rate": sample_rate},
                                    world.slant_range_span(flight, margin))

    @property
    def samples_per_update(self) -> int:
        return int(round(self.imu_rate))

    @property
    def samples_per_step(self) -> int:
        return int(round(self.imu_rate * COV_STEP))

    @property
    def targets_per_image(self) -> int:
        return self.scene["targets_per_image"]

    @property
    def focus(self) -> str:
        return self.imaging.focus

    @property
    def sar_update(self) -> SarUpdateSettings:
        """How the navigator models and screens the SAR pairs (``navigation.sar_aiding``)."""
        return SarUpdateSettings(sar_sigma=self.sar_sigma, cross_model=self.cross_model,
                                 delayed_state=self.delayed_state, second_order=self.second_order,
                                 gate_probability=self.gate_probability, registration_sigma=self.registration_sigma,
                                 image_added_noise=self.image_added_noise,
                                 geolocation_sigma=np.asarray(self.scene["geolocation_sigma"], dtype=np.float64),
                                 focus=self.imaging.focus)


def measurement_sigma(prm: RdaNavParams, image: bool):
    """(sigma (2,) [range, cross] of R before the images are made, 0/1 factor of Table 2's white noise added to z):
    ``navigation.sar_aiding.measurement_sigma`` of the scenario's settings."""
    return _aiding_sigma(prm.sar_update, image)


def reference_targets(prm: RdaNavParams) -> np.ndarray:
    """(U, 3) the first geolocated reference target of each sub-aperture (``rda_nav_world.reference_targets`` gives
    all of them, (U, T, 3))."""
    return world.reference_targets(prm)[:, 0]


# --- the Monte Carlo ------------------------------------------------------------------------------

class _Sar:
    """The world's side of the SAR pairs of one sub-aperture (one per reference target): the true targets and what
    the map says of them, the measurements (the images the navigator forms along its own track, plus what the world
    adds to them; or the oracle's truth), and the comparison of each image with the geometric truth. The navigator's
    side is ``nav`` (:class:`~sarnav.navigation.sar_navigator.SarNavigator`)."""

    def __init__(self, prm: RdaNavParams, fl: ErrorStateFlight, imager, nav: SarNavigator):
        self.prm, self.fl, self.imager, self.nav = prm, fl, imager, nav
        self.T = prm.targets_per_image
        self.targets = world.reference_targets(prm)  # (U, T, 3) truth
        self.map = self.targets[None] + world.map_errors(prm, fl.extra)  # (R, U, T, 3) what the map says
        self.aid = nav.aid

    def measure(self, u: int, iv: Interval, noise, record: dict):
        """(z (R, 2T), TOC each pair's prediction refers to (R, T)): from the images, or the oracle's truth."""
        fl, prm, R, aid = self.fl, self.prm, self.fl.R, self.aid
        j, steps = fl.j, fl.steps
        bm = fl.bm_truth[:, j]
        truth_track = fl.truth_out.position[u * steps:j + 1]
        true_toc = [closest_approach(self.targets[u, k], iv.t, truth_track) for k in range(self.T)]
        if self.imager is None:
            return self._oracle(u, iv, noise, bm, true_toc)
        am = self.nav.measure_images(self.imager, u, iv, self.map[:, u])
        n_add = (prm.sar_sigma[None, None, :] * noise.reshape(R, self.T, 2)) * aid.add_white
        # what the world adds to the image-derived range and to cross-range (0 at zero Doppler): truth biases + noise
        self.added = np.stack([bm[:, 1:2] + n_add[..., 0], bm[:, 2:3] + n_add[..., 1]], axis=2)
        self._record(u, am, true_toc, record)
        return self.nav.image_pairs(am, iv, self.added)

    def _oracle(self, u: int, iv: Interval, noise, bm, true_toc):
        """The oracle: the models at the truth state of the true TOC, plus the truth bias and Table 2's noise."""
        fl, prm, R = self.fl, self.prm, self.fl.R
        z, eta = [], np.empty((R, self.T))
        for k, (eta_true, _, p_true) in enumerate(true_toc):
            v_true = prm.trajectory.state(np.array([eta_true])).velocity[0]
            truth_toc = NavState(p=np.broadcast_to(p_true, (R, 3)), v=np.broadcast_to(v_true, (R, 3)),
                                 q=fl.nav.q, ba=fl.nav.ba, bg=fl.nav.bg, bm=bm)
            # the oracle measures the true target (the map's error enters only through the prediction)
            sigma = self.aid.sigma
            ms = [SarRangeMeasurement(self.targets[u, k], sigma[:, k, 0], fl.layout),
                  SarCrossRangeMeasurement(self.targets[u, k], sigma[:, k, 1], fl.layout,
                                           model=prm.cross_model, **(dict(u_c=iv.p[:, -1] - iv.p[:, 0],
                                                                          r_orig=iv.p[:, 0])
                                                                     if prm.cross_model == "paper" else {}))]
            z += [m.simulate(truth_toc, noise=noise[:, 2 * k + i:2 * k + i + 1]) for i, m in enumerate(ms)]
            eta[:, k] = eta_true
        return np.concatenate(z, axis=1), eta

    def _record(self, u, am, true_toc, record) -> None:
        V = self.prm.trajectory.speed
        for k, (eta_true, r_true, _) in enumerate(true_toc):
            record["registration_error"][:, u, 1 + 2 * k] = am.range[:, k] - r_true
            # along track: what the image's TOC says beyond the truth, in the metres of the cross-range measurement
            # (the along-track offset of the target at the TOC, which moves at the rate along_rate: V on a straight
            # track), less the modelled shift of focusing with a speed that is not the true one (sensitivity x
            # (V_focus - V), §2): the registration error proper
            shift = (np.nan_to_num(am.sensitivity[:, k]) * (am.speed - V) + np.nan_to_num(am.focus_offset[:, k])
                     if self.prm.focus == "estimate" else 0.0)
            rate = along_rate(self.prm.trajectory, self.targets[u, k], eta_true)
            record["registration_error"][:, u, 2 + 2 * k] = rate * (am.toc[:, k] - eta_true) - shift
            record["registration_sigma"][:, u, 1 + 2 * k:3 + 2 * k] = am.sigma[:, k]
        record["autofocus_dk"][:, u] = am.autofocus_dk
        record["stage_seconds"][:, u, :len(IMAGE_STAGES)] += am.seconds
        if am.capture is not None:
            record["capture"] = am.capture


#: the noise models of the last parameters this process imaged with (``_shared_store``)
_SHARED: dict = {}


def _shared_store(prm: RdaNavParams) -> dict:
    """The noise models the imagers of one campaign share in this process (a worker's chunks, one after another:
    without it each chunk paid the reference set-up again, which made small chunks slow): keyed by the parameters'
    pickled bytes, only the latest kept (a few MB)."""
    key = hashlib.sha256(pickle.dumps(prm, protocol=4)).hexdigest()
    if _SHARED.get("key") != key:
        _SHARED.clear()
        _SHARED["key"] = key
    return _SHARED.setdefault("store", {})


def forget_shared_noise_models() -> None:
    """Drop the noise models kept for the next chunk (``_shared_store``): a benchmark timing a cold chunk."""
    _SHARED.clear()


def _imager(prm: RdaNavParams, fl: ErrorStateFlight, capture_aperture=None):
    if not (prm.sar_enabled and prm.measurement == "image"):
        return None
    # the per-run clutter seeds (fl.extra) also key the in-flight receiver noise
    imager = world.world_imager(prm, fl.extra, capture_aperture=capture_aperture)[1]
    imager.share_noise_models(_shared_store(prm))
    return imager


def run(prm: RdaNavParams, seeds, run_ids=None, observer=None) -> list[RunRecord]:
    """The records of the runs with ``seeds`` (numbered ``run_ids``, default 0, 1, ...), flown as one batch (module
    docstring). ``observer`` (``simulation.export``) sees what the navigator is handed, without changing a number:
    ``observer.start(flight, sar)`` once the world is drawn (``flight.navigator`` at its initial estimate; ``sar``
    None, or the world's SAR side: ``targets`` (U, T, 3), ``map`` (R, U, T, 3), ``imager`` and its ``source``), and
    ``observer.interval(u, flight, z_alt, sar)`` after the measurements of interval u, before the update
    (``flight.imu_block``: the interval's IMU samples; ``sar.added`` (R, T, 2): what the world added to the
    image-derived range and to cross-range, its truth biases and any white noise)."""
    return _simulate(prm, range(len(seeds)) if run_ids is None else run_ids, seeds, observer=observer)[0]


def simulate_runs(prm: RdaNavParams, run_ids, seeds) -> list[RunRecord]:
    """:func:`run` in the argument order of the scenario kinds."""
    return run(prm, seeds, run_ids)


def run_capture_images(prm: RdaNavParams, seed, aperture: int) -> dict:
    """The images of sub-aperture ``aperture`` of the run with ``seed`` (reference, in flight before and after
    mapdrift, correlation surface; ``measurements.sar_image.SubApertureImager``), for figures. The run's numbers
    are the same as without the capture."""
    return _simulate(prm, [0], [seed], capture_aperture=aperture)[1].get("capture")


def _new_record(R: int, n_upd: int, M: int) -> dict:
    nan = lambda *s: np.full(s, np.nan)  # noqa: E731
    return {"residual": nan(R, n_upd, M), "residual_sigma": nan(R, n_upd, M), "nis": np.empty((R, n_upd)),
            "nis_dof": np.zeros((R, n_upd), dtype=np.int64), "toc": nan(R, n_upd),
            "update_rejected": np.zeros((R, n_upd), dtype=np.int64), "pairs_fused": np.zeros((R, n_upd), dtype=np.int64),
            "registration_error": nan(R, n_upd, M), "registration_sigma": nan(R, n_upd, M),
            "autofocus_dk": nan(R, n_upd), "stage_seconds": np.zeros((R, n_upd, len(STAGES)))}


def _simulate(prm: RdaNavParams, run_ids, seeds, capture_aperture=None, observer=None):
    L = STATE_LAYOUT
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, prm.bias_sigma, prm.bias_tau, prm.p0_sigma,
                      prm.n_updates, prm.samples_per_update, prm.samples_per_step, imu_filter=prm.imu_filter,
                      earth_rate=prm.earth_rate, filter_earth_rate=prm.filter_earth_rate)
    # the clutter seed is drawn after the bias drive, before IMU sample 0; F at the step's start attitude
    fl = ErrorStateFlight(spec, L, seeds, extra_draws=lambda rngs: [int(g.integers(2**63)) for g in rngs],
                          covariance_attitude="start")
    R, n_upd, T = fl.R, prm.n_updates, prm.targets_per_image
    alt = AltimeterMeasurement(prm.alt_sigma, L)
    imager = _imager(prm, fl, capture_aperture)
    nav = SarNavigator(fl.navigator, prm.alt_sigma, prm.sar_update if prm.sar_enabled else None, T,
                       image=imager is not None)
    sar = _Sar(prm, fl, imager, nav) if prm.sar_enabled else None
    rec = _new_record(R, n_upd, 1 + 2 * T)
    if observer is not None:
        observer.start(fl, sar)
    for u in range(n_upd):
        iv = fl.fly_interval(u)
        z_alt = alt.simulate(fl.truth, fl.rngs)
        z_sar = eta = None
        if sar is not None:
            noise = np.stack([g.standard_normal(2 * T) for g in fl.rngs])  # (R, 2T), drawn in every mode
            z_sar, eta = sar.measure(u, iv, noise, rec)
            rec["toc"][:, u] = eta[:, 0]
        if observer is not None:
            observer.interval(u, fl, z_alt, sar)
        up = nav.update(iv, z_alt, z_sar, eta, None if sar is None else sar.map[:, u])
        fl.record_update()
        _record_update(rec, u, up, sar is not None)
    return _records(prm, fl, run_ids, rec, image=sar is not None and sar.imager is not None), rec


def _record_update(rec: dict, u: int, up: AidedUpdate, sar: bool) -> None:
    """The record of update u: residuals, NIS and, with SAR, which pairs were fused and the prediction's time."""
    cols = slice(0, up.z.shape[1])
    rec["residual"][:, u, cols] = up.fused.residual
    rec["residual_sigma"][:, u, cols] = up.fused.residual_sigma
    rec["nis"][:, u], rec["nis_dof"][:, u] = up.fused.nis, up.fused.dof
    if sar:
        rec["stage_seconds"][:, u, -1] += up.seconds
        rec["update_rejected"][:, u] = up.rejected
        rec["pairs_fused"][:, u] = up.pairs_fused


def _records(prm, fl, run_ids, rec, image: bool) -> list[RunRecord]:
    t_out = fl.t_out
    t_upd = t_out[fl.steps::fl.steps]
    records = []
    for i in range(fl.R):
        extras = {"toc": (("update",), rec["toc"][i])}
        if prm.sar_enabled:
            extras["update_rejected"] = (("update",), rec["update_rejected"][i])
            extras["pairs_fused"] = (("update",), rec["pairs_fused"][i])
        if image:
            extras["registration_error"] = (("update", "meas"), rec["registration_error"][i])
            extras["registration_sigma"] = (("update", "meas"), rec["registration_sigma"][i])
            extras["autofocus_dk"] = (("update",), rec["autofocus_dk"][i])
            extras["stage_seconds"] = (("update", "stage"), rec["stage_seconds"][i])
        records.append(RunRecord(
            run=int(run_ids[i]), time=t_out.copy(), error=fl.err[i], sigma=fl.sig[i], nees=fl.nees[i],
            update_time=t_upd.copy(), residual=rec["residual"][i], residual_sigma=rec["residual_sigma"][i],
            nis=rec["nis"][i], nis_dof=rec["nis_dof"][i], extras=extras))
    return records

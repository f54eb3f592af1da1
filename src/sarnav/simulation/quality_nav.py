"""The ``quality-nav`` experiment: the INS aided by the best-focus along-track velocity of its own SAR images.

Hathaway (2023) scores images formed along candidate tracks; here the focus of each aperture becomes a measurement
the navigator fuses (docs/quality.md §7), with no reference map: no chip, no geolocated target.

* the world (truth, tactical IMU, error record): ``simulation.flight.ErrorStateFlight``; the navigator
  (``navigation.Navigator``) carries the 15-state error of position, velocity, attitude and IMU biases;
* the fixes: ``measurements.focus_image.FocusApertureImager`` (echoes of a points-over-clutter scene along the true
  track, receiver noise, the INS positions at the pulse times, kurtosis-optimal along-track velocity offset, and
  mapdrift's speed on the same pulses for comparison); the measurement model
  ``measurements.focus.FocusVelocityMeasurement`` (z = e . v(t_c), sigma^2 = kappa / curvature, kappa calibrated
  by Monte Carlo on apertures of the same configuration: ``FocusApertureImager.calibrate``);
* the update: ``filters.delayed`` (``delayed_state``: the fix refers to the aperture centre t_c, mapped to the update
  epoch with the process noise after t_c as correlated noise) and the navigator's correlated update.

``measurement = "oracle"`` replaces the fixes by e . v_true(t_c) + ``oracle_sigma`` noise (the only mode in which
truth becomes a measurement); ``enabled = False`` flies the free INS.

Random draws, per run from its own Generator, in this order: IMU biases (6), initial error (15), the scene seed
(one integer), IMU sample 0; then per update the IMU block and one unit normal (used by the oracle, drawn in every
mode). The scene of update u of a run is drawn from ``SeedSequence([scene seed, u])``; kappa's calibration from
``calibration_seed`` (the same for every run and batch: a pure function of the parameters).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sarnav.filters import ErrorStateLayout, delayed, update
from sarnav.filters.ekf import directional_sigma
from sarnav.ins import NavState
from sarnav.measurements.focus import FocusVelocityMeasurement, body_specific_force
from sarnav.measurements.focus_image import FocusApertureImager, FocusSettings
from sarnav.navigation import Interval
from sarnav.radar.params import RadarParams
from sarnav.record import RunRecord
from sarnav.rotations import quat_to_dcm
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec
from sarnav.trajectory import StraightLevel

__all__ = ["QualityNavParams", "run", "simulate_runs", "kappa_for", "LAYOUT", "MEAS_NAMES", "MEAS_UNITS",
           "EXTRA_ATTRS", "COV_STEP"]

COV_STEP = 0.1
LAYOUT = ErrorStateLayout(())  # p, v, th, ba, bg: no measurement bias
MEAS_NAMES = ("v_focus",)
MEAS_UNITS = ("m/s",)
EXTRA_ATTRS = {
    "focus_error": {"units": "m/s", "description": "focus fix minus the measurement model at the truth, e . v(t_c) "
                                                   "+ lever u . (a_INS - a) (NaN: no fix used)"},
    "focus_accel_term": {"units": "m/s", "description": "lever u . (a_INS - a): what the INS's line-of-sight "
                                                        "acceleration error adds to a fix (R / 2V times it)"},
    "focus_sigma": {"units": "m/s", "description": "1-sigma the filter gives the fix: sqrt(kappa / curvature) "
                                                   "(image) or focus.oracle_sigma"},
    "focus_curvature": {"units": "1/(m/s)^2", "description": "relative curvature -S''/S of the kurtosis at its peak"},
    "mapdrift_error": {"units": "m/s", "description": "mapdrift's speed on the same pulses minus the true speed "
                                                      "(compared, not fused; NaN: off or failed)"},
    "predicted_sigma": {"units": "m/s", "description": "the EKF's 1-sigma of e . v at t_c before the update"},
    "focus_used": {"units": "", "description": "1 where the fix was fused, 0 where there was none (no focused image, "
                                               "optimum at the search's end, failed image) or it was gated"},
    "focus_gated": {"units": "", "description": "1 where a fix was refused by the innovation gate focus.gate_sigmas"},
}


@dataclass(frozen=True)
class QualityNavParams:
    """Validated, SI-converted content of a quality-nav scenario."""

    runs: int
    trajectory: StraightLevel
    imu: ImuSpec
    imu_filter: ImuSpec
    imu_rate: float
    radar: RadarParams
    settings: FocusSettings
    p0_sigma: np.ndarray  # (15,)
    interval: float
    enabled: bool
    measurement: str
    delayed_state: bool
    oracle_sigma: float
    span_sigmas: float
    span_max: float
    gate_sigmas: float
    calibration_apertures: int
    calibration_seed: int
    calibration_key: str  # the scenario text kappa depends on (its cache key)
    earth_rate: np.ndarray | None = None  # [earth]: omega_ie^t when earth.rotation, else None
    filter_earth_rate: np.ndarray | None = None  # what the INS / filter assume (None unless earth.modelled)

    @property
    def n_updates(self) -> int:
        return int(round(self.trajectory.duration / self.interval))

    @property
    def samples_per_update(self) -> int:
        return int(round(self.imu_rate * self.interval))

    @property
    def samples_per_step(self) -> int:
        return int(round(self.imu_rate * COV_STEP))


_KAPPA: dict[str, dict] = {}


def kappa_for(prm: QualityNavParams) -> dict:
    """kappa of the configuration (``FocusApertureImager.calibrate`` on ``focus.calibration_apertures`` apertures with
    INS errors drawn from the initial 1-sigma), computed once per process and scenario text."""
    hit = _KAPPA.get(prm.calibration_key)
    if hit is None:
        imager = FocusApertureImager(prm.radar, prm.trajectory, prm.settings)
        hit = imager.calibrate(prm.calibration_apertures, prm.calibration_seed, prm.interval, prm.p0_sigma[:12],
                               prm.span_sigmas, prm.span_max)
        _KAPPA[prm.calibration_key] = hit
    return hit


# --- the Monte Carlo ------------------------------------------------------------------------------

def _state_at(nav: NavState, iv: Interval, t: float) -> NavState:
    """The INS estimate at time t inside the interval: p, v interpolated in its history, the rest of the update
    epoch (only v enters the focus measurement)."""
    p = np.stack([[np.interp(t, iv.t, iv.p[r, :, i]) for i in range(3)] for r in range(nav.p.shape[0])])
    v = np.stack([[np.interp(t, iv.t, iv.v[r, :, i]) for i in range(3)] for r in range(nav.p.shape[0])])
    return NavState(p=p, v=v, q=nav.q, ba=nav.ba, bg=nav.bg, bm=nav.bm)


class _Focus:
    """The focus measurement of one update for every run: z, the model, the record."""

    def __init__(self, prm: QualityNavParams, fl: ErrorStateFlight):
        self.prm, self.fl = prm, fl
        self.imager = FocusApertureImager(prm.radar, prm.trajectory, prm.settings)
        self.kappa = kappa_for(prm)["kappa"] if prm.measurement == "image" else None

    def measure(self, u: int, iv: Interval, noise) -> dict:
        """z (R, 1), the model, ok (R,), t_c, mapdrift's speed and the curvature (R,) of update u."""
        prm, fl = self.prm, self.fl
        t_end = float(iv.t[-1])
        times = self.imager.times(t_end)
        t_c = 0.5 * (times[0] + times[-1])
        v_true = prm.trajectory.state(np.array([t_c])).velocity[0]
        nan = np.full(fl.R, np.nan)
        truth_c = replace(fl.truth, v=np.broadcast_to(v_true, (fl.R, 3)).copy())  # truth at t_c (biases: epoch's)
        if prm.measurement == "oracle":
            nav_c = _state_at(fl.nav, iv, t_c)
            geo = [self.imager.geometry(nav_c.p[r], nav_c.v[r]) for r in range(fl.R)]
            model = FocusVelocityMeasurement(LAYOUT, nav_c.v, np.full(fl.R, prm.oracle_sigma), **self.coupling(
                np.array([g[1] for g in geo]), np.array([g[2] for g in geo]), iv))
            return {"z": model.simulate(truth_c, noise=noise), "model": model, "ok": np.ones(fl.R, bool), "t_c": t_c,
                    "mapdrift": nan, "curvature": nan, "truth_c": truth_c}
        spans = self.spans(iv, t_c)
        fx = self.imager.measure(t_end, iv.t, iv.p, iv.v, [[int(s), u] for s in fl.extra], spans)
        ok = fx.ok
        e = np.where(ok[:, None], fx.direction, fx.v_hat)
        sigma = np.where(ok, np.sqrt(self.kappa / np.where(ok, fx.curvature, 1.0)), 1.0)
        model = FocusVelocityMeasurement(LAYOUT, e, sigma, **self.coupling(fx.los, fx.lever, iv))
        return {"z": np.where(ok, fx.value, 0.0)[:, None], "model": model, "ok": ok, "t_c": t_c,
                "mapdrift": fx.mapdrift_speed, "curvature": np.where(ok, fx.curvature, np.nan), "truth_c": truth_c}

    def spans(self, iv: Interval, t_c: float) -> np.ndarray:
        """Half-width of each run's first search stage: focus.span_sigmas x the filter's predicted 1-sigma of the fix
        (sqrt(H P H^T), the acceleration coupling included), clipped to [focus.span, focus.span_max] [m/s]."""
        prm, fl = self.prm, self.fl
        nav_c = _state_at(fl.nav, iv, t_c)
        geo = [self.imager.geometry(nav_c.p[r], nav_c.v[r]) for r in range(fl.R)]
        model = FocusVelocityMeasurement(LAYOUT, nav_c.v, 1.0, **self.coupling(
            np.array([g[1] for g in geo]), np.array([g[2] for g in geo]), iv))
        pred, _ = _predict(prm, fl, iv, model, t_c)
        s_pred = np.sqrt(np.maximum(update.innovation_covariance(fl.P, pred)[:, 0, 0] - pred.R[:, 0, 0], 0.0))
        return np.clip(prm.span_sigmas * s_pred, prm.settings.span, prm.span_max)

    def coupling(self, los, lever, iv: Interval) -> dict:
        """The acceleration coupling of the fix (``FocusVelocityMeasurement``): the INS's specific force of the
        interval's last step, in the nav frame (f_ref) and back in the body frame with its bias estimate (f_body)."""
        nav = self.fl.nav
        return {"los": los, "lever": lever, **body_specific_force(nav.q, iv.f_mean, nav.ba)}


def _predict(prm: QualityNavParams, fl: ErrorStateFlight, iv: Interval, model, t_c: float):
    """(prediction at the update epoch, covariance at t_c): the model at the INS state of t_c, mapped by the
    delayed-state strategy (``focus.delayed_state``)."""
    pred = model.predict(_state_at(fl.nav, iv, t_c)).replace(hessians=None)
    if not prm.delayed_state:
        return pred, fl.P
    span = np.full(fl.R, float(iv.t[-1]) - t_c)
    Phi_inv, Qd = delayed.back_transition(fl.model, quat_to_dcm(fl.nav.q), iv.f_mean, span)
    return delayed.map_to_update_epoch(pred, Phi_inv, Qd), delayed.covariance_at(fl.P, Phi_inv, Qd)


def _update(prm: QualityNavParams, fl: ErrorStateFlight, iv: Interval, z, model, ok, t_c):
    """The navigator's (delayed-state) correlated update, runs without a fix (or whose innovation is beyond
    ``focus.gate_sigmas``) left out; returns (Fused, predicted sigma of e . v at t_c, used (R,))."""
    pred, Pc = _predict(prm, fl, iv, model, t_c)
    predicted = directional_sigma(Pc, LAYOUT.slice("v"), np.broadcast_to(model.directions, (fl.R, 3)))
    S = update.innovation_covariance(fl.P, pred)[:, 0, 0]
    ok = ok & (np.abs(np.asarray(z)[:, 0] - pred.z_hat[:, 0]) <= prm.gate_sigmas * np.sqrt(S))
    if pred.C is None:  # the correlated form with C = 0, as with the delayed state
        pred = pred.replace(C=np.zeros((fl.R, LAYOUT.n, pred.dim)))
    return fl.navigator.update(pred, z, ok[:, None]), predicted, ok


def run(prm: QualityNavParams, seeds, run_ids=None) -> list[RunRecord]:
    """The records of the runs with ``seeds`` (numbered ``run_ids``, default 0, 1, ...), flown as one batch."""
    return simulate_runs(prm, range(len(seeds)) if run_ids is None else run_ids, seeds)


def simulate_runs(prm: QualityNavParams, run_ids, seeds) -> list[RunRecord]:
    """The batched Monte Carlo of the ``quality-nav`` kind (module docstring)."""
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, np.zeros(0), np.zeros(0), prm.p0_sigma, prm.n_updates,
                      prm.samples_per_update, prm.samples_per_step, imu_filter=prm.imu_filter,
                      earth_rate=prm.earth_rate, filter_earth_rate=prm.filter_earth_rate)
    fl = ErrorStateFlight(spec, LAYOUT, seeds, extra_draws=lambda rngs: [int(g.integers(2**63)) for g in rngs],
                          covariance_attitude="start")
    R, U = fl.R, prm.n_updates
    nan = lambda: np.full((R, U), np.nan)  # noqa: E731
    rec = {"residual": nan(), "residual_sigma": nan(), "nis": np.zeros((R, U)), "nis_dof": np.zeros((R, U), int),
           **{k: nan() for k in EXTRA_ATTRS}}
    focus = _Focus(prm, fl) if prm.enabled else None
    for u in range(U):
        iv = fl.fly_interval(u)
        noise = np.stack([g.standard_normal(1) for g in fl.rngs])  # (R, 1), drawn in every mode
        if focus is None:
            fl.navigator.feedback(np.zeros((R, LAYOUT.n)), fl.P)
            fl.record_update()
            continue
        m = focus.measure(u, iv, noise)
        ok, model = m["ok"], m["model"]
        up, predicted, used = _update(prm, fl, iv, m["z"], model, ok, m["t_c"])
        rec["focus_used"][:, u] = used
        rec["focus_gated"][:, u] = ok & ~used
        ok = used
        fl.record_update()
        v_true = prm.trajectory.state(np.array([m["t_c"]])).velocity[0]
        e = np.broadcast_to(model.directions, (R, 3))
        h_true = model.predict(m["truth_c"]).z_hat[:, 0]  # the model at the truth: what an error-free fix gives
        rec["residual"][ok, u] = up.residual[ok, 0]
        rec["residual_sigma"][ok, u] = up.residual_sigma[ok, 0]
        rec["nis"][ok, u], rec["nis_dof"][ok, u] = up.nis[ok], up.dof[ok]
        rec["focus_error"][ok, u] = m["z"][ok, 0] - h_true[ok]
        rec["focus_accel_term"][:, u] = h_true - e @ v_true
        rec["focus_sigma"][ok, u] = np.broadcast_to(model.sigma, (R,))[ok]
        rec["focus_curvature"][:, u] = m["curvature"]
        rec["mapdrift_error"][:, u] = m["mapdrift"] - float(np.sqrt(v_true @ v_true))
        rec["predicted_sigma"][:, u] = predicted
    return _records(prm, fl, run_ids, rec)


def _records(prm, fl, run_ids, rec) -> list[RunRecord]:
    t_upd = fl.t_out[fl.steps::fl.steps]
    out = []
    for i in range(fl.R):
        extras = {k: (("update",), rec[k][i]) for k in EXTRA_ATTRS}
        out.append(RunRecord(run=int(run_ids[i]), time=fl.t_out.copy(), error=fl.err[i], sigma=fl.sig[i],
                             nees=fl.nees[i], update_time=t_upd.copy(), residual=rec["residual"][i][:, None],
                             residual_sigma=rec["residual_sigma"][i][:, None], nis=rec["nis"][i],
                             nis_dof=rec["nis_dof"][i], extras=extras))
    return out

"""The ``telemetry`` experiment: thesis chapter 3 (INS + altimeter, range and range-rate to one known ground target,
18-state error-state EKF; Figs 3.4-3.7, App. A.5-A.6), flown through the simulated world.

Per run: analytic truth trajectory -> IMU (white noise + FOGM biases) -> the navigator (``navigation.Navigator``:
strapdown INS, covariance propagation by closed-form Van Loan every ``COV_STEP_MAX`` s or less) -> altimeter, range
and range-rate updates at ``meas_rate`` -> full feedback and reset. The update strategy is ``strategy``:
``gaussian-sum`` (``filters.gaussian_sum``: second-order terms in every component, a component split where its
second-order term exceeds ``split_threshold`` of the filter's posterior 1-sigma of the measurement),
``second-order`` (one component) or ``ekf`` (first order, Joseph form, thesis eqs. 3.20-3.22); docs/scenarios/
telemetry.md "Target under the track". Truth enters only through the simulated sensors and the initial-error draw.

Random draws, per run from its own Generator and in this fixed order: IMU biases (6), measurement biases (3),
initial error (18), measurement-bias drive (cov steps x 3), IMU sample 0 (4 x 1 x 3); then per update interval the
IMU block (4 x m x 3) and the three measurement noises. Run i therefore depends only on ``seeds[i]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.filters import ErrorStateLayout
from sarnav.filters.gaussian_sum import GaussianSum, nonlinearity
from sarnav.errors import ConfigError
from sarnav.filters.prediction import stack_predictions
from sarnav.measurements.telemetry import AltimeterMeasurement, RangeMeasurement, RangeRateMeasurement
from sarnav.record import RunRecord
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec
from sarnav.trajectory.sampled import min_distance

__all__ = ["TelemetryParams", "run", "simulate_runs", "STATE_LAYOUT", "MEAS_NAMES", "MEAS_UNITS", "EXTRA_ATTRS",
           "COV_STEP_MAX", "MIN_TARGET_RANGE", "check_target_range"]

#: longest covariance-propagation step [s]; the step is the largest whole number of IMU samples
#: dividing the update interval that does not exceed it (F is held constant over a step).
COV_STEP_MAX = 0.1
STATE_LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_rate"), scalar_units=("m", "m", "m/s"))
#: validation limit: the closest approach of the track to the target [m] at an update (range rate and its Jacobian
#: divide by the range)
MIN_TARGET_RANGE = 1.0
MEAS_NAMES = ["alt", "range", "rate"]
MEAS_UNITS = ["m", "m", "m/s"]
EXTRA_ATTRS = {
    "components": {"units": "1", "description": "Gaussian-sum components used at the update (1: no split)"},
    "nonlinearity": {"units": "1", "description": "second-order term of each measurement at the estimate under the "
                     "filter's prior covariance: std of dx^T A dx / 2 over the posterior 1-sigma of the measurement"},
}


@dataclass(frozen=True)
class TelemetryParams:
    """The validated, SI-converted content of a telemetry scenario."""

    runs: int
    trajectory: object
    imu: ImuSpec  # the truth sensor
    imu_filter: ImuSpec  # the filter's model of it ([filter.imu], default [imu])
    imu_rate: float
    meas_rate: float
    meas_sigma: np.ndarray  # (3,) alt [m], range [m], rate [m/s]
    bias_sigma: np.ndarray  # (3,) FOGM steady-state sigma of b_alt, b_range, b_rate
    bias_tau: np.ndarray  # (3,)
    target: np.ndarray
    p0_sigma: np.ndarray  # (18,) 1-sigma of the initial error
    strategy: str = "gaussian-sum"  # update.strategy
    split_threshold: float = 0.1  # update.split_threshold
    max_components: int = 27  # update.max_components
    earth_rate: np.ndarray | None = None  # [earth]: omega_ie^t when earth.rotation, else None
    filter_earth_rate: np.ndarray | None = None  # what the INS / filter assume (None unless earth.modelled)

    @property
    def samples_per_update(self) -> int:
        return int(round(self.imu_rate / self.meas_rate))

    @property
    def samples_per_cov_step(self) -> int:
        m = self.samples_per_update
        best = 1
        for d in range(1, m + 1):
            if m % d == 0 and d / self.imu_rate <= COV_STEP_MAX + 1e-12:
                best = d
        return best

    @property
    def updates(self) -> int:
        return int(math.floor(self.trajectory.duration * self.meas_rate + 1e-9))


def check_target_range(trajectory, meas_rate: float, target) -> None:
    """Raise ConfigError("target.position_ned") when the track comes within ``MIN_TARGET_RANGE`` of the target at an
    update epoch (range, range rate and H, thesis eq. 3.17, divide by |r - p|)."""
    n_upd = int(math.floor(trajectory.duration * meas_rate + 1e-9))
    track = trajectory.state(np.arange(1, n_upd + 1) / meas_rate).position
    closest = min_distance(track, target)
    if closest < MIN_TARGET_RANGE:
        raise ConfigError("target.position_ned", f"must be >= {MIN_TARGET_RANGE} m from the aircraft at every update "
                          f"(range rate is undefined at the target), comes within {closest:.3g} m")


def run(prm: TelemetryParams, seeds, run_ids=None) -> list[RunRecord]:
    """The records of the runs with ``seeds`` (numbered ``run_ids``, default 0, 1, ...), flown as one batch."""
    return simulate_runs(prm, range(len(seeds)) if run_ids is None else run_ids, seeds)


def simulate_runs(prm: TelemetryParams, run_ids, seeds) -> list[RunRecord]:
    """The batched Monte Carlo of the ``telemetry`` kind (see the module docstring)."""
    L = STATE_LAYOUT
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, prm.bias_sigma, prm.bias_tau, prm.p0_sigma, prm.updates,
                      prm.samples_per_update, prm.samples_per_cov_step, imu_filter=prm.imu_filter,
                      earth_rate=prm.earth_rate, filter_earth_rate=prm.filter_earth_rate)
    mixture = prm.strategy != "ekf"
    # F at the mid-step attitude, mean f^n; a Gaussian sum also needs each interval's transition
    fl = ErrorStateFlight(spec, L, seeds, covariance_attitude="mid", interval_transition=mixture)
    R, n_upd, steps, t_out = fl.R, prm.updates, fl.steps, fl.t_out
    meas = [
        AltimeterMeasurement(prm.meas_sigma[0], L),
        RangeMeasurement(prm.target, prm.meas_sigma[1], L),
        RangeRateMeasurement(prm.target, prm.meas_sigma[2], L),
    ]
    slots = prm.max_components if prm.strategy == "gaussian-sum" else 1
    mix = GaussianSum.single(fl.P, slots) if mixture else None
    nv = fl.navigator

    def predict_at(run, dx):  # the measurements predicted from run[i]'s estimate corrected by dx[i]
        return stack_predictions([mk.predict(nv.corrected(run, dx)) for mk in meas])

    res, res_sig = np.empty((R, n_upd, 3)), np.empty((R, n_upd, 3))
    nis, comps, nonlin = np.empty((R, n_upd)), np.ones((R, n_upd), dtype=np.int64), np.empty((R, n_upd, 3))
    for u in range(n_upd):
        iv = fl.fly_interval(u)
        z = np.concatenate([mk.simulate(fl.truth, fl.rngs) for mk in meas], axis=1)
        pred = stack_predictions([mk.predict(nv.nav) for mk in meas])
        nonlin[:, u] = nonlinearity(pred, nv.P)  # under the filter's (mixture) covariance at its estimate
        if mixture:
            fused, comps[:, u] = nv.update_mixture(mix, predict_at, z, prm.split_threshold, iv)
        else:
            fused = nv.update(pred, z)
        fl.record_update()
        res[:, u], res_sig[:, u], nis[:, u] = fused.residual, fused.residual_sigma, fused.nis
    err, sig, nees = fl.err, fl.sig, fl.nees

    t_upd = t_out[steps::steps]
    return [
        RunRecord(
            run=int(run_ids[i]), time=t_out.copy(), error=err[i], sigma=sig[i], nees=nees[i],
            update_time=t_upd.copy(), residual=res[i], residual_sigma=res_sig[i], nis=nis[i],
            nis_dof=np.full(n_upd, 3, dtype=int),
            extras={"components": (("update",), comps[i]), "nonlinearity": (("update", "meas"), nonlin[i])},
        )
        for i in range(R)
    ]

"""The ``telemetry`` scenario kind: thesis chapter 3 (INS + altimeter, range and range-rate to one known ground target,
18-state error-state EKF, Monte Carlo; Figs 3.4-3.7, App. A.5-A.6). Configuration and wiring only: the defaults
(``defaults/telemetry.toml``: values the sources leave out are chosen there, a comment beside each;
docs/scenarios/telemetry.md), ``parse`` (TOML -> :class:`~sarnav.simulation.telemetry.TelemetryParams`) and the kind;
the experiment is ``sarnav.simulation.telemetry``.
"""

from __future__ import annotations

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError
from sarnav.montecarlo.kind import validate_campaign
from sarnav.scenarios.error_state import ErrorStateKind
from sarnav.scenarios.fields import bounded_positive, choice, get, integer
from sarnav.scenarios.fields import positive as _pos
from sarnav.scenarios.fields import vector as _vector
from sarnav.scenarios.registry import packaged
from sarnav.scenarios.vocabulary import (read_earth, flight_size_check, IMU_OVERRIDES, TRAJECTORY_TYPES,
                                         filter_imu_keys, read_filter_imu,
                                         read_imu, read_initial, read_trajectory, result_bytes_check)
from sarnav.simulation.telemetry import (COV_STEP_MAX, EXTRA_ATTRS, MEAS_NAMES, MEAS_UNITS, STATE_LAYOUT,
                                        TelemetryParams, check_target_range, simulate_runs)

#: refuse campaigns whose assembled error + sigma histories would exceed this many bytes
MAX_RESULT_BYTES = 8 * 2**30

#: measurement-bias initial 3-sigma keys of [initial] (optional; default: the [measurements] FOGM figures)
_MEAS_BIAS = ("bias_alt_3sigma", "bias_range_3sigma", "bias_rate_3sigma")
#: update.strategy values (docs/scenarios/telemetry.md)
STRATEGIES = ("gaussian-sum", "second-order", "ekf")
#: update.split_threshold range; update.max_components range (components per run, memory R x K x n x n)
SPLIT_THRESHOLD_RANGE = (1e-3, 1e3)
MAX_COMPONENTS_RANGE = (1, 81)



def parse(cfg: dict) -> TelemetryParams:
    """Validate ``cfg`` and convert it to SI; ConfigError names the first bad field and its range."""
    runs, seed = validate_campaign(cfg)
    traj = read_trajectory(cfg, types=TRAJECTORY_TYPES)
    duration = traj.duration
    imu, imu_rate = read_imu(cfg)
    flight_size_check(traj.duration, imu_rate)
    filt = read_filter_imu(cfg, imu)

    meas_rate = _pos(cfg, "measurements", "rate_hz", "Hz")
    ratio = imu_rate / meas_rate
    if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
        raise ConfigError("measurements.rate_hz", f"must divide imu.rate_hz={imu_rate} Hz into a whole number of samples, got {meas_rate} Hz")
    if duration * meas_rate < 1 - 1e-9:
        raise ConfigError("trajectory.duration", f"must last at least one measurement interval (>= {1 / meas_rate} s), got {duration}")
    three = units.three_sigma_to_sigma
    meas_sigma = three(np.array([_pos(cfg, "measurements", k) for k in ("alt_3sigma", "range_3sigma", "rate_3sigma")]))
    bias3 = np.array([_pos(cfg, "measurements", k) for k in ("bias_alt_3sigma", "bias_range_3sigma", "bias_rate_3sigma")])
    bias_tau = np.array([_pos(cfg, "measurements", k, "s") for k in ("tau_alt", "tau_range", "tau_rate")])
    target = _vector(cfg, "target", "position_ned", unit="m")
    check_target_range(traj, meas_rate, target)  # no update epoch may be at the target
    ini = read_initial(cfg, filt)
    result_bytes_check(cfg.get("campaign", {}).get("runs", 1), duration, COV_STEP_MAX, 18, MAX_RESULT_BYTES)
    scalar3 = dict(zip(_MEAS_BIAS, bias3))  # the measurement biases' initial 3-sigma default to their FOGM figures
    b3 = {k: bounded_positive(f"initial.{k}", cfg["initial"].get(k, scalar3[k])) for k in _MEAS_BIAS}
    p0 = np.concatenate([ini["p"], ini["v"], ini["th"], ini["ba"], ini["bg"],
                         three(np.array([b3["bias_alt_3sigma"], b3["bias_range_3sigma"], b3["bias_rate_3sigma"]]))])
    return TelemetryParams(
        runs=runs, trajectory=traj, imu=imu, imu_filter=filt, imu_rate=imu_rate,
        meas_rate=meas_rate, meas_sigma=meas_sigma, bias_sigma=three(bias3), bias_tau=bias_tau,
        target=target, p0_sigma=p0, **read_earth(cfg), **_read_update(cfg),
    )


def _read_update(cfg: dict) -> dict:
    """The ``[update]`` table: strategy, split_threshold, max_components (ConfigError naming the key)."""
    lo, hi = SPLIT_THRESHOLD_RANGE
    return {"strategy": choice(cfg, "update", "strategy", STRATEGIES),
            "split_threshold": bounded_positive("update.split_threshold", get(cfg, "update", "split_threshold"), lo=lo,
                                                hi=hi),
            "max_components": integer(cfg, "update", "max_components", *MAX_COMPONENTS_RANGE)}


class TelemetryKind(ErrorStateKind):
    """Thesis chapter 3 telemetry-aided INS Monte Carlo (see module docstring)."""

    kind = "telemetry"
    #: the runs of a chunk are one vectorised pass over the flight (a chunk of 1 run costs about one of 50): the
    #: probe chunks hold an even share of the runs, up to 50 (measured: probes of 1 run made 200 runs 1.18x slower)
    probe_chunk = 50

    def default_config(self) -> dict:
        """Chapter 3 validation: Tables A.1, A.7, A.8, 3.1; 200 runs (thesis L656, L1855): ``defaults/telemetry.toml``."""
        return packaged("telemetry")

    def optional_keys(self) -> list[str]:
        """Keys accepted although the default configuration leaves them out."""
        return ([f"imu.{k}" for k in IMU_OVERRIDES] + [f"initial.{k}" for k in ("accel_bias_3sigma", "gyro_bias_3sigma")]
                + [f"initial.{k}" for k in _MEAS_BIAS] + filter_imu_keys())

    layout = STATE_LAYOUT
    measurement_names = tuple(MEAS_NAMES)
    measurement_units = tuple(MEAS_UNITS)

    parse = staticmethod(parse)
    simulate_runs = staticmethod(simulate_runs)
    extra = EXTRA_ATTRS



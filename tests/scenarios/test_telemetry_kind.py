"""The ``telemetry`` scenario kind: 200-run Monte Carlo consistency (thesis ch. 3, App. A.6),
batch independence, and configuration errors."""

import copy

import numpy as np
import pytest
from scipy.stats import chi2

from sarnav.errors import ConfigError
from sarnav.scenarios.telemetry import TelemetryKind

KIND = TelemetryKind()


def _seeds(cfg, n=None):
    n = cfg["campaign"]["runs"] if n is None else n
    return np.random.SeedSequence(cfg["campaign"]["seed"]).spawn(n)


@pytest.fixture(scope="module")
def campaign():
    cfg = KIND.default_config()
    assert cfg["campaign"]["runs"] == 200
    seeds = _seeds(cfg)
    return cfg, seeds, KIND.simulate(cfg, list(range(200)), seeds)


def test_records_follow_the_contract(campaign):
    cfg, _, recs = campaign
    assert KIND.state_names(cfg) == "pN pE pD vN vE vD thN thE thD baX baY baZ bgX bgY bgZ b_alt b_range b_rate".split()
    assert KIND.meas_names(cfg) == ["alt", "range", "rate"]
    assert len(KIND.state_units(cfg)) == 18 and KIND.meas_units(cfg) == ["m", "m", "m/s"]
    for r in recs[:3]:
        r.check(18, 3)
    assert [r.run for r in recs] == list(range(200))
    np.testing.assert_allclose(recs[0].update_time, np.arange(1, 201) * 0.1)
    assert np.all(recs[0].nis_dof == 3)


def test_monte_carlo_is_consistent(campaign):
    _check_consistency(campaign[2])
    # the target 200 m off the track: every second-order term is small, the Gaussian sum never splits
    assert all(np.all(r.extras["components"][1] == 1) for r in campaign[2])
    assert max(r.extras["nonlinearity"][1].max() for r in campaign[2]) < campaign[0]["update"]["split_threshold"]


def test_maneuvering_monte_carlo_is_consistent():
    cfg = KIND.default_config()
    cfg["trajectory"]["type"] = "maneuver"  # turns, climb and descent within the 20 s
    _check_consistency(KIND.simulate(cfg, list(range(200)), _seeds(cfg)))


def _check_consistency(recs, converges=True, epochs_in_band=0.90):
    R = len(recs)
    err = np.stack([r.error for r in recs])
    sig = np.stack([r.sigma for r in recs])
    nees = np.stack([r.nees for r in recs]).mean(axis=0)
    S = err.shape[2]
    lo, hi = chi2.ppf([0.025, 0.975], R * S) / R  # two-sided 95% band of the mean NEES
    assert lo < nees[-1] < hi, (nees[-1], lo, hi)
    assert lo < nees[0] < hi
    assert lo < nees.mean() < hi, (nees.mean(), lo, hi)  # the time average of the run-mean NEES
    inside = np.mean((nees > lo) & (nees < hi))
    assert epochs_in_band is None or inside >= epochs_in_band, inside  # 95% expected per epoch; epochs are correlated
    # >= 99% of error samples inside +-3 sigma for every state
    frac = (np.abs(err) <= 3 * sig).mean(axis=(0, 1))
    assert np.all(frac >= 0.99), dict(zip(KIND.state_names({}), frac.round(4)))
    # residuals zero-mean within 3 standard errors; NIS mean inside its band
    res = np.stack([r.residual for r in recs])
    rsig = np.stack([r.residual_sigma for r in recs])
    n = res.shape[0] * res.shape[1]
    se = np.sqrt(np.mean(rsig**2, axis=(0, 1)) / n)
    assert np.all(np.abs(res.mean(axis=(0, 1))) < 3 * se), (res.mean(axis=(0, 1)), se)
    nis = np.stack([r.nis for r in recs])
    lo3, hi3 = chi2.ppf([0.025, 0.975], 3 * nis.size) / nis.size
    assert lo3 < nis.mean() < hi3
    # the filter converges: final position 3-sigma below the initial one in N, E and D
    if not converges:
        return
    s0, sT = sig[:, 0, :3].mean(axis=0), sig[:, -1, :3].mean(axis=0)
    np.testing.assert_allclose(3 * s0, [1.0, 1.0, 3.0])  # Table A.7
    assert np.all(sT < s0), (3 * sT, 3 * s0)


def test_runs_do_not_depend_on_the_batch(campaign):
    cfg, seeds, recs = campaign
    halves = KIND.simulate(cfg, list(range(100)), seeds[:100]) + KIND.simulate(cfg, list(range(100, 200)), seeds[100:])
    singles = {i: KIND.simulate(cfg, [i], [seeds[i]])[0] for i in (0, 137)}
    fields = ("error", "sigma", "nees", "residual", "residual_sigma", "nis", "time", "update_time")
    for a, b in zip(recs, halves):
        for f in fields:
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    for i, b in singles.items():
        assert b.run == i
        for f in fields:
            np.testing.assert_array_equal(getattr(recs[i], f), getattr(b, f))


def test_maneuver_and_other_grades_run():
    cfg = KIND.default_config()
    cfg["trajectory"].update(type="maneuver", duration=3.0)
    cfg["imu"].update(grade="custom", vrw_3sigma=0.1, accel_bias_3sigma=0.01, arw_3sigma=0.1, gyro_bias_3sigma=5.0)
    cfg["initial"]["gyro_bias_3sigma"] = 15.0
    KIND.validate(cfg)
    recs = KIND.simulate(cfg, [0, 1], _seeds(cfg, 2))
    assert len(recs[0].time) == 31 and np.all(np.isfinite(recs[1].nees))
    # the optional keys exist in what the kind advertises
    assert "imu.vrw_3sigma" in KIND.optional_keys() and "initial.gyro_bias_3sigma" in KIND.optional_keys()


#: Table 3.4's track (start east -200 m, flying north) passes over this target at t = 10 s, 500 m above it
OVERFLOWN = [500.0, -200.0, 0.0]


def _overflown(runs, strategy):
    cfg = KIND.default_config()
    cfg["campaign"]["runs"] = runs
    cfg["target"]["position_ned"] = list(OVERFLOWN)
    cfg["update"]["strategy"] = strategy
    return cfg, KIND.simulate(cfg, list(range(runs)), _seeds(cfg))


def _mean_nees_and_nis(recs):
    nees = np.stack([r.nees for r in recs]).mean(axis=0)
    nis = np.stack([r.nis for r in recs])
    R = len(recs)
    band = chi2.ppf([0.025, 0.975], 18 * R) / R
    nis_band = chi2.ppf([0.025, 0.975], 3 * nis.size) / nis.size / 3
    return nees, nis.mean() / 3, band, nis_band


def test_target_under_the_track_first_order_ekf_is_over_confident_and_the_gaussian_sum_is_not():
    """40 runs (issue 10 item 5): the cross-track error is seen only at second order; the EKF treats its
    persistent linearisation remainder as white noise (docs/scenarios/telemetry.md, "Target under the track")."""
    _, ekf = _overflown(40, "ekf")
    nees, nis, (lo, hi), (nlo, nhi) = _mean_nees_and_nis(ekf)
    assert nees.mean() > hi and nees[-1] > 1.5 * hi, (nees.mean(), nees[-1], hi)
    assert nlo < nis < nhi  # the innovations look fine: only the NEES shows it
    cfg, mix = _overflown(40, "gaussian-sum")
    nees, nis, (lo, hi), (nlo, nhi) = _mean_nees_and_nis(mix)
    assert lo < nees.mean() < hi and nees[-1] < 1.5 * hi, (nees.mean(), nees[-1], lo, hi)
    assert nlo < nis < nhi
    # a single Gaussian's second-order term exceeds the threshold and the filter splits where it does
    comps = np.stack([r.extras["components"][1] for r in mix])
    nonlin = np.stack([r.extras["nonlinearity"][1] for r in mix])
    assert nonlin.max() > 10 * cfg["update"]["split_threshold"] and comps.max() > 1
    assert np.all(comps[nonlin.max(axis=2) > cfg["update"]["split_threshold"]] > 1)


def test_runs_with_split_components_do_not_depend_on_the_batch():
    cfg, recs = _overflown(4, "gaussian-sum")
    seeds = _seeds(cfg)
    for i in (1, 3):
        alone = KIND.simulate(cfg, [i], [seeds[i]])[0]
        assert alone.extras["components"][1].max() > 1
        for f in ("error", "sigma", "nees", "residual", "residual_sigma", "nis"):
            np.testing.assert_array_equal(getattr(alone, f), getattr(recs[i], f))
        np.testing.assert_array_equal(alone.extras["components"][1], recs[i].extras["components"][1])


@pytest.mark.slow
def test_target_under_the_track_is_consistent_with_the_gaussian_sum():
    """1000 runs (band +-0.37 on the mean NEES): the consistency check of the default geometry, except convergence of
    the cross-track position, which the measurements see only at second order (its 3-sigma grows to about 19 m), and
    the share of epochs in band, which a filter fed the linearised measurements misses too here (0.88: this INS
    filter's NEES creeps up by ~0.5 % over the flight, inside 200-run bands, outside some 1000-run ones)."""
    _, recs = _overflown(1000, "gaussian-sum")
    _check_consistency(recs, converges=False, epochs_in_band=None)


@pytest.mark.parametrize(
    "table,key,value,field",
    [
        ("imu", "tau_accel", 0.0, "imu.tau_accel"),
        ("imu", "tau_gyro", -5.0, "imu.tau_gyro"),
        ("imu", "rate_hz", float("nan"), "imu.rate_hz"),
        ("imu", "grade", "military", "imu.grade"),
        ("measurements", "tau_range", 0.0, "measurements.tau_range"),
        ("measurements", "alt_3sigma", float("nan"), "measurements.alt_3sigma"),
        ("measurements", "rate_hz", 3.0, "measurements.rate_hz"),
        ("campaign", "runs", 0, "campaign.runs"),
        ("trajectory", "start_ned", [0.0, 1.0], "trajectory.start_ned"),
        ("trajectory", "type", "loop", "trajectory.type"),
        ("trajectory", "duration", 0.05, "trajectory.duration"),
        ("trajectory", "speed", -50.0, "trajectory.speed"),
        ("trajectory", "speed", 1e300, "trajectory.speed"),  # overflowed to NaN residuals
        ("imu", "vrw_3sigma", True, "imu.vrw_3sigma"),  # TOML `true` was taken as 1.0
        ("trajectory", "duration", True, "trajectory.duration"),
        ("imu", "rate_hz", 1e9, "imu.rate_hz"),  # was a 149 GiB MemoryError traceback
        # the aircraft is at the target at t = 10 s: was "residual: must be finite" after a NaN warning
        ("target", "position_ned", [500.0, -200.0, -500.0], "target.position_ned"),
        ("target", "position_ned", [1.0, float("inf"), 0.0], "target.position_ned[1]"),
        ("initial", "p_3sigma", [1.0, 0.0, 3.0], "initial.p_3sigma[1]"),
        ("initial", "bias_alt_3sigma", -1.0, "initial.bias_alt_3sigma"),
        ("update", "strategy", "iterated", "update.strategy"),
        ("update", "split_threshold", 0.0, "update.split_threshold"),
        ("update", "split_threshold", float("nan"), "update.split_threshold"),
        ("update", "split_threshold", 1e6, "update.split_threshold"),
        ("update", "max_components", 0, "update.max_components"),
        ("update", "max_components", 100, "update.max_components"),
        ("update", "max_components", 9.0, "update.max_components"),
        ("update", "max_components", True, "update.max_components"),
    ],
)
def test_bad_values_name_the_field(table, key, value, field):
    cfg = copy.deepcopy(KIND.default_config())
    cfg[table][key] = value
    with pytest.raises(ConfigError) as err:
        KIND.validate(cfg)
    assert err.value.field == field


def test_custom_grade_needs_all_figures():
    cfg = KIND.default_config()
    cfg["imu"]["grade"] = "custom"
    cfg["imu"]["vrw_3sigma"] = 0.1
    with pytest.raises(ConfigError, match="imu.accel_bias_3sigma"):
        KIND.validate(cfg)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="Table A.7's 0.1 rad attitude 3-sigma makes the EKF inconsistent "
                   "(spurious yaw observability from g*dtheta in f^n; docs/scenarios/telemetry.md)")
def test_table_a7_attitude_uncertainty_is_consistent():
    cfg = KIND.default_config()
    cfg["initial"]["theta_3sigma"] = [0.1, 0.1, 0.1]  # as printed in Table A.7
    _check_consistency(KIND.simulate(cfg, list(range(200)), _seeds(cfg)))

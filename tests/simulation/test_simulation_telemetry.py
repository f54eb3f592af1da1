"""``sarnav.simulation.telemetry``: the chapter-3 telemetry experiment. ``check_target_range`` against the track's
distance to the target at the update epochs (by hand on a straight track); the cadence properties of
``TelemetryParams`` against their closed forms; a tiny run (3 runs, 1 s) follows the record contract (shapes, the
update epochs, the extras); the same seeds give bit-identical records, and run i depends on ``seeds[i]`` alone (the
module's promise), whatever the batch."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from helpers import spawn_seeds

from sarnav.errors import ConfigError
from sarnav.simulation.telemetry import (
    COV_STEP_MAX,
    EXTRA_ATTRS,
    MEAS_NAMES,
    MEAS_UNITS,
    MIN_TARGET_RANGE,
    STATE_LAYOUT,
    check_target_range,
    run,
    simulate_runs,
)
from sarnav.trajectory.straight import StraightLevel


def _params(duration: float = 1.0, **update):
    """The packaged telemetry scenario cut to ``duration`` s (parsed by the scenario layer)."""
    from sarnav.scenarios.registry import packaged
    from sarnav.scenarios.telemetry import parse

    cfg = packaged("telemetry")
    cfg["trajectory"]["duration"] = duration
    cfg["campaign"]["runs"] = 3
    cfg["update"].update(update)
    return parse(cfg)


@pytest.fixture(scope="module")
def tiny():
    """(params, seeds, records) of 3 runs over 1 s (10 updates)."""
    prm = _params()
    seeds = spawn_seeds(3, 11)
    return prm, seeds, run(prm, seeds)


# --- check_target_range ------------------------------------------------------------------------------------

def _track(duration=2.0):
    """North at 50 m/s, 500 m up, from the origin's vertical."""
    return StraightLevel([0.0, 0.0, -500.0], 50.0, 0.0, duration)


def test_target_on_the_track_at_an_update_is_refused():
    """A target where the aircraft is at update 3 (t = 0.3 s at 10 Hz: 15 m north) is refused naming
    target.position_ned, the limit and the distance."""
    with pytest.raises(ConfigError) as exc:
        check_target_range(_track(), 10.0, np.array([15.0, 0.0, -500.0]))
    err = exc.value
    assert err.field == "target.position_ned"
    assert f">= {MIN_TARGET_RANGE} m" in err.message and "\n" not in str(err)
    assert float(err.message.rsplit("within ", 1)[1].split()[0]) < 1e-9


def test_closest_distance_is_reported():
    """A target 0.4 m beside the track at an update epoch: 'comes within 0.4 m'."""
    with pytest.raises(ConfigError, match=r"comes within 0\.4 m"):
        check_target_range(_track(), 10.0, np.array([50.0, 0.4, -500.0]))


@pytest.mark.parametrize("target", [[2.5, 0.0, -500.0],  # t = 0.05 s: between updates (2.5 m from each)
                                    [0.0, 0.0, -500.0],  # t = 0: the start is not an update epoch
                                    [100.0, 1.0, -500.0],  # exactly MIN_TARGET_RANGE from update 20 (t = 2 s)
                                    [101.0, 0.0, -500.0]])  # 1 m beyond the end of the track (t = 2 s)
def test_targets_away_from_every_update_epoch_pass(target):
    """Only the update epochs t = k / rate, k = 1..floor(duration * rate), count; a distance of exactly
    MIN_TARGET_RANGE passes."""
    check_target_range(_track(), 10.0, np.array(target))


def test_target_past_the_last_update_passes():
    """duration 2.05 s at 10 Hz has 20 updates (t <= 2.0 s): a target at t = 2.05 s's position (102.5 m) passes;
    at t = 2.0 s's (100 m) it is refused."""
    check_target_range(_track(2.05), 10.0, np.array([102.5, 0.0, -500.0]))
    with pytest.raises(ConfigError):
        check_target_range(_track(2.05), 10.0, np.array([100.0, 0.0, -500.0]))


# --- TelemetryParams cadence -------------------------------------------------------------------------------

@pytest.mark.parametrize("imu_rate, meas_rate, per_update, per_cov", [
    (100.0, 10.0, 10, 10),  # 0.1 s interval: one covariance step
    (200.0, 1.0, 200, 20),  # 1 s: 20 samples = 0.1 s steps
    (100.0, 1.0 / 3.0, 300, 10),
    (70.0, 10.0, 7, 7),
    (300.0, 2.0, 150, 30),
    (400.0, 4.0, 100, 25),  # 25 samples = 0.0625 s; 50 would be 0.125 s > 0.1 s
    (90.0, 1.0, 90, 9),  # divisors of 90 up to 9 samples (0.1 s): 9
])
def test_cadence_matches_its_closed_form(imu_rate, meas_rate, per_update, per_cov):
    """samples_per_update = imu / meas rate; samples_per_cov_step = the largest divisor of it lasting <= 0.1 s."""
    prm = dataclasses.replace(_params(), imu_rate=imu_rate, meas_rate=meas_rate)
    assert prm.samples_per_update == per_update
    assert prm.samples_per_cov_step == per_cov
    assert per_update % per_cov == 0 and per_cov / imu_rate <= COV_STEP_MAX + 1e-12
    # brute force: no larger divisor fits
    assert all(per_update % d or d / imu_rate > COV_STEP_MAX for d in range(per_cov + 1, per_update + 1))


@pytest.mark.parametrize("duration, rate, updates", [(1.0, 10.0, 10), (20.0, 10.0, 200), (1.05, 10.0, 10),
                                                     (0.3, 10.0, 3), (3.0, 1.0 / 3.0, 1)])
def test_updates_is_the_whole_number_of_intervals(duration, rate, updates):
    """updates = floor(duration x rate), robust to the rounding of 0.3 x 10."""
    prm = dataclasses.replace(_params(), meas_rate=rate, trajectory=_track(duration))
    assert prm.updates == updates == math.floor(duration * rate + 1e-9)


# --- a tiny run --------------------------------------------------------------------------------------------

def test_records_follow_the_contract(tiny):
    """3 records numbered 0..2; 18 error states at 0, 0.1, ..., 1 s; 10 updates of the 3 measurements at 0.1, ...,
    1 s; the extras of EXTRA_ATTRS with their dims."""
    prm, _, recs = tiny
    assert [r.run for r in recs] == [0, 1, 2]
    assert STATE_LAYOUT.n == 18 and MEAS_NAMES == ["alt", "range", "rate"] and MEAS_UNITS == ["m", "m", "m/s"]
    for r in recs:
        r.check(18, 3)
        np.testing.assert_allclose(r.time, np.arange(11) * 0.1, rtol=0, atol=1e-12)
        np.testing.assert_allclose(r.update_time, np.arange(1, 11) * 0.1, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(r.nis_dof, 3)
        assert set(r.extras) == set(EXTRA_ATTRS)
        assert r.extras["components"][0] == ("update",) and r.extras["components"][1].shape == (10,)
        assert r.extras["nonlinearity"][0] == ("update", "meas") and r.extras["nonlinearity"][1].shape == (10, 3)
        assert np.all(np.isfinite(r.error)) and np.all(r.sigma > 0) and np.all(np.isfinite(r.residual))
        assert np.all(r.residual_sigma > 0) and np.all(r.nis >= 0) and np.all(r.nees >= 0)
        c = r.extras["components"][1]
        assert np.all((1 <= c) & (c <= prm.max_components))


def test_nees_is_the_error_over_the_covariance_diagonal_bound(tiny):
    """NEES = e^T P^-1 e >= (e_i / sigma_i)^2 for every state i (Cauchy-Schwarz, P_ii = sigma_i^2): a property of the
    recorded error, sigma and NEES together."""
    _, _, recs = tiny
    for r in recs:
        z2 = (r.error / r.sigma) ** 2
        assert np.all(r.nees >= z2.max(axis=1) * (1 - 1e-9))


def test_same_seeds_give_bit_identical_records(tiny):
    """A second run with the same seeds reproduces every array exactly."""
    prm, seeds, recs = tiny
    again = run(prm, seeds)
    for a, b in zip(recs, again):
        for f in ("time", "error", "sigma", "nees", "update_time", "residual", "residual_sigma", "nis", "nis_dof"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        for k in a.extras:
            np.testing.assert_array_equal(a.extras[k][1], b.extras[k][1])


def test_a_run_depends_only_on_its_seed(tiny):
    """Run 1 flown alone (numbered 7) equals run 1 of the batch: the module promises run i depends only on
    seeds[i]."""
    prm, seeds, recs = tiny
    alone = simulate_runs(prm, [7], seeds[1:2])[0]
    assert alone.run == 7
    np.testing.assert_array_equal(alone.error, recs[1].error)
    np.testing.assert_array_equal(alone.residual, recs[1].residual)
    np.testing.assert_array_equal(alone.extras["components"][1], recs[1].extras["components"][1])


def test_different_seeds_give_different_runs(tiny):
    """Runs of different seeds differ (the draws are the seeds', not shared)."""
    _, _, recs = tiny
    assert not np.array_equal(recs[0].error, recs[1].error)
    assert not np.array_equal(recs[0].residual, recs[2].residual)


@pytest.mark.parametrize("strategy", ["ekf", "second-order"])
def test_single_component_strategies(strategy):
    """The ekf and second-order updates never split: one component at every update."""
    prm = _params(0.3, strategy=strategy)
    recs = run(prm, spawn_seeds(2, 4))
    for r in recs:
        r.check(18, 3)
        np.testing.assert_array_equal(r.extras["components"][1], 1)

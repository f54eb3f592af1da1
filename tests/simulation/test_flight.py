"""The error-state flight spine shared by telemetry and rda-nav (sarnav.simulation.flight): records, batch
independence, draw order, and the truth sensor apart from the filter's model of it."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.filters import joseph_update
from sarnav.scenarios import rda_nav as rn
from sarnav.sensors.imu import IMU_GRADES
from sarnav.simulation.flight import ErrorStateFlight, FlightSpec, ImuSpec


def _spec(**kw):
    cfg = rn.default_config()
    cfg["trajectory"]["duration"] = 3.0
    prm = rn.parse(cfg)
    args = dict(trajectory=prm.trajectory, imu_truth=prm.imu, imu_rate=prm.imu_rate, bias_sigma=prm.bias_sigma,
                bias_tau=prm.bias_tau, p0_sigma=prm.p0_sigma, n_updates=prm.n_updates,
                samples_per_update=prm.samples_per_update, samples_per_step=prm.samples_per_step)
    args.update(kw)
    return FlightSpec(**args)


def test_free_flight_records_every_epoch_and_the_history_of_each_interval():
    fl = ErrorStateFlight(_spec(), rn.STATE_LAYOUT, np.random.SeedSequence(4).spawn(2))
    L = rn.STATE_LAYOUT
    for u in range(3):
        iv = fl.fly_interval(u)
        assert fl.j == (u + 1) * fl.steps and iv.t.shape == (fl.steps + 1,)
        np.testing.assert_array_equal(iv.p[:, -1], fl.nav.p)
        np.testing.assert_array_equal(iv.v[:, -1], fl.nav.v)
        # a null update (H = 0) leaves the estimate and P unchanged
        H = np.zeros((2, 1, L.n))
        dx, P, _ = joseph_update(fl.P, H, np.ones((2, 1, 1)), np.zeros((2, 1)))
        fl.navigator.feedback(dx, P)
        fl.record_update()
    assert np.all(np.isfinite(fl.err)) and np.all(np.isfinite(fl.sig)) and np.all(np.isfinite(fl.nees))
    # no aiding: the position sigma grows
    assert np.all(fl.sig[:, -1, :3] > fl.sig[:, 0, :3])
    # the recorded error at t = 0 is the drawn initial error, scaled by P0
    assert np.all(np.abs(fl.err[:, 0] / fl.sig[:, 0]) < 6)


def test_runs_do_not_depend_on_the_batch_and_attitude_choice_matters_only_for_p():
    seeds = np.random.SeedSequence(8).spawn(3)
    a = ErrorStateFlight(_spec(), rn.STATE_LAYOUT, seeds)
    b = ErrorStateFlight(_spec(), rn.STATE_LAYOUT, seeds[1:2])
    c = ErrorStateFlight(_spec(), rn.STATE_LAYOUT, seeds, covariance_attitude="start")
    for fl in (a, b, c):
        fl.fly_interval(0)
    np.testing.assert_array_equal(a.nav.p[1], b.nav.p[0])
    np.testing.assert_array_equal(a.P[1], b.P[0])
    np.testing.assert_array_equal(a.nav.p, c.nav.p)  # the INS does not depend on it
    assert not np.array_equal(a.P, c.P)
    d = lambda P: np.einsum("rii->ri", P)  # noqa: E731
    np.testing.assert_allclose(d(a.P), d(c.P), rtol=1e-3)  # variances: a second-order effect of the attitude


def test_extra_draws_come_between_the_bias_drive_and_the_imu():
    seeds = np.random.SeedSequence(2).spawn(1)
    fl = ErrorStateFlight(_spec(), rn.STATE_LAYOUT, seeds, extra_draws=lambda rngs: [g.integers(100) for g in rngs])
    assert len(fl.extra) == 1
    plain = ErrorStateFlight(_spec(), rn.STATE_LAYOUT, seeds)
    np.testing.assert_array_equal(fl.bm_truth, plain.bm_truth)  # draws before it unchanged


def test_bad_input_names_the_field():
    with pytest.raises(ConfigError, match="^covariance_attitude"):
        ErrorStateFlight(_spec(), rn.STATE_LAYOUT, np.random.SeedSequence(1).spawn(1), covariance_attitude="end")
    with pytest.raises(ConfigError, match="^samples_per_step"):
        ErrorStateFlight(_spec(samples_per_step=7), rn.STATE_LAYOUT, np.random.SeedSequence(1).spawn(1))


def test_the_filter_model_defaults_to_the_truth_sensor_and_can_differ_from_it():
    seeds = np.random.SeedSequence(6).spawn(2)
    spec = _spec()
    same = _spec(imu_filter=spec.imu_truth)
    nav_grade = ImuSpec(IMU_GRADES["navigation"], spec.imu_truth.tau_accel, spec.imu_truth.tau_gyro)
    other = _spec(imu_filter=nav_grade)
    a, b, c = (ErrorStateFlight(s, rn.STATE_LAYOUT, seeds) for s in (spec, same, other))
    for fl in (a, b, c):
        fl.fly_interval(0)
    np.testing.assert_array_equal(a.P, b.P)
    np.testing.assert_array_equal(a.nav.p, b.nav.p)
    # the truth (and so the INS fed by the same samples) is the truth sensor's: unchanged by the filter's belief
    np.testing.assert_array_equal(a.truth.ba, c.truth.ba)
    np.testing.assert_array_equal(a.nav.p, c.nav.p)
    # the filter's covariance grows with its own (smaller) noise figures
    v = rn.STATE_LAYOUT.slice("v")
    assert np.all(np.einsum("rii->ri", c.P[:, v, v]) < np.einsum("rii->ri", a.P[:, v, v]))


def test_a_short_flight_of_the_paper_scenario_runs_unaided(short_flight):
    prm = short_flight
    spec = FlightSpec(prm.trajectory, prm.imu, prm.imu_rate, prm.bias_sigma, prm.bias_tau, prm.p0_sigma,
                      prm.n_updates, prm.samples_per_update, prm.samples_per_step)
    fl = ErrorStateFlight(spec, rn.STATE_LAYOUT, np.random.SeedSequence(3).spawn(4))
    for u in range(prm.n_updates):
        fl.fly_interval(u)
        fl.after_update(fl.j, np.zeros((4, rn.STATE_LAYOUT.n)), fl.P)
    assert fl.err.shape == (4, prm.n_updates * fl.steps + 1, rn.STATE_LAYOUT.n)
    # the velocity error grows like the accelerometer bias times t: within the filter's own 3 sigma
    assert np.all(np.abs(fl.err[:, -1, 3:6]) < 3 * fl.sig[:, -1, 3:6])

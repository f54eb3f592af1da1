"""The best-focus along-track velocity: extraction, measurement contract, variance model against Monte Carlo.

Slow test (``pytest -m slow tests/measurements/test_focus.py``, about 5 minutes on 2 cores): kappa calibrated on
20 simulated apertures, checked on 20 fresh ones (chi-square band).
"""

import numpy as np
import pytest
from scipy import stats

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.layout import ErrorStateLayout
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.measurements.focus import FocusVelocityMeasurement, calibrate_kappa, extract_focus_velocity
from sarnav.radar.quality_scenes import QualityGeometry, point_clutter_scene, simulate_pulses
from helpers import level_nav

LAYOUT = ErrorStateLayout(("b_alt", "b_range", "b_cross"))


def _state(v):
    return level_nav(np.zeros_like(v), v)


def _aperture(seed, n_pulses=1200, snr_db=None, clutter=0.0):
    geo = QualityGeometry(n_pulses=n_pulses, scene_extent=8.0)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    scene = point_clutter_scene(rng, geo.scene_center, geo.scene_extent, n_points=4, clutter_density=clutter)
    rc = range_compress(simulate_pulses(geo, scene, snr_db, rng if snr_db is not None else None))
    grid = GroundGrid.centered(0.0, geo.ground_range, 0.125, (64, 64))
    return geo, rc, grid, rng


def _ins_track(geo, dv, rng, cross=0.02, offset=0.2):
    """Positions an INS with along-track velocity error -dv (and a small cross-track one, an offset) believes."""
    t = geo.pulse_times()
    tau = t - 0.5 * (t[0] + t[-1])
    return (geo.positions() - (dv * tau)[:, None] * geo.along_track + np.outer(cross * tau, geo.cross_track)
            + rng.normal(0.0, offset, 3))


def test_the_best_focus_recovers_the_along_track_velocity_error():
    dv = -0.25
    geo, rc, grid, rng = _aperture(4)
    fix = extract_focus_velocity(rc, grid, _ins_track(geo, dv, rng), span=0.4, n_grid=9)
    # focus depth of this 0.72 s aperture (quadratic phase pi/2): 0.6 m/s; the fix is 1/20 of it
    assert fix.offset == pytest.approx(dv, abs=0.03)
    assert fix.curvature > 0 and fix.direction @ geo.along_track == pytest.approx(1.0, abs=1e-6)
    # the fix is e . v_hat + offset with v_hat = V - dv the INS velocity: it measures the true speed
    assert fix.value == pytest.approx(geo.speed, abs=0.03)


def test_predict_is_linear_in_velocity_with_the_stated_jacobian():
    rng = np.random.default_rng(1)
    e = rng.normal(size=(4, 3))
    e[:, 2] = 0
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    meas = FocusVelocityMeasurement(LAYOUT, e, [0.01, 0.02, 0.03, 0.04])
    v = rng.normal(0, 30, (4, 3))
    pred = meas.predict(_state(v))
    assert pred.z_hat.shape == (4, 1) and pred.H.shape == (4, 1, LAYOUT.n) and pred.R.shape == (4, 1, 1)
    np.testing.assert_allclose(pred.z_hat[:, 0], np.sum(e * v, axis=1))
    np.testing.assert_allclose(pred.R[:, 0, 0], [1e-4, 4e-4, 9e-4, 1.6e-3])
    # central differences of z(v_hat + dv) with dx = truth - estimate
    h = 1e-4
    for j in range(3):
        dvj = np.zeros((4, 3))
        dvj[:, j] = h
        num = (meas.predict(_state(v + dvj)).z_hat - meas.predict(_state(v - dvj)).z_hat)[:, 0] / (2 * h)
        np.testing.assert_allclose(pred.H[:, 0, LAYOUT.slice("v").start + j], num, atol=1e-8)
    others = np.delete(pred.H[:, 0, :], np.r_[LAYOUT.slice("v")], axis=1)
    assert np.all(others == 0)


def test_simulate_draws_one_number_per_run():
    meas = FocusVelocityMeasurement(LAYOUT, [1.0, 0.0, 0.0], 0.05)
    v = np.tile([60.0, 1.0, 0.0], (3, 1))
    z1 = meas.simulate(_state(v), [np.random.default_rng(k) for k in range(3)])
    z2 = meas.simulate(_state(v), [np.random.default_rng(k) for k in range(3)])
    np.testing.assert_array_equal(z1, z2)
    expect = [60.0 + 0.05 * np.random.default_rng(k).standard_normal() for k in range(3)]
    np.testing.assert_allclose(z1[:, 0], expect)
    np.testing.assert_allclose(meas.simulate(_state(v), noise=np.zeros((3, 1)))[:, 0], 60.0)
    with pytest.raises(InputDataError, match="rngs"):
        meas.simulate(_state(v))


def test_kappa_calibration_is_the_maximum_likelihood_scale():
    rng = np.random.default_rng(7)
    c = rng.uniform(1.0, 10.0, 4000)
    err = rng.standard_normal(4000) * np.sqrt(3e-4 / c)
    kappa, rel_se = calibrate_kappa(err, c)
    assert kappa == pytest.approx(3e-4, rel=4 * rel_se)


def test_bad_input_is_named():
    with pytest.raises(ConfigError, match="layout"):
        FocusVelocityMeasurement(_NoV(), [1, 0, 0], 0.1)
    with pytest.raises(ConfigError, match="focus.sigma"):
        FocusVelocityMeasurement(LAYOUT, [1, 0, 0], 0.0)
    meas = FocusVelocityMeasurement(LAYOUT, np.tile([1.0, 0, 0], (3, 1)), 0.1)
    with pytest.raises(InputDataError, match="runs"):
        meas.predict(_state(np.zeros((2, 3))))
    geo, rc, grid, rng = _aperture(4, n_pulses=200)
    with pytest.raises(ConfigError, match="focus.n_grid"):
        extract_focus_velocity(rc, grid, geo.positions(), n_grid=4)
    with pytest.raises(ConfigError, match="focus.span"):
        extract_focus_velocity(rc, grid, geo.positions(), span=-1.0)
    with pytest.raises(InputDataError, match="positions"):
        extract_focus_velocity(rc, grid, geo.positions()[:-1])
    with pytest.raises(InputDataError, match="curvatures"):
        calibrate_kappa([0.1, 0.2], [1.0, -1.0])


class _NoV:
    def has(self, block):
        return block != "v"


@pytest.mark.slow
def test_variance_model_against_monte_carlo():
    """kappa from 20 apertures (receiver noise, clutter, random along-track errors); 20 fresh apertures: the mean of
    (err / sigma)^2 lies in the 95 % chi-square band of 20 degrees of freedom."""
    def fixes(seeds):
        out = []
        for s in seeds:
            geo, rc, grid, rng = _aperture(s, n_pulses=1200, snr_db=0.0, clutter=1.0)
            dv = rng.uniform(-0.3, 0.3)
            f = extract_focus_velocity(rc, grid, _ins_track(geo, dv, rng), span=0.4, n_grid=9)
            out.append((f.offset - dv, f.curvature))
        return np.array(out)
    cal = fixes(range(100, 120))
    kappa, _ = calibrate_kappa(cal[:, 0], cal[:, 1])
    fresh = fixes(range(200, 220))
    z2 = fresh[:, 0] ** 2 * fresh[:, 1] / kappa
    lo, hi = stats.chi2.ppf([0.025, 0.975], 20) / 20
    assert lo <= np.mean(z2) <= hi

"""Focus fixes of a flight (measurements.focus_image): the line-of-sight acceleration coupling against the
closed form R / 2V, the rejection of unfocused images, the calibration against the full model, bad input.

Every fix is made from echoes simulated along the true track and back-projected along the track an INS believes.
"""

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.measurements.focus_image import FocusApertureImager, FocusSettings
from sarnav.radar.presets import flexsar
from sarnav.trajectory import StraightLevel

TRUTH = StraightLevel(np.array([0.0, 0.0, -1000.0]), 60.0, 0.0, 10.0)
#: a small configuration: 1200 pulses (0.72 s), 48 x 48 pixels of 0.125 m, points over clutter
SMALL = FocusSettings(aperture_pulses=1200, pixels=48, pixel_m=0.125, length=40.0, width=8.0, point_density=0.12,
                      clutter_density=0.3, span=1.5)


@pytest.fixture(scope="module")
def imager():
    return FocusApertureImager(flexsar(pulse_length=0.2e-6), TRUTH, SMALL)


def _ins(imager, times, dv=np.zeros(3), dacc=np.zeros(3), dp=np.zeros(3)):
    """The INS track: truth + dp + dv tau + dacc tau^2 / 2 (estimate - truth), and its velocity at t_c."""
    t_c = 0.5 * (times[0] + times[-1])
    tau = times - t_c
    p = TRUTH.state(times).position + dp + np.outer(tau, dv) + 0.5 * np.outer(tau**2, dacc)
    return p, TRUTH.state(np.array([t_c])).velocity[0] + dv


def test_the_fix_measures_the_true_along_track_velocity(imager):
    times = imager.times(2.0)
    p_hat, v_hat = _ins(imager, times, dv=np.array([0.2, 0.03, -0.05]), dp=np.array([0.4, -0.3, 0.5]))
    fx, speed = imager.fix(imager.echoes(times, [1, 0]), times, p_hat, v_hat)
    # the INS believes 60.2 m/s; the best focus says 60 (focus depth of this 0.72-s aperture: 0.6 m/s)
    assert fx.value == pytest.approx(60.0, abs=0.1)
    assert fx.offset == pytest.approx(-0.2, abs=0.1)
    assert not fx.at_edge and fx.contrast > SMALL.contrast_threshold(imager.radar, 60.0, 1000.0)
    assert speed == pytest.approx(60.0, abs=0.1)  # mapdrift on the same pulses


def test_a_line_of_sight_acceleration_error_looks_like_a_velocity_error_r_over_2v_larger(imager):
    """FM rate (2 / lambda)(V^2 / R - u . a): an INS acceleration error da along the line of sight shifts the best
    focus by (R / 2V) u . da (FocusVelocityMeasurement's coupling)."""
    times = imager.times(2.0)
    p_hat, v_hat = _ins(imager, times)
    _, u, lever = imager.geometry(p_hat[times.size // 2], v_hat)
    assert lever == pytest.approx(np.hypot(1000.0, 1760.0) / 120.0, rel=1e-3)  # R / 2V = 16.9 s
    dacc = 0.04 * u  # 0.04 m/s^2 along the line of sight: 0.67 m/s
    p_acc, _ = _ins(imager, times, dacc=dacc)
    rc = imager.echoes(times, [2, 0])
    base, _ = imager.fix(rc, times, p_hat, v_hat)
    shifted, _ = imager.fix(rc, times, p_acc, v_hat)
    assert shifted.value - base.value == pytest.approx(lever * 0.04, rel=0.1)
    # an acceleration error along the track (perpendicular to u) does not move it
    along, _ = imager.fix(rc, times, _ins(imager, times, dacc=np.array([0.04, 0.0, 0.0]))[0], v_hat)
    assert abs(along.value - base.value) < 0.1 * lever * 0.04


#: fully developed speckle: 20 Rayleigh scatterers per m^2 (6 per resolution cell), no bright point
SPECKLE = FocusSettings(**{**SMALL.__dict__, "point_density": 0.0, "clutter_density": 20.0, "length": 10.0})


def test_speckle_without_a_bright_point_is_rejected(imager):
    st = SPECKLE
    speckle = FocusApertureImager(imager.radar, TRUTH, st)
    t = np.linspace(1.0, 2.0, 11)
    tr = TRUTH.state(t)
    fixes = speckle.measure(2.0, t, tr.position[None], tr.velocity[None], [[3, 0]])
    assert not fixes.ok[0] and "speckle" in fixes.error[0]
    assert abs(fixes.contrast[0]) < st.contrast_threshold(imager.radar, 60.0, 1000.0)


def test_measure_interpolates_the_ins_history_and_returns_the_coupling(imager):
    t = np.linspace(1.0, 2.0, 11)
    tr = TRUTH.state(t)
    dv = np.array([[0.1, 0.0, 0.0], [-0.15, 0.0, 0.0]])
    p = tr.position[None] + (t - 2.0)[None, :, None] * dv[:, None, :]
    v = tr.velocity[None] + dv[:, None, :]
    fixes = imager.measure(2.0, t, p, v, [[4, 0], [4, 1]])
    assert fixes.ok.all()
    np.testing.assert_allclose(fixes.value, 60.0, atol=0.1)
    np.testing.assert_allclose(fixes.lever, np.hypot(1000.0, 1760.0) / 120.0, rtol=5e-3)
    np.testing.assert_allclose(np.linalg.norm(fixes.los, axis=1), 1.0)
    with pytest.raises(InputDataError, match="scene_keys"):
        imager.measure(2.0, t, p, v, [[4, 0]])


def test_calibration_uses_the_full_model_and_needs_fixes(imager):
    sigma = np.r_[[0.3] * 3, [0.05] * 3, [3e-4] * 3, [5e-3] * 3]
    cal = imager.calibrate(4, 7, 2.0, sigma, span_max=2.5)
    assert cal["used"] == 4 and cal["kappa"] > 0 and cal["span"] >= SMALL.span
    # errors against the coupled model stay within the focus precision although lever x sigma_a = 0.085 m/s
    assert np.sqrt(np.mean(cal["errors"] ** 2)) < 0.1
    st = SPECKLE
    with pytest.raises(InputDataError, match="focus.calibration_apertures"):
        FocusApertureImager(imager.radar, TRUTH, st).calibrate(2, 7, 2.0, sigma)

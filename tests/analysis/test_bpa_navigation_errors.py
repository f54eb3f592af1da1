"""How navigation errors move and blur a back-projected point target (Lindstrom 2020 thesis ch. 4).

Echoes are simulated on the TRUE track (``radar.echoes.simulate_echoes``, no antenna pattern, so
the azimuth response is the uniform-aperture one) and range compressed without a window; the image
is formed with an ERRONEOUS track ``positions = true + error`` handed to ``backproject``. Geometry:
straight and level flight north at V = 50 m/s, altitude h = 1000 m, PRF 400 Hz, target on the
ground y_t = 1800 m east, at the aperture centre; slow time eta is measured from the aperture centre
(the error is zero at the target's time of closest approach, so only the velocity term acts).

Predictions (derived here; thesis §4.3, notes/seed-000 §11.1, §11.2, §11.5):

* position error d (§4.3.1, (4.32)–(4.33)): ``||p - (a_k + d)|| = ||t - a_k||`` for every pulse k
  exactly when ``p = t + d``, so the target focuses at t + d, unblurred (constant phase only). On
  the ground plane a down error d_D moves it east to ``sqrt(y_t^2 + (h + d_D)^2 - h^2)`` (same range
  of closest approach).
* velocity error perpendicular to the track (§4.3.2, (4.34)–(4.35)): with a_k = a_0 + V eta n and
  the estimate a_k + dv eta, ``R^2(p) = |p - a_0|^2 - 2 eta (V x + (p - a_0).dv) + eta^2 |V n + dv|^2``;
  focusing needs the linear term of the true history (zero at the target) to be matched, so
  ``x = -(t - a_0).dv / V``: an along-track shift of -(y_t dv_E + h dv_D)/V, no blur (the estimated
  track is the true one rotated by dv/V; extraction §11.5 table, sign for ``positions = true + err``).
* velocity error along the track (§4.3.2, the 2 v0.dv0 term): the phase history at the target picks
  up ``4 pi / lambda (R_hat - R) ~ 4 pi V dv eta^2 / (lambda R0)`` — a quadratic phase error growing
  as the aperture time squared: peak loss and azimuth broadening that grow with aperture length.
  Checked against an independent 1-D computation of the azimuth response from the geometry alone.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import straight_pulse_track

from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.signal.metrics import (impulse_response, index_to_coordinate, interpolate_value, irf_from_fine_cut,
                                    peak_location)
from sarnav.imaging.range_compression import range_compress
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import point_targets
from sarnav.units import C

FC, BW = 9.75e9, 150e6
LAM = C / FC
V, PRF, H, YT = 50.0, 400.0, 1000.0, 1800.0
R0 = float(np.hypot(H, YT))
TARGET = np.array([0.0, YT, 0.0])
RANGE_IRW = 0.886 * C / (2 * BW)
GROUND_RANGE_CELL = RANGE_IRW * R0 / YT              # slant IRW projected on the ground
INTERP = dict(interpolation="upsample", upsample=8)  # low-order interpolation biases peaks (docs)


def true_track(n_pulses: int):
    return straight_pulse_track(n_pulses, PRF, V, H)


def compressed(n_pulses: int):
    eta, pos = true_track(n_pulses)
    params = RadarParams(carrier_frequency=FC, bandwidth=BW, pulse_length=0.5e-6, sample_rate=1.25 * BW, prf=PRF,
                         near_range=R0 - 120.0, n_range_samples=320, antenna_length=1.0)
    raw = simulate_echoes(params, pos, eta, point_targets(TARGET), pattern=False)
    return range_compress(raw, window="none"), eta


def azimuth_cell(n_pulses: int) -> float:
    return 0.886 * LAM * R0 / (2 * n_pulses * V / PRF)


def peak(img):
    iy, ix = peak_location(img)
    return np.array([index_to_coordinate(img.y, iy), index_to_coordinate(img.x, ix)]), abs(interpolate_value(img.data, (iy, ix)))


@pytest.fixture(scope="module")
def rc256():
    return compressed(256)


@pytest.mark.parametrize("d", [(3.0, 0.0, 0.0), (0.0, 3.0, 0.0), (0.0, 0.0, 3.0), (-1.3, 2.2, -0.7)],
                         ids=["along", "cross", "down", "mixed"])
def test_constant_position_error_moves_focus_by_exactly_d(rc256, d):
    rc, _ = rc256
    d = np.asarray(d)
    spacing = 0.2
    ref = backproject(rc, GroundGrid.centered(TARGET[0], TARGET[1], spacing, (64, 64), down=TARGET[2]), **INTERP)
    # grid through t + d (3-D: the plane down = t_D + d_D)
    grid = GroundGrid.centered(TARGET[0] + d[0], TARGET[1] + d[1], spacing, (64, 64), down=TARGET[2] + d[2])
    img = backproject(rc, grid, positions=rc.positions + d, **INTERP)
    (pn, pe), amp = peak(img)
    (_, _), amp_ref = peak(ref)
    assert abs(pn - (TARGET[0] + d[0])) < azimuth_cell(256) / 20
    assert abs(pe - (TARGET[1] + d[1])) < GROUND_RANGE_CELL / 20
    assert abs(20 * np.log10(amp / amp_ref)) < 0.1          # no blur: no peak loss


def test_down_position_error_seen_on_the_ground_plane(rc256):
    """Down error d_D on the z = 0 image: east shift to sqrt(y_t^2 + (h + d_D)^2 - h^2) (same R0)."""
    rc, _ = rc256
    d_down = 3.0
    img = backproject(rc, GroundGrid.centered(0.0, YT, 0.2, (64, 64)), positions=rc.positions + [0, 0, d_down],
                      **INTERP)
    (pn, pe), _ = peak(img)
    expected_east = np.sqrt(YT ** 2 + (H + d_down) ** 2 - H ** 2)     # = y_t + h d_D / y_t to first order
    assert abs(pn - 0.0) < azimuth_cell(256) / 20
    assert abs(pe - expected_east) < GROUND_RANGE_CELL / 20
    assert expected_east - YT == pytest.approx(H * d_down / YT, rel=0.01)


@pytest.mark.parametrize("dv", [(0.0, 0.05, 0.0), (0.0, -0.05, 0.0), (0.0, 0.0, 0.05)], ids=["east", "west", "down"])
def test_cross_track_velocity_error_shifts_along_track(rc256, dv):
    """Thesis sim values (§12.10): 0.05 m/s cross-track / elevation -> shift -(t - a0).dv / V."""
    rc, eta = rc256
    dv = np.asarray(dv)
    expected = -(YT * dv[1] + H * dv[2]) / V                 # (t - a0) = (0, y_t, h) at the TOC
    img = backproject(rc, GroundGrid.centered(expected, YT, 0.2, (64, 64)),
                      positions=rc.positions + eta[:, None] * dv, **INTERP)
    ref = backproject(rc, GroundGrid.centered(0.0, YT, 0.2, (64, 64)), **INTERP)
    (pn, pe), amp = peak(img)
    _, amp_ref = peak(ref)
    assert abs(expected) > azimuth_cell(256)                 # more than a resolution cell
    assert pn == pytest.approx(expected, rel=0.05)
    assert abs(pe - YT) < GROUND_RANGE_CELL / 20
    assert abs(20 * np.log10(amp / amp_ref)) < 0.1          # rotation of the track: no blur


def azimuth_response_model(n_pulses: int, dv_along: float, x: np.ndarray, error=None) -> np.ndarray:
    """Independent 1-D model: |sum_k exp(j 4 pi (R_hat_k(x) - R_k(t)) / lambda)| along track at y = y_t.

    Geometry only (no echoes, no range envelope, no interpolation): R_k(t) true range to the target,
    R_hat_k(x) range from the erroneous antenna a_k + dv eta_k n (or a_k + ``error(eta_k)``) to the
    pixel (x, y_t, 0).
    """
    eta, pos = true_track(n_pulses)
    r_true = np.linalg.norm(TARGET - pos, axis=1)
    est = pos + (np.outer(eta, [dv_along, 0.0, 0.0]) if error is None else error(eta))
    pix = np.stack([x, np.full_like(x, YT), np.zeros_like(x)], axis=1)
    r_hat = np.linalg.norm(pix[:, None, :] - est[None, :, :], axis=2)
    return np.abs(np.exp(4j * np.pi * (r_hat - r_true[None, :]) / LAM).sum(axis=1))


def reference_image(n_pulses: int, shape):
    """(pulses, their times, the azimuth cell, a grid of ``shape`` pixels around the target, the true track's image)."""
    rc, eta = compressed(n_pulses)
    cell = azimuth_cell(n_pulses)
    grid = GroundGrid.centered(0.0, YT, cell / 6, shape, spacing_east=0.25)
    return rc, eta, cell, grid, backproject(rc, grid, **INTERP)


def test_along_track_velocity_error_blurs_more_with_longer_aperture():
    dv = 0.2                                                  # m/s along track
    results = {}
    for n_pulses in (256, 1024):
        rc, eta, cell, grid, ref = reference_image(n_pulses, (160, 48))
        img = backproject(rc, grid, positions=rc.positions + np.outer(eta, [dv, 0, 0]), **INTERP)
        (pn, _), amp = peak(img)
        _, amp_ref = peak(ref)
        irw_ref = impulse_response(ref, axis=0, n_sidelobes=None, half_width=70).irw * (grid.north[1] - grid.north[0])
        irw = impulse_response(img, axis=0, n_sidelobes=None, half_width=70).irw * (grid.north[1] - grid.north[0])
        # independent prediction on a fine along-track cut
        xs = np.linspace(-12 * cell, 12 * cell, 4801)
        model_err = azimuth_response_model(n_pulses, dv, xs)
        model_ref = azimuth_response_model(n_pulses, 0.0, xs)
        loss_model = 20 * np.log10(model_err.max() / model_ref.max())
        irw_model = irf_from_fine_cut(model_err ** 2, xs[1] - xs[0], n_sidelobes=None).irw
        irw_model_ref = irf_from_fine_cut(model_ref ** 2, xs[1] - xs[0], n_sidelobes=None).irw
        results[n_pulses] = dict(loss=20 * np.log10(amp / amp_ref), growth=irw / irw_ref, loss_model=loss_model,
                                 growth_model=irw_model / irw_model_ref)
        assert abs(pn) < cell / 20                            # symmetric error: no shift at the aperture centre
        assert results[n_pulses]["loss"] == pytest.approx(loss_model, abs=0.2)
        assert irw / irw_ref == pytest.approx(irw_model / irw_model_ref, rel=0.05)
        assert irw_ref == pytest.approx(cell, rel=0.05)
    short, long_ = results[256], results[1024]
    # the quadratic phase at the aperture edge, 4 pi V dv (T/2)^2 / (lambda R0), is 16x larger for 4x T
    assert short["loss"] > -0.1 and short["growth"] < 1.02
    assert long_["loss"] < short["loss"] - 1.0
    assert long_["growth"] > short["growth"] + 0.1


def attitude_position_error(dtheta):
    """Position error of the estimate from a constant attitude error (thesis (4.36)-(4.38)).

    The thesis' delta p = p - p_hat = 1/2 (nu x dtheta) eta^2 with specific force nu = (0, 0, -g)
    (NED, level flight), so ``positions = true - 1/2 (nu x dtheta) eta^2``; (4.37):
    nu x dtheta = (g dtheta_y, -g dtheta_x, 0): yaw gives no error, roll a cross-track acceleration.
    """
    acc = np.cross([0.0, 0.0, -9.81], np.asarray(dtheta, dtype=float))
    return lambda eta: -0.5 * np.outer(eta ** 2, acc)


def test_roll_error_blurs_and_yaw_error_does_nothing():
    """Thesis sim values (§12.10): roll 0.001 rad, yaw 0.1 rad; aperture centred on the target."""
    yaw = attitude_position_error([0.0, 0.0, 0.1])
    assert np.all(yaw(np.linspace(-2, 2, 5)) == 0.0)          # (4.37): no acceleration error from yaw
    roll = attitude_position_error([0.001, 0.0, 0.0])
    losses = {}
    for n_pulses in (256, 1024):
        rc, eta, cell, grid, ref = reference_image(n_pulses, (96, 32))
        img = backproject(rc, grid, positions=rc.positions + roll(eta), **INTERP)
        _, amp = peak(img)
        _, amp_ref = peak(ref)
        xs = np.linspace(-12 * cell, 12 * cell, 2401)
        loss_model = 20 * np.log10(azimuth_response_model(n_pulses, 0.0, xs, roll).max()
                                   / azimuth_response_model(n_pulses, 0.0, xs).max())
        losses[n_pulses] = 20 * np.log10(amp / amp_ref)
        assert losses[n_pulses] == pytest.approx(loss_model, abs=0.2)
    assert losses[256] > -0.1 and losses[1024] < losses[256] - 1.0

"""The SAR-aided navigator's update (``sarnav.navigation.sar_navigator.SarNavigator``) on its own, on a small
synthetic case: 1 s flown north at 60 m/s, 1000 m up, past one reference target at 2 km slant range whose time of
closest approach (TOC) is 0.5 s. The estimate is the truth less a chosen error dx (dx = truth - estimate); the
measurements (altimeter; range and zero-Doppler cross-range of the target) are made here from the truth, the
navigator is handed only them, its own interval and the map's target.

Checked against independent computations: the update against the textbook Kalman update of the models written out
here (at the map's target, never the true one), the posterior covariance against P - P H^T S^-1 H P and never
above the prior, NIS and posterior NEES of consistent measurements against their chi-square bands over many runs,
the stacked predictions' Jacobians against central finite differences, a failed or gated pair against the
altimeter-only update."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from helpers import level_nav
from scipy.stats import chi2

from sarnav.filters.feedback import error_state
from sarnav.frames.ned import GRAVITY_NED
from sarnav.ins import NavState
from sarnav.navigation import Navigator, error_model
from sarnav.navigation.navigator import Interval
from sarnav.navigation.sar_aiding import REJECTIONS, SarUpdateSettings
from sarnav.navigation.sar_navigator import (
    COV_STEP,
    STATE_LAYOUT,
    UPDATE_SECONDS,
    AidedUpdate,
    SarNavigator,
)
from sarnav.rotations import apply_attitude_error
from sarnav.sensors.imu import IMU_GRADES, ImuSpec

L = STATE_LAYOUT
N = L.n
IP, IV = L.slice("p"), L.slice("v")
I_ALT, I_RNG, I_CRS = (L.index(b) for b in ("b_alt", "b_range", "b_cross"))
SPEED, ALT = 60.0, 1000.0
V_TRUE = np.array([SPEED, 0.0, 0.0])
T_EPOCHS = np.arange(round(UPDATE_SECONDS / COV_STEP) + 1) * COV_STEP  # the step epochs of one update
TARGET = np.array([30.0, np.sqrt(2000.0**2 - ALT**2), 0.0])  # abeam of the truth at t = 0.5 s
ETA = 0.5
B_TRUE = np.array([0.5, -0.4, 0.3])  # truth altimeter, range, cross-range biases [m]
SIG0 = np.repeat([10.0, 0.5, 1e-3, 1e-2, 1e-5, 1.0, 1.0, 1.0], [3, 3, 3, 3, 3, 1, 1, 1])  # P0 1-sigma
ALT_SIGMA, SAR_SIGMA = 1.0, np.array([2.0, 3.0])
DX2 = np.zeros((2, N))  # two runs' errors (truth - estimate): different positions, velocities and biases
DX2[0, IP], DX2[0, IV], DX2[0, L.scalar_slice] = [6.0, -8.0, 3.0], [0.3, -0.4, 0.1], [0.8, -1.2, 0.6]
DX2[1, IP], DX2[1, IV], DX2[1, L.scalar_slice] = [-9.0, 4.0, -5.0], [-0.2, 0.6, -0.3], [-0.5, 1.5, -0.9]


def truth_p(t):
    return np.array([SPEED * t, 0.0, -ALT])


def flight(dx, sar=True, alt=True, P=None, **sar_settings):
    """(SarNavigator, Interval) of runs whose estimate is the truth less dx (R, n): the interval's history
    truth(t) - dx_p, velocity V - dx_v; identity attitude; IMU biases -dx (truth zero); measurement biases
    B_TRUE - dx. Oracle pairs (R from ``sar_sigma``) unless ``image=True`` is among the settings."""
    runs = dx.shape[0]
    p = np.stack([[truth_p(t) - dx[r, IP] for t in T_EPOCHS] for r in range(runs)])
    v = np.broadcast_to((V_TRUE - dx[:, IV])[:, None], p.shape).copy()
    iv = Interval(T_EPOCHS, p, v, np.tile([1.0, 0, 0, 0], (runs, T_EPOCHS.size, 1)), np.tile(-GRAVITY_NED, (runs, 1)),
                  ())
    nav = level_nav(p[:, -1], v[:, -1], B_TRUE)
    nav.bm = nav.bm - dx[:, L.scalar_slice]
    nav.ba, nav.bg = -dx[:, L.slice("ba")], -dx[:, L.slice("bg")]
    model = error_model(L, ImuSpec(IMU_GRADES["tactical"], 3600.0, 3600.0), np.ones(3), np.full(3, 300.0))
    P = np.diag(SIG0**2) if P is None else P
    nv = Navigator(nav, np.broadcast_to(P, (runs, N, N)).copy(), model, L, tau_accel=3600.0, tau_gyro=3600.0,
                   bias_tau=np.full(3, 300.0))
    image = sar_settings.pop("image", False)
    targets = sar_settings.pop("targets", 1)
    settings = SarUpdateSettings(**{"sar_sigma": SAR_SIGMA, **sar_settings}) if sar else None
    return SarNavigator(nv, ALT_SIGMA if alt else None, settings, targets=targets, image=image), iv


def truth_measurements(runs, noise=None):
    """(z_alt (R, 1), z_sar (R, 2)) of the truth at the TOC: altitude + b_alt; range + b_range; cross-range (0 at
    zero Doppler) + b_cross; plus ``noise`` (R, 3) [m]."""
    p = truth_p(ETA)
    z = np.tile([ALT + B_TRUE[0], np.linalg.norm(TARGET - p) + B_TRUE[1], V_TRUE @ (p - TARGET) / SPEED + B_TRUE[2]],
                (runs, 1))
    if noise is not None:
        z = z + noise
    return z[:, :1], z[:, 1:]


def hand_prediction(p_end, p_toc, v, bm, target):
    """(z_hat (3,), H (3, n)) of altimeter, range, zero-Doppler cross-range written out from their definitions."""
    d, u = target - p_toc, v / np.linalg.norm(v)
    los = p_toc - target
    H = np.zeros((3, N))
    H[0, 2], H[0, I_ALT] = -1.0, 1.0
    H[1, IP], H[1, I_RNG] = -d / np.linalg.norm(d), 1.0
    H[2, IP], H[2, IV], H[2, I_CRS] = u, (los - u * (u @ los)) / np.linalg.norm(v), 1.0
    return np.array([-p_end[2] + bm[0], np.linalg.norm(d) + bm[1], u @ los + bm[2]]), H


def update(sn, iv, z_alt, z_sar, runs, eta=ETA, targets=None):
    targets = np.broadcast_to(TARGET, (runs, 1, 3)) if targets is None else targets
    return sn.update(iv, z_alt, z_sar, np.full((runs, 1), eta), targets)


# --------------------------------------------------------------------------- the update
def test_nothing_to_fuse_is_no_update():
    """No altimeter value and no pairs: None, and the estimate and covariance stay as they were."""
    sn, iv = flight(DX2)
    P, p = sn.navigator.P.copy(), sn.navigator.nav.p.copy()
    assert sn.update(iv) is None
    np.testing.assert_array_equal(sn.navigator.P, P)
    np.testing.assert_array_equal(sn.navigator.nav.p, p)


def test_the_update_is_the_textbook_kalman_update_of_the_models_at_the_maps_target():
    """No delay, no second order, no gate: dx = K (z - z_hat), P+ = P - K S K^T with z_hat, H written out at the
    estimate and the *map's* target (off the true one: the navigator is never told the truth)."""
    sn, iv = flight(DX2, delayed_state=False, second_order=False, gate_probability=0.0)
    nv = sn.navigator
    z_alt, z_sar = truth_measurements(2)
    mapped = TARGET + np.array([[[4.0, -3.0, 1.0]], [[-2.0, 5.0, 0.0]]])
    P0, nav0 = nv.P.copy(), nv.nav.copy()
    up = update(sn, iv, z_alt, z_sar, 2, targets=mapped)
    assert isinstance(up, AidedUpdate)
    z = np.c_[z_alt, z_sar]
    np.testing.assert_array_equal(up.z, z)
    for r in range(2):
        p_toc = truth_p(ETA) - DX2[r, IP]
        z_hat, H = hand_prediction(nav0.p[r], p_toc, nav0.v[r], nav0.bm[r], mapped[r, 0])
        S = H @ P0[r] @ H.T + np.diag(np.r_[ALT_SIGMA, SAR_SIGMA] ** 2)
        K = P0[r] @ H.T @ np.linalg.inv(S)
        res = z[r] - z_hat
        np.testing.assert_allclose(up.fused.residual[r], res, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(up.fused.residual_sigma[r], np.sqrt(np.diag(S)), rtol=1e-9)
        assert up.fused.nis[r] == pytest.approx(res @ np.linalg.solve(S, res), rel=1e-8)
        np.testing.assert_allclose(nv.P[r], P0[r] - K @ S @ K.T, rtol=1e-7, atol=1e-12)
        dx = K @ res
        np.testing.assert_allclose(nv.nav.p[r], nav0.p[r] + dx[IP], rtol=0, atol=1e-8)
        np.testing.assert_allclose(nv.nav.bm[r], nav0.bm[r] + dx[L.scalar_slice], rtol=0, atol=1e-9)
    assert up.status.tolist() == [[0], [0]] and up.rejected.tolist() == [0, 0] and up.pairs_fused.tolist() == [1, 1]
    assert up.fused.dof.tolist() == [3, 3] and up.seconds >= 0.0


def test_a_consistent_update_shrinks_the_covariance_along_the_measured_directions():
    """Full model (delayed state, second order, gate): P+ <= P- in every direction, strictly smaller along the line
    of sight (range) and along track (cross-range) at the TOC and in altitude; the variance of the range
    combination (LOS position and range bias) at least halves."""
    sn, iv = flight(DX2)
    nv = sn.navigator
    P0 = nv.P.copy()
    z_alt, z_sar = truth_measurements(2)
    up = update(sn, iv, z_alt, z_sar, 2)
    assert up.status.tolist() == [[0], [0]] and up.pairs_fused.tolist() == [1, 1]
    p_toc = truth_p(ETA)
    los = (TARGET - p_toc) / np.linalg.norm(TARGET - p_toc)
    for r in range(2):
        assert np.linalg.eigvalsh(P0[r] - nv.P[r]).min() > -1e-9 * np.abs(P0[r]).max()
        for direction in (los, V_TRUE / SPEED, np.array([0.0, 0.0, 1.0])):
            prior, post = direction @ P0[r][IP, IP] @ direction, direction @ nv.P[r][IP, IP] @ direction
            assert post < 0.9 * prior
    # the range measures -LOS . dp + b_range: its prior variance 100 + 1 m^2 against R = 4 m^2
    for r in range(2):
        h_rng = np.zeros(N)
        h_rng[IP], h_rng[I_RNG] = -los, 1.0
        assert h_rng @ nv.P[r] @ h_rng < 0.5 * (h_rng @ P0[r] @ h_rng)


def test_consistent_measurements_give_chi_square_nis_and_posterior_nees():
    """Errors drawn from P and noise from R over 300 runs: mean NIS in the chi2(3) band and the posterior NEES of
    all 18 states in the chi2(18) band, that of the three measured combinations in the chi2(3) band (99.9 %): the
    update's gain and covariance agree with its errors."""
    runs = 300
    rng = np.random.default_rng(np.random.SeedSequence(20240))
    dx = rng.standard_normal((runs, N)) * SIG0
    sn, iv = flight(dx, delayed_state=False, gate_probability=0.0)  # the history's error is dx at every epoch
    noise = rng.standard_normal((runs, 3)) * np.r_[ALT_SIGMA, SAR_SIGMA]
    up = update(sn, iv, *truth_measurements(runs, noise), runs)
    lo, hi = chi2.ppf([0.0005, 0.9995], 3 * runs) / runs
    assert lo < up.fused.nis.mean() < hi
    nv = sn.navigator
    level = np.tile([1.0, 0.0, 0.0, 0.0], (runs, 1))
    truth = NavState(np.tile(truth_p(1.0), (runs, 1)), np.tile(V_TRUE, (runs, 1)),
                     apply_attitude_error(level, dx[:, L.slice("th")]), np.zeros((runs, 3)), np.zeros((runs, 3)),
                     np.tile(B_TRUE, (runs, 1)))
    e = error_state(truth, nv.nav, L)
    nees = np.einsum("ri,ri->r", e, np.linalg.solve(nv.P, e[..., None])[..., 0])
    lo, hi = chi2.ppf([0.0005, 0.9995], N * runs) / runs
    assert lo < nees.mean() < hi
    # sharper: the error of the three measured combinations (altitude, range, cross-range) under H P+ H^T
    H = np.stack([hand_prediction(truth_p(1.0), truth_p(ETA), V_TRUE, B_TRUE, TARGET)[1]] * runs)
    He = np.einsum("rmn,rn->rm", H, e)
    nees_m = np.einsum("rm,rm->r", He, np.linalg.solve(H @ nv.P @ np.swapaxes(H, 1, 2), He[..., None])[..., 0])
    lo, hi = chi2.ppf([0.0005, 0.9995], 3 * runs) / runs
    assert lo < nees_m.mean() < hi


def test_jacobians_of_the_stacked_predictions_agree_with_finite_differences():
    """The prediction the navigator fuses (altimeter + pair, no delay): H equals central differences of its z_hat
    when the estimate (end state, the interval's history, the bias estimates) moves by +-h along each state."""
    seen = []

    def predicted(dx_shift):
        sn, iv = flight(DX2 - dx_shift, delayed_state=False, second_order=False, gate_probability=0.0)
        nv = sn.navigator
        nv.update = lambda pred, z, keep=None: seen.append(pred) or Navigator.update(nv, pred, z, keep)
        update(sn, iv, *truth_measurements(2), 2)
        return seen[-1]

    H = predicted(np.zeros((2, N))).H
    fd = np.zeros_like(H)
    for j in list(range(6)) + list(range(15, N)):  # the states the models depend on; attitude / IMU biases stay 0
        h = 1e-3
        e = np.zeros((2, N))
        e[:, j] = h
        fd[:, :, j] = (predicted(e).z_hat - predicted(-e).z_hat) / (2 * h)
    np.testing.assert_allclose(fd, H, rtol=1e-6, atol=1e-9)
    assert np.all(H[:, :, 6:15] == 0)


# --------------------------------------------------------------------------- failed and gated pairs
def _alt_only(dx):
    sn, iv = flight(dx, sar=False)
    z_alt, _ = truth_measurements(dx.shape[0])
    up = sn.update(iv, z_alt)
    return sn.navigator, up


def test_without_sar_the_altimeter_alone_is_fused():
    """No SAR settings: no aiding; an altimeter update has no status, nothing rejected, no pairs."""
    _, up = _alt_only(DX2)
    assert up.status is None and up.rejected.tolist() == [0, 0] and up.pairs_fused.tolist() == [0, 0]
    assert up.z.shape == (2, 1) and up.seconds == 0.0 and up.fused.dof.tolist() == [1, 1]


def test_a_failed_image_is_recorded_and_not_fused():
    """An image that failed (status 2 in run 0): its code is recorded, its pair left out (NaN residual), and run 0's
    estimate and covariance are those of the altimeter-only update; run 1's pair is fused."""
    sn, iv = flight(DX2, image=True)
    am = SimpleNamespace(status=np.array([[2], [0]]), sigma=np.array([[[np.nan, np.nan]], [[2.0, 3.0]]]),
                         sensitivity=np.zeros((2, 1)), focus_offset=np.zeros((2, 1)),
                         range=np.array([[np.nan], [0.0]]), toc=np.array([[np.nan], [ETA]]))
    sn.aid.take(am)
    z_alt, z_sar = truth_measurements(2)
    am.range[1, 0] = z_sar[1, 0] - B_TRUE[1]
    z_pairs, eta = sn.image_pairs(am, iv, np.array([B_TRUE[1], B_TRUE[2]]))
    np.testing.assert_allclose(z_pairs[1], z_sar[1], rtol=1e-15)
    assert eta[0, 0] == 0.5 * (T_EPOCHS[0] + T_EPOCHS[-1]) and eta[1, 0] == ETA
    up = sn.update(iv, z_alt, z_pairs, eta, np.broadcast_to(TARGET, (2, 1, 3)))
    assert up.status.tolist() == [[2], [0]] and REJECTIONS[2] == "registration failed"
    assert up.rejected.tolist() == [2, 0] and up.pairs_fused.tolist() == [0, 1] and up.fused.dof.tolist() == [1, 3]
    assert np.all(np.isnan(up.fused.residual[0, 1:])) and np.all(np.isfinite(up.fused.residual[1]))
    ref, _ = _alt_only(DX2)
    np.testing.assert_allclose(sn.navigator.P[0], ref.P[0], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(sn.navigator.nav.p[0], ref.nav.p[0], rtol=0, atol=1e-12)
    assert not np.allclose(sn.navigator.P[1], ref.P[1])


def test_a_gated_pair_is_recorded_and_not_fused():
    """A range 500 m off (run 1) fails the chi-square gate: coded 'innovation gate', left out (the run's update is
    the altimeter-only one); run 0's consistent pair is fused."""
    sn, iv = flight(DX2)
    z_alt, z_sar = truth_measurements(2)
    z_sar[1, 0] += 500.0
    up = update(sn, iv, z_alt, z_sar, 2)
    gate = REJECTIONS.index("innovation gate")
    assert up.status.tolist() == [[0], [gate]] and up.rejected.tolist() == [0, gate]
    assert up.pairs_fused.tolist() == [1, 0] and np.isnan(up.fused.residual[1, 1])
    ref, _ = _alt_only(DX2)
    np.testing.assert_allclose(sn.navigator.P[1], ref.P[1], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(sn.navigator.nav.p[1], ref.nav.p[1], rtol=0, atol=1e-12)


def test_pairs_without_the_altimeter_are_screened_from_component_zero():
    """No altimeter: the pairs are components 0, 1 and a gated pair leaves the estimate exactly unchanged."""
    sn, iv = flight(DX2, alt=False)
    _, z_sar = truth_measurements(2)
    z_sar[0, 1] -= 400.0
    P0, p0 = sn.navigator.P.copy(), sn.navigator.nav.p.copy()
    up = update(sn, iv, None, z_sar, 2)
    assert up.z.shape == (2, 2) and up.status[:, 0].tolist() == [REJECTIONS.index("innovation gate"), 0]
    np.testing.assert_allclose(sn.navigator.P[0], P0[0], rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(sn.navigator.nav.p[0], p0[0], rtol=0, atol=1e-12)
    assert up.fused.dof.tolist() == [0, 2]


# --------------------------------------------------------------------------- images
def test_image_pairs_add_the_offsets_and_refer_each_pair_to_its_toc():
    """z = (image range + offset, cross-range offset) per pair; the TOC measured, or the aperture centre where the
    image failed; offsets broadcast from (2,)."""
    sn, iv = flight(DX2, image=True, targets=2)
    am = SimpleNamespace(status=np.array([[0, 1], [0, 0]]), range=np.array([[2000.0, 2010.0], [1990.0, 2005.0]]),
                         toc=np.array([[0.3, np.nan], [0.6, 0.7]]), sigma=np.ones((2, 2, 2)),
                         sensitivity=np.zeros((2, 2)), focus_offset=np.zeros((2, 2)))
    sn.aid.take(am)
    off = np.array([[[0.5, -0.2], [1.0, 2.0]], [[0.0, 0.1], [-1.0, 0.3]]])
    z, eta = sn.image_pairs(am, iv, off)
    np.testing.assert_allclose(z, [[2000.5, -0.2, 2011.0, 2.0], [1990.0, 0.1, 2004.0, 0.3]], rtol=1e-15)
    np.testing.assert_array_equal(eta, [[0.3, 0.5], [0.6, 0.7]])
    z, _ = sn.image_pairs(am, iv, np.array([0.25, -0.5]))
    np.testing.assert_allclose(z[:, 1::2], -0.5)
    np.testing.assert_allclose(z[:, 0::2], am.range + 0.25)


def test_measure_images_hands_the_imager_the_estimated_track_and_the_filters_sigmas():
    """The imager gets the interval's own track and attitudes, the filter's forward-speed sigma sqrt(u^T P_vv u) and
    the along-track sigma of the first target; its measurements set the aiding's R."""
    sn, iv = flight(DX2, image=True)
    calls = []
    am = SimpleNamespace(status=np.zeros((2, 1), dtype=np.int64), sigma=np.full((2, 1, 2), 0.7),
                         sensitivity=np.zeros((2, 1)), focus_offset=np.zeros((2, 1)))

    class Imager:
        def measure(self, aperture, t, p, v, speed_sigma, map_targets, along_sigma, ap_q):
            calls.append({"aperture": aperture, "t": t, "p": p, "v": v, "speed_sigma": speed_sigma,
                          "map_targets": map_targets, "along_sigma": along_sigma, "ap_q": ap_q})
            return am

    mt = np.broadcast_to(TARGET, (2, 1, 3))
    assert sn.measure_images(Imager(), 7, iv, mt) is am
    c = calls[0]
    assert c["aperture"] == 7 and c["t"] is iv.t and c["p"] is iv.p and c["v"] is iv.v and c["ap_q"] is iv.q
    assert c["map_targets"] is mt
    P = sn.navigator.P
    for r in range(2):
        u = sn.navigator.nav.v[r] / np.linalg.norm(sn.navigator.nav.v[r])
        assert c["speed_sigma"][r] == pytest.approx(np.sqrt(u @ P[r][IV, IV] @ u), rel=1e-12)
    np.testing.assert_allclose(c["along_sigma"], sn.aid.along_sigma(sn.navigator, iv, mt[:, 0]), rtol=1e-15)
    np.testing.assert_array_equal(sn.aid.sigma, am.sigma)


def test_the_state_layout_and_the_update_cadence():
    """18 error states ending with the altimeter, range and cross-range biases; whole covariance steps per update."""
    assert L.n == 18 and L.state_names()[-3:] == ["b_alt", "b_range", "b_cross"]
    assert UPDATE_SECONDS / COV_STEP == pytest.approx(round(UPDATE_SECONDS / COV_STEP), abs=1e-12)

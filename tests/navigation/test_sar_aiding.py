"""The navigator's SAR pairs (``sarnav.navigation.sar_aiding``) on a small synthetic aperture: 1 s flown north at
60 m/s, 1000 m up, past one reference target at 2 km slant range whose time of closest approach (TOC) is 0.5 s;
two runs whose estimated tracks are off the truth by different position and velocity errors.

Checked against independent computations: range and zero-Doppler cross-range written out from their definitions,
the Jacobians against central finite differences of the estimate, the map's geolocation noise as J D J^T, the
second-order terms in closed form (isotropic position / velocity covariance), the delayed-state mapping through
the forward transition, the along-track sigma as sqrt(H P H^T), the gate at the chi-square quantile."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from helpers import level_nav
from scipy.stats import chi2

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters import ErrorStateLayout
from sarnav.frames.ned import GRAVITY_NED
from sarnav.measurements.sar_image import FAILURES
from sarnav.navigation import Navigator, error_model
from sarnav.navigation.navigator import Interval
from sarnav.navigation.sar_aiding import (
    REJECTIONS,
    SarAiding,
    SarUpdateSettings,
    measurement_sigma,
    toc_state,
)
from sarnav.rotations import quat_to_dcm
from sarnav.sensors.imu import IMU_GRADES, ImuSpec

L = ErrorStateLayout(("b_alt", "b_range", "b_cross"), scalar_units=("m", "m", "m"))
IP, IV = L.slice("p"), L.slice("v")
I_ALT, I_RNG, I_CRS = (L.index(b) for b in ("b_alt", "b_range", "b_cross"))
SPEED, ALT = 60.0, 1000.0
T_EPOCHS = np.linspace(0.0, 1.0, 11)
TARGET = np.array([30.0, np.sqrt(2000.0**2 - ALT**2), 0.0])  # abeam of the truth at t = 0.5 s, 2 km slant range
DP = np.array([[4.0, -3.0, 2.0], [-6.0, 5.0, -1.0]])  # estimate - truth at t = 0 [m], per run
DV = np.array([[0.3, -0.2, 0.1], [-0.1, 0.4, 0.0]])  # estimate - truth velocity [m/s], per run
BM = np.array([[0.5, -0.3, 0.2], [-0.1, 0.4, -0.6]])  # bias estimates: altimeter, range, cross-range [m]
SIGMA = np.array([0.1, 1.0, 0.01, 0.05, 1e-4, 1.0, 1.0, 1.0])  # P0 1-sigma of p, v, th, ba, bg, b_alt, b_range, b_cross


def truth_p(t):
    return np.stack([SPEED * np.asarray(t, float), 0.0 * np.asarray(t, float), np.full(np.shape(t), -ALT)], -1)


def est_p(r, t):
    """The estimated track of run r: the truth off by DP[r] + DV[r] t (consistent with its velocity)."""
    return truth_p(t) + DP[r] + DV[r] * np.asarray(t, float)[..., None]


def est_v(r):
    return np.array([SPEED, 0.0, 0.0]) + DV[r]


def interval(dp=None, dv=None):
    """The aperture's estimated track at the step epochs (an ``Interval`` as ``Navigator.propagate`` gives), each
    run's history optionally shifted by dp (R, 3) and dv (R, 3)."""
    dp = np.zeros((2, 3)) if dp is None else dp
    dv = np.zeros((2, 3)) if dv is None else dv
    p = np.stack([est_p(r, T_EPOCHS) + dp[r] for r in range(2)])
    v = np.stack([np.broadcast_to(est_v(r) + dv[r], (T_EPOCHS.size, 3)) for r in range(2)])
    q = np.tile([1.0, 0.0, 0.0, 0.0], (2, T_EPOCHS.size, 1))
    return Interval(T_EPOCHS, p, v, q, np.tile(-GRAVITY_NED, (2, 1)), ())


def navigator(P=None, bm=BM):
    """A Navigator of the two runs at the end of the interval (identity attitude: level, heading north)."""
    nav = level_nav(np.stack([est_p(r, 1.0) for r in range(2)]), np.stack([est_v(r) for r in range(2)]))
    nav.bm = np.array(bm, dtype=float)
    imu = ImuSpec(IMU_GRADES["tactical"], 3600.0, 3600.0)
    model = error_model(L, imu, np.ones(3), np.full(3, 300.0))
    if P is None:
        P = np.diag(np.repeat(SIGMA, [3, 3, 3, 3, 3, 1, 1, 1]) ** 2)
    P = np.broadcast_to(P, (2, L.n, L.n)).copy()
    return Navigator(nav, P, model, L, tau_accel=3600.0, tau_gyro=3600.0, bias_tau=np.full(3, 300.0))


def settings(**kw):
    base = {"sar_sigma": np.array([2.0, 3.0]), "delayed_state": False, "second_order": False, "gate_probability": 0.0}
    return SarUpdateSettings(**{**base, **kw})


def map_targets(offsets=((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))):
    """(R, T=1, 3) what the map says of the target, per run."""
    return (TARGET + np.asarray(offsets, dtype=float))[:, None]


def hand_pair(target, p, v, b_range, b_cross):
    """(range, zero-Doppler cross-range) from their definitions: |target - p| + b_r, v/|v| . (p - target) + b_c."""
    return np.linalg.norm(target - p) + b_range, v @ (p - target) / np.linalg.norm(v) + b_cross


def hand_rows(target, p, v):
    """H rows of (range, cross-range) written out: range -LOS unit in p; cross u in p and the lever in v."""
    n = L.n
    d = target - p
    u = v / np.linalg.norm(v)
    los = p - target
    hr, hc = np.zeros(n), np.zeros(n)
    hr[IP], hr[I_RNG] = -d / np.linalg.norm(d), 1.0
    hc[IP], hc[IV], hc[I_CRS] = u, (los - u * (u @ los)) / np.linalg.norm(v), 1.0
    return np.stack([hr, hc])


# --------------------------------------------------------------------------- R before the images, TOC state
@pytest.mark.parametrize("image, reg, added, want_sigma, want_white", [
    (False, None, False, [2.0, 3.0], 1.0),  # oracle: Table 2's noise is the measurement's error and R
    (True, None, False, [1.0, 1.0], 0.0),  # image: placeholders, replaced by each image's own sigma
    (True, [0.4, 0.7], False, [0.4, 0.7], 0.0),  # image with constant registration sigma
    (True, [0.4, 0.7], True, [np.hypot(2.0, 0.4), np.hypot(3.0, 0.7)], 1.0),  # plus Table 2's noise, added to z and R
    (True, None, True, [np.hypot(2.0, 1.0), np.hypot(3.0, 1.0)], 1.0),
])
def test_measurement_sigma_of_the_oracle_and_of_images(image, reg, added, want_sigma, want_white):
    """Oracle R = Table 2's sigma with the white noise added; images: registration sigma, white noise on request."""
    s = settings(registration_sigma=None if reg is None else np.array(reg), image_added_noise=added)
    sig, white = measurement_sigma(s, image)
    np.testing.assert_allclose(sig, want_sigma, rtol=1e-15)
    assert white == want_white
    sig[:] = -1.0  # a copy: the settings are not changed through it
    assert np.all(s.sar_sigma == [2.0, 3.0]) and (reg is None or np.all(s.registration_sigma == reg))


def test_toc_state_interpolates_each_runs_track_and_keeps_the_update_epochs_biases():
    """Each run at its own TOC: position and velocity of its linear history exactly; attitude and biases unchanged."""
    nv, iv = navigator(), interval()
    eta = np.array([0.37, 0.81])
    st = toc_state(nv.nav, iv, eta)
    for r in range(2):
        np.testing.assert_allclose(st.p[r], est_p(r, eta[r]), rtol=0, atol=1e-9)
        np.testing.assert_allclose(st.v[r], est_v(r), rtol=0, atol=1e-12)
    assert st.q is nv.nav.q and st.bm is nv.nav.bm and st.ba is nv.nav.ba and st.bg is nv.nav.bg


def test_toc_state_refuses_a_toc_outside_the_aperture():
    """A TOC outside the interval's epochs is an InputDataError naming eta and the valid span."""
    with pytest.raises(InputDataError, match=r"^eta: must be in \[0.0, 1.0\] s"):
        toc_state(navigator().nav, interval(), np.array([0.5, 1.2]))


# --------------------------------------------------------------------------- the prediction
def test_predict_gives_the_hand_range_and_cross_range_at_the_map_target_with_the_settings_sigma():
    """No delay, no second order: z_hat, H written out at each run's TOC state and map target; R = diag(sigma^2)."""
    nv, iv = navigator(), interval()
    eta = np.array([[0.45], [0.6]])
    mt = map_targets([(3.0, -2.0, 1.0), (-1.0, 4.0, 0.5)])  # the map's own error, different per run
    aid = SarAiding(settings(), L, runs=2, targets=1, image=False)
    pred = aid.predict(nv, iv, eta, mt)
    assert pred.z_hat.shape == (2, 2) and pred.C is None and pred.hessians is None
    for r in range(2):
        p, v = est_p(r, eta[r, 0]), est_v(r)
        np.testing.assert_allclose(pred.z_hat[r], hand_pair(mt[r, 0], p, v, BM[r, 1], BM[r, 2]), rtol=1e-13)
        np.testing.assert_allclose(pred.H[r], hand_rows(mt[r, 0], p, v), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(pred.R[r], np.diag([4.0, 9.0]), rtol=1e-15)


def test_jacobians_of_the_predictions_agree_with_central_finite_differences():
    """d z_hat / d dx by moving the estimate at the TOC (p, v of the history; the bias estimates) by +-h: equals H;
    the attitude, IMU-bias and altimeter-bias columns are zero."""
    nv, iv = navigator(), interval()
    eta = np.array([[0.45], [0.62]])
    aid = SarAiding(settings(), L, runs=2, targets=1, image=False)
    H = aid.predict(nv, iv, eta, map_targets()).H

    def z_at(dx):
        nv.nav.bm = BM + dx[:, L.scalar_slice]
        z = aid.predict(nv, interval(dx[:, IP], dx[:, IV]), eta, map_targets()).z_hat
        nv.nav.bm = BM.copy()
        return z

    fd = np.zeros_like(H)
    for j in range(L.n):
        h = 1e-3 if j < 6 else 1e-4
        e = np.zeros((2, L.n))
        e[:, j] = h
        fd[:, :, j] = (z_at(e) - z_at(-e)) / (2 * h)
    np.testing.assert_allclose(fd, H, rtol=1e-6, atol=1e-9)
    assert np.all(H[:, :, 6:15] == 0) and np.all(H[:, :, I_ALT] == 0)


def test_the_paper_cross_range_model_uses_the_estimated_aperture_direction():
    """"paper": z = u_c . (p(eta) - r_orig) + b_c with u_c along the estimated aperture, r_orig its first epoch."""
    nv, iv = navigator(), interval()
    eta = np.array([[0.3], [0.7]])
    pred = SarAiding(settings(cross_model="paper"), L, 2, 1, image=False).predict(nv, iv, eta, map_targets())
    for r in range(2):
        u_c = est_p(r, 1.0) - est_p(r, 0.0)
        u_c /= np.linalg.norm(u_c)
        assert pred.z_hat[r, 1] == pytest.approx(u_c @ (est_p(r, eta[r, 0]) - est_p(r, 0.0)) + BM[r, 2], rel=1e-12)
        np.testing.assert_allclose(pred.H[r, 1, IP], u_c, rtol=1e-12)
        assert np.all(pred.H[r, 1, IV] == 0)


def test_an_unknown_cross_range_model_is_one_line_naming_the_key():
    """The cross-range model is validated when the models are made: ConfigError naming sar.cross_range_model."""
    aid = SarAiding(settings(cross_model="doppler"), L, 2, 1, image=False)
    with pytest.raises(ConfigError, match=r"^sar.cross_range_model: must be one of"):
        aid.predict(navigator(), interval(), np.full((2, 1), 0.5), map_targets())


def test_the_maps_geolocation_noise_adds_J_D_J_transpose_to_R():
    """R gains J D J^T with J = d(range, cross) / d(target) = -H_p: the settings' sigma by default, map_sigma per
    target instead; z_hat and H are unchanged (the map's error is independent of the vehicle's)."""
    nv, iv = navigator(), interval()
    eta = np.full((2, 1), 0.5)
    base = SarAiding(settings(), L, 2, 1, image=False).predict(nv, iv, eta, map_targets())
    geo = np.array([1.5, 2.5, 4.0])
    with_map = SarAiding(settings(geolocation_sigma=geo), L, 2, 1, image=False).predict(nv, iv, eta, map_targets())
    own = SarAiding(settings(geolocation_sigma=geo), L, 2, 1, image=False).predict(
        nv, iv, eta, map_targets(), map_sigma=np.array([[3.0, 3.0, 3.0]]))
    for r in range(2):
        p, v = est_p(r, 0.5), est_v(r)
        d = TARGET - p
        J = np.stack([d / np.linalg.norm(d), -v / np.linalg.norm(v)])  # range grows, cross-range shrinks with the target
        np.testing.assert_allclose(with_map.R[r] - base.R[r], J @ np.diag(geo**2) @ J.T, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(own.R[r] - base.R[r], 9.0 * J @ J.T, rtol=1e-10, atol=1e-12)
    np.testing.assert_array_equal(with_map.z_hat, base.z_hat)
    np.testing.assert_array_equal(with_map.H, base.H)


def test_second_order_terms_in_closed_form_for_isotropic_covariances():
    """P = s_p^2 I (position), s_v^2 I (velocity), uncorrelated: range gains s_p^2 / rho in z_hat and s_p^4 / rho^2
    in R; zero-Doppler cross-range gains -s_v^2 (u . l) / |v|^2 in z_hat (Gelb §6.1, tr(A P) / 2)."""
    sp, sv = 20.0, 0.8
    P = np.diag(np.r_[np.full(3, sp**2), np.full(3, sv**2), np.full(12, 1e-6)])
    nv, iv = navigator(P), interval()
    eta = np.full((2, 1), 0.4)
    first = SarAiding(settings(), L, 2, 1, image=False).predict(nv, iv, eta, map_targets())
    second = SarAiding(settings(second_order=True), L, 2, 1, image=False).predict(nv, iv, eta, map_targets())
    for r in range(2):
        p, v = est_p(r, 0.4), est_v(r)
        rho = np.linalg.norm(TARGET - p)
        l_u = (p - TARGET) @ v / np.linalg.norm(v)
        dz = second.z_hat[r] - first.z_hat[r]
        assert dz[0] == pytest.approx(sp**2 / rho, rel=1e-9)
        assert dz[1] == pytest.approx(-sv**2 * l_u / (v @ v), rel=1e-6, abs=1e-12)
        assert second.R[r, 0, 0] - first.R[r, 0, 0] == pytest.approx(sp**4 / rho**2, rel=1e-9)
    np.testing.assert_array_equal(second.H, first.H)
    assert second.hessians is None


def test_delayed_state_maps_the_toc_jacobian_through_the_back_transition():
    """Delayed state: H Phi(t_k, t_c) = H at the TOC, C = -Q_d H^T and R + H Q_d H^T (Phi, Q_d of the error model
    over t_k - t_c); a TOC at the update epoch changes nothing but adds C = 0."""
    nv, iv = navigator(), interval()
    eta = np.array([[0.35], [0.55]])
    toc = SarAiding(settings(), L, 2, 1, image=False).predict(nv, iv, eta, map_targets())
    late = SarAiding(settings(delayed_state=True), L, 2, 1, image=False)
    pred = late.predict(nv, iv, eta, map_targets())
    T = quat_to_dcm(nv.nav.q)
    for r in range(2):
        Phi, Qd = nv.model.discretize(T[r:r + 1], iv.f_mean[r:r + 1], 1.0 - eta[r, 0])
        np.testing.assert_allclose(pred.H[r] @ Phi[0], toc.H[r], rtol=1e-9, atol=1e-10)
        np.testing.assert_allclose(pred.C[r], -Qd[0] @ pred.H[r].T, rtol=1e-12, atol=1e-18)
        np.testing.assert_allclose(pred.R[r] - toc.R[r], pred.H[r] @ Qd[0] @ pred.H[r].T, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(pred.z_hat, toc.z_hat, rtol=1e-15)
    at_end = late.predict(nv, iv, np.ones((2, 1)), map_targets())
    plain = SarAiding(settings(), L, 2, 1, image=False).predict(nv, iv, np.ones((2, 1)), map_targets())
    np.testing.assert_allclose(at_end.H, plain.H, rtol=1e-15)
    np.testing.assert_allclose(at_end.R, plain.R, rtol=1e-15)
    assert np.all(at_end.C == 0)


def test_pairs_of_several_targets_stack_each_at_its_own_toc():
    """T targets: components (range, cross) of target k at 2k, 2k + 1, each at its own TOC and map target; R block
    diagonal."""
    nv, iv = navigator(), interval()
    second = TARGET + np.array([25.0, 10.0, 0.0])
    mt = np.stack([np.stack([TARGET, second])] * 2)  # (R, T=2, 3)
    eta = np.array([[0.5, 0.9], [0.45, 0.85]])
    pred = SarAiding(settings(), L, 2, 2, image=False).predict(nv, iv, eta, mt)
    assert pred.z_hat.shape == (2, 4)
    for r in range(2):
        for k, tg in enumerate((TARGET, second)):
            np.testing.assert_allclose(pred.z_hat[r, 2 * k:2 * k + 2],
                                       hand_pair(tg, est_p(r, eta[r, k]), est_v(r), BM[r, 1], BM[r, 2]), rtol=1e-13)
        assert np.all(pred.R[r, :2, 2:] == 0)


def test_along_sigma_is_the_filters_cross_range_sigma_at_the_aperture_centre():
    """sqrt(H P H^T) of the zero-Doppler cross-range at the middle epoch of the estimated track, no R."""
    nv, iv = navigator(), interval()
    aid = SarAiding(settings(), L, 2, 1, image=True)
    got = aid.along_sigma(nv, iv, map_targets()[:, 0])
    for r in range(2):
        h = hand_rows(TARGET, est_p(r, 0.5), est_v(r))[1]
        assert got[r] == pytest.approx(np.sqrt(h @ nv.P[r] @ h), rel=1e-10)


# --------------------------------------------------------------------------- what the images give
def _measurements(status, sigma, sensitivity, offset):
    """The fields of ``ApertureMeasurements`` that ``SarAiding.take`` reads."""
    return SimpleNamespace(status=np.array(status), sigma=np.array(sigma, dtype=float),
                           sensitivity=np.array(sensitivity, dtype=float), focus_offset=np.array(offset, dtype=float))


def test_take_uses_each_images_sigma_and_focus_model_where_it_measured():
    """Measured pairs: the image's sigma and focusing-shift model; failed pairs and NaN or non-positive sigmas: 1 m
    placeholders and no shift; the status is kept (a copy)."""
    am = _measurements(status=[[0, 0], [2, 0]], sigma=[[[0.3, 0.4], [np.nan, 0.5]], [[0.2, 0.2], [0.6, -1.0]]],
                       sensitivity=[[0.1, np.nan], [0.7, 0.2]], offset=[[0.5, 0.3], [9.0, np.nan]])
    aid = SarAiding(settings(), L, 2, 2, image=True)
    aid.take(am)
    np.testing.assert_array_equal(aid.sigma, [[[0.3, 0.4], [1.0, 0.5]], [[1.0, 1.0], [0.6, 1.0]]])
    np.testing.assert_array_equal(aid.sensitivity, [[0.1, 0.0], [0.0, 0.2]])
    np.testing.assert_array_equal(aid.focus_offset, [[0.5, 0.3], [0.0, 0.0]])
    am.status[1, 0] = 0
    assert aid.status[1, 0] == 2


def test_take_with_constant_registration_sigma_and_added_noise():
    """``registration_sigma`` replaces the image's; ``image_added_noise`` adds Table 2's sigma in quadrature; the
    mapdrift focus carries no shift model."""
    am = _measurements([[0], [1]], [[[0.3, 0.4]], [[0.2, 0.2]]], [[0.1], [0.1]], [[0.5], [0.5]])
    aid = SarAiding(settings(registration_sigma=np.array([0.5, 0.6]), image_added_noise=True, focus="mapdrift"),
                    L, 2, 1, image=True)
    aid.take(am)
    np.testing.assert_allclose(aid.sigma, [[[np.hypot(2.0, 0.5), np.hypot(3.0, 0.6)]],
                                           [[np.hypot(2.0, 1.0), np.hypot(3.0, 1.0)]]], rtol=1e-15)
    assert aid.sensitivity is None and aid.focus_offset is None


def test_the_focus_model_shifts_the_cross_range_and_adds_a_velocity_column():
    """After an image focused with the estimate: cross-range z_hat less its focus offset, H_v + sensitivity u;
    R from the image's sigma; the range is unchanged."""
    nv, iv = navigator(), interval()
    eta = np.full((2, 1), 0.5)
    aid = SarAiding(settings(), L, 2, 1, image=True)
    before = aid.predict(nv, iv, eta, map_targets())
    aid.take(_measurements([[0], [0]], [[[0.3, 0.4]], [[0.5, 0.6]]], [[0.25], [-0.4]], [[1.5], [-2.0]]))
    after = aid.predict(nv, iv, eta, map_targets())
    for r, (sens, off) in enumerate([(0.25, 1.5), (-0.4, -2.0)]):
        u = est_v(r) / np.linalg.norm(est_v(r))
        assert after.z_hat[r, 1] == pytest.approx(before.z_hat[r, 1] - off, rel=1e-12)
        np.testing.assert_allclose(after.H[r, 1, IV] - before.H[r, 1, IV], sens * u, rtol=1e-12, atol=1e-15)
        assert after.z_hat[r, 0] == before.z_hat[r, 0]
    np.testing.assert_allclose(after.R[:, [0, 1], [0, 1]], [[0.09, 0.16], [0.25, 0.36]], rtol=1e-12)
    np.testing.assert_allclose(before.R[:, [0, 1], [0, 1]], 1.0)


# --------------------------------------------------------------------------- screening
def _screen_case(gate, status, offsets):
    """Screen one altimeter (first component) + one pair per run whose z is z_hat + offsets (R, 3) of sigma-units:
    (codes, S of each pair)."""
    nv, iv = navigator(), interval()
    aid = SarAiding(settings(gate_probability=gate), L, 2, 1, image=False)
    aid.status = np.array(status)
    from sarnav.filters.prediction import Prediction, stack_predictions
    from sarnav.filters.update import innovation_covariance

    sar = aid.predict(nv, iv, np.full((2, 1), 0.5), map_targets())
    h_alt = np.zeros((2, 1, L.n))
    h_alt[:, 0, 2] = -1.0
    pred = stack_predictions([Prediction(np.zeros((2, 1)), h_alt, np.ones((2, 1, 1))), sar])
    S = innovation_covariance(nv.P, pred)
    sd = np.sqrt(np.diagonal(S, axis1=1, axis2=2))
    z = pred.z_hat + np.asarray(offsets, dtype=float) * sd
    return aid.screen(nv, pred, z, first=1), S


def test_screen_gates_a_pair_beyond_the_chi_square_quantile_and_not_the_altimeter():
    """A pair whose NIS exceeds chi2.isf(p, 2) is coded 'innovation gate'; one inside passes (0); the altimeter in
    front of the pairs is never gated, however far off."""
    codes, S = _screen_case(1e-4, [[0], [0]], [[1e6, 1.0, 1.0], [0.0, 8.0, 0.0]])
    nis1 = 8.0**2 / (1 - S[1, 1, 2] ** 2 / (S[1, 1, 1] * S[1, 2, 2]))  # r = (8 sigma, 0): r^T S^-1 r of the pair
    assert nis1 > chi2.isf(1e-4, 2)  # the second run's pair is far beyond the gate
    assert REJECTIONS[codes[1, 0]] == "innovation gate" and codes[1, 0] == len(FAILURES)
    assert codes[0, 0] == 0


def test_screen_keeps_the_images_own_failure_and_gates_nothing_at_probability_zero():
    """A failed image keeps its own code (even with a wild or NaN z); probability 0 accepts every finite pair."""
    codes, _ = _screen_case(1e-4, [[3], [0]], [[0.0, np.nan, 1e3], [0.0, 0.5, -0.5]])
    assert codes.tolist() == [[3], [0]] and REJECTIONS[3] == "weak match (correlation)"
    codes, _ = _screen_case(0.0, [[0], [1]], [[0.0, 50.0, 50.0], [0.0, 1e3, 0.0]])
    assert codes.tolist() == [[0], [1]]


def test_rejections_are_the_image_failures_then_the_gate():
    """REJECTIONS extends FAILURES (0: fused) with the innovation gate as the last code."""
    assert REJECTIONS[:len(FAILURES)] == FAILURES and REJECTIONS[-1] == "innovation gate" and REJECTIONS[0] == ""


def test_a_nan_map_sigma_is_refused_not_dropped():
    """A NaN in the map's geolocation sigma is one InputDataError naming ``map_sigma``; before, an all-NaN sigma
    switched the map's noise off silently (``np.any(D > 0)`` is False for NaN)."""
    from sarnav.errors import InputDataError

    aid = SarAiding(settings(), L, 2, 1, image=False)
    for bad in ([[np.nan, np.nan, np.nan]], [[1.0, np.nan, 1.0]]):
        with pytest.raises(InputDataError, match="^map_sigma: .*finite"):
            aid.predict(navigator(), interval(), np.full((2, 1), 0.5), map_targets(), map_sigma=np.array(bad))

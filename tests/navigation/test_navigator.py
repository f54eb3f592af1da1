"""The navigator (``sarnav.navigation.navigator``): INS + covariance between events and the one update path.

Checked against independent computations: the covariance against Phi P Phi^T + Q_d of the error model written out
here, the Kalman update against the textbook gain and Joseph form in plain numpy, a masked component against the
same update without it, the NIS against r^T S^-1 r, the gate against the chi-square quantile; a perfect IMU flown from
the truth stays on the truth (the strapdown's integration error only)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters import ErrorStateLayout
from sarnav.frames.ned import GRAVITY_NED
from sarnav.filters.prediction import Prediction
from sarnav.ins import NavState
from sarnav.navigation import Navigator, error_model, fuse
from sarnav.sensors.imu import IMU_GRADES, ImuSpec
from sarnav.trajectory import StraightLevel

LAYOUT = ErrorStateLayout(("b_alt",), scalar_units=("m",))
RATE = 100.0


def _truth(runs=2, duration=2.0):
    traj = StraightLevel(start=np.array([0.0, 0.0, -1000.0]), speed=50.0, heading=0.3, duration=duration)
    t = np.arange(int(duration * RATE) + 1) / RATE
    st = traj.state(t)
    nu = np.broadcast_to(traj.specific_force(t), (runs, t.size, 3)).copy()
    om = np.broadcast_to(traj.angular_rate(t), (runs, t.size, 3)).copy()
    return t, st, nu, om


def _navigator(runs=2, attitude="mid", P0=None):
    t, st, nu, om = _truth(runs)
    nav = NavState(p=np.broadcast_to(st.position[0], (runs, 3)).copy(), v=np.broadcast_to(st.velocity[0], (runs, 3)).copy(),
                   q=np.broadcast_to(st.quaternion[0], (runs, 4)).copy(), ba=np.zeros((runs, 3)),
                   bg=np.zeros((runs, 3)), bm=np.zeros((runs, 1)))
    imu = ImuSpec(IMU_GRADES["tactical"], 3600.0, 3600.0)
    model = error_model(LAYOUT, imu, np.array([0.1]), np.array([300.0]))
    if P0 is None:
        P0 = np.broadcast_to(np.diag(np.linspace(0.5, 2.0, LAYOUT.n) ** 2), (runs, LAYOUT.n, LAYOUT.n)).copy()
    nv = Navigator(nav, P0, model, LAYOUT, tau_accel=3600.0, tau_gyro=3600.0, bias_tau=np.array([300.0]),
                   covariance_attitude=attitude)
    return nv, (t, st, nu, om)


def test_a_perfect_imu_keeps_the_truth_and_the_covariance_follows_the_error_model():
    nv, (t, st, nu, om) = _navigator(attitude="start")
    P_prev = nv.P.copy()
    iv = nv.propagate(t[:101], nu[:, :101], om[:, :101], samples_per_step=10, transition=True)
    assert iv.t.shape == (11,) and iv.p.shape == (2, 11, 3) and len(iv.estimates) == 10
    # the INS on error-free samples: the truth at every step epoch (three-point rule on a straight track)
    np.testing.assert_allclose(iv.p[0], st.position[:101:10], atol=1e-6)
    np.testing.assert_allclose(iv.v[0], st.velocity[:101:10], atol=1e-8)
    # the covariance: P <- Phi P Phi^T + Qd step by step, Phi and Qd from the error model at the step's start
    # attitude (the truth's: it stays on the truth) and the true f^n
    P, Phi_all = P_prev[0], np.eye(LAYOUT.n)
    from sarnav.rotations import quat_to_dcm
    for s in range(10):
        f_n = -GRAVITY_NED[None]  # level, unaccelerated flight: f^n = -g
        Phi, Qd = nv.model.discretize(quat_to_dcm(st.quaternion[10 * s][None]), f_n, 0.1)
        P = Phi[0] @ P @ Phi[0].T + Qd[0]
        Phi_all = Phi[0] @ Phi_all
    np.testing.assert_allclose(nv.P[0], P, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(iv.Phi[0], Phi_all, rtol=1e-6, atol=1e-12)
    # the transition over the block maps the prior to the propagated covariance with the block's process noise
    np.testing.assert_allclose(iv.Phi[0] @ P_prev[0] @ iv.Phi[0].T + iv.Qd[0], nv.P[0], rtol=1e-6, atol=1e-10)


def _prediction(nv, m=3, seed=1, C=False):
    rng = np.random.default_rng(seed)
    R, n = nv.runs, LAYOUT.n
    H = rng.standard_normal((R, m, n))
    A = rng.standard_normal((R, m, m))
    Rm = A @ np.swapaxes(A, 1, 2) + np.eye(m)
    Cm = 0.05 * rng.standard_normal((R, n, m)) if C else None
    return Prediction(rng.standard_normal((R, m)), H, Rm, Cm), rng.standard_normal((R, m))


def _textbook(P, H, Rm, r, C=None):
    """Kalman update written out (Brown & Hwang with cov(dx, v) = C; C = 0: the Joseph form)."""
    C = np.zeros((P.shape[0], H.shape[0])) if C is None else C
    S = H @ P @ H.T + Rm + H @ C + C.T @ H.T
    K = (P @ H.T + C) @ np.linalg.inv(S)
    A = np.eye(P.shape[0]) - K @ H
    P_post = A @ P @ A.T + K @ Rm @ K.T - A @ C @ K.T - K @ C.T @ A.T
    return K @ r, P_post, S


@pytest.mark.parametrize("correlated", [False, True])
def test_the_update_is_the_textbook_kalman_update_and_feeds_back(correlated):
    nv, _ = _navigator()
    pred, z = _prediction(nv, C=correlated)
    P0, p0 = nv.P.copy(), nv.nav.p.copy()
    fused = nv.update(pred, z)
    for i in range(nv.runs):
        r = z[i] - pred.z_hat[i]
        dx, P_post, S = _textbook(P0[i], pred.H[i], pred.R[i], r, None if pred.C is None else pred.C[i])
        np.testing.assert_allclose(fused.update.dx[i], dx, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(nv.P[i], P_post, rtol=1e-8, atol=1e-12)
        assert fused.nis[i] == pytest.approx(r @ np.linalg.solve(S, r), rel=1e-9)
        # feedback: dx = truth - estimate, so the estimate moves by +dx in position
        np.testing.assert_allclose(nv.nav.p[i], p0[i] + dx[:3], rtol=0, atol=1e-9)
    assert np.all(fused.dof == 3)


def test_a_component_left_out_changes_nothing_and_the_nis_counts_the_rest():
    a, _ = _navigator()
    b, _ = _navigator()
    pred, z = _prediction(a, m=3)
    keep = np.array([[True, False, True], [True, True, True]])
    fa = a.update(pred, z, keep)
    # run 0 without component 1, written as a 2-component prediction
    idx = [0, 2]
    sub = Prediction(pred.z_hat[:1, idx], pred.H[:1, idx], pred.R[:1][:, idx][:, :, idx])
    dx, P_post, S = _textbook(b.P[0], sub.H[0], sub.R[0], z[0, idx] - sub.z_hat[0])
    np.testing.assert_allclose(fa.update.dx[0], dx, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(a.P[0], P_post, rtol=1e-8, atol=1e-12)
    r = z[0, idx] - sub.z_hat[0]
    assert fa.nis[0] == pytest.approx(r @ np.linalg.solve(S, r), rel=1e-9) and fa.dof[0] == 2
    assert np.isnan(fa.residual[0, 1]) and np.isnan(fa.residual_sigma[0, 1]) and np.isfinite(fa.residual[1]).all()
    assert fa.dof[1] == 3


def test_the_gate_rejects_at_the_chi_square_quantile():
    nv, _ = _navigator(runs=3)
    m = 2
    H = np.zeros((3, m, LAYOUT.n))
    H[:, 0, 0] = H[:, 1, 1] = 1.0
    pred = Prediction(np.zeros((3, m)), H, np.broadcast_to(np.eye(m), (3, m, m)))
    S = nv.P[:, :2, :2] + np.eye(m)  # H P H^T + R
    limit = chi2.isf(0.01, 2)
    # residuals along the first axis at NIS = 0.9, 1.1 x the limit and a NaN (no measurement)
    z = np.zeros((3, m))
    z[0, 0] = np.sqrt(0.9 * limit * S[0, 0, 0] * (1 - S[0, 0, 1] ** 2 / (S[0, 0, 0] * S[0, 1, 1])))
    z[1, 0] = np.sqrt(1.1 * limit * S[1, 0, 0] * (1 - S[1, 0, 1] ** 2 / (S[1, 0, 0] * S[1, 1, 1])))
    z[2, 0] = np.nan
    np.testing.assert_array_equal(nv.gate(pred, z, [[0, 1]], 0.01)[:, 0], [True, False, False])


def test_bad_input_names_the_parameter():
    nv, (t, _, nu, om) = _navigator()
    with pytest.raises(InputDataError, match="^samples_per_step"):
        nv.propagate(t[:11], nu[:, :11], om[:, :11], samples_per_step=3)
    with pytest.raises(ConfigError, match="^covariance_attitude"):
        _navigator(attitude="end")
    with pytest.raises(InputDataError, match="^P"):
        _navigator(P0=np.eye(3))


def test_the_navigation_package_never_imports_the_world():
    """The navigator never sees truth: nothing in ``sarnav.navigation`` imports the simulated world, truth motion,
    truth sensors or the echo simulator (trajectory.sampled, geometry on any track, is allowed)."""
    forbidden = ("sarnav.simulation", "sarnav.scenarios", "sarnav.montecarlo", "sarnav.radar.echoes",
                 "sarnav.radar.scene", "sarnav.radar.ground_scene", "sarnav.sensors.gauss_markov",
                 "sarnav.trajectory.straight", "sarnav.trajectory.maneuver", "sarnav.trajectory.orbit")
    root = Path(__file__).resolve().parents[2] / "src" / "sarnav" / "navigation"
    bad = []
    for f in root.rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            bad += [f"{f.name}: {n}" for n in names if n.startswith(forbidden) or n == "sarnav.trajectory"]
    assert not bad, bad


def test_fuse_with_underweighting_inflates_the_gain_covariance_by_one_plus_beta():
    """Lear's underweighting (spacecraft paper eqs. 35-43): the gain of S = (1 + beta) H P H^T + R, Joseph form with
    R' = beta H P H^T + R; beta = 0 is the plain update."""
    nv, _ = _navigator()
    pred, z = _prediction(nv, m=2)
    beta = np.array([0.0, 0.2])
    fused = fuse(nv.P, pred, z, beta=beta)
    plain = fuse(nv.P, pred, z)
    np.testing.assert_allclose(fused.update.dx[0], plain.update.dx[0], rtol=1e-12, atol=1e-15)
    P, H, Rm = nv.P[1], pred.H[1], pred.R[1]
    r = z[1] - pred.z_hat[1]
    dx, P_post, S = _textbook(P, H, beta[1] * H @ P @ H.T + Rm, r)
    np.testing.assert_allclose(S, (1 + beta[1]) * H @ P @ H.T + Rm, rtol=1e-12)
    np.testing.assert_allclose(fused.update.dx[1], dx, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fused.update.P[1], P_post, rtol=1e-8, atol=1e-12)
    assert fused.nis[1] == pytest.approx(r @ np.linalg.solve(S, r), rel=1e-9)
    with pytest.raises(InputDataError, match="^beta"):
        fuse(nv.P, pred, z, keep=np.ones((2, 2), bool), beta=beta)

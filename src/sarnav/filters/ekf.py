"""Error-state EKF steps, batched over runs (thesis eqs. 3.18, 3.20-3.22).

All functions take stacks with a leading run axis and never mix runs, so a run's numbers do not
depend on which other runs share the batch (tests/test_ekf.py checks bit-identity).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import InputDataError


def _t(a):
    return np.swapaxes(a, -1, -2)


def symmetrize(P):
    """(P + P^T)/2."""
    return 0.5 * (P + _t(P))


def propagate_covariance(P, Phi, Qd):
    """P <- Phi P Phi^T + Q_d (discrete form of eq. 3.18), symmetrised. Shapes (R, n, n)."""
    return symmetrize(Phi @ P @ _t(Phi) + Qd)


def joseph_update(P, H, R, residual):
    """Kalman gain, Joseph-form covariance update and error-state estimate (eqs. 3.20-3.22).

    Parameters
    ----------
    P : (R, n, n) prior covariance; H : (R, m, n); R : (R, m, m) or (m, m) measurement noise
    (G = I, extraction seed-000 §16 item 19); residual : (R, m) z - z_hat.

    Returns
    -------
    dx : (R, n) error-state estimate K r; P_post : (R, n, n) symmetrised
    ``(I - K H) P (I - K H)^T + K R K^T``; S : (R, m, m) innovation covariance H P H^T + R.
    """
    P = np.asarray(P, dtype=float)
    H = np.asarray(H, dtype=float)
    residual = np.asarray(residual, dtype=float)
    if not np.all(np.isfinite(residual)):
        raise InputDataError("residual", "measurement residuals must be finite")
    Rm = np.broadcast_to(np.asarray(R, dtype=float), H.shape[:-1] + H.shape[-2:-1])
    PHt = P @ _t(H)
    S = symmetrize(H @ PHt + Rm)
    # K = P H^T S^-1  <=>  S K^T = H P  (S symmetric)
    K = _t(np.linalg.solve(S, _t(PHt)))
    n = P.shape[-1]
    IKH = np.eye(n) - K @ H
    P_post = symmetrize(IKH @ P @ _t(IKH) + K @ Rm @ _t(K))
    dx = (K @ residual[..., None])[..., 0]
    return dx, P_post, S


def correlated_update(P, H, R, C, residual):
    """Kalman update with measurement noise correlated with the state error, cov(dx, nu) = C (Brown & Hwang,
    "correlated process and measurement noise"); C = 0 gives the Joseph update of ``filters.joseph_update``.

    S = H P H^T + R + H C + C^T H^T,  K = (P H^T + C) S^-1,
    P+ = (I - K H) P (I - K H)^T + K R K^T - (I - K H) C K^T - K C^T (I - K H)^T  (valid for any K).
    Shapes: P (R, n, n), H (R, m, n), R (R, m, m), C (R, n, m), residual (R, m). Returns dx, P+, S.
    Used for a delayed-state measurement whose noise includes the process noise after its epoch
    (docs/scenarios/rda-nav.md §2).
    """
    residual = np.asarray(residual, dtype=float)
    if not np.all(np.isfinite(residual)):
        raise InputDataError("residual", "measurement residuals must be finite")
    Ht = np.swapaxes(H, -1, -2)
    Ct = np.swapaxes(C, -1, -2)
    S = H @ P @ Ht + R + H @ C + Ct @ Ht
    S = 0.5 * (S + np.swapaxes(S, -1, -2))
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(P @ Ht + C, -1, -2)), -1, -2)
    A = np.eye(P.shape[-1]) - K @ H
    Kt = np.swapaxes(K, -1, -2)
    P_new = A @ P @ np.swapaxes(A, -1, -2) + K @ R @ Kt - A @ C @ Kt - K @ Ct @ np.swapaxes(A, -1, -2)
    P_new = 0.5 * (P_new + np.swapaxes(P_new, -1, -2))
    dx = (K @ residual[..., None])[..., 0]
    return dx, P_new, S


def normalized_squared(e, C):
    """e^T C^-1 e for stacks (NEES with C = P, NIS with C = S): (R, n), (R, n, n) -> (R,)."""
    e = np.asarray(e, dtype=float)
    return np.sum(e * np.linalg.solve(C, e[..., None])[..., 0], axis=-1)


def directional_sigma(P, block: slice, direction):
    """(R,) 1-sigma of a 3-vector block of the error state along ``direction`` (R, 3) (normalised here),
    sqrt(u^T P_bb u), e.g. the forward-speed uncertainty along the estimated velocity."""
    d = np.asarray(direction, dtype=float)
    u = d / np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2])[:, None]
    Pb = np.asarray(P)[:, block, block]
    # written out term by term (elementwise over the runs, no reduction): einsum's and norm's reductions round by
    # the batch's size and memory alignment, which made a run's last bits depend on the runs batched with it
    t = u[:, :, None] * Pb * u[:, None, :]
    q = t[:, 0, 0] + t[:, 0, 1] + t[:, 0, 2] + t[:, 1, 0] + t[:, 1, 1] + t[:, 1, 2] + t[:, 2, 0] + t[:, 2, 1] + t[:, 2, 2]
    return np.sqrt(q)

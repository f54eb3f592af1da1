"""Delayed-state measurements: a measurement of the state at an earlier epoch applied at the update epoch.

A SAR image measures the vehicle at the target's time of closest approach t_c, inside the aperture; the update
happens at its end t_k (NAVIGATION paper eq. 57, extended with the process noise; docs/scenarios/rda-nav.md §2).
With the error-state transition Phi = Phi(t_k, t_c) and the process noise w accumulated over [t_c, t_k] (cov Q_d)::

    dx(t_c) = Phi^-1 (dx(t_k) - w)
    z = H_c dx(t_c) + v = (H_c Phi^-1) dx(t_k) + (v - H_c Phi^-1 w)

so the mapped Jacobian is H = H_c Phi^-1, the noise covariance gains H Q_d H^T and the noise is correlated with
dx(t_k): cov(dx(t_k), nu) = -Q_d H^T (use ``sarnav.filters.update.correlated``). The covariance of dx(t_c),
needed by the second-order terms, is Phi^-1 (P - Q_d) Phi^-T.
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters.prediction import Prediction

__all__ = ["back_transition", "covariance_at", "map_to_update_epoch"]


def back_transition(model, T_hat, f_mean, spans):
    """Phi(t_c, t_k) = Phi(t_k, t_c)^-1 and Q_d over [t_c, t_k] for each run, (R, n, n) each.

    ``model``: an error model with ``discretize(T (1, 3, 3), f^n (1, 3), dt) -> (Phi, Q_d)`` and ``layout.n``;
    ``T_hat`` (R, 3, 3) and ``f_mean`` (R, 3): attitude and specific force held over the span (the last
    propagation step's); ``spans`` (R,) t_k - t_c [s] (identity and zero noise for a span <= 0).
    """
    spans = np.asarray(spans, dtype=np.float64)
    runs, n = spans.shape[0], model.layout.n
    Phi_inv, Qd = np.empty((runs, n, n)), np.empty((runs, n, n))
    for r in range(runs):  # the span differs per run
        if spans[r] <= 0:
            Phi_inv[r], Qd[r] = np.eye(n), 0.0
            continue
        Phi, Q = model.discretize(T_hat[r:r + 1], f_mean[r:r + 1], float(spans[r]))
        Phi_inv[r], Qd[r] = np.linalg.inv(Phi)[0], Q[0]
    return Phi_inv, Qd


def covariance_at(P, Phi_inv, Qd):
    """Covariance of dx(t_c) = Phi^-1 (dx(t_k) - w): Phi^-1 (P - Q_d) Phi^-T, (R, n, n)."""
    out = np.empty_like(np.asarray(P, dtype=np.float64))
    for r in range(out.shape[0]):
        out[r] = Phi_inv[r] @ (P[r] - Qd[r]) @ Phi_inv[r].T
    return out


def map_to_update_epoch(pred: Prediction, Phi_inv, Qd) -> Prediction:
    """The prediction of a measurement of dx(t_c) expressed in dx(t_k): H Phi^-1, R + H Q_d H^T, C = -Q_d H^T.

    ``pred`` must carry no cross-covariance yet (C is None); its Hessians (still w.r.t. dx(t_c)) are dropped.
    """
    if pred.C is not None:
        raise InputDataError("prediction.C", "is already set; map a prediction to the update epoch once")
    runs, m, n = pred.H.shape
    if np.shape(Phi_inv) != (runs, n, n) or np.shape(Qd) != (runs, n, n):
        raise InputDataError("Phi_inv", f"Phi_inv and Q_d must be (R, n, n) = {(runs, n, n)}")
    H, R, C = np.empty_like(pred.H), pred.R.copy(), np.empty((runs, n, m))
    for r in range(runs):
        for i in range(m):  # row by row: each component alone would give the same numbers
            H[r, i:i + 1] = pred.H[r, i:i + 1] @ Phi_inv[r]
        R[r] += H[r] @ Qd[r] @ H[r].T
        C[r] = -Qd[r] @ H[r].T
    return pred.replace(H=H, R=R, C=C, hessians=None)

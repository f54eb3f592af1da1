"""Gaussian second-order filter terms of a measurement (Gelb 1974 §6.1; docs/scenarios/rda-nav.md §2).

For z = h(x) + v with Hessians A_i = d^2 h_i / d(dx)^2 and a zero-mean Gaussian error of covariance P, the
expected measurement gains ``dz_i = tr(A_i P) / 2`` and the noise gains the variance of the quadratic remainder,
``C_ij = tr(A_i P A_j P) / 2`` (uncorrelated with the error itself). ``P`` is the covariance of the error state
*at the measurement's epoch* (``sarnav.filters.delayed.covariance_at`` for a delayed-state measurement).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters.prediction import Prediction

__all__ = ["second_order_terms", "with_second_order", "batched_terms", "with_second_order_batched"]


def second_order_terms(hessians, P):
    """(dz (m,), C (m, m)) of one run: hessians (m, n, n) or a sequence of (n, n), P (n, n)."""
    P = np.asarray(P, dtype=np.float64)
    n = P.shape[0]
    if P.shape != (n, n) or not np.all(np.isfinite(P)):
        raise InputDataError("P_toc", f"must be a finite square matrix, got {P.shape}")
    AP = []
    for A in hessians:
        A = np.asarray(A, dtype=np.float64)
        if A.shape != (n, n):
            raise InputDataError("hessian", f"must be ({n}, {n}) like P_toc, got {A.shape}")
        AP.append(A @ P)
    dz = np.array([0.5 * np.trace(a) for a in AP])
    C = np.array([[0.5 * np.sum(a * b.T) for b in AP] for a in AP])
    return dz, C


def with_second_order(pred: Prediction, P) -> Prediction:
    """``pred`` with the second-order mean correction added to z_hat and the remainder variance added to R.

    ``P`` (R, n, n): covariance of the error state the Hessians refer to. Needs ``pred.hessians``.
    """
    if pred.hessians is None:
        raise InputDataError("prediction.hessians", "the second-order terms need the measurement's Hessians")
    P = np.asarray(P, dtype=np.float64)
    if P.shape != (pred.runs, pred.n_states, pred.n_states):
        raise InputDataError("P", f"must be (R, n, n) = {(pred.runs, pred.n_states, pred.n_states)}, got {P.shape}")
    z_hat, R = pred.z_hat.copy(), pred.R.copy()
    for r in range(pred.runs):  # per run: the same arithmetic as a single run alone
        dz, C = second_order_terms(pred.hessians[r], P[r])
        z_hat[r] += dz
        R[r] += C
    return pred.replace(z_hat=z_hat, R=R)


def batched_terms(hessians, P):
    """(dz (R, m), C (R, m, m)) for a batch: hessians (R, m, n, n), P (R, n, n); the same terms as
    :func:`second_order_terms`, vectorised (rounding differs from the loop). Only the states where some Hessian of
    the batch is non-zero enter: tr(A P) and tr(A P A P) need no other block of P (for the measurement models, whose
    Hessians have a fixed pattern, a row's result does not depend on the other rows)."""
    A = np.asarray(hessians, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    if A.ndim != 4 or P.shape != (A.shape[0],) + A.shape[2:] or A.shape[2] != A.shape[3]:
        raise InputDataError("hessians", f"need hessians (R, m, n, n) and P (R, n, n), got {A.shape}, {P.shape}")
    nz = np.any(A, axis=(0, 1))
    on = np.flatnonzero(nz.any(axis=0) | nz.any(axis=1))
    A, P = A[:, :, on][:, :, :, on], P[:, on][:, :, on]
    AP = A @ P[:, None]
    return 0.5 * np.einsum("rmii->rm", AP), 0.5 * np.einsum("rmij,rlji->rml", AP, AP)


def with_second_order_batched(pred: Prediction, P) -> Prediction:
    """:func:`with_second_order` through :func:`batched_terms` (for large batches, e.g. mixture components)."""
    if pred.hessians is None:
        raise InputDataError("prediction.hessians", "the second-order terms need the measurement's Hessians")
    dz, C = batched_terms(pred.hessians, P)
    return pred.replace(z_hat=pred.z_hat + dz, R=pred.R + C)

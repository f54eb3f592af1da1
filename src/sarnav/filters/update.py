"""Update strategies: how a :class:`~sarnav.filters.prediction.Prediction` and a measurement change the estimate.

Separate from the measurement models (Stone Soup's updater/model split): a model says what it expects
(``Prediction``), a strategy says how to fuse it. All batched over runs (leading axis R) and never mixing runs.

* :func:`joseph` — Kalman gain, Joseph-form covariance (thesis eqs. 3.20-3.22); the noise must be independent of
  the state error (``prediction.C`` is refused).
* :func:`correlated` — measurement noise correlated with the state error, cov(dx, nu) = C (Brown & Hwang); used
  for delayed-state measurements (``sarnav.filters.delayed``). C = None counts as zero (the form differs from
  Joseph's in rounding only).

Transformations of a prediction before the update live beside: ``sarnav.filters.second_order`` (Gaussian
second-order terms) and ``sarnav.filters.delayed`` (a measurement of the state at an earlier epoch). Lear's
underweighting is ``sarnav.filters.underweighting``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters.ekf import correlated_update, joseph_update, normalized_squared
from sarnav.filters.prediction import Prediction

__all__ = ["Update", "joseph", "correlated", "innovation_covariance"]


@dataclass(frozen=True)
class Update:
    """Result of one update for R runs: ``dx`` (R, n) error-state estimate, ``P`` (R, n, n) posterior covariance,
    ``S`` (R, m, m) innovation covariance, ``residual`` (R, m) z - z_hat."""

    dx: np.ndarray
    P: np.ndarray
    S: np.ndarray
    residual: np.ndarray

    @property
    def residual_sigma(self) -> np.ndarray:
        """(R, m) sqrt(diag S): the 1-sigma of each residual."""
        return np.sqrt(np.einsum("rii->ri", self.S))

    @property
    def nis(self) -> np.ndarray:
        """(R,) normalised innovation squared r^T S^-1 r (chi-square with m dof for a consistent filter)."""
        return normalized_squared(self.residual, self.S)


def _residual(pred: Prediction, z) -> np.ndarray:
    z = np.asarray(z, dtype=np.float64)
    if z.shape != pred.z_hat.shape:
        raise InputDataError("z", f"measurements must have the shape of z_hat {pred.z_hat.shape}, got {z.shape}")
    return z - pred.z_hat


def joseph(P, pred: Prediction, z) -> Update:
    """Joseph-form Kalman update of ``P`` (R, n, n) with measurement ``z`` (R, m)."""
    if pred.C is not None:
        raise InputDataError("prediction.C", "the Joseph update assumes noise independent of the state; "
                             "use filters.update.correlated")
    r = _residual(pred, z)
    dx, P_post, S = joseph_update(P, pred.H, pred.R, r)
    return Update(dx, P_post, S, r)


def correlated(P, pred: Prediction, z) -> Update:
    """Kalman update with cov(dx, nu) = ``pred.C`` (zero when None); see the module docstring."""
    r = _residual(pred, z)
    C = pred.C if pred.C is not None else np.zeros((pred.runs, pred.n_states, pred.dim))
    dx, P_post, S = correlated_update(P, pred.H, pred.R, C, r)
    return Update(dx, P_post, S, r)


def innovation_covariance(P, pred: Prediction) -> np.ndarray:
    """(R, m, m) innovation covariance S = H P H^T + R + H C + C^T H^T of a prediction (C = None: zero), before any
    update: the spread a consistent filter expects of z - z_hat (search windows, innovation gates)."""
    H = pred.H
    Ht = np.swapaxes(H, -1, -2)
    S = H @ np.asarray(P, dtype=np.float64) @ Ht + pred.R
    if pred.C is not None:
        HC = H @ pred.C
        S = S + HC + np.swapaxes(HC, -1, -2)
    return 0.5 * (S + np.swapaxes(S, -1, -2))

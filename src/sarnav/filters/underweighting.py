"""Lear underweighting as an update strategy (Pogorelsky et al. 2022, eqs. 35-37, 42-43; Lear 1985 via ref. [39]).

    S  = (1 + beta) H P H^T + R                      (35)   beta = beta_bar when active, else 0
    K  = P H^T S^-1                                  (36)
    dx = K (y - z_hat)                               (37)
    P+ = (I - K H) P (I - K H)^T + K R' K^T           (42)
    R' = beta H P H^T + R                            (43)   (the printed "beta" read as beta_bar or 0: gap G19)

Here R is the prediction's whole measurement-noise covariance (for the spacecraft measurement it already holds the
geolocation term B = H~ D H~^T of eq. 33). Since S = H P H^T + R', eq. 42 equals P - K H P exactly (claim T5), so the
update is a Joseph update with R' in place of R: the posterior is larger than the plain EKF's whenever beta > 0.

When to underweight (gap G12): :class:`LearUnderweighting` gives beta_bar for the first ``first_updates`` updates
(what the paper ran: TC-1, beta_bar = 0.2, first 10 updates), or whenever sqrt(tr(P_ii)) of a chosen partition
exceeds ``trace_threshold`` (eq. 35's trigger; gamma is never given numerically), or both (either triggers).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters.ekf import joseph_update
from sarnav.filters.prediction import Prediction

__all__ = ["LearUnderweighting", "underweighted_update"]


@dataclass(frozen=True)
class LearUnderweighting:
    """When and how much to underweight.

    beta : beta_bar >= 0 (0 disables). first_updates : underweight updates 0 .. first_updates-1 (None: not by
    index). trace_threshold : gamma of eq. 35 [units of the partition] (None: not by trace). partition : the error
    states whose covariance trace is tested (default: position, indices 0-2).
    """

    beta: float = 0.2
    first_updates: int | None = 10
    trace_threshold: float | None = None
    partition: tuple[int, ...] = (0, 1, 2)

    def __post_init__(self):
        if not (math.isfinite(self.beta) and self.beta >= 0):
            raise ConfigError("mekf.underweight_beta", f"must be finite and >= 0 (0 disables), got {self.beta!r}")
        if self.first_updates is not None and (not isinstance(self.first_updates, int) or self.first_updates < 0):
            raise ConfigError("mekf.underweight_updates", f"must be an integer >= 0, got {self.first_updates!r}")
        if self.trace_threshold is not None and not (math.isfinite(self.trace_threshold) and self.trace_threshold > 0):
            raise ConfigError("mekf.underweight_gamma", f"must be finite and > 0, got {self.trace_threshold!r}")

    def beta_for(self, update_index: int, P) -> np.ndarray:
        """beta (R,) for the update number ``update_index`` (0-based) given the prior P (R, n, n)."""
        P = np.asarray(P, dtype=float)
        active = np.zeros(P.shape[0], dtype=bool)
        if self.first_updates is not None:
            active |= update_index < self.first_updates
        if self.trace_threshold is not None:
            idx = np.asarray(self.partition)
            tr = np.trace(P[:, idx[:, None], idx[None, :]], axis1=1, axis2=2)
            active |= np.sqrt(tr) > self.trace_threshold
        return np.where(active, self.beta, 0.0)


def underweighted_update(P, prediction: Prediction, residual, beta):
    """Eqs. 35-37, 42-43 for R runs: (dx (R, n), P+ (R, n, n), S (R, m, m)) like ``filters.joseph_update``.

    P : (R, n, n) prior; prediction : H (R, m, n), R (R, m, m); residual : (R, m) y - z_hat; beta : scalar or (R,).
    S returned is the underweighted innovation covariance (1 + beta) H P H^T + R used for the gain (and NIS).
    """
    P = np.asarray(P, dtype=float)
    beta = np.broadcast_to(np.asarray(beta, dtype=float), (P.shape[0],))
    if not np.all(np.isfinite(beta)) or np.any(beta < 0):
        raise ConfigError("mekf.underweight_beta", f"must be finite and >= 0, got {np.unique(beta).tolist()}")
    H = prediction.H
    HPHt = H @ P @ np.swapaxes(H, -1, -2)
    R_prime = beta[:, None, None] * HPHt + prediction.R  # eq. 43
    return joseph_update(P, H, R_prime, residual)  # S = H P H^T + R' = eq. 35; P+ = eq. 42

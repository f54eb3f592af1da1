"""Update strategies: how a :class:`~sarnav.filters.prediction.Prediction` and a measurement change the estimate.

Separate from the measurement models (Stone Soup's updater/model split): a model says what it expects
(``Prediction``), a strategy says how to fuse it. All batched over runs (leading axis R) and never mixing runs.

* :func:`joseph` — Kalman gain, Joseph-form covariance (thesis eqs. 3.20-3.22); the noise must be independent of
  the state error (``prediction.C`` is refused).
* :func:`fuse` — the one update every filter calls: Joseph or correlated by the prediction, components left out
  (``keep``), Lear's underweighting (``beta``); returns :class:`Fused` (the NIS over the components present).
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
from sarnav.filters.underweighting import underweighted_update

__all__ = ["Update", "Fused", "fuse", "joseph", "correlated", "innovation_covariance", "chi2_gate", "present_nis"]


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
    """S = H P H^T + R + H C + C^T H^T (R, m, m): the covariance of the residual before the update."""
    Ht = np.swapaxes(pred.H, -1, -2)
    S = pred.H @ P @ Ht + pred.R
    if pred.C is not None:
        S = S + pred.H @ pred.C + np.swapaxes(pred.H @ pred.C, -1, -2)
    return 0.5 * (S + np.swapaxes(S, -1, -2))


def chi2_gate(P, pred: Prediction, z, groups, probability: float):
    """Innovation gate: for each run and each group of components (lists of indices), the NIS of the group under its
    own block of S; the group is rejected when it exceeds the chi-square quantile of 1 - ``probability`` (its dof =
    the group size). ``probability`` is the rate at which a consistent filter rejects good measurements; 0 gates
    nothing. Returns (NIS (R, G), accepted (R, G) bool)."""
    from scipy.stats import chi2

    S = innovation_covariance(P, pred)
    r = np.asarray(z, dtype=np.float64) - pred.z_hat
    nis = np.empty((pred.runs, len(groups)))
    for g, idx in enumerate(groups):
        idx = list(idx)
        sub = S[:, idx][:, :, idx]
        rg = r[:, idx]
        finite = np.all(np.isfinite(rg), axis=1)
        nis[:, g] = np.where(finite, normalized_squared(np.where(finite[:, None], rg, 0.0), sub), np.inf)
    if not probability > 0:
        return nis, np.isfinite(nis)
    limits = np.array([chi2.isf(probability, len(idx)) for idx in groups])
    return nis, nis <= limits


def present_nis(residual, S, present) -> tuple[np.ndarray, np.ndarray]:
    """(NIS over the components present (R,), their count (R,)): r_p^T S_pp^-1 r_p per run."""
    runs = residual.shape[0]
    nis, dof = np.zeros(runs), np.asarray(present, dtype=bool).sum(axis=1)
    for i in range(runs):
        idx = np.flatnonzero(present[i])
        if idx.size:
            nis[i] = float(residual[i, idx] @ np.linalg.solve(S[i][np.ix_(idx, idx)], residual[i, idx]))
    return nis, dof


@dataclass(frozen=True)
class Fused:
    """One event's update for R runs: the strategy's :class:`~sarnav.filters.Update`, the components that
    took part (``keep`` (R, m)), the NIS over them (``nis`` (R,)) and their count (``dof`` (R,))."""

    update: Update
    keep: np.ndarray
    nis: np.ndarray
    dof: np.ndarray

    @property
    def residual(self) -> np.ndarray:
        """(R, m) z - z_hat of the components present, NaN elsewhere."""
        return np.where(self.keep, self.update.residual, np.nan)

    @property
    def residual_sigma(self) -> np.ndarray:
        """(R, m) sqrt(diag S) of the components present, NaN elsewhere."""
        return np.where(self.keep, self.update.residual_sigma, np.nan)


def fuse(P, pred: Prediction, z, keep=None, beta=None) -> Fused:
    """The one Kalman update of every filter over a covariance ``P`` (R, n, n) (the navigator, the MEKF, the
    pulse-grid KF): ``z`` (R, m) predicted by
    ``pred``; the components where ``keep`` (R, m) is False take no part (``Prediction.masked``, their z replaced by
    z_hat) and the NIS counts the rest. Joseph form when ``pred.C`` is None, else the correlated form
    (above); ``beta`` (R,) Lear's underweighting (``filters.underweighting``, spacecraft paper eqs. 35-43:
    Joseph form with R' = beta H P H^T + R, uncorrelated noise only). The caller applies the correction (the INS
    feedback of ``navigation.Navigator``, the MEKF reset)."""
    if beta is not None:
        if pred.C is not None or keep is not None:
            raise InputDataError("beta", "underweighting applies to uncorrelated, unmasked updates only")
        r = np.asarray(z, dtype=np.float64) - pred.z_hat
        up = Update(*underweighted_update(P, pred, r, beta), r)
        return Fused(up, np.ones(r.shape, dtype=bool), up.nis, np.full(pred.runs, pred.dim, dtype=np.int64))
    if keep is None or np.all(keep):
        keep = np.ones(pred.z_hat.shape, dtype=bool)
        up = joseph(P, pred, z) if pred.C is None else correlated(P, pred, z)
        nis, dof = up.nis, np.full(pred.runs, pred.dim, dtype=np.int64)
    else:
        keep = np.asarray(keep, dtype=bool)
        zz, masked = np.where(keep, z, pred.z_hat), pred.masked(keep)
        up = joseph(P, masked, zz) if pred.C is None else correlated(P, masked, zz)
        nis, dof = present_nis(up.residual, up.S, keep)
    return Fused(up, keep, nis, dof)

"""What a measurement model predicts for a batch of runs: the one object every update strategy consumes.

A measurement (``sarnav.measurements``) turns the filter's estimate into a :class:`Prediction`; update strategies
(``sarnav.filters.update``) and transformations of a prediction (the delayed-state mapping of
``sarnav.filters.delayed``, the Gaussian second-order terms of ``sarnav.filters.second_order``) take it and
return a new one. Nothing here knows what is measured.

Shapes, with R runs, m measurement components and n error states (``dx = truth - estimate``):

========== =============== ==================================================================================
z_hat      (R, m)          expected measurement
H          (R, m, n)       d z / d(dx)
R          (R, m, m)       measurement-noise covariance
C          (R, n, m)       cov(dx, noise) when the noise is correlated with the state error (None: zero)
hessians   (R, m, n, n)    d^2 z / d(dx)^2 of each component (None: not provided / linear)
names      (m,)            component names, e.g. ("alt", "range", "cross")
========== =============== ==================================================================================
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from sarnav.errors import InputDataError

__all__ = ["Prediction", "stack_predictions"]


@dataclass(frozen=True)
class Prediction:
    """Expected measurement, Jacobian and noise of m components for R runs (module docstring)."""

    z_hat: np.ndarray
    H: np.ndarray
    R: np.ndarray
    C: np.ndarray | None = None
    hessians: np.ndarray | None = None
    names: tuple[str, ...] = ()

    def __post_init__(self):
        z, H, R = (np.asarray(a, dtype=np.float64) for a in (self.z_hat, self.H, self.R))
        if z.ndim != 2 or H.ndim != 3 or H.shape[:2] != z.shape or R.shape != z.shape + z.shape[-1:]:
            raise InputDataError("prediction", f"need z_hat (R, m), H (R, m, n), R (R, m, m); got {z.shape}, "
                                 f"{H.shape}, {R.shape}")
        runs, m, n = H.shape
        object.__setattr__(self, "z_hat", z)
        object.__setattr__(self, "H", H)
        object.__setattr__(self, "R", R)
        if self.C is not None:
            C = np.asarray(self.C, dtype=np.float64)
            if C.shape != (runs, n, m):
                raise InputDataError("prediction.C", f"must be (R, n, m) = {(runs, n, m)}, got {C.shape}")
            object.__setattr__(self, "C", C)
        if self.hessians is not None:
            A = np.asarray(self.hessians, dtype=np.float64)
            if A.shape != (runs, m, n, n):
                raise InputDataError("prediction.hessians", f"must be (R, m, n, n) = {(runs, m, n, n)}, got {A.shape}")
            object.__setattr__(self, "hessians", A)
        names = tuple(self.names)
        if names and len(names) != m:
            raise InputDataError("prediction.names", f"need {m} names, got {names}")
        object.__setattr__(self, "names", names)

    @property
    def runs(self) -> int:
        return self.H.shape[0]

    @property
    def dim(self) -> int:
        return self.H.shape[1]

    @property
    def n_states(self) -> int:
        return self.H.shape[2]

    def replace(self, **changes) -> "Prediction":
        return replace(self, **changes)

    def masked(self, keep) -> "Prediction":
        """The prediction with the components where ``keep`` (R, m) is False taken out of the update: their H rows,
        C columns and Hessians are zero and their noise is decoupled (unit variance, no correlation), so a Kalman
        update with them changes nothing (its gain columns are zero) while the shapes stay batched."""
        keep = np.asarray(keep, dtype=bool)
        if keep.shape != self.z_hat.shape:
            raise InputDataError("keep", f"must be (R, m) = {self.z_hat.shape}, got {keep.shape}")
        drop = ~keep
        H = np.where(drop[:, :, None], 0.0, self.H)
        pair = keep[:, :, None] & keep[:, None, :]
        R = np.where(pair, self.R, 0.0)
        idx = np.arange(self.dim)
        R[:, idx, idx] = np.where(drop, 1.0, R[:, idx, idx])
        C = None if self.C is None else np.where(drop[:, None, :], 0.0, self.C)
        A = None if self.hessians is None else np.where(drop[:, :, None, None], 0.0, self.hessians)
        return self.replace(H=H, R=R, C=C, hessians=A)


def stack_predictions(parts: Sequence[Prediction]) -> Prediction:
    """One prediction of all components of ``parts`` (block-diagonal R; C and Hessians where any part has them)."""
    if not parts:
        raise InputDataError("predictions", "need at least one prediction to stack")
    runs, n = parts[0].runs, parts[0].n_states
    for p in parts:
        if p.runs != runs or p.n_states != n:
            raise InputDataError("predictions", f"runs/states differ: {(p.runs, p.n_states)} vs {(runs, n)}")
    z = np.concatenate([p.z_hat for p in parts], axis=1)
    H = np.concatenate([p.H for p in parts], axis=1)
    m = z.shape[1]
    R = np.zeros((runs, m, m))
    C = np.zeros((runs, n, m)) if any(p.C is not None for p in parts) else None
    A = np.zeros((runs, m, n, n)) if any(p.hessians is not None for p in parts) else None
    i = 0
    for p in parts:
        k = p.dim
        R[:, i:i + k, i:i + k] = p.R
        if C is not None and p.C is not None:
            C[:, :, i:i + k] = p.C
        if A is not None and p.hessians is not None:
            A[:, i:i + k] = p.hessians
        i += k
    names = sum((p.names or ("",) * p.dim for p in parts), ())
    return Prediction(z, H, R, C, A, names if any(names) else ())

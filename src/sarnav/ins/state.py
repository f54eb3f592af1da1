"""The navigation (estimated) state, batched over runs (thesis eq. 3.2 / 5.10)."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np


@dataclass
class NavState:
    """Whole-state estimate (or truth) for R runs.

    Attributes
    ----------
    p : (R, 3) position p^n [m]; v : (R, 3) velocity v^n [m/s];
    q : (R, 4) attitude q_b^n (Hamilton, scalar first);
    ba : (R, 3) accelerometer bias [m/s^2]; bg : (R, 3) gyro bias [rad/s];
    bm : (R, K) scalar measurement biases, in the order of the filter layout's ``scalar_biases``.
    """

    p: np.ndarray
    v: np.ndarray
    q: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    bm: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def copy(self) -> "NavState":
        return replace(self, **{k: np.array(getattr(self, k), dtype=float) for k in ("p", "v", "q", "ba", "bg", "bm")})

    @property
    def runs(self) -> int:
        return self.p.shape[0]

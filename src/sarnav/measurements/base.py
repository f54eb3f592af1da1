"""The measurement contract: ``predict(nav) -> (z_hat, H, R)`` and ``simulate(truth, bias, rngs)``.

A measurement object knows its model (thesis eq. 3.13-3.17 for telemetry), where its bias state
sits in the filter's :class:`~sarnav.filters.layout.ErrorStateLayout`, and its noise. Everything is
batched over runs: ``nav`` and ``truth`` are :class:`~sarnav.ins.state.NavState` with R runs,
``z_hat`` is (R, m), ``H`` (R, m, n) (rows d z / d(dx), dx = truth - estimate), ``R`` (R, m, m).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Sequence

import numpy as np

from sarnav.errors import require_positive
from sarnav.filters.layout import ErrorStateLayout
from sarnav.ins.state import NavState


class Measurement(ABC):
    """A scalar measurement with additive FOGM bias and white Gaussian noise.

    Parameters
    ----------
    sigma : 1-sigma white noise [measurement unit], > 0.
    layout : error-state layout (for H's columns).
    bias : name of the bias state in ``layout.scalar_biases``.
    """

    name: str = ""
    dim: int = 1

    def __init__(self, sigma: float, layout: ErrorStateLayout, bias: str):
        self.sigma = require_positive(f"measurements.{self.name}.sigma", sigma)
        self.layout = layout
        self.bias = bias
        self.bias_index = layout.index(bias)
        self.bias_column = layout.scalar_biases.index(bias)

    @abstractmethod
    def model(self, p, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise- and bias-free value h(p, v) (R,) and its gradients dh/dp, dh/dv (R, 3)."""

    def predict(self, nav: NavState):
        """(z_hat, H, R): the expected measurement from the estimate, its Jacobian and noise."""
        h, dp, dv = self.model(nav.p, nav.v)
        runs = nav.p.shape[0]
        z_hat = (h + nav.bm[:, self.bias_column])[:, None]
        H = np.zeros((runs, 1, self.layout.n))
        H[:, 0, self.layout.slice("p")] = dp
        H[:, 0, self.layout.slice("v")] = dv
        H[:, 0, self.bias_index] = 1.0
        R = np.full((runs, 1, 1), self.sigma**2)
        return z_hat, H, R

    def simulate(self, truth: NavState, truth_bias, rngs: Sequence[np.random.Generator]):
        """z = h(truth) + bias + sigma N(0, 1), one draw from each run's generator; (R, 1)."""
        h, _, _ = self.model(truth.p, truth.v)
        noise = np.array([g.standard_normal() for g in rngs])
        return (h + np.asarray(truth_bias, dtype=float) + self.sigma * noise)[:, None]


def stack_predictions(measurements: Sequence[Measurement], nav: NavState):
    """Stack several measurements into one (z_hat (R, M), H (R, M, n), block-diagonal R (R, M, M))."""
    parts = [m.predict(nav) for m in measurements]
    z = np.concatenate([p[0] for p in parts], axis=1)
    H = np.concatenate([p[1] for p in parts], axis=1)
    M = z.shape[1]
    R = np.zeros((z.shape[0], M, M))
    i = 0
    for _, _, r in parts:
        k = r.shape[-1]
        R[:, i:i + k, i:i + k] = r
        i += k
    return z, H, R

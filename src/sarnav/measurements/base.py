"""The one measurement contract (docs/architecture.md §Contracts), batched over runs.

A measurement model knows what it measures, where its bias state sits in the filter's error state, and its
noise. It has two faces:

* ``predict(nav) -> Prediction``: what the filter expects from its estimate ``nav`` (z_hat (R, m), H (R, m, n)
  w.r.t. dx = truth - estimate, R (R, m, m), and the Hessians (R, m, n, n) for second-order strategies);
* ``simulate(truth, rngs=None, noise=None) -> (R, m)``: the measurement a perfect sensor with this model's noise
  would give at the true state ``truth`` (the bias states read from ``truth.bm``). This is how sensors are
  simulated, and it is the only place truth becomes a measurement: image-derived measurements come from
  ``sarnav.measurements.sar_image``, and kinds use ``simulate`` for SAR only in the mode named ``oracle``.

The contract is generalised to the spacecraft's orbital state (``ins.orbital.OrbitalNavState``: r, v, q_mu; the
MEKF's 9 error states of ``filters.mekf``): ``measurements.spacecraft.CenterPixelMeasurement`` derives from
:class:`Measurement` with ``layout = None`` and ``n_states = 9``, predicts from an ``OrbitalNavState`` (H w.r.t. the
MEKF's dx = truth - estimate, no Hessians: ``has_hessians = False``), and its geolocation noise sits in the r_f it is
built on (R + B of eq. 33), so its simulation is ``measurements.spacecraft.simulate_image``.

``noise``, when given, are the unit normals to use (R, m) — for kinds whose draw order is fixed elsewhere;
otherwise each run's Generator in ``rngs`` draws them. Update strategies (Joseph, correlated noise, second
order, delayed state, underweighting) are in ``sarnav.filters`` and never in a model.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Sequence

import numpy as np

from sarnav.errors import InputDataError, require_positive
from sarnav.filters.layout import ErrorStateLayout
from sarnav.filters.prediction import Prediction
from sarnav.ins.state import NavState

__all__ = ["Measurement", "ScalarBiasedMeasurement", "unit_noise"]


def unit_noise(runs: int, m: int, rngs=None, noise=None) -> np.ndarray:
    """(R, m) unit normals: ``noise`` as given (checked), or m draws from each run's Generator."""
    if noise is not None:
        noise = np.asarray(noise, dtype=np.float64)
        if noise.shape != (runs, m) or not np.all(np.isfinite(noise)):
            raise InputDataError("noise", f"must be finite unit normals of shape {(runs, m)}, got {noise.shape}")
        return noise
    if rngs is None or len(rngs) != runs:
        raise InputDataError("rngs", f"need one Generator per run ({runs}) or the noise itself")
    if m == 1:
        return np.array([g.standard_normal() for g in rngs])[:, None]
    return np.stack([g.standard_normal(m) for g in rngs])


class Measurement(ABC):
    """A measurement model of ``dim`` components (module docstring).

    Attributes
    ----------
    names, units : component names (the ``meas`` coordinate of results) and their units.
    layout : the filter's error-state layout (H's columns).
    """

    names: tuple[str, ...] = ()
    units: tuple[str, ...] = ()
    layout: ErrorStateLayout
    #: whether ``predict`` provides Hessians (second-order strategies need them)
    has_hessians: bool = True

    @property
    def dim(self) -> int:
        return len(self.names)

    @abstractmethod
    def predict(self, nav: NavState) -> Prediction:
        """Expected measurement, Jacobian, noise (and Hessians) from the estimate ``nav`` (R runs)."""

    @abstractmethod
    def simulate(self, truth: NavState, rngs: Sequence[np.random.Generator] | None = None, noise=None) -> np.ndarray:
        """(R, dim) measurement of the true state: model + truth bias + sigma x unit normals."""


class ScalarBiasedMeasurement(Measurement):
    """A scalar h(p, v) plus a first-order Gauss-Markov bias state plus white noise (thesis eqs. 3.13-3.17).

    Subclasses give ``model(p, v) -> (h (R,), dh/dp (R, 3), dh/dv (R, 3))`` and ``hessian_blocks(p, v) ->
    (d2h/dp2, d2h/dpdv, d2h/dv2)``, each (R, 3, 3).

    Parameters
    ----------
    sigma : 1-sigma white noise [measurement unit], > 0.
    layout : error-state layout; ``bias`` : name of the bias state in ``layout.scalar_biases``.
    """

    unit: str = ""

    def __init__(self, sigma: float, layout: ErrorStateLayout, bias: str):
        self.sigma = require_positive(f"measurements.{self.names[0]}.sigma", sigma)
        self.layout = layout
        self.bias = bias
        self.bias_index = layout.index(bias)
        self.bias_column = layout.scalar_biases.index(bias)

    @abstractmethod
    def model(self, p, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Noise- and bias-free value h(p, v) (R,) and its gradients dh/dp, dh/dv (R, 3)."""

    @abstractmethod
    def hessian_blocks(self, p, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """d2h/dp2, d2h/dp dv, d2h/dv2 at (p, v), each (R, 3, 3)."""

    def hessians(self, nav: NavState) -> np.ndarray:
        """(R, 1, n, n) Hessian of h w.r.t. the error state (the bias enters linearly)."""
        pp, pv, vv = self.hessian_blocks(nav.p, nav.v)
        L = self.layout
        A = np.zeros((nav.p.shape[0], 1, L.n, L.n))
        p, v = L.slice("p"), L.slice("v")
        A[:, 0, p, p] = pp
        A[:, 0, p, v] = pv
        A[:, 0, v, p] = np.swapaxes(pv, -1, -2)
        A[:, 0, v, v] = vv
        return A

    def predict(self, nav: NavState) -> Prediction:
        h, dp, dv = self.model(nav.p, nav.v)
        runs = nav.p.shape[0]
        z_hat = (h + nav.bm[:, self.bias_column])[:, None]
        H = np.zeros((runs, 1, self.layout.n))
        H[:, 0, self.layout.slice("p")] = dp
        H[:, 0, self.layout.slice("v")] = dv
        H[:, 0, self.bias_index] = 1.0
        R = np.full((runs, 1, 1), self.sigma**2)
        return Prediction(z_hat, H, R, hessians=self.hessians(nav), names=self.names)

    def simulate(self, truth: NavState, rngs=None, noise=None) -> np.ndarray:
        h, _, _ = self.model(truth.p, truth.v)
        n = unit_noise(truth.p.shape[0], 1, rngs, noise)[:, 0]
        return (h + np.asarray(truth.bm[:, self.bias_column], dtype=float) + self.sigma * n)[:, None]

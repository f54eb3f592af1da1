"""A GNSS fix: position (and optionally velocity) in the navigation frame, with the receiver's stated 1-sigma.

z = [p + n_p] or [p + n_p, v + n_v] (NED, m and m/s), linear in the error state: H has identity blocks on the
position (and velocity) error states (dx = truth - estimate). The fix is of the point the INS navigates (the IMU;
a GNSS antenna lever arm is not modelled). The noise is white with the per-axis 1-sigma the fix states (a real
receiver's errors are correlated over seconds: a recording's GNSS aiding is meant for the first seconds of a flight,
before it is GPS-denied, docs/navigate.md).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from sarnav.errors import InputDataError
from sarnav.filters.layout import ErrorStateLayout
from sarnav.filters.prediction import Prediction
from sarnav.ins.state import NavState
from sarnav.measurements.base import Measurement, unit_noise

__all__ = ["GnssFix"]

_AXES = ("north", "east", "down")


class GnssFix(Measurement):
    """A GNSS position fix with 1-sigma ``position_sigma`` (3,) [m], and a velocity with ``velocity_sigma`` (3,)
    [m/s] when given (module docstring)."""

    def __init__(self, layout: ErrorStateLayout, position_sigma, velocity_sigma=None):
        sig = [np.asarray(position_sigma, dtype=np.float64)]
        if velocity_sigma is not None:
            sig.append(np.asarray(velocity_sigma, dtype=np.float64))
        self.sigma = np.concatenate(sig)
        if self.sigma.shape != (3 * len(sig),) or not np.all(np.isfinite(self.sigma) & (self.sigma > 0)):
            raise InputDataError("gnss.sigma", f"must be finite and > 0 per axis, got {self.sigma.tolist()}")
        self.layout = layout
        self.velocity = velocity_sigma is not None
        self.names = tuple(f"gnss_{a}" for a in _AXES) + (tuple(f"gnss_v_{a}" for a in _AXES) if self.velocity else ())
        self.units = ("m",) * 3 + (("m/s",) * 3 if self.velocity else ())

    def _value(self, nav: NavState) -> np.ndarray:
        return np.concatenate([nav.p, nav.v], axis=1) if self.velocity else np.array(nav.p, dtype=np.float64)

    def predict(self, nav: NavState) -> Prediction:
        runs, m, L = nav.p.shape[0], self.dim, self.layout
        H = np.zeros((runs, m, L.n))
        H[:, 0:3, L.slice("p")] = np.eye(3)
        if self.velocity:
            H[:, 3:6, L.slice("v")] = np.eye(3)
        R = np.broadcast_to(np.diag(self.sigma**2), (runs, m, m)).copy()
        return Prediction(self._value(nav), H, R, hessians=np.zeros((runs, m, L.n, L.n)), names=self.names)

    def simulate(self, truth: NavState, rngs: Sequence[np.random.Generator] | None = None, noise=None) -> np.ndarray:
        runs = truth.p.shape[0]
        return self._value(truth) + self.sigma[None] * unit_noise(runs, self.dim, rngs, noise)

"""The navigator: the filter's INS + covariance between measurement events, the events fused through the one
``Prediction`` contract and the update strategies of ``sarnav.filters``. It never sees truth; the simulated world
(``sarnav.simulation``) or a recorded flight is its source of IMU samples and events."""

from sarnav.navigation.navigator import COVARIANCE_ATTITUDES, Fused, Interval, Navigator, error_model, fuse

__all__ = ["Navigator", "Interval", "Fused", "fuse", "error_model", "COVARIANCE_ATTITUDES"]

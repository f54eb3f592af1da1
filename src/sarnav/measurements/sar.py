"""SAR image-shift measurements: slant range and cross-range of a geolocated reference target.

Design (docs/scenarios/rda-nav.md §2; NAVIGATION paper eqs. 47-49, 51-52, 54-56; thesis §5.2 with the bias columns
the thesis omits, extraction seed-000 §5.2 errata). Both refer to the vehicle state at the target's time of
closest approach (TOC) eta0: ``predict`` takes the estimate *at the TOC* (positions and velocities interpolated
from the INS history, the bias estimates of the update epoch); the delayed-state mapping to the update epoch is
``sarnav.filters.delayed``, the second-order terms ``sarnav.filters.second_order``.

* range, eq. 47: ``h_r = ||p_targ - p(eta0)|| + b_r``, H_r = [-d^T/||d||, 0, ..., 1 at b_range],
  Hessian (I - d d^T/|d|^2)/|d| in the position block;
* cross-range, two models:

  - ``"zero-doppler"`` (default, the one an image realises): at the TOC of a zero-squint stop-and-hop SAR the line
    of sight is orthogonal to the velocity, so the truth value of ``u^T (p(eta0) - p_targ)`` with ``u = v/||v||``
    is 0. Model ``h_c = u^T (p - p_targ) + b_c``: position row u^T *and* velocity row
    ``(p - p_targ)^T (I - u u^T)/||v||`` (the SAR azimuth-geolocation lever, thesis §4.3.2); with l = p - p_targ,
    s = |v|: d2h/dp dv = (I - u u^T)/s, d2h/dv2 = -(l u^T + u l^T)/s^2 - (u^T l)(I - 3 u u^T)/s^2. The lever is
    divided by the *estimated* speed, so an along-track speed error scales it: the second-order terms matter;
  - ``"paper"``: eq. 48 with u_c and r_orig constants per run, ``h_c = u_c^T (p - r_orig) + b_c``, H_c of eq. 56
    (eq. 49 computes u_c from the *estimated* positions; paper L1185-1192).

The arithmetic is per run (a run's numbers never depend on the batch).
"""

from __future__ import annotations

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.layout import ErrorStateLayout
from sarnav.filters.prediction import Prediction
from sarnav.ins.state import NavState
from sarnav.measurements.base import Measurement, unit_noise

__all__ = ["CROSS_RANGE_MODELS", "SarRangeMeasurement", "SarCrossRangeMeasurement", "target_position_noise"]

CROSS_RANGE_MODELS = ("zero-doppler", "paper")


def _vec3(name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputDataError(name, f"must be a finite 3-vector (NED, m), got shape {a.shape}")
    return a


def _sigma(field: str, sigma):
    """A 1-sigma [m]: one number for every run, or one per run (R,) (e.g. predicted from each image)."""
    a = np.asarray(sigma, dtype=np.float64)
    if a.ndim > 1 or not (np.all(np.isfinite(a)) and np.all(a > 0)):
        raise ConfigError(field, f"must be finite and > 0 m (a number or one per run), got {sigma!r}")
    return float(a) if a.ndim == 0 else a


class _SarMeasurement(Measurement):
    units = ("m",)

    def __init__(self, target, sigma: float, layout: ErrorStateLayout, bias: str, sigma_field: str):
        t = np.asarray(target, dtype=np.float64)
        self.target = _vec3("p_targ", t) if t.ndim == 1 else np.stack([_vec3("p_targ", row) for row in t])
        self.sigma = _sigma(sigma_field, sigma)
        self.layout = layout
        self.bias_index = layout.index(bias)
        self.bias_column = layout.scalar_biases.index(bias)

    def _one(self, r: int, p, v, b):
        """(z_hat, H row (n,), Hessian (n, n)) of run r at the TOC."""
        raise NotImplementedError

    def value(self, r: int, p, v, b=0.0) -> float:
        """Noise-free h(x) of run r at the TOC (eqs. 47-48 without noise)."""
        raise NotImplementedError

    def _target(self, r: int) -> np.ndarray:
        """The target of run r: one for every run (3,), or one per run (R, 3) (e.g. a map with its own error)."""
        return self.target if self.target.ndim == 1 else self.target[r]

    def _sigmas(self, runs: int) -> np.ndarray:
        s = np.broadcast_to(np.asarray(self.sigma, dtype=np.float64), (runs,))
        return s

    def predict(self, nav: NavState) -> Prediction:
        """From the estimate at the TOC (p, v (R, 3); bias estimates ``nav.bm``)."""
        runs, n = nav.p.shape[0], self.layout.n
        z, H, A = np.empty((runs, 1)), np.zeros((runs, 1, n)), np.zeros((runs, 1, n, n))
        for r in range(runs):
            z[r, 0], H[r, 0], A[r, 0] = self._one(r, _vec3("p_hat", nav.p[r]), nav.v[r], nav.bm[r, self.bias_column])
        R = (self._sigmas(runs) ** 2)[:, None, None] if np.ndim(self.sigma) else np.full((runs, 1, 1), self.sigma**2)
        return Prediction(z, H, R, hessians=A, names=self.names)

    def simulate(self, truth: NavState, rngs=None, noise=None) -> np.ndarray:
        """h(truth at the TOC) + truth bias + sigma N(0, 1): the ``oracle`` mode's measurement."""
        runs = truth.p.shape[0]
        n = unit_noise(runs, 1, rngs, noise)[:, 0]
        sig = self._sigmas(runs)
        return np.array([self.value(r, truth.p[r], truth.v[r], truth.bm[r, self.bias_column]) + sig[r] * n[r]
                         for r in range(runs)])[:, None]


class SarRangeMeasurement(_SarMeasurement):
    """Slant range of closest approach to a known target (paper eqs. 47, 51, 55); ``target`` (3,) or one per run
    (R, 3), NED [m]."""

    names = ("range",)

    def __init__(self, target, sigma: float, layout: ErrorStateLayout, bias: str = "b_range"):
        super().__init__(target, sigma, layout, bias, "sar.range_sigma")

    def value(self, r, p, v=None, b=0.0) -> float:
        return float(np.linalg.norm(self._target(r) - np.asarray(p, dtype=np.float64)) + b)

    def _one(self, r, p_hat, v_hat, b_hat):
        d = self._target(r) - p_hat
        rng = np.linalg.norm(d)
        if rng <= 0:
            raise InputDataError("p_hat", "coincides with the target; range Jacobian undefined")
        n, L = self.layout.n, self.layout
        H = np.zeros(n)
        H[L.slice("p")] = -d / rng
        H[self.bias_index] = 1.0
        A = np.zeros((n, n))
        A[L.slice("p"), L.slice("p")] = (np.eye(3) - np.outer(d, d) / rng**2) / rng
        return rng + b_hat, H, A


class SarCrossRangeMeasurement(_SarMeasurement):
    """Along-track (cross-range) position of the vehicle at the target's TOC (paper eqs. 48-49, 52, 56).

    Parameters
    ----------
    target : (3,) or (R, 3) the reference target (NED, m); the cross-range origin of the zero-Doppler model.
    sigma : 1-sigma noise [m]; layout, bias : error-state layout and the b_cross state.
    model : ``"zero-doppler"`` (default) or ``"paper"``.
    u_c, r_orig : ``"paper"`` only: (R, 3) along-track direction and origin per run, constants of the update.
    focus_sensitivity : zero-Doppler only, optional (R,): d(along-track registration [m]) / d(focusing speed [m/s])
        [s] of an image focused with the *estimated* speed (measured by refocusing,
        ``measurements.sar_image.SubApertureImager``). A focusing FM rate off by 2 dv/V (dv = truth - estimate of the
        speed along the track) moves a target whose TOC is off the aperture centre (about 2 (eta0 - eta_c) dv in
        metres for a strong azimuth chirp, less for the weak chirps of short apertures), so the measured TOC is late
        by -sensitivity u^T dv / V and the cross-range residual gets +sensitivity u^T dv: a velocity column of H
        (docs/scenarios/rda-nav.md §2).
    """

    names = ("cross",)

    def __init__(self, target, sigma: float, layout: ErrorStateLayout, bias: str = "b_cross",
                 model: str = "zero-doppler", u_c=None, r_orig=None, focus_sensitivity=None, focus_offset=None):
        super().__init__(target, sigma, layout, bias, "sar.cross_sigma")
        self.focus_sensitivity = None if focus_sensitivity is None else np.asarray(focus_sensitivity, dtype=np.float64)
        self.focus_offset = None if focus_offset is None else np.asarray(focus_offset, dtype=np.float64)
        if model not in CROSS_RANGE_MODELS:
            raise ConfigError("sar.cross_range_model", f"must be one of {CROSS_RANGE_MODELS}, got {model!r}")
        self.model = model
        if model == "paper":
            if u_c is None or r_orig is None:
                raise ConfigError("sar.cross_range_model", "'paper' needs u_c and r_orig")
            u = np.atleast_2d(np.asarray(u_c, dtype=np.float64))
            nrm = np.linalg.norm(u, axis=1, keepdims=True)
            if u.shape[1] != 3 or not np.all(np.isfinite(u)) or np.any(nrm == 0):
                raise InputDataError("u_c", "must be finite non-zero 3-vectors, one per run")
            self.u_c = np.stack([_vec3("u_c", row) / np.linalg.norm(row) for row in u])
            self.r_orig = np.stack([_vec3("r_orig", row) for row in np.atleast_2d(r_orig)])

    def value(self, r, p, v=None, b=0.0) -> float:
        p = np.asarray(p, dtype=np.float64)
        if self.model == "paper":
            return float(self.u_c[r] @ (p - self.r_orig[r]) + b)
        v = _vec3("v", v)
        return float(v @ (p - self._target(r)) / np.linalg.norm(v) + b)

    def _one(self, r, p_hat, v_hat, b_hat):
        L, n = self.layout, self.layout.n
        ip, iv = L.slice("p"), L.slice("v")
        H, A = np.zeros(n), np.zeros((n, n))
        if self.model == "paper":
            z = self.u_c[r] @ (p_hat - self.r_orig[r])
            H[ip] = self.u_c[r]  # eq. 56
        else:
            v_hat = _vec3("v_hat", v_hat)
            speed = np.linalg.norm(v_hat)
            if speed <= 0:
                raise InputDataError("v_hat", "speed must be > 0 for the zero-Doppler cross-range model")
            u = v_hat / speed
            los = p_hat - self._target(r)
            z = u @ los
            H[ip] = u
            H[iv] = (los - u * (u @ los)) / speed
            if self.focus_sensitivity is not None:
                H[iv] += self.focus_sensitivity[r] * u
            if self.focus_offset is not None:
                z = z - self.focus_offset[r]
            ul = u @ los
            A[ip, iv] = (np.eye(3) - np.outer(u, u)) / speed
            A[iv, ip] = A[ip, iv].T
            A[iv, iv] = -(np.outer(los, u) + np.outer(u, los)) / speed**2 - ul * (np.eye(3) - 3 * np.outer(u, u)) / speed**2
        H[self.bias_index] = 1.0
        return z + b_hat, H, A


def target_position_noise(pred: Prediction, layout: ErrorStateLayout, D, rows) -> Prediction:
    """``pred`` with the reference target's geolocation error added to its noise: ``R += J D J^T`` on ``rows`` (the
    components that refer to one target: its range and cross-range), with ``J = -H_p`` their Jacobian with respect to
    the target position (both models depend on p - p_targ only) and ``D`` (3, 3) the covariance of the map's
    geolocation of the target [m^2] (the spacecraft paper's B = H D H^T, Pogorelsky et al. eq. 31). The error is
    the map's, independent of the vehicle's, so it adds to R with no cross-covariance with the state."""
    D = np.asarray(D, dtype=np.float64)
    if D.shape != (3, 3) or not np.all(np.isfinite(D)) or np.any(np.linalg.eigvalsh(0.5 * (D + D.T)) < 0):
        raise ConfigError("scene.geolocation_sigma_m", f"the geolocation covariance must be 3x3 positive "
                          f"semi-definite, got {D.tolist()}")
    rows = list(rows)
    J = -pred.H[:, rows][:, :, layout.slice("p")]
    R = pred.R.copy()
    R[np.ix_(range(pred.runs), rows, rows)] += J @ D @ np.swapaxes(J, -1, -2)
    return pred.replace(R=R)

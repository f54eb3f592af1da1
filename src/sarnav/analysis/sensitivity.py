"""Predicted SAR image shift and blur from an injected navigation error (thesis ch. 4).

Geometry (thesis §4.3, L923-929): truth flies straight and level, ``p(eta) = p0 + v0 eta`` with eta the time
since the error is injected (the aperture start). An initial error dx0 = [dp0, dv0, dth0] (truth minus
estimate, attitude per ``T = (I - [dth x]) T_hat``) is propagated through the linear model of thesis
eqs. 4.17-4.20 (paper eq. 37, the position/velocity/attitude block): ``dx(eta) = expm(F eta) dx0``. The
processor's trajectory is ``p_hat(eta) = p(eta) - dp(eta)``.

* **Shift** (thesis eq. 4.41): reference "X" = (R0, eta0) = closest approach of the target to the true
  trajectory; prediction "O" = (R0_hat, eta0_hat) = closest approach to the estimated trajectory. An image
  formed with the estimated trajectory and geo-referenced by it shows the target at X while the estimate
  predicts it at O; the *offset* (image minus prediction) is ``(R0 - R0_hat, V (eta0 - eta0_hat))``.
* **First-order closed forms** (extraction seed-000 §11.5, generalised): with ``d0 = p_targ - p(eta0)``,
  ``e = dp``, ``R0_hat - R0 = d0_hat . e(eta0)`` and ``V (eta0_hat - eta0) = u . e(eta0) - d0 . e'(eta0) / V``.
* **Blur**: the azimuth FM rate K = 2 R''/lambda (R'' = V^2/R0 for the truth, paper eq. 7). The estimated
  range history has ``R_hat'' - R'' = (d0 . e'' - 2 v0 . e') / R0 - V^2 (d0 . e) / R0^3`` to first order
  (the 2 v0^T dv0 and p_t^T dv_dot terms of thesis eqs. 4.35, 4.40, plus the R0 change), i.e. ``dK = 2 (R_hat'' - R'') / lambda``; the peak loss of
  a quadratic phase ``pi dK eta^2`` over an aperture T is ``1 - |C(z) + j S(z)| / z``, ``z = T sqrt(|dK|/2)``
  (Fresnel integrals).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq
from scipy.special import fresnel

from sarnav.errors import ConfigError, InputDataError
from sarnav.rotations import skew
from sarnav.units import G0

#: specific force in NED of straight and level flight, f^n = -g^n (thesis eq. 4.37)
LEVEL_SPECIFIC_FORCE = np.array([0.0, 0.0, -G0])


def _vec(name, value, n=3):
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise InputDataError(name, f"must be a finite {n}-vector, got shape {a.shape}")
    return a


def nav_error_dynamics(specific_force_n=LEVEL_SPECIFIC_FORCE) -> np.ndarray:
    """F (9x9) of the position/velocity/attitude error for a given specific force in NED (paper eq. 37).

    dp' = dv;  dv' = [f^n x] dth;  dth' = 0 (no gyro error in the ch. 4 study).
    """
    f = _vec("specific_force_n", specific_force_n)
    F = np.zeros((9, 9))
    F[0:3, 3:6] = np.eye(3)
    F[3:6, 6:9] = skew(f)
    return F


def propagate_nav_error(dx0, times, specific_force_n=LEVEL_SPECIFIC_FORCE) -> np.ndarray:
    """dx(eta) = expm(F eta) dx0 for each eta in ``times`` (thesis eqs. 4.19-4.20). Returns (T, 9)."""
    dx0 = _vec("dx0", dx0, 9)
    F = nav_error_dynamics(specific_force_n)
    times = np.atleast_1d(np.asarray(times, dtype=np.float64))
    return np.stack([expm(F * t) @ dx0 for t in times])


def _estimated_state_fn(p0, v0, dx0, specific_force_n):
    """(p_hat(t), v_hat(t)) = truth minus the linearly propagated error."""
    F = nav_error_dynamics(specific_force_n)

    def state(t):
        e = expm(F * t) @ dx0
        return p0 + v0 * t - e[0:3], v0 - e[3:6]

    return state


def _closest_approach(p_targ, state, t_lo, t_hi):
    """Zero-Doppler root (p_targ - p(t)) . v(t) = 0, i.e. the minimum of the range history (eq. 4.41)."""

    def doppler(t):
        p, v = state(t)
        return float((p_targ - p) @ v)

    a, b = doppler(t_lo), doppler(t_hi)
    if not (a > 0 > b):
        raise InputDataError("p_targ", f"no closest approach inside the search span [{t_lo}, {t_hi}] s")
    t = brentq(doppler, t_lo, t_hi, xtol=1e-13, rtol=4 * np.finfo(float).eps)
    return float(t), float(np.linalg.norm(p_targ - state(t)[0]))


@dataclass(frozen=True)
class ShiftPrediction:
    """Thesis eq. 4.41: X = (r0, eta0) on the true track, O = (r0_hat, eta0_hat) on the estimated track.

    ``offset_range = r0 - r0_hat`` and ``offset_along = speed (eta0 - eta0_hat)`` are the image offsets
    (where the target is imaged minus where the estimate predicts it), the quantities a registration
    measures; the thesis's O - X is their negative.
    """

    eta0: float
    r0: float
    eta0_hat: float
    r0_hat: float
    speed: float

    @property
    def offset_range(self) -> float:
        return self.r0 - self.r0_hat

    @property
    def offset_along(self) -> float:
        return self.speed * (self.eta0 - self.eta0_hat)


def predict_shift(p_targ, p0, v0, dx0, span, specific_force_n=LEVEL_SPECIFIC_FORCE) -> ShiftPrediction:
    """Thesis eq. 4.41 evaluated numerically (root of the range-rate, i.e. the range minimum).

    Parameters
    ----------
    p_targ : (3,) target position (NED, m).
    p0, v0 : (3,) truth position at eta = 0 and constant truth velocity.
    dx0 : (9,) injected error [dp0, dv0, dth0] at eta = 0 (truth minus estimate).
    span : (t_lo, t_hi) search interval for the closest approach [s].
    """
    p_targ, p0, v0 = _vec("p_targ", p_targ), _vec("p0", p0), _vec("v0", v0)
    dx0 = _vec("dx0", dx0, 9)
    t_lo, t_hi = float(span[0]), float(span[1])
    if not t_hi > t_lo:
        raise ConfigError("span", f"must be (t_lo, t_hi) with t_hi > t_lo, got {span!r}")
    eta0, r0 = _closest_approach(p_targ, lambda t: (p0 + v0 * t, v0), t_lo, t_hi)
    eta0_hat, r0_hat = _closest_approach(p_targ, _estimated_state_fn(p0, v0, dx0, specific_force_n), t_lo, t_hi)
    return ShiftPrediction(eta0, r0, eta0_hat, r0_hat, float(np.linalg.norm(v0)))


def _error_derivatives(p0, v0, dx0, eta, specific_force_n):
    """e, e', e'' of the position error at eta from the linear model (e' = dv, e'' = f x dth)."""
    dx = propagate_nav_error(dx0, [eta], specific_force_n)[0]
    acc = nav_error_dynamics(specific_force_n)[3:6] @ dx
    return dx[0:3], dx[3:6], acc


def linear_shift(p_targ, p0, v0, dx0, specific_force_n=LEVEL_SPECIFIC_FORCE) -> tuple[float, float]:
    """First-order image offsets (offset_range, offset_along) [m] (extraction seed-000 §11.5, generalised).

    offset_range = -(d0_hat . e(eta0)), offset_along = -(u . e(eta0) - d0 . e'(eta0) / V).
    """
    p_targ, p0, v0 = _vec("p_targ", p_targ), _vec("p0", p0), _vec("v0", v0)
    speed = np.linalg.norm(v0)
    u = v0 / speed
    eta0 = float(u @ (p_targ - p0) / speed)
    d0 = p_targ - (p0 + v0 * eta0)
    e, de, _ = _error_derivatives(p0, v0, dx0, eta0, specific_force_n)
    r0 = np.linalg.norm(d0)
    return float(-(d0 @ e) / r0), float(-(u @ e - d0 @ de / speed))


def fm_rate_error(p_targ, p0, v0, dx0, wavelength, specific_force_n=LEVEL_SPECIFIC_FORCE) -> float:
    """Azimuth FM-rate error dK = K_hat - K [Hz/s] to first order (thesis eqs. 4.35, 4.40; paper eq. 7)."""
    p_targ, p0, v0 = _vec("p_targ", p_targ), _vec("p0", p0), _vec("v0", v0)
    if not (np.isfinite(wavelength) and wavelength > 0):
        raise ConfigError("wavelength", f"must be finite and > 0 m, got {wavelength!r}")
    speed = np.linalg.norm(v0)
    eta0 = float((v0 / speed) @ (p_targ - p0) / speed)
    d0 = p_targ - (p0 + v0 * eta0)
    e, de, dde = _error_derivatives(p0, v0, dx0, eta0, specific_force_n)
    r0 = np.linalg.norm(d0)
    # R'' = (|D'|^2 + D.D'')/R at the minimum, D = d0 + e: first-order change incl. the R0 change (d0.e)/R0
    d_rdd = (d0 @ dde - 2.0 * v0 @ de) / r0 - (v0 @ v0) * (d0 @ e) / r0**3
    return float(2.0 * d_rdd / wavelength)


def peak_loss_from_fm_rate_error(dk, aperture_time) -> float:
    """Relative loss of peak amplitude from a quadratic phase pi dK eta^2 over |eta| <= T/2 (Fresnel)."""
    if not (np.isfinite(aperture_time) and aperture_time > 0):
        raise ConfigError("aperture_time", f"must be finite and > 0 s, got {aperture_time!r}")
    dk = abs(float(dk))
    if dk == 0.0:
        return 0.0
    z = aperture_time * np.sqrt(dk / 2.0)
    s, c = fresnel(z)
    return float(1.0 - np.hypot(c, s) / z)

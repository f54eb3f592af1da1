"""Focus as a navigation measurement: the along-track velocity that best focuses an aperture of pulses.

Back-projection along a track whose along-track velocity is wrong by dv defocuses the image (azimuth FM-rate
error 2 dv / V, Hathaway 2023 §3.2, Figs. 4.2-4.6; notes/seed-004 T7). Given the range-compressed pulses of
one aperture and the antenna positions the INS believes, the extractor forms the images of the candidate tracks

    p_hat(t) + dv (t - t_c) e          (t_c the aperture's centre time, e the unit along-track direction)

and finds the dv that maximises a focus score (kurtosis, eq. 3.5, by default): a coarse grid over +- ``span``,
then bounded Brent around the best grid point (imaging.offset_bpa: one pass over the pulses per stage). A
constant position error or a cross-track / vertical velocity error shifts or rotates the image without
defocusing it (docs/quality.md), so the best-focus velocity measures the along-track velocity only:

    z = e . v(t_c) + n,     z_hat = e . v_hat(t_c),     H = [0_3, e^T, 0 ...]  (dx = truth - estimate)

The noise variance comes from a model calibrated by Monte Carlo: ``sigma^2 = kappa / c`` with c the relative
curvature of the score at its peak, -S''(dv*) / S(dv*) [1/(m/s)^2] (a sharper peak, a better fix), and kappa
fitted on simulated apertures with known truth (:func:`calibrate_kappa`; checked on fresh ones,
tests/measurements/test_focus.py). :class:`FocusVelocityMeasurement` is the filter-facing object
(``predict(state) -> Prediction``, ``simulate(truth)`` for the oracle mode).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from sarnav.errors import ConfigError, InputDataError, require_positive
from sarnav.filters.layout import ErrorStateLayout
from sarnav.filters.prediction import Prediction
from sarnav.imaging.offset_bpa import offset_moments, order_for
from sarnav.imaging.quality import normalised_complex_kurtosis, quality_measure
from sarnav.ins.state import NavState
from sarnav.measurements.base import Measurement, unit_noise
from sarnav.rotations import quat_to_dcm

__all__ = ["FocusFix", "extract_focus_velocity", "calibrate_kappa", "FocusVelocityMeasurement", "body_specific_force"]


@dataclass(frozen=True)
class FocusFix:
    """One best-focus velocity fix.

    Attributes
    ----------
    value : e . v at the aperture centre implied by the best focus, ``e . v_hat(t_c) + offset`` [m/s].
    offset : best-focus correction dv* to the INS along-track velocity [m/s].
    time : aperture centre time t_c [s]; direction : (3,) unit along-track direction e.
    curvature : relative curvature -S''/S of the score at dv* [1/(m/s)^2] (> 0 at a maximum; 0 if none found).
    score : the score at dv*.
    contrast : normalised complex kurtosis (eq. 3.5 / m2^2) of the image at dv*: 0 for speckle (no focus
        information), its standard error 2 / sqrt(P_eff) over P_eff independent cells.
    at_edge : the first stage's best grid point is an end of its grid (the optimum may lie beyond ``span``).
    """

    value: float
    offset: float
    time: float
    direction: np.ndarray
    curvature: float
    score: float
    contrast: float = float("nan")
    at_edge: bool = False


def _aperture_direction(positions: np.ndarray) -> np.ndarray:
    d = positions[-1] - positions[0]
    d[2] = 0.0
    n = np.linalg.norm(d)
    if n == 0:
        raise InputDataError("positions", "the estimated track does not move horizontally over the aperture")
    return d / n


def _g_max(grid, positions, e) -> float:
    pts = np.asarray(grid.points(), dtype=np.float64).reshape(-1, 3)
    ends = positions[[0, -1]]
    d = pts[None, :, :] - ends[:, None, :]
    return float(np.max(np.abs(d @ e) / np.linalg.norm(d, axis=-1)))


def _stage(rc, grid, base, e, tau, span, n_grid, measure, tolerance, g_max):
    """Grid over +-span, Brent between the best point's neighbours; returns (dv*, S(dv*), S''(dv*), normalised
    kurtosis of the image at dv*, whether the grid's best point is an end point)."""
    k = 4.0 * math.pi / rc.wavelength
    order = order_for(k * span * float(np.max(np.abs(tau))) * g_max * 1.05, 0.1 * tolerance)
    mom = offset_moments(rc, grid, base, e, tau, order)

    def score(d):
        return measure.better(mom.image(d, tolerance))

    d = np.linspace(-span, span, n_grid)
    s = np.array([measure.better(im) for im in mom.images(d, tolerance)])
    i = int(np.argmax(s))
    lo, hi = d[max(i - 1, 0)], d[min(i + 1, n_grid - 1)]
    res = minimize_scalar(lambda x: -score(x), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-4 * (d[1] - d[0])})
    best, best_s = (float(res.x), -float(res.fun)) if -res.fun >= s[i] else (float(d[i]), float(s[i]))
    h = 0.05 * (d[1] - d[0])
    lo2, hi2 = max(best - h, -span), min(best + h, span)
    curv = (score(hi2) - 2.0 * best_s + score(lo2)) / (0.25 * (hi2 - lo2) ** 2) if hi2 > lo2 else 0.0
    return best, best_s, curv, normalised_complex_kurtosis(mom.image(best, tolerance)), i in (0, n_grid - 1)


def extract_focus_velocity(rc, grid, positions, times=None, span: float = 0.5, n_grid: int = 11,
                           measure: str = "kurtosis", tolerance: float = 1e-2, refine: bool = True,
                           velocity_estimate=None) -> FocusFix:
    """Best-focus along-track velocity of one aperture (module docstring).

    Parameters
    ----------
    rc : range-compressed pulses of the aperture (``PulseData``).
    grid : image grid of the focus region (e.g. a ``GroundGrid`` sampled finer than the resolution: the
        score's optimum is biased by pixel sampling otherwise, docs/quality.md).
    positions : (P, 3) antenna positions from the navigation estimate [m]; times : (P,) [s] (default rc's).
    span : half-width of the first search stage [m/s]; n_grid : grid points per stage (odd, >= 3).
    measure : quality measure name (maximised or minimised per its sense).
    tolerance : phase accuracy of the candidate images [rad]. refine : a second stage around the first
        optimum (candidate tracks recentred, span = one grid step).
    velocity_estimate : (3,) INS velocity at the aperture centre [m/s] (default: from ``positions``, the mean
        velocity over the aperture).

    Returns
    -------
    FocusFix
    """
    m = quality_measure(measure, "focus.measure")
    if isinstance(n_grid, bool) or not isinstance(n_grid, (int, np.integer)) or n_grid < 3 or n_grid % 2 == 0:
        raise ConfigError("focus.n_grid", f"must be an odd integer >= 3, got {n_grid!r}")
    span = require_positive("focus.span", span, "m/s")
    pos = np.asarray(positions, dtype=np.float64)
    t = np.asarray(rc.pulse_times if times is None else times, dtype=np.float64)
    if pos.shape != (rc.n_pulses, 3) or t.shape != (rc.n_pulses,) or not np.all(np.isfinite(pos)):
        raise InputDataError("positions", f"must be finite ({rc.n_pulses}, 3) with times ({rc.n_pulses},)")
    e = _aperture_direction(pos)
    t_c = 0.5 * (t[0] + t[-1])
    tau = t - t_c
    g_max = _g_max(grid, pos, e)
    d1, s, c, k, edge = _stage(rc, grid, pos, e, tau, span, n_grid, m, tolerance, g_max)
    dv = d1
    if refine:
        step = 2.0 * span / (n_grid - 1)
        d2, s, c, k, _ = _stage(rc, grid, pos + (d1 * tau)[:, None] * e[None, :], e, tau, step, n_grid, m,
                                0.1 * tolerance, g_max)
        dv = d1 + d2
    v_hat = (np.asarray(velocity_estimate, dtype=np.float64) if velocity_estimate is not None
             else (pos[-1] - pos[0]) / (t[-1] - t[0]))
    rel = -c / s if s != 0 and c < 0 else 0.0
    return FocusFix(float(e @ v_hat + dv), float(dv), float(t_c), e, float(rel), float(s), float(k), bool(edge))


def body_specific_force(q, f_nav, accel_bias) -> dict:
    """``{"f_body", "f_ref"}`` of ``FocusVelocityMeasurement``'s coupling from the INS: its attitude q (R, 4), nav-frame
    specific force f_nav (R, 3) and accelerometer-bias estimate (R, 3): f_body = C_b^n^T f_nav + b_a (the IMU's
    raw specific force), f_ref = f_nav."""
    f_ref = np.asarray(f_nav, dtype=np.float64)
    f_body = np.einsum("rji,rj->ri", quat_to_dcm(np.asarray(q, dtype=np.float64)), f_ref) + np.asarray(accel_bias)
    return {"f_body": f_body, "f_ref": f_ref}


def _unit_rows(a, field: str) -> np.ndarray:
    """(R, 3) or (1, 3) rows normalised to unit length; InputDataError naming ``field`` for a zero or bad row."""
    e = np.atleast_2d(np.asarray(a, dtype=np.float64))
    if e.ndim != 2 or e.shape[-1] != 3 or not np.all(np.isfinite(e)):
        raise InputDataError(field, f"must be finite (R, 3) or (3,), got shape {np.shape(a)}")
    norm = np.sqrt(np.sum(e * e, axis=1, keepdims=True))
    if np.any(norm == 0):
        raise InputDataError(field, "must be non-zero directions")
    return e / norm


def calibrate_kappa(errors, curvatures) -> tuple[float, float]:
    """Monte Carlo calibration of ``sigma^2 = kappa / c``: the maximum-likelihood kappa = mean(err^2 c) and its
    relative standard error sqrt(2 / n) (err^2 c / kappa ~ chi^2_1).

    errors : (n,) fix errors z - e.v_true [m/s]; curvatures : (n,) relative curvatures c > 0 [1/(m/s)^2].
    """
    err = np.asarray(errors, dtype=np.float64)
    c = np.asarray(curvatures, dtype=np.float64)
    if err.shape != c.shape or err.size < 2 or np.any(c <= 0) or not np.all(np.isfinite(err)):
        raise InputDataError("curvatures", "need >= 2 finite errors and positive curvatures of the same shape")
    return float(np.mean(err**2 * c)), math.sqrt(2.0 / err.size)


class FocusVelocityMeasurement(Measurement):
    """Best-focus along-track velocity fixes of R runs as an error-state measurement (module docstring).

    One model of the measurement contract (:class:`~sarnav.measurements.base.Measurement`, checked by
    tests/measurements/test_contract.py); its Hessians are returned as zero (linear in v; the attitude enters through
    the rotation of the specific force, whose second-order term is negligible at these tilts).

    The azimuth FM rate of a scatterer at range R is (2 / lambda) (V_perp^2 / R - u . a) with u the unit line of
    sight from the antenna to it and a the antenna's acceleration (notes/seed-004 §2.1; Cumming & Wong eq. 4.37 with
    acceleration), so the track that focuses best has along-track speed V_true + (R / 2V) u . (a_INS - a_true): a
    line-of-sight acceleration error of the INS (its tilt and accelerometer bias) looks like a velocity error
    R / 2V (17 s here) times larger. With ``los``, ``lever`` = R / 2V [s] and the INS's specific force, the model is

        h(x) = e . v - lever u . (f(x) - f_ref),   f(x) = C_b^n(q) (f_body - b_a),   f_ref = f(x_hat)

    H = [0, e^T, -lever (u x f)^T, lever u^T C_b^n, 0 ...] (dx = truth - estimate; eq. 3.7: d(dv)/dt = f x dth -
    C db_a); without them h = e . v.

    Parameters
    ----------
    layout : the filter's :class:`~sarnav.filters.layout.ErrorStateLayout` (needs the ``v`` block).
    directions : (R, 3) or (3,) unit along-track directions e of the fixes (normalised here; must not be zero).
    sigma : (R,) or scalar 1-sigma noise of each fix [m/s] (from ``kappa / curvature``, or a constant).
    los : (R, 3) or (3,) unit line of sight antenna -> scene centre at t_c (optional, with the next three).
    lever : (R,) or scalar R / (2 V) [s]; f_body : (R, 3) the IMU's specific force in the body frame (bias not
        removed) [m/s^2]; f_ref : (R, 3) the INS's nav-frame specific force at t_c, C_b^n (f_body - b_a_hat).
    """

    names = ("v_focus",)
    units = ("m/s",)

    def __init__(self, layout: ErrorStateLayout, directions, sigma, los=None, lever=None, f_body=None, f_ref=None):
        if not layout.has("v"):
            raise ConfigError("layout.blocks", "the focus velocity needs the 'v' block")
        self.layout = layout
        self.directions = _unit_rows(directions, "directions")
        s = np.atleast_1d(np.asarray(sigma, dtype=np.float64))
        if s.ndim != 1 or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ConfigError("focus.sigma", f"must be finite and > 0 m/s, got {sigma!r}")
        self.sigma = s
        given = [x is not None for x in (los, lever, f_body, f_ref)]
        if any(given) and not all(given):
            raise InputDataError("los", "the acceleration coupling needs los, lever, f_body and f_ref together")
        self.coupled = all(given)
        if self.coupled:
            self.los = _unit_rows(los, "los")
            self.lever = np.atleast_1d(np.asarray(lever, dtype=np.float64))
            self.f_body = np.atleast_2d(np.asarray(f_body, dtype=np.float64))
            self.f_ref = np.atleast_2d(np.asarray(f_ref, dtype=np.float64))
            if not (np.all(np.isfinite(self.lever)) and np.all(np.isfinite(self.f_body))
                    and np.all(np.isfinite(self.f_ref))):
                raise InputDataError("lever", "lever, f_body and f_ref must be finite")

    @classmethod
    def from_fixes(cls, layout: ErrorStateLayout, fixes, kappa: float) -> tuple["FocusVelocityMeasurement", np.ndarray]:
        """The measurement of one fix per run and the measured values z (R, 1); sigma^2 = kappa / curvature."""
        kappa = require_positive("focus.kappa", kappa, "")
        curv = np.array([f.curvature for f in fixes])
        if np.any(curv <= 0):
            raise InputDataError("fixes", "a fix without a score maximum (curvature <= 0) cannot be used")
        z = np.array([[f.value] for f in fixes])
        return cls(layout, np.array([f.direction for f in fixes]), np.sqrt(kappa / curv)), z

    def _per_run(self, runs: int) -> tuple[np.ndarray, np.ndarray]:
        e = np.broadcast_to(self.directions, (runs, 3)) if self.directions.shape[0] in (1, runs) else None
        s = np.broadcast_to(self.sigma, (runs,)) if self.sigma.shape[0] in (1, runs) else None
        if e is None or s is None:
            raise InputDataError("state", f"has {runs} runs; the measurement has {self.directions.shape[0]} "
                                 f"directions and {self.sigma.shape[0]} sigmas")
        return e, s

    def _coupling(self, nav: NavState, runs: int):
        """(lever u . (f(x) - f_ref) (R,), H row of th (R, 3), H row of ba (R, 3)) at ``nav``."""
        b = lambda a, k: np.broadcast_to(a, (runs,) + a.shape[1:]) if a.shape[0] in (1, runs) else None  # noqa: E731
        u, lev, fb, fr = b(self.los, 0), b(self.lever, 0), b(self.f_body, 0), b(self.f_ref, 0)
        if any(x is None for x in (u, lev, fb, fr)):
            raise InputDataError("state", f"has {runs} runs; the coupling arrays do not match")
        C = quat_to_dcm(np.asarray(nav.q, dtype=np.float64))
        f = np.einsum("rij,rj->ri", C, fb - np.asarray(nav.ba, dtype=np.float64))
        return (lev * np.sum(u * (f - fr), axis=1), -lev[:, None] * np.cross(u, f),
                lev[:, None] * np.einsum("ri,rij->rj", u, C))

    def predict(self, nav: NavState) -> Prediction:
        """Expected fix h(x_hat), H, R = sigma^2, zero Hessians (batched over runs; class docstring)."""
        v = np.asarray(nav.v, dtype=np.float64)
        runs = v.shape[0]
        e, s = self._per_run(runs)
        n = self.layout.n
        H = np.zeros((runs, 1, n))
        H[:, 0, self.layout.slice("v")] = e
        z = np.sum(e * v, axis=1)
        if self.coupled:
            dz, h_th, h_ba = self._coupling(nav, runs)
            z = z - dz
            H[:, 0, self.layout.slice("th")] = h_th
            if self.layout.has("ba"):
                H[:, 0, self.layout.slice("ba")] = h_ba
        return Prediction(z[:, None], H, (s**2)[:, None, None], hessians=np.zeros((runs, 1, n, n)), names=self.names)

    def simulate(self, truth: NavState, rngs=None, noise=None) -> np.ndarray:
        """Oracle fixes h(truth) + sigma x unit normal, (R, 1); ``noise`` (R, 1) unit normals,
        else one draw from each run's Generator in ``rngs`` (the contract of measurements.base)."""
        v = np.asarray(truth.v, dtype=np.float64)
        runs = v.shape[0]
        e, s = self._per_run(runs)
        if noise is not None:
            noise = np.asarray(noise, dtype=np.float64).reshape(runs, -1) if np.size(noise) == runs else noise
        n = unit_noise(runs, 1, rngs, noise)[:, 0]
        z = np.sum(e * v, axis=1)
        if self.coupled:
            z = z - self._coupling(truth, runs)[0]
        return (z + s * n)[:, None]

"""The error-state navigator: INS + covariance between measurement events, one update loop for every event.

It holds the filter's belief and nothing else: the estimate ``nav`` (a batched :class:`~sarnav.ins.NavState`, R
runs) and its covariance ``P`` (R, n, n), the error model of the filter's own IMU (``ErrorStateModel``: F, Q, P0 of
the biases), and what the strapdown needs (bias correlation times, the Earth rate it assumes). It never sees truth: a
*source* (the simulated world of ``sarnav.simulation``, or a recorded flight) hands it IMU samples and measurement
events (a :class:`~sarnav.filters.prediction.Prediction` and z); comparing the estimate with truth happens outside.

* :meth:`Navigator.propagate` advances the strapdown INS (``ins.mechanize``, three-point rule) and the covariance
  (Van Loan, F held over one covariance step) through a block of IMU samples, and returns the :class:`Interval`: the
  INS history at the step epochs (an aperture's estimated track), the last step's mean f^n, the estimate after every
  step and, on request, the transition and process noise of the whole block (Gaussian sums need them).
* :meth:`Navigator.update` fuses one event through the update strategies of ``filters.update``: Joseph form when the
  noise is independent of the state (``pred.C is None``), the correlated form otherwise (delayed-state events);
  components left out (``keep``) go through ``Prediction.masked`` with z set to z_hat; the NIS counts the components
  present. :meth:`Navigator.update_mixture` does the same with a Gaussian sum (``filters.gaussian_sum``). Both feed
  the correction back into the INS (thesis eq. 3.23) and restart the three-point rule.
* :meth:`Navigator.gate` is the chi-square innovation gate of groups of components (``filters.update.chi2_gate``).

The covariance of a step uses T_b^n at the step's start (``covariance_attitude="start"``) or the normalised mean of
the start and end quaternions (``"mid"``); f^n is the step mean of the INS either way.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters import ErrorStateLayout, ErrorStateModel, apply_feedback, propagate_covariance, update
from sarnav.filters.update import Fused, fuse
from sarnav.filters.gaussian_sum import GaussianSum, gaussian_sum_update
from sarnav.filters.prediction import Prediction
from sarnav.ins import NavState, mechanize
from sarnav.ins.strapdown import MAX_GAP_INTERVALS, UNIFORM_RTOL, check_sample_times
from sarnav.rotations import quat_normalize, quat_to_dcm
from sarnav.sensors.imu import ImuSpec

COVARIANCE_ATTITUDES = ("start", "mid")


def error_model(layout: ErrorStateLayout, imu: ImuSpec, bias_sigma, bias_tau, earth_rate=None) -> ErrorStateModel:
    """The filter's error model (F, B, Q) for its belief ``imu`` about the IMU and the scalar measurement biases
    (steady-state 1-sigma ``bias_sigma``, correlation times ``bias_tau``)."""
    g = imu.grade
    return ErrorStateModel(layout, g.vrw, g.arw, g.accel_bias, g.gyro_bias, imu.tau_accel, imu.tau_gyro,
                           bias_sigma, bias_tau, earth_rate=earth_rate)


@dataclass(frozen=True)
class Interval:
    """What :meth:`Navigator.propagate` returns for one block of IMU samples split into ``steps`` covariance steps.

    ``t`` (steps + 1,) the step epochs; ``p``, ``v`` (R, steps + 1, 3), ``q`` (R, steps + 1, 4) the INS at them (the
    estimated track of an aperture); ``f_mean`` (R, 3) the mean f^n of the last step; ``estimates``: (nav, P) after
    each step; ``Phi``, ``Qd`` (R, n, n) the transition and process noise of the whole block (None unless asked)."""

    t: np.ndarray
    p: np.ndarray
    v: np.ndarray
    q: np.ndarray
    f_mean: np.ndarray
    estimates: tuple
    Phi: np.ndarray | None = None
    Qd: np.ndarray | None = None


class Navigator:
    """INS + error-state covariance of R runs between events; events fused through the one contract (module
    docstring). ``nav``, ``P``: the estimate and its covariance now; ``model``: the filter's error model."""

    def __init__(self, nav: NavState, P, model: ErrorStateModel, layout: ErrorStateLayout, *, tau_accel: float,
                 tau_gyro: float, bias_tau=(), earth_rate=None, covariance_attitude: str = "mid"):
        if covariance_attitude not in COVARIANCE_ATTITUDES:
            raise ConfigError("covariance_attitude", f"must be one of {COVARIANCE_ATTITUDES}, got {covariance_attitude!r}")
        P = np.asarray(P, dtype=np.float64)
        if P.shape != (nav.runs, layout.n, layout.n):
            raise InputDataError("P", f"must be (runs, n, n) = {(nav.runs, layout.n, layout.n)}, got {P.shape}")
        self.nav, self.P, self.model, self.layout = nav, P, model, layout
        self.tau_accel, self.tau_gyro, self.bias_tau = float(tau_accel), float(tau_gyro), bias_tau
        self.earth_rate, self.attitude = earth_rate, covariance_attitude
        self._history = None

    @property
    def runs(self) -> int:
        return self.nav.runs

    def propagate(self, times, nu, omega, samples_per_step: int | None, transition: bool = False,
                  step_seconds: float | None = None, max_gap: float | None = None, bounds=None,
                  bridge: dict | None = None) -> Interval:
        """Advance through IMU samples ``times`` (N + 1,) [s], ``nu``, ``omega`` (R, N + 1, 3) (sample 0 is the one at
        the current estimate's time), in covariance steps of ``samples_per_step`` samples (N a multiple of it).
        The clock may jitter or miss isolated samples (``ins.check_sample_times``; ``max_gap`` [s], None:
        ``MAX_GAP_INTERVALS`` median intervals of the block): each step's covariance is over its actual span of
        ``times``. ``step_seconds``: a uniform clock's nominal step (samples x interval), used instead of a span
        equal to it within ``UNIFORM_RTOL`` (bit-identical to the clock's own arithmetic); None: always the span.
        ``bounds``: the steps' first and last samples instead (increasing indices from 0 to N; ``samples_per_step``
        None): steps of any number of samples, e.g. a recorded clock's samples nearest to the step epochs.
        ``bridge``: {step: (n, n)} covariance added after that step's propagation (a bridged gap in the log)."""
        times = check_sample_times(times, max_gap=max_gap)
        if max_gap is None:
            max_gap = MAX_GAP_INTERVALS * float(np.median(np.diff(times)))
        n_samples = len(times) - 1
        if bounds is None:
            c = int(samples_per_step)
            if c < 1 or n_samples < 1 or n_samples % c:
                raise InputDataError("samples_per_step", f"must divide the block's {n_samples} samples, got {c}")
            bounds = np.arange(0, n_samples + 1, c)
        bounds = np.asarray(bounds, dtype=np.int64)
        if bounds.ndim != 1 or bounds.size < 2 or bounds[0] != 0 or bounds[-1] != n_samples or np.any(
                np.diff(bounds) < 1):
            raise InputDataError("bounds", f"must increase from 0 to the block's {n_samples} samples, got "
                                 f"{bounds.tolist()}")
        steps, R = bounds.size - 1, self.runs
        p_hist, v_hist = np.empty((R, steps + 1, 3)), np.empty((R, steps + 1, 3))
        q_hist = np.empty((R, steps + 1, 4))
        p_hist[:, 0], v_hist[:, 0], q_hist[:, 0] = self.nav.p, self.nav.v, self.nav.q
        f_mean, estimates = None, []
        if transition:
            n = self.layout.n
            Phi_i, Qd_i = np.broadcast_to(np.eye(n), (R, n, n)).copy(), np.zeros((R, n, n))
        for s in range(steps):
            a, b = int(bounds[s]), int(bounds[s + 1])
            q_start = self.nav.q
            self.nav, f_mean, self._history = mechanize(
                self.nav, times[a:b + 1], nu[:, a:b + 1], omega[:, a:b + 1], self.tau_accel, self.tau_gyro,
                self.bias_tau, self._history, earth_rate=self.earth_rate, max_gap=max_gap)
            q_cov = q_start if self.attitude == "start" else quat_normalize(q_start + self.nav.q)
            span = times[b] - times[a]
            if step_seconds is not None and abs(span - step_seconds) <= UNIFORM_RTOL * step_seconds:
                span = step_seconds
            Phi, Qd = self.model.discretize(quat_to_dcm(q_cov), f_mean, span)
            if bridge and s in bridge:
                Qd = Qd + bridge[s]
            self.P = propagate_covariance(self.P, Phi, Qd)
            if transition:
                Phi_i, Qd_i = Phi @ Phi_i, propagate_covariance(Qd_i, Phi, Qd)
            p_hist[:, s + 1], v_hist[:, s + 1], q_hist[:, s + 1] = self.nav.p, self.nav.v, self.nav.q
            estimates.append((self.nav, self.P))
        t_steps = times[bounds]
        return Interval(t_steps, p_hist, v_hist, q_hist, f_mean, tuple(estimates),
                        Phi_i if transition else None, Qd_i if transition else None)

    def feedback(self, dx, P_post) -> None:
        """Feed the error-state estimate ``dx`` (R, n) back into the INS (eq. 3.23), take the posterior covariance and
        restart the three-point integration rule."""
        self.nav = apply_feedback(self.nav, dx, self.layout)
        self.P = P_post
        self._history = None

    def gate(self, pred: Prediction, z, groups, probability: float) -> np.ndarray:
        """(R, G) True where each group of components (lists of indices) passes the chi-square innovation gate at the
        false-rejection rate ``probability`` (``filters.update.chi2_gate``; 0 passes every finite group)."""
        return update.chi2_gate(self.P, pred, z, groups, probability)[1]

    def update(self, pred: Prediction, z, keep=None) -> Fused:
        """Fuse ``z`` (R, m) predicted by ``pred`` (:func:`fuse`) and feed the correction back."""
        fused = fuse(self.P, pred, z, keep)
        self.feedback(fused.update.dx, fused.update.P)
        return fused

    def update_mixture(self, mixture: GaussianSum, predict_at: Callable, z, threshold: float, interval: Interval):
        """A Gaussian-sum update (``filters.gaussian_sum``): the mixture propagated over ``interval`` (its ``Phi``,
        ``Qd``), split where a component's second-order term exceeds ``threshold``, fused and collapsed; feeds back.
        ``predict_at(runs, dx)`` is the event's prediction at the estimate corrected by dx. Returns (Fused, the
        components used (R,))."""
        mixture.propagate(interval.Phi, interval.Qd, self.P)
        gs = gaussian_sum_update(mixture, predict_at, z, threshold)
        up = gs.update
        self.feedback(up.dx, up.P)
        keep = np.ones(up.residual.shape, dtype=bool)
        return Fused(up, keep, up.nis, keep.sum(axis=1)), gs.components

    def corrected(self, runs, dx) -> NavState:
        """The estimate of ``runs`` (index array) corrected by ``dx`` (len(runs), n), without changing it."""
        nav = NavState(*(getattr(self.nav, f)[runs] for f in ("p", "v", "q", "ba", "bg", "bm")))
        return apply_feedback(nav, dx, self.layout)

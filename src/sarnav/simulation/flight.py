"""The spine that every error-state Monte Carlo kind shares (``telemetry``, ``rda-nav``).

The truth sensor and the filter's belief about it are two objects (pyins' practice): :class:`ImuSpec` ``truth``
corrupts the true kinematics (white noise + FOGM biases, ``sensors.ImuModel``); ``filter`` is what the INS and the
error model assume (bias decay in the mechanization, F / Q / P0 of the biases). They are equal unless a scenario
sets ``[filter.imu]`` (a model-mismatch study).

One batch of runs flies the same analytic truth; per run, from its own Generator and in this order: IMU
biases (6), measurement biases and initial error (k + n, k = 3 or 0 measurement biases), the measurement-bias drive (one 3-vector per
covariance step), the kind's extra draws (``extra_draws``), IMU sample 0; then per update interval the IMU
block. Between updates the strapdown INS (``ins.mechanize``) and the covariance (``ErrorStateModel``, Van
Loan, F held over one covariance step) advance together; the error, the filter 1-sigma and the NEES are
recorded at every output epoch. A kind makes its measurements at the end of each interval, updates
(``nav``, ``P``) and calls :meth:`ErrorStateFlight.after_update`.

The covariance of a step uses T_b^n at the step's start (``covariance_attitude="start"``) or the normalised
mean of the start and end quaternions (``"mid"``); f^n is the step mean of the INS either way. With
``interval_transition=True`` :meth:`ErrorStateFlight.fly_interval` also returns the transition and process noise of
the whole interval (the product of the steps'), for filters that carry more than one covariance (Gaussian sums).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters import (
    ErrorStateLayout,
    ErrorStateModel,
    apply_feedback,
    corrupt_state,
    error_state,
    normalized_squared,
    propagate_covariance,
)
from sarnav.ins import NavState, mechanize
from sarnav.rotations import quat_normalize, quat_to_dcm
from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path
from sarnav.sensors.imu import ImuBlocks, ImuGrade, ImuModel
from sarnav.trajectory.base import Trajectory

COVARIANCE_ATTITUDES = ("start", "mid")


@dataclass(frozen=True)
class ImuSpec:
    """An IMU error model: 1-sigma figures and bias correlation times [s] (SI)."""

    grade: ImuGrade
    tau_accel: float
    tau_gyro: float


@dataclass(frozen=True)
class FlightSpec:
    """What the spine needs of a parsed scenario (SI units). ``imu_filter`` defaults to ``imu_truth``."""

    trajectory: Trajectory
    imu_truth: ImuSpec
    imu_rate: float  # [Hz]
    bias_sigma: np.ndarray  # (k,) steady-state 1-sigma of the scalar measurement biases (k = 3, or 0 for none)
    bias_tau: np.ndarray  # (k,)
    p0_sigma: np.ndarray  # (n,) initial 1-sigma of the error state
    n_updates: int
    samples_per_update: int  # IMU samples per update interval
    samples_per_step: int  # IMU samples per covariance step (divides samples_per_update)
    imu_filter: ImuSpec | None = None
    earth_rate: np.ndarray | None = None  # omega_ie^t (3,) [rad/s] of a rotating tangent frame (earth.rotation); None: off
    filter_earth_rate: object = "truth"  # what the INS and F assume: "truth" (= earth_rate), None or a vector

    @property
    def filter_earth(self) -> np.ndarray | None:
        """The Earth rate the INS and the error model assume (``filter_earth_rate``; "truth": ``earth_rate``)."""
        if isinstance(self.filter_earth_rate, str) and self.filter_earth_rate == "truth":
            return self.earth_rate
        return self.filter_earth_rate

    @property
    def filter_imu(self) -> ImuSpec:
        """The IMU model the filter assumes (``imu_filter``, or the truth sensor's when None)."""
        return self.imu_truth if self.imu_filter is None else self.imu_filter


class ErrorStateFlight:
    """Truth, INS, covariance and the error record of one batch of runs (module docstring).

    Attributes a kind reads or sets: ``nav`` (NavState, R runs), ``P`` (R, n, n), ``truth`` (NavState at the
    last epoch flown), ``bm_truth`` (R, T, 3) the truth measurement biases at every output epoch, ``t_out``,
    ``truth_out``, ``model``, ``rngs``, ``extra`` (what ``extra_draws`` returned), ``err``, ``sig``, ``nees``.
    """

    def __init__(self, spec: FlightSpec, layout: ErrorStateLayout, seeds,
                 extra_draws: Callable | None = None, covariance_attitude: str = "mid", interval_transition: bool = False):
        if covariance_attitude not in COVARIANCE_ATTITUDES:
            raise ConfigError("covariance_attitude", f"must be one of {COVARIANCE_ATTITUDES}, got {covariance_attitude!r}")
        m, c = int(spec.samples_per_update), int(spec.samples_per_step)
        if c < 1 or m % c:
            raise ConfigError("samples_per_step", f"must divide samples_per_update = {m}, got {c}")
        self.spec, self.layout, self.attitude = spec, layout, covariance_attitude
        self.interval_transition = bool(interval_transition)
        self.rngs = [np.random.default_rng(s) for s in seeds]
        R, L = len(self.rngs), layout
        self.R, self.m, self.c, self.steps = R, m, c, m // c
        self.dt = 1.0 / spec.imu_rate
        n_upd = int(spec.n_updates)
        traj = spec.trajectory
        self.t_imu = np.arange(n_upd * m + 1) * self.dt
        nu_true = traj.specific_force(self.t_imu, spec.earth_rate)  # the truth IMU senses the Earth's turn when on
        om_true = traj.angular_rate(self.t_imu, spec.earth_rate)
        self.t_out = np.arange(n_upd * self.steps + 1) * (c * self.dt)
        self.truth_out = traj.state(self.t_out)
        tr, fi = spec.imu_truth, spec.filter_imu
        imu = ImuModel(tr.grade, spec.imu_rate, tr.tau_accel, tr.tau_gyro)
        g = fi.grade
        self.model = ErrorStateModel(L, g.vrw, g.arw, g.accel_bias, g.gyro_bias, fi.tau_accel, fi.tau_gyro,
                                     spec.bias_sigma, spec.bias_tau, earth_rate=spec.filter_earth)
        # --- per-run draws, fixed order ---
        ba, bg = imu.initial_biases(self.rngs)
        nb = len(spec.bias_sigma)  # 3 for telemetry and rda-nav; 0 for a filter without measurement biases
        w0 = np.stack([r.standard_normal(nb + L.n) for r in self.rngs])
        bm0 = spec.bias_sigma * w0[:, :nb]
        dx0 = spec.p0_sigma * w0[:, nb:]
        drive = np.stack([r.standard_normal((n_upd * self.steps, nb)) for r in self.rngs])
        self.extra = None if extra_draws is None else extra_draws(self.rngs)
        bm_path, bm_last = fogm_path(bm0, drive, *fogm_coefficients(spec.bias_sigma, spec.bias_tau, c * self.dt))
        self.bm_truth = np.concatenate([bm_path, bm_last[:, None]], axis=1)  # (R, T, 3)
        self._imu = ImuBlocks(imu, nu_true, om_true, ba, bg, self.rngs)
        ba_k, bg_k = self._imu.first[2], self._imu.first[3]

        self.truth = self.truth_at(0, ba_k[:, 0], bg_k[:, 0])
        self.nav = corrupt_state(self.truth, dx0, L)  # x_hat = m(x, dx0), thesis eq. A.5
        self.P = np.broadcast_to(np.diag(spec.p0_sigma**2), (R, L.n, L.n)).copy()
        T_out = len(self.t_out)
        self.err = np.empty((R, T_out, L.n))
        self.sig = np.empty((R, T_out, L.n))
        self.nees = np.empty((R, T_out))
        self._history = None
        self.record(0, self.truth)

    def truth_at(self, j: int, ba_now, bg_now) -> NavState:
        """Truth NavState of every run at output epoch j (IMU biases at that epoch, measurement biases)."""
        R, tr = self.R, self.truth_out
        return NavState(p=np.broadcast_to(tr.position[j], (R, 3)).copy(), v=np.broadcast_to(tr.velocity[j], (R, 3)).copy(),
                        q=np.broadcast_to(tr.quaternion[j], (R, 4)).copy(), ba=ba_now, bg=bg_now, bm=self.bm_truth[:, j])

    def record(self, j: int, truth_now: NavState) -> None:
        e = error_state(truth_now, self.nav, self.layout)
        self.err[:, j] = e
        self.sig[:, j] = np.sqrt(np.einsum("rii->ri", self.P))
        self.nees[:, j] = normalized_squared(e, self.P)

    def fly_interval(self, u: int) -> dict:
        """INS + covariance over update interval u; records every epoch but the last (recorded by
        :meth:`after_update`). Returns {"j": index of the last epoch, "t": (steps + 1,) epochs, "p", "v":
        (R, steps + 1, 3) the INS position and velocity at them, "q": (R, steps + 1, 4) its attitude, "f_mean": (R, 3)
        f^n of the last step}; with ``interval_transition`` also "Phi", "Qd": (R, n, n) transition and process noise
        over the interval."""
        m, c, steps = self.m, self.c, self.steps
        k0 = u * m
        nu_blk, om_blk, ba_blk, bg_blk = self._imu.next(m)
        p_hist = np.empty((self.R, steps + 1, 3))
        v_hist = np.empty((self.R, steps + 1, 3))
        q_hist = np.empty((self.R, steps + 1, 4))
        p_hist[:, 0], v_hist[:, 0], q_hist[:, 0] = self.nav.p, self.nav.v, self.nav.q
        f_mean = None
        if self.interval_transition:
            n = self.layout.n
            Phi_i, Qd_i = np.broadcast_to(np.eye(n), (self.R, n, n)).copy(), np.zeros((self.R, n, n))
        for s in range(steps):
            a, b = s * c, (s + 1) * c
            q_start = self.nav.q
            self.nav, f_mean, self._history = mechanize(
                self.nav, self.t_imu[k0 + a:k0 + b + 1], nu_blk[:, a:b + 1], om_blk[:, a:b + 1],
                self.spec.filter_imu.tau_accel, self.spec.filter_imu.tau_gyro, self.spec.bias_tau, self._history,
                earth_rate=self.spec.filter_earth)
            q_cov = q_start if self.attitude == "start" else quat_normalize(q_start + self.nav.q)
            Phi, Qd = self.model.discretize(quat_to_dcm(q_cov), f_mean, c * self.dt)
            self.P = propagate_covariance(self.P, Phi, Qd)
            if self.interval_transition:
                Phi_i, Qd_i = Phi @ Phi_i, propagate_covariance(Qd_i, Phi, Qd)
            j = u * steps + s + 1
            p_hist[:, s + 1], v_hist[:, s + 1], q_hist[:, s + 1] = self.nav.p, self.nav.v, self.nav.q
            if s < steps - 1:
                self.record(j, self.truth_at(j, ba_blk[:, b], bg_blk[:, b]))
        j = (u + 1) * steps
        self.truth = self.truth_at(j, ba_blk[:, m], bg_blk[:, m])
        out = {"j": j, "t": self.t_out[u * steps:j + 1], "p": p_hist, "v": v_hist, "q": q_hist, "f_mean": f_mean}
        if self.interval_transition:
            out.update(Phi=Phi_i, Qd=Qd_i)
        return out

    def after_update(self, j: int, dx, P_post) -> None:
        """Feed the error-state estimate back into the INS (eq. 3.23), take the posterior covariance, restart
        the three-point integration rule and record epoch j."""
        self.nav = apply_feedback(self.nav, dx, self.layout)
        self.P = P_post
        self._history = None
        self.record(j, self.truth)

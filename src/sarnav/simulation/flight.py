"""The simulated world that every error-state Monte Carlo kind flies (``telemetry``, ``rda-nav``, ``quality-nav``).

The world holds the truth (trajectory, truth IMU, measurement biases, initial-error draw) and is the navigator's
source of IMU samples; the filter itself is a :class:`~sarnav.navigation.Navigator`, which never sees the truth.
The world compares the navigator's estimate with the truth (error, 1-sigma, NEES at every output epoch).

The truth sensor and the filter's belief about it are two objects (pyins' practice): :class:`ImuSpec` ``truth``
corrupts the true kinematics (white noise + FOGM biases, ``sensors.ImuModel``); ``filter`` is what the INS and the
error model assume (bias decay in the mechanization, F / Q / P0 of the biases). They are equal unless a scenario
sets ``[filter.imu]`` (a model-mismatch study).

One batch of runs flies the same analytic truth; per run, from its own Generator and in this order: IMU
biases (6), measurement biases and initial error (k + n, k = 3 or 0 measurement biases), the measurement-bias drive (one 3-vector per
covariance step), the kind's extra draws (``extra_draws``), IMU sample 0; then per update interval the IMU
block. Between updates the navigator's strapdown INS and covariance advance through the truth IMU's block
(``Navigator.propagate``); the error, the filter 1-sigma and the NEES are recorded at every output epoch. A kind
makes its measurements at the end of each interval, fuses them through ``flight.navigator.update`` (or
``update_mixture``) and calls :meth:`ErrorStateFlight.record_update`.

``covariance_attitude`` ("start" or "mid") is the navigator's (``sarnav.navigation.navigator``). With
``interval_transition=True`` :meth:`ErrorStateFlight.fly_interval` also returns the transition and process noise of
the whole interval (the product of the steps'), for filters that carry more than one covariance (Gaussian sums).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from sarnav.errors import ConfigError
from sarnav.filters import ErrorStateLayout, corrupt_state, error_state, normalized_squared
from sarnav.frames import earth_rate_tangent
from sarnav.ins import NavState
from sarnav.navigation import Interval, Navigator, error_model
from sarnav.navigation.navigator import COVARIANCE_ATTITUDES
from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path
from sarnav.sensors.imu import ImuBlocks, ImuModel, ImuSpec
from sarnav.trajectory.base import Trajectory

__all__ = ["ErrorStateFlight", "FlightSpec", "ImuSpec", "COVARIANCE_ATTITUDES"]


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

    @staticmethod
    def earth_fields(latitude: float, rotation: bool, modelled: bool) -> dict:
        """``earth_rate`` and ``filter_earth_rate`` of a flight over an Earth that rotates (omega_ie^t at ``latitude``
        [rad], ``frames.earth_rate_tangent``) or not (None), and that the filter models (the same rate) or not
        (None: a flat-Earth filter)."""
        rate = earth_rate_tangent(latitude) if rotation else None
        return {"earth_rate": rate, "filter_earth_rate": rate if modelled else None}

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
    """Truth, the truth IMU, the navigator and the error record of one batch of runs (module docstring).

    Attributes a kind reads: ``navigator`` (the filter: ``nav``, ``P``, ``model``), ``truth`` (NavState at the last
    epoch flown), ``bm_truth`` (R, T, 3) the truth measurement biases at every output epoch, ``t_out``,
    ``truth_out``, ``rngs``, ``extra`` (what ``extra_draws`` returned), ``err``, ``sig``, ``nees``, ``imu_block``
    (after :meth:`fly_interval`: the samples the navigator was handed, ``(times (m + 1,), nu, omega, ba, bg)``, each
    (R, m + 1, 3) but the times; ba, bg the truth biases at the samples: what a recording of the flight stores);
    ``nav``, ``P`` and ``model`` read the navigator's.
    """

    def __init__(self, spec: FlightSpec, layout: ErrorStateLayout, seeds,
                 extra_draws: Callable | None = None, covariance_attitude: str = "mid", interval_transition: bool = False):
        if covariance_attitude not in COVARIANCE_ATTITUDES:
            raise ConfigError("covariance_attitude", f"must be one of {COVARIANCE_ATTITUDES}, got {covariance_attitude!r}")
        m, c = int(spec.samples_per_update), int(spec.samples_per_step)
        if c < 1 or m % c:
            raise ConfigError("samples_per_step", f"must divide samples_per_update = {m}, got {c}")
        self.spec, self.layout = spec, layout
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
        model = error_model(L, fi, spec.bias_sigma, spec.bias_tau, earth_rate=spec.filter_earth)
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
        nav0 = corrupt_state(self.truth, dx0, L)  # x_hat = m(x, dx0), thesis eq. A.5
        P0 = np.broadcast_to(np.diag(spec.p0_sigma**2), (R, L.n, L.n)).copy()
        self.navigator = Navigator(nav0, P0, model, L, tau_accel=fi.tau_accel, tau_gyro=fi.tau_gyro,
                                   bias_tau=spec.bias_tau, earth_rate=spec.filter_earth,
                                   covariance_attitude=covariance_attitude)
        T_out = len(self.t_out)
        self.err = np.empty((R, T_out, L.n))
        self.sig = np.empty((R, T_out, L.n))
        self.nees = np.empty((R, T_out))
        self.record(0, self.truth)

    @property
    def nav(self) -> NavState:
        """The navigator's estimate now."""
        return self.navigator.nav

    @property
    def P(self) -> np.ndarray:
        """The navigator's covariance now."""
        return self.navigator.P

    @property
    def model(self):
        """The navigator's error model."""
        return self.navigator.model

    def truth_at(self, j: int, ba_now, bg_now) -> NavState:
        """Truth NavState of every run at output epoch j (IMU biases at that epoch, measurement biases)."""
        R, tr = self.R, self.truth_out
        return NavState(p=np.broadcast_to(tr.position[j], (R, 3)).copy(), v=np.broadcast_to(tr.velocity[j], (R, 3)).copy(),
                        q=np.broadcast_to(tr.quaternion[j], (R, 4)).copy(), ba=ba_now, bg=bg_now, bm=self.bm_truth[:, j])

    def record(self, j: int, truth_now: NavState, estimate=None) -> None:
        """Error, 1-sigma and NEES at output epoch j of ``estimate`` (nav, P), default the navigator's now."""
        nav, P = (self.navigator.nav, self.navigator.P) if estimate is None else estimate
        e = error_state(truth_now, nav, self.layout)
        self.err[:, j] = e
        self.sig[:, j] = np.sqrt(np.einsum("rii->ri", P))
        self.nees[:, j] = normalized_squared(e, P)

    def fly_interval(self, u: int) -> Interval:
        """The navigator through the truth IMU's block of update interval u; records every epoch but the last
        (recorded by :meth:`record_update`). Returns the navigator's :class:`~sarnav.navigation.Interval` (with
        ``interval_transition``, its ``Phi`` and ``Qd``); ``self.j`` is the index of its last epoch."""
        m, steps = self.m, self.steps
        k0 = u * m
        nu_blk, om_blk, ba_blk, bg_blk = self._imu.next(m)
        self.imu_block = (self.t_imu[k0:k0 + m + 1], nu_blk, om_blk, ba_blk, bg_blk)
        iv = self.navigator.propagate(self.t_imu[k0:k0 + m + 1], nu_blk, om_blk, self.c,
                                      transition=self.interval_transition, step_seconds=self.c * self.dt)
        for s in range(steps - 1):
            j, b = u * steps + s + 1, (s + 1) * self.c
            self.record(j, self.truth_at(j, ba_blk[:, b], bg_blk[:, b]), iv.estimates[s])
        self.j = (u + 1) * steps
        self.truth = self.truth_at(self.j, ba_blk[:, m], bg_blk[:, m])
        return replace(iv, t=self.t_out[u * steps:self.j + 1])  # the step epochs on the output clock (i c dt)

    def record_update(self) -> None:
        """Record the last epoch flown (after the kind's update, or with none)."""
        self.record(self.j, self.truth)

    def after_update(self, j: int, dx, P_post) -> None:
        """Feed a correction back through the navigator (``Navigator.feedback``) and record epoch j."""
        self.navigator.feedback(dx, P_post)
        self.record(j, self.truth)

"""IMU error model: white noise plus first-order Gauss-Markov biases (thesis eqs. 3.3-3.4).

``nu_meas = nu + b_a + n_nu``, ``omega_meas = omega + b_g + n_omega``; no scale factor,
misalignment or quantisation (as in the sources). White noise of root-PSD ``sigma`` (VRW, ARW) is
sampled as ``sigma / sqrt(dt) N(0, 1)`` (thesis footnote L1857, with the 1-sigma value); biases are
FOGM processes (``sarnav.sensors.gauss_markov``) started from N(0, sigma_ss^2).

Grades (3-sigma source values, converted once here with ``sarnav.units``):

================== ================= ============== =============== ================
preset             VRW [m/s/sqrt hr] accel bias [g] ARW [deg/sqrt hr] gyro bias [deg/hr]
================== ================= ============== =============== ================
consumer           0.6               0.01           0.7             10    (thesis Table 3.2)
tactical           0.06              0.001          0.07            1     (thesis Table 3.2, A.8)
navigation         0.006             0.0001         0.007           0.1   (thesis Table 3.2)
nav-paper-tactical 0.1               0.01           0.1             5     (NAVIGATION paper Tables 1-2)
================== ================= ============== =============== ================

The NAVIGATION paper's Table 2 gives only the white-noise terms; its bias figures are the initial
3-sigma uncertainties of Table 1 (sim), used here as the steady-state sigma.

Named parts of Sun (2022) Tables 5.2 and 5.4 (datasheet 1-sigma figures, stored x3 like the rest; the unit
decisions of gap G23, docs/particles.md):

================== ===================== ===================== ================== ==================
preset             VRW as printed        accel bias stability  ARW                gyro bias stab.
================== ===================== ===================== ================== ==================
novatel-isa-100c   "100 ug/sqrt(hr)"     1250 ug               0.012 deg/sqrt(hr) 0.5 deg/hr
                   -> read 100 ug/sqrt(Hz) = 0.0589 m/s/sqrt(hr) (as printed)
adis16465          0.012 m/s/sqrt(hr)    3.6e-3 m/s^2 = 367 ug 0.15 deg/sqrt(hr)  2.0 deg/hr
                   (as printed)          (as printed; datasheet possibly 3.6 ug)
================== ===================== ===================== ================== ==================

The source fed these to gnss-ins-sim with no correlation time, where a "bias stability" is drawn as white
noise of that standard deviation at every sample (gnss-ins-sim ``bias_drift`` with an infinite correlation
time); an ``ImuModel`` with ``tau`` much shorter than the sample interval draws exactly that process.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from sarnav import units
from sarnav.errors import ConfigError, InputDataError, require_finite, require_positive
from sarnav.sensors.gauss_markov import fogm_coefficients, fogm_path


@dataclass(frozen=True)
class ImuGrade:
    """1-sigma IMU error figures in SI.

    Attributes
    ----------
    name : preset name or "custom".
    vrw : velocity random walk [m/s/sqrt(s)] (accelerometer white-noise root-PSD).
    accel_bias : accelerometer bias steady-state sigma [m/s^2].
    arw : angle random walk [rad/sqrt(s)].
    gyro_bias : gyro bias steady-state sigma [rad/s].
    """

    name: str
    vrw: float
    accel_bias: float
    arw: float
    gyro_bias: float

    @classmethod
    def from_three_sigma(cls, name, vrw_3sigma, accel_bias_3sigma, arw_3sigma, gyro_bias_3sigma):
        """Build from 3-sigma figures in source units: m/s/sqrt(hr), g, deg/sqrt(hr), deg/hr."""
        vals = {
            "vrw_3sigma": vrw_3sigma,
            "accel_bias_3sigma": accel_bias_3sigma,
            "arw_3sigma": arw_3sigma,
            "gyro_bias_3sigma": gyro_bias_3sigma,
        }
        for k, v in vals.items():
            require_finite(f"imu.{k}", v, lo=0.0)
        s = units.three_sigma_to_sigma
        return cls(
            name=name,
            vrw=float(s(units.m_per_s_per_sqrt_hr_to_si(vrw_3sigma))),
            accel_bias=float(s(units.g_to_m_per_s2(accel_bias_3sigma))),
            arw=float(s(units.deg_per_sqrt_hr_to_rad_per_sqrt_s(arw_3sigma))),
            gyro_bias=float(s(units.deg_per_hr_to_rad_per_s(gyro_bias_3sigma))),
        )


#: 3-sigma source figures (VRW m/s/sqrt hr, accel bias g, ARW deg/sqrt hr, gyro bias deg/hr)
GRADE_THREE_SIGMA = {
    "consumer": (0.6, 0.01, 0.7, 10.0),  # thesis Table 3.2
    "tactical": (0.06, 0.001, 0.07, 1.0),  # thesis Table 3.2 / A.8
    "navigation": (0.006, 0.0001, 0.007, 0.1),  # thesis Table 3.2
    "nav-paper-tactical": (0.1, 0.01, 0.1, 5.0),  # NAVIGATION paper Table 2 (noise) + Table 1 (biases)
    # Sun (2022) Table 5.2, 1-sigma x 3; G23: VRW "100 ug/sqrt(hr)" read as 100 ug/sqrt(Hz) (NovAtel quotes
    # accelerometer noise per sqrt(Hz)): 100e-6 * 9.81 m/s^2/sqrt(Hz) * 60 = 0.0589 m/s/sqrt(hr)
    "novatel-isa-100c": (3 * 100e-6 * units.G0 * 60.0, 3 * 1250e-6, 3 * 0.012, 3 * 0.5),
    # Sun (2022) Table 5.4, 1-sigma x 3, as printed (accel bias stability 3.6e-3 m/s^2 = 3.67e-4 g)
    "adis16465": (3 * 0.012, 3 * 3.6e-3 / units.G0, 3 * 0.15, 3 * 2.0),
}

IMU_GRADES = {name: ImuGrade.from_three_sigma(name, *v) for name, v in GRADE_THREE_SIGMA.items()}


def imu_grade(name: str) -> ImuGrade:
    """Return the preset named ``name`` or raise ConfigError listing the valid names."""
    try:
        return IMU_GRADES[name]
    except KeyError:
        raise ConfigError("imu.grade", f"must be one of {sorted(IMU_GRADES)} or 'custom', got {name!r}") from None


@dataclass(frozen=True)
class ImuSpec:
    """An IMU error model: 1-sigma figures (``grade``) and bias correlation times [s] (SI). The truth sensor
    (``sarnav.simulation``) and the filter's belief about it (``sarnav.navigation``) are each one of these."""

    grade: ImuGrade
    tau_accel: float
    tau_gyro: float


class ImuModel:
    """White noise + FOGM biases, batched over runs with one Generator per run.

    Parameters
    ----------
    grade : the 1-sigma figures.
    rate_hz : sample rate [Hz], > 0.
    tau_accel, tau_gyro : bias correlation times [s], > 0.
    """

    def __init__(self, grade: ImuGrade, rate_hz: float, tau_accel: float, tau_gyro: float):
        for k in ("vrw", "accel_bias", "arw", "gyro_bias"):
            require_finite(f"imu.{k}", getattr(grade, k), lo=0.0)
        self.grade = grade
        self.rate_hz = require_positive("imu.rate_hz", rate_hz, "Hz")
        self.tau_accel = require_positive("imu.tau_accel", tau_accel, "s")
        self.tau_gyro = require_positive("imu.tau_gyro", tau_gyro, "s")
        self.dt = 1.0 / self.rate_hz
        self._coef_a = fogm_coefficients(grade.accel_bias, self.tau_accel, self.dt)
        self._coef_g = fogm_coefficients(grade.gyro_bias, self.tau_gyro, self.dt)

    def initial_biases(self, rngs: Sequence[np.random.Generator]):
        """Draw b_a, b_g ~ N(0, sigma_ss^2) per run: returns two (R, 3) arrays (6 draws per run)."""
        w = np.stack([g.standard_normal(6) for g in rngs]) if len(rngs) else np.zeros((0, 6))
        return self.grade.accel_bias * w[:, :3], self.grade.gyro_bias * w[:, 3:]

    def measure(self, nu, omega, ba, bg, rngs: Sequence[np.random.Generator]):
        """Corrupt N consecutive true samples for every run.

        Parameters
        ----------
        nu, omega : (N, 3) or (R, N, 3) true specific force [m/s^2] and rate [rad/s].
        ba, bg : (R, 3) biases at the first of the N samples.
        rngs : one Generator per run; each draws a (4, N, 3) unit-normal block
            (accel noise, gyro noise, accel-bias drive, gyro-bias drive).

        Returns
        -------
        nu_meas, omega_meas : (R, N, 3); ba_path, bg_path : (R, N, 3) true biases at the samples;
        ba_next, bg_next : (R, 3) biases at the sample after the last.
        """
        nu = np.asarray(nu, dtype=float)
        omega = np.asarray(omega, dtype=float)
        if nu.shape[-1] != 3 or nu.shape != omega.shape:
            raise InputDataError("imu.samples", f"nu and omega must both be (..., N, 3), got {nu.shape}, {omega.shape}")
        if not (np.all(np.isfinite(nu)) and np.all(np.isfinite(omega))):
            raise InputDataError("imu.samples", "true specific force / angular rate contain NaN or inf")
        n = nu.shape[-2]
        w = np.stack([g.standard_normal((4, n, 3)) for g in rngs])
        root_dt = np.sqrt(self.dt)
        ba_path, ba_next = fogm_path(ba, w[:, 2], *self._coef_a)
        bg_path, bg_next = fogm_path(bg, w[:, 3], *self._coef_g)
        nu_meas = nu + ba_path + (self.grade.vrw / root_dt) * w[:, 0]
        om_meas = omega + bg_path + (self.grade.arw / root_dt) * w[:, 1]
        return nu_meas, om_meas, ba_path, bg_path, ba_next, bg_next


class ImuBlocks:
    """Corrupted IMU samples of a batch of runs, delivered block by block.

    The first sample is measured at construction (so the random draws keep their order: the caller
    builds this where it would measure sample 0); each :meth:`next` measures the following ``m`` samples
    and returns blocks of ``m + 1`` samples that start with the previous block's last sample, as the
    strapdown integration over [t_k, t_k + m dt] needs.

    Attributes
    ----------
    first : (nu, omega, ba_path, bg_path), each (R, 1, 3): sample 0 and the true biases there.
    """

    def __init__(self, imu: ImuModel, nu_true, omega_true, ba, bg, rngs: Sequence[np.random.Generator]):
        self.imu, self.nu_true, self.omega_true, self.rngs = imu, nu_true, omega_true, rngs
        *self.first, self._ba, self._bg = imu.measure(nu_true[:1], omega_true[:1], ba, bg, rngs)
        self.first = tuple(self.first)
        self._last = self.first
        self._k = 0

    def next(self, m: int):
        """(nu, omega, ba_path, bg_path), each (R, m + 1, 3), for samples k .. k + m."""
        k = self._k
        new = self.imu.measure(self.nu_true[k + 1:k + m + 1], self.omega_true[k + 1:k + m + 1],
                               self._ba, self._bg, self.rngs)
        blocks = tuple(np.concatenate([prev[:, -1:], cur], axis=1) for prev, cur in zip(self._last, new[:4]))
        self._last, self._ba, self._bg, self._k = blocks, new[4], new[5], k + m
        return blocks

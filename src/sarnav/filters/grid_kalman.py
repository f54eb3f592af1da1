"""The linear Kalman filter of Sun (2022) eqs. 3.1-3.15 and the aided (reset) INS, on the up-sampled grid.

State ``x = [p (3); v (3)]`` in local metres (NED; curvilinear about the origin in a geodetic frame, gap G6),
acceleration as the control input (eq. 3.10, stacked per axis, extraction §2.8)::

    x_k = F x_{k-1} + B a,   F = [[I, dt I], [0, I]],   B = [dt^2/2 I; dt I]        (3.9-3.10)
    P_k = F P_{k-1} F^T + Q_k                                                        (3.11)
    S = H P H^T + R,  K = P H^T S^-1,  x += K (y - H x),  P = (I - K H) P (I - K H)^T + K R K^T   (3.12-3.15)

with ``H = [I 0]`` (GPS position only, L644), the update only at fix epochs (L648) and the predicted P in S
(the printed 3.12 uses P_{k-1}, gap G7). ``a = 1/2 (C_b^n(k-1) + C_b^n(k)) f^b + g^n`` from the latest IMU
sample (zero-order hold, L750) and the filter's own attitude, propagated with the gyro (eq. 2.51; Earth and
transport rate from the filter's estimate in a geodetic frame). Gravity: constant in a flat frame, WGS-84
normal gravity at the estimate in a geodetic one. The linear model has no Coriolis or transport-rate terms:
that is the source's KF, and what the particle filter's geodetic model adds (claim T11). ``coriolis=True``
(geodetic frames) adds them to the control input, ``a -= (2 omega_ie^n + omega_en^n) x v`` at the estimate
(Groves 2008 eq. 5.54): the same linear F and Q, a consistent KF over the rotating Earth (docs/particles.md).

Q: white acceleration noise of PSD ``accel_psd`` [m^2/s^3] per axis, exact over each sub-step
``Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]`` (these compose exactly, so splitting an IMU interval into
sub-steps leaves P at the IMU epochs unchanged, T10). The update is ``sarnav.filters.update.fuse`` (Joseph form).

``mode="reset"`` is the aided INS without a filter (§3.3, L721-726): dead reckoning with the same model and
the position set to the fix at each fix epoch (the source's sawtooth).
"""

from __future__ import annotations


import math

import numba
import numpy as np

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters.prediction import Prediction
from sarnav.filters.update import fuse
from sarnav.filters.pulse_grid import GridFilter, ImuStream, NavFrame
from sarnav.frames.earth import OMEGA_EARTH
from sarnav.ins.geodetic import gravity_scalar, attitude_step_inplace, navigation_rate_inplace, rotate_to_nav


@numba.njit(cache=True)
def linear_acceleration(x, q, f_b, w_b, dt, world, a_out):
    """Advance the attitude q over dt and return in a_out the NED acceleration f^n + g^n of the linear model.
    world = (geodetic, lat0, h0, scale_n, omega_e, g_flat[, coriolis])."""
    geodetic, lat0, h0, scale_n, omega_e, g_flat = world[0], world[1], world[2], world[3], world[4], world[5]
    coriolis = world.size > 6 and world[6] > 0.5
    a_out[:] = 0.0
    rotate_to_nav(q, f_b, a_out)
    if geodetic > 0.5:
        tmp = np.empty(6)
        tmp[0], tmp[1], tmp[2] = lat0 + x[0] / scale_n, 0.0, h0 - x[2]
        tmp[3], tmp[4], tmp[5] = x[3], x[4], x[5]
        w_n = np.empty(3)
        navigation_rate_inplace(tmp, omega_e, w_n)
        g = gravity_scalar(tmp[0], tmp[2])
    else:
        w_n = np.zeros(3)
        g = g_flat
    attitude_step_inplace(q, w_b, w_n, dt)
    rotate_to_nav(q, f_b, a_out)
    for i in range(3):
        a_out[i] *= 0.5
    a_out[2] += g
    if coriolis and geodetic > 0.5:  # (2 omega_ie + omega_en) x v = (omega_in + omega_ie) x v
        c0 = w_n[0] + omega_e * math.cos(tmp[0])
        c1 = w_n[1]
        c2 = w_n[2] - omega_e * math.sin(tmp[0])
        a_out[0] -= c1 * x[5] - c2 * x[4]
        a_out[1] -= c2 * x[3] - c0 * x[5]
        a_out[2] -= c0 * x[4] - c1 * x[3]


@numba.njit(cache=True)
def _linear_block(x, P, q, t, held, f_b, w_b, qa, world, with_cov, out_x, out_q):
    """Propagate every run over epochs t[0..S] (sub-interval k holds IMU sample held[k]); records states."""
    a = np.empty(3)
    for r in range(x.shape[0]):
        out_x[r, 0] = x[r]
        out_q[r, 0] = q[r]
        for k in range(t.size - 1):
            dt = t[k + 1] - t[k]
            j = held[k]
            linear_acceleration(x[r], q[r], f_b[r, j], w_b[r, j], dt, world, a)
            for i in range(3):
                x[r, i] += x[r, i + 3] * dt + 0.5 * a[i] * dt * dt
                x[r, i + 3] += a[i] * dt
            if with_cov:
                Pr = P[r]
                for i in range(6):  # P F^T: column i += dt * column i+3
                    for c in range(3):
                        Pr[i, c] += dt * Pr[i, c + 3]
                for c in range(6):  # F (P F^T): row i += dt * row i+3
                    for i in range(3):
                        Pr[i, c] += dt * Pr[i + 3, c]
                for i in range(3):
                    Pr[i, i] += qa[i] * dt ** 3 / 3.0
                    Pr[i, i + 3] += qa[i] * dt * dt / 2.0
                    Pr[i + 3, i] += qa[i] * dt * dt / 2.0
                    Pr[i + 3, i + 3] += qa[i] * dt
            out_x[r, k + 1] = x[r]
            out_q[r, k + 1] = q[r]


def world_parameters(frame: NavFrame, earth_rate: bool = True, coriolis: bool = False) -> np.ndarray:
    """Numba-friendly description of ``frame``: (geodetic, lat0, h0, R_N0 + h0, omega_e, g_flat, coriolis)."""
    scale_n = frame.scales()[0] if frame.geodetic else 1.0
    return np.array([float(frame.geodetic), frame.origin[0], frame.origin[2], scale_n,
                     OMEGA_EARTH if (frame.geodetic and earth_rate) else 0.0, frame.gravity, float(bool(coriolis))])


def check_three_nonnegative(field, value):
    v = np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ConfigError(field, f"must be 3 finite values >= 0, got {value!r}")
    return v


class GridKalmanFilter(GridFilter):
    """KF (eqs. 3.1-3.15) or aided reset INS on the up-sampled grid, batched over R runs.

    Parameters
    ----------
    frame : the world (:class:`~sarnav.filters.pulse_grid.NavFrame`).
    accel_psd : white-acceleration PSD per axis [m^2/s^3] (Q of eq. 3.11; gap G7).
    mode : ``"kalman"`` or ``"reset"`` (aided INS without a filter).
    coriolis : add the Coriolis and transport-rate acceleration to the control input (geodetic frames; module
        docstring); False is the source's model.
    """

    def __init__(self, frame: NavFrame, accel_psd=1e-2, mode: str = "kalman", coriolis: bool = False):
        if mode not in ("kalman", "reset"):
            raise ConfigError("kf.mode", f"must be 'kalman' or 'reset', got {mode!r}")
        self.frame, self.mode = frame, mode
        self.accel_psd = check_three_nonnegative("kf.accel_psd", accel_psd)
        if not isinstance(coriolis, bool):
            raise ConfigError("kf.coriolis", f"must be a boolean, got {coriolis!r}")
        if coriolis and not frame.geodetic:
            raise ConfigError("kf.coriolis", "needs a geodetic NavFrame (the flat frame has no Earth rate)")
        self._world = world_parameters(frame, coriolis=coriolis)

    def initialize(self, t0, position, velocity, quaternion, cov=None):
        """State at ``t0``: ``position`` (R, 3) native, ``velocity`` (R, 3) NED, ``quaternion`` (R, 4);
        ``cov`` (6, 6) or (R, 6, 6) [m^2, m^2/s^2] (required in kalman mode)."""
        position = np.atleast_2d(np.asarray(position, dtype=float))
        runs = position.shape[0]
        self.x = np.concatenate([self.frame.to_local(position), np.atleast_2d(velocity)], -1).astype(float)
        self.q = np.array(np.broadcast_to(quaternion, (runs, 4)), dtype=float)
        if self.mode == "kalman":
            if cov is None:
                raise ConfigError("kf.initial_cov", "a (6, 6) initial covariance is required in kalman mode")
            self.P = np.array(np.broadcast_to(np.asarray(cov, dtype=float), (runs, 6, 6)))
        else:
            self.P = np.zeros((runs, 6, 6))
        self._start(t0)
        return self

    def _propagate(self, grid, a, b, imu: ImuStream):
        runs, n = self.x.shape[0], b - a + 1
        out_x, out_q = np.empty((runs, n, 6)), np.empty((runs, n, 4))
        if imu.specific_force.shape[0] != runs:
            raise InputDataError("imu.specific_force", f"has {imu.specific_force.shape[0]} runs, filter has {runs}")
        _linear_block(self.x, self.P, self.q, grid.t[a:b + 1], grid.imu[a:b + 1], imu.specific_force,
                      imu.angular_rate, self.accel_psd, self._world, self.mode == "kalman", out_x, out_q)
        return self.frame.to_native(out_x[..., :3]), out_x[..., 3:], out_q

    def _update(self, z, sigma):
        zl = self.frame.to_local(z)
        if self.mode == "reset":
            self.x[:, :3] = zl
            return
        runs = self.x.shape[0]
        H = np.broadcast_to(np.hstack([np.eye(3), np.zeros((3, 3))]), (runs, 3, 6))
        Rm = np.broadcast_to(np.diag(np.asarray(sigma, dtype=float) ** 2), (runs, 3, 3))
        up = fuse(self.P, Prediction(self.x[:, :3], H, Rm), zl).update  # a position fix: H = [I 0]
        self.P = up.P
        self.x = self.x + up.dx

    def _current(self):
        return self.frame.to_native(self.x[:, :3]), self.x[:, 3:].copy(), self.q.copy()

    def _position_cov(self):
        return self.P[:, :3, :3].copy()

    @property
    def covariance(self) -> np.ndarray:
        """(R, 6, 6) current covariance of [p, v] in local metres."""
        return self.P.copy()


def white_acceleration_q(psd, dt):
    """Discrete Q (6, 6) of white acceleration noise with PSD ``psd`` (3,) over ``dt`` (exact)."""
    psd = np.broadcast_to(np.asarray(psd, dtype=float), (3,))
    Q = np.zeros((6, 6))
    for i in range(3):
        Q[i, i], Q[i, i + 3], Q[i + 3, i], Q[i + 3, i + 3] = (psd[i] * dt**3 / 3, psd[i] * dt**2 / 2,
                                                              psd[i] * dt**2 / 2, psd[i] * dt)
    return Q


__all__ = ["GridKalmanFilter", "white_acceleration_q", "world_parameters"]

"""Orbital navigation state and the paper's ECEF mechanization (Pogorelsky et al. 2022, eqs. 8-11; extraction §2.6).

    a_e  = (T_e^b)^T a_b - 2 w x v_{k-1} + g_l(r_{k-1})                       (8)
    g_l  = g(r_{k-1}) - w x (w x r_{k-1})                                     (9)
    v_k  = v_{k-1} + a_e dt                                                   (10)
    r_k  = r_{k-1} + v_{k-1} dt + 1/2 a_e dt^2                                (11)
    q_mu unchanged

g is point mass + J2 (``frames.gravity``). The spacecraft does not manoeuvre, so a_b = 0 (gap G5: the paper uses no
accelerometer data; its noise is in the process noise): the batched kernel :func:`mechanize` has no a_b input, the
reference step :func:`mechanization_step` takes one. The integrator is first order in dt: at 100 Hz it drifts
~8 m in 600 s from an RK4 truth, at 10 Hz ten times more (extraction §8.2); run it at 100 Hz.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numba
import numpy as np

from sarnav.errors import InputDataError
from sarnav.frames.earth import GM_EARTH, OMEGA_EARTH, OMEGA_EARTH_VECTOR
from sarnav.frames.gravity import J2_COEFF, gravitation_vec, local_gravity

__all__ = ["OrbitalNavState", "mechanization_step", "mechanize", "mech_step"]


@dataclass
class OrbitalNavState:
    """Estimate (or truth) of the spacecraft MEKF for R runs (paper Table 1).

    r : (R, 3) ECEF position [m]; v : (R, 3) ECEF velocity [m/s];
    q_mu : (R, 4) antenna misalignment, Hamilton scalar first, quat_to_dcm(q_mu) = T_mu (nominal -> true antenna).
    """

    r: np.ndarray
    v: np.ndarray
    q_mu: np.ndarray

    def __post_init__(self):
        r, v, q = (np.array(a, dtype=np.float64) for a in (self.r, self.v, self.q_mu))
        if r.ndim != 2 or r.shape[1] != 3 or v.shape != r.shape or q.shape != (r.shape[0], 4):
            raise InputDataError("state", f"need r (R, 3), v (R, 3), q_mu (R, 4); got {r.shape}, {v.shape}, {q.shape}")
        self.r, self.v, self.q_mu = r, v, q

    @property
    def runs(self) -> int:
        return self.r.shape[0]

    def copy(self) -> "OrbitalNavState":
        return replace(self, r=self.r.copy(), v=self.v.copy(), q_mu=self.q_mu.copy())

    def select(self, idx) -> "OrbitalNavState":
        """The runs ``idx`` (a slice or index array) as a new state."""
        return OrbitalNavState(self.r[idx], self.v[idx], self.q_mu[idx])


def mechanization_step(r, v, dt: float, a_b=None, T_eb=None):
    """One step of eqs. 8-11 (numpy reference, batched (R, 3)); returns (r_k, v_k). a_b (R, 3) body-frame
    acceleration with T_eb (R, 3, 3) ECEF -> body, or None for a_b = 0."""
    r = np.asarray(r, dtype=float)
    v = np.asarray(v, dtype=float)
    a = -2.0 * np.cross(OMEGA_EARTH_VECTOR, v) + local_gravity(r)  # eqs. 8-9
    if a_b is not None:
        a = a + np.einsum("...ji,...j->...i", np.asarray(T_eb, float), np.asarray(a_b, float))
    return r + v * dt + 0.5 * a * dt * dt, v + a * dt  # eqs. 11, 10


@numba.njit(cache=True)
def mech_step(r, v, dt, mu, c, omega):
    """Eqs. 8-11 with a_b = 0 on one run, in place on r (3,), v (3,)."""
    gx, gy, gz = gravitation_vec(r[0], r[1], r[2], mu, c)
    w2 = omega * omega
    ax = gx + w2 * r[0] + 2.0 * omega * v[1]  # -2 w x v = 2 w [v_y, -v_x, 0]; -w x (w x r) = w^2 [x, y, 0]
    ay = gy + w2 * r[1] - 2.0 * omega * v[0]
    az = gz
    h = 0.5 * dt * dt
    r[0] += v[0] * dt + h * ax
    r[1] += v[1] * dt + h * ay
    r[2] += v[2] * dt + h * az
    v[0] += ax * dt
    v[1] += ay * dt
    v[2] += az * dt


@numba.njit(cache=True)
def _mechanize_kernel(r, v, dt, n_steps, mu, c, omega):
    for j in range(r.shape[0]):
        for _ in range(n_steps):
            mech_step(r[j], v[j], dt, mu, c, omega)


def mechanize(r, v, dt: float, n_steps: int):
    """``n_steps`` steps of eqs. 8-11 (a_b = 0) for R runs (numba); returns new (r, v) (R, 3)."""
    r = np.array(r, dtype=np.float64, order="C", ndmin=2)
    v = np.array(v, dtype=np.float64, order="C", ndmin=2)
    _mechanize_kernel(r, v, float(dt), int(n_steps), GM_EARTH, J2_COEFF, OMEGA_EARTH)
    return r, v

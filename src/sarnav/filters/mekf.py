"""The spacecraft MEKF (Pogorelsky et al. 2022, §V; extraction seed-002 §2.5-2.6, §2.14): 9 error states
dx = [dr (ECEF, m), dv (ECEF, m/s), dmu (antenna frame, rad)], dx = truth - estimate.

Propagation (eqs. 12-15), with G the gradient of the local gravity g_l (``frames.gravity``, J2 included)::

    P_k = F P F^T + G Q_PSD G^T dt                                        (12)
    F   = [[I + 1/2 G dt^2, I dt, 0], [G dt, I, 0], [0, 0, I]]            (13)   (coriolis=True, gap G7:
          F_rv = I dt - [w x] dt^2, F_vv = I - 2 [w x] dt, the full Jacobian of eqs. 8-11)
    G   = [[-1/2 T_eb^T dt^2, 0], [-T_eb^T dt, 0], [0, -I]]  (9 x 6)    (15)
    Q_PSD = blkdiag(3.5e-11 I3 [m^2/s^3], 3.4e-13 I3 [rad^2/s])           (paper §VI.C)

Q discretisation (gap G6): ``literal_q=True`` is eq. 12 as printed (dt inside G and again outside: position block
q dt^5/4, velocity q dt^3, cross q dt^4/2, misalignment q_mu dt); ``literal_q=False`` is the standard white-noise
acceleration form (q dt^3/3, q dt, q dt^2/2; q_mu dt). Q_PSD is isotropic, so T_eb drops out of G Q G^T.

Misalignment convention (eqs. 29, 40-41): T_mu,true = (I - [dmu x]) T_mu,est; the reset is
q_mu+ = dq(dmu) (x)_Shuster q_mu-, i.e. in sarnav's Hamilton form q_mu+ = rotvec_to_quat(-dmu) (x) q_mu-, normalised.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from sarnav.errors import ConfigError, require_positive
from sarnav.filters.ekf import symmetrize
from sarnav.frames.earth import GM_EARTH, OMEGA_EARTH
from sarnav.frames.gravity import J2_COEFF, gravitation_gradient_fill, local_gravity_gradient
from sarnav.ins.orbital import OrbitalNavState, mech_step
from sarnav.rotations import quat_multiply, quat_normalize, quat_to_rotvec, quat_conjugate, rotvec_to_quat, skew

__all__ = ["STATE_NAMES", "Q_PSD_ACCEL", "Q_PSD_MISALIGNMENT", "MekfModel", "transition_matrix",
           "noise_input_matrix", "process_noise", "propagate", "reset", "error_state", "disperse"]

#: error-state names (results.nc vocabulary): ECEF position, ECEF velocity, misalignment about the antenna axes
STATE_NAMES = ("rX", "rY", "rZ", "vX", "vY", "vZ", "muX", "muY", "muZ")
#: paper §VI.C process-noise PSDs: accelerometer noise [m^2/s^3], misalignment [rad^2/s]
Q_PSD_ACCEL = 3.5e-11
Q_PSD_MISALIGNMENT = 3.4e-13


@dataclass(frozen=True)
class MekfModel:
    """The filter's propagation model: Q_PSD, the G6 and G7 switches, the mechanization step [s]."""

    q_accel: float = Q_PSD_ACCEL
    q_misalignment: float = Q_PSD_MISALIGNMENT
    literal_q: bool = True
    coriolis: bool = False
    dt: float = 0.01

    def __post_init__(self):
        for name in ("q_accel", "q_misalignment"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ConfigError(f"mekf.{name}", f"must be a finite PSD >= 0, got {v!r}")
        require_positive("mekf.dt", self.dt, "s")

    def process_noise(self) -> np.ndarray:
        """Q_d (9, 9) per mechanization step (eq. 12, literal or standard: module docstring)."""
        return process_noise(self.dt, self.q_accel, self.q_misalignment, self.literal_q)


def transition_matrix(r_hat, dt: float, coriolis: bool = False):
    """F (R, 9, 9) of eq. 13 at r_hat (R, 3) (coriolis=True adds the G7 terms)."""
    Gg = local_gravity_gradient(r_hat)
    runs = Gg.shape[0]
    F = np.tile(np.eye(9), (runs, 1, 1))
    W = skew([0.0, 0.0, OMEGA_EARTH]) if coriolis else np.zeros((3, 3))
    F[:, :3, :3] += 0.5 * Gg * dt * dt
    F[:, :3, 3:6] = np.eye(3) * dt - W * dt * dt
    F[:, 3:6, :3] = Gg * dt
    F[:, 3:6, 3:6] -= 2.0 * W * dt
    return F


def noise_input_matrix(T_eb, dt: float):
    """G (R, 9, 6) of eq. 15 from the ADS attitude T_eb (R, 3, 3) (ECEF -> body)."""
    Tt = np.swapaxes(np.asarray(T_eb, dtype=float), -1, -2)
    G = np.zeros(Tt.shape[:-2] + (9, 6))
    G[..., :3, :3] = -0.5 * Tt * dt * dt
    G[..., 3:6, :3] = -Tt * dt
    G[..., 6:, 3:] = -np.eye(3)
    return G


def process_noise(dt: float, q_accel: float, q_mu: float, literal: bool = True):
    """Q_d (9, 9) for one step: literal eq. 12 (G Q G^T dt) or the standard discretisation (G6)."""
    Q = np.zeros((9, 9))
    if literal:
        a, b, c = q_accel * dt**5 / 4.0, q_accel * dt**4 / 2.0, q_accel * dt**3
    else:
        a, b, c = q_accel * dt**3 / 3.0, q_accel * dt**2 / 2.0, q_accel * dt
    for i in range(3):
        Q[i, i], Q[i, 3 + i], Q[3 + i, i], Q[3 + i, 3 + i] = a, b, b, c
        Q[6 + i, 6 + i] = q_mu * dt
    return Q


@numba.njit(cache=True)
def _covariance_step(P, rj, dt, mu, c, omega, coriolis, Qd, Gg, F6, T6, Pn):
    """P <- F P F^T + Qd for one run, F of eq. 13 (only the 6 x 6 r/v block of F differs from I)."""
    gravitation_gradient_fill(rj[0], rj[1], rj[2], mu, c, Gg)
    Gg[0, 0] += omega * omega
    Gg[1, 1] += omega * omega
    for i in range(6):
        for j in range(6):
            F6[i, j] = 1.0 if i == j else 0.0
    for i in range(3):
        for j in range(3):
            F6[i, j] += 0.5 * Gg[i, j] * dt * dt
            F6[3 + i, j] = Gg[i, j] * dt
        F6[i, 3 + i] = dt
    if coriolis:  # F_rv -= [w x] dt^2, F_vv -= 2 [w x] dt; [w x] = [[0, -w, 0], [w, 0, 0], [0, 0, 0]]
        F6[0, 4] += omega * dt * dt
        F6[1, 3] -= omega * dt * dt
        F6[3, 4] += 2.0 * omega * dt
        F6[4, 3] -= 2.0 * omega * dt
    for i in range(6):  # T6 = F6 P[:6, :]
        for j in range(9):
            s = 0.0
            for k in range(6):
                s += F6[i, k] * P[k, j]
            T6[i, j] = s
    for i in range(6):
        for j in range(6):
            s = 0.0
            for k in range(6):
                s += T6[i, k] * F6[j, k]
            Pn[i, j] = s
        for j in range(6, 9):
            Pn[i, j] = T6[i, j]
            Pn[j, i] = T6[i, j]
    for i in range(6, 9):
        for j in range(6, 9):
            Pn[i, j] = P[i, j]
    for i in range(9):
        for j in range(9):
            P[i, j] = 0.5 * (Pn[i, j] + Pn[j, i]) + Qd[i, j]


@numba.njit(cache=True)
def _propagate_kernel(r, v, P, dt, n_steps, mu, c, omega, coriolis, Qd):
    Gg, F6, T6, Pn = np.empty((3, 3)), np.empty((6, 6)), np.empty((6, 9)), np.empty((9, 9))
    for j in range(r.shape[0]):
        for _ in range(n_steps):
            _covariance_step(P[j], r[j], dt, mu, c, omega, coriolis, Qd, Gg, F6, T6, Pn)  # F at r_{k-1}
            mech_step(r[j], v[j], dt, mu, c, omega)


def propagate(state: OrbitalNavState, P, n_steps: int, model: MekfModel):
    """``n_steps`` mechanization steps (eqs. 8-11) and covariance steps (eqs. 12-15) for R runs (numba).

    Returns a new state (q_mu unchanged) and P (R, 9, 9); the inputs are not modified.
    """
    r = np.array(state.r, dtype=np.float64, order="C")
    v = np.array(state.v, dtype=np.float64, order="C")
    P = np.array(P, dtype=np.float64, order="C")
    _propagate_kernel(r, v, P, float(model.dt), int(n_steps), GM_EARTH, J2_COEFF, OMEGA_EARTH, bool(model.coriolis),
                      model.process_noise())
    return OrbitalNavState(r, v, state.q_mu.copy()), P


def reset(state: OrbitalNavState, dx) -> OrbitalNavState:
    """Eqs. 38-41: r+ = r- + dr, v+ = v- + dv, q_mu+ = dq(dmu) (x)_S q_mu- (Hamilton: rotvec_to_quat(-dmu) (x) q_mu-),
    normalised so that |q_mu| = 1 (claim T6). dx (R, 9)."""
    dx = np.asarray(dx, dtype=float)
    q = quat_normalize(quat_multiply(rotvec_to_quat(-dx[:, 6:9]), state.q_mu))
    return OrbitalNavState(state.r + dx[:, :3], state.v + dx[:, 3:6], q)


def error_state(truth: OrbitalNavState, est: OrbitalNavState):
    """dx = truth - estimate (R, 9); dmu exact: T_mu,true = R(dmu)^T T_mu,est, dmu = -rotvec(q_true (x) q_est*)."""
    dmu = -quat_to_rotvec(quat_multiply(truth.q_mu, quat_conjugate(est.q_mu)))
    return np.concatenate([truth.r - est.r, truth.v - est.v, dmu], axis=1)


def disperse(truth: OrbitalNavState, sigma, rngs):
    """Initial estimates: one draw e ~ N(0, diag(sigma^2)) (9 normals, state order) per run from its generator;
    r^ = r - e_r, v^ = v - e_v, q^ = rotvec_to_quat(e_mu) (x) q_true (gap G17), so error_state == e.

    sigma : (9,) 1-sigma [m, m/s, rad]; rngs : R generators. Returns (estimate, e (R, 9)).
    """
    sigma = np.asarray(sigma, dtype=float)
    if sigma.shape != (9,) or not np.all(np.isfinite(sigma)) or np.any(sigma < 0):
        raise ConfigError("initial.sigma", f"must be 9 finite values >= 0 [m, m/s, rad], got {sigma.tolist()}")
    e = np.stack([g.standard_normal(9) for g in rngs]) * sigma
    q = quat_normalize(quat_multiply(rotvec_to_quat(e[:, 6:]), truth.q_mu))
    return OrbitalNavState(truth.r - e[:, :3], truth.v - e[:, 3:6], q), e


def covariance_propagation_reference(P, r_hat, model: MekfModel):
    """One covariance step F P F^T + Q_d with numpy (eqs. 12-13), for tests of the kernel. P (R, 9, 9)."""
    F = transition_matrix(r_hat, model.dt, model.coriolis)
    return symmetrize(F @ P @ np.swapaxes(F, -1, -2)) + model.process_noise()

"""The spacecraft SAR measurement of one image (Pogorelsky et al. 2022, eqs. 16-34; extraction seed-002 §2.11-2.13).

y = [tan az, tan el, slant range, in-track speed] of the image centre pixel r_f (ECEF). With M = T_mu T_b^s T_e^b
(ECEF -> true antenna, eq. 19), r_sf = r_f - r (eq. 18) and r^s = M r_sf = [x_s, y_s, z_s]::

    h = [x_s / z_s, y_s / z_s, |r_sf|, |v|]                                   (20-22)
    H = [[dphi/dr^s (-M), 0, dphi/dr^s [r^s x]], [-r_sf^T/|r_sf|, 0, 0], [0, v^T/|v|, 0]]   (24-32), 4 x 9
    dphi/dr^s = [[1/z_s, 0, -x_s/z_s^2], [0, 1/z_s, -y_s/z_s^2]]              (25)
    H~ = dh/dr_f = [-dphi/dr; -d|r_sf|/dr; 0]                                  (34)  (claim T4)
    B = H~ D H~^T                                                              (33)

The measured angles are zero by construction (the centre pixel is on the boresight, paper L311; gap G10): the
filter predicts them from the *geolocated* r_f,geo = r_f + N(0, D), so their whole noise is B. R = diag(0, 0,
sigma_range^2, sigma_vic^2) (Table 3: 1 m, 0.54 m/s); the prediction's R is R + B (B is measurement noise: the
geolocation error is seen once, paper L413). In-track speed (gap G9): ``velocity_model="speed"`` is |v_ECEF| as in
eq. 22 (the open loop simulates it the same way, L484); ``velocity_model="effective"`` is the velocity a hyperbolic
range-Doppler processor focuses with, the effective radar velocity V_r of the centre pixel (the closed loop's
autofocus measures it)::

    R(eta)^2 = |r(t_m + eta) - r_f|^2 = R0^2 + 2 d.v eta + (|v|^2 + d.a) eta^2 + O(eta^3),   d = r - r_f
    V_r^2 = |v|^2 + d.a,   a = g_l(r) - 2 w x v   (eqs. 8-9 with a_b = 0: the ECEF acceleration, r_f fixed)
    dV_r/dr = (a + G d) / (2 V_r),   dV_r/dv = (v + [w x] d) / V_r,   dV_r/dr_f = -a / (2 V_r)

(G = dg_l/dr of eq. 14; at zero Doppler d.v = 0 and the range history is the hyperbola sqrt(R0^2 + V_r^2 eta^2) to
second order; V_r ~ 7.2 km/s here against |v| ~ 7.6 km/s).

The true centre pixel (open loop, L484) is the near intersection of the true boresight with the WGS-84 ellipsoid
at zero height: p(t) = r + t u, u = M^T e_z, A t^2 + 2 B t + C = 0 with A = (u_x^2 + u_y^2)/a^2 + u_z^2/b^2,
B = (x u_x + y u_y)/a^2 + z u_z/b^2, C = (x^2 + y^2)/a^2 + z^2/b^2 - 1, t = (-B - sqrt(B^2 - A C))/A.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from sarnav.errors import ConfigError, InputDataError, require_positive
from sarnav.filters.prediction import Prediction
from sarnav.measurements.base import Measurement
from sarnav.frames.earth import OMEGA_EARTH, WGS84_A, WGS84_B
from sarnav.frames.gravity import local_gravity, local_gravity_gradient
from sarnav.ins.orbital import OrbitalNavState
from sarnav.rotations import quat_to_dcm, skew

__all__ = ["SarMeasurementNoise", "CenterPixelMeasurement", "boresight_intersection", "simulate_image",
           "MEASUREMENT_NAMES", "MEASUREMENT_UNITS", "VELOCITY_MODELS", "effective_velocity"]

MEASUREMENT_NAMES = ("tan_az", "tan_el", "range", "v_ic")
MEASUREMENT_UNITS = ("1", "1", "m", "m/s")
#: what the fourth component measures (gap G9): eq. 22's |v| or the processor's effective velocity
VELOCITY_MODELS = ("speed", "effective")


def effective_velocity(r, v, r_f):
    """(V_r (R,), dV_r/dr (R, 3), dV_r/dv (R, 3), dV_r/dr_f (R, 3)): the effective radar velocity of the centre pixel
    r_f seen from (r, v) ECEF (module docstring, gap G9)."""
    r, v = np.atleast_2d(np.asarray(r, dtype=float)), np.atleast_2d(np.asarray(v, dtype=float))
    d = r - np.atleast_2d(np.asarray(r_f, dtype=float))
    w = np.array([0.0, 0.0, OMEGA_EARTH])
    a = local_gravity(r) - 2.0 * np.cross(w, v)
    vr2 = np.einsum("ri,ri->r", v, v) + np.einsum("ri,ri->r", d, a)
    if np.any(vr2 <= 0):
        raise InputDataError("state", "effective velocity undefined (|v|^2 + d.a <= 0)")
    vr = np.sqrt(vr2)
    G = local_gravity_gradient(r)
    d_dr = (a + np.einsum("rij,rj->ri", G, d)) / (2.0 * vr[:, None])
    d_dv = (v + np.cross(w, d)) / vr[:, None]
    return vr, d_dr, d_dv, -a / (2.0 * vr[:, None])


@dataclass(frozen=True)
class SarMeasurementNoise:
    """Noise of the spacecraft SAR measurement (paper Table 3, §VI.C).

    sigma_range : slant-range 1-sigma [m] (1 m); sigma_vic : in-track speed 1-sigma [m/s] (0.54 m/s);
    D : (3, 3) ECEF covariance of the geolocated centre pixel [m^2] (paper: "2 to 8 m 1-sigma", values not given;
    gap G8 default 5^2 I, i.e. 5 m per axis).
    """

    sigma_range: float = 1.0
    sigma_vic: float = 0.54
    D: np.ndarray = field(default_factory=lambda: np.eye(3) * 25.0)

    def __post_init__(self):
        require_positive("noise.sigma_range", self.sigma_range, "m")
        require_positive("noise.sigma_vic", self.sigma_vic, "m/s")
        D = np.array(self.D, dtype=np.float64)
        if D.shape != (3, 3) or not np.all(np.isfinite(D)) or not np.allclose(D, D.T):
            raise ConfigError("noise.D", f"must be a symmetric finite 3 x 3 covariance [m^2], got {D.tolist()}")
        try:
            L = np.linalg.cholesky(D)
        except np.linalg.LinAlgError:
            raise ConfigError("noise.D", f"must be positive definite [m^2], got eigenvalues {np.linalg.eigvalsh(D)}") \
                from None
        object.__setattr__(self, "D", D)
        object.__setattr__(self, "_L", L)

    @property
    def R(self) -> np.ndarray:
        """diag(0, 0, sigma_range^2, sigma_vic^2) (4, 4) (Table 3)."""
        return np.diag([0.0, 0.0, self.sigma_range**2, self.sigma_vic**2])

    def draw(self, rngs: Sequence[np.random.Generator]) -> np.ndarray:
        """(R, 5): per run, 5 standard normals from its own generator -> [geolocation error (3) ~ N(0, D) [m],
        range error [m], speed error [m/s]] (fixed order: a run's draws never depend on the batch)."""
        z = np.stack([g.standard_normal(5) for g in rngs])
        return np.concatenate([z[:, :3] @ self._L.T, z[:, 3:4] * self.sigma_range, z[:, 4:5] * self.sigma_vic], 1)


def boresight_intersection(r, T_es):
    """Near intersection of the antenna boresight with the WGS-84 ellipsoid (module docstring) (R, 3) [m].

    r : (R, 3) ECEF position; T_es : (R, 3, 3) ECEF -> antenna DCM (the boresight is its third row).
    Raises ConfigError("antenna.look_angle_deg") when the ray misses the Earth.
    """
    r = np.asarray(r, dtype=float)
    u = np.asarray(T_es, dtype=float)[..., 2, :]
    a2, b2 = WGS84_A**2, WGS84_B**2
    A = (u[:, 0] ** 2 + u[:, 1] ** 2) / a2 + u[:, 2] ** 2 / b2
    B = (r[:, 0] * u[:, 0] + r[:, 1] * u[:, 1]) / a2 + r[:, 2] * u[:, 2] / b2
    C = (r[:, 0] ** 2 + r[:, 1] ** 2) / a2 + r[:, 2] ** 2 / b2 - 1.0
    disc = B * B - A * C
    if np.any(disc < 0) or np.any(C <= 0):
        raise ConfigError("antenna.look_angle_deg", "the boresight misses the WGS-84 ellipsoid (or the spacecraft is "
                          "inside it): reduce the look angle below the Earth's limb (~64 deg from nadir at 700 km)")
    t = (-B - np.sqrt(disc)) / A
    if np.any(t <= 0):
        raise ConfigError("antenna.look_angle_deg", "the boresight points away from the Earth")
    return r + t[:, None] * u


class CenterPixelMeasurement(Measurement):
    """y = [tan az, tan el, slant range, in-track speed] of one image (module docstring), batched over R runs.

    Parameters
    ----------
    T_eb : (R, 3, 3) or (3, 3) ADS attitude at the image time t_m, ECEF -> body (perfect ADS: from the truth).
    T_bs : (3, 3) body -> nominal antenna (``trajectory.orbit.antenna_dcm``).
    r_f : (R, 3) or (3,) ECEF centre pixel the filter uses (geolocated: r_f,geo) [m].
    noise : :class:`SarMeasurementNoise`.
    velocity_model : "speed" (|v|, eq. 22) or "effective" (V_r, gap G9).

    Part of the one measurement contract (:class:`sarnav.measurements.base.Measurement`, generalised there to the
    orbital state): ``predict(state) -> Prediction`` with H w.r.t. dx = truth - estimate of ``filters.mekf``
    (rX rY rZ vX vY vZ muX muY muZ) and R = diag(0, 0, sigma_range^2, sigma_vic^2) + B; no Hessians.
    """

    names = MEASUREMENT_NAMES
    units = MEASUREMENT_UNITS
    layout = None  # the MEKF's 9 error states (filters.mekf.STATE_NAMES), not an ErrorStateLayout
    n_states = 9
    has_hessians = False

    def __init__(self, T_eb, T_bs, r_f, noise: SarMeasurementNoise, velocity_model: str = "speed"):
        if velocity_model not in VELOCITY_MODELS:
            raise InputDataError("velocity_model", f"must be one of {VELOCITY_MODELS}, got {velocity_model!r}")
        self.velocity_model = velocity_model
        self.T_eb = np.asarray(T_eb, dtype=float)
        self.T_bs = np.asarray(T_bs, dtype=float)
        self.r_f = np.atleast_2d(np.asarray(r_f, dtype=float))
        self.noise = noise
        if self.T_bs.shape != (3, 3) or self.T_eb.shape[-2:] != (3, 3) or self.r_f.shape[-1] != 3:
            raise InputDataError("measurement", f"need T_eb (R, 3, 3), T_bs (3, 3), r_f (R, 3); got {self.T_eb.shape}, "
                                 f"{self.T_bs.shape}, {self.r_f.shape}")
        if not np.all(np.isfinite(self.r_f)):
            raise InputDataError("r_f", "the centre pixel must be finite")

    def _geometry(self, state: OrbitalNavState):
        M = quat_to_dcm(state.q_mu) @ self.T_bs @ self.T_eb  # eq. 19, (R, 3, 3)
        r_sf = self.r_f - state.r  # eq. 18
        rs = np.einsum("rij,rj->ri", M, r_sf)
        return M, r_sf, rs

    def _dphi_drs(self, rs):
        x, y, z = rs[:, 0], rs[:, 1], rs[:, 2]
        J = np.zeros((rs.shape[0], 2, 3))
        J[:, 0, 0] = J[:, 1, 1] = 1.0 / z
        J[:, 0, 2] = -x / z**2
        J[:, 1, 2] = -y / z**2
        return J  # eq. 25

    def jacobians(self, state: OrbitalNavState):
        """(z_hat (R, 4), H (R, 4, 9), H~ (R, 4, 3)) at the estimate (eqs. 20-32, 34)."""
        M, r_sf, rs = self._geometry(state)
        rng = np.linalg.norm(r_sf, axis=1)
        J = self._dphi_drs(rs)
        H = np.zeros((state.runs, 4, 9))
        H[:, :2, :3] = -J @ M  # eqs. 24, 26
        H[:, :2, 6:] = J @ skew(rs)  # eqs. 30-31
        H[:, 2, :3] = -r_sf / rng[:, None]  # eq. 27
        Ht = np.zeros((state.runs, 4, 3))
        Ht[:, :3] = -H[:, :3, :3]  # eq. 34 (T4)
        if self.velocity_model == "speed":
            speed = np.linalg.norm(state.v, axis=1)
            H[:, 3, 3:6] = state.v / speed[:, None]  # eq. 28
        else:  # G9: effective velocity of the centre pixel
            speed, H[:, 3, :3], H[:, 3, 3:6], Ht[:, 3] = effective_velocity(state.r, state.v, self.r_f)
        z_hat = np.stack([rs[:, 0] / rs[:, 2], rs[:, 1] / rs[:, 2], rng, speed], axis=1)
        return z_hat, H, Ht

    def predict(self, state: OrbitalNavState) -> Prediction:
        """Prediction with R + B, B = H~ D H~^T (eq. 33)."""
        z_hat, H, Ht = self.jacobians(state)
        B = Ht @ self.noise.D @ np.swapaxes(Ht, 1, 2)
        return Prediction(z_hat, H, self.noise.R + B, names=self.names)

    def simulate(self, truth: OrbitalNavState, rngs=None, noise=None) -> np.ndarray:
        """y (R, 4) from the truth: [0, 0, |r_f,true - r| + n_range, |v| + n_vic] (paper L484, G10).

        r_f,true is the true boresight's ellipsoid intersection. noise : (R, 2) [m, m/s] additive errors, or None
        to draw them (2 normals per run) from ``rngs``.
        """
        T_es = quat_to_dcm(truth.q_mu) @ self.T_bs @ self.T_eb
        r_f_true = boresight_intersection(truth.r, np.broadcast_to(T_es, (truth.runs, 3, 3)))
        if noise is None:
            if rngs is None:
                raise InputDataError("rngs", "need one generator per run (or explicit noise)")
            noise = np.stack([g.standard_normal(2) for g in rngs]) * [self.noise.sigma_range, self.noise.sigma_vic]
        noise = np.asarray(noise, dtype=float)
        y = np.zeros((truth.runs, 4))
        y[:, 2] = np.linalg.norm(r_f_true - truth.r, axis=1) + noise[:, 0]
        speed = (np.linalg.norm(truth.v, axis=1) if self.velocity_model == "speed"
                 else effective_velocity(truth.r, truth.v, r_f_true)[0])
        y[:, 3] = speed + noise[:, 1]
        return y


def simulate_image(truth: OrbitalNavState, T_eb, T_bs, noise: SarMeasurementNoise, rngs, velocity_model: str = "speed"):
    """One open-loop image (paper §VI.B): (measurement built on r_f,geo = r_f + N(0, D), y (R, 4), r_f,true (R, 3)).

    Per run, 5 normals from its generator (``SarMeasurementNoise.draw``): geolocation, range, speed.
    """
    draws = noise.draw(rngs)
    T_es = quat_to_dcm(truth.q_mu) @ np.asarray(T_bs) @ np.asarray(T_eb)
    r_f_true = boresight_intersection(truth.r, np.broadcast_to(T_es, (truth.runs, 3, 3)))
    meas = CenterPixelMeasurement(T_eb, T_bs, r_f_true + draws[:, :3], noise, velocity_model)
    return meas, meas.simulate(truth, noise=draws[:, 3:]), r_f_true

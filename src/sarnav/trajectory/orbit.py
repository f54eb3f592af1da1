"""LEO truth orbit: Keplerian elements, an RK4 propagator with point mass + J2, LVLH attitude and the SAR antenna frame.

Source: Pogorelsky, Zanetti, Chen, Jenkins 2022 (extraction seed-002). Table 2 gives only altitude at the equator
691.5 km, inclination 98.16 deg and eccentricity 0.00118; the rest is gap G1 (see :meth:`KeplerElements.table2`).

Frames: ``frames.earth`` (ECI = ECEF frozen at t = 0; ECEF rotates at omega_ie about z). The truth is integrated in
ECI (no fictitious forces; J2 is zonal, so the same gravitation formula holds) and returned in ECEF.

Attitude (gaps G3/G4): the body is exactly LVLH at every instant (the paper fits a constant body rate to 5 Wahba
solutions; with a perfect ADS shared by truth and filter, exact LVLH is the accepted simplification), the LVLH of the
orbit (inertial velocity v_i = v + w x r, expressed in ECEF; no yaw steering): z_b = -r/|r| (nadir),
y_b = -(r x v_i)/|r x v_i| (right of the orbit), x_b = y_b x z_b (along the inertial velocity). Antenna: look angle theta from nadir toward +y_b (right-looking), squint toward
+x_b; T_b^s rows x_s = [1, 0, 0], y_s = [0, cos th, -sin th], z_s = [0, sin th, cos th] at zero squint (z_s = boresight,
x_s = azimuth, y_s = elevation). The misalignment T_mu rotates the nominal antenna frame into the true one, so
r^s = T_mu T_b^s T_e^b r (paper eq. 19), with T_mu = quat_to_dcm(q_mu) (Hamilton; rotations.py for the paper's
Shuster form).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from sarnav.errors import ConfigError
from sarnav.frames.earth import GM_EARTH, OMEGA_EARTH, WGS84_A, eci_to_ecef
from sarnav.frames.gravity import J2_COEFF, gravitation_vec
from sarnav.rotations import quat_to_dcm

__all__ = ["KeplerElements", "table2_elements", "elements_to_eci", "propagate_rk4_eci", "OrbitTruth",
           "lvlh_dcm", "zero_doppler_dcm", "body_dcm", "STEERING", "antenna_dcm", "ecef_to_antenna_dcm", "right_ascension_of_node", "initial_ecef_state", "MIN_PERIGEE_RADIUS"]

#: smallest accepted perigee radius [m]: the WGS-84 equatorial radius + 100 km (below it the orbit hits the Earth
#: or the atmosphere that the J2-only model ignores)
MIN_PERIGEE_RADIUS = WGS84_A + 100e3


@dataclass(frozen=True)
class KeplerElements:
    """Osculating elements at the epoch (t = 0) in the ECI frame of ``frames.earth``. SI units, radians.

    a : semi-major axis [m]; e : eccentricity; i : inclination; raan : right ascension of the ascending node;
    argp : argument of perigee; nu : true anomaly.
    """

    a: float
    e: float
    i: float
    raan: float
    argp: float
    nu: float

    def __post_init__(self):
        if not (math.isfinite(self.e) and 0.0 <= self.e < 1.0):
            raise ConfigError("orbit.eccentricity", f"must be in [0, 1) for a bound orbit (else it escapes), got {self.e!r}")
        if not math.isfinite(self.a) or self.a * (1.0 - self.e) < MIN_PERIGEE_RADIUS:
            raise ConfigError("orbit.semi_major_axis", f"perigee radius a (1 - e) must be >= {MIN_PERIGEE_RADIUS:.0f} m "
                              f"(the orbit must clear the Earth), got a = {self.a!r} m, e = {self.e!r}")
        for name in ("i", "raan", "argp", "nu"):
            if not math.isfinite(getattr(self, name)):
                raise ConfigError(f"orbit.{name}", f"must be finite [rad], got {getattr(self, name)!r}")

    @property
    def period(self) -> float:
        """Keplerian period 2 pi sqrt(a^3 / mu) [s]."""
        return 2.0 * math.pi * math.sqrt(self.a**3 / GM_EARTH)

    @classmethod
    def table2(cls, altitude: float = 691.5e3, inclination: float = math.radians(98.16), eccentricity: float = 0.00118,
               latitude: float = math.radians(30.15), longitude: float = math.radians(-100.0),
               argp: float = math.radians(90.0)) -> "KeplerElements":
        """Paper Table 2 (ALOS) elements with the gap-G1 choices filled in.

        From Table 2: a = R_e + altitude (691.5 km above the WGS-84 equatorial radius), i = 98.16 deg, e = 0.00118.
        Filled (G1, extraction §6): an ascending pass whose position at t = 0 has geocentric latitude 30.15 deg N and
        longitude 100 deg W (right-looking at 34.3 deg the boresight then lands near Houston, 31 N 95 W, and after
        10 min over northern Canada); argument of perigee 90 deg (frozen-orbit value); RAAN and true anomaly follow.
        """
        u = math.asin(math.sin(latitude) / math.sin(inclination))  # argument of latitude, ascending branch
        raan = longitude - math.atan2(math.cos(inclination) * math.sin(u), math.cos(u))
        return cls(WGS84_A + altitude, eccentricity, inclination, raan, argp, u - argp)


#: :meth:`KeplerElements.table2` under the name the spacecraft experiment and the tests use
table2_elements = KeplerElements.table2


def elements_to_eci(el: KeplerElements, mu: float = GM_EARTH):
    """Position and velocity (3,), (3,) [m, m/s] in ECI from Keplerian elements (perifocal frame rotated by
    R3(-raan) R1(-i) R3(-argp))."""
    p = el.a * (1.0 - el.e**2)
    r_mag = p / (1.0 + el.e * math.cos(el.nu))
    r_pf = np.array([r_mag * math.cos(el.nu), r_mag * math.sin(el.nu), 0.0])
    v_pf = math.sqrt(mu / p) * np.array([-math.sin(el.nu), el.e + math.cos(el.nu), 0.0])
    cO, sO, ci, si, cw, sw = (math.cos(el.raan), math.sin(el.raan), math.cos(el.i), math.sin(el.i),
                              math.cos(el.argp), math.sin(el.argp))
    Q = np.array([[cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
                  [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
                  [sw * si, cw * si, ci]])
    return Q @ r_pf, Q @ v_pf


@numba.njit(cache=True)
def _deriv(s, mu, c, out):
    out[0], out[1], out[2] = s[3], s[4], s[5]
    out[3], out[4], out[5] = gravitation_vec(s[0], s[1], s[2], mu, c)


@numba.njit(cache=True)
def _rk4_kernel(r0, v0, dt, n_steps, every, mu, c):
    runs = r0.shape[0]
    n_out = n_steps // every + 1
    r_out = np.empty((n_out, runs, 3))
    v_out = np.empty((n_out, runs, 3))
    s = np.empty(6)
    tmp = np.empty(6)
    k1, k2, k3, k4 = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for j in range(runs):
        for m in range(3):
            s[m], s[m + 3] = r0[j, m], v0[j, m]
            r_out[0, j, m], v_out[0, j, m] = r0[j, m], v0[j, m]
        for k in range(1, n_steps + 1):
            _deriv(s, mu, c, k1)
            for m in range(6):
                tmp[m] = s[m] + 0.5 * dt * k1[m]
            _deriv(tmp, mu, c, k2)
            for m in range(6):
                tmp[m] = s[m] + 0.5 * dt * k2[m]
            _deriv(tmp, mu, c, k3)
            for m in range(6):
                tmp[m] = s[m] + dt * k3[m]
            _deriv(tmp, mu, c, k4)
            for m in range(6):
                s[m] += dt / 6.0 * (k1[m] + 2.0 * k2[m] + 2.0 * k3[m] + k4[m])
            if k % every == 0:
                for m in range(3):
                    r_out[k // every, j, m], v_out[k // every, j, m] = s[m], s[m + 3]
    return r_out, v_out


def propagate_rk4_eci(r0, v0, dt: float, n_steps: int, every: int = 1, j2: bool = True):
    """Classical RK4 with fixed step ``dt`` [s] under point mass + J2, in ECI, batched over runs.

    r0, v0 : (R, 3) or (3,) [m, m/s]. Returns r, v of shape (n_steps // every + 1, R, 3) (or (K, 3) for (3,) input)
    at t = 0, every*dt, 2*every*dt, ...
    """
    r0 = np.asarray(r0, dtype=np.float64)
    single = r0.ndim == 1
    r0 = np.ascontiguousarray(np.atleast_2d(r0))
    v0 = np.ascontiguousarray(np.atleast_2d(np.asarray(v0, dtype=np.float64)))
    r, v = _rk4_kernel(r0, v0, float(dt), int(n_steps), int(every), GM_EARTH, J2_COEFF if j2 else 0.0)
    return (r[:, 0], v[:, 0]) if single else (r, v)


class OrbitTruth:
    """The true orbit sampled on a fixed time grid, in ECEF.

    Parameters
    ----------
    elements : epoch elements (ECI at t = 0, ECI = ECEF at the epoch).
    dt : RK4 step [s]; duration : [s], a multiple of ``dt``; every : keep every ``every``-th step.

    Attributes: ``t`` (K,) [s], ``r``, ``v`` (K, 3) ECEF [m, m/s].
    """

    def __init__(self, elements: KeplerElements, duration: float, dt: float = 0.1, every: int = 1):
        n_steps = int(round(duration / dt))
        if n_steps < 1 or abs(n_steps * dt - duration) > 1e-9 * max(1.0, duration):
            raise ConfigError("orbit.duration", f"must be a positive multiple of the step {dt} s, got {duration!r}")
        r_i, v_i = propagate_rk4_eci(*elements_to_eci(elements), dt, n_steps, every)
        self.elements = elements
        self.t = np.arange(r_i.shape[0]) * (dt * every)
        self.r, self.v = eci_to_ecef(self.t, r_i, v_i)

    def index(self, t) -> np.ndarray:
        """Grid index of time(s) t [s]; raises when t is not on the grid."""
        t = np.asarray(t, dtype=float)
        step = self.t[1] - self.t[0]
        k = np.rint(t / step).astype(int)
        if np.any(np.abs(k * step - t) > 1e-6 * step) or np.any(k < 0) or np.any(k >= self.t.size):
            raise ConfigError("t", f"times must lie on the truth grid (step {step} s, 0..{self.t[-1]} s)")
        return k


def right_ascension_of_node(r_eci, v_eci):
    """Osculating RAAN [rad] (unwrapped along the first axis) from ECI position/velocity (..., 3)."""
    h = np.cross(r_eci, v_eci)
    return np.unwrap(np.arctan2(h[..., 0], -h[..., 1]), axis=0)


def lvlh_dcm(r, v, omega: float = OMEGA_EARTH):
    """T_e^b (..., 3, 3): ECEF -> LVLH body, rows x_b, y_b, z_b (module docstring; gaps G3/G4).

    r, v : ECEF position and velocity (..., 3). The LVLH frame is the orbit's: it uses the inertial velocity
    v + w x r (the orbital plane), expressed in ECEF; pass ``omega=0`` for inputs already in ECI.
    """
    r = np.asarray(r, dtype=float)
    v = np.asarray(v, dtype=float) + np.cross([0.0, 0.0, omega], r)
    z = -r / np.linalg.norm(r, axis=-1, keepdims=True)
    h = np.cross(r, v)
    y = -h / np.linalg.norm(h, axis=-1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-2)


def zero_doppler_dcm(r, v):
    """T_e^b (..., 3, 3) of a zero-Doppler-steered body: x_b = v/|v| (ECEF velocity), y_b = -(r x v)/|r x v|,
    z_b = x_b x y_b (about nadir, within the radial-velocity angle |v_r|/|v| ~ 1 mrad).

    Every boresight in the y_b-z_b plane (zero squint) is perpendicular to the ECEF velocity, so the beam centre is at
    zero Doppler for the ground, fixed in ECEF (the closed loop's gap decision G3/G9: total zero-Doppler steering;
    docs/spacecraft.md). ``lvlh_dcm`` (the paper's LVLH) instead looks ~3 deg off zero Doppler at this orbit.
    """
    r = np.asarray(r, dtype=float)
    v = np.asarray(v, dtype=float)
    x = v / np.linalg.norm(v, axis=-1, keepdims=True)
    h = np.cross(r, v)
    y = -h / np.linalg.norm(h, axis=-1, keepdims=True)
    return np.stack([x, y, np.cross(x, y)], axis=-2)


#: body attitude laws: name -> T_e^b(r, v) (ECEF position and velocity)
STEERING = {"lvlh": lvlh_dcm, "zero-doppler": zero_doppler_dcm}


def body_dcm(r, v, steering: str = "lvlh"):
    """T_e^b of the attitude law ``steering`` (:data:`STEERING`)."""
    if steering not in STEERING:
        raise ConfigError("antenna.steering", f"must be one of {tuple(STEERING)}, got {steering!r}")
    return STEERING[steering](r, v)


def antenna_dcm(look_angle: float, squint: float = 0.0):
    """T_b^s (3, 3): body -> nominal antenna; boresight z_s at ``look_angle`` [rad] from nadir toward +y_b (right),
    turned by ``squint`` [rad] toward +x_b (gap G3)."""
    if not (math.isfinite(look_angle) and 0.0 <= look_angle < math.pi / 2):
        raise ConfigError("antenna.look_angle_deg", f"must be in [0, 90) deg from nadir, got {math.degrees(look_angle)!r}")
    if not (math.isfinite(squint) and abs(squint) < math.pi / 2):
        raise ConfigError("antenna.squint_deg", f"must be in (-90, 90) deg, got {math.degrees(squint)!r}")
    c, s = math.cos(look_angle), math.sin(look_angle)
    look = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    cq, sq = math.cos(squint), math.sin(squint)
    turn = np.array([[cq, 0.0, -sq], [0.0, 1.0, 0.0], [sq, 0.0, cq]])  # z_s' = cos sq z_s + sin sq x_s
    return turn @ look


def ecef_to_antenna_dcm(T_eb, T_bs, q_mu=None):
    """T_e^s = T_mu T_b^s T_e^b (paper eq. 19); T_eb (..., 3, 3), T_bs (3, 3), q_mu (..., 4) Hamilton or None."""
    M = np.asarray(T_bs, dtype=float) @ np.asarray(T_eb, dtype=float)
    return M if q_mu is None else quat_to_dcm(q_mu) @ M


def initial_ecef_state(elements: KeplerElements):
    """(r, v) ECEF at t = 0 of the elements (ECI = ECEF at the epoch)."""
    return eci_to_ecef(0.0, *elements_to_eci(elements))


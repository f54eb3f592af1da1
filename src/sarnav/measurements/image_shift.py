"""SAR image-shift measurements: slant range and cross-range of a geolocated reference target.

Design (docs/scenarios/rda-nav.md §2; paper eqs. 47-49, 51-52, 54-56; thesis §5.2 with the bias columns the
thesis omits, extraction seed-000 §5.2 errata):

* range, eq. 47: ``h_r = ||p_targ - p(eta0)|| + b_r``, H_r = [-d^T/||d||, 0, ..., 1 at b_range];
* cross-range, two models:

  - ``"zero-doppler"`` (default, the one an image realises): at the time of closest approach (TOC) eta0 of
    a zero-squint stop-and-hop SAR the line of sight is orthogonal to the velocity, so the truth value of
    ``u^T (p(eta0) - p_targ)`` with ``u = v/||v||`` is 0. Design model ``h_c = u^T (p - p_targ) + b_c``,
    whose Jacobian has the paper's position row u^T *and* a velocity row ``(p - p_targ)^T (I - u u^T)/||v||``
    (the SAR azimuth-geolocation lever, thesis §4.3.2);
  - ``"paper"``: eq. 48 with u_c and r_orig constants, ``h_c = u_c^T (p - r_orig) + b_c``, H_c of eq. 56.

The measurement refers to the state at the TOC. When the update is applied later (end of sub-aperture)
pass ``phi_back`` = Phi(eta0, t_k), the error-state transition from the update epoch back to the TOC, and
H becomes H_toc @ phi_back (paper eq. 57 without process-noise correlation).

``second_order(p_hat, v_hat, P_toc)`` gives the Gaussian second-order terms (Hessian A of h w.r.t. the
error state at the TOC): the mean correction ``tr(A P)/2`` to add to z_hat and the variance
``tr(A P A P)/2`` to add to R. They matter for the zero-Doppler cross-range: its lever (p - p_targ)_perp / |v|
is divided by the *estimated* speed, so an along-track speed error dv_N scales the lever and
``h(x) - h(x_hat) - H dx = -(l_perp . dv)(u . dv) / V^2`` (docs/scenarios/rda-nav.md §2). The
weakly observed along-track chain makes that 0.1-0.2 m (mean and std) in the paper geometry.

Every object's ``predict(p_hat, v_hat, b_hat)`` returns (z_hat (1,), H (1, S), R (1, 1)).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sarnav.errors import ConfigError, InputDataError

CROSS_RANGE_MODELS = ("zero-doppler", "paper")


def _vec3(name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise InputDataError(name, f"must be a finite 3-vector (NED, m), got shape {a.shape}")
    return a


def _check_layout(n_states: int, indices: dict[str, int]) -> None:
    if int(n_states) < 1:
        raise ConfigError("n_states", f"must be >= 1, got {n_states}")
    for name, idx in indices.items():
        width = 3 if name in ("pos_index", "vel_index") else 1
        if not (0 <= int(idx) and int(idx) + width <= n_states):
            raise ConfigError(name, f"must be in [0, {n_states - width}] for {n_states} states, got {idx}")


def _check_phi(phi, n_states: int):
    if phi is None:
        return None
    phi = np.asarray(phi, dtype=np.float64)
    if phi.shape != (n_states, n_states) or not np.all(np.isfinite(phi)):
        raise InputDataError("phi_back", f"must be a finite ({n_states}, {n_states}) matrix, got {phi.shape}")
    return phi


@dataclass
class RangeMeasurement:
    """Slant range of closest approach to a known target (paper eqs. 47, 51, 55).

    Parameters
    ----------
    p_targ : (3,) known target position (NED, m).
    sigma : 1-sigma measurement noise [m], > 0.
    n_states : length of the error state.
    bias_index : error-state column of the range bias b_range.
    pos_index : first error-state column of the position (3 columns).
    phi_back : optional (S, S) transition from the update epoch back to the TOC.
    """

    p_targ: np.ndarray
    sigma: float
    n_states: int
    bias_index: int
    pos_index: int = 0
    phi_back: np.ndarray | None = None
    name: str = field(default="range", init=False)

    def __post_init__(self):
        self.p_targ = _vec3("p_targ", self.p_targ)
        if not (np.isfinite(self.sigma) and self.sigma > 0):
            raise ConfigError("sar.range_sigma", f"must be finite and > 0 m, got {self.sigma!r}")
        _check_layout(self.n_states, {"pos_index": self.pos_index, "bias_index": self.bias_index})
        self.phi_back = _check_phi(self.phi_back, self.n_states)

    def model(self, p, v=None, b=0.0) -> float:
        """Noise-free measurement function h(x) at the TOC (eq. 47 without n_r)."""
        return float(np.linalg.norm(self.p_targ - np.asarray(p, dtype=np.float64)) + b)

    def predict(self, p_hat, v_hat=None, b_hat=0.0):
        """(z_hat, H, R) from the estimated position at the TOC and the estimated range bias (eqs. 51, 55)."""
        p_hat = _vec3("p_hat", p_hat)
        d = self.p_targ - p_hat
        rng = np.linalg.norm(d)
        if rng <= 0:
            raise InputDataError("p_hat", "coincides with the target; range Jacobian undefined")
        H = np.zeros((1, self.n_states))
        H[0, self.pos_index:self.pos_index + 3] = -d / rng
        H[0, self.bias_index] = 1.0
        if self.phi_back is not None:
            H = H @ self.phi_back
        return np.array([rng + b_hat]), H, np.array([[self.sigma**2]])

    def hessian(self, p_hat, v_hat=None) -> np.ndarray:
        """(S, S) Hessian of h w.r.t. the error state at the TOC: (I - d d^T / |d|^2) / |d| in the position block."""
        p_hat = _vec3("p_hat", p_hat)
        d = self.p_targ - p_hat
        rng = np.linalg.norm(d)
        A = np.zeros((self.n_states, self.n_states))
        i = slice(self.pos_index, self.pos_index + 3)
        A[i, i] = (np.eye(3) - np.outer(d, d) / rng**2) / rng
        return A

    def second_order(self, p_hat, v_hat, P_toc):
        """Gaussian second-order terms (mean correction for z_hat, variance for R) for the TOC covariance
        ``P_toc`` (S, S); see the module docstring."""
        return _second_order(self.hessian(p_hat, v_hat), P_toc, self.n_states)


def _second_order(A, P_toc, n_states):
    dz, C = second_order_terms([A], P_toc)
    return float(dz[0]), float(C[0, 0])


def second_order_terms(hessians, P_toc):
    """Gaussian second-order filter terms of stacked measurements with Hessians A_i and error covariance P:
    mean correction ``dz_i = tr(A_i P) / 2`` (add to z_hat) and covariance ``C_ij = tr(A_i P A_j P) / 2`` (add
    to R). For a zero-mean Gaussian error the quadratic terms are uncorrelated with the error itself."""
    P_toc = np.asarray(P_toc, dtype=np.float64)
    n = P_toc.shape[0]
    if P_toc.shape != (n, n) or not np.all(np.isfinite(P_toc)):
        raise InputDataError("P_toc", f"must be a finite square matrix, got {P_toc.shape}")
    AP = []
    for A in hessians:
        A = np.asarray(A, dtype=np.float64)
        if A.shape != (n, n):
            raise InputDataError("hessian", f"must be ({n}, {n}) like P_toc, got {A.shape}")
        AP.append(A @ P_toc)
    dz = np.array([0.5 * np.trace(a) for a in AP])
    C = np.array([[0.5 * np.sum(a * b.T) for b in AP] for a in AP])
    return dz, C


@dataclass
class CrossRangeMeasurement:
    """Along-track (cross-range) position of the vehicle at the target's TOC (paper eqs. 48-49, 52, 56).

    Parameters
    ----------
    p_targ : (3,) known target position (NED, m); the cross-range origin r_orig of the zero-Doppler model.
    sigma : 1-sigma measurement noise [m], > 0.
    n_states, bias_index, pos_index, vel_index : error-state layout (b_cross column, position and velocity
        blocks).
    model : ``"zero-doppler"`` (default) or ``"paper"``.
    u_c, r_orig : for ``"paper"`` only: the along-track unit vector and origin, treated as constants (eq. 49
        computes u_c from the *estimated* positions; paper L1185-1192).
    phi_back : optional (S, S) transition from the update epoch back to the TOC.
    """

    p_targ: np.ndarray
    sigma: float
    n_states: int
    bias_index: int
    pos_index: int = 0
    vel_index: int = 3
    model_name: str = "zero-doppler"
    u_c: np.ndarray | None = None
    r_orig: np.ndarray | None = None
    phi_back: np.ndarray | None = None
    name: str = field(default="cross", init=False)

    def __post_init__(self):
        self.p_targ = _vec3("p_targ", self.p_targ)
        if not (np.isfinite(self.sigma) and self.sigma > 0):
            raise ConfigError("sar.cross_sigma", f"must be finite and > 0 m, got {self.sigma!r}")
        if self.model_name not in CROSS_RANGE_MODELS:
            raise ConfigError("sar.cross_range_model", f"must be one of {CROSS_RANGE_MODELS}, got {self.model_name!r}")
        _check_layout(self.n_states, {"pos_index": self.pos_index, "vel_index": self.vel_index,
                                      "bias_index": self.bias_index})
        if self.model_name == "paper":
            if self.u_c is None or self.r_orig is None:
                raise ConfigError("sar.cross_range_model", "'paper' needs u_c and r_orig")
            u = _vec3("u_c", self.u_c)
            nrm = np.linalg.norm(u)
            if nrm == 0:
                raise InputDataError("u_c", "must be non-zero")
            self.u_c = u / nrm
            self.r_orig = _vec3("r_orig", self.r_orig)
        self.phi_back = _check_phi(self.phi_back, self.n_states)

    def model(self, p, v=None, b=0.0) -> float:
        """Noise-free measurement function h(x) at the TOC."""
        p = np.asarray(p, dtype=np.float64)
        if self.model_name == "paper":
            return float(self.u_c @ (p - self.r_orig) + b)
        v = _vec3("v", v)
        return float(v @ (p - self.p_targ) / np.linalg.norm(v) + b)

    def predict(self, p_hat, v_hat=None, b_hat=0.0):
        """(z_hat, H, R) from the estimated position and velocity at the TOC and the estimated b_cross."""
        p_hat = _vec3("p_hat", p_hat)
        H = np.zeros((1, self.n_states))
        if self.model_name == "paper":
            z = self.u_c @ (p_hat - self.r_orig)
            H[0, self.pos_index:self.pos_index + 3] = self.u_c  # eq. 56
        else:
            v_hat = _vec3("v_hat", v_hat)
            speed = np.linalg.norm(v_hat)
            if speed <= 0:
                raise InputDataError("v_hat", "speed must be > 0 for the zero-Doppler cross-range model")
            u = v_hat / speed
            los = p_hat - self.p_targ
            z = u @ los
            H[0, self.pos_index:self.pos_index + 3] = u
            H[0, self.vel_index:self.vel_index + 3] = (los - u * (u @ los)) / speed
        H[0, self.bias_index] = 1.0
        if self.phi_back is not None:
            H = H @ self.phi_back
        return np.array([z + b_hat]), H, np.array([[self.sigma**2]])

    def hessian(self, p_hat, v_hat=None) -> np.ndarray:
        """(S, S) Hessian of h w.r.t. the error state at the TOC (zero for the linear ``"paper"`` model).

        Zero-Doppler, h = u^T l + b with l = p - p_targ, s = |v|, u = v / s:
        d2h/dp dv = (I - u u^T) / s,  d2h/dv2 = -(l u^T + u l^T) / s^2 - (u^T l)(I - 3 u u^T) / s^2.
        """
        A = np.zeros((self.n_states, self.n_states))
        if self.model_name == "paper":
            return A
        p_hat, v_hat = _vec3("p_hat", p_hat), _vec3("v_hat", v_hat)
        s = np.linalg.norm(v_hat)
        if s <= 0:
            raise InputDataError("v_hat", "speed must be > 0 for the zero-Doppler cross-range model")
        u = v_hat / s
        l = p_hat - self.p_targ
        ul = u @ l
        ip = slice(self.pos_index, self.pos_index + 3)
        iv = slice(self.vel_index, self.vel_index + 3)
        A[ip, iv] = (np.eye(3) - np.outer(u, u)) / s
        A[iv, ip] = A[ip, iv].T
        A[iv, iv] = -(np.outer(l, u) + np.outer(u, l)) / s**2 - ul * (np.eye(3) - 3 * np.outer(u, u)) / s**2
        return A

    def second_order(self, p_hat, v_hat, P_toc):
        """Gaussian second-order terms (mean correction for z_hat, variance for R) for the TOC covariance
        ``P_toc`` (S, S); see the module docstring."""
        return _second_order(self.hessian(p_hat, v_hat), P_toc, self.n_states)


def stack(predictions):
    """Stack several (z_hat, H, R) into one (z_hat (M,), H (M, S), R (M, M) block-diagonal) update (G15)."""
    z = np.concatenate([p[0] for p in predictions])
    H = np.vstack([p[1] for p in predictions])
    R = np.zeros((len(z), len(z)))
    i = 0
    for p in predictions:
        m = len(p[0])
        R[i:i + m, i:i + m] = p[2]
        i += m
    return z, H, R


def closest_approach(p_targ, times, positions):
    """Time and range of closest approach of a sampled trajectory to a target (thesis eq. 4.41).

    The squared range of the three samples around the discrete minimum is fitted by a parabola, which is
    exact for constant-velocity motion; the position at the TOC is interpolated linearly.

    Returns
    -------
    eta0 : time of closest approach [s]; r0 : range of closest approach [m]; p0 : (3,) position at eta0.
    """
    p_targ = _vec3("p_targ", p_targ)
    times = np.asarray(times, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)
    if times.ndim != 1 or len(times) < 3 or positions.shape != (len(times), 3):
        raise InputDataError("positions", f"need (T, 3) positions with T >= 3 matching times, got {positions.shape}")
    if np.any(np.diff(times) <= 0):
        raise InputDataError("times", "must be strictly increasing")
    r2 = np.sum((positions - p_targ) ** 2, axis=1)
    k = int(np.argmin(r2))
    if k == 0 or k == len(times) - 1:
        raise InputDataError("positions", "closest approach lies at the end of the trajectory samples")
    t3, y3 = times[k - 1:k + 2], r2[k - 1:k + 2]
    a, b, _ = np.polyfit(t3 - t3[1], y3, 2)
    eta0 = t3[1] - b / (2 * a) if a > 0 else t3[1]
    eta0 = float(np.clip(eta0, t3[0], t3[2]))
    p0 = np.array([np.interp(eta0, times, positions[:, i]) for i in range(3)])
    return eta0, float(np.linalg.norm(p0 - p_targ)), p0


def interpolate_state(times, values, eta):
    """Linear interpolation of an (T, 3) history (positions or velocities) at time eta."""
    times = np.asarray(times, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    if not (times[0] <= eta <= times[-1]):
        raise InputDataError("eta", f"must be in [{times[0]}, {times[-1]}] s, got {eta}")
    return np.array([np.interp(eta, times, values[:, i]) for i in range(values.shape[1])])


def synthesize_oracle(range_meas: RangeMeasurement, cross_meas: CrossRangeMeasurement, p_true, v_true,
                      b_range: float, b_cross: float, rng: np.random.Generator):
    """``oracle`` mode: measurements from the truth state at the TOC plus white noise (eqs. 47-48).

    Returns z (2,) = [z_r, z_c]. The only function in sarnav that turns truth into a measurement.
    """
    n = rng.standard_normal(2)
    z_r = range_meas.model(p_true, v_true, b_range) + range_meas.sigma * n[0]
    z_c = cross_meas.model(p_true, v_true, b_cross) + cross_meas.sigma * n[1]
    return np.array([z_r, z_c])

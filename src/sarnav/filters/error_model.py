"""Linearised INS error model: F, B, Q (thesis eqs. 3.5-3.12, 3.19) and its exact discretisation.

Error state (truth minus estimate; attitude per eq. 4.8) in an :class:`ErrorStateLayout`::

    d(dp)/dt  = dv
    d(dv)/dt  = [f^n x] dth - T db_a - T n_nu          f^n = T (nu_meas - b_a_hat)  (eq. 3.7, B.4)
    d(dth)/dt = T db_g + T n_omega                                                  (eq. 3.8, B.17)
    d(db)/dt  = -db/tau + w_b    for every FOGM bias                                (eq. 3.9)

On an Earth-fixed tangent frame that turns at ``omega_ie^t`` (``earth_rate``; ``frames.ned``, Groves 2008 §5.3 /
§14.2.3 in a local tangent frame) two terms join: ``d(dv)/dt += -2 [omega_ie x] dv`` (Coriolis) and
``d(dth)/dt += -[omega_ie x] dth`` (the frame's turn; nav-frame attitude error). The closed form below does not
cover them; :meth:`ErrorStateModel.discretize` then uses Van Loan (on sub-steps no longer than the shortest
correlation time, where its exp(+s/tau) blocks stay well conditioned).

``Q = diag(vrw^2 I3, arw^2 I3, 2 sigma_a^2/tau_a I3, 2 sigma_g^2/tau_g I3, 2 sigma_i^2/tau_i)``
(eq. 3.19). :meth:`ErrorStateModel.discretize` gives ``Phi = expm(F dt)`` and the Van Loan
``Q_d`` in closed form for F held constant over dt; it equals
:func:`sarnav.filters.discretization.van_loan` to rounding (tests/test_error_model.py). The closed
form uses that the white-noise PSDs are isotropic (``T sigma^2 I T^T = sigma^2 I``).

Closed form. With ``A = [f^n x]`` and the FOGM kernels ``phi_0(s) = exp(-s/tau)``,
``phi_{k+1}(s) = int_0^s phi_k``, the transition matrix over s is::

    col v : p += s I
    col th: p += A s^2/2,     v += A s
    col ba: p += -T phi_2a,   v += -T phi_1a,   ba = phi_0a I
    col bg: p += A T phi_3g,  v += A T phi_2g,  th += T phi_1g,  bg = phi_0g I

and ``Q_d = sum_j q_j int_0^dt Phi_j(s) Phi_j(s)^T ds`` over the noise columns j; the scalar
integrals ``int phi_i phi_j`` come from Gauss-Legendre quadrature of the kernels (:func:`fogm_kernels`).
"""

from __future__ import annotations

import functools
import math

import numpy as np
from sarnav.errors import ConfigError, require_finite, require_positive
from sarnav.filters.discretization import van_loan
from sarnav.filters.layout import ErrorStateLayout
from sarnav.frames import earth_rate_or_zero
from sarnav.rotations import skew


_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)
#: s/tau beyond which exp(-s/tau) (< 5e-18) is negligible in the FOGM kernels
_EXP_NEGLIGIBLE = 40.0


def _fogm_chain(s, tau):
    """phi_k(s), k = 0..3, of a FOGM kernel chain without cancellation, (..., 4).

    phi_k(s) = s^k sum_j (-u)^j/(j + k)!, u = s/tau (series for u < 0.5, closed forms otherwise).
    """
    s = np.asarray(s, dtype=float)
    u = s / tau
    small = u < 0.5
    us = np.where(small, u, 0.0)
    g = np.zeros(s.shape + (4,))
    for k in range(4):
        term = np.full(s.shape, 1.0 / math.factorial(k))
        acc = term.copy()
        for j in range(1, 22):
            term = term * (-us) / (j + k)
            acc = acc + term
        g[..., k] = acc
    ul = np.where(small, 1.0, u)
    em = -np.expm1(-ul)  # 1 - exp(-u)
    iu = 1.0 / ul  # written in powers of 1/u so that tau << s cannot overflow
    big = np.stack([1.0 - em, em * iu, iu - em * iu * iu, 0.5 * iu - iu * iu + em * iu * iu * iu], -1)
    g = np.where(small[..., None], g, big)
    return g * s[..., None] ** np.arange(4)


@functools.lru_cache(maxsize=64)
def fogm_kernels(tau: float, dt: float):
    """phi_k(dt), k = 0..3, and the Gram matrix G[i, j] = int_0^dt phi_i phi_j ds of a FOGM chain.

    ``phi_0(s) = exp(-s/tau)``, ``phi_{k+1} = int_0^s phi_k``. The integrals use composite
    24-point Gauss-Legendre quadrature with panels no wider than tau/2 (the integrands are smooth
    exponential-polynomials, so this is exact to rounding; checked against closed forms in tests).
    Beyond s = 40 tau the exponentials are below 5e-18 and the integrands are polynomials of degree
    <= 4, integrated exactly by one more panel, so the cost stays bounded for any tau << dt.
    """
    head = min(dt, _EXP_NEGLIGIBLE * tau)
    panels = max(1, int(math.ceil(2.0 * head / tau)))
    edges = np.linspace(0.0, head, panels + 1)
    if head < dt:
        edges = np.append(edges, dt)
    half = 0.5 * np.diff(edges)
    s = (0.5 * (edges[:-1] + edges[1:]))[:, None] + half[:, None] * _GL_X
    w = (half[:, None] * _GL_W).ravel()
    y = _fogm_chain(s.ravel(), tau)
    gram = np.einsum("n,ni,nj->ij", w, y, y)
    return _fogm_chain(np.array(dt), tau), gram


class ErrorStateModel:
    """F, B, Q and their discretisation for a layout (no radar or scenario knowledge).

    Parameters
    ----------
    layout : the error-state layout.
    vrw, arw : white-noise root-PSDs [m/s/sqrt(s)], [rad/sqrt(s)], >= 0.
    accel_bias_sigma, gyro_bias_sigma : FOGM steady-state sigmas [m/s^2], [rad/s] (if the layout
        has ``ba`` / ``bg``).
    tau_accel, tau_gyro : their correlation times [s], > 0.
    scalar_sigma, scalar_tau : steady-state sigma and tau of each scalar bias, layout order.
    earth_rate : omega_ie^t (3,) [rad/s] of a rotating Earth-fixed tangent frame, or None (the sources' frame).
    """

    def __init__(self, layout: ErrorStateLayout, vrw, arw, accel_bias_sigma=0.0, gyro_bias_sigma=0.0,
                 tau_accel=1.0, tau_gyro=1.0, scalar_sigma=(), scalar_tau=(), earth_rate=None):
        self.layout = layout
        self.earth_rate = None if earth_rate is None else earth_rate_or_zero(earth_rate)
        self.vrw = require_finite("vrw", vrw, lo=0.0)
        self.arw = require_finite("arw", arw, lo=0.0)
        self.accel_bias_sigma = require_finite("accel_bias_sigma", accel_bias_sigma, lo=0.0)
        self.gyro_bias_sigma = require_finite("gyro_bias_sigma", gyro_bias_sigma, lo=0.0)
        self.tau_accel = require_positive("tau_accel", tau_accel, "s")
        self.tau_gyro = require_positive("tau_gyro", tau_gyro, "s")
        k = len(layout.scalar_biases)
        if len(scalar_sigma) != k or len(scalar_tau) != k:
            raise ConfigError("scalar_sigma", f"need {k} sigmas and taus for {layout.scalar_biases}")
        self.scalar_sigma = np.array([require_finite(f"{n}.sigma", s, lo=0.0) for n, s in zip(layout.scalar_biases, scalar_sigma)])
        self.scalar_tau = np.array([require_positive(f"{n}.tau", t, "s") for n, t in zip(layout.scalar_biases, scalar_tau)])

    # --- continuous model ------------------------------------------------------------------
    def noise_names(self) -> list[str]:
        names = ["n_nu"] * 3 + ["n_omega"] * 3
        if self.layout.has("ba"):
            names += ["w_a"] * 3
        if self.layout.has("bg"):
            names += ["w_g"] * 3
        return names + [f"w_{n}" for n in self.layout.scalar_biases]

    def Q(self) -> np.ndarray:
        """Noise PSD (eq. 3.19), (m, m)."""
        d = [self.vrw**2] * 3 + [self.arw**2] * 3
        if self.layout.has("ba"):
            d += [2 * self.accel_bias_sigma**2 / self.tau_accel] * 3
        if self.layout.has("bg"):
            d += [2 * self.gyro_bias_sigma**2 / self.tau_gyro] * 3
        d += list(2 * self.scalar_sigma**2 / self.scalar_tau)
        return np.diag(d)

    def F(self, T, f_n) -> np.ndarray:
        """System matrix (eqs. 3.6-3.9), (R, n, n), from T_b^n (R, 3, 3) and f^n (R, 3)."""
        L = self.layout
        T = np.asarray(T, dtype=float)
        F = np.zeros(T.shape[:-2] + (L.n, L.n))
        p, v, th = L.slice("p"), L.slice("v"), L.slice("th")
        F[..., p, v] = np.eye(3)
        F[..., v, th] = skew(f_n)
        if L.has("ba"):
            F[..., v, L.slice("ba")] = -T
            F[..., L.slice("ba"), L.slice("ba")] = -np.eye(3) / self.tau_accel
        if L.has("bg"):
            F[..., th, L.slice("bg")] = T
            F[..., L.slice("bg"), L.slice("bg")] = -np.eye(3) / self.tau_gyro
        s = L.scalar_slice
        F[..., s, s] = np.diag(-1.0 / self.scalar_tau)
        if self.earth_rate is not None:
            W = skew(self.earth_rate)
            F[..., v, v] = -2.0 * W  # Coriolis
            F[..., th, th] = -W  # the tangent frame turns under the attitude
        return F

    def B(self, T) -> np.ndarray:
        """Noise input matrix (eqs. 3.10-3.11), (R, n, m)."""
        L = self.layout
        T = np.asarray(T, dtype=float)
        m = len(self.noise_names())
        B = np.zeros(T.shape[:-2] + (L.n, m))
        B[..., L.slice("v"), 0:3] = -T
        B[..., L.slice("th"), 3:6] = T
        j = 6
        for blk in ("ba", "bg"):
            if L.has(blk):
                B[..., L.slice(blk), j:j + 3] = np.eye(3)
                j += 3
        s = L.scalar_slice
        B[..., s, j:] = np.eye(len(L.scalar_biases))
        return B

    # --- exact discretisation ----------------------------------------------------------------
    def discretize(self, T, f_n, dt: float):
        """(Phi, Q_d) over ``dt`` with T and f^n held constant; closed form of Van Loan.

        Parameters
        ----------
        T : (R, 3, 3) T_b^n of the estimate; f_n : (R, 3) nav-frame specific force; dt : step [s].
        """
        if self.earth_rate is not None:
            return self._discretize_van_loan(T, f_n, dt)
        L = self.layout
        T = np.asarray(T, dtype=float)
        f_n = np.asarray(f_n, dtype=float)
        R = T.shape[0]
        n = L.n
        I3 = np.eye(3)
        A = skew(f_n)
        AAt = _aat(f_n)
        p, v, th = L.slice("p"), L.slice("v"), L.slice("th")
        Phi = np.zeros((R, n, n))
        Phi[:, np.arange(n), np.arange(n)] = 1.0
        Phi[:, p, v] = dt * I3
        Phi[:, p, th] = 0.5 * dt * dt * A
        Phi[:, v, th] = dt * A
        Qd = np.zeros((R, n, n))

        def add(rows, cols, block):
            Qd[:, rows, cols] += block
            if rows != cols:
                Qd[:, cols, rows] += np.swapaxes(block, -1, -2)

        qv, qt = self.vrw**2, self.arw**2
        # velocity white noise (B column -T, isotropic): int [s; 1][s; 1]^T ds
        add(p, p, qv * dt**3 / 3 * I3)
        add(p, v, qv * dt**2 / 2 * I3)
        add(v, v, qv * dt * I3)
        # angle white noise: columns [A s^2/2; A s; I]
        add(p, p, qt * dt**5 / 20 * AAt)
        add(p, v, qt * dt**4 / 8 * AAt)
        add(p, th, qt * dt**3 / 6 * A)
        add(v, v, qt * dt**3 / 3 * AAt)
        add(v, th, qt * dt**2 / 2 * A)
        add(th, th, qt * dt * I3)
        if L.has("ba"):
            ba = L.slice("ba")
            k, G = fogm_kernels(self.tau_accel, dt)
            qa = 2 * self.accel_bias_sigma**2 / self.tau_accel
            Phi[:, p, ba] = -k[2] * T
            Phi[:, v, ba] = -k[1] * T
            Phi[:, ba, ba] = k[0] * I3
            # columns [-T phi2; -T phi1; 0; phi0 I]
            add(p, p, qa * G[2, 2] * I3)
            add(p, v, qa * G[2, 1] * I3)
            add(p, ba, -qa * G[2, 0] * T)
            add(v, v, qa * G[1, 1] * I3)
            add(v, ba, -qa * G[1, 0] * T)
            add(ba, ba, qa * G[0, 0] * I3)
        if L.has("bg"):
            bg = L.slice("bg")
            k, G = fogm_kernels(self.tau_gyro, dt)
            qg = 2 * self.gyro_bias_sigma**2 / self.tau_gyro
            AT = A @ T
            Phi[:, p, bg] = k[3] * AT
            Phi[:, v, bg] = k[2] * AT
            Phi[:, th, bg] = k[1] * T
            Phi[:, bg, bg] = k[0] * I3
            # columns [A T phi3; A T phi2; T phi1; 0; phi0 I]
            add(p, p, qg * G[3, 3] * AAt)
            add(p, v, qg * G[3, 2] * AAt)
            add(p, th, qg * G[3, 1] * A)
            add(p, bg, qg * G[3, 0] * AT)
            add(v, v, qg * G[2, 2] * AAt)
            add(v, th, qg * G[2, 1] * A)
            add(v, bg, qg * G[2, 0] * AT)
            add(th, th, qg * G[1, 1] * I3)
            add(th, bg, qg * G[1, 0] * T)
            add(bg, bg, qg * G[0, 0] * I3)
        for j, name in enumerate(L.scalar_biases):
            i = L.index(name)
            k, G = fogm_kernels(float(self.scalar_tau[j]), dt)
            Phi[:, i, i] = k[0]
            Qd[:, i, i] += 2 * self.scalar_sigma[j] ** 2 / self.scalar_tau[j] * G[0, 0]
        return Phi, Qd


    def _discretize_van_loan(self, T, f_n, dt: float):
        """(Phi, Q_d) by Van Loan on n equal sub-steps h <= the shortest correlation time, composed."""
        T = np.asarray(T, dtype=float)
        F = self.F(T, np.asarray(f_n, dtype=float))
        B = self.B(T)
        BQBt = B @ self.Q() @ np.swapaxes(B, -1, -2)
        taus = [self.tau_accel if self.layout.has("ba") else np.inf, self.tau_gyro if self.layout.has("bg") else np.inf,
                *self.scalar_tau]
        n = max(1, int(math.ceil(dt / min(taus))))
        Phi_h, Qd_h = van_loan(F, BQBt, dt / n)
        Phi, Qd = Phi_h, Qd_h
        for _ in range(n - 1):
            Phi, Qd = Phi_h @ Phi, Phi_h @ Qd @ np.swapaxes(Phi_h, -1, -2) + Qd_h
        return Phi, 0.5 * (Qd + np.swapaxes(Qd, -1, -2))


def _aat(f):
    """[f x][f x]^T = |f|^2 I - f f^T, (R, 3, 3)."""
    f = np.asarray(f, dtype=float)
    out = -f[:, :, None] * f[:, None, :]
    nrm = np.sum(f * f, axis=1)
    for i in range(3):
        out[:, i, i] += nrm
    return out

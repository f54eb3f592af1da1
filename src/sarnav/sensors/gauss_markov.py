"""First-order Gauss-Markov (FOGM) processes with exact discretisation.

Continuous model (thesis eq. 3.1, every bias): ``b_dot = -b/tau + w``, ``E[w w] = 2 sigma_ss^2/tau``
(the PSD in thesis eq. 3.19). Sampled every ``dt`` it is exactly the AR(1) recursion

    b[k+1] = exp(-dt/tau) b[k] + sigma_ss sqrt(1 - exp(-2 dt/tau)) w[k],   w[k] ~ N(0, 1),

whose stationary law is N(0, sigma_ss^2) and autocorrelation ``sigma_ss^2 exp(-|lag| dt/tau)``.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter


def fogm_coefficients(sigma_ss, tau, dt):
    """Return (phi, drive) = (exp(-dt/tau), sigma_ss sqrt(1 - exp(-2 dt/tau))) (exact, see module doc)."""
    phi = np.exp(-np.divide(dt, tau))
    drive = np.multiply(sigma_ss, np.sqrt(-np.expm1(-2.0 * np.divide(dt, tau))))
    return phi, drive


def fogm_path(b0, w, phi, drive):
    """Run the exact recursion from b[0] = b0 over the unit-normal draws w.

    Parameters
    ----------
    b0 : (..., d) value at the first sample.
    w : (..., N, d) unit-normal draws; w[..., k, :] drives the step k -> k+1.
    phi, drive : per-component coefficients (d,) or scalars from :func:`fogm_coefficients`.

    Returns
    -------
    path : (..., N, d) values b[0..N-1]; next : (..., d) value b[N].
    """
    b0 = np.asarray(b0, dtype=float)
    w = np.asarray(w, dtype=float)
    phi = np.broadcast_to(np.asarray(phi, dtype=float), b0.shape[-1:])
    drive = np.broadcast_to(np.asarray(drive, dtype=float), b0.shape[-1:])
    out = np.empty(w.shape[:-2] + (w.shape[-2] + 1, w.shape[-1]))
    out[..., 0, :] = b0
    for j in range(w.shape[-1]):
        # y[n] = phi y[n-1] + drive w[n], y[-1] = b0  ->  y[n] = b[n+1]
        y, _ = lfilter([drive[j]], [1.0, -phi[j]], w[..., j], axis=-1, zi=(phi[j] * b0[..., j])[..., None])
        out[..., 1:, j] = y
    return out[..., :-1, :], out[..., -1, :]

"""Discretisation of a linear continuous-time error model (Van Loan, 1978).

For ``dx/dt = F x + B w`` with white ``w`` of PSD ``Q`` held over ``dt``::

    C = expm([[-F, B Q B^T], [0, F^T]] dt),   Phi = C22^T,   Q_d = Phi C12

gives ``Phi = expm(F dt)`` and ``Q_d = int_0^dt Phi(s) B Q B^T Phi(s)^T ds`` exactly (the discrete
form of thesis eq. 3.18, ``P_dot = F P + P F^T + B Q B^T``).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm


def van_loan(F, BQBt, dt: float):
    """Exact (Phi, Q_d) of a time-invariant model over ``dt``; batched over leading axes.

    Parameters
    ----------
    F : (..., n, n) system matrix.
    BQBt : (..., n, n) noise-input covariance rate B Q B^T.
    dt : step [s].
    """
    F = np.asarray(F, dtype=float)
    BQBt = np.broadcast_to(np.asarray(BQBt, dtype=float), F.shape)
    n = F.shape[-1]
    M = np.zeros(F.shape[:-2] + (2 * n, 2 * n))
    M[..., :n, :n] = -F
    M[..., :n, n:] = BQBt
    M[..., n:, n:] = np.swapaxes(F, -1, -2)
    C = expm(M * dt)
    Phi = np.swapaxes(C[..., n:, n:], -1, -2)
    Qd = Phi @ C[..., :n, n:]
    return Phi, 0.5 * (Qd + np.swapaxes(Qd, -1, -2))

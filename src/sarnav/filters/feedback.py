"""Feedback of the error-state estimate into the navigation state (thesis eq. 3.23 / 5.39).

``p+ = p- + dp``, ``v+ = v- + dv``, ``q+ = [1; -dth/2] (x) q-`` (normalised), ``b+ = b- + db``;
afterwards the error-state estimate is zero (reset).
"""

from __future__ import annotations

import numpy as np

from sarnav.filters.layout import ErrorStateLayout
from sarnav.ins.state import NavState
from sarnav.rotations import apply_attitude_error, attitude_error, corrupt_attitude


def apply_feedback(nav: NavState, dx, layout: ErrorStateLayout) -> NavState:
    """Return the corrected navigation state (``nav`` is not modified).

    Parameters
    ----------
    nav : estimate before correction; dx : (R, n) error-state estimate (truth - estimate);
    layout : the error-state layout of dx.
    """
    dx = np.asarray(dx, dtype=float)
    out = nav.copy()
    out.p = nav.p + dx[:, layout.slice("p")]
    out.v = nav.v + dx[:, layout.slice("v")]
    out.q = apply_attitude_error(nav.q, dx[:, layout.slice("th")])
    if layout.has("ba"):
        out.ba = nav.ba + dx[:, layout.slice("ba")]
    if layout.has("bg"):
        out.bg = nav.bg + dx[:, layout.slice("bg")]
    if layout.scalar_biases:
        out.bm = nav.bm + dx[:, layout.scalar_slice]
    return out


def error_state(truth: NavState, estimate: NavState, layout: ErrorStateLayout) -> np.ndarray:
    """Truth minus estimate in error-state coordinates (attitude by ``rotations.attitude_error``)."""
    parts = [truth.p - estimate.p, truth.v - estimate.v, attitude_error(truth.q, estimate.q)]
    if layout.has("ba"):
        parts.append(truth.ba - estimate.ba)
    if layout.has("bg"):
        parts.append(truth.bg - estimate.bg)
    if layout.scalar_biases:
        parts.append(truth.bm - estimate.bm)
    return np.concatenate(parts, axis=-1)


def corrupt_state(truth: NavState, dx, layout: ErrorStateLayout) -> NavState:
    """Estimate from truth and an error (thesis map m(), eq. A.5): x_hat = x - dx, q_hat = [1; dth/2] (x) q."""
    dx = np.asarray(dx, dtype=float)
    out = truth.copy()
    out.p = truth.p - dx[:, layout.slice("p")]
    out.v = truth.v - dx[:, layout.slice("v")]
    out.q = corrupt_attitude(truth.q, dx[:, layout.slice("th")])
    if layout.has("ba"):
        out.ba = truth.ba - dx[:, layout.slice("ba")]
    if layout.has("bg"):
        out.bg = truth.bg - dx[:, layout.slice("bg")]
    if layout.scalar_biases:
        out.bm = truth.bm - dx[:, layout.scalar_slice]
    return out

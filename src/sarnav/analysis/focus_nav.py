"""Statistics of the focus fixes of a ``quality-nav`` campaign (summary.json -> ``focus``; docs/quality.md §7).

The fix error (measured minus the true along-track velocity) against the 1-sigma the filter gave each fix: their
RMS, and the mean of (error / sigma)^2 with its chi-square band (1 for a correct variance model); mapdrift's speed
error on the same pulses; the EKF's predicted 1-sigma of the along-track velocity at the first and the last update.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

__all__ = ["focus_statistics"]


def _errors(e) -> dict:
    e = np.asarray(e, dtype=np.float64).ravel()
    e = e[np.isfinite(e)]
    if e.size == 0:
        return {"count": 0}
    return {"count": int(e.size), "mean": float(e.mean()), "std": float(e.std(ddof=1)) if e.size > 1 else 0.0,
            "rms": float(np.sqrt(np.mean(e**2))), "max_abs": float(np.max(np.abs(e)))}


def focus_statistics(ds, confidence: float = 0.95) -> dict:
    """``fix``: fix-error statistics, ``sigma_rms`` (the filter's 1-sigma of the fixes, RMS), ``normalised_mean``
    (mean of (error / sigma)^2) and its two-sided ``normalised_band``; ``mapdrift``: its speed-error statistics;
    ``predicted_sigma``: the EKF's RMS 1-sigma of e . v over runs at the first and last update."""
    err = ds["focus_error"].values
    sig = ds["focus_sigma"].values
    ok = np.isfinite(err) & np.isfinite(sig) & (sig > 0)
    out = {"fix": _errors(err[ok])}
    if ok.any():
        z2 = (err[ok] / sig[ok]) ** 2
        n = int(z2.size)
        alpha = 1.0 - confidence
        out["fix"].update(sigma_rms=float(np.sqrt(np.mean(sig[ok] ** 2))), normalised_mean=float(z2.mean()),
                          normalised_band=[float(chi2.ppf(alpha / 2, n) / n), float(chi2.ppf(1 - alpha / 2, n) / n)])
    if "mapdrift_error" in ds:
        out["mapdrift"] = _errors(ds["mapdrift_error"].values)
    if "predicted_sigma" in ds:
        p = ds["predicted_sigma"].values
        if np.isfinite(p).any():
            rms = np.sqrt(np.nanmean(p**2, axis=0))
            out["predicted_sigma"] = {"first_update": float(rms[0]), "last_update": float(rms[-1])}
    return out

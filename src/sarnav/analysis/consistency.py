"""Filter-consistency statistics over a Monte Carlo campaign.

For a consistent filter the estimation error e ~ N(0, P), so NEES = eᵀP⁻¹e ~ χ²(n_x), and the
innovation r ~ N(0, S), so NIS = rᵀS⁻¹r ~ χ²(n_z) (Bar-Shalom, Li & Kirubarajan, *Estimation with
Applications to Tracking and Navigation*, 2001, §5.4.2, eqs. 5.4.2-1..5.4.2-11). Averaged over N
independent runs, N·mean ~ χ²(N·n), so the two-sided (1-α) band of the mean is
``chi2.ppf([α/2, 1-α/2], N·n) / N``. When the number of measurements differs between runs at an
update, the sum of the NIS over runs is χ² with the sum of their dofs.

The thesis (Lindstrom 2020, §3.8 and App. A.6) judges consistency by eye ("errors mostly within
3σ"); these statistics make the same judgement with numbers (extraction §15, "advisable").
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

__all__ = ["rejection_counts", 
    "chi2_band",
    "sigma_containment",
    "nees_statistics",
    "nis_statistics",
    "residual_statistics",
    "final_sigma",
    "summarize",
    "mean_three_sigma",
    "case_statistics",
    "consistency_verdict",
    "strict",
    "MIN_POOLED_CONTAINMENT",
]


def chi2_band(total_dof, n_avg, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Two-sided band for the average of ``n_avg`` χ² variables whose dofs sum to ``total_dof``.

    Returns ``chi2.ppf([α/2, 1-α/2], total_dof) / n_avg`` (arrays broadcast).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence: must be in (0, 1), got {confidence!r}")
    alpha = 1.0 - confidence
    total_dof = np.asarray(total_dof, dtype=np.float64)
    n_avg = np.asarray(n_avg, dtype=np.float64)
    lo = chi2.ppf(alpha / 2.0, total_dof) / n_avg
    hi = chi2.ppf(1.0 - alpha / 2.0, total_dof) / n_avg
    return lo, hi


def sigma_containment(error: np.ndarray, sigma: np.ndarray, k: float = 3.0) -> np.ndarray:
    """Fraction of samples with ``|error| <= k·sigma`` per state (last axis), over finite samples.

    ``error`` and ``sigma`` have shape (..., S); for a Gaussian consistent filter and k = 3 the
    expected fraction is 2Φ(3) − 1 = 0.9973.
    """
    error = np.asarray(error, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    ok = np.isfinite(error) & np.isfinite(sigma)
    inside = (np.abs(error) <= k * sigma) & ok
    axes = tuple(range(error.ndim - 1))
    count = ok.sum(axis=axes)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, inside.sum(axis=axes) / count, np.nan)


def nees_statistics(nees: np.ndarray, n_state: int, confidence: float = 0.95) -> dict:
    """Mean NEES over runs at each epoch against its χ² band.

    Parameters
    ----------
    nees : (R, T) NEES of each run at each epoch.
    n_state : state dimension (dof of each NEES).

    Returns
    -------
    dict with ``mean`` (T,), ``band`` (lo, hi) for N = R runs, ``fraction_in_band`` (share of epochs
    whose mean lies in the band; ≈ confidence for a consistent filter if epochs were independent),
    ``time_average`` (mean over epochs of ``mean``; expected n_state).
    """
    nees = np.asarray(nees, dtype=np.float64)
    if nees.ndim != 2:
        raise ValueError(f"nees: expected (runs, time), got shape {nees.shape}")
    n_runs = nees.shape[0]
    mean = nees.mean(axis=0)
    lo, hi = chi2_band(n_runs * n_state, n_runs, confidence)
    inside = (mean >= lo) & (mean <= hi)
    finite = np.isfinite(mean)
    return {
        "dof": int(n_state),
        "runs": int(n_runs),
        "mean": mean,
        "band": (float(lo), float(hi)),
        "fraction_in_band": float(inside[finite].mean()) if finite.any() else float("nan"),
        "time_average": float(np.nanmean(mean)) if finite.any() else float("nan"),
    }


def nis_statistics(nis: np.ndarray, nis_dof: np.ndarray, confidence: float = 0.95) -> dict:
    """Mean NIS over runs at each update, with bands that follow the measurements present.

    Parameters
    ----------
    nis : (R, U) NIS of each run at each update (ignored where ``nis_dof`` is 0).
    nis_dof : (R, U) number of measurements in each NIS.

    Returns
    -------
    dict with per-update ``mean`` (U,), ``expected`` (U,) = Σdof/N_u, ``lo``, ``hi`` (U,) where N_u
    is the number of runs with a measurement at update u; ``fraction_in_band``; and the pooled
    ``per_dof`` = ΣNIS/Σdof over everything with its band ``per_dof_band`` (innovations of a
    consistent filter are white, so the pooled sum is χ²(Σdof)).
    """
    nis = np.asarray(nis, dtype=np.float64)
    dof = np.asarray(nis_dof, dtype=np.float64)
    if nis.shape != dof.shape or nis.ndim != 2:
        raise ValueError(f"nis, nis_dof: expected equal (runs, updates) shapes, got {nis.shape} and {dof.shape}")
    present = (dof > 0) & np.isfinite(nis)
    n_u = present.sum(axis=0)
    dof_u = np.where(present, dof, 0.0).sum(axis=0)
    sum_u = np.where(present, nis, 0.0).sum(axis=0)
    has = n_u > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(has, sum_u / np.maximum(n_u, 1), np.nan)
        expected = np.where(has, dof_u / np.maximum(n_u, 1), np.nan)
    lo = np.full(mean.shape, np.nan)
    hi = np.full(mean.shape, np.nan)
    if has.any():
        lo[has], hi[has] = chi2_band(dof_u[has], n_u[has], confidence)
    inside = (mean >= lo) & (mean <= hi)
    total_dof = float(dof_u.sum())
    if total_dof > 0:
        plo, phi = chi2_band(total_dof, total_dof, confidence)
        per_dof = float(sum_u.sum() / total_dof)
    else:
        plo = phi = per_dof = float("nan")
    return {
        "mean": mean,
        "expected": expected,
        "lo": lo,
        "hi": hi,
        "fraction_in_band": float(inside[has].mean()) if has.any() else float("nan"),
        "per_dof": per_dof,
        "per_dof_band": (float(plo), float(phi)),
        "total_dof": total_dof,
    }


def residual_statistics(residual: np.ndarray, residual_sigma: np.ndarray | None = None) -> dict:
    """Mean of each measurement's residual over all runs and updates, with its standard error.

    ``residual`` is (..., M), NaN where absent. Returns per-measurement arrays ``mean``, ``stderr``
    (= sample std / √n), ``count``; with ``residual_sigma`` also ``normalized_mean`` and
    ``normalized_std`` of r/σ_r (0 and 1 for a consistent filter).
    """
    residual = np.asarray(residual, dtype=np.float64)
    flat = residual.reshape(-1, residual.shape[-1])
    out = {"mean": [], "stderr": [], "count": []}
    norm_flat = None
    if residual_sigma is not None:
        norm_flat = (residual / np.asarray(residual_sigma, dtype=np.float64)).reshape(flat.shape)
        out["normalized_mean"], out["normalized_std"] = [], []
    for m in range(flat.shape[1]):
        col = flat[:, m]
        col = col[np.isfinite(col)]
        n = col.size
        out["count"].append(int(n))
        out["mean"].append(float(col.mean()) if n else float("nan"))
        out["stderr"].append(float(col.std(ddof=1) / np.sqrt(n)) if n > 1 else float("nan"))
        if norm_flat is not None:
            z = norm_flat[:, m]
            z = z[np.isfinite(z)]
            out["normalized_mean"].append(float(z.mean()) if z.size else float("nan"))
            out["normalized_std"].append(float(z.std(ddof=1)) if z.size > 1 else float("nan"))
    return {k: np.asarray(v) for k, v in out.items()}


def final_sigma(sigma: np.ndarray) -> np.ndarray:
    """Filter 1σ per state at the last epoch, averaged over runs: ``sigma`` (R, T, S) -> (S,)."""
    sigma = np.asarray(sigma, dtype=np.float64)
    return sigma[:, -1, :].mean(axis=0)


def summarize(ds, confidence: float = 0.95) -> dict:
    """The ``summary.json`` content for a results Dataset (schema in docs/results.md)."""
    states = [str(s) for s in ds["state"].values]
    meas = [str(m) for m in ds["meas"].values]
    error = ds["error"].values
    sigma = ds["sigma"].values
    n_runs = error.shape[0]
    fin = final_sigma(sigma)
    final_err_rms = np.sqrt(np.nanmean(error[:, -1, :] ** 2, axis=0))
    final_mean = np.nanmean(error[:, -1, :], axis=0)
    final_sample = np.nanstd(error[:, -1, :], axis=0, ddof=1) if n_runs > 1 else np.full(len(states), np.nan)
    contain = sigma_containment(error, sigma, 3.0)
    s_units = [str(u) for u in ds["state_units"].values] if "state_units" in ds.variables else [""] * len(states)
    m_units = [str(u) for u in ds["meas_units"].values] if "meas_units" in ds.variables else [""] * len(meas)
    per_state = {
        s: {
            "units": str(s_units[i]) if i < len(s_units) else "",
            "final_sigma": float(fin[i]),
            "final_3sigma": float(3.0 * fin[i]),
            "final_error_rms": float(final_err_rms[i]),
            "final_sample_sigma": float(final_sample[i]),
            "final_mean_error": float(final_mean[i]),
            "fraction_inside_3sigma": float(contain[i]),
        }
        for i, s in enumerate(states)
    }
    nees = nees_statistics(ds["nees"].values, len(states), confidence)
    out = {
        "runs": int(n_runs),
        "confidence": confidence,
        "final_time": float(ds["time"].values[-1]),
        "states": per_state,
        "nees": {k: v for k, v in nees.items() if k != "mean"},
    }
    if ds.sizes.get("update", 0) > 0 and len(meas) > 0:
        nis = nis_statistics(ds["nis"].values, ds["nis_dof"].values, confidence)
        res = residual_statistics(ds["residual"].values, ds["residual_sigma"].values)
        out["nis"] = {
            "fraction_in_band": nis["fraction_in_band"],
            "mean_over_updates": _finite_mean(nis["mean"]),
            "expected_over_updates": _finite_mean(nis["expected"]),
            "per_dof": nis["per_dof"],
            "per_dof_band": nis["per_dof_band"],
            "total_dof": nis["total_dof"],
        }
        out["residuals"] = {
            m: {
                "units": str(m_units[j]) if j < len(m_units) else "",
                "mean": float(res["mean"][j]),
                "stderr": float(res["stderr"][j]),
                "count": int(res["count"][j]),
                "normalized_mean": float(res["normalized_mean"][j]),
                "normalized_std": float(res["normalized_std"][j]),
            }
            for j, m in enumerate(meas)
        }
    if "registration_error" in ds:
        pred = ds["registration_sigma"].values if "registration_sigma" in ds else None
        reg = ds["registration_error"].values
        if "update_rejected" in ds:  # the statistics of the images fused (a refused match is recorded, not fused)
            reg = np.where((ds["update_rejected"].values != 0)[..., None], np.nan, reg)
        out["registration"] = registration_statistics(reg, meas, m_units, pred)
    if "update_rejected" in ds:
        out["sar_updates"] = rejection_counts(ds["update_rejected"], ds["pairs_fused"] if "pairs_fused" in ds else None)
    if "focus_error" in ds:  # quality-nav: the focus fixes against their sigma and mapdrift (analysis.focus_nav)
        from sarnav.analysis.focus_nav import focus_statistics

        out["focus"] = focus_statistics(ds, confidence)
    out.update(consistency_verdict(error, sigma, out["nees"]))
    return strict(out)


def _finite_mean(values) -> float:
    """Mean of the finite values; NaN (undefined in summary.json) when there are none."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    return float(v.mean()) if v.size else float("nan")


#: a campaign whose pooled fraction of error samples inside +-3 sigma is below this is reported inconsistent
MIN_POOLED_CONTAINMENT = 0.90


def consistency_verdict(error, sigma, nees: dict) -> dict:
    """``{"consistent": bool, "pooled_fraction_inside_3sigma": f, "inconsistency": [reasons]}``: inconsistent when the
    pooled fraction of error samples inside +-3 sigma is below :data:`MIN_POOLED_CONTAINMENT` (0.9973 expected) or
    the time-averaged mean NEES is beyond twice its band (above 2 x its upper bound or below half its lower one)."""
    pooled = float(sigma_containment(np.reshape(error, (-1, 1)), np.reshape(sigma, (-1, 1)), 3.0)[0])
    reasons = []
    if not pooled >= MIN_POOLED_CONTAINMENT:
        reasons.append(f"{100 * pooled:.1f} % of error samples inside 3 sigma (< {100 * MIN_POOLED_CONTAINMENT:.0f} %)")
    lo, hi = nees["band"]
    t = nees["time_average"]
    if not (lo / 2 <= t <= 2 * hi):
        reasons.append(f"mean NEES {t:.4g} beyond twice its 95 % band [{lo:.4g}, {hi:.4g}]")
    return {"consistent": not reasons, "pooled_fraction_inside_3sigma": pooled, "inconsistency": reasons}


def strict(obj, path: str = ""):
    """``obj`` as strict JSON: numpy values as Python numbers, NaN / inf as null, and every dict that had an undefined
    statistic gets ``"undefined": {key: reason}`` (no samples, one sample, absent measurement)."""
    if isinstance(obj, dict):
        out, why = {}, {}
        for k, v in obj.items():
            out[k] = strict(v, f"{path}.{k}")
            if out[k] is None and v is not None:
                why[k] = _reason(obj, k)
        if why:
            out["undefined"] = why
        return out
    if isinstance(obj, (list, tuple)):
        return [strict(v, path) for v in obj]
    if isinstance(obj, np.ndarray):
        return strict(obj.tolist(), path)
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        obj = obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def _reason(parent: dict, key: str) -> str:
    count = parent.get("count")
    if count == 0:
        return "no samples (the measurement is absent in every update)"
    if count == 1 and key in ("stderr", "std", "normalized_std"):
        return "one sample: no spread"
    if "total_dof" in parent and not parent.get("total_dof"):
        return "no measurements were fused"
    return "not finite (undefined for these data)"


def registration_statistics(reg: np.ndarray, meas: list[str], units: list[str] | None = None,
                            predicted: np.ndarray | None = None) -> dict:
    """Per measurement axis of an image-derived measurement: statistics of the registration error
    (measured minus geometric truth), ``reg`` (R, U, M) with NaN where an axis is not image-derived.

    Returns {meas: {units, count, mean, std, stderr, rms, p99_abs, max_abs}} for the axes with data: the
    numbers that justify the R a filter gives those measurements. With ``predicted`` (R, U, M), the 1-sigma each
    image predicted for its registration: ``predicted_sigma_rms`` (rms over the same samples), ``std_over_predicted``
    (the measured std over it: 1 for a right prediction) and ``normalized_rms`` (rms of error / predicted sigma)."""
    reg = np.asarray(reg, dtype=np.float64)
    out = {}
    for j, m in enumerate(meas):
        e = reg[..., j].ravel()
        keep = np.isfinite(e)
        if predicted is not None:
            s = np.asarray(predicted, dtype=np.float64)[..., j].ravel()
            keep &= np.isfinite(s) & (s > 0)
        e = e[keep]
        if e.size == 0:
            continue
        out[m] = {
            "units": str(units[j]) if units and j < len(units) else "",
            "count": int(e.size),
            "mean": float(e.mean()),
            "std": float(e.std(ddof=1)) if e.size > 1 else 0.0,
            "stderr": float(e.std(ddof=1) / np.sqrt(e.size)) if e.size > 1 else float("nan"),
            "rms": float(np.sqrt(np.mean(e**2))),
            "p99_abs": float(np.percentile(np.abs(e), 99)),
            "max_abs": float(np.max(np.abs(e))),
        }
        if predicted is not None:
            s = s[keep]
            rms_pred = float(np.sqrt(np.mean(s**2)))
            out[m].update(predicted_sigma_rms=rms_pred,
                          std_over_predicted=float(out[m]["std"] / rms_pred) if e.size > 1 else float("nan"),
                          normalized_rms=float(np.sqrt(np.mean((e / s) ** 2))))
    return out


def rejection_counts(rejected, fused=None) -> dict:
    """``{"updates": n, "with_all_pairs_fused": k, "pairs_fused": m, "rejected": {reason: count}}`` of a campaign's
    SAR updates: ``rejected`` the ``update_rejected`` variable (run, update) whose ``flag_meanings`` attribute names
    the codes (0 = fused), ``fused`` the ``pairs_fused`` variable (run, update) or None."""
    codes = np.asarray(rejected.values if hasattr(rejected, "values") else rejected).astype(np.int64)
    meanings = str(getattr(rejected, "attrs", {}).get("flag_meanings", "")).split()
    counts = {}
    for c, n in zip(*np.unique(codes[codes != 0], return_counts=True)):
        name = meanings[c].replace("_", " ") if c < len(meanings) else f"code {c}"
        counts[name] = int(n)
    out = {"updates": int(codes.size), "with_all_pairs_fused": int(np.count_nonzero(codes == 0)), "rejected": counts}
    if fused is not None:
        out["pairs_fused"] = int(np.sum(np.asarray(fused.values if hasattr(fused, "values") else fused)))
    return out


def mean_three_sigma(ds) -> tuple:
    """(time (T,), 3 x the filter 1-sigma averaged over runs (T, S), state names) of a campaign's results."""
    return ds["time"].values, 3.0 * ds["sigma"].values.mean(axis=0), [str(s) for s in ds["state"].values]


def case_statistics(summary: dict, curve: tuple) -> dict:
    """Per state: final 1-sigma and 3-sigma, time-averaged 3-sigma, fraction of errors inside 3-sigma (a study case)."""
    _, sig3, states = curve
    return {s: {"final_sigma": summary["states"][s]["final_sigma"],
                "final_3sigma": summary["states"][s]["final_3sigma"],
                "mean_3sigma": float(np.mean(sig3[:, j])),
                "fraction_inside_3sigma": summary["states"][s]["fraction_inside_3sigma"]}
            for j, s in enumerate(states)}

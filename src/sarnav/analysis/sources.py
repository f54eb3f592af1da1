"""Statistics of campaigns that compare navigation sources (multi-IMU fusion, UPF flight, per-pulse sources).

Their results hold ``source_ms (run, source)``: per run, the mean over the epochs after the settling time of the
squared 3-D position error [m^2] (``sarnav.simulation.fusion_records``). ``summary.json`` -> ``rmse`` is, per
source, ``sqrt(mean over runs)`` — the 3-D RMS error over runs and epochs (Sun 2022 Fig. 5.24 "3-dimensional
positional accuracy"; gap G18) — with a delta-method standard error from the spread of the per-run values.
"""

from __future__ import annotations

import numpy as np

__all__ = ["source_rmse", "rmse_ratio", "filter_nees_summary", "focus_table"]


def source_rmse(ds) -> dict:
    """``{"rmse": {source: m}, "rmse_stderr": {source: m}, "rmse_runs": R}`` from ``ds["source_ms"]``."""
    ms = np.asarray(ds["source_ms"].values, dtype=float)
    names = [str(s) for s in ds["source"].values]
    runs = ms.shape[0]
    mean = ms.mean(axis=0)
    rmse = np.sqrt(mean)
    out = {"rmse": {n: float(v) for n, v in zip(names, rmse)}, "rmse_runs": int(runs)}
    if runs > 1:  # delta method: se(sqrt(m)) = se(m) / (2 sqrt(m))
        se = ms.std(axis=0, ddof=1) / np.sqrt(runs) / (2.0 * np.where(rmse > 0, rmse, np.inf))
        out["rmse_stderr"] = {n: float(v) for n, v in zip(names, se)}
    return out


def filter_nees_summary(ds, confidence: float = 0.95) -> dict:
    """Per filter of ``ds["filter_nees"] (run, time, filter)`` (3 dof): the time-averaged run-mean NEES, its
    per-epoch band and the fraction of epochs inside (``analysis.consistency.nees_statistics``)."""
    from sarnav.analysis.consistency import nees_statistics

    out = {}
    for j, name in enumerate(str(f) for f in ds["filter"].values):
        st = nees_statistics(ds["filter_nees"].values[..., j], 3, confidence)
        out[name] = {k: v for k, v in st.items() if k != "mean"}
    return out


def rmse_ratio(rmse: dict, numerator, denominator) -> float:
    """RMS ratio of two sources or of the mean RMS of several (``numerator`` a name or a list of names)."""
    num = np.mean([rmse[n] for n in ([numerator] if isinstance(numerator, str) else numerator)])
    den = np.mean([rmse[n] for n in ([denominator] if isinstance(denominator, str) else denominator)])
    return float(num / den) if den > 0 else float("nan")


def focus_table(ds) -> list[dict]:
    """One row per source of ``ds["focus"] (run, source, reflector, metric)``: the mean over reflectors and runs
    of each metric (the rows of ``focus.csv``: ``source`` and the metric names)."""
    f = np.asarray(ds["focus"].values, dtype=float)
    metrics = [str(m) for m in ds["metric"].values]
    mean = f.mean(axis=(0, 2))  # (source, metric)
    return [{"source": str(s), **{m: float(mean[j, i]) for i, m in enumerate(metrics)}}
            for j, s in enumerate(ds["source"].values)]

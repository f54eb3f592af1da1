"""Figures drawn over one or several campaigns (``sarnav report``, ``sarnav compare``): consistency (run-mean NEES
and NIS against their χ² bands, normalised by their degrees of freedom so campaigns of different state or
measurement dimension share an axis) and, per block of states, the filter 3σ and the RMS error over runs.

Bands: Bar-Shalom, Li & Kirubarajan (2001) §5.4.2 through :mod:`sarnav.analysis.consistency` — the run mean of
N NEES of n dof lies in ``chi2.ppf([α/2, 1-α/2], N·n)/N`` with probability 1-α; divided by n here.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from sarnav.analysis.consistency import nees_statistics, nis_statistics

__all__ = ["rms_over_runs", "consistency_figure", "state_overlay_figure"]


def rms_over_runs(error: np.ndarray) -> np.ndarray:
    """Root mean square over runs: ``error`` (R, T, S) -> (T, S), NaN samples ignored."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.sqrt(np.nanmean(np.asarray(error, dtype=np.float64) ** 2, axis=0))


def _log_y(ax) -> None:
    """Log y axis with a grid at every tick (matplotlib labels minor ticks where the data span under a decade)."""
    ax.set_yscale("log")
    ax.grid(True, which="both", lw=0.3)


def _has_updates(ds) -> bool:
    return ds.sizes.get("update", 0) > 0 and ds.sizes.get("meas", 0) > 0


def _nees_panel(ax, entries, confidence) -> None:
    for k, (label, ds) in enumerate(entries):
        n = ds.sizes["state"]
        st = nees_statistics(ds["nees"].values, n, confidence)
        c = f"C{k % 10}"
        ax.plot(ds["time"].values, st["mean"] / n, color=c, lw=1.2, label=f"{label} (dof {n}, {st['runs']} runs)")
        for b in st["band"]:
            ax.axhline(b / n, color=c, ls="--", lw=0.8)
    _log_y(ax)
    ax.set_ylabel("run-mean NEES / dof [-]")
    ax.set_title(f"NEES: dashed = {100 * confidence:.0f} % band of the run mean (1 = consistent)", fontsize=9, loc="left")
    ax.legend(fontsize=7, loc="upper right")


def _nis_panel(ax, entries, confidence) -> None:
    for k, (label, ds) in enumerate(entries):
        if not _has_updates(ds):
            continue
        st = nis_statistics(ds["nis"].values, ds["nis_dof"].values, confidence)
        tu, ex = ds["update_time"].values, st["expected"]
        with np.errstate(invalid="ignore", divide="ignore"):
            c = f"C{k % 10}"
            ax.plot(tu, st["mean"] / ex, ".-", color=c, lw=0.8, ms=3, label=label)
            ax.plot(tu, st["lo"] / ex, color=c, ls="--", lw=0.8)
            ax.plot(tu, st["hi"] / ex, color=c, ls="--", lw=0.8)
    _log_y(ax)
    ax.set_ylabel("run-mean NIS / dof [-]")
    ax.set_title(f"NIS per update: dashed = {100 * confidence:.0f} % band", fontsize=9, loc="left")


def consistency_figure(entries: Sequence[tuple[str, object]], confidence: float = 0.95) -> Figure:
    """NEES (and, when any campaign has updates, NIS) of each ``(label, results Dataset)`` against its band."""
    with_nis = any(_has_updates(ds) for _, ds in entries)
    fig = Figure(figsize=(8, 5.6 if with_nis else 3.2), layout="constrained")
    axes = fig.subplots(2 if with_nis else 1, 1, squeeze=False)[:, 0]
    _nees_panel(axes[0], entries, confidence)
    if with_nis:
        _nis_panel(axes[1], entries, confidence)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Filter consistency")
    return fig


def state_overlay_figure(entries: Sequence[tuple[str, object]], states: Sequence[str], units: Sequence[str],
                         title: str) -> Figure:
    """Per state (rows): the filter 3σ (3 × mean over runs of σ; left) and the RMS error over runs (right) of
    every campaign on log axes; ``units`` one per state."""
    fig = Figure(figsize=(11, 2.4 * len(states)), layout="constrained")
    axes = fig.subplots(len(states), 2, sharex=True, squeeze=False)
    for k, (label, ds) in enumerate(entries):
        names = [str(s) for s in ds["state"].values]
        t = ds["time"].values
        sig3 = 3.0 * ds["sigma"].values.mean(axis=0)
        rms = rms_over_runs(ds["error"].values)
        for row, s in enumerate(states):
            j = names.index(s)
            axes[row, 0].plot(t, sig3[:, j], color=f"C{k % 10}", lw=1.2, label=label)
            axes[row, 1].plot(t, rms[:, j], color=f"C{k % 10}", lw=1.0, label=label)
    for row, (s, u) in enumerate(zip(states, units)):
        unit = f" [{u}]" if u else ""
        axes[row, 0].set_ylabel(f"{s} 3σ{unit}")
        axes[row, 1].set_ylabel(f"{s} RMS error{unit}")
        for ax in axes[row]:
            _log_y(ax)
    axes[0, 0].set_title("filter 3σ (mean over runs)", fontsize=9)
    axes[0, 1].set_title("RMS error over runs", fontsize=9)
    axes[0, 0].legend(fontsize=7, loc="best")
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.suptitle(title)
    return fig

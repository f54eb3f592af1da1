"""Figures of the campaigns that compare navigation sources (multi-IMU fusion, UPF flight, navigation-source focus):
the RMS error per source over time (Sun 2022 Figs. 5.5, 5.11-5.13 style), the UPF cloud variance (Fig. 5.26),
the back-projected images side by side (Figs. 6.5-6.9) and the ``focus.csv`` table writer.

Matplotlib object API on the Agg canvas (``report.figures.save_png``)."""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from sarnav.report.figures import save_png

__all__ = ["plot_source_rmse", "plot_cloud_variance", "plot_focus_images", "write_focus_csv", "FOCUS_COLUMNS"]

#: the columns of focus.csv, in order (issue 12)
FOCUS_COLUMNS = ("source", "irw_along_m", "pslr_along_db", "peak_offset_m", "entropy", "kurtosis")


def plot_source_rmse(ds, path) -> str:
    """3-D RMS over runs of each source's position error against time (log scale); the legend gives the RMS
    over runs and epochs after the settling time (summary.json ``rmse``)."""
    t = ds["time"].values
    err = ds["source_error"].values  # (R, T, S, 3)
    names = [str(s) for s in ds["source"].values]
    rms_t = np.sqrt(np.mean(np.sum(err**2, axis=-1), axis=0))  # (T, S)
    total = np.sqrt(ds["source_ms"].values.mean(axis=0))
    fig = Figure(figsize=(8, 4.2), constrained_layout=True)
    ax = fig.subplots()
    for j, name in enumerate(names):
        ax.semilogy(t, np.maximum(rms_t[:, j], 1e-6), lw=1.0, label=f"{name}: {total[j]:.3g} m")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("3-D position error, RMS over runs [m]")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7, ncol=2, title="RMS after settling", title_fontsize=7)
    fig.suptitle(f"Position error per navigation source: {err.shape[0]} runs")
    return save_png(fig, path)


def plot_cloud_variance(ds, path) -> str:
    """The UPF cloud's position variance per NED axis, normalised by its late median (Fig. 5.26), mean over
    runs, with the settling times (T13)."""
    t = ds["time"].values
    var = ds["cloud_var"].values.mean(axis=0)  # (T, 3)
    late = np.median(var[t >= t[0] + 0.5 * (t[-1] - t[0])], axis=0)
    fig = Figure(figsize=(8, 3.8), constrained_layout=True)
    ax = fig.subplots()
    for a, name in enumerate(("N", "E", "D")):
        ax.semilogy(t, var[:, a] / late[a], lw=0.9, label=f"{name} (late median {np.sqrt(late[a]):.3g} m 1σ)")
    st = ds["settle_time"].values
    ax.axvline(float(st.max()), color="k", lw=0.8, ls="--", label=f"settled: {st.max():.1f} s (worst run)")
    ax.axvline(75.0, color="r", lw=0.8, ls=":", label="75 s (source, L1285)")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("cloud variance / late median")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7)
    fig.suptitle("UPF cloud position variance after each fix (Fig. 5.26)")
    return save_png(fig, path)


def plot_focus_images(images: dict, extent, targets, path, title: str = "") -> str:
    """Images side by side: ``images`` source -> (rows, cols) magnitude of one run's image [linear], ``extent``
    (east0, east1, north0, north1) [m] of every image, ``targets`` (n, 2) true (north, east) [m]. Each panel in dB
    relative to the truth image's peak (Figs. 6.5-6.9)."""
    names = list(images)
    ref = max(float(np.max(np.abs(images.get("truth", next(iter(images.values())))))), 1e-300)
    cols = 4
    rows = int(np.ceil(len(names) / cols))
    fig = Figure(figsize=(3.2 * cols, 3.3 * rows), constrained_layout=True)
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    im = None
    for ax, name in zip(axes, names):
        db = 20.0 * np.log10(np.maximum(np.abs(images[name]), 1e-12 * ref) / ref)
        im = ax.imshow(db, origin="lower", extent=extent, vmin=-40.0, vmax=0.0, cmap="viridis", aspect="equal")
        ax.plot(np.asarray(targets)[:, 1], np.asarray(targets)[:, 0], "r+", ms=8, mew=0.8)
        ax.set_title(f"{name} (peak {db.max():.1f} dB)", fontsize=9)
        ax.set_xlabel("east (cross-track) [m]", fontsize=7)
        ax.set_ylabel("north (along-track) [m]", fontsize=7)
        ax.tick_params(labelsize=6)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    if im is not None:
        fig.colorbar(im, ax=list(axes[:len(names)]), shrink=0.6, label="dB re truth peak")
    fig.suptitle(title or "Back-projected images per navigation source (+: true reflectors)")
    return save_png(fig, path)


def write_focus_csv(rows: list[dict], path: str | os.PathLike) -> str:
    """``focus.csv``: one row per source with exactly :data:`FOCUS_COLUMNS` (numbers with 6 significant digits),
    written atomically (temporary file + ``os.replace``)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(FOCUS_COLUMNS)
    for r in rows:
        w.writerow([r["source"]] + [f"{float(r[c]):.6g}" for c in FOCUS_COLUMNS[1:]])
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(buf.getvalue())
    os.replace(tmp, path)
    return str(path)

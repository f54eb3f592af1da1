"""Campaign figures in the style of the thesis (Lindstrom 2020, Figs 3.4-3.7): Monte Carlo error
hairlines against the filter's ±3σ, one figure per block (position, velocity, attitude; panels N, E,
D), and measurement residuals against ±3√(HP⁻Hᵀ+R).

Matplotlib's object API with the Agg canvas (no pyplot, no global backend change). The ±3σ curve is
three times the mean over runs of the filter 1σ; at most ``max_runs`` runs are drawn (evenly thinned).
"""

from __future__ import annotations

import io
import os
import warnings
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

__all__ = ["state_blocks", "thin_runs", "error_figure", "plot_error_block", "residual_limit", "residual_figure",
           "plot_residuals", "campaign_figures", "write_campaign_figures", "save_png", "png_bytes"]

#: figure name -> (title, state names); drawn when all three states exist
KNOWN_BLOCKS = (
    ("position", "Position error", ("pN", "pE", "pD")),
    ("velocity", "Velocity error", ("vN", "vE", "vD")),
    ("attitude", "Attitude error", ("thN", "thE", "thD")),
)


def save_png(fig: Figure, path: str | os.PathLike, dpi: int = 110) -> str:
    """Write ``fig`` as PNG at ``path`` (parent folders created); returns the path."""
    FigureCanvasAgg(fig)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return str(path)


def png_bytes(fig: Figure, dpi: int = 110) -> bytes:
    """``fig`` as PNG bytes (for pages that embed their figures)."""
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def state_blocks(state_names: Sequence[str]) -> list[tuple[str, str, list[int]]]:
    """(file stem, title, state indices) for the standard blocks present; if none is present, the
    states in groups of three (``states_1``, ...)."""
    names = list(state_names)
    blocks = [(stem, title, [names.index(s) for s in want]) for stem, title, want in KNOWN_BLOCKS if all(s in names for s in want)]
    if not blocks:
        for k in range(0, len(names), 3):
            idx = list(range(k, min(k + 3, len(names))))
            blocks.append((f"states_{k // 3 + 1}", "Error " + ", ".join(names[i] for i in idx), idx))
    return blocks


def thin_runs(n_runs: int, max_runs: int) -> np.ndarray:
    """At most ``max_runs`` run indices spread evenly over 0..n_runs-1."""
    if n_runs <= max_runs:
        return np.arange(n_runs)
    return np.unique(np.linspace(0, n_runs - 1, max_runs).round().astype(int))


def _units(ds, coord: str) -> list[str]:
    name = f"{coord}_units"
    if name in ds.coords:
        return [str(u) for u in ds[name].values]
    return [""] * ds.sizes[coord]


def error_figure(ds, indices: Sequence[int], title: str, max_runs: int = 50) -> Figure:
    """Panels (one per state) of error hairlines with ±3σ (mean σ over runs)."""
    t = ds["time"].values
    err = ds["error"].values
    sig3 = 3.0 * ds["sigma"].values.mean(axis=0)
    runs = thin_runs(err.shape[0], max_runs)
    names = [str(s) for s in ds["state"].values]
    units = _units(ds, "state")
    fig = Figure(figsize=(8, 2.3 * len(indices)), constrained_layout=True)
    axes = fig.subplots(len(indices), 1, sharex=True, squeeze=False)[:, 0]
    for ax, i in zip(axes, indices):
        ax.plot(t, err[runs, :, i].T, color="0.45", lw=0.5, alpha=0.6)
        ax.plot(t, sig3[:, i], "r", lw=1.4, label="±3σ (filter)")
        ax.plot(t, -sig3[:, i], "r", lw=1.4)
        ax.set_ylabel(f"{names[i]} [{units[i]}]" if units[i] else names[i])
        ax.grid(True, lw=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"{title}: {len(runs)} of {err.shape[0]} runs")
    return fig


def plot_error_block(ds, indices: Sequence[int], title: str, path, max_runs: int = 50) -> str:
    """:func:`error_figure` saved as PNG at ``path``."""
    return save_png(error_figure(ds, indices, title, max_runs), path)


#: residual panels: y limits = RESIDUAL_MARGIN x the RESIDUAL_PERCENTILE-th percentile over updates of the per-update
#: envelope max(|residual| over the drawn runs, 3 sigma), so that a few large early updates do not flatten the rest
RESIDUAL_PERCENTILE = 80.0
RESIDUAL_MARGIN = 1.3


def residual_limit(residual: np.ndarray, sigma3: np.ndarray) -> float | None:
    """Half-height of a residual panel scaled to the bulk of the data.

    ``residual`` (R, U) of one measurement (NaN where absent), ``sigma3`` (U,) its 3σ bound. Returns
    ``RESIDUAL_MARGIN`` × the ``RESIDUAL_PERCENTILE``-th percentile over updates of
    ``max(max_runs |residual|, sigma3)``, or None when there is nothing finite to scale to.
    """
    with warnings.catch_warnings():  # updates without this measurement
        warnings.simplefilter("ignore", RuntimeWarning)
        env = np.fmax(np.nanmax(np.abs(residual), axis=0), np.abs(sigma3))
    env = env[np.isfinite(env)]
    if env.size == 0:
        return None
    lim = RESIDUAL_MARGIN * float(np.percentile(env, RESIDUAL_PERCENTILE))
    return lim if lim > 0 else None


def _residual_panel(ax, tu, res, s3, label) -> None:
    """Residual dots, ±3σ, robust limits; residuals beyond them drawn as triangles on the edge and counted."""
    ax.plot(tu, res.T, ".", color="0.4", ms=1.5, alpha=0.6)
    ax.plot(tu, s3, "r", lw=1.2, label="±3σ residual")
    ax.plot(tu, -s3, "r", lw=1.2)
    lim = residual_limit(res, s3)
    if lim is not None:
        ax.set_ylim(-lim, lim)
        t = np.broadcast_to(tu, res.shape)
        over, under = res > lim, res < -lim
        ax.plot(t[over], np.full(over.sum(), 0.96 * lim), "^", color="C1", ms=4)
        ax.plot(t[under], np.full(under.sum(), -0.96 * lim), "v", color="C1", ms=4)
        n_out = int(over.sum() + under.sum())
        if n_out:
            ax.set_title(f"{n_out} of {int(np.isfinite(res).sum())} residuals beyond ±{lim:.3g} (triangles on the edge)",
                         loc="left", fontsize=7, color="C1")
    ax.set_ylabel(label)
    ax.grid(True, lw=0.3)


def residual_figure(ds, max_runs: int = 20) -> Figure:
    """Residual of each measurement against ±3√(HP⁻Hᵀ+R) (mean over runs), thesis Fig 3.4 style; each panel
    scaled to the bulk of the data (:func:`residual_limit`)."""
    tu = ds["update_time"].values
    res = ds["residual"].values
    with warnings.catch_warnings():  # updates where a measurement is absent in every run
        warnings.simplefilter("ignore", RuntimeWarning)
        s3 = 3.0 * np.nanmean(ds["residual_sigma"].values, axis=0)
    runs = thin_runs(res.shape[0], max_runs)
    names = [str(m) for m in ds["meas"].values]
    units = _units(ds, "meas")
    n = len(names)
    fig = Figure(figsize=(8, 2.3 * max(n, 1)), constrained_layout=True)
    axes = fig.subplots(max(n, 1), 1, sharex=True, squeeze=False)[:, 0]
    for j in range(n):
        _residual_panel(axes[j], tu, res[runs, :, j], s3[:, j], f"{names[j]} [{units[j]}]" if units[j] else names[j])
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"Measurement residuals: {len(runs)} of {res.shape[0]} runs (y limits: bulk of the data)")
    return fig


def plot_residuals(ds, path, max_runs: int = 20) -> str:
    """:func:`residual_figure` saved as PNG at ``path``."""
    return save_png(residual_figure(ds, max_runs), path)


def campaign_figures(ds, max_runs: int = 50) -> dict[str, Figure]:
    """The standard figures of a campaign, ``{name: Figure}``: one per block of states (``position``, ``velocity``,
    ``attitude``, ...) and ``residuals`` when the campaign has measurement updates (``sarnav.figures``)."""
    figs = {stem: error_figure(ds, idx, title, max_runs) for stem, title, idx in state_blocks(ds["state"].values)}
    if ds.sizes.get("update", 0) and ds.sizes.get("meas", 0):
        figs["residuals"] = residual_figure(ds)
    return figs


def write_campaign_figures(ds, out, kind=None, max_runs: int = 50) -> list[str]:
    """All standard figures of a campaign (:func:`campaign_figures`) into ``out/figures/<name>.png``, then the
    kind's own; returns the paths written."""
    figdir = Path(out) / "figures"
    paths = [save_png(fig, figdir / f"{stem}.png") for stem, fig in campaign_figures(ds, max_runs).items()]
    if kind is not None:
        paths.extend(kind.figures(ds, figdir))
    return paths

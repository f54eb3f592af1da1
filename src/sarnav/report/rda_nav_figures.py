"""Figures of the image-aided flight (NAVIGATION paper style): the images of one sub-aperture of the
first run (reference, in-flight image before and after mapdrift, correlation surface; paper Figs 4–6)
and the position 3σ with and without SAR on a log scale (paper Fig. 15).

Matplotlib object API on the Agg canvas, as :mod:`sarnav.report.figures`.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from sarnav.report.figures import save_png

__all__ = ["plot_aperture_images", "plot_sar_ablation"]


def _db(a, floor=-40.0):
    a = np.abs(np.asarray(a))
    peak = a.max() if a.size and a.max() > 0 else 1.0
    return np.maximum(20 * np.log10(np.maximum(a / peak, 1e-12)), floor)


def plot_aperture_images(capture: dict, path) -> str:
    """2×2 grid of one sub-aperture's images.

    ``capture`` (written by ``ApertureImager.measure`` when asked): ``reference`` (SarImage focused with
    the true track), ``before`` (in-flight image focused with the estimated speed), ``after`` (after
    mapdrift), ``correlation`` (surface, lags_y, lags_x), ``run``, ``aperture``, ``speed_hat``,
    ``autofocus_speed``, ``used`` ("mapdrift" or "estimate").
    """
    fig = Figure(figsize=(11, 8.5), layout="constrained")
    axes = fig.subplots(2, 2)
    panels = (("reference", "reference (true track)"),
              ("before", f"in flight, before autofocus (V̂ = {capture['speed_hat']:.3f} m/s)"),
              ("after", f"after mapdrift (V = {capture['autofocus_speed']:.3f} m/s; used: {capture['used']})"))
    for ax, (key, title) in zip(axes.flat, panels):
        img = capture[key]
        ext = [img.x[0], img.x[-1], img.y[-1], img.y[0]]
        im = ax.imshow(_db(img.data), extent=ext, aspect="auto", cmap="gray", vmin=-40, vmax=0)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("slant range [m]")
        ax.set_ylabel(f"{img.y_name.replace('_', ' ')} [m]")
    fig.colorbar(im, ax=axes[0, :], label="dB re peak", shrink=0.8)
    surf, ly, lx = capture["correlation"]
    ax = axes[1, 1]
    cim = ax.imshow(np.abs(surf) / max(np.abs(surf).max(), 1e-300), extent=[lx[0], lx[-1], ly[-1], ly[0]],
                    aspect="auto", cmap="viridis", vmin=0, vmax=1)
    fig.colorbar(cim, ax=ax, label="|correlation| / peak [-]", shrink=0.8)
    ax.set_title("correlation of the reference chip with the in-flight image", fontsize=9)
    ax.set_xlabel("range lag [pixels]")
    ax.set_ylabel("azimuth lag [pixels]")
    fig.suptitle(f"run {capture['run']}, sub-aperture {capture['aperture']} (t = {capture['aperture']}–"
                 f"{capture['aperture'] + 1} s)")
    return save_png(fig, path)


def plot_sar_ablation(time_with, sigma_with, time_without, sigma_without, path, names=("pN", "pE", "pD")) -> str:
    """Position 3σ with and without SAR updates on a log scale (paper Fig. 15).

    ``sigma_*``: (T, 3) filter 1σ of the position states [m].
    """
    fig = Figure(figsize=(8, 7.5), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    for i, ax in enumerate(axes):
        ax.semilogy(time_with, 3 * np.asarray(sigma_with)[:, i], color="C0", label="SAR + altimeter")
        ax.semilogy(time_without, 3 * np.asarray(sigma_without)[:, i], color="C3", ls="--", label="altimeter only")
        ax.set_ylabel(f"{names[i]} 3σ [m]")
        ax.grid(True, which="both", lw=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Position 3σ with and without SAR (paper Fig. 15 style)")
    return save_png(fig, path)

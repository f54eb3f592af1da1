"""Tables and figures of the ``bpa-sensitivity`` study: ``sensitivity.csv`` and the image grid ``sensitivity.png``
(thesis Figs 4.11-4.13: |image| in dB, X = reference target, O = predicted image position)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from sarnav.analysis.bpa_sensitivity import CSV_FIELDS
from sarnav.report.figures import save_png

__all__ = ["write_csv", "plot_grid"]


def _cell(v) -> str:
    if isinstance(v, str):
        return v
    return f"{v:.6g}" if np.isfinite(v) else ""  # undefined (e.g. no IRW of a response without nulls): empty


def write_csv(results, path, fields=CSV_FIELDS) -> Path:
    """One row per case, the attributes named in ``fields`` (numbers with 6 significant digits; an undefined value,
    such as the IRW of a response too blurred to have -3 dB points inside the image, is an empty cell)."""
    path = Path(path)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fields)
        for r in results:
            w.writerow([_cell(getattr(r, f)) for f in fields])
    return path


def plot_grid(results, ref, path) -> Path:
    """Figure like thesis Figs 4.11-4.13: |image| in dB, X = reference target, O = predicted location."""
    n = len(results)
    ncol = 3
    nrow = int(math.ceil(n / ncol))
    fig = Figure(figsize=(4.0 * ncol, 3.2 * nrow), layout="constrained")
    axes = fig.subplots(nrow, ncol, squeeze=False)
    peak = np.max(np.abs(ref.data))
    for ax, r in zip(axes.flat, results):
        img = r.image
        db = 20 * np.log10(np.maximum(np.abs(img.data) / peak, 1e-6))
        im = ax.imshow(db, origin="lower", cmap="gray", vmin=-40, vmax=0, aspect="equal",
                       extent=[img.x[0], img.x[-1], img.y[0], img.y[-1]])
        ax.plot(r.reference_xy[1], r.reference_xy[0], "rx", ms=9, mew=2, label="X reference")
        ax.plot(r.predicted_xy[1], r.predicted_xy[0], "o", mfc="none", mec="c", ms=10, mew=2, label="O predicted")
        ax.set_title(f"{r.name} {r.value:g} {r.unit}", fontsize=9)
        ax.set_xlabel("east [m]", fontsize=8)
        ax.set_ylabel("north [m]", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7, loc="upper right")
    fig.colorbar(im, ax=list(axes.flat[:n]), label="amplitude [dB re reference peak]", shrink=0.8)
    return Path(save_png(fig, path))

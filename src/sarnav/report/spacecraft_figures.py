"""Figures of the spacecraft SAR navigation campaigns in the style of Pogorelsky et al. 2022 Figs. 8-11: every run's
error (grey), the sample mean (dashed black), the filter-predicted 3-sigma (red, mean over runs) and the sample
3-sigma (green), for position, velocity and antenna misalignment in ECEF as the paper reports, and position and
velocity in the radial / in-track / cross-track frame of the true orbit (where the weak in-track direction shows).
Closed loop extras: the autofocus sharpness curve (paper Fig. 4) and the registration of one image with its inliers
(paper Fig. 5).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from sarnav import units
from sarnav.report.figures import save_png, thin_runs

__all__ = ["paper_style_panels", "write_spacecraft_figures", "plot_sharpness_curve", "plot_registration"]

#: (file stem, title, variable, component names, display scale, display unit)
ECEF_BLOCKS = (("sc_position_ecef", "Position error (ECEF)", "error", ("rX", "rY", "rZ"), 1.0, "m"),
               ("sc_velocity_ecef", "Velocity error (ECEF)", "error", ("vX", "vY", "vZ"), 1.0, "m/s"),
               ("sc_misalignment", "Antenna misalignment error (antenna axes, z = boresight)", "error",
                ("muX", "muY", "muZ"), float(units.rad_to_deg(1.0)), "deg"))
RIC_BLOCKS = (("sc_position_ric", "Position error (radial / in-track / cross-track)", ("pR", "pI", "pC"), "m"),
              ("sc_velocity_ric", "Velocity error (radial / in-track / cross-track)", ("vR", "vI", "vC"), "m/s"))


def paper_style_panels(t, err, sig, names, title, unit, max_runs: int = 100, t_scale=None) -> Figure:
    """One panel per component: err (R, T, k) grey per run, sample mean, predicted (mean of sig) and sample 3-sigma.
    The y range is scaled to the curves from ``t_scale`` on (the first update: the initial 3-sigma would flatten
    the rest), default the whole record."""
    fig = Figure(figsize=(8, 2.3 * len(names)), constrained_layout=True)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    runs = thin_runs(err.shape[0], max_runs)
    mean = err.mean(axis=0)
    sample3 = 3.0 * (err.std(axis=0, ddof=1) if err.shape[0] > 1 else np.full_like(mean, np.nan))
    pred3 = 3.0 * sig.mean(axis=0)
    for k, (ax, name) in enumerate(zip(axes, names)):
        ax.plot(t, err[runs, :, k].T, color="0.6", lw=0.4, alpha=0.6)
        ax.plot(t, mean[:, k], "k--", lw=1.2, label="sample mean")
        ax.plot(t, pred3[:, k], "r", lw=1.3, label="predicted 3σ")
        ax.plot(t, -pred3[:, k], "r", lw=1.3)
        ax.plot(t, sample3[:, k], "g", lw=1.3, label="sample 3σ")
        ax.plot(t, -sample3[:, k], "g", lw=1.3)
        sel = np.asarray(t) >= (t[0] if t_scale is None else t_scale)
        env = np.concatenate([pred3[sel, k], np.abs(sample3[sel, k])])
        env = env[np.isfinite(env)]
        if env.size and np.max(env) > 0:
            ax.set_ylim(-1.5 * np.max(env), 1.5 * np.max(env))
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(True, lw=0.3)
    axes[0].legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"{title}: {len(runs)} of {err.shape[0]} runs")
    return fig


def write_spacecraft_figures(ds, outdir) -> list[str]:
    """The paper-style figures of a spacecraft campaign into ``outdir``; returns the paths."""
    outdir = Path(outdir)
    t = ds["time"].values
    states = [str(s) for s in ds["state"].values]
    paths = []
    t1 = float(ds["update_time"].values[0]) if ds.sizes.get("update", 0) else None
    for stem, title, _, names, scale, unit in ECEF_BLOCKS:
        idx = [states.index(n) for n in names]
        fig = paper_style_panels(t, ds["error"].values[:, :, idx] * scale, ds["sigma"].values[:, :, idx] * scale,
                                 names, title, unit, t_scale=t1)
        paths.append(save_png(fig, outdir / f"{stem}.png"))
    if "error_ric" in ds:
        ric = [str(s) for s in ds["ric"].values]
        for stem, title, names, unit in RIC_BLOCKS:
            idx = [ric.index(n) for n in names]
            fig = paper_style_panels(t, ds["error_ric"].values[:, :, idx], ds["sigma_ric"].values[:, :, idx],
                                     names, title, unit, t_scale=t1)
            paths.append(save_png(fig, outdir / f"{stem}.png"))
    return paths


def plot_sharpness_curve(speeds, sharpness, visited, truth_speed, path) -> str:
    """Paper Fig. 4: normalised-variance sharpness against the processor's velocity, the hill climb's evaluations
    (``visited``: (speed, sharpness) pairs) and the true effective velocity."""
    fig = Figure(figsize=(6.5, 3.6), constrained_layout=True)
    ax = fig.subplots()
    s0 = float(truth_speed)
    ax.plot(np.asarray(speeds) - s0, sharpness, "k.-", lw=1.0, label="sharpness (eq. 3)")
    if len(visited):
        v = np.asarray(visited, dtype=float)
        ax.plot(v[:, 0] - s0, v[:, 1], "ro", ms=4, label="hill-climb evaluations")
    ax.axvline(0.0, color="g", lw=1.0, label="true effective velocity")
    ax.set_xlabel(f"processor velocity - true V_r ({s0:.2f} m/s) [m/s]")
    ax.set_ylabel("normalised variance")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7)
    return save_png(fig, path)


def plot_registration(image, reference, src, dst, inliers, centre_image, centre_reference, path) -> str:
    """Paper Fig. 5: the formed amplitude image and the geocoded reference side by side, matched features (inliers
    drawn in green, outliers grey), the image centre pixel and where it lands in the reference."""
    fig = Figure(figsize=(10, 5), constrained_layout=True)
    a, b = fig.subplots(1, 2)
    for ax, img, ttl in ((a, image, "formed image (azimuth x slant range)"), (b, reference, "reference (map grid)")):
        ax.imshow(np.asarray(img), cmap="gray", origin="lower", aspect="auto",
                  vmax=np.percentile(img, 99.5) if np.size(img) else None)
        ax.set_title(ttl, fontsize=9)
    src, dst, inl = np.asarray(src).reshape(-1, 2), np.asarray(dst).reshape(-1, 2), np.asarray(inliers, bool)
    for pts, ax in ((src, a), (dst, b)):
        if pts.size:
            ax.plot(pts[~inl, 1], pts[~inl, 0], "x", color="0.7", ms=3)
            ax.plot(pts[inl, 1], pts[inl, 0], "g+", ms=5)
    a.plot(centre_image[1], centre_image[0], "r*", ms=10)
    if centre_reference is not None:
        b.plot(centre_reference[1], centre_reference[0], "r*", ms=10)
    fig.suptitle(f"registration: {int(inl.sum())} inliers of {len(inl)} matches")
    return save_png(fig, path)

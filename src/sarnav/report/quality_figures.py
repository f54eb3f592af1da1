"""Files and figures of the image-quality scenarios (docs/quality.md).

* ``quality-sweep``: ``sweep.nc`` (score versus velocity error, both directions), figures in the style of Hathaway
  (2023) Figs. 4.1-4.8 and the T16 reliability histogram;
* ``gpsd-search`` / ``gpsd-search-table41``: ``rho.csv`` (exactly the columns of ``ROW_COLUMNS``),
  ``rho_diagnostics.csv``, whisker plots in the style of Figs. 4.19-4.25 (red median, box 25-75 %, whiskers min/max
  as MATLAB's ``boxplot`` with the thesis' settings, the line rho = 1), the failure analysis (rho versus spacing, rho
  against the reach bound) and the improved searches on the same realisations.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sarnav.analysis.consistency import strict
from sarnav.cf import apply_cf
from sarnav.report.figures import save_png

__all__ = ["write_rows_csv", "write_strict_json", "sweep_dataset", "plot_score_curves", "plot_t3", "plot_reliability", "plot_whiskers",
           "plot_realisations", "plot_noise_runs", "plot_failure", "plot_methods", "plot_focus_nav"]


def _cell(v) -> str:
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v)) if math.isfinite(v) else ""  # an undefined value (a failed run) is an empty cell


def write_rows_csv(rows, path, columns) -> Path:
    """``rows`` (dicts) as CSV with exactly ``columns``; floats written exactly (repr), NaN as an empty cell. Written
    to ``path.partial`` and renamed, so an interrupted write never leaves a file that looks complete."""
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in rows:
            w.writerow([_cell(r[c]) for c in columns])
    os.replace(tmp, path)
    return path


def write_strict_json(obj, path) -> Path:
    """``obj`` as strict JSON (numpy values as numbers, arrays as lists, NaN as null with the reason:
    ``analysis.consistency.strict``), written through ``path.partial``."""
    path = Path(path)
    tmp = path.with_name(path.name + ".partial")
    tmp.write_text(json.dumps(strict(obj), indent=2, allow_nan=False) + "\n", encoding="utf-8")
    os.replace(tmp, path)
    return path


def sweep_dataset(sweeps: dict, attrs: dict) -> xr.Dataset:
    """One Dataset of the sweeps of every direction: dims ``direction``, ``size``, ``bins``, ``step`` (grid step,
    0 = no error); ``error`` (direction, step) is the injected error (along-track: relative, cross-track: m/m), CF-1.10
    (:mod:`sarnav.cf`); the sweeps' ``maximise_<measure>`` (1: larger is better focus) and ``pivot`` attributes kept."""
    parts, kept = [], {}
    for direction, ds in sweeps.items():
        kept.update({k: v for k, v in ds.attrs.items() if k.startswith("maximise_") or k == "pivot"})
        n = ds.sizes["error"]
        d = ds.assign_coords(step=("error", np.arange(n) - n // 2)).swap_dims(error="step").reset_coords("error")
        d.attrs = {}
        parts.append(d.expand_dims(direction=[direction]))
    out = xr.concat(parts, dim="direction")
    out["error"].attrs = {"units": "1", "long_name": "constant velocity error of the track used for back-projection: "
                          "relative along-track speed error (direction along) or cross-track velocity over the speed "
                          "(direction cross)"}
    for name in out.data_vars:
        if name != "error":
            sense = kept.get(f"maximise_{name}")
            better = "" if sense is None else f": {'larger' if sense else 'smaller'} is better focus"
            out[name].attrs.update(units="1", long_name=f"{name} of the BPA image{better}")
    coords = {"direction": ("", "direction of the velocity error"),
              "size": ("1", "image size n (n x n pixels over the fixed scene extent)"),
              "bins": ("1", "histogram bins N of the entropy measures"),
              "step": ("1", "step of the error grid (0: no error)")}
    for name, (units, long_name) in coords.items():
        if name in out.coords:
            out[name].attrs.update({"long_name": long_name, **({"units": units} if units else {})})
    out.attrs.update({k: v for k, v in attrs.items() if isinstance(v, (str, int, float))})
    out.attrs.update({k: int(v) if isinstance(v, (bool, np.bool_)) else v for k, v in kept.items()})
    return apply_cf(out, "sarnav quality-sweep: focus measures of BPA images versus velocity error")


def _panel_curve(ax, ds, measure, size, n_bins, scatter):
    e = ds["error"].values
    c = ds[measure].sel(size=size)
    if "bins" in c.dims:
        c = c.sel(bins=n_bins)
    x = 100.0 * e if ds.attrs.get("direction") == "along" else e
    ax.plot(x, c.values, "o" if scatter else "o-", ms=3)
    ax.axvline(0.0, color="0.6", lw=0.8)
    ax.tick_params(labelsize=7)


def plot_score_curves(ds, measures, panels, path, title: str, scatter: bool = False) -> Path:
    """Rows = measures, columns = ``panels`` [(size, bins)]: score versus velocity error (Figs. 4.2-4.8)."""
    fig = Figure(figsize=(3.0 * len(panels), 2.3 * len(measures)), layout="constrained")
    axes = fig.subplots(len(measures), len(panels), squeeze=False)
    unit = "along-track velocity error [%]" if ds.attrs.get("direction") == "along" else "cross-track error [m/m]"
    for i, m in enumerate(measures):
        for j, (size, n_bins) in enumerate(panels):
            ax = axes[i, j]
            _panel_curve(ax, ds, m, size, n_bins, scatter)
            label = f"{size}x{size}" + (f", N = {n_bins}" if "bins" in ds[m].dims else "")
            ax.set_title(f"{m} ({label})", fontsize=8)
            if i == len(measures) - 1:
                ax.set_xlabel(unit, fontsize=8)
    fig.suptitle(title, fontsize=10)
    return Path(save_png(fig, path))


def plot_t3(t3: dict, spacing: float, path) -> Path:
    """Fig. 4.1: the reference image, 0.2 % along-track and 0.002 m/m cross-track error (|image| in dB)."""
    fig = Figure(figsize=(10.5, 3.6), layout="constrained")
    axes = fig.subplots(1, 3)
    ref = t3["reference"]
    peak = float(np.max(np.abs(ref)))
    n = ref.shape[0]
    ext = [-n * spacing / 2, n * spacing / 2, -n * spacing / 2, n * spacing / 2]
    for ax, key, label in zip(axes, ("reference", "along", "cross"),
                              ("(a) nominal track", "(b) 0.2 % along-track", "(c) 0.002 m/m cross-track")):
        db = 20 * np.log10(np.maximum(np.abs(t3[key]) / peak, 1e-4))
        im = ax.imshow(db, origin="lower", cmap="gray", vmin=-40, vmax=0, extent=ext)
        extra = "" if key == "reference" else (f"\ncorrelation {t3[key + '_correlation']:.2f}, sharpness "
                                                f"{t3[key + '_sharpness']:.2f}, shift {t3[key + '_shift_m'][0]:+.2f} m")
        ax.set_title(label + extra, fontsize=8)
        ax.set_xlabel("east [m]", fontsize=8)
        ax.set_ylabel("north (along-track) [m]", fontsize=8)
    fig.colorbar(im, ax=list(axes), label="dB re reference peak", shrink=0.8)
    return Path(save_png(fig, path))


def plot_reliability(best_steps, measures, path) -> Path:
    """T16: distance of each measure's extremum from zero error (grid steps) over the scenes."""
    steps = np.abs(np.round(np.asarray(best_steps)))
    fig = Figure(figsize=(6.5, 3.2), layout="constrained")
    ax = fig.subplots()
    top = int(max(2, steps.max()))
    w = 0.8 / len(measures)
    for j, m in enumerate(measures):
        counts = [np.sum(steps[:, j] == k) for k in range(top + 1)]
        ax.bar(np.arange(top + 1) + (j - len(measures) / 2 + 0.5) * w, counts, w, label=m)
    ax.set_xlabel("|extremum| [grid steps from zero error]")
    ax.set_ylabel("scenes")
    ax.set_title(f"T16: extremum of each measure over {steps.shape[0]} point/clutter scenes", fontsize=9)
    ax.legend(fontsize=7)
    return Path(save_png(fig, path))


# ---------------------------------------------------------------------------------------------
# the search (rho.csv)

def _select(rows, **eq):
    return [r for r in rows if all(r[k] == v for k, v in eq.items()) and math.isfinite(r["rho"])]


def _boxes(ax, groups, labels):
    """MATLAB-style boxplot as in the thesis: red median, box 25-75 %, whiskers to min / max, line at 1."""
    data = [np.asarray(g, dtype=float) for g in groups]
    keep = [k for k, g in enumerate(data) if g.size]
    if keep:
        ax.boxplot([data[k] for k in keep], positions=[k + 1 for k in keep], whis=(0, 100), widths=0.6,
                   medianprops={"color": "red"}, boxprops={"color": "navy"}, showfliers=False)
    ax.axhline(1.0, color="deepskyblue", lw=1.0)
    ax.set_xticks(np.arange(1, len(labels) + 1))
    ax.set_xticklabels(labels, rotation=60, fontsize=6)
    ax.tick_params(axis="y", labelsize=7)


def plot_whiskers(rows, block_pulses: int, candidates: int, methods, path) -> Path:
    """Figs. 4.19-4.21: rho across the spacings for every sigma, one panel per method (first realisation)."""
    methods = [m for m in methods if _select(rows, method=m, block_pulses=block_pulses, candidates=candidates)]
    sigmas = sorted({r["sigma"] for r in rows if r["block_pulses"] == block_pulses})
    fig = Figure(figsize=(max(4.0, 3.6 * len(methods)), 3.4), layout="constrained")
    axes = fig.subplots(1, max(len(methods), 1), squeeze=False)[0]
    r0 = min((r["realisation"] for r in rows), default=0)
    for ax, m in zip(axes, methods):
        sel = _select(rows, method=m, block_pulses=block_pulses, candidates=candidates, realisation=r0)
        _boxes(ax, [[r["rho"] for r in sel if r["sigma"] == s] for s in sigmas], [f"{s:.3g}" for s in sigmas])
        ax.set_title(m, fontsize=9)
        ax.set_xlabel("sigma [m/sample]", fontsize=8)
    axes[0].set_ylabel("variance ratio rho", fontsize=8)
    fig.suptitle(f"S_i = {block_pulses}, L = {candidates}", fontsize=10)
    return Path(save_png(fig, path))


def plot_realisations(rows, block_pulses: int, candidates: int, path, method: str = "source") -> Path | None:
    """Figs. 4.22-4.24: of the realisations, the best (lowest median rho), the most compact (smallest spread) and the
    most variable (largest spread), on a common y-scale; None with fewer than two realisations."""
    sel = _select(rows, method=method, block_pulses=block_pulses, candidates=candidates)
    reals = sorted({r["realisation"] for r in sel})
    if len(reals) < 2:
        return None
    by = {k: [r for r in sel if r["realisation"] == k] for k in reals}
    med = {k: np.median([r["rho"] for r in v]) for k, v in by.items()}
    spread = {k: np.ptp([r["rho"] for r in v]) for k, v in by.items()}
    picks = [("best", min(med, key=med.get)), ("compact", min(spread, key=spread.get)),
             ("variable", max(spread, key=spread.get))]
    sigmas = sorted({r["sigma"] for r in sel})
    fig = Figure(figsize=(11.0, 3.4), layout="constrained")
    axes = fig.subplots(1, 3, sharey=True)
    for ax, (what, k) in zip(axes, picks):
        _boxes(ax, [[r["rho"] for r in by[k] if r["sigma"] == s] for s in sigmas], [f"{s:.3g}" for s in sigmas])
        ax.set_title(f"{what}: realisation {k}", fontsize=9)
        ax.set_xlabel("sigma [m/sample]", fontsize=8)
    axes[0].set_ylabel("variance ratio rho", fontsize=8)
    fig.suptitle(f"{method}, S_i = {block_pulses}, L = {candidates}: {len(reals)} noise realisations", fontsize=10)
    return Path(save_png(fig, path))


def plot_noise_runs(rows, block_pulses: int, candidates: int, sigma: float, drifts: dict, path,
                    method: str = "source") -> Path | None:
    """Fig. 4.25: (a) rho across the spacings of up to three realisations at one sigma; (b) the along-track position
    error each realisation's noise makes, ``drifts`` {realisation: (P,) [m]}. None with fewer than two."""
    reals = sorted(drifts)[:3]
    if len(reals) < 2:
        return None
    fig = Figure(figsize=(11.0, 3.6), layout="constrained")
    ax_a, ax_b = fig.subplots(1, 2)
    groups = [[r["rho"] for r in _select(rows, method=method, block_pulses=block_pulses, candidates=candidates,
                                         realisation=k) if r["sigma"] == sigma] for k in reals]
    _boxes(ax_a, groups, [f"run {k}" for k in reals])
    ax_a.set_ylabel("variance ratio rho", fontsize=8)
    ax_a.set_title(f"(a) {method}, S_i = {block_pulses}, L = {candidates}, sigma = {sigma:.4g}", fontsize=9)
    for k in reals:
        ax_b.plot(drifts[k], lw=0.8, label=f"run {k}")
    ax_b.set_xlabel("pulse", fontsize=8)
    ax_b.set_ylabel("along-track position error of the noise [m]", fontsize=8)
    ax_b.set_title("(b) the noise of each run (bias + sigma w, cumulated)", fontsize=9)
    ax_b.legend(fontsize=7)
    return Path(save_png(fig, path))


def plot_failure(rows, path) -> Path:
    """Why the thesis' search fails: (a) median rho over sigma versus the spacing index for the thesis' scorer and the
    controls; (b) every rho against its reach bound B with the envelope (1 - B)^2 .. (1 + B)^2."""
    fig = Figure(figsize=(11.0, 3.8), layout="constrained")
    ax_a, ax_b = fig.subplots(1, 2)
    for m, style in (("source", "o-"), ("source-oracle", "s--"), ("source-random", "^:"), ("source-carry", "d-.")):
        for (si, L) in sorted({(r["block_pulses"], r["candidates"]) for r in _select(rows, method=m)}):
            sel = _select(rows, method=m, block_pulses=si, candidates=L)
            by_sigma = {}
            for r in sel:
                by_sigma.setdefault(r["sigma"], []).append(r["rho"])
            n = min(len(v) for v in by_sigma.values())
            med = np.median([v[:n] for v in by_sigma.values()], axis=0)
            ax_a.plot(np.arange(1, n + 1), med, style, ms=3, label=f"{m} S_i={si} L={L}")
    ax_a.axhline(1.0, color="deepskyblue", lw=1.0)
    ax_a.set_xlabel("spacing index (Delta = index x sigma / 1e4 for 30 spacings)", fontsize=8)
    ax_a.set_ylabel("median rho over sigma", fontsize=8)
    ax_a.legend(fontsize=6)
    pts = [r for r in rows if math.isfinite(r["rho"]) and math.isfinite(r.get("reach", float("nan")))]
    for m in sorted({r["method"] for r in pts}):
        sel = [r for r in pts if r["method"] == m]
        ax_b.loglog([max(r["reach"], 1e-6) for r in sel], [r["rho"] for r in sel], ".", ms=3, label=m)
    b = np.logspace(-4, 1, 200)
    ax_b.loglog(b, (1 + b) ** 2, "k-", lw=0.8, label="(1 +- B)^2")
    ax_b.loglog(b[b < 1], (1 - b[b < 1]) ** 2, "k-", lw=0.8)
    ax_b.set_xlabel("reach bound B = max slope x std(t) / std(noisy error)", fontsize=8)
    ax_b.set_ylabel("rho", fontsize=8)
    ax_b.legend(fontsize=6)
    return Path(save_png(fig, path))


def plot_methods(rows, path) -> Path:
    """Every method on the same noise realisations: rho per method and (S_i, L), log scale."""
    keys = sorted({(r["method"], r["block_pulses"], r["candidates"]) for r in rows if math.isfinite(r["rho"])},
                  key=lambda k: (k[1], k[2], k[0]))
    fig = Figure(figsize=(max(5.0, 0.55 * len(keys) + 2), 3.8), layout="constrained")
    ax = fig.subplots()
    groups = [[r["rho"] for r in _select(rows, method=m, block_pulses=si, candidates=L)] for m, si, L in keys]
    _boxes(ax, groups, [f"{m} {si}/{L}" for m, si, L in keys])
    ax.set_yscale("log")
    ax.set_ylabel("variance ratio rho", fontsize=8)
    ax.set_title("every method on the same noise realisations", fontsize=9)
    return Path(save_png(fig, path))


# ---------------------------------------------------------------------------------------------
# quality-nav

def plot_focus_nav(ds, free_time, free_sigma, path, max_runs: int = 50) -> Path:
    """(a) along-track (north) velocity error of the runs, the filter's mean +-3 sigma and the free INS's 3 sigma
    (run 0 without fixes); (b) every fix error against time with the mean +-1 sigma the filter gave the fixes, and
    mapdrift's speed error on the same pulses."""
    states = [str(s) for s in ds["state"].values]
    j = states.index("vN")
    t = ds["time"].values
    err = ds["error"].values[:max_runs, :, j]
    s3 = 3.0 * ds["sigma"].values[:, :, j].mean(axis=0)
    fig = Figure(figsize=(11.0, 3.8), layout="constrained")
    ax_a, ax_b = fig.subplots(1, 2)
    ax_a.plot(t, err.T, color="0.6", lw=0.5)
    ax_a.plot(t, s3, "r-", label="+-3 sigma (focus-aided)")
    ax_a.plot(t, -s3, "r-")
    ax_a.plot(free_time, 3.0 * free_sigma[:, j], "b--", label="+-3 sigma (free INS)")
    ax_a.plot(free_time, -3.0 * free_sigma[:, j], "b--")
    ax_a.set_xlabel("time [s]", fontsize=8)
    ax_a.set_ylabel("vN error [m/s]", fontsize=8)
    ax_a.legend(fontsize=7)
    tu = ds["update_time"].values
    fe = ds["focus_error"].values
    ax_b.plot(np.broadcast_to(tu, fe.shape).ravel(), fe.ravel(), ".", ms=2, color="0.4", label="focus fix error")
    if "mapdrift_error" in ds and np.isfinite(ds["mapdrift_error"].values).any():
        md = ds["mapdrift_error"].values
        ax_b.plot(np.broadcast_to(tu, md.shape).ravel() + 0.15, md.ravel(), "x", ms=2, color="tab:green",
                  label="mapdrift speed error")
    fs_ = np.sqrt(np.nanmean(ds["focus_sigma"].values ** 2, axis=0))
    ax_b.plot(tu, fs_, "r-", label="+-1 sigma given to the fixes")
    ax_b.plot(tu, -fs_, "r-")
    ax_b.set_xlabel("time [s]", fontsize=8)
    ax_b.set_ylabel("error [m/s]", fontsize=8)
    ax_b.legend(fontsize=7)
    return Path(save_png(fig, path))

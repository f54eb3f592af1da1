"""The files of the image-quality kinds (docs/quality.md): ``quality-sweep`` (``sweep.nc`` through a ``.partial``
file, ``claims.json``, ``figures/``) and ``gpsd-search`` (``rho.csv``, ``rho_diagnostics.csv``, ``search.json``,
``figures/``)."""

from __future__ import annotations

from pathlib import Path

from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.measurements.focus_search import DIAGNOSTIC_COLUMNS, ROW_COLUMNS
from sarnav.report.quality_figures import (plot_failure, plot_methods, plot_noise_runs, plot_realisations,
                                           plot_reliability, plot_score_curves, plot_t3, plot_whiskers, sweep_dataset,
                                           write_rows_csv, write_strict_json)

__all__ = ["write_sweep_files", "write_search_files", "sweep_figures", "search_figures"]


def write_sweep_files(res: dict, prm, name: str, out: Path, figures: bool) -> Path:
    """``sweep.nc`` (written whole, then renamed), ``claims.json`` and (``figures``) the figures of the quality sweep
    ``res`` of ``prm`` (``analysis.quality_sweep``) of the scenario ``name``; returns the path of ``sweep.nc``."""
    ds = sweep_dataset(res["sweeps"], {"scenario": name, "references": "Hathaway 2023 §4.1.1"})
    path = out / "sweep.nc"
    ds.to_netcdf(out / "sweep.nc.partial")
    Path(out / "sweep.nc.partial").replace(path)
    write_strict_json(res["claims"], out / "claims.json")
    if figures:
        sweep_figures(res, prm, out / "figures")
    return path


def write_search_files(res, prm, out: Path, figures: bool) -> Path:
    """``rho.csv``, ``rho_diagnostics.csv``, ``search.json`` and (``figures``) the figures of the search sweep ``res``
    of ``prm`` (``simulation.gpsd_search``); returns the path of ``rho.csv``."""
    path = write_rows_csv(res.rows, out / "rho.csv", ROW_COLUMNS)
    write_rows_csv(res.rows, out / "rho_diagnostics.csv", ROW_COLUMNS + DIAGNOSTIC_COLUMNS)
    write_strict_json(res.summary, out / "search.json")
    if figures:
        search_figures(res.rows, prm, out / "figures")
    return path


def sweep_figures(res: dict, prm, figdir: Path) -> list[Path]:
    """Figs. 4.1-4.8 of the sweep ``res`` (``analysis.quality_sweep.run``) into ``figdir``, and T16's reliability."""
    figdir.mkdir(exist_ok=True)
    measures = list(prm.measures)
    fig_n = min(prm.sizes, key=lambda n: abs(n - prm.figure_size))
    b0, bmax = prm.bins[0], prm.bins[-1]
    paths = [plot_t3(res["t3"], prm.geometry.grid_spacing(prm.figure_size), figdir / "fig4_1_images.png")]
    three = [m for m in ("kurtosis", "entropy_magnitude", "entropy_sum") if m in measures] or measures[:3]
    for d, ds in res["sweeps"].items():
        sizes = [(n, bmax) for n in prm.sizes]
        bins = [(fig_n, b) for b in prm.bins]
        if d == "along":
            paths.append(plot_score_curves(ds, three, [(fig_n, b0)], figdir / f"fig4_2_along_{fig_n}.png",
                                           f"Fig. 4.2: along-track, {fig_n}x{fig_n}, N = {b0}", scatter=True))
            paths.append(plot_score_curves(ds, measures, sizes, figdir / "fig4_3-4_6_sizes.png",
                                           f"Figs. 4.3-4.6: along-track, N = {bmax}"))
        else:
            paths.append(plot_score_curves(ds, measures, sizes, figdir / "cross_sizes.png",
                                           f"cross-track (T8), N = {bmax}"))
        ent = [m for m in measures if QUALITY_MEASURES[m].uses_bins] or measures[:1]
        name = "fig4_7_bins_along.png" if d == "along" else "fig4_8_bins_cross.png"
        paths.append(plot_score_curves(ds, ent, bins, figdir / name,
                                       f"Fig. {'4.7' if d == 'along' else '4.8'}: {d}-track, {fig_n}x{fig_n}"))
    if res["reliability"] is not None:
        paths.append(plot_reliability(res["reliability"][1], list(prm.reliability.measures),
                                      figdir / "t16_reliability.png"))
    return paths


def search_figures(rows, prm, figdir: Path) -> None:
    """The search's figures (Figs. 4.19-4.25, the failure analysis, every method) into ``figdir``."""
    figdir.mkdir(exist_ok=True)
    methods = ["source", "source-carry", "source-oracle", "source-random"]
    sigma, drifts = prm.noise_drifts()
    for si, L in prm.configurations:
        plot_whiskers(rows, si, L, methods, figdir / f"whiskers_Si{si}_L{L}.png")
        plot_realisations(rows, si, L, figdir / f"realisations_Si{si}_L{L}.png")
        plot_noise_runs(rows, si, L, sigma, drifts, figdir / f"fig4_25_Si{si}_L{L}.png")
    plot_failure(rows, figdir / "failure_analysis.png")
    plot_methods(rows, figdir / "methods.png")

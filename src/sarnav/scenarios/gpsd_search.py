"""Scenario kind ``gpsd-search``: the velocity-offset search of Hathaway (2023) Alg. 3.3, its controls and searches
that work (docs/quality.md §4-§6).

Configuration and wiring only: the defaults, ``parse`` (TOML ->
:class:`~sarnav.simulation.gpsd_search.GpsdSearchParams`) and the kind; the sweep is ``sarnav.simulation.gpsd_search``
(over ``sarnav.measurements.focus_search.table41_rows``: Alg. 3.3 exactly, the controls, the spanning grid and Brent),
the files and figures ``sarnav.report.quality_figures``. Scenarios:

* ``gpsd-search``: a reduced Table 4.1 sweep (S_i = 500, L = 11, the ten sigma of Table 4.1, 5 spacings, one
  noise realisation), about two minutes on 2 cores;
* ``gpsd-search-table41``: the full Table 4.1 sweep (S_i in {100, 500, 1000}, L in {11, 22}, 10 sigma x 30
  spacings); ``--runs 10`` gives the ten realisations of Figs. 4.22-4.24.

``campaign.runs`` is the number of noise realisations (one noise vector per realisation and sigma, shared by the
spacings: gap 13), ``campaign.seed`` their seed. Keys of ``[search]``: ``method`` (searches, each scored by
``search.measure``: ``"source"`` the thesis' algorithm, ``"source-carry"`` the same grid keeping the chosen offsets
(gap 10's other reading), ``"grid"`` and ``"brent"`` the searches spanning the bias), ``controls`` (``"one"``: L = 1,
rho = 1 exactly; ``"oracle"``, ``"random"`` scorers on the thesis' grid), ``candidates`` (L, a list),
``block_pulses`` (S_i, a list), ``initial_pulses`` (S_0), ``sigmas`` and ``spacings`` (how many of Table 4.1's
linspace values), ``bias`` [m/sample], ``span_sigmas`` (the spanning searches cover +-(|b| + span_sigmas sigma /
sqrt(S_i))), ``measure``.

Files in ``--out``: ``rho.csv`` (columns exactly ``method, block_pulses, candidates, sigma, spacing, realisation,
rho``), ``rho_diagnostics.csv`` (the same rows with scorer, coverage, agreement with the oracle, reach bound and the
error of a failed run), ``search.json`` (per (S_i, L) and method: median, mean, range, per-sigma means; the failure
analysis; the source's numbers) and ``figures/``.
"""

from __future__ import annotations

from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.measurements.focus_search import DIAGNOSTIC_COLUMNS, ROW_COLUMNS
from sarnav.montecarlo.kind import validate_campaign
from sarnav.scenarios.fields import choice, int_list, integer, name_list, number
from sarnav.scenarios.kind_base import FileKind
from sarnav.scenarios.quality_tables import read_geometry, read_scene
from sarnav.scenarios.registry import packaged
from sarnav.simulation.gpsd_search import SEARCH_CONTROLS, SEARCH_METHODS, SOURCE_RHO, GpsdSearchParams, run

__all__ = ["GpsdSearchKind", "default_config", "parse", "run_search_scenario", "SEARCH_METHODS",
           "SEARCH_CONTROLS", "GpsdSearchParams", "SOURCE_RHO"]

#: search runs that form images (controls need none): about 1 s each for S_i = 500 at 200 x 200 on 2 cores
MAX_IMAGE_RUNS = 20_000


def default_config() -> dict:
    """``gpsd-search``: the reduced sweep (S_i = 500, L = 11, 10 sigma x 5 spacings, one realisation):
    ``defaults/gpsd-search.toml`` (``gpsd-search-table41.toml``: every (S_i, L) of Table 4.1, 10 sigma x 30
    spacings, L656-666)."""
    return packaged("gpsd-search")


def _parse_search(cfg: dict, geo) -> dict:
    s = {"methods": name_list(cfg, "search", "method", SEARCH_METHODS, allow_empty=True),
         "controls": name_list(cfg, "search", "controls", SEARCH_CONTROLS, allow_empty=True),
         "candidates": int_list(cfg, "search", "candidates", 1, 200),
         "block_pulses": int_list(cfg, "search", "block_pulses", 1, 100_000),
         "initial_pulses": integer(cfg, "search", "initial_pulses", 1, 100_000),
         "sigmas": integer(cfg, "search", "sigmas", 1, 100),
         "spacings": integer(cfg, "search", "spacings", 1, 300),
         "bias": number(cfg, "search", "bias", -1e-3, 1e-3, "m/sample"),
         "span_sigmas": number(cfg, "search", "span_sigmas", 0.0, 100.0),
         "measure": choice(cfg, "search", "measure", sorted(QUALITY_MEASURES))}
    if not s["methods"] and not s["controls"]:
        raise ConfigError("search.method", "and search.controls are both empty: nothing to run")
    if s["initial_pulses"] >= geo.n_pulses:
        raise ConfigError("search.initial_pulses", f"must be < aperture.n_pulses = {geo.n_pulses}, "
                          f"got {s['initial_pulses']}")
    left = geo.n_pulses - s["initial_pulses"]
    for i, si in enumerate(s["block_pulses"]):
        if si > left:
            raise ConfigError(f"search.block_pulses[{i}]", f"a block of {si} pulses is longer than the {left} pulses "
                              f"after the initial {s['initial_pulses']}; must be <= {left}")
    if s["bias"] == 0.0 and s["sigmas"] < 1:  # pragma: no cover - sigmas >= 1 above
        raise ConfigError("search.bias", "no noise to correct")
    return s


def parse(cfg: dict) -> GpsdSearchParams:
    """Checked content of a gpsd-search scenario; ConfigError names the first bad key and its range."""
    runs, seed = validate_campaign(cfg)
    geo = read_geometry(cfg)
    scene = read_scene(cfg, geo)
    size = integer(cfg, "image", "size", 2, 400)
    s = _parse_search(cfg, geo)
    per = s["sigmas"] * (s["spacings"] * sum(m.startswith("source") for m in s["methods"])
                         + sum(m in ("grid", "brent") for m in s["methods"]))
    image_runs = runs * len(s["candidates"]) * len(s["block_pulses"]) * per
    if image_runs > MAX_IMAGE_RUNS:
        raise ConfigError("campaign.runs", f"{image_runs} search runs that form images; at most {MAX_IMAGE_RUNS} "
                          "(fewer realisations, spacings, sigmas or configurations)")
    work = image_runs * geo.n_pulses * size ** 2 * 4
    if work > 1e14:
        raise ConfigError("image.size", f"{work:.3g} pixel-pulse moment evaluations; at most 1e14")
    return GpsdSearchParams(runs=runs, seed=seed, geometry=geo, scene=scene, size=size,
                            **{k: tuple(v) if isinstance(v, list) else v for k, v in s.items()})


def _figures(rows, prm: GpsdSearchParams, figdir: Path) -> None:
    from sarnav.report.quality_figures import (plot_failure, plot_methods, plot_noise_runs, plot_realisations,
                                               plot_whiskers)

    figdir.mkdir(exist_ok=True)
    methods = ["source", "source-carry", "source-oracle", "source-random"]
    sigma, drifts = prm.noise_drifts()
    for si, L in prm.configurations:
        plot_whiskers(rows, si, L, methods, figdir / f"whiskers_Si{si}_L{L}.png")
        plot_realisations(rows, si, L, figdir / f"realisations_Si{si}_L{L}.png")
        plot_noise_runs(rows, si, L, sigma, drifts, figdir / f"fig4_25_Si{si}_L{L}.png")
    plot_failure(rows, figdir / "failure_analysis.png")
    plot_methods(rows, figdir / "methods.png")


def _progress(rows: int, seconds: float) -> None:
    print(f"gpsd-search: {rows} runs, {seconds:.0f} s", flush=True)


def run_search_scenario(cfg: dict, out, figures: bool = True, overwrite: bool = False, quiet: bool = True) -> Path:
    """Run the sweep (``simulation.gpsd_search.run``) into ``out`` (``INCOMPLETE`` until the end; ``rho.csv`` is
    written, through ``rho.csv.partial``, only when every row is done, so an interrupted sweep never leaves a file
    that looks complete). Returns the path of ``rho.csv``."""
    from sarnav.montecarlo.outdir import OutputFolder, identity
    from sarnav.report.quality_figures import write_rows_csv, write_strict_json

    prm = parse(cfg)
    out = Path(out)
    with OutputFolder(out, identity(cfg), overwrite=overwrite):
        marker = out / "INCOMPLETE"
        marker.write_text("gpsd-search running\n")
        res = run(prm, None if quiet else _progress)
        path = write_rows_csv(res.rows, out / "rho.csv", ROW_COLUMNS)
        write_rows_csv(res.rows, out / "rho_diagnostics.csv", ROW_COLUMNS + DIAGNOSTIC_COLUMNS)
        write_strict_json(res.summary, out / "search.json")
        if figures:
            _figures(res.rows, prm, out / "figures")
        marker.unlink()
    return path


class GpsdSearchKind(FileKind):
    """``gpsd-search``: the search sweep, run by :func:`run_search_scenario` (not through ``simulate``); the
    realisations run in this process."""

    kind = "gpsd-search"
    config, check, write = staticmethod(default_config), staticmethod(parse), staticmethod(run_search_scenario)
    options = ("figures", "overwrite", "quiet")
    what = "a sweep"

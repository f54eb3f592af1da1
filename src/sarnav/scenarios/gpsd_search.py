"""Scenario kind ``gpsd-search``: the velocity-offset search of Hathaway (2023) Alg. 3.3, its controls and searches
that work (docs/quality.md §4-§6: the ``[search]`` keys, the scenarios ``gpsd-search`` and ``gpsd-search-table41``,
the files ``rho.csv``, ``rho_diagnostics.csv``, ``search.json`` and ``figures/``).

Configuration and wiring only: the defaults, ``parse`` (TOML -> :class:`~sarnav.simulation.gpsd_search.
GpsdSearchParams`) and the kind; the sweep is ``sarnav.simulation.gpsd_search`` (over
``sarnav.measurements.focus_search.table41_rows``), the files and figures ``sarnav.report.quality_figures``.
``campaign.runs`` is the number of noise realisations (one noise vector per realisation and sigma, shared by the
spacings: gap 13), ``campaign.seed`` their seed.
"""

from __future__ import annotations

import sys
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.montecarlo.kind import validate_campaign
from sarnav.scenarios.fields import choice, int_list, integer, name_list, number
from sarnav.scenarios.kind_base import FileKind, writing
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
    prm = GpsdSearchParams(runs=runs, seed=seed, geometry=geo, scene=scene, size=size,
                           **{k: tuple(v) if isinstance(v, list) else v for k, v in s.items()})
    image_runs = prm.image_runs()
    if image_runs > MAX_IMAGE_RUNS:
        raise ConfigError("campaign.runs", f"{image_runs} search runs that form images; at most {MAX_IMAGE_RUNS} "
                          "(fewer realisations, spacings, sigmas or configurations)")
    work = image_runs * geo.n_pulses * size ** 2 * 4
    if work > 1e14:
        raise ConfigError("image.size", f"{work:.3g} pixel-pulse moment evaluations; at most 1e14")
    return prm


def _progress(rows: int, seconds: float) -> None:
    print(f"gpsd-search: {rows} runs, {seconds:.0f} s", file=sys.stderr, flush=True)


def run_search_scenario(cfg: dict, out, figures: bool = True, overwrite: bool = False, quiet: bool = True) -> Path:
    """Run the sweep (``simulation.gpsd_search.run``) into ``out`` (``INCOMPLETE`` until the end; the files of
    ``report.quality_files.write_search_files``: ``rho.csv`` only when every row is done, so an interrupted sweep
    never leaves a file that looks complete). Returns the path of ``rho.csv``."""
    from sarnav.report.quality_files import write_search_files

    prm = parse(cfg)
    with writing(cfg, out, overwrite, "gpsd-search"):
        return write_search_files(run(prm, None if quiet else _progress), prm, Path(out), figures)


class GpsdSearchKind(FileKind):
    """``gpsd-search``: the search sweep, run by :func:`run_search_scenario` (not through ``simulate``); the
    realisations run in this process."""

    kind = "gpsd-search"
    config, check, write = staticmethod(default_config), staticmethod(parse), staticmethod(run_search_scenario)
    options = ("figures", "overwrite", "quiet")
    what = "a sweep"

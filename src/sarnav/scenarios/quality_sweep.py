"""Scenario kind ``quality-sweep``: focus score versus along- and cross-track velocity error (Hathaway 2023 §4.1.1).

Configuration and wiring only: the defaults, ``parse`` (TOML ->
:class:`~sarnav.analysis.quality_sweep.QualitySweepParams`) and the kind; the sweep is
``sarnav.analysis.quality_sweep.run``, the measures ``sarnav.imaging.quality``, the files (``sweep.nc``,
``claims.json``, ``figures/``) and figures ``sarnav.report.quality_figures`` (docs/quality.md §3). Sizes keep the
ground extent (``scene.extent``) and vary the pixel count (gap 4).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from sarnav.analysis.quality_sweep import DIRECTIONS, RELIABILITY_SCENES, QualitySweepParams, ReliabilitySpec, run
from sarnav.errors import ConfigError
from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.scenarios.fields import choice, int_list, integer, name_list, number
from sarnav.scenarios.kind_base import FileKind, writing
from sarnav.scenarios.quality_tables import MAX_ECHO_WORK, read_geometry, read_scene
from sarnav.scenarios.registry import packaged

__all__ = ["QualitySweepKind", "default_config", "parse", "run_sweep", "QualitySweepParams"]

PIVOTS = ("first", "centre")
#: BPA work of a sweep (pixels x pulses over every image), about 3 min on 2 cores
MAX_BPA_WORK = 3e11


def default_config() -> dict:
    """Figs. 4.1-4.8 on the USU-like picture, and T16 over 20 point/clutter scenes: ``defaults/quality-sweep.toml``."""
    return packaged("quality-sweep")


def _parse_sweep(cfg: dict) -> dict:
    return {"directions": tuple(name_list(cfg, "sweep", "directions", DIRECTIONS)),
            "sizes": tuple(sorted(int_list(cfg, "sweep", "sizes", 2, 400))),
            "bins": tuple(sorted(int_list(cfg, "sweep", "bins", 2, 100_000))),
            "measures": tuple(name_list(cfg, "sweep", "measures", sorted(QUALITY_MEASURES))),
            "steps": integer(cfg, "sweep", "steps", 1, 50),
            "span_depths": number(cfg, "sweep", "span_depths", 0.1, 100.0, "focus depths"),
            "figure_size": integer(cfg, "sweep", "figure_size", 2, 400),
            "pivot": choice(cfg, "sweep", "pivot", PIVOTS)}


def _parse_reliability(cfg: dict) -> ReliabilitySpec:
    return ReliabilitySpec(scenes=integer(cfg, "reliability", "scenes", 0, 200),
                           size=integer(cfg, "reliability", "size", 2, 400),
                           bins=integer(cfg, "reliability", "bins", 2, 100_000),
                           seed=integer(cfg, "reliability", "seed", 0, 2**63 - 1),
                           clutter_density=number(cfg, "reliability", "clutter_density", 0.01, 100.0, "1/m^2"),
                           measures=tuple(name_list(cfg, "reliability", "measures", sorted(QUALITY_MEASURES))),
                           scene=choice(cfg, "reliability", "scene", RELIABILITY_SCENES),
                           contrast_db=number(cfg, "reliability", "contrast_db", 0.0, 30.0, "dB"),
                           correlation_m=number(cfg, "reliability", "correlation_m", 0.05, 100.0, "m"),
                           texture_density=number(cfg, "reliability", "texture_density", 0.01, 1000.0, "1/m^2"),
                           span_depths=number(cfg, "reliability", "span_depths", 0.0, 100.0, "focus depths") or None)


def parse(cfg: dict) -> QualitySweepParams:
    """Checked, SI content of a quality-sweep scenario; ConfigError names the first bad key and its range."""
    geo = read_geometry(cfg)
    prm = QualitySweepParams(geometry=geo, scene=read_scene(cfg, geo), **_parse_sweep(cfg),
                             reliability=_parse_reliability(cfg))
    rel = prm.reliability
    n_err = 2 * prm.steps + 1
    work = geo.n_pulses * n_err * (len(prm.directions) * sum(n * n for n in prm.sizes) + prm.figure_size ** 2)
    if work > MAX_BPA_WORK:
        raise ConfigError("sweep.sizes", f"{work:.3g} pixel-pulses of back-projection; at most {MAX_BPA_WORK:.0e} "
                          "(fewer or smaller sizes, fewer steps, fewer pulses)")
    rel_work = rel.scenes * geo.n_pulses * n_err * rel.size ** 2
    if rel_work > MAX_BPA_WORK:
        raise ConfigError("reliability.scenes", f"{rel_work:.3g} pixel-pulses of back-projection; at most "
                          f"{MAX_BPA_WORK:.0e}")
    key, density = (("texture_density", rel.texture_density) if rel.scene == "textured"
                    else ("clutter_density", rel.clutter_density))
    if rel.scenes and density * geo.scene_extent**2 * geo.n_pulses > MAX_ECHO_WORK:
        raise ConfigError(f"reliability.{key}", f"{density * geo.scene_extent**2 * geo.n_pulses:.3g} scatterers x "
                          f"pulses; at most {MAX_ECHO_WORK:.0e} (a lower density, a smaller scene or fewer pulses)")
    return prm


def _stderr_progress():
    """``progress(text)`` of :func:`analysis.quality_sweep.run`: one line per stage on stderr, with the seconds since
    the sweep started."""
    t0 = time.perf_counter()
    return lambda text: print(f"quality-sweep: {text} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)


def run_sweep(cfg: dict, out, figures: bool = True, overwrite: bool = False, quiet: bool = True) -> Path:
    """Run the sweep (``analysis.quality_sweep.run``) into ``out`` (claimed as ``montecarlo.outdir.OutputFolder``;
    ``INCOMPLETE`` until the end; ``report.quality_files.write_sweep_files``); returns the path of ``sweep.nc``. Unless ``quiet``, each stage is
    told on stderr."""
    from sarnav.report.quality_files import write_sweep_files

    prm = parse(cfg)
    with writing(cfg, out, overwrite, "quality-sweep"):
        return write_sweep_files(run(prm, None if quiet else _stderr_progress()), prm, cfg["scenario"]["name"],
                                 Path(out), figures)


class QualitySweepKind(FileKind):
    """``quality-sweep``: a deterministic study run by :func:`run_sweep` (not a Monte Carlo campaign)."""

    kind = "quality-sweep"
    needs_campaign = False
    config, check, write = staticmethod(default_config), staticmethod(parse), staticmethod(run_sweep)
    options = ("figures", "overwrite", "quiet")

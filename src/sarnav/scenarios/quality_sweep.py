"""Scenario kind ``quality-sweep``: focus score versus along- and cross-track velocity error (Hathaway 2023 §4.1.1).

Configuration and wiring only: the defaults, ``parse`` (TOML ->
:class:`~sarnav.analysis.quality_sweep.QualitySweepParams`) and the kind; the sweep is
``sarnav.analysis.quality_sweep.run`` (score of BPA images formed along tracks with a constant velocity error), the
measures ``sarnav.imaging.quality``, the files and figures ``sarnav.report.quality_figures`` (docs/quality.md §3). ``sarnav run quality-sweep`` writes into ``--out``:

* ``sweep.nc``: every measure versus error for each image size and bin count, both directions;
* ``claims.json``: the thesis' claims T3, T7-T17 with the numbers of this sweep beside the source's statement;
* ``figures/``: ``fig4_1_images.png`` (T3), ``fig4_2_along_100.png``, ``fig4_3-4_6_sizes.png``, ``fig4_7_bins_along.png``,
  ``fig4_8_bins_cross.png``, ``cross_sizes.png`` and (``reliability.scenes`` > 0) ``t16_reliability.png``.

Sizes keep the ground extent (``scene.extent``) and vary the pixel count (gap 4): 10, 50, 100, 200 pixels
(the thesis' 300 x 300 is 200 x 200 here).
"""

from __future__ import annotations

from pathlib import Path

from sarnav.analysis.quality_sweep import DIRECTIONS, QualitySweepParams, ReliabilitySpec, run
from sarnav.errors import ConfigError
from sarnav.imaging.quality import QUALITY_MEASURES
from sarnav.scenarios.fields import choice, int_list, integer, name_list, number
from sarnav.scenarios.kind_base import FileKind
from sarnav.scenarios.quality_tables import read_geometry, read_scene
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
                           measures=tuple(name_list(cfg, "reliability", "measures", sorted(QUALITY_MEASURES))))


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
    if rel.scenes and rel.clutter_density * geo.scene_extent**2 * geo.n_pulses > 1e8:
        raise ConfigError("reliability.clutter_density", "too many clutter scatterers x pulses (at most 1e8)")
    return prm


def _figures(res: dict, prm: QualitySweepParams, figdir: Path) -> list[Path]:
    from sarnav.report.quality_figures import plot_reliability, plot_score_curves, plot_t3

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


def run_sweep(cfg: dict, out, figures: bool = True, overwrite: bool = False) -> Path:
    """Run the sweep (``analysis.quality_sweep.run``) into ``out`` (claimed as ``montecarlo.outdir.OutputFolder``;
    ``INCOMPLETE`` until the end); returns the path of ``sweep.nc``."""
    from sarnav.montecarlo.outdir import OutputFolder, identity
    from sarnav.report.quality_figures import sweep_dataset, write_strict_json

    prm = parse(cfg)
    out = Path(out)
    with OutputFolder(out, identity(cfg), overwrite=overwrite):
        marker = out / "INCOMPLETE"
        marker.write_text("quality-sweep running\n")
        res = run(prm)
        ds = sweep_dataset(res["sweeps"], {"scenario": cfg["scenario"]["name"], "source": "Hathaway 2023 §4.1.1"})
        path = out / "sweep.nc"
        ds.to_netcdf(out / "sweep.nc.partial")
        Path(out / "sweep.nc.partial").replace(path)
        write_strict_json(res["claims"], out / "claims.json")
        if figures:
            _figures(res, prm, out / "figures")
        marker.unlink()
    return path


class QualitySweepKind(FileKind):
    """``quality-sweep``: a deterministic study run by :func:`run_sweep` (not a Monte Carlo campaign)."""

    kind = "quality-sweep"
    needs_campaign = False
    config, check, write = staticmethod(default_config), staticmethod(parse), staticmethod(run_sweep)

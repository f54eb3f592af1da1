"""``sarnav figures DIR``: redraw the figures of a finished campaign (or of every case of a study and the study's
comparison figures) from what is stored, without simulating again (a kind's own figures may re-simulate run 0,
as rda-nav's do).

The PNG files in ``DIR/figures/`` are removed first, so the folder holds exactly the figures of this drawing. The
kind-specific figures come from the kind's ``figures(results, outdir)`` hook; the kind is found by the caller's
``resolve_kind(name)`` (the CLI passes ``sarnav.scenarios.registry.get_kind``: this layer looks nothing up in
scenarios). A kind that cannot be resolved is a notice, not an error: the standard figures are still drawn.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from sarnav.errors import ConfigError, SarnavError
from sarnav.report.outputs import CAMPAIGN, STUDY, describe, output_kind, read_campaign, read_json

__all__ = ["Redrawn", "redraw_figures", "redraw_campaign", "redraw_study"]


@dataclass
class Redrawn:
    """What :func:`redraw_figures` wrote, and notices for the user (e.g. a kind that could not be resolved)."""

    paths: list[Path] = field(default_factory=list)
    notices: list[str] = field(default_factory=list)


def _clear_pngs(folder: Path) -> None:
    if folder.is_dir():
        for p in folder.glob("*.png"):
            if p.is_file():
                p.unlink()


def _kind(name: str, resolve_kind: Callable | None, notices: list[str]):
    if resolve_kind is None or not name:
        return None
    try:
        return resolve_kind(name)
    except SarnavError as err:
        notices.append(f"kind {name!r} cannot be resolved ({err}): only the standard figures are drawn")
        return None


def _redraw(c, resolve_kind: Callable | None) -> Redrawn:
    from sarnav.report.figures import write_campaign_figures

    done = Redrawn()
    kind = _kind(c.kind, resolve_kind, done.notices)
    figdir = c.path / "figures"
    try:
        _clear_pngs(figdir)
        done.paths = [Path(p) for p in write_campaign_figures(c.results, c.path, kind=kind)]
    except OSError as err:
        raise ConfigError(c.given, f"cannot write {figdir}: {err.strerror or err}") from None
    return done


def redraw_campaign(directory: str | os.PathLike, resolve_kind: Callable | None = None) -> Redrawn:
    """Clear ``directory/figures/*.png`` and draw the campaign's figures from its results.nc (with the kind's
    ``figures`` hook when ``resolve_kind`` finds the kind)."""
    return _redraw(read_campaign(directory), resolve_kind)


def redraw_study(directory: str | os.PathLike, resolve_kind: Callable | None = None) -> Redrawn:
    """Redraw every case's figures and the study's comparison figures (``study_<name>.png``, from study.json's
    scenario text and the cases' results)."""
    from sarnav.analysis.consistency import mean_three_sigma
    from sarnav.report.study_figure import LINE_STYLES, plot_study_comparison, study_figure_specs
    from sarnav.tomlio import parse_toml

    p, given = Path(directory), str(directory)
    study = read_json(p / "study.json", given)
    try:
        cfg = parse_toml(study.get("scenario_toml", ""), origin=str(p / "study.json"))
        cases = {c["label"]: c for c in cfg["cases"]}
    except (SarnavError, KeyError, TypeError) as err:
        raise ConfigError(given, f"study.json holds no readable study scenario ({err})") from None
    done, curves, units = Redrawn(), {}, {}
    for label in cases:
        c = read_campaign(p / label)
        sub = _redraw(c, resolve_kind)
        done.paths += sub.paths
        done.notices += [n for n in sub.notices if n not in done.notices]
        curves[label], units[label] = mean_three_sigma(c.results), c.state_units
    for old in p.glob("study_*.png"):
        old.unlink()
    styles = {lab: case.get("style", LINE_STYLES[k % len(LINE_STYLES)]) for k, (lab, case) in enumerate(cases.items())}
    for spec in study_figure_specs(cfg):
        first = spec["cases"][0]
        sel = [(lab, *curves[lab][:2], styles[lab]) for lab in spec["cases"]]
        done.paths.append(Path(plot_study_comparison(sel, curves[first][2], spec["states"], spec["title"],
                                                     p / f"study_{spec['name']}.png", state_units=units[first])))
    return done


def redraw_figures(directory: str | os.PathLike, resolve_kind: Callable | None = None) -> Redrawn:
    """Redraw the figures of the campaign or study in ``directory`` (see the module docstring)."""
    kind = output_kind(directory)
    if kind == CAMPAIGN:
        return redraw_campaign(directory, resolve_kind)
    if kind == STUDY:
        return redraw_study(directory, resolve_kind)
    raise ConfigError(str(directory), f"{describe(kind)}: its figure is drawn by `sarnav run` (figures are redrawn "
                                      "only for campaigns and studies, from results.nc)")

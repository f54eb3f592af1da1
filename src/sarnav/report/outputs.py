"""Reading what ``sarnav run`` / ``sarnav image`` wrote (layouts in docs/results.md): which kind of output a
directory holds, and a finished campaign's manifest, summary and results.

Every problem with a directory is a :class:`~sarnav.errors.ConfigError` whose field is the directory as the user
gave it, so the CLI prints one line such as ``sarnav: error: out/a: not a finished campaign ...``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.montecarlo import store

__all__ = ["CAMPAIGN", "STUDY", "SENSITIVITY", "IMAGE", "CampaignDir", "output_kind", "read_campaign", "read_json",
           "figure_files", "describe"]

CAMPAIGN, STUDY, SENSITIVITY, IMAGE = "campaign", "study", "sensitivity", "image"

#: the file that tells each kind of output directory apart, in the order they are tried
_MARKERS = ((store.MANIFEST, CAMPAIGN), (store.RESULTS, CAMPAIGN), ("study.json", STUDY),
            ("sensitivity.csv", SENSITIVITY), ("metrics.json", IMAGE), ("image.npz", IMAGE))

#: campaign figures in reading order (the rest follow alphabetically)
_FIGURE_ORDER = ("position", "velocity", "attitude", "residuals")


@dataclass
class CampaignDir:
    """A finished campaign directory.

    ``results`` is the ``results.nc`` Dataset (loaded into memory), ``summary`` the parsed ``summary.json``,
    ``manifest`` the parsed ``campaign.json`` (None for results copied without it), ``figures`` the PNG files in
    ``figures/`` in reading order.
    """

    path: Path
    given: str
    manifest: dict | None
    summary: dict
    results: object
    figures: list[Path] = field(default_factory=list)

    @property
    def scenario_toml(self) -> str:
        text = self.results.attrs.get("scenario") or (self.manifest or {}).get("scenario_toml") or ""
        return str(text)

    @property
    def name(self) -> str:
        return str(self.results.attrs.get("scenario_name") or self.summary.get("scenario") or self.path.name)

    @property
    def kind(self) -> str:
        return str(self.results.attrs.get("kind") or (self.manifest or {}).get("kind") or "")

    @property
    def state_names(self) -> list[str]:
        return [str(s) for s in self.results["state"].values]

    @property
    def state_units(self) -> list[str]:
        if "state_units" in self.results.coords:
            return [str(u) for u in self.results["state_units"].values]
        return [""] * len(self.state_names)


def _existing_dir(path: str | os.PathLike) -> Path:
    p = Path(path)
    if not p.exists():
        raise ConfigError(str(path), "no such directory")
    if not p.is_dir():
        raise ConfigError(str(path), "not a directory (give the folder that `sarnav run --out` wrote)")
    return p


def output_kind(path: str | os.PathLike) -> str:
    """``"campaign"``, ``"study"``, ``"sensitivity"`` or ``"image"``: what ``sarnav run`` wrote into ``path``."""
    p = _existing_dir(path)
    for marker, kind in _MARKERS:
        if (p / marker).is_file():
            return kind
    raise ConfigError(str(path), "not a sarnav output directory (none of campaign.json, results.nc, study.json, "
                                 "sensitivity.csv, metrics.json in it): give the folder `sarnav run --out` wrote")


def describe(kind: str) -> str:
    """``"a study"``, ``"an image output"``, ...: an output kind in a sentence."""
    return {CAMPAIGN: "a campaign", STUDY: "a study", SENSITIVITY: "a bpa-sensitivity output",
            IMAGE: "an image output"}.get(kind, f"a {kind} output")


def read_json(path: Path, given: str) -> dict:
    """A JSON file written by sarnav (NaN tolerated for files written before summary.json became strict)."""
    try:
        with open(path, encoding="utf-8") as fh:
            obj = json.load(fh)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ConfigError(given, f"{path.name} cannot be read ({err})") from None
    if not isinstance(obj, dict):
        raise ConfigError(given, f"{path.name} does not hold a JSON object")
    return obj


def figure_files(figdir: Path) -> list[Path]:
    """The PNG files of ``figdir`` in reading order: position, velocity, attitude, residuals, then the rest."""
    if not figdir.is_dir():
        return []
    pngs = sorted(p for p in figdir.glob("*.png") if p.is_file())
    rank = {stem: i for i, stem in enumerate(_FIGURE_ORDER)}
    return sorted(pngs, key=lambda p: (rank.get(p.stem, len(rank)), p.name))


def _unfinished(p: Path, given: str, manifest: dict | None) -> ConfigError:
    n_stored = len(store.stored_runs(p))
    total = (manifest or {}).get("runs", "?")
    return ConfigError(given, f"an unfinished campaign ({n_stored} of {total} runs stored, no results yet): finish "
                              f"it with the same `sarnav run` command and --resume, then try again")


def read_campaign(path: str | os.PathLike) -> CampaignDir:
    """The finished campaign in ``path`` (results.nc, summary.json and, when present, campaign.json and figures).

    Raises :class:`ConfigError` (field: ``path`` as given) for a missing directory, a study or other output, an
    unfinished campaign or unreadable files.
    """
    from sarnav.montecarlo.assemble import open_results

    given = str(path)
    kind = output_kind(path)
    p = Path(path)
    if kind == STUDY:
        cases = sorted(str(d) for d in p.iterdir() if (d / store.MANIFEST).is_file()) or [str(p / "<case>")]
        raise ConfigError(given, f"a study, not one campaign: give its case folders, e.g. {' '.join(cases)}")
    if kind != CAMPAIGN:
        raise ConfigError(given, f"{describe(kind)}, not a Monte Carlo campaign (no results.nc)")
    manifest = read_json(p / store.MANIFEST, given) if (p / store.MANIFEST).is_file() else None
    complete = manifest is None or bool(manifest.get("complete"))
    if not complete or (p / store.MARKER).exists() or not (p / store.RESULTS).is_file() \
            or not (p / store.SUMMARY).is_file():
        raise _unfinished(p, given, manifest)
    store.verify_products(p, given)
    summary = read_json(p / store.SUMMARY, given)
    try:
        results = open_results(p / store.RESULTS)
    except (OSError, ValueError, KeyError) as err:
        raise ConfigError(given, f"{store.RESULTS} cannot be read ({type(err).__name__}: {err})") from None
    for var in ("error", "sigma", "nees", "state"):
        if var not in results.variables:
            raise ConfigError(given, f"{store.RESULTS} has no variable {var!r}: not a sarnav campaign result")
    return CampaignDir(p, given, manifest, summary, results, figure_files(p / "figures"))

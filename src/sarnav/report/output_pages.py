"""The pages of outputs other than one campaign: a study (cases, comparison figures, one collapsible campaign
section per case), ``bpa-sensitivity`` (its CSV and grid figure) and an image (``metrics.json``, ``image.png``, the
scenario text stored in ``image.npz``). Each function returns (title, body HTML)."""

from __future__ import annotations

import csv
import zipfile
from pathlib import Path

import numpy as np

from sarnav.errors import ConfigError, SarnavError
from sarnav.report import html_parts as H
from sarnav.report.campaign_page import campaign_body
from sarnav.report.outputs import read_campaign, read_json

__all__ = ["study_page", "sensitivity_page", "image_page"]


def study_page(p: Path, given: str) -> tuple[str, str]:
    study = read_json(p / "study.json", given)
    cases = study.get("cases", [])
    rows = [(c.get("label", ""), "; ".join(f"{k} = {v}" for k, v in c.get("set", {}).items()) or "(base)")
            for c in cases]
    body = H.kv_table({"study": study.get("study"), "runs per case": study.get("runs"), "seed": study.get("seed"),
                       "complete": study.get("complete")})
    body += H.table(("case", "overrides"), rows, "Cases", text_columns=2)
    body += _study_states_table(study)
    figs = [p / f for f in study.get("figures", [])] or sorted(p.glob("study_*.png"))
    body += H.section("Comparison figures", "".join(H.figure(f.read_bytes(), f.name) for f in figs if f.is_file()))
    body += H.section("Cases", "".join(_case_block(p, c) for c in cases))
    body += H.section("Scenario", H.pre(study.get("scenario_toml", "(not stored)")))
    return f"sarnav study: {study.get('study', p.name)}", body


def _study_states(study: dict) -> list[str]:
    """The states the study compares (``study.states`` of its scenario text; pN pE pD by default)."""
    from sarnav.tomlio import parse_toml

    try:
        return list(parse_toml(study.get("scenario_toml", "")).get("study", {}).get("states", ["pN", "pE", "pD"]))
    except (SarnavError, AttributeError, TypeError):  # the page still shows every state
        return []


def _study_states_table(study: dict) -> str:
    cases, shown = study.get("cases", []), _study_states(study)
    head = ("case", "state", "final 1σ", "final 3σ", "time-averaged 3σ", "inside 3σ [%]")

    def rows(keep):
        return [(c.get("label", ""), name, H.fmt(st.get("final_sigma")), H.fmt(st.get("final_3sigma")),
                 H.fmt(st.get("mean_3sigma")), H.pct(st.get("fraction_inside_3sigma")))
                for c in cases for name, st in c.get("states", {}).items() if keep(name)]

    out = H.table(head, rows(lambda n: n in shown), f"States compared: {' '.join(shown)} (study.json)", 2) \
        if shown else ""
    return out + H.details("Every state of every case (study.json; units as in each case's summary below)",
                           H.table(head, rows(lambda n: True), text_columns=2))


def _case_block(p: Path, case: dict) -> str:
    label = str(case.get("label", ""))
    try:
        c = read_campaign(p / case.get("dir", label))
    except ConfigError as err:
        return f'<p class="bad">case {H.esc(label)}: {H.esc(err)}</p>\n'
    return H.details(f"case {label}", campaign_body(c, level=3))


def sensitivity_page(p: Path, given: str) -> tuple[str, str]:
    try:
        with open(p / "sensitivity.csv", newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise ConfigError(given, f"sensitivity.csv cannot be read ({err})") from None
    if not rows:
        raise ConfigError(given, "sensitivity.csv is empty")
    body = H.table(rows[0], rows[1:], "sensitivity.csv: image shift and blur per navigation error against "
                                     "the prediction (thesis eq. 4.41)", text_columns=3)
    if (p / "sensitivity.png").is_file():
        body += H.figure((p / "sensitivity.png").read_bytes(), "sensitivity.png")
    body += H.section("Scenario", '<p class="meta">bpa-sensitivity stores no scenario text; '
                                  "<code>sarnav show bpa-sensitivity</code> prints the default.</p>\n")
    return f"sarnav bpa-sensitivity: {p.name}", body


def image_page(p: Path, given: str) -> tuple[str, str]:
    metrics = read_json(p / "metrics.json", given) if (p / "metrics.json").is_file() else {}
    body = H.kv_table(H.flatten(metrics), "metrics.json") if metrics else ""
    if (p / "image.png").is_file():
        body += H.figure((p / "image.png").read_bytes(), "image.png")
    toml = ""
    if (p / "image.npz").is_file():
        try:
            with np.load(p / "image.npz", allow_pickle=False) as z:
                toml = str(z["scenario_toml"]) if "scenario_toml" in z.files else ""
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:  # truncated, empty or not a zip
            raise ConfigError(given, f"image.npz cannot be read ({err})") from None
    body += H.section("Scenario", H.pre(toml or "(not stored)"))
    return f"sarnav image: {metrics.get('scenario', p.name)}", body

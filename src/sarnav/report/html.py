"""``sarnav report DIR``: one self-contained HTML page (``DIR/report.html``) of what ``sarnav run`` wrote.

A campaign page holds the run facts (scenario, kind, runs, seed, start, finish, versions), the summary tables of
``summary.json`` (final 1σ/3σ, RMS error and fraction inside 3σ per state; NEES and NIS against their χ² bands;
residual means; registration statistics when present), the consistency figure (run-mean NEES and NIS over time
against their bands, drawn from results.nc), the campaign's figures (``figures/*.png``, or drawn from results.nc
when that folder is empty) and the scenario TOML. A study page holds the cases' table, the comparison figures and
one collapsible campaign section per case; ``bpa-sensitivity`` and image outputs get their table, figure and, where
stored, the scenario text. Figures are embedded as base64 PNG; the page refers to nothing outside itself.
"""

from __future__ import annotations

import csv
import datetime as _dt
import os
import platform
import tempfile
from pathlib import Path

import numpy as np

import sarnav
from sarnav.errors import ConfigError, SarnavError
from sarnav.report import html_parts as H
from sarnav.report.outputs import (CAMPAIGN, IMAGE, SENSITIVITY, STUDY, CampaignDir, output_kind,
                                   read_campaign, read_json)

__all__ = ["REPORT", "write_report", "report_html", "campaign_body", "versions", "flatten"]

REPORT = "report.html"
_SUMMARY_KNOWN = {"scenario", "seed", "complete", "runs", "confidence", "final_time", "states", "nees", "nis",
                  "residuals", "registration"}


def versions() -> dict:
    """Versions of the software making the page: sarnav, numpy, xarray, matplotlib, Python."""
    import matplotlib
    import xarray

    return {"sarnav": sarnav.__version__, "numpy": np.__version__, "xarray": xarray.__version__,
            "matplotlib": matplotlib.__version__, "python": platform.python_version()}


def flatten(obj, prefix: str = "") -> dict:
    """Nested dicts as one dict of dotted keys (lists of scalars kept as values)."""
    out = {}
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    else:
        out[prefix] = obj
    return out


def _elapsed(started, finished) -> str:
    try:
        dt = _dt.datetime.fromisoformat(str(finished)) - _dt.datetime.fromisoformat(str(started))
    except (TypeError, ValueError):
        return "n/a"
    return str(dt)


def _overview(c: CampaignDir) -> str:
    m, s, a = c.manifest or {}, c.summary, c.results.attrs
    facts = {"scenario": c.name, "kind": c.kind, "runs": s.get("runs", a.get("runs")),
             "seed": s.get("seed", a.get("seed")), "final time [s]": s.get("final_time"),
             "states": len(c.state_names), "measurements": ", ".join(str(x) for x in c.results["meas"].values),
             "written by sarnav": a.get("sarnav_version", m.get("sarnav_version")),
             "started (UTC)": m.get("started"), "finished (UTC)": m.get("finished"),
             "elapsed (start to finish, interruptions included)": _elapsed(m.get("started"), m.get("finished")),
             "complete": bool(s.get("complete", m.get("complete", True)))}
    extra = {k: v for k, v in m.items() if k not in {"scenario", "kind", "runs", "seed", "sarnav_version", "started",
                                                       "finished", "complete", "scenario_toml"}}
    body = H.kv_table(facts)
    if extra:
        body += H.details("campaign.json: other entries", H.kv_table(flatten(extra)))
    return body


def _verdict(s: dict) -> str:
    """The consistency verdict when summary.json carries one (``consistent`` and its reasons)."""
    if "consistent" not in s:
        return ""
    reasons = [f"{k}: {H.fmt(v)}" for k, v in flatten({k: v for k, v in s.items()
                                                        if "reason" in k or "warning" in k}).items()]
    text = "consistent with its covariance" if s["consistent"] else "NOT consistent with its covariance"
    cls = "note" if s["consistent"] else "bad"
    return f'<p class="{cls}">Filter {H.esc(text)}' + (": " + H.esc("; ".join(reasons)) if reasons else "") + "</p>\n"


def _pct(v):
    return H.fmt(100.0 * v) if isinstance(v, (int, float)) and not isinstance(v, bool) else H.fmt(v)


def _states_table(s: dict) -> str:
    rows = [(name, st.get("units", ""), H.fmt(st.get("final_sigma")), H.fmt(st.get("final_3sigma")),
             H.fmt(st.get("final_error_rms")), _pct(st.get("fraction_inside_3sigma")))
            for name, st in s.get("states", {}).items()]
    return H.table(("state", "units", "final 1σ", "final 3σ", "final RMS error", "inside 3σ [%] (99.73 expected)"),
                   rows, "Per state, at the last epoch (σ: mean over runs; RMS: over runs)", text_columns=2)


def _nees_nis(s: dict) -> str:
    n = s.get("nees", {})
    conf = H.fmt(100 * s.get("confidence", 0.95), 3)
    out = H.kv_table({"dof (states)": n.get("dof"), "runs": n.get("runs"),
                      f"{conf} % band of the run-mean NEES": n.get("band"),
                      "time average of the run-mean NEES (expected: dof)": n.get("time_average"),
                      "share of epochs inside the band": n.get("fraction_in_band")}, "NEES (χ², Bar-Shalom §5.4.2)")
    if "nis" in s:
        i = s["nis"]
        out += H.kv_table({"NIS per dof, pooled (expected 1)": i.get("per_dof"),
                           f"{conf} % band of the pooled NIS per dof": i.get("per_dof_band"),
                           "total measurement dof": i.get("total_dof"),
                           "mean NIS over updates": i.get("mean_over_updates"),
                           "expected mean NIS over updates": i.get("expected_over_updates"),
                           "share of updates inside their band": i.get("fraction_in_band")}, "NIS")
    return out


def _residual_tables(s: dict) -> str:
    out = ""
    if s.get("residuals"):
        rows = [(m, r.get("units", ""), H.fmt(r.get("mean")), H.fmt(r.get("stderr")), H.fmt(r.get("count")),
                 H.fmt(r.get("normalized_mean")), H.fmt(r.get("normalized_std")))
                for m, r in s["residuals"].items()]
        out += H.table(("measurement", "units", "mean", "std. error", "count", "mean r/σ (0)", "std r/σ (1)"),
                       rows, "Residuals over all runs and updates", text_columns=2)
    if s.get("registration"):
        cols = ("count", "mean", "std", "stderr", "rms", "p99_abs", "max_abs")
        rows = [(m, r.get("units", ""), *(H.fmt(r.get(k)) for k in cols)) for m, r in s["registration"].items()]
        out += H.table(("axis", "units") + cols, rows,
                       "Image registration error (measured minus geometric truth)", text_columns=2)
    return out


def _other_summary(s: dict) -> str:
    other = {k: v for k, v in s.items() if k not in _SUMMARY_KNOWN and k != "consistent"
             and "reason" not in k and "warning" not in k}
    return H.details("summary.json: other entries", H.kv_table(flatten(other))) if other else ""


def _drawn_figures(c: CampaignDir) -> list[tuple[bytes, str]]:
    """The standard campaign figures drawn from results.nc (for a campaign run with ``--no-figures``)."""
    from sarnav.report.figures import write_campaign_figures

    with tempfile.TemporaryDirectory(prefix="sarnav-report-") as tmp:
        paths = write_campaign_figures(c.results, tmp)
        return [(Path(p).read_bytes(), f"{Path(p).name} (drawn from results.nc for this page: figures/ is empty)")
                for p in paths]


def _consistency(c: CampaignDir) -> str:
    from sarnav.report.figures import png_bytes
    from sarnav.report.overlays import consistency_figure

    return H.figure(png_bytes(consistency_figure([(c.name, c.results)])),
                    "Consistency over time: run-mean NEES / dof and NIS / dof against their bands (from results.nc)")


def _figures(c: CampaignDir) -> str:
    pngs = [(p.read_bytes(), f"figures/{p.name}") for p in c.figures] or _drawn_figures(c)
    return "".join(H.figure(png, cap) for png, cap in pngs)


def campaign_body(c: CampaignDir, level: int = 2) -> str:
    """The sections of one campaign (overview, verdict, tables, figures, scenario TOML), headings at ``level``."""
    s = c.summary
    return (_overview(c) + _verdict(s)
            + H.section("Summary", _states_table(s) + _nees_nis(s) + _consistency(c) + _residual_tables(s)
                        + _other_summary(s), level)
            + H.section("Figures", _figures(c), level)
            + H.section("Scenario", H.pre(c.scenario_toml or "(not stored)"), level))


def _footer() -> str:
    made = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    v = ", ".join(f"{k} {val}" for k, val in versions().items())
    return f'<p class="meta">Page made {H.esc(made)} by {H.esc(v)}.</p>\n'


def _study_page(p: Path, given: str) -> tuple[str, str]:
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
                 H.fmt(st.get("mean_3sigma")), _pct(st.get("fraction_inside_3sigma")))
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


def _sensitivity_page(p: Path, given: str) -> tuple[str, str]:
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


def _image_page(p: Path, given: str) -> tuple[str, str]:
    metrics = read_json(p / "metrics.json", given) if (p / "metrics.json").is_file() else {}
    body = H.kv_table(flatten(metrics), "metrics.json") if metrics else ""
    if (p / "image.png").is_file():
        body += H.figure((p / "image.png").read_bytes(), "image.png")
    toml = ""
    if (p / "image.npz").is_file():
        try:
            with np.load(p / "image.npz", allow_pickle=False) as z:
                toml = str(z["scenario_toml"]) if "scenario_toml" in z.files else ""
        except (OSError, ValueError) as err:
            raise ConfigError(given, f"image.npz cannot be read ({err})") from None
    body += H.section("Scenario", H.pre(toml or "(not stored)"))
    return f"sarnav image: {metrics.get('scenario', p.name)}", body


def report_html(directory: str | os.PathLike) -> str:
    """The report page of ``directory`` (a campaign, study, bpa-sensitivity or image output) as HTML text."""
    given = str(directory)
    kind = output_kind(directory)
    p = Path(directory)
    if kind == CAMPAIGN:
        c = read_campaign(directory)
        title, body = f"sarnav campaign: {c.name}", campaign_body(c)
    elif kind == STUDY:
        title, body = _study_page(p, given)
    elif kind == SENSITIVITY:
        title, body = _sensitivity_page(p, given)
    else:
        assert kind == IMAGE
        title, body = _image_page(p, given)
    return H.page(title, body + _footer())


def write_report(directory: str | os.PathLike) -> Path:
    """Write ``directory/report.html`` (atomically) and return its path."""
    from sarnav.montecarlo.store import atomic_write_text

    text = report_html(directory)
    path = Path(directory) / REPORT
    try:
        atomic_write_text(path, text)
    except OSError as err:
        for tmp in path.parent.glob(f".{path.name}.tmp-{os.getpid()}"):  # the half-done temporary, if any
            tmp.unlink()
        raise ConfigError(str(directory), f"cannot write {path}: {err.strerror or err}") from None
    return path

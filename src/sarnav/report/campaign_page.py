"""The campaign part of ``report.html``: run facts, the ``summary.json`` tables, the consistency figure, the
campaign's figures and the scenario TOML (docs/results.md, "Reading and sharing")."""

from __future__ import annotations

import datetime as _dt
import tempfile
from pathlib import Path

from sarnav.report import html_parts as H
from sarnav.report.outputs import CampaignDir

__all__ = ["campaign_body"]

_SUMMARY_KNOWN = {"scenario", "seed", "complete", "runs", "confidence", "final_time", "states", "nees", "nis",
                  "residuals", "registration"}


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
        body += H.details("campaign.json: other entries", H.kv_table(H.flatten(extra)))
    return body


def _verdict(s: dict) -> str:
    """The consistency verdict when summary.json carries one (``consistent`` and its reasons)."""
    if "consistent" not in s:
        return ""
    reasons = [f"{k}: {H.fmt(v)}" for k, v in H.flatten({k: v for k, v in s.items()
                                                        if "reason" in k or "warning" in k}).items()]
    text = "consistent with its covariance" if s["consistent"] else "NOT consistent with its covariance"
    cls = "note" if s["consistent"] else "bad"
    return f'<p class="{cls}">Filter {H.esc(text)}' + (": " + H.esc("; ".join(reasons)) if reasons else "") + "</p>\n"


def _states_table(s: dict) -> str:
    rows = [(name, st.get("units", ""), H.fmt(st.get("final_sigma")), H.fmt(st.get("final_3sigma")),
             H.fmt(st.get("final_error_rms")), H.pct(st.get("fraction_inside_3sigma")))
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
    return H.details("summary.json: other entries", H.kv_table(H.flatten(other))) if other else ""


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

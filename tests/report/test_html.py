"""``sarnav report DIR`` (sarnav.report.html): one self-contained page per output directory (campaign, study,
bpa-sensitivity, image) holding the figures as data URIs, the summary tables, the scenario TOML, versions and run
time. The browser checks are in test_browser.py; the CLI's error lines in tests/cli/test_report_cli.py."""

from __future__ import annotations

import base64
import html
import json
import platform
import re
import shutil

import numpy as np

from page_checks import assert_self_contained
from sarnav.montecarlo.store import CHECKSUMS, SUMMARY, product_checksums, read_manifest, write_manifest
from sarnav.report.html import report_html, write_report
from sarnav.report.html_parts import fmt


def test_campaign_page_holds_figures_tables_toml_versions_and_times(small_campaigns):
    d = small_campaigns["tactical"]
    path = write_report(d)
    assert path == d / "report.html" and path.is_file()
    text = path.read_text(encoding="utf-8")
    payloads = assert_self_contained(text)
    figures = sorted((d / "figures").glob("*.png"))
    assert len(figures) == 4
    for png in figures:  # each campaign figure embedded byte for byte
        assert base64.b64encode(png.read_bytes()).decode() in payloads
    assert len(payloads) == len(figures) + 1  # + the consistency figure drawn from results.nc
    summary = json.loads((d / "summary.json").read_text())
    manifest = json.loads((d / "campaign.json").read_text())
    for name in summary["states"]:
        assert f"<td class=\"t\">{name}</td>" in text
    assert html.escape(manifest["scenario_toml"], quote=True) in text
    assert manifest["started"] in text and manifest["finished"] in text
    assert f"numpy {np.__version__}" in text and f"python {platform.python_version()}" in text
    # the numbers are the stored ones: pN's final 3-sigma from results.nc, formatted as the page formats
    import xarray as xr

    with xr.open_dataset(d / "results.nc") as ds:
        j = list(ds["state"].values).index("pN")
        final3 = float(3.0 * ds["sigma"].values[:, -1, j].mean())
    assert f"<td>{fmt(final3)}</td>" in text
    lo, hi = summary["nees"]["band"]
    assert f"[{fmt(lo)}, {fmt(hi)}]" in text
    for meas in summary["residuals"]:
        assert f"<td class=\"t\">{meas}</td>" in text


def test_campaign_without_figures_gets_them_drawn_for_the_page_only(small_campaigns):
    d = small_campaigns["consumer"]
    text = report_html(d)
    payloads = assert_self_contained(text)
    assert len(payloads) == 5  # consistency + position, velocity, attitude, residuals
    assert "drawn from results.nc for this page" in text
    assert not (d / "figures").exists()  # the report writes nothing but report.html


def test_null_and_verdict_in_summary_are_shown_not_crashed_on(small_campaigns, tmp_path):
    """summary.json written strictly (null for an undefined statistic, a consistency verdict with its reason)."""
    d = tmp_path / "c"
    shutil.copytree(small_campaigns["tactical"], d)
    summary = json.loads((d / "summary.json").read_text())
    summary["nees"]["time_average"] = None
    summary.update(consistent=False, consistency_reason="pooled containment 81 % < 90 %")
    (d / "summary.json").write_text(json.dumps(summary))
    manifest = read_manifest(d)  # the summary is rewritten as a writer would: its checksum recorded again
    write_manifest(d, {**manifest, CHECKSUMS: {**manifest[CHECKSUMS], **product_checksums(d, (SUMMARY,))}})
    text = report_html(d)
    assert "NOT consistent" in text and "pooled containment 81 % &lt; 90 %" in text
    assert re.search(r"time average of the run-mean NEES \(expected: dof\)</td><td class=\"t\">n/a</td>", text)


def test_study_page_has_cases_comparison_figure_and_each_case(small_study):
    text = report_html(small_study)
    payloads = assert_self_contained(text)
    study = json.loads((small_study / "study.json").read_text())
    assert base64.b64encode((small_study / "study_3sigma.png").read_bytes()).decode() in payloads
    for case in study["cases"]:
        assert f"case {case['label']}</summary>" in text
        for png in (small_study / case["label"] / "figures").glob("*.png"):
            assert base64.b64encode(png.read_bytes()).decode() in payloads
    assert html.escape(study["scenario_toml"], quote=True) in text


def test_sensitivity_and_image_outputs_give_a_page(tmp_path):
    from matplotlib.figure import Figure

    from sarnav.report.figures import save_png

    fig = Figure(figsize=(2, 2))
    fig.subplots().plot([0, 1], [1, 0], "r")
    sens = tmp_path / "bpa"
    save_png(fig, sens / "sensitivity.png")
    (sens / "sensitivity.csv").write_text("name,value,unit,meas_offset_range\nposition_along,3,m,-0.0044\n")
    text = report_html(sens)
    assert len(assert_self_contained(text)) == 1
    assert "<td class=\"t\">position_along</td>" in text and "<td>-0.0044</td>" in text
    img = tmp_path / "img"
    save_png(fig, img / "image.png")
    (img / "metrics.json").write_text(json.dumps({"scenario": "pt", "point_target": {"irw_m": {"theory": 0.2656}}}))
    np.savez(img / "image.npz", data=np.zeros((2, 2)), scenario_toml='[scenario]\nname = "pt"\n')
    text = report_html(img)
    assert len(assert_self_contained(text)) == 1
    assert "point_target.irw_m.theory" in text and "0.2656" in text and "name = &quot;pt&quot;" in text

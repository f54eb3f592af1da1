"""``report.campaign_page.campaign_body``: the campaign part of report.html, built from a small toy campaign (6 runs
of the exact scalar Kalman filter, tests/toy_kind.py): the run facts, the verdict, the summary tables carrying the
numbers of summary.json, the figures embedded byte for byte (or drawn from results.nc when figures/ is empty), and
the scenario TOML."""

from __future__ import annotations

import base64
import html
import json
import shutil

import pytest

from sarnav.montecarlo.campaign import run_campaign
from sarnav.report.campaign_page import campaign_body
from sarnav.report.html_parts import fmt, pct
from sarnav.report.outputs import read_campaign
from toy_kind import TOY, toy_cfg


@pytest.fixture(scope="module")
def toy_campaign(tmp_path_factory):
    """A finished toy campaign without figures (run_campaign draws none)."""
    out = tmp_path_factory.mktemp("page") / "toy"
    run_campaign(toy_cfg(runs=6, steps=20), out, TOY, executor="serial", quiet=True)
    return out


@pytest.fixture(scope="module")
def body(toy_campaign):
    """campaign_body of the figureless toy campaign (drawn once: drawing is the cost)."""
    return campaign_body(read_campaign(toy_campaign))


def _kv(key, value):
    return f'<tr><td class="t">{key}</td><td class="t">{value}</td></tr>'


def test_overview_holds_the_run_facts(toy_campaign, body):
    """Scenario, runs, seed, number of states and measurements as stored; elapsed = finished - started."""
    import datetime as dt

    m = json.loads((toy_campaign / "campaign.json").read_text())
    for key, value in (("scenario", "toy"), ("runs", "6"), ("seed", "7"), ("states", "1"), ("measurements", "z1, z2")):
        assert _kv(key, value) in body, key
    elapsed = dt.datetime.fromisoformat(m["finished"]) - dt.datetime.fromisoformat(m["started"])
    assert html.escape(str(elapsed)) in body


def test_tables_carry_the_summary_numbers(toy_campaign, body):
    """The state row and the NEES table show summary.json's values formatted as the page formats them."""
    s = json.loads((toy_campaign / "summary.json").read_text())
    x = s["states"]["x"]
    row = "".join(f"<td>{v}</td>" for v in (fmt(x["final_sigma"]), fmt(x["final_3sigma"]), fmt(x["final_error_rms"]),
                                             pct(x["fraction_inside_3sigma"])))
    assert f'<td class="t">x</td><td class="t">{x["units"]}</td>{row}' in body
    assert _kv("time average of the run-mean NEES (expected: dof)", fmt(s["nees"]["time_average"])) in body
    assert _kv("NIS per dof, pooled (expected 1)", fmt(s["nis"]["per_dof"])) in body
    for meas in ("z1", "z2"):
        assert f"<td class=\"t\">{meas}</td>" in body


def test_figures_embedded_byte_for_byte_then_the_scenario(toy_campaign, tmp_path):
    """Each PNG of figures/ is in the page as base64, plus the consistency figure; then the scenario TOML, escaped."""
    import numpy as np
    from matplotlib.image import imsave

    d = tmp_path / "withfig"
    shutil.copytree(toy_campaign, d)
    for k, name in enumerate(("states_1", "residuals")):  # small stand-ins with distinct bytes
        (d / "figures").mkdir(exist_ok=True)
        imsave(d / "figures" / f"{name}.png", np.full((2, 2, 3), 0.3 * k))
    c = read_campaign(d)
    body = campaign_body(c, level=3)
    pngs = sorted((d / "figures").glob("*.png"))
    assert len(c.figures) == 2 and all(base64.b64encode(p.read_bytes()).decode() in body for p in pngs)
    assert body.count("data:image/png;base64,") == len(pngs) + 1
    assert "drawn from results.nc" not in body
    assert body.index("<h3>Summary</h3>") < body.index("<h3>Figures</h3>") < body.index("<h3>Scenario</h3>")
    assert html.escape(c.scenario_toml) in body and 'name = "toy"' in c.scenario_toml


def test_without_figures_they_are_drawn_for_the_page(toy_campaign, body):
    """No figures/: the standard figures are drawn from results.nc into the page only (captions say so)."""
    assert body.count("(drawn from results.nc for this page: figures/ is empty)") == 4  # alt + caption, 2 figures
    assert not (toy_campaign / "figures").exists()


def test_verdict_elapsed_and_other_entries(toy_campaign, monkeypatch):
    """A 'consistent' flag gives the verdict with its reasons; unknown summary and manifest entries go into
    details; unparseable times give n/a (figures not drawn here: tested above)."""
    from sarnav.report import campaign_page

    monkeypatch.setattr(campaign_page, "_figures", lambda c: "")
    monkeypatch.setattr(campaign_page, "_consistency", lambda c: "")
    c = read_campaign(toy_campaign)
    c.summary = {**c.summary, "consistent": False, "nees_reason": "too high", "extra_number": 1.5}
    c.manifest = {**(c.manifest or {}), "started": "not a time", "host_note": "lab"}
    body = campaign_body(c)
    assert '<p class="bad">Filter NOT consistent with its covariance: nees_reason: too high</p>' in body
    assert "summary.json: other entries" in body and "extra_number" in body
    assert "campaign.json: other entries" in body and "host_note" in body
    assert _kv("elapsed (start to finish, interruptions included)", "n/a") in body
    c.summary["consistent"] = True
    assert '<p class="note">Filter consistent with its covariance' in campaign_body(c)

"""``sarnav report`` and ``sarnav compare`` pages in headless Chromium (issue 9, Done when): the page loads with no
console message, every embedded figure decodes, and the screenshot shows the figures (helpers and the exact
Chromium command in headless_chromium.py). Skipped, with the reason, where no chromium binary is installed.

A page built to fail (a script error and a broken image) checks that these checks can fail."""

from __future__ import annotations

import re

import pytest

from headless_chromium import SKIP_REASON, find_chromium, load_probe, pixel_stats, screenshot
from sarnav.cli.main import main

CHROMIUM = find_chromium()
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason=SKIP_REASON)


def _n_images(page) -> int:
    return len(re.findall(r"<img ", page.read_text(encoding="utf-8")))


def _check_loads(page, tmp_path) -> None:
    probe, console = load_probe(CHROMIUM, page, tmp_path)
    n = _n_images(page)
    assert n >= 2
    assert probe == f"images={n} broken=0", probe
    assert console == []


def _shows_figures(page, tmp_path):
    """The page loads with every image and no console message, and its screenshot shows plots; its pixel stats."""
    _check_loads(page, tmp_path)
    shot = screenshot(CHROMIUM, page, tmp_path)
    assert shot.console == []
    stats = pixel_stats(shot.png)
    # text and tables alone give a few hundred grey levels at most; plots add thousands of anti-aliased colours
    assert stats.distinct_colours > 1000, stats
    assert stats.non_white_fraction > 0.05, stats
    return stats


def test_report_page_loads_and_shows_its_figures(small_campaigns, tmp_path, capsys):
    assert main(["report", str(small_campaigns["tactical"])]) == 0
    page = small_campaigns["tactical"] / "report.html"
    stats = _shows_figures(page, tmp_path)
    assert stats.red_pixels > 500, stats  # the figures' red ±3σ curves are on screen


def test_compare_page_loads_and_shows_its_overlays(compared_campaigns, tmp_path):
    page = compared_campaigns[0] / "compare.html"
    stats = _shows_figures(page, tmp_path)
    assert stats.orange_pixels > 500, stats  # the second campaign's curves (matplotlib C1) are on screen


def test_checks_fail_on_a_broken_page(tmp_path):
    page = tmp_path / "broken.html"
    page.write_text('<!DOCTYPE html><html><head><meta charset="utf-8"><title>x</title></head><body><h1>x</h1>'
                    '<img src="data:image/png;base64,AAAA" alt="a"><img src="missing.png" alt="b">'
                    '<script>throw new Error("boom")</script></body></html>', encoding="utf-8")
    probe, console = load_probe(CHROMIUM, page, tmp_path)
    assert probe == "images=2 broken=2"
    assert any("boom" in line for line in console) and any("broken image" in line for line in console)
    stats = pixel_stats(screenshot(CHROMIUM, page, tmp_path, size=(800, 600)).png)
    assert stats.red_pixels == 0 and stats.orange_pixels == 0 and stats.non_white_fraction < 0.05

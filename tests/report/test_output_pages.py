"""``sarnav.report.output_pages``: the (title, body HTML) of a study, a ``bpa-sensitivity`` output and an image.

Inputs are written here with csv, json, numpy and matplotlib (the study: the report conftest's ``small_study``);
the bodies are parsed with the standard library's HTMLParser: table cells, embedded figures (decoded back to the
files' bytes), ``<pre>`` text and headings. Text from the files is escaped, never markup.
"""

from __future__ import annotations

import base64
import csv
import json
import shutil
from html.parser import HTMLParser

import numpy as np
import pytest
from matplotlib.image import imsave

from sarnav.errors import ConfigError
from sarnav.report.output_pages import image_page, sensitivity_page, study_page


class Body(HTMLParser):
    """Tables (lists of rows of cell texts, with their captions), figure images (bytes, alt), pre texts, headings,
    details summaries and paragraphs of class "bad"."""

    def __init__(self, html: str):
        super().__init__(convert_charrefs=True)
        self.tables, self.captions, self.images, self.pres, self.headings, self.summaries, self.bad = \
            [], [], [], [], [], [], []
        self._text, self._into = None, None
        self.feed(html)

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th", "pre", "h2", "h3", "summary", "caption") or (tag == "p" and a.get("class") == "bad"):
            self._text, self._into = [], tag
        elif tag == "img":
            head, data = a["src"].split(",", 1)
            assert head == "data:image/png;base64"
            self.images.append((base64.b64decode(data), a.get("alt")))

    def handle_data(self, data):
        if self._text is not None:
            self._text.append(data)

    def handle_endtag(self, tag):
        if self._into != tag:
            return
        text, self._text, self._into = "".join(self._text), None, None
        if tag in ("td", "th"):
            self.tables[-1][-1].append(text)
        elif tag == "pre":
            self.pres.append(text)
        elif tag in ("h2", "h3"):
            self.headings.append(text)
        elif tag == "summary":
            self.summaries.append(text)
        elif tag == "caption":
            self.captions.append(text)
        elif tag == "p":
            self.bad.append(text)


def png(path, value: float) -> bytes:
    imsave(path, np.full((3, 4, 3), value))
    return path.read_bytes()


# ---- image ---------------------------------------------------------------------------------------------------------


def test_image_page_shows_metrics_figure_and_scenario(tmp_path):
    metrics = {"scenario": "point-<target>", "algorithm": "bpa", "pixel_spacing_m": {"along_track": 0.25},
               "contrast": None}
    (tmp_path / "metrics.json").write_text(json.dumps(metrics))
    picture = png(tmp_path / "image.png", 0.5)
    toml = '[scene]\nname = "a <b>bold</b> & bare"\n'
    np.savez(tmp_path / "image.npz", data=np.zeros((2, 2)), scenario_toml=toml)
    title, body = image_page(tmp_path, "out/img")
    assert title == "sarnav image: point-<target>"
    b = Body(body)
    rows = {r[0]: r[1] for r in b.tables[0]}
    assert rows == {"scenario": "point-<target>", "algorithm": "bpa", "pixel_spacing_m.along_track": "0.25",
                    "contrast": "n/a"}
    assert b.images == [(picture, "image.png")]
    assert b.pres == [toml]
    assert "<b>bold</b>" not in body and "&lt;b&gt;" in body  # the scenario text is escaped
    assert b.headings == ["Scenario"]


def test_image_page_of_a_bare_folder_says_not_stored(tmp_path):
    title, body = image_page(tmp_path, "out/img")
    assert title == f"sarnav image: {tmp_path.name}"
    b = Body(body)
    assert (b.tables, b.images, b.pres) == ([], [], ["(not stored)"])


def test_image_page_npz_without_scenario_text(tmp_path):
    np.savez(tmp_path / "image.npz", data=np.ones(3))
    assert Body(image_page(tmp_path, "x")[1]).pres == ["(not stored)"]


def test_image_page_refuses_an_npz_that_is_no_archive(tmp_path):
    (tmp_path / "image.npz").write_text("not an archive at all")
    with pytest.raises(ConfigError) as err:
        image_page(tmp_path, "out/img")
    assert err.value.field == "out/img" and err.value.message.startswith("image.npz cannot be read (")
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("content", [b"PK\x03\x04 a truncated zip", b""], ids=["corrupt-zip", "empty"])
def test_image_page_refuses_a_corrupt_or_empty_npz(tmp_path, content):
    (tmp_path / "image.npz").write_bytes(content)
    with pytest.raises(ConfigError) as err:
        image_page(tmp_path, "out/img")
    assert err.value.field == "out/img" and err.value.message.startswith("image.npz cannot be read (")


def test_image_page_refuses_unreadable_metrics(tmp_path):
    (tmp_path / "metrics.json").write_text("[1, 2]")
    with pytest.raises(ConfigError, match=r"^out/img: metrics.json does not hold a JSON object$"):
        image_page(tmp_path, "out/img")


# ---- bpa-sensitivity -----------------------------------------------------------------------------------------------


def test_sensitivity_page_is_the_csv_as_a_table_with_its_figure(tmp_path):
    rows = [["error", "state", "value", "shift_m", "blur"], ["position", "pN", "1.5", "0.25", "1.01"],
            ["velocity", "vE", "0.1", "-0.75", "<1.2>"]]
    with open(tmp_path / "sensitivity.csv", "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows(rows)
    picture = png(tmp_path / "sensitivity.png", 0.25)
    (tmp_path.parent / "other").mkdir(exist_ok=True)
    title, body = sensitivity_page(tmp_path, "out/s")
    assert title == f"sarnav bpa-sensitivity: {tmp_path.name}"
    b = Body(body)
    assert b.tables[0] == rows
    assert b.images == [(picture, "sensitivity.png")]
    assert "&lt;1.2&gt;" in body
    assert b.headings == ["Scenario"]


def test_sensitivity_page_without_figure(tmp_path):
    (tmp_path / "sensitivity.csv").write_text("a,b\n1,2\n", encoding="utf-8")
    b = Body(sensitivity_page(tmp_path, "out/s")[1])
    assert b.tables[0] == [["a", "b"], ["1", "2"]] and b.images == []


@pytest.mark.parametrize("content, start", [
    (None, "sensitivity.csv cannot be read ("),
    (b"", "sensitivity.csv is empty"),
    (b"a,b\n\xff\xfe\n", "sensitivity.csv cannot be read ("),
])
def test_sensitivity_page_refuses_a_missing_empty_or_unreadable_csv(tmp_path, content, start):
    if content is not None:
        (tmp_path / "sensitivity.csv").write_bytes(content)
    with pytest.raises(ConfigError) as err:
        sensitivity_page(tmp_path, "out/s")
    assert err.value.field == "out/s" and err.value.message.startswith(start), str(err.value)


# ---- study ---------------------------------------------------------------------------------------------------------


def test_study_page_lists_cases_states_figures_and_scenario(small_study):
    """Every case with its overrides, the compared states' figures from study.json, the comparison figures as
    stored, one collapsible section per case, and the scenario text."""
    study = json.loads((small_study / "study.json").read_text())
    title, body = study_page(small_study, str(small_study))
    assert title == f"sarnav study: {study['study']}"
    b = Body(body)
    head = {r[0]: r[1] for r in b.tables[0]}
    assert head["runs per case"] == str(study["runs"]) and head["seed"] == str(study["seed"])
    cases = [c["label"] for c in study["cases"]]
    overrides = ["; ".join(f"{k} = {v}" for k, v in c.get("set", {}).items()) or "(base)" for c in study["cases"]]
    assert b.tables[1] == [["case", "overrides"]] + [[c, o] for c, o in zip(cases, overrides)]
    compared = b.tables[2]
    assert compared[0] == ["case", "state", "final 1σ", "final 3σ", "time-averaged 3σ", "inside 3σ [%]"]
    shown = {(r[0], r[1]) for r in compared[1:]}
    assert shown == {(c, s) for c in cases for s in ("pN", "pE", "pD")}
    every = b.tables[3]
    assert len(every) - 1 == sum(len(c["states"]) for c in study["cases"])
    figs = [small_study / f for f in study.get("figures", [])] or sorted(small_study.glob("study_*.png"))
    embedded = [img for img, alt in b.images if alt.startswith("study_")]
    assert embedded == [f.read_bytes() for f in figs if f.is_file()] and embedded
    assert [s for s in b.summaries if s.startswith("case ")] == [f"case {c}" for c in cases]
    assert b.pres[-1] == study["scenario_toml"]
    assert b.headings[:2] == ["Comparison figures", "Cases"] and b.headings[-1] == "Scenario"


def test_study_page_names_a_case_that_cannot_be_read(small_study, tmp_path):
    """A case folder that is missing is one "bad" line in the page; the rest of the page stands."""
    s = tmp_path / "study"
    shutil.copytree(small_study, s)
    study = json.loads((s / "study.json").read_text())
    gone = study["cases"][0]
    shutil.rmtree(s / gone.get("dir", gone["label"]))
    _, body = study_page(s, str(s))
    b = Body(body)
    assert len(b.bad) == 1 and b.bad[0].startswith(f"case {gone['label']}: ")
    assert [x for x in b.summaries if x.startswith("case ")] == [f"case {c['label']}" for c in study["cases"][1:]]


def test_study_page_of_a_minimal_study_json(tmp_path):
    """Missing fields show as n/a; states default to pN pE pD; a scenario text without [study] keeps the defaults."""
    study = {"study": "s1", "cases": [{"label": "a<1>", "set": {"imu.grade": "consumer"}, "dir": "nowhere",
                                       "states": {"pN": {"final_sigma": 2.0, "fraction_inside_3sigma": 0.5},
                                                  "vE": {"final_sigma": 0.1}}}]}
    (tmp_path / "study.json").write_text(json.dumps(study))
    title, body = study_page(tmp_path, "out/st")
    assert title == "sarnav study: s1"
    b = Body(body)
    assert {r[0]: r[1] for r in b.tables[0]} == {"study": "s1", "runs per case": "n/a", "seed": "n/a",
                                                 "complete": "n/a"}
    assert b.tables[1] == [["case", "overrides"], ["a<1>", "imu.grade = consumer"]]
    assert [r[:3] for r in b.tables[2][1:]] == [["a<1>", "pN", "2"]]
    assert b.tables[2][1][5] == "50"
    assert len(b.tables[3]) == 3
    assert b.bad and b.bad[0].startswith("case a<1>: ")
    assert b.pres == ["(not stored)"]
    assert "a<1>" not in body  # escaped everywhere


def test_study_page_states_from_the_scenario_text(tmp_path):
    study = {"study": "s2", "scenario_toml": '[study]\nstates = ["vE"]\n',
             "cases": [{"label": "a", "states": {"pN": {"final_sigma": 2.0}, "vE": {"final_sigma": 0.1}}}]}
    (tmp_path / "study.json").write_text(json.dumps(study))
    b = Body(study_page(tmp_path, "out/st")[1])
    assert [r[1] for r in b.tables[2][1:]] == ["vE"]
    assert any("vE" in c for c in b.captions)

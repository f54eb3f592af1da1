"""report.html of ``sarnav navigate`` (report.navigate_html, report.navigate_figures): a 2-s rda-nav flight exported
with ``sarnav export`` and navigated with ``sarnav navigate``; the page is well-formed, self-contained, has its
sections and figures, flags an incomplete run; each figure draws what the output files hold (checked against the
files read here with numpy and the csv module, and the chi-square bands against scipy)."""

from __future__ import annotations

import csv
import json
import shutil
from html.parser import HTMLParser

import numpy as np
import pytest
from matplotlib.figure import Figure
from scipy.stats import chi2

from page_checks import assert_self_contained
from sarnav.cli.main import main
from sarnav.recording import read_recording
from sarnav.report import navigate_figures as NF
from sarnav.report.navigate_files import STATUS_FILE, run_navigate
from sarnav.report.navigate_html import REPORT_FILE, pair_statuses, read_outputs, write_navigate_report
from sarnav.scenarios.navigate import read_navigate_settings

SECTIONS = ("run", "track", "errors", "gnss", "consistency", "updates")


@pytest.fixture(scope="module")
def navigated(tmp_path_factory):
    """The rda-nav paper flight cut to 2 s, run 1 of 2, exported and navigated by the commands."""
    root = tmp_path_factory.mktemp("navreport")
    assert main(["export", "rda-nav", "--runs", "2", "--run", "1", "--set", "trajectory.duration=2.0", "--out",
                 str(root / "rec"), "--quiet"]) == 0
    assert main(["navigate", str(root / "rec"), "--out", str(root / "out"), "--quiet"]) == 0
    return root


def _columns(path) -> dict:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    data = np.array(rows[1:], dtype=float)
    return {h: data[:, i] for i, h in enumerate(rows[0])}


class _Balance(HTMLParser):
    """Tag nesting of a page: every non-void element closed in order; section ids."""
    VOID = {"meta", "img", "br", "hr", "input", "link"}

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.ids = [], [], []

    def handle_starttag(self, tag, attrs):
        if tag == "section":
            self.ids.append(dict(attrs).get("id"))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag):
        if not self.stack or self.stack[-1] != tag:
            self.errors.append((tag, list(self.stack[-3:])))
        else:
            self.stack.pop()


def _parse(text: str) -> _Balance:
    p = _Balance()
    p.feed(text)
    p.close()
    assert text.startswith("<!DOCTYPE html>") and not p.errors and not p.stack, (p.errors, p.stack)
    return p


def test_report_is_written_with_its_sections(navigated):
    out = navigated / "out"
    text = (out / REPORT_FILE).read_text(encoding="utf-8")
    assert not list(out.glob("*.partial"))
    doc = json.loads((out / STATUS_FILE).read_text())
    assert doc["complete"] is True and REPORT_FILE in doc["files"]
    page = _parse(text)
    assert tuple(page.ids) == SECTIONS
    pngs = assert_self_contained(text)
    assert len(pngs) == 1 + 3 + 1  # track; position, velocity, attitude errors; NEES and NIS
    assert "INCOMPLETE" not in text and 'id="incomplete"' not in text
    assert "no GNSS (gnss.csv)" in text and "flight.toml (manifest)" in text
    assert "real_time_factor" in text
    with open(out / "updates.csv", newline="") as fh:
        n_pairs = sum(1 for _ in csv.DictReader(fh))
    assert text.count("<tr>") >= n_pairs + 1 and "fused" in text


def test_incomplete_run_is_flagged(navigated, tmp_path):
    """A navigate.json at complete: false (a run killed outright) makes the page say INCOMPLETE at its top."""
    out = tmp_path / "out"
    shutil.copytree(navigated / "out", out)
    doc = json.loads((out / STATUS_FILE).read_text())
    doc.update(complete=False, interrupted="KeyboardInterrupt")
    (out / STATUS_FILE).write_text(json.dumps(doc))
    write_navigate_report(out, reference_images=0)
    text = (out / REPORT_FILE).read_text(encoding="utf-8")
    _parse(text)
    body = text[text.index("<body>"):]
    assert body.index('id="incomplete"') < body.index('<section id="run"')
    assert "<strong>INCOMPLETE</strong>" in body and "(INCOMPLETE)</title>" in text and "KeyboardInterrupt" in body


def test_interrupted_run_leaves_an_incomplete_partial_report(navigated, tmp_path):
    rec = read_recording(navigated / "rec")

    def stop(u, n, nav):
        if u == 0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_navigate(rec, tmp_path / "out", read_navigate_settings(rec), progress=stop)
    doc = json.loads((tmp_path / "out" / STATUS_FILE).read_text())
    assert doc["complete"] is False and f"{REPORT_FILE}.partial" in doc["files"]
    assert not (tmp_path / "out" / REPORT_FILE).exists()
    text = (tmp_path / "out" / f"{REPORT_FILE}.partial").read_text(encoding="utf-8")
    _parse(text)
    assert 'id="incomplete"' in text and "1 of 2 updates" in text


def test_no_report(navigated, tmp_path):
    assert main(["navigate", str(navigated / "rec"), "--out", str(tmp_path / "out"), "--quiet", "--no-report"]) == 0
    assert not (tmp_path / "out" / REPORT_FILE).exists()
    assert REPORT_FILE not in json.loads((tmp_path / "out" / STATUS_FILE).read_text())["files"]


def test_error_figures_draw_errors_csv(navigated):
    """The error and ±3σ curves are errors.csv's error_ and 3 x sigma_ columns (attitude in mrad)."""
    e = _columns(navigated / "out" / "errors.csv")
    for title, names, unit, scale in NF.ERROR_BLOCKS:
        fig = NF.error_figure(e, names, title, unit, scale)
        assert isinstance(fig, Figure) and len(fig.axes) == 3
        for ax, n in zip(fig.axes, names):
            err, up, lo = ax.lines[:3]
            np.testing.assert_array_equal(err.get_xdata(), e["time"])
            np.testing.assert_allclose(err.get_ydata(), scale * e[f"error_{n}"], rtol=1e-15)
            np.testing.assert_allclose(up.get_ydata(), 3.0 * scale * e[f"sigma_{n}"], rtol=1e-15)
            np.testing.assert_allclose(lo.get_ydata(), -3.0 * scale * e[f"sigma_{n}"], rtol=1e-15)
    assert NF.ERROR_BLOCKS[2][2:] == ("mrad", 1e3)


def test_consistency_figure_bands(navigated):
    """NEES from errors.csv against chi2(dof) 2.5-97.5 %; NIS per update against chi2(dof of the update)."""
    out = read_outputs(navigated / "out")
    e = _columns(navigated / "out" / "errors.csv")
    nees = {"time": e["time"], "nees": e["nees"], "dof": e["nees_dof"]}
    fig = NF.consistency_figure(out.updates, nees)
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    ax_nees, ax_nis = fig.axes
    np.testing.assert_allclose(ax_nees.lines[0].get_ydata(), e["nees"], rtol=1e-15)
    band = ax_nees.collections[0].get_paths()[0].vertices[:, 1]
    assert np.isclose(band.max(), chi2.ppf(0.975, e["nees_dof"][0])) and \
        np.isclose(band.min(), chi2.ppf(0.025, e["nees_dof"][0]))
    segs = ax_nis.collections[0].get_segments()
    dof = out.updates["dof"]
    assert len(segs) == dof.size == 2
    for seg, d in zip(segs, dof):
        np.testing.assert_allclose(sorted(seg[:, 1]), chi2.ppf([0.025, 0.975], d), rtol=1e-12)
    shown = np.concatenate([ln.get_ydata() for ln in ax_nis.lines])
    np.testing.assert_allclose(np.sort(shown), np.sort(out.updates["nis"]), rtol=1e-15)


def test_track_figure_draws_the_track_and_points(navigated):
    """The track is trajectory.csv's north/east; the update points the track at the update times, all fused (green);
    the map circles are points.csv's map positions."""
    out = read_outputs(navigated / "out")
    tr = _columns(navigated / "out" / "trajectory.csv")
    pts = _columns(navigated / "rec" / "reference" / "points.csv")
    fig = NF.track_figure(out.track, out.updates, out.recording.points, (), pair_statuses(
        out.pairs, out.recording.points.anchors.shape[:2]))
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    ax = fig.axes[1]
    np.testing.assert_allclose(ax.lines[0].get_xdata(), tr["east"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(ax.lines[0].get_ydata(), tr["north"], rtol=0, atol=1e-9)
    ups = ax.collections[0]
    t_up = out.updates["time"]
    assert t_up.size == 2
    np.testing.assert_allclose(ups.get_offsets(), np.c_[np.interp(t_up, tr["time"], tr["east"]),
                                                        np.interp(t_up, tr["time"], tr["north"])], atol=1e-6)
    assert ups.get_label().startswith("update: fused (2)")
    circles = fig.axes[0].collections[-1]
    np.testing.assert_allclose(circles.get_offsets(), np.c_[pts["map_east_m"], pts["map_north_m"]], rtol=1e-12)
    np.testing.assert_allclose(circles.get_facecolors()[:, :3], [[0.17254902, 0.62745098, 0.17254902]] * 2,
                               atol=1e-6)  # tab:green


def test_update_status_and_pair_statuses():
    up = NF.update_status([1.0, 2.0, 3.0, 4.0], [1.0, 1.0, 2.0, 3.0], [2, 0, 3, -1])
    assert up == ["fused", "rejected", "skipped", "none"]
    rows = [{"aperture": "0", "point": "1", "status_code": "0"}, {"aperture": "1", "point": "0", "status_code": "4"},
            {"aperture": "2", "point": "1", "status_code": "-1"}]
    assert pair_statuses(rows, (3, 2)) == ["none", "fused", "rejected", "none", "none", "skipped"]
    assert NF.pick_apertures(50, range(50), 3) == [0, 24, 49] and NF.pick_apertures(5, [4, 1, 9], 3) == [1, 4]


def test_reference_tile_shows_the_point_at_its_anchor(navigated):
    """An export's reference points are the scene's reflectors: the amplitude image of the reference pass peaks at
    the anchor (within a pixel across and the 3-m azimuth resolution along)."""
    rec = read_recording(navigated / "rec")
    (tile,) = NF.reference_tiles(rec, [1])
    i, j = np.unravel_index(np.argmax(tile.amplitude), tile.amplitude.shape)
    a = rec.points.anchors[1, 0]
    assert abs(tile.east[j] - a[1]) <= 1.5 * (tile.east[1] - tile.east[0])
    assert abs(tile.north[i] - a[0]) <= 1.5
    assert tile.amplitude[i, j] > 20 * np.median(tile.amplitude)


def test_gnss_section(navigated, tmp_path):
    """A recording with gnss.csv (truth + a known offset, 1-sigma 0.5/0.5/1 m): the figure draws estimate - GNSS,
    against 3 sqrt(sigma_est^2 + sigma_GNSS^2), as computed here from trajectory.csv."""
    rec_dir = tmp_path / "rec"
    shutil.copytree(navigated / "rec", rec_dir)
    truth = _columns(rec_dir / "truth.csv")
    k = np.arange(0, truth["time"].size, 5)
    offset, sig = np.array([0.3, -0.2, 0.1]), np.array([0.5, 0.5, 1.0])
    with open(rec_dir / "gnss.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_s", "north_m", "east_m", "down_m", "sigma_north_m", "sigma_east_m", "sigma_down_m"])
        for i in k:
            pos = [repr(float(truth[c][i] + o)) for c, o in zip(("north", "east", "down"), offset)]
            w.writerow([repr(float(truth["time"][i])), *pos, *sig])
    with open(rec_dir / "flight.toml", "a") as fh:
        fh.write('\n[gnss]\nfile = "gnss.csv"\n')
    rec = read_recording(rec_dir)
    tr = _columns(navigated / "out" / "trajectory.csv")
    out = read_outputs(navigated / "out", rec=rec)
    diff = NF.gnss_difference(out.track, rec.gnss)
    fig = NF.gnss_figure(diff)
    assert isinstance(fig, Figure)
    for i, (ax, c) in enumerate(zip(fig.axes, ("north", "east", "down"))):
        est = np.interp(truth["time"][k], tr["time"], tr[c])
        s = np.interp(truth["time"][k], tr["time"], tr[f"sigma_{c}"])
        np.testing.assert_allclose(ax.lines[0].get_ydata(), est - truth[c][k] - offset[i], atol=1e-9)
        np.testing.assert_allclose(ax.lines[1].get_ydata(), 3 * np.sqrt(s ** 2 + sig[i] ** 2), rtol=1e-12)
    page = tmp_path / "out"
    shutil.copytree(navigated / "out", page)
    write_navigate_report(page, rec=rec, reference_images=0)
    text = (page / REPORT_FILE).read_text(encoding="utf-8")
    _parse(text)
    gnss = text[text.index('<section id="gnss"'):text.index('<section id="consistency"')]
    assert gnss.count("data:image/png;base64,") == 1 and "within 3σ (north)" in gnss


def test_report_from_trajectory_csv_alone_and_from_nothing(navigated, tmp_path):
    """Without trajectory.nc the track comes from trajectory.csv (no NIS panel); a folder a killed run left (only
    navigate.json at complete: false) still gives a well-formed page flagged INCOMPLETE."""
    out = tmp_path / "out"
    shutil.copytree(navigated / "out", out)
    (out / "trajectory.nc").unlink()
    o = read_outputs(out)
    tr = _columns(out / "trajectory.csv")
    np.testing.assert_array_equal(o.track["east"], tr["east"])
    assert "nis" not in o.updates and o.updates["time"].size == 2
    write_navigate_report(out, reference_images=0)
    assert _parse((out / REPORT_FILE).read_text(encoding="utf-8")).ids == list(SECTIONS)
    bare = tmp_path / "bare"
    bare.mkdir()
    (bare / STATUS_FILE).write_text(json.dumps({"complete": False, "recording": str(navigated / "rec")}))
    write_navigate_report(bare)
    text = (bare / REPORT_FILE).read_text(encoding="utf-8")
    _parse(text)
    assert 'id="incomplete"' in text and "No trajectory file" in text

"""``sarnav navigate`` writes the images it forms (issue 26 item 4): a PNG of every in-flight image registered, with
``--sicd`` its SICD on the navigator's own estimated track, images.csv; none for an aperture not imaged; an
interrupted run leaves ``images.partial/``, never an ``images/`` that looks complete.

The rda-nav paper flight cut to 3 s (three apertures, one reference point each), exported by ``sarnav export``.
"""

from __future__ import annotations

import csv
import datetime
import json
import shutil

import numpy as np
import pytest
import sarkit.verification as skver
from PIL import Image

from sarnav.cli.main import main
from sarnav.io.frames import ecef_to_ned
from sarnav.io.sicd import read_sicd
from sarnav.recording import read_recording
from sarnav.recording.navigate import navigate
from sarnav.report.navigate_files import STATUS_FILE, run_navigate
from sarnav.report.navigate_images import DYNAMIC_RANGE_DB, INDEX_FILE, db_pixels
from sarnav.scenarios.navigate import read_navigate_settings

IMAGE_FAILED = "image formation or autofocus failed"


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    root = tmp_path_factory.mktemp("navimg")
    assert main(["export", "rda-nav", "--runs", "2", "--run", "1", "--set", "trajectory.duration=3.0", "--out",
                 str(root / "rec"), "--quiet"]) == 0
    assert main(["navigate", str(root / "rec"), "--out", str(root / "out"), "--quiet", "--no-report", "--sicd"]) == 0
    return root


def _rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _columns(path):
    rows = _rows(path)
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def test_one_png_per_image_formed(flown):
    out = flown / "out"
    formed = [r for r in _rows(out / "updates.csv") if int(r["status_code"]) >= 0 and r["status"] != IMAGE_FAILED]
    index = _rows(out / "images" / INDEX_FILE)
    assert len(formed) == 3 and len(index) == len(formed)
    assert sorted(p.name for p in (out / "images").glob("*.png")) == [f"aperture_{r['aperture'].zfill(3)}.png"
                                                                     for r in formed]
    assert [(r["aperture"], r["point"], r["time"]) for r in index] == [(r["aperture"], r["point"], r["time"])
                                                                        for r in formed]
    doc = json.loads((out / STATUS_FILE).read_text())
    assert doc["complete"] is True and "images/" in doc["files"] and not (out / "images.partial").exists()
    assert doc["images"]["png"] == doc["images"]["sicd"] == 3 and doc["sicd"] is True


def test_png_is_the_registered_image_in_db(flown):
    """The PNG's grey levels are the in-flight image's (formed again by the same navigator, handed to a collector),
    40 dB below the peak to it; the brightest pixel is where the image measured the reference point (its TOC and
    range of closest approach in updates.csv)."""
    out = flown / "out"
    rec = read_recording(flown / "rec")
    kept = {}
    navigate(rec, read_navigate_settings(rec), images=lambda ap, t, im: kept.update({ap: im[0]["image"].data.copy()}))
    for r, u in zip(_rows(out / "images" / INDEX_FILE), _rows(out / "updates.csv")):
        with Image.open(out / "images" / r["png"]) as im:
            grey = np.asarray(im)
            assert im.mode == "L" and f"down {DYNAMIC_RANGE_DB:g} dB" in im.info["Description"]
        want, peak = db_pixels(kept[int(r["aperture"])])
        np.testing.assert_array_equal(grey, want)
        assert grey.max() == 255 and abs(peak - float(r["peak_db"])) < 1e-9
        assert r["rows"] == "zero_doppler_time" and r["cols"] == "slant_range"
        i, j = np.unravel_index(np.argmax(grey), grey.shape)
        n = grey.shape[0]
        row = (float(u["toc"]) - float(r["row_first"])) / float(r["row_spacing"])
        col = (float(u["measured_range"]) - float(r["col_first"])) / float(r["col_spacing"])
        # an azimuth resolution cell is ~30 rows (lambda R / (2 V T) = 3 m at 10 m/s, 0.1 m a pulse), a range one
        # ~1 column: the peak within a sixth of the one and 1.5 of the other
        assert abs((i - row + n / 2) % n - n / 2) <= 5 and abs(j - col) <= 1.5, (i, row, j, col)


def test_sicd_passes_the_checker_on_the_estimated_track(flown):
    """Each SICD passes sarkit's checker (no error, no warning); its antenna at the SCP's centre of aperture is
    navigate's own estimate there (trajectory.csv), so it differs from truth by the estimate's error (errors.csv),
    and its SCP lies in the in-flight image's slant-range window."""
    out, rec = flown / "out", read_recording(flown / "rec")
    tr, err, truth = _columns(out / "trajectory.csv"), _columns(out / "errors.csv"), rec.truth
    origin, epoch = rec.manifest.frame.origin, rec.manifest.time.epoch
    for r in _rows(out / "images" / INDEX_FILE):
        path = out / "images" / r["sicd"]
        with open(path, "rb") as f:
            con = skver.SicdConsistency.from_file(f)
            con.check()
        bad = {k: [d["details"] for d in v["details"] if not d["passed"]] for k, v in con.failures().items()}
        assert not any(bad.values()), bad
        prod = read_sicd(path)
        xml = prod.xml
        start = datetime.datetime.fromisoformat(xml.findtext("./{*}Timeline/{*}CollectStart"))
        t = (start - epoch).total_seconds() + float(xml.findtext("./{*}SCPCOA/{*}SCPTime"))
        assert float(r["row_first"]) <= t <= float(r["row_first"]) + 100 * float(r["row_spacing"])
        arp = ecef_to_ned(np.array([float(xml.findtext(f"./{{*}}SCPCOA/{{*}}ARPPos/{{*}}{c}")) for c in "XYZ"]),
                          origin)
        est = np.array([np.interp(t, tr["time"], tr[c]) for c in ("north", "east", "down")])
        np.testing.assert_allclose(arp, est, rtol=0, atol=2e-3)          # 2 mm: the ARPPoly fit of the track
        true = np.array([np.interp(t, truth.time, truth.position[:, i]) for i in range(3)])
        e = np.array([np.interp(t, err["time"], err[f"error_{c}"]) for c in ("north", "east", "down")])
        np.testing.assert_allclose(true - arp, e, rtol=0, atol=2e-3)
        assert np.linalg.norm(e) > 0.1                                   # the estimate is not the truth
        scp_range = np.linalg.norm(ecef_to_ned(prod.scp, origin) - arp)
        cols = float(r["col_first"]), float(r["col_first"]) + 160 * float(r["col_spacing"])
        assert cols[0] < scp_range < cols[1]


def test_interrupted_run_leaves_images_partial_and_overwrite_replaces_them(flown, tmp_path, capsys):
    rec = read_recording(flown / "rec")

    def stop(u, n, nav):
        if u == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_navigate(rec, tmp_path / "out", read_navigate_settings(rec), progress=stop, report=False)
    out = tmp_path / "out"
    doc = json.loads((out / STATUS_FILE).read_text())
    assert doc["complete"] is False and "images.partial/" in doc["files"] and doc["images"]["png"] == 2
    assert not (out / "images").exists()
    assert [r["png"] for r in _rows(out / "images.partial" / INDEX_FILE)] == ["aperture_000.png", "aperture_001.png"]
    # a file navigate did not write in its image folder: refused in one line, left alone
    args = ["navigate", str(flown / "rec"), "--out", str(out), "--quiet", "--no-report", "--overwrite"]
    (out / "images.partial" / "notes.txt").write_text("mine")
    capsys.readouterr()
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sarnav: error: --out: ") and "notes.txt" in err[0]
    assert (out / "images.partial" / "notes.txt").is_file() and (out / "trajectory.csv.partial").is_file()
    # --overwrite clears navigate's images, and the complete run publishes images/
    (out / "images.partial" / "notes.txt").unlink()
    assert main(args) == 0
    assert sorted(p.name for p in (out / "images").iterdir()) == ["aperture_000.png", "aperture_001.png",
                                                                  "aperture_002.png", INDEX_FILE]
    assert not (out / "images.partial").exists()


def test_an_aperture_not_imaged_writes_no_image(flown, tmp_path):
    """Aperture 1's reference point 3 km off its pass (tests/recording/test_navigate.py): skipped, no PNG; the
    run completes with the other two."""
    folder = tmp_path / "rec"
    shutil.copytree(flown / "rec", folder)
    path = folder / "reference" / "points.csv"
    rows = _rows(path)
    rows[1]["anchor_east_m"] = repr(float(rows[1]["anchor_east_m"]) + 3000.0)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    rec = read_recording(folder)
    doc = run_navigate(rec, tmp_path / "out", read_navigate_settings(rec), report=False)
    assert doc["complete"] is True and doc["pairs_skipped"] == 1
    assert sorted(p.name for p in (tmp_path / "out" / "images").glob("*.png")) == ["aperture_000.png",
                                                                                   "aperture_002.png"]

"""``report.html`` of ``sarnav navigate`` (docs/navigate.md): one self-contained page built from the output files.

It reads only what ``run_navigate`` wrote (``trajectory.nc``, else ``trajectory.csv``; ``updates.csv``;
``errors.csv`` when present; ``navigate.json``) and the recording the run names (its reference points, its
reference passes for the amplitude images, its GNSS log), and shows:

1. **Track**: the estimated track (north/east) with the update points coloured by status over the reference (the
   reference points and the amplitude images of up to ``MAX_REFERENCE_IMAGES`` reference passes);
2. **Errors** against ±3σ with truth (``errors.csv``), and the estimate minus GNSS against ±3 sqrt(σ_est² +
   σ_GNSS²) where the recording has ``gnss.csv``;
3. **Consistency**: NEES per epoch (with truth) and NIS per update against their 95 % chi-square bands, and
   navigate.json's ``consistency`` summary;
4. **Run**: counts, real-time factor, notices, settings; the updates.csv table (collapsed when long).

A run that navigate.json marks ``complete: false`` is flagged INCOMPLETE at the top. The figures are PNG embedded
as ``data:`` URIs (``report.html_parts``): the page refers to nothing outside itself.
"""

from __future__ import annotations

import csv
import datetime as _dt
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sarnav.errors import SarnavError
from sarnav.report import html_parts as H
from sarnav.report import navigate_figures as NF
from sarnav.report.figures import png_bytes

__all__ = ["REPORT_FILE", "MAX_REFERENCE_IMAGES", "COLLAPSE_ROWS", "NavigateOutputs", "read_outputs",
           "navigate_report_html", "write_navigate_report", "pair_statuses"]

REPORT_FILE = "report.html"
#: reference passes imaged for the track figure at most (each reads its CPHD: ~0.1-0.3 s)
MAX_REFERENCE_IMAGES = 3
#: updates.csv tables longer than this are collapsed
COLLAPSE_ROWS = 30
_DPI = 90
_TRACK_VARS = ("time", "north", "east", "down", "sigma_north", "sigma_east", "sigma_down")


@dataclass
class NavigateOutputs:
    """What a navigate output folder holds: ``doc`` (navigate.json), ``track`` (trajectory columns ``time, north,
    east, down, sigma_north, sigma_east, sigma_down``), ``updates`` (per update ``time``, ``aperture``, ``nis``,
    ``dof``, from trajectory.nc; ``time`` only from updates.csv without it), ``pairs`` (updates.csv rows), ``errors``
    (errors.csv columns or None), ``recording`` (``recording.Recording`` or None, with ``recording_error``)."""

    folder: Path
    doc: dict
    track: dict | None
    updates: dict
    pairs: list
    errors: dict | None
    recording: object | None
    recording_error: str | None = None


def _read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    return (rows[0], rows[1:]) if rows else ([], [])


def _numeric_columns(path: Path) -> dict:
    header, rows = _read_csv(path)
    data = np.array(rows, dtype=np.float64).reshape(len(rows), len(header))
    return {h: data[:, i] for i, h in enumerate(header)}


def _read_track(out: Path, suffix: str) -> tuple[dict | None, dict | None]:
    """(track columns, per-update NIS) from trajectory.nc, else (track, None) from trajectory.csv."""
    nc, tcsv = out / f"trajectory.nc{suffix}", out / f"trajectory.csv{suffix}"
    if nc.is_file():
        import xarray as xr

        with xr.open_dataset(nc, engine="netcdf4") as ds:
            track = {k: ds[k].values.astype(np.float64) for k in _TRACK_VARS}
            ups = {"time": ds["update_time"].values.astype(np.float64), "nis": ds["nis"].values.astype(np.float64),
                   "dof": ds["nis_dof"].values.astype(np.float64),
                   "aperture": ds["update_aperture"].values.astype(np.int64)}
        return track, ups
    if tcsv.is_file():
        cols = _numeric_columns(tcsv)
        return {k: cols[k] for k in _TRACK_VARS}, None
    return None, None


def _load_recording(doc: dict, rec):
    if rec is not None:
        return rec, None
    from sarnav.recording import read_recording

    try:
        return read_recording(doc.get("recording", "")), None
    except (SarnavError, OSError) as err:
        return None, f"the recording {doc.get('recording')!r} could not be read: {err}"


def read_outputs(out, doc: dict | None = None, rec=None, suffix: str = "") -> NavigateOutputs:
    """The outputs in folder ``out`` (each name + ``suffix``: ``.partial`` before run_navigate renames them);
    ``doc``: navigate.json's content (default: read from ``out``); ``rec``: the recording (default: read from the
    folder navigate.json names; a recording that does not read leaves the reference and GNSS out, with a note)."""
    out = Path(out)
    if doc is None:
        doc = json.loads((out / "navigate.json").read_text(encoding="utf-8"))
    track, ups = _read_track(out, suffix)
    pairs = []
    if (out / f"updates.csv{suffix}").is_file():
        with open(out / f"updates.csv{suffix}", newline="", encoding="utf-8") as fh:
            pairs = list(csv.DictReader(fh))
    if ups is None:
        ups = {"time": np.unique([float(p["time"]) for p in pairs])}
    ups["pair_time"] = np.array([float(p["time"]) for p in pairs])
    ups["pair_code"] = np.array([int(p["status_code"]) for p in pairs], dtype=np.int64)
    epath = out / f"errors.csv{suffix}"
    errors = _numeric_columns(epath) if epath.is_file() else None
    rec, why = _load_recording(doc, rec)
    return NavigateOutputs(out, doc, track, ups, pairs, errors, rec, why)


def pair_statuses(pairs: list, shape: tuple[int, int]) -> list[str]:
    """Status of every (aperture, point) of a (U, T) grid from updates.csv rows: "fused" (code 0), "rejected"
    (> 0), "skipped" (-1), "none" (no row: not processed)."""
    out = np.full(shape, "none", dtype=object)
    for p in pairs:
        u, k, c = int(p["aperture"]), int(p["point"]), int(p["status_code"])
        if 0 <= u < shape[0] and 0 <= k < shape[1]:
            out[u, k] = "fused" if c == 0 else "rejected" if c > 0 else "skipped"
    return out.reshape(-1).tolist()


def _fig(fig, caption: str) -> str:
    return H.figure(png_bytes(fig, dpi=_DPI), caption)


def _section(key: str, title: str, body: str) -> str:
    return f'<section id="{key}">\n<h2>{H.esc(title)}</h2>\n{body}</section>\n'


def _banner(doc: dict) -> str:
    if doc.get("complete") is True:
        return ""
    why = doc.get("interrupted") or "navigate.json says complete: false (the run stopped before its outputs were " \
                                    "in place)"
    return (f'<p class="bad" id="incomplete" style="font-size:1.4em"><strong>INCOMPLETE</strong>: this run did not '
            f"finish ({H.esc(why)}). What follows is what was done up to "
            f"{H.esc(H.fmt(doc.get('updates')))} of {H.esc(H.fmt(doc.get('updates_planned')))} updates.</p>\n")


def _run_section(o: NavigateOutputs) -> str:
    d = o.doc
    facts = {k: d.get(k) for k in ("recording", "complete", "interrupted", "started", "sarnav_version", "updates",
                                   "updates_planned", "epochs", "pairs_fused", "pairs_rejected", "pairs_skipped",
                                   "flight_seconds", "wall_seconds", "real_time_factor") if k in d}
    im = d.get("images") or {}
    if im:  # named, not linked: the page refers to nothing outside itself
        where = "images/" if d.get("complete") is True else "images.partial/"
        facts["in-flight images"] = (f"{im.get('png', 0)} PNG, {im.get('sicd', 0)} SICD in {where} (one per "
                                     "aperture imaged; images.csv lists them)")
    body = H.kv_table(facts, "run (navigate.json; wall time and real-time factor exclude this page)")
    body += H.kv_table({"--config": d.get("config"), "--set": " ".join(d.get("set") or []) or "none"},
                       "settings given (defaults: the recording's scenario.toml, else rda-nav's; docs/navigate.md)")
    notices = d.get("notices") or []
    body += ("<h3>Notices</h3>\n<ul>" + "".join(f"<li>{H.esc(n)}</li>" for n in notices) + "</ul>\n") if notices \
        else "<p>No notices.</p>\n"
    if o.recording is not None and getattr(o.recording, "scenario_text", None):
        body += H.details("the recording's scenario.toml (the navigator's default settings)",
                          H.pre(o.recording.scenario_text))
    manifest = Path(o.recording.folder) / "flight.toml" if o.recording is not None else None
    if manifest is not None and manifest.is_file():
        body += H.details("the recording's flight.toml (manifest)", H.pre(manifest.read_text(encoding="utf-8")))
    if o.recording_error:
        body += f'<p class="note">{H.esc(o.recording_error)}</p>\n'
    return _section("run", "Run", body)


def _tiles(rec, pairs: list, at_most: int) -> tuple[list, str]:
    """Reference images of up to ``at_most`` apertures that were imaged (pairs not skipped), and a note of any
    that could not be formed."""
    n = len(rec.manifest.apertures or ())
    imaged = {int(p["aperture"]) for p in pairs if int(p["status_code"]) >= 0}
    tiles, failed = [], []
    for u in NF.pick_apertures(n, imaged if imaged else range(n), at_most):
        try:
            tiles += NF.reference_tiles(rec, [u])
        except Exception as err:  # noqa: BLE001 - a picture: the page says why it is missing and goes on
            failed.append(f"aperture {u}: {type(err).__name__}: {err}")
    note = f'<p class="note">Reference images not formed: {H.esc("; ".join(failed))}</p>\n' if failed else ""
    return tiles, note


def _track_section(o: NavigateOutputs, reference_images: int) -> str:
    if o.track is None:
        return _section("track", "Track", "<p>No trajectory file.</p>\n")
    rec = o.recording
    points = getattr(rec, "points", None)
    tiles, note = _tiles(rec, o.pairs, reference_images) if points is not None and reference_images > 0 else ([], "")
    status = pair_statuses(o.pairs, points.anchors.shape[:2]) if points is not None else None
    fig = NF.track_figure(o.track, o.updates, points, tiles, status)
    shown = ", ".join(str(t.aperture) for t in tiles)
    cap = ("Estimated track (north/east of the recording's local frame) and the update points (green: a SAR pair "
           "fused, red: rejected, grey: skipped, blue: altimeter only); reference points: crosses where the reference "
           "puts them (anchor), circles where the map does, filled by their pair's status"
           + (f"; amplitude of the reference passes of aperture(s) {shown} (cyan outlines), back-projected along "
              "their trusted positions" if tiles else "") + ".")
    return _section("track", "Track over the reference", _fig(fig, cap) + note)


def _errors_section(o: NavigateOutputs) -> str:
    body = ""
    if o.errors is not None:
        for title, names, unit, scale in NF.ERROR_BLOCKS:
            fig = NF.error_figure(o.errors, names, title, unit, scale)
            body += _fig(fig, f"{title}: truth minus estimate (errors.csv) against ±3σ of the filter.")
    else:
        body += "<p>The recording has no truth (truth.csv): no errors against truth.</p>\n"
    return _section("errors", "Errors against ±3σ (truth)", body)


def _gnss_section(o: NavigateOutputs) -> str:
    body = ""
    gnss = getattr(o.recording, "gnss", None)
    diff = NF.gnss_difference(o.track, gnss) if gnss is not None and o.track is not None else None
    if diff is not None:
        until = getattr(o.recording.manifest.initial, "gnss_until", None)
        body += _fig(NF.gnss_figure(diff, until), "Estimate minus GNSS position at the GNSS fixes (gnss.csv) against "
                     "±3√(σ_est² + σ_GNSS²), the estimate interpolated linearly to the fixes' times.")
        body += H.kv_table({f"estimate − GNSS within 3σ ({n})": H.pct(float(np.mean(
            np.abs(diff["difference"][:, i]) <= diff["bound"][:, i]))) + " %" for i, n in
            enumerate(("north", "east", "down"))})
    elif gnss is None:
        body += "<p>The recording has no GNSS (gnss.csv).</p>\n"
    else:
        body += "<p>No GNSS fix lies inside the estimated track's time span.</p>\n"
    return _section("gnss", "Estimate minus GNSS", body)


def _consistency_section(o: NavigateOutputs) -> str:
    c = o.doc.get("consistency") or {}
    nees = None
    if o.errors is not None and "nees" in o.errors:
        nees = {"time": o.errors["time"], "nees": o.errors["nees"], "dof": o.errors["nees_dof"]}
    nis = o.updates if "nis" in o.updates and o.updates["time"].size else None
    body = ""
    if nees is not None or nis is not None:
        fig = NF.consistency_figure(nis, nees)
        body += _fig(fig, "NEES per epoch (with truth) and NIS per update against the two-sided 95 % chi-square band "
                     "of one run (each update's band for its number of measurements); red: outside the band.")
    rows = []
    if "nees" in c:
        n = c["nees"]
        rows.append(("NEES (time average)", H.fmt(n["time_average"]), H.fmt(n["band_95"]), H.fmt(n["dof"]),
                     H.pct(n["fraction_in_band"]) + " %"))
    if "nis" in c:
        n = c["nis"]
        rows.append(("NIS per dof", H.fmt(n["per_dof"]), H.fmt(n["per_dof_band_95"]), "-",
                     H.pct(n["fraction_in_band"]) + " %"))
    if rows:
        body += H.table(("statistic", "value", "95 % band", "dof", "in band"), rows, "navigate.json: consistency")
    extra = {k: c[k] for k in ("final_position_error_m", "final_position_sigma_m", "within_3sigma") if k in c}
    if extra:
        body += H.kv_table(extra)
    return _section("consistency", "Consistency: NEES and NIS", body or "<p>No updates.</p>\n")


def _updates_section(o: NavigateOutputs) -> str:
    if not o.pairs:
        return _section("updates", "Updates", "<p>No SAR pairs (updates.csv is empty).</p>\n")
    header = list(o.pairs[0])

    def cell(v: str) -> str:
        try:
            return H.fmt(float(v), 6) if v.strip() not in ("", "0", "1") else v
        except ValueError:
            return v

    rows = [[cell(p[h]) for h in header] for p in o.pairs]
    table = H.table(header, rows, text_columns=0)
    body = table if len(rows) <= COLLAPSE_ROWS else H.details(f"updates.csv: {len(rows)} rows (click to show)", table)
    return _section("updates", "Updates (updates.csv)", body)


def navigate_report_html(outputs: NavigateOutputs, reference_images: int = MAX_REFERENCE_IMAGES) -> str:
    """The report page of ``outputs`` (:func:`read_outputs`) as HTML text."""
    o = outputs
    name = Path(str(o.doc.get("recording", o.folder))).name
    made = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    versions = ", ".join(f"{k} {v}" for k, v in H.versions().items())
    body = (_banner(o.doc) + _run_section(o) + _track_section(o, reference_images) + _errors_section(o)
            + _gnss_section(o) + _consistency_section(o) + _updates_section(o)
            + f'<p class="meta">Page made {H.esc(made)} by {H.esc(versions)}.</p>\n')
    title = f"sarnav navigate: {name}" + ("" if o.doc.get("complete") is True else " (INCOMPLETE)")
    return H.page(title, body)


def write_navigate_report(out, doc: dict | None = None, rec=None, suffix: str = "",
                          reference_images: int = MAX_REFERENCE_IMAGES) -> str:
    """Write ``out/report.html`` + ``suffix`` from the outputs there (:func:`read_outputs`); returns the name
    written."""
    out = Path(out)
    text = navigate_report_html(read_outputs(out, doc, rec, suffix), reference_images)
    name = REPORT_FILE + suffix
    tmp = out / f".{name}.tmp"
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, out / name)
    return name

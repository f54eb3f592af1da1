"""``sarnav compare DIR1 DIR2 ... --out OUT``: campaigns side by side over the states they share.

Writes ``OUT/compare.csv`` (one row per campaign × shared state, columns :data:`CSV_COLUMNS`) and ``OUT/compare.html``
(one self-contained page: the campaigns, the table, overlays of the filter 3σ and the RMS error per block of shared
states, and the consistency figure: run-mean NEES / dof and NIS / dof against their χ² bands).

Statistics, computed from each ``results.nc`` with :mod:`sarnav.analysis.consistency`:

* ``final_3sigma``: 3 × the filter 1σ at the last epoch, mean over runs;
* ``rms_error_final``: √(mean over runs of e²) at the last epoch; ``rms_error_time_average``: the time average of
  that RMS over all output epochs;
* ``fraction_inside_3sigma``: share of |e| ≤ 3σ over all runs and epochs (0.9973 for a consistent Gaussian filter);
* ``nees_time_average`` with ``nees_band_lo/hi``: the time average of the run-mean NEES (expected: ``nees_dof`` =
  the campaign's number of states) and the 95 % band of the run mean at one epoch (Bar-Shalom et al. 2001 §5.4.2);
* ``nis_per_dof`` with its band: ΣNIS/Σdof pooled over runs and updates (expected 1).

Compatible campaigns share at least one state of the same name and unit (rda-nav with and without SAR, two IMU
grades, telemetry and rda-nav: the 15 navigation states). Anything else is a one-line
:class:`~sarnav.errors.ConfigError` naming the directory.
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from sarnav.analysis.consistency import nees_statistics, nis_statistics, sigma_containment
from sarnav.errors import ConfigError
from sarnav.report import html_parts as H
from sarnav.report.outputs import CampaignDir, read_campaign

__all__ = ["CSV_COLUMNS", "COMPARE_HTML", "COMPARE_CSV", "shared_states", "compare_rows", "compare_campaigns"]

COMPARE_HTML, COMPARE_CSV = "compare.html", "compare.csv"
CSV_COLUMNS = ("campaign", "directory", "scenario", "kind", "runs", "state", "units", "final_3sigma",
               "rms_error_final", "rms_error_time_average", "fraction_inside_3sigma", "nees_time_average", "nees_dof",
               "nees_band_lo", "nees_band_hi", "nis_per_dof", "nis_per_dof_band_lo", "nis_per_dof_band_hi")


def _labels(camps: Sequence[CampaignDir]) -> list[str]:
    """Each campaign's folder name, or the path as given where folder names repeat."""
    names = [c.path.resolve().name or c.given for c in camps]
    return [c.given if names.count(n) > 1 else n for c, n in zip(camps, names)]


def shared_states(camps: Sequence[CampaignDir]) -> tuple[list[str], list[str]]:
    """(names, units) of the states every campaign has with the same unit, in the first campaign's order.

    Raises ConfigError naming the first directory that shares no state with the first campaign, or the last one
    when every pair shares something but all together share nothing.
    """
    first = dict(zip(camps[0].state_names, camps[0].state_units))
    for c in camps[1:]:
        mine = dict(zip(c.state_names, c.state_units))
        if not any(mine.get(s) == u for s, u in first.items()):
            raise ConfigError(c.given, f"no state in common with {camps[0].given} (states of the same name and unit; "
                                       f"its states: {' '.join(mine) or 'none'}; {camps[0].given}: {' '.join(first)})")
    names = [s for s, u in first.items()
             if all(dict(zip(c.state_names, c.state_units)).get(s) == u for c in camps[1:])]
    if not names:
        raise ConfigError(camps[-1].given, "the campaigns together share no state (each pair shares some)")
    return names, [first[s] for s in names]


def _campaign_stats(c: CampaignDir, confidence: float) -> dict:
    ds = c.results
    n_state = ds.sizes["state"]
    nees = nees_statistics(ds["nees"].values, n_state, confidence)
    out = {"nees_time_average": nees["time_average"], "nees_dof": n_state, "nees_band_lo": nees["band"][0],
           "nees_band_hi": nees["band"][1], "nis_per_dof": np.nan, "nis_per_dof_band_lo": np.nan,
           "nis_per_dof_band_hi": np.nan}
    if ds.sizes.get("update", 0) and ds.sizes.get("meas", 0):
        nis = nis_statistics(ds["nis"].values, ds["nis_dof"].values, confidence)
        out.update(nis_per_dof=nis["per_dof"], nis_per_dof_band_lo=nis["per_dof_band"][0],
                   nis_per_dof_band_hi=nis["per_dof_band"][1])
    return out


def compare_rows(camps: Sequence[CampaignDir], states: Sequence[str], confidence: float = 0.95) -> list[dict]:
    """One dict per campaign × state with the keys of :data:`CSV_COLUMNS` (statistics in the module docstring)."""
    from sarnav.report.overlays import rms_over_runs

    rows = []
    for label, c in zip(_labels(camps), camps):
        ds = c.results
        names = c.state_names
        err, sig = ds["error"].values, ds["sigma"].values
        rms = rms_over_runs(err)
        inside = sigma_containment(err, sig, 3.0)
        common = _campaign_stats(c, confidence)
        for s in states:
            j = names.index(s)
            rows.append({"campaign": label, "directory": c.given, "scenario": c.name, "kind": c.kind,
                         "runs": int(ds.sizes["run"]), "state": s, "units": c.state_units[j],
                         "final_3sigma": float(3.0 * sig[:, -1, j].mean()), "rms_error_final": float(rms[-1, j]),
                         "rms_error_time_average": float(np.nanmean(rms[:, j])),
                         "fraction_inside_3sigma": float(inside[j]), **common})
    return rows


def _csv_value(v) -> str:
    if isinstance(v, (float, np.floating)):
        return "" if not np.isfinite(v) else f"{float(v):.6g}"
    return str(v)


def _csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in rows:
        w.writerow([_csv_value(r[k]) for k in CSV_COLUMNS])
    return buf.getvalue()


def _campaigns_table(camps: Sequence[CampaignDir], labels: Sequence[str]) -> str:
    rows = [(lab, c.given, c.name, c.kind, H.fmt(int(c.results.sizes["run"])), H.fmt(c.results.attrs.get("seed")),
             H.fmt(len(c.state_names)), H.fmt(float(c.results["time"].values[-1])))
            for lab, c in zip(labels, camps)]
    return H.table(("campaign", "directory", "scenario", "kind", "runs", "seed", "states", "final time [s]"),
                   rows, "Campaigns", text_columns=4)


def _rows_table(rows: list[dict]) -> str:
    shown = ("campaign", "state", "units", "final_3sigma", "rms_error_final", "rms_error_time_average",
             "fraction_inside_3sigma", "nees_time_average", "nees_dof", "nees_band_lo", "nees_band_hi", "nis_per_dof")
    head = ("campaign", "state", "units", "final 3σ", "RMS error (end)", "RMS error (time avg.)", "inside 3σ [%]",
            "mean NEES", "NEES dof", "NEES band lo", "NEES band hi", "NIS / dof")
    body = [[H.fmt(100 * r[k]) if k == "fraction_inside_3sigma" else H.fmt(r[k]) for k in shown] for r in rows]
    return H.table(head, body, "Per campaign and shared state (compare.csv)", text_columns=3)


def _figures_html(camps, labels, states, units) -> str:
    from sarnav.report.figures import png_bytes, state_blocks
    from sarnav.report.overlays import consistency_figure, state_overlay_figure

    entries = list(zip(labels, (c.results for c in camps)))
    out = H.figure(png_bytes(consistency_figure(entries)),
                   "Consistency: run-mean NEES / dof and NIS / dof of each campaign against its band (dashed)")
    for _stem, title, idx in state_blocks(states):
        fig = state_overlay_figure(entries, [states[i] for i in idx], [units[i] for i in idx], title.replace(
            " error", "") + ": filter 3σ and RMS error")
        out += H.figure(png_bytes(fig), f"{title}: 3σ and RMS error over runs")
    return out


def _read_all(directories: Sequence[str | os.PathLike]) -> list[CampaignDir]:
    if len(directories) < 2:
        raise ConfigError("DIR", f"give at least two campaign directories to compare, got {len(directories)}")
    seen = {}
    for d in directories:
        key = Path(d).resolve()
        if key in seen:
            raise ConfigError(str(d), f"given twice (also as {seen[key]})")
        seen[key] = str(d)
    return [read_campaign(d) for d in directories]


def compare_campaigns(directories: Sequence[str | os.PathLike], out: str | os.PathLike,
                      confidence: float = 0.95) -> tuple[Path, Path]:
    """Write ``out/compare.csv`` and ``out/compare.html`` for the finished campaigns in ``directories``; returns
    their paths. Errors (fewer than two, repeated, unfinished or incompatible directories) are ConfigError."""
    from sarnav.montecarlo.store import atomic_write_text
    from sarnav.report.html_parts import versions

    camps = _read_all(directories)
    states, units = shared_states(camps)
    labels = _labels(camps)
    rows = compare_rows(camps, states, confidence)
    out = Path(out)
    body = (_campaigns_table(camps, labels)
            + f"<p>Shared states ({len(states)}): {H.esc(' '.join(states))}</p>\n" + _rows_table(rows)
            + H.section("Figures", _figures_html(camps, labels, states, units))
            + f'<p class="meta">Made by {H.esc(", ".join(f"{k} {v}" for k, v in versions().items()))}.</p>\n')
    try:
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / COMPARE_CSV, _csv_text(rows))
        atomic_write_text(out / COMPARE_HTML, H.page("sarnav compare: " + ", ".join(labels), body))
    except OSError as err:
        raise ConfigError("--out", f"cannot write into {str(out)!r}: {err.strerror or err}") from None
    return out / COMPARE_HTML, out / COMPARE_CSV

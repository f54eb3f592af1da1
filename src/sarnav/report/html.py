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

import datetime as _dt
import os
from pathlib import Path

from sarnav.errors import ConfigError
from sarnav.report import html_parts as H
from sarnav.report.campaign_page import campaign_body
from sarnav.report.output_pages import image_page, sensitivity_page, study_page
from sarnav.report.outputs import CAMPAIGN, IMAGE, SENSITIVITY, STUDY, output_kind, read_campaign

__all__ = ["REPORT", "write_report", "report_html"]

REPORT = "report.html"


def _footer() -> str:
    made = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    v = ", ".join(f"{k} {val}" for k, val in H.versions().items())
    return f'<p class="meta">Page made {H.esc(made)} by {H.esc(v)}.</p>\n'


def report_html(directory: str | os.PathLike) -> str:
    """The report page of ``directory`` (a campaign, study, bpa-sensitivity or image output) as HTML text."""
    given = str(directory)
    kind = output_kind(directory)
    p = Path(directory)
    if kind == CAMPAIGN:
        c = read_campaign(directory)
        title, body = f"sarnav campaign: {c.name}", campaign_body(c)
    elif kind == STUDY:
        title, body = study_page(p, given)
    elif kind == SENSITIVITY:
        title, body = sensitivity_page(p, given)
    else:
        assert kind == IMAGE
        title, body = image_page(p, given)
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

"""Pieces of a self-contained HTML page: escaped text, number formatting, tables, figures embedded as
``data:image/png;base64`` URIs, preformatted text and the page itself with an inline style sheet.

Nothing here refers to anything outside the page (no external style sheet, font, script or image), so a page can be
mailed as one file and opened offline.
"""

from __future__ import annotations

import base64
import html
import math
import platform
from typing import Iterable, Sequence

import numpy as np

import sarnav

__all__ = ["esc", "fmt", "table", "kv_table", "figure", "pre", "details", "section", "page", "versions", "flatten",
           "pct"]

_CSS = """
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; margin: 1.5em auto; max-width: 1100px;
       padding: 0 1em; color: #1b1b1b; background: #ffffff; line-height: 1.4; }
h1 { font-size: 1.6em; border-bottom: 2px solid #2b5797; padding-bottom: .2em; }
h2 { font-size: 1.3em; margin-top: 1.6em; color: #2b5797; }
h3 { font-size: 1.1em; margin-top: 1.2em; }
table { border-collapse: collapse; margin: .6em 0 1em 0; font-size: .9em; }
th, td { border: 1px solid #c8c8c8; padding: .25em .6em; text-align: right; }
td:not(.t) { white-space: nowrap; }
th { background: #eef2f8; }
td.t, th.t { text-align: left; }
caption { text-align: left; font-weight: 600; padding-bottom: .3em; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #dddddd; }
figcaption { font-size: .85em; color: #555555; }
pre { background: #f6f6f6; border: 1px solid #dddddd; padding: .8em; overflow-x: auto; font-size: .85em; }
.note { background: #fff6dd; border-left: 4px solid #d9a400; padding: .5em .8em; }
.bad { background: #fde8e8; border-left: 4px solid #b22222; padding: .5em .8em; }
.meta { color: #555555; font-size: .9em; }
"""


def esc(text) -> str:
    """``text`` as HTML-escaped string."""
    return html.escape(str(text), quote=True)


def fmt(value, digits: int = 4) -> str:
    """A table cell: numbers to ``digits`` significant digits, None / NaN as ``n/a``, lists joined."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "n/a" if not math.isfinite(value) else f"{value:.{digits}g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(fmt(v, digits) for v in value) + "]"
    return str(value)


def _cell(tag: str, value, left: bool) -> str:
    cls = ' class="t"' if left else ""
    return f"<{tag}{cls}>{esc(value)}</{tag}>"


def table(header: Sequence[str] | None, rows: Iterable[Sequence], caption: str = "", text_columns: int = 1) -> str:
    """An HTML table (no header row when ``header`` is None); the first ``text_columns`` columns left-aligned;
    cells already formatted (see :func:`fmt`)."""
    head = ""
    if header is not None:
        head = "<thead><tr>" + "".join(_cell("th", h, j < text_columns) for j, h in enumerate(header)) + "</tr></thead>"
    body = "".join("<tr>" + "".join(_cell("td", v, j < text_columns) for j, v in enumerate(r)) + "</tr>\n"
                   for r in rows)
    cap = f"<caption>{esc(caption)}</caption>" if caption else ""
    return f"<table>{cap}{head}<tbody>\n{body}</tbody></table>\n"


def kv_table(pairs: dict, caption: str = "") -> str:
    """Two-column table of key -> value (values through :func:`fmt`)."""
    return table(None, [(k, fmt(v)) for k, v in pairs.items()], caption, text_columns=2)


def figure(png: bytes, caption: str) -> str:
    """``png`` embedded in the page as a data URI, with a caption."""
    b64 = base64.b64encode(png).decode("ascii")
    return (f'<figure><img src="data:image/png;base64,{b64}" alt="{esc(caption)}">'
            f"<figcaption>{esc(caption)}</figcaption></figure>\n")


def pre(text: str) -> str:
    return f"<pre>{esc(text)}</pre>\n"


def details(summary: str, body: str, open_: bool = False) -> str:
    """A collapsible block (HTML ``<details>``, no script)."""
    return f"<details{' open' if open_ else ''}><summary>{esc(summary)}</summary>\n{body}</details>\n"


def section(title: str, body: str, level: int = 2) -> str:
    return f"<h{level}>{esc(title)}</h{level}>\n{body}"


def page(title: str, body: str) -> str:
    """The whole document: doctype, UTF-8, viewport, the inline style sheet and ``body``."""
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{esc(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n<h1>{esc(title)}</h1>\n"
            f"{body}</body>\n</html>\n")


def versions() -> dict:
    """Versions of the software making the page: sarnav, numpy, xarray, matplotlib, Python."""
    import matplotlib
    import xarray

    return {"sarnav": sarnav.__version__, "numpy": np.__version__, "xarray": xarray.__version__,
            "matplotlib": matplotlib.__version__, "python": platform.python_version()}


def flatten(obj, prefix: str = "") -> dict:
    """Nested dicts as one dict of dotted keys (lists of scalars kept as values)."""
    out = {}
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    else:
        out[prefix] = obj
    return out


def pct(v) -> str:
    """A fraction as a percentage cell (n/a where undefined)."""
    return fmt(100.0 * v) if isinstance(v, (int, float)) and not isinstance(v, bool) else fmt(v)

"""Helpers for the headless-browser checks of the HTML pages (tests/report/test_browser.py): Debian's ``chromium``
binary only (no playwright, no driver), run as::

    chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking \\
             --disable-component-update --disable-sync --user-data-dir=<fresh dir> --enable-logging=stderr --v=0 \\
             --window-size=1280,4000 --screenshot=<png> file://<page>

* console: every line of Chromium's log that carries a console message (``...:CONSOLE:...]``); a page without
  scripts must produce none, so any such line is an error;
* load probe: a copy of the page with a small script that, on ``load``, counts the ``<img>`` elements that did
  not decode (``complete && naturalWidth > 0`` false), logs each as a console error and writes
  ``data-probe="images=N broken=K"`` on ``<body>``; read back with ``--dump-dom``;
* screenshot statistics: distinct colours, share of non-white pixels and counts of pixels of the figures' own
  colours (the red ±3σ curves of campaign figures, the orange of the second campaign in overlays), which the page's
  style sheet never uses.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-logging=stderr", "--v=0"]
TIMEOUT_S = 120
SKIP_REASON = ("no chromium binary on PATH (Debian: apt-get install -y chromium; .ci/run installs it): "
               "the headless-browser checks of report.html / compare.html are skipped")
_PROBE = ("<script>window.addEventListener('load',()=>{const im=[...document.images];"
          "const bad=im.filter(i=>!(i.complete&&i.naturalWidth>0));"
          "bad.forEach(i=>console.error('broken image: '+i.alt));"
          "document.body.setAttribute('data-probe','images='+im.length+' broken='+bad.length);});</script>")


def find_chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _run(binary: str, args: list[str], user_dir: Path) -> subprocess.CompletedProcess:
    user_dir.mkdir(parents=True, exist_ok=False)  # a fresh profile for every start
    return subprocess.run([binary, *FLAGS, f"--user-data-dir={user_dir}", *args], capture_output=True, text=True,
                          timeout=TIMEOUT_S, check=False)


def console_lines(stderr: str) -> list[str]:
    """Console messages in Chromium's log (``[pid:tid:time:INFO:CONSOLE:line] "message", source: ...``)."""
    return [line for line in stderr.splitlines() if re.search(r":CONSOLE[:(\]]", line)]


@dataclass
class Shot:
    png: Path
    console: list[str]


def screenshot(binary: str, page: Path, tmp: Path, size=(1280, 4000)) -> Shot:
    """Load ``page`` and take a screenshot of its top ``size`` pixels."""
    png = tmp / f"{page.stem}-shot.png"
    proc = _run(binary, [f"--window-size={size[0]},{size[1]}", f"--screenshot={png}", page.resolve().as_uri()],
                tmp / f"profile-{page.stem}-shot")
    assert png.is_file(), f"chromium wrote no screenshot (rc {proc.returncode}): {proc.stderr[-2000:]}"
    return Shot(png, console_lines(proc.stderr))


def load_probe(binary: str, page: Path, tmp: Path) -> tuple[str, list[str]]:
    """(``data-probe`` value, console lines) of a copy of ``page`` with the image-load probe added."""
    text = page.read_text(encoding="utf-8")
    assert "</body>" in text
    probe_page = tmp / f"{page.stem}-probe.html"
    probe_page.write_text(text.replace("</body>", _PROBE + "</body>"), encoding="utf-8")
    proc = _run(binary, ["--dump-dom", probe_page.resolve().as_uri()], tmp / f"profile-{page.stem}-probe")
    m = re.search(r'data-probe="([^"]*)"', proc.stdout)
    return (m.group(1) if m else ""), console_lines(proc.stderr)


@dataclass
class PixelStats:
    distinct_colours: int
    non_white_fraction: float
    red_pixels: int  #: R > 0.8, G < 0.25, B < 0.25: matplotlib "r" (the ±3σ curves)
    orange_pixels: int  #: matplotlib C1 (1.0, 0.5, 0.05) within 0.1


def pixel_stats(png: Path) -> PixelStats:
    from matplotlib.image import imread

    img = imread(png)[..., :3].astype(np.float64)
    rgb = img.reshape(-1, 3)
    q = np.round(rgb * 255).astype(np.int64)
    distinct = np.unique(q[:, 0] * 65536 + q[:, 1] * 256 + q[:, 2]).size
    non_white = float(np.mean(rgb.min(axis=1) < 0.95))
    r, g, b = rgb.T
    red = int(np.sum((r > 0.8) & (g < 0.25) & (b < 0.25)))
    orange = int(np.sum(np.all(np.abs(rgb - [1.0, 0.498, 0.055]) < 0.1, axis=1)))
    return PixelStats(distinct, non_white, red, orange)

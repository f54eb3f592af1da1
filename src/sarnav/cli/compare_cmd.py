"""``sarnav compare DIR1 DIR2 ... [--out DIR]``: campaigns side by side over their shared states
(``compare.html``, ``compare.csv``). Parses and prints only: the work is ``sarnav.report.compare``."""

from __future__ import annotations

from pathlib import Path

NAME = "compare"
DEFAULT_OUT = Path("sarnav-out") / "compare"
DESCRIPTION = ("Compare finished campaigns over the states they share: write compare.csv (final 3-sigma, RMS error, "
               "fraction inside 3-sigma, NEES and NIS per campaign and state) and compare.html (the table and "
               f"overlay figures) to --out (default ./{DEFAULT_OUT}).")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="compare campaigns (table and overlay figures)", description=DESCRIPTION)
    p.add_argument("directories", metavar="DIR", nargs="+", help="two or more campaign folders written by `sarnav run`")
    p.add_argument("--out", default=str(DEFAULT_OUT), help=f"output directory (default: ./{DEFAULT_OUT})")
    p.set_defaults(handler=run)


def run(args) -> int:
    from sarnav.report.compare import compare_campaigns

    html, table = compare_campaigns(args.directories, args.out)
    print(html)
    print(table)
    return 0

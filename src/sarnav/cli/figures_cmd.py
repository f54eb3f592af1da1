"""``sarnav figures DIR``: redraw a campaign's figures (or a study's) from its results.nc into ``DIR/figures``.
Parses and prints only: the work is ``sarnav.report.redraw.redraw_figures``; the kind (for its own figures) is
looked up here, in the registry."""

from __future__ import annotations

import sys

NAME = "figures"
DESCRIPTION = ("Redraw the figures of a finished campaign from DIR/results.nc into DIR/figures (the old PNG files "
               "there are removed first), including the scenario kind's own figures; for a study, every case's "
               "figures and the comparison figures.")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="redraw a campaign's figures from its results", description=DESCRIPTION)
    p.add_argument("directory", metavar="DIR", help="a campaign or study folder written by `sarnav run`")
    p.set_defaults(handler=run)


def run(args) -> int:
    from sarnav.montecarlo.outdir import record_files
    from sarnav.report.redraw import redraw_figures
    from sarnav.scenarios.registry import get_kind

    done = redraw_figures(args.directory, resolve_kind=get_kind)
    for line in done.notices:
        print(f"sarnav: notice: {line}", file=sys.stderr)
    record_files(args.directory, done.paths)  # --overwrite may remove them later
    for path in done.paths:
        print(path)
    return 0

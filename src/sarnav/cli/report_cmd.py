"""``sarnav report DIR``: one self-contained HTML page, ``DIR/report.html``, of a campaign, study, bpa-sensitivity or
image output. Parses and prints only: the work is ``sarnav.report.html.write_report``."""

from __future__ import annotations

NAME = "report"
DESCRIPTION = ("Write DIR/report.html: one self-contained page (figures embedded) with the summary tables, the "
               "consistency statistics, the figures, the scenario TOML, versions and run time of what `sarnav run` "
               "wrote into DIR (a campaign, a study, bpa-sensitivity or an image).")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="one HTML page of a campaign's results, to read or send", description=DESCRIPTION)
    p.add_argument("directory", metavar="DIR", help="a folder written by `sarnav run` (its --out)")
    p.set_defaults(handler=run)


def run(args) -> int:
    from sarnav.montecarlo.outdir import record_files
    from sarnav.report.html import write_report

    path = write_report(args.directory)
    record_files(args.directory, [path])  # --overwrite may remove it later
    print(path)
    return 0

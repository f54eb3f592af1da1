"""``sarnav show SCENARIO``: the full scenario as TOML (a starting point for your own file)."""

from __future__ import annotations

import sys

DESCRIPTION = 'Print the full scenario as TOML (a starting point for your own file).'
NAME = "show"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="print a scenario as TOML", description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", help="registered name or FILE.toml")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value (dotted key, TOML value), repeatable")
    p.set_defaults(handler=run)


def run(args) -> int:
    from sarnav.scenarios.config import load_scenario
    from sarnav.tomlio import dump_toml

    notices: list[str] = []
    cfg = load_scenario(args.scenario, args.overrides, notices=notices)
    for line in notices:
        print(f"sarnav: notice: {line}", file=sys.stderr)
    print(dump_toml(cfg), end="")
    return 0

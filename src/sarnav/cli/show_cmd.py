"""``sarnav show SCENARIO``: the full scenario as TOML (a starting point for your own file)."""

from __future__ import annotations

DESCRIPTION = 'Print the full scenario as TOML (a starting point for your own file).'
NAME = "show"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="print a scenario as TOML", description=DESCRIPTION)
    p.add_argument("scenario", metavar="SCENARIO", help="registered name or FILE.toml")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a value (dotted key, TOML value), repeatable")
    p.set_defaults(handler=run)


def run(args) -> int:
    from sarnav.scenarios.config import dump_toml, load_scenario
    from sarnav.scenarios.imaging import IMAGE_SCENARIOS, load_image_scenario

    if args.scenario in IMAGE_SCENARIOS:  # a single-image scenario (``sarnav image``)
        cfg = load_image_scenario(args.scenario, args.overrides)
    else:
        cfg = load_scenario(args.scenario, args.overrides)
    print(dump_toml(cfg), end="")
    return 0

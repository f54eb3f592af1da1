"""``sarnav scenarios``: the registered scenario names with one-line descriptions."""

from __future__ import annotations

from sarnav.scenarios.registry import list_scenarios

DESCRIPTION = 'List the registered scenarios with one-line descriptions.'
NAME = "scenarios"


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(NAME, help="list the named scenarios", description=DESCRIPTION)
    p.set_defaults(handler=run)


def run(args) -> int:
    rows = list_scenarios()
    width = max(len(name) for name, _ in rows)
    for name, desc in rows:
        print(f"{name:<{width}}  {desc}")
    return 0

"""The ``sarnav`` command: one module per subcommand, each with ``add_parser(subparsers)`` and
``run(args) -> int``; adding a subcommand is one line in :data:`COMMANDS`.

Every :class:`sarnav.errors.SarnavError` becomes one line on stderr,
``sarnav: error: <field>: <message>``, and exit status 2 (no traceback).
"""

from __future__ import annotations

import argparse
import sys
from typing import Sequence

import sarnav
from sarnav.cli import compare_cmd, figures_cmd, image_cmd, report_cmd, run_cmd, scenarios_cmd, show_cmd
from sarnav.errors import SarnavError

#: subcommand modules, in the order ``sarnav --help`` lists them
COMMANDS = [scenarios_cmd, show_cmd, run_cmd, image_cmd, report_cmd, compare_cmd, figures_cmd]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sarnav",
        description="GPS-denied navigation aided by SAR: scenarios, Monte Carlo campaigns, results and figures.",
    )
    parser.add_argument("--version", action="version", version=f"sarnav {sarnav.__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in COMMANDS:
        mod.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point (``sarnav = sarnav.cli.main:main``); returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "handler", None) is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.handler(args) or 0)
    except SarnavError as err:
        print(f"sarnav: error: {err}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


if __name__ == "__main__":
    sys.exit(main())

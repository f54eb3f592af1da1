"""The ``sarnav`` command: one module per subcommand, each with ``add_parser(subparsers)`` and
``run(args) -> int``; adding a subcommand is one line in :data:`COMMAND_MODULES`.

Every :class:`sarnav.errors.SarnavError` (argument errors included) becomes one line on stderr,
``sarnav: error: <field>: <message>``, and exit status 2 (no traceback); a fault of the machine
(:class:`sarnav.errors.RunFault`: a dead worker, a full disk) is the same one line with exit status 3. SIGINT and
SIGTERM, at any moment after the interpreter has run the first line of ``sarnav/__init__.py``, end the command with
one ``sarnav: interrupted by signal N ...`` line and exit status 128 + N (130, 143); the console script then leaves at once (``os._exit``), so no worker
pool or thread can keep it alive. Signals that arrive while the command is importing are deferred
(``sarnav.PENDING_SIGNALS``); only one arriving in the interpreter's own start-up, before it runs any sarnav code
(10-30 ms), or in the first statements of ``sarnav/__init__.py`` (microseconds), gets the operating system's default.
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
import threading
from typing import Sequence

#: subcommand modules (``sarnav.cli.<name>``), in the order ``sarnav --help`` lists them
COMMAND_MODULES = ("scenarios_cmd", "show_cmd", "run_cmd", "export_cmd", "navigate_cmd", "image_cmd", "report_cmd",
                   "compare_cmd", "figures_cmd")
#: set when the last :func:`main` ended by a signal (the console script then exits without waiting for threads)
_INTERRUPTED = False


def __getattr__(name):
    if name == "COMMANDS":  # the subcommand modules, imported on first use
        return [importlib.import_module(f"sarnav.cli.{m}") for m in COMMAND_MODULES]
    raise AttributeError(name)


class _Parser(argparse.ArgumentParser):
    """argparse with its errors as one documented line (``sarnav: error: <argument>: <message>``)."""

    def error(self, message):
        from sarnav.errors import ConfigError

        field = "arguments"
        if message.startswith("argument ") and ": " in message:
            field, _, message = message[len("argument "):].partition(": ")
            field = field.split("/")[-1]
        raise ConfigError(field, message)


class _Version(argparse.Action):
    """``--version``: the version derived from git and the commit (sarnav.version), computed only when asked."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from sarnav.version import commit, version

        print(f"sarnav {version()} (commit {commit()})")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="sarnav",
        description="GPS-denied navigation aided by SAR: scenarios, Monte Carlo campaigns, results and figures.",
    )
    parser.add_argument("--version", action=_Version, help="print the version (derived from git) and commit, and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for mod in __getattr__("COMMANDS"):
        mod.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sarnav`` as a function; returns the exit status."""
    global _INTERRUPTED
    _INTERRUPTED = False
    from sarnav.errors import raise_interrupted

    saved = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            saved[sig] = signal.signal(sig, raise_interrupted)
    try:
        from sarnav.cli import PENDING_SIGNALS

        if PENDING_SIGNALS:  # arrived while the command was starting
            raise_interrupted(PENDING_SIGNALS.pop(0), None)
        return _main(argv)
    except KeyboardInterrupt as exc:  # Interrupted, or a SIGINT that beat the handler
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"sarnav: interrupted by signal {int(signum)}", file=sys.stderr)
        _INTERRUPTED = True
        return 128 + int(signum)
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def _main(argv) -> int:
    global _INTERRUPTED
    from sarnav.errors import RunFault, SarnavError, deferred_signals

    try:
        with deferred_signals():  # the subcommands import numpy & co
            parser = build_parser()
        args = parser.parse_args(argv)
        if getattr(args, "handler", None) is None:
            parser.print_help(sys.stderr)
            return 2
        code = int(args.handler(args) or 0)
        _INTERRUPTED = code > 128
        return code
    except SarnavError as err:
        print(f"sarnav: error: {err}", file=sys.stderr)
        return 2
    except RunFault as err:  # a dead worker, a full disk...: what was stored is kept, the message says how to finish
        print(f"sarnav: error: {err}", file=sys.stderr)
        return 3
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1


def entry() -> None:
    """The console script: :func:`main`, then exit; after a signal, exit at once (``os._exit``)."""
    # leaving with os._exit after an interruption skips the pool's clean-up; the resource tracker (a helper process
    # started later, which takes its warning options from here) would then report the pool's semaphores as leaked
    sys.warnoptions.append("ignore::UserWarning:multiprocessing.resource_tracker")
    code = main()
    if _INTERRUPTED:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:  # noqa: BLE001 - leaving anyway
                pass
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    entry()

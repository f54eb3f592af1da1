"""sarnav: GPS-denied navigation aided by synthetic aperture radar.

See docs/architecture.md for the package layout and docs/conventions.md for frames,
units, attitude and error-state conventions.

When this interpreter runs the ``sarnav`` command (the console script, ``python -m sarnav`` or
``python -m sarnav.cli.main``; never a worker process, a test runner or a program importing sarnav), SIGINT and SIGTERM are deferred from the first lines
of this package on: a signal that arrives while the command is still importing is recorded in
:data:`PENDING_SIGNALS` and answered by :func:`sarnav.cli.main.main` with the one "interrupted" line and exit
status 128 + N. The handlers are installed through the built-in ``_signal`` module (the ``signal`` module alone
imports ``enum`` and costs ~10 ms), so the only moment left to the operating system's defaults is the interpreter's
own start-up and the first statements of this file, up to the handlers' installation (the deferral is installed in
every process first, and given back at once where the interpreter does not run the command: the argv test that
decides took long enough for a signal to land in it, 2026-12-06).

From Python (docs/api.md): ``sarnav.run(scenario, runs=..., seed=..., **overrides)`` runs a campaign and returns its
results Dataset; ``sarnav.figures`` draws them; ``sarnav.__version__`` is the version derived from git
(:mod:`sarnav.version`). These are imported on first use: ``import sarnav`` stays light.
"""

import _signal as _sg  # the deferral first (the interpreter has this module loaded already): see the docstring


def _defer(signum, frame):
    PENDING_SIGNALS.append(signum)


#: SIGINT / SIGTERM received before :func:`sarnav.cli.main.main` took over (kept only when running the command)
PENDING_SIGNALS: list[int] = []
try:
    _BEFORE = (_sg.signal(_sg.SIGINT, _defer), _sg.signal(_sg.SIGTERM, _defer))
except ValueError:  # imported outside the main thread: signals are the main thread's business
    _BEFORE = None

import sys as _sys  # noqa: E402


def __getattr__(name):  # PEP 562: the version (asks git in a checkout) and the API on first use
    if name == "__version__":
        from sarnav.version import version

        return version()
    if name in ("run", "run_result"):
        from sarnav import api

        return getattr(api, name)
    raise AttributeError(f"module 'sarnav' has no attribute {name!r}")


_COMMAND_MODULES = ("sarnav", "sarnav.cli.main", "sarnav.cli")


def _runs_the_command(argv) -> bool:
    """Whether the interpreter's command line (``sys.orig_argv``) runs the ``sarnav`` command."""
    args = list(argv[1:])
    i = 0
    while i < len(args):
        a = args[i]
        if a == "-m":
            return i + 1 < len(args) and args[i + 1] in _COMMAND_MODULES
        if a == "-c" or a == "-":
            return False
        if a in ("-X", "-W", "--check-hash-based-pycs"):  # options with a separate argument
            i += 2
            continue
        if a.startswith("-"):
            i += 1
            continue
        return a.replace("\\", "/").rsplit("/", 1)[-1].removesuffix(".exe") == "sarnav"
    return False


if _BEFORE is not None and not _runs_the_command(getattr(_sys, "orig_argv", ())):
    # a worker, a test runner or a program importing sarnav: its own handlers back, and a signal that came meanwhile
    # delivered as it would have been
    for _sig, _old in zip((_sg.SIGINT, _sg.SIGTERM), _BEFORE):
        _sg.signal(_sig, _sg.SIG_DFL if _old is None else _old)
    while PENDING_SIGNALS:
        _sg.raise_signal(PENDING_SIGNALS.pop(0))

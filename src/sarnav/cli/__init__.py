"""sarnav.cli: the ``sarnav`` command (``main.py``; one module per subcommand, listed in
``main.COMMAND_MODULES``).

When this package is imported to *run* the command (the ``sarnav`` console script, or ``python -m sarnav.cli.main``),
SIGINT and SIGTERM are deferred from this moment on: a signal that arrives while the command is still importing
is recorded here and answered by :func:`sarnav.cli.main.main` with the one "interrupted" line, never a traceback
from inside an import.
"""

import os
import signal
import sys

#: signals received before ``main()`` took over (set only when running the command)
PENDING_SIGNALS: list[int] = []


def _defer(signum, frame):
    PENDING_SIGNALS.append(signum)


if sys.argv and (sys.argv[0] == "-m" or os.path.basename(sys.argv[0]) == "sarnav"):
    for _sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(_sig, _defer)

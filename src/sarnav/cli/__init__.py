"""sarnav.cli: the ``sarnav`` command (``main.py``; one module per subcommand, listed in
``main.COMMAND_MODULES``).

SIGINT and SIGTERM that arrive while the command starts are deferred by the first line of the package
(``sarnav/__init__.py``: :data:`sarnav.PENDING_SIGNALS`, the same list as :data:`PENDING_SIGNALS` here) and
answered by :func:`sarnav.cli.main.main` with the one "interrupted" line, never a traceback from inside an import.
"""

from sarnav import PENDING_SIGNALS  # noqa: F401  (re-exported for sarnav.cli.main)

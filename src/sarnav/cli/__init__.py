"""sarnav.cli: the ``sarnav`` command (``main.py``; one module per subcommand, listed in
``main.COMMANDS``)."""

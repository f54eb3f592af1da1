"""``python -m sarnav``: the ``sarnav`` command (:func:`sarnav.cli.main.entry`), e.g. ``python -m sarnav --version``."""

from sarnav.cli.main import entry

if __name__ == "__main__":
    entry()

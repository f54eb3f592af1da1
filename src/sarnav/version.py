"""Which code this is: the version derived from git and the commit, stamped into every results file.

The version follows setuptools-scm (``[tool.setuptools_scm]`` in pyproject.toml): ``X.Y.Z`` on a ``vX.Y.Z`` tag,
``X.Y.(Z+1).devN+gHASH`` N commits after it, ``.dYYYYMMDD`` appended when the working tree is modified; without a
tag it counts from :data:`FALLBACK` (``0.2.1.devN+gHASH``), and a tree without git metadata is :data:`FALLBACK`
itself. Where it comes from, first found wins:

1. running from a git checkout of sarnav (an editable install, ``PYTHONPATH=src``) with setuptools-scm importable:
   asked from git now, so a checkout never reports the version it was installed at;
2. ``sarnav/_version.py``, written by setuptools-scm when the package was built or installed (a wheel);
3. the installed distribution's metadata;
4. :data:`FALLBACK`.

:func:`commit` is the full commit hash (``-dirty`` appended when tracked files are modified) from git in a checkout,
else the abbreviated one the build recorded, else ``"unknown"``. Both are computed once per process.
"""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path

__all__ = ["version", "commit", "provenance", "FALLBACK"]

#: pyproject.toml's ``fallback_version``: the version of a tree without git metadata, the base of one without tags
FALLBACK = "0.2.1.dev0"

_ROOT = Path(__file__).resolve().parents[2]  # the checkout's root when this file is src/sarnav/version.py


def _checkout() -> Path | None:
    """The root of the git checkout this package is running from (None when installed from a wheel)."""
    if (_ROOT / "pyproject.toml").is_file() and (_ROOT / ".git").exists() and (_ROOT / "src" / "sarnav").is_dir():
        return _ROOT
    return None


def _git(root: Path, *args: str) -> str | None:
    try:
        res = subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return res.stdout.strip() if res.returncode == 0 else None


@functools.cache
def version() -> str:
    """The version of the running code (module docstring: where it comes from)."""
    root = _checkout()
    if root is not None:
        try:
            from setuptools_scm import get_version
        except ImportError:
            pass
        else:
            try:
                return get_version(root=str(root), fallback_version=FALLBACK)
            except Exception:  # noqa: BLE001 - no git, a broken repository: the recorded version below
                pass
    try:
        from sarnav._version import version as built
        return str(built)
    except ImportError:
        pass
    from importlib import metadata

    try:
        return metadata.version("sarnav")
    except metadata.PackageNotFoundError:
        return FALLBACK


@functools.cache
def commit() -> str:
    """The commit of the running code: 40 hex digits (``-dirty`` when tracked files are modified), the build's
    abbreviated ``gHASH`` for an installed wheel, or ``"unknown"``."""
    root = _checkout()
    if root is not None:
        head = _git(root, "rev-parse", "HEAD")
        if head:
            dirty = _git(root, "status", "--porcelain", "--untracked-files=no")
            return head + ("-dirty" if dirty else "")
    try:
        from sarnav._version import dirty, node
    except ImportError:
        return "unknown"
    return f"{node}{'-dirty' if dirty else ''}" if node else "unknown"


def provenance() -> dict[str, str]:
    """``{"sarnav_version": ..., "sarnav_commit": ...}``: the attributes every results file carries."""
    return {"sarnav_version": version(), "sarnav_commit": commit()}

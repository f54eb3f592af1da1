"""Exceptions that the CLI turns into one-line messages (no traceback).

Every error raised for bad user input names the field and the valid range, e.g.
``ConfigError("imu.tau_accel", "must be > 0 s, got -1.0")`` prints as
``imu.tau_accel: must be > 0 s, got -1.0``.
"""

from __future__ import annotations


class _Named:
    """``field: message`` errors: both kept as attributes, the text ``f"{field}: {message}"``."""

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"{field}: {message}")

    def __reduce__(self):  # picklable across worker processes (two-argument __init__)
        return (type(self), (self.field, self.message))


class SarnavError(Exception):
    """Base class for errors caused by user input; the CLI prints ``str(err)`` and exits 2."""


class ConfigError(_Named, SarnavError, ValueError):
    """A scenario / parameter value is missing, unknown, of the wrong type or out of range."""


class InputDataError(_Named, SarnavError, ValueError):
    """An input array is malformed (wrong shape, NaN, missing samples)."""


class RunFault(_Named, Exception):
    """A run stopped by a fault of the machine, not of its input: a dead worker process, a full disk, an unwritable
    file, a lost dask scheduler. What was stored is kept and consistent; the message names the cause and the repair
    (a campaign: the same command with ``--resume``). The CLI prints ``sarnav: error: <where>: <message>`` and exits
    with status 3 (docs/cli.md)."""


def disk_message(err: OSError) -> str:
    """An OSError in words for a one-line fault (``No space left on device (ENOSPC)``)."""
    import errno as _errno

    name = _errno.errorcode.get(err.errno or 0, "")
    return f"{err.strerror or err}{f' ({name})' if name else ''}"


def _is_bool(value) -> bool:
    """A TOML ``true`` or a string: float() would take them (``float(True) == 1.0``, ``float("3") == 3.0``), a scenario
    value must be a number."""
    import numpy as np

    return isinstance(value, (bool, np.bool_, str, bytes))


def require_positive(field: str, value, unit: str = "") -> float:
    """Return float(value) or raise ConfigError naming the field when it is not finite and > 0."""
    import math

    try:
        if _is_bool(value):  # float(True) == 1.0: a TOML `true` must not pass as a number
            raise TypeError
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(field, f"must be a number > 0{(' ' + unit) if unit else ''}, got {value!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise ConfigError(field, f"must be finite and > 0{(' ' + unit) if unit else ''}, got {v!r}")
    return v


def require_finite(field: str, value, lo=None, hi=None, unit: str = "") -> float:
    """Return float(value) or raise ConfigError when it is NaN/inf or outside [lo, hi]."""
    import math

    try:
        if _is_bool(value):
            raise TypeError
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(field, f"must be a number, got {value!r}") from None
    rng = f"[{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]{(' ' + unit) if unit else ''}"
    if not math.isfinite(v):
        raise ConfigError(field, f"must be finite in {rng}, got {v!r}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ConfigError(field, f"must be in {rng}, got {v!r}")
    return v


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived; what was stored is kept (a campaign: ``--resume`` finishes it).

    The CLI prints one line and exits with 128 + the signal number (130 for SIGINT, 143 for SIGTERM)."""

    def __init__(self, signum: int):
        super().__init__(f"interrupted by signal {signum}")
        self.signum = signum

    def __reduce__(self):
        return (type(self), (self.signum,))


class deferred_signals:
    """``with deferred_signals():`` SIGINT/SIGTERM arriving inside the block are recorded, not raised, and raised as
    :class:`Interrupted` when the block ends. For imports of C extensions (numpy, xarray, dask...): an exception
    raised by a signal handler inside them can surface as an unrelated ImportError. A no-op outside the main thread
    or when the current handlers are Python's defaults (a library caller's process is left alone)."""

    def __enter__(self):
        import signal
        import threading

        self.pending, self.saved = [], {}
        if threading.current_thread() is not threading.main_thread():
            return self
        for sig in (signal.SIGINT, signal.SIGTERM):
            current = signal.getsignal(sig)
            if getattr(current, "raises_interrupted", False):
                self.saved[sig] = current
                signal.signal(sig, lambda signum, frame: self.pending.append(signum))
        return self

    def __exit__(self, exc_type, exc, tb):
        import signal

        for sig, handler in self.saved.items():
            signal.signal(sig, handler)
        if self.pending and exc_type is None:
            raise Interrupted(self.pending[0])
        return False


def raise_interrupted(signum, frame):
    """Signal handler of the ``sarnav`` command: SIGINT/SIGTERM become :class:`Interrupted`."""
    raise Interrupted(signum)


raise_interrupted.raises_interrupted = True


class MissingExtraError(SarnavError, ImportError):
    """A feature needs an optional dependency that is not installed; names the extra of sarnav that installs it
    (``pip install 'sarnav[dask]'``; the extras are in pyproject.toml)."""

    def __init__(self, field: str, extra: str, package: str):
        self.field, self.extra, self.package = field, extra, package
        super().__init__(f"{field}: needs the optional package {package}, which is not installed: "
                         f"pip install 'sarnav[{extra}]'")

    def __reduce__(self):
        return (type(self), (self.field, self.extra, self.package))


def require_extra(field: str, extra: str, module: str, package: str | None = None) -> None:
    """Raise :class:`MissingExtraError` when the optional ``module`` cannot be found (looked up, not imported).

    ``field`` names what needs it (``--executor``, ``measurement.mode``, a function), ``extra`` the extra of sarnav
    that installs it, ``package`` its distribution name when it differs from the module's (``scikit-image``)."""
    import importlib.util

    try:
        found = importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a parent package missing, or a module set to None in sys.modules
        found = False
    if not found:
        raise MissingExtraError(field, extra, package or module)

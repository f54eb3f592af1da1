"""The CSV logs of a flight recording (docs/recording.md): named columns, one header line, one row per sample.

Every value is read with Python's ``float`` (correctly rounded, so a value written with ``repr`` reads back bit for
bit) and checked where it is read: a missing, unknown or repeated column, a row of the wrong length, a value that is
not a number or not finite, a time that does not follow the previous row's, each give one line naming the file, the
line of the file (the header is line 1) and the column: ``imu.csv:14:accel_x_mps2: must be finite, got nan``.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from sarnav.errors import InputDataError

__all__ = ["read_columns", "write_columns", "choose_columns"]

#: a recording's log is at most this large [bytes] (a day at 1 kHz of a 7-column IMU is about 4 GB; refuse beyond)
MAX_LOG_BYTES = 8 * 2**30


def _open_rows(path: Path, name: str):
    if not path.is_file():
        raise InputDataError(name, f"missing file (expected at {str(path)!r})")
    if path.stat().st_size > MAX_LOG_BYTES:
        raise InputDataError(name, f"is {path.stat().st_size} bytes; a log is at most {MAX_LOG_BYTES} bytes")
    try:
        fh = open(path, newline="", encoding="utf-8")
    except OSError as err:
        raise InputDataError(name, f"cannot read: {err.strerror}") from None
    return fh


def _header(row: list[str] | None, name: str, known: Iterable[str]) -> list[str]:
    if row is None:
        raise InputDataError(name, "is empty (a header line of column names is required)")
    cols = [c.strip() for c in row]
    known = list(known)
    seen = set()
    for c in cols:
        if c not in known:
            raise InputDataError(f"{name}:1:{c}", f"unknown column (known: {', '.join(known)})")
        if c in seen:
            raise InputDataError(f"{name}:1:{c}", "appears twice in the header")
        seen.add(c)
    return cols


def read_columns(path, name: str, required: Sequence[str], optional: Sequence[str] = (),
                 time_column: str | None = None) -> dict[str, np.ndarray]:
    """The columns of the CSV file ``path`` (``name``: how errors name it, e.g. ``imu.csv``) as float64 arrays.

    ``required`` columns must all be present, ``optional`` ones may be; any other column is an error (a misspelt
    unit suffix must not be read as absent). ``time_column`` (one of them): strictly increasing from row to row.
    Row i of the arrays is line i + 2 of the file (blank lines only at its end); a file without data rows is an
    error.
    """
    path = Path(path)
    known = list(required) + [c for c in optional if c not in required]
    with _open_rows(path, name) as fh:
        reader = csv.reader(fh)
        try:
            cols = _header(next(reader, None), name, known)
            missing = [c for c in required if c not in cols]
            if missing:
                raise InputDataError(f"{name}:1:{missing[0]}", f"missing column (the header has: {', '.join(cols)})")
            values: list[list[float]] = [[] for _ in cols]
            t_col = cols.index(time_column) if time_column is not None else None
            last, last_line, blank = -math.inf, 0, 0
            for row in reader:
                line = reader.line_num
                if not row or all(not f.strip() for f in row):
                    blank = blank or line
                    continue
                if blank:  # data rows are lines 2, 3, ... of the file: blank lines only at its end
                    raise InputDataError(f"{name}:{blank}", "blank line between data rows")
                if len(row) != len(cols):
                    raise InputDataError(f"{name}:{line}", f"has {len(row)} fields, the header {len(cols)}")
                for j, field in enumerate(row):
                    values[j].append(_number(field, f"{name}:{line}:{cols[j]}"))
                if t_col is not None:
                    t = values[t_col][-1]
                    if t == last:
                        raise InputDataError(f"{name}:{line}:{time_column}", f"duplicates the time {t!r} of line "
                                             f"{last_line} (one row per time)")
                    if t < last:
                        raise InputDataError(f"{name}:{line}:{time_column}", f"{t!r} is earlier than {last!r} on line "
                                             f"{last_line} (rows must be sorted by time)")
                    last, last_line = t, line
        except csv.Error as err:
            raise InputDataError(f"{name}:{reader.line_num}", f"malformed CSV: {err}") from None
        except UnicodeDecodeError:
            raise InputDataError(name, "is not UTF-8 text") from None
    if not values or not values[0]:
        raise InputDataError(name, "has no data rows")
    return {c: np.asarray(v, dtype=np.float64) for c, v in zip(cols, values)}


def _number(text: str, field: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputDataError(field, f"must be a number, got {text.strip()!r}") from None
    if not math.isfinite(v):
        raise InputDataError(field, f"must be finite, got {text.strip()}")
    return v


def choose_columns(cols: dict, name: str, options: Sequence[Sequence[str]]) -> int:
    """Which of the alternative column sets ``options`` the file ``name`` holds (exactly one, whole), by index."""
    present = [i for i, opt in enumerate(options) if any(c in cols for c in opt)]
    labels = " or ".join("(" + ", ".join(opt) + ")" for opt in options)
    if len(present) != 1:
        raise InputDataError(f"{name}:1", f"must have exactly one of the column sets {labels}")
    opt = options[present[0]]
    absent = [c for c in opt if c not in cols]
    if absent:
        raise InputDataError(f"{name}:1:{absent[0]}", f"missing column (with {', '.join(c for c in opt if c in cols)})")
    return present[0]


def write_columns(path, columns: dict) -> None:
    """Write ``columns`` (name -> 1-D array, all one length) as a CSV file with a header; floats as ``repr`` (the
    shortest text that reads back to the same float64)."""
    names = list(columns)
    arrays = [np.asarray(columns[n]) for n in names]
    n = {a.shape for a in arrays}
    if len(n) != 1 or len(next(iter(n))) != 1:
        raise InputDataError("columns", f"must be 1-D arrays of one length, got shapes {sorted(n)}")
    lists = [a.tolist() for a in arrays]
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(names)
        w.writerows(zip(*lists))

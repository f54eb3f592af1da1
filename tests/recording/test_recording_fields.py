"""``sarnav.recording.fields``: the typed readers of the manifest's tables (``Table``). Each reader accepts values
inside its range (bounds included) and refuses those outside, of the wrong type or non-finite with one line
``flight.toml:<table>.<key>: ...`` stating the valid range; unknown keys are refused naming the first (sorted) and
the known ones."""

from __future__ import annotations

import datetime
import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.recording.fields import MANIFEST, Table


def _err(fn, *args, **kw) -> ConfigError:
    with pytest.raises(ConfigError) as exc:
        fn(*args, **kw)
    assert "\n" not in str(exc.value)
    return exc.value


def test_manifest_name():
    """The manifest's file name, used in every error."""
    assert MANIFEST == "flight.toml"


def test_unknown_key_names_the_first_sorted_and_the_known_keys():
    """An unknown key is refused naming ``flight.toml:imu.<key>`` (the first in sorted order) and listing the known."""
    err = _err(Table, {"rate_hz": 100.0, "zeta": 1, "alpha": 2}, "imu", ("rate_hz", "file"))
    assert err.field == "flight.toml:imu.alpha"
    assert err.message == "unknown key (known: rate_hz, file)"
    assert str(err) == "flight.toml:imu.alpha: unknown key (known: rate_hz, file)"


def test_known_keys_only_are_accepted():
    """A table holding only known keys (or none of them) is accepted."""
    assert Table({"rate_hz": 1.0}, "imu", ("rate_hz", "file")).has("rate_hz")
    assert not Table({}, "imu", ("rate_hz",)).has("rate_hz")


@pytest.mark.parametrize("data", [[1, 2], "imu", 3.0, None])
def test_table_must_be_a_table(data):
    """A value that is not a TOML table is refused naming the table and the type found."""
    err = _err(Table, data, "imu", ("rate_hz",))
    assert err.field == "flight.toml:imu" and f"got {type(data).__name__}" in err.message


def test_field_names_file_table_and_key():
    """``field``: ``<where>:<table>.<key>``; a root table (name "") is ``<where>:<key>``; ``where`` replaces the
    file name."""
    assert Table({}, "aperture[3]", ()).field("time_s") == "flight.toml:aperture[3].time_s"
    assert Table({}, "", ()).field("version") == "flight.toml:version"
    assert Table({}, "imu", (), where="other.toml").field("rate_hz") == "other.toml:imu.rate_hz"


def test_missing_key_and_defaults():
    """A missing key without a default: ``<field>: missing``; with one, the default (checked like a value)."""
    t = Table({}, "imu", ("rate_hz", "n"))
    err = _err(t.get, "rate_hz")
    assert str(err) == "flight.toml:imu.rate_hz: missing"
    assert t.get("rate_hz", None) is None
    assert t.number("rate_hz", 0.0, 10.0, default=5) == 5.0
    assert t.integer("n", 1, 3, default=2) == 2
    err = _err(t.integer, "n", 1, 3, default=9)  # a default is checked too
    assert err.field == "flight.toml:imu.n"


# --- number ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("value", [0.0, 10, 5.5, 10.0])
def test_number_inside_closed_range(value):
    """number(lo, hi): bounds included, ints become floats."""
    v = Table({"x": value}, "t", ("x",)).number("x", 0.0, 10.0, "m")
    assert v == float(value) and type(v) is float


@pytest.mark.parametrize("value, text", [(-1e-9, "must be in [0, 10] m, got -1e-09"),
                                         (10.5, "must be in [0, 10] m, got 10.5"),
                                         (math.nan, "must be finite in [0, 10] m"),
                                         (math.inf, "must be finite in [0, 10] m")])
def test_number_outside_range_states_the_range(value, text):
    """Out of range or non-finite: ``flight.toml:t.x: must be ... [lo, hi] unit, got v``."""
    err = _err(Table({"x": value}, "t", ("x",)).number, "x", 0.0, 10.0, "m")
    assert err.field == "flight.toml:t.x" and text in err.message


def test_number_open_bounds():
    """A None bound is open: shown as -inf / inf in the range."""
    t = Table({"x": -1e300, "y": 5.0}, "t", ("x", "y"))
    assert t.number("x", None, 0.0) == -1e300
    err = _err(t.number, "y", None, 1.0)
    assert "[-inf, 1]" in err.message


@pytest.mark.parametrize("value", [True, "3.0", [1.0], None])
def test_number_refuses_non_numbers(value):
    """Booleans, strings, lists are not numbers (``float(True) == 1`` must not pass)."""
    err = _err(Table({"x": value}, "t", ("x",)).number, "x", 0.0, 10.0, "m")
    assert err.field == "flight.toml:t.x" and f"got {value!r}" in err.message


def test_number_of_a_non_number_states_the_range():
    """The module docstring: every bad key names the valid range, also when the value is not a number."""
    err = _err(Table({"x": "abc"}, "t", ("x",)).number, "x", 0.0, 10.0, "m")
    assert "[0, 10]" in err.message


# --- positive ----------------------------------------------------------------------------------------------

def test_positive_docstring_example():
    """The module docstring's line, exactly."""
    err = _err(Table({"rate_hz": -100.0}, "imu", ("rate_hz",)).positive, "rate_hz", "Hz", hi=10000)
    assert str(err) == "flight.toml:imu.rate_hz: must be a finite number in (0, 10000] Hz, got -100.0"


@pytest.mark.parametrize("value, ok", [(1e-300, True), (10000, True), (10000.000001, False), (0.0, False),
                                       (-0.0, False), (math.inf, False), (math.nan, False), (True, False),
                                       ("1", False)])
def test_positive_range_is_left_open_right_closed(value, ok):
    """positive(hi): (0, hi]; zero, non-finite, booleans and strings refused, stating (0, hi]."""
    t = Table({"x": value}, "t", ("x",))
    if ok:
        v = t.positive("x", "s", hi=10000)
        assert v == float(value) and type(v) is float
    else:
        err = _err(t.positive, "x", "s", hi=10000)
        assert err.field == "flight.toml:t.x" and "(0, 10000] s" in err.message


def test_positive_default_upper_bound():
    """Without hi, the bound is 1e12."""
    t = Table({"x": 1e12, "y": 2e12}, "t", ("x", "y"))
    assert t.positive("x") == 1e12
    assert "(0, 1e+12]" in _err(t.positive, "y").message


# --- integer, boolean, string ------------------------------------------------------------------------------

@pytest.mark.parametrize("value, ok", [(1, True), (3, True), (0, False), (4, False), (2.0, False), (True, False),
                                       ("2", False)])
def test_integer_closed_range_no_floats_no_bools(value, ok):
    """integer(lo, hi): an int in [lo, hi]; floats (even whole), booleans and strings refused, stating [lo, hi]."""
    t = Table({"n": value}, "t", ("n",))
    if ok:
        assert t.integer("n", 1, 3) == value
    else:
        err = _err(t.integer, "n", 1, 3)
        assert str(err) == f"flight.toml:t.n: must be an integer in [1, 3], got {value!r}"


@pytest.mark.parametrize("value, ok", [(True, True), (False, True), (1, False), ("true", False), (0.0, False)])
def test_boolean_only_true_or_false(value, ok):
    """boolean: TOML true / false only."""
    t = Table({"b": value}, "t", ("b",))
    if ok:
        assert t.boolean("b") is value
    else:
        assert _err(t.boolean, "b").message == f"must be true or false, got {value!r}"


def test_string_with_and_without_choices():
    """string: any string, or one of ``choices`` (listed in the error); non-strings refused."""
    t = Table({"s": "FLU", "n": 3}, "imu", ("s", "n"))
    assert t.string("s") == "FLU" and t.string("s", ("FRD", "FLU")) == "FLU"
    assert _err(t.string, "s", ("FRD",)).message == "must be one of ['FRD'], got 'FLU'"
    assert _err(t.string, "n").message == "must be a string, got 3"


# --- vector ------------------------------------------------------------------------------------------------

def test_vector_reads_n_numbers():
    """vector(n, lo, hi): a float64 array of the n values."""
    v = Table({"v": [1, -2.5, 3.0]}, "t", ("v",)).vector("v", 3, -10, 10, "m")
    assert v.dtype == np.float64
    np.testing.assert_array_equal(v, [1.0, -2.5, 3.0])


@pytest.mark.parametrize("value", [[1.0, 2.0], [1.0, 2.0, 3.0, 4.0], 1.0, "1,2,3"])
def test_vector_wrong_length_or_type(value):
    """Not a list of n: refused naming the key and the length wanted."""
    err = _err(Table({"v": value}, "t", ("v",)).vector, "v", 3, unit="m")
    assert err.field == "flight.toml:t.v" and "list of 3 numbers [m]" in err.message


def test_vector_entry_out_of_range_is_named_with_its_index():
    """A bad entry is named ``flight.toml:t.v[i]`` with the range."""
    err = _err(Table({"v": [0.0, 11.0, 0.0]}, "t", ("v",)).vector, "v", 3, -10, 10, "m")
    assert err.field == "flight.toml:t.v[1]" and "[-10, 10] m" in err.message
    err = _err(Table({"v": [0.0, 0.0, True]}, "t", ("v",)).vector, "v", 3, -10, 10)
    assert err.field == "flight.toml:t.v[2]"


# --- path --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("value, want", [("imu.csv", "imu.csv"), ("logs/imu.csv", "logs/imu.csv"),
                                         ("./logs//imu.csv", "logs/imu.csv"), (None, None)])
def test_path_relative_inside_the_folder(value, want):
    """path: a relative POSIX path (normalised by PurePosixPath), or None when the value is None."""
    assert Table({"f": value}, "imu", ("f",)).path("f") == want


@pytest.mark.parametrize("value", ["/etc/passwd", "../imu.csv", "logs/../../x", "logs\\imu.csv", "", 3])
def test_path_outside_the_folder_is_refused(value):
    """Absolute paths, ``..``, backslashes, empty strings and non-strings are refused naming the key."""
    err = _err(Table({"f": value}, "imu", ("f",)).path, "f")
    assert err.field == "flight.toml:imu.f" and "relative to the recording's folder" in err.message


# --- datetime ----------------------------------------------------------------------------------------------

def test_datetime_is_converted_to_utc():
    """A TOML offset date-time or an ISO 8601 string (``Z`` or an offset) becomes the same instant in UTC."""
    utc = datetime.UTC
    plus2 = datetime.timezone(datetime.timedelta(hours=2))
    t = Table({"a": datetime.datetime(2026, 1, 1, 2, 0, tzinfo=plus2), "b": "2026-01-01T00:00:00Z",
               "c": "2025-12-31T19:00:00-05:00"}, "time", ("a", "b", "c"))
    want = datetime.datetime(2026, 1, 1, 0, 0, tzinfo=utc)
    for k in "abc":
        got = t.datetime(k)
        assert got == want and got.utcoffset() == datetime.timedelta(0)


@pytest.mark.parametrize("value, text", [(datetime.datetime(2026, 1, 1), "UTC offset"),
                                         ("2026-01-01T00:00:00", "UTC offset"),
                                         ("yesterday", "ISO 8601"), (20260101, "UTC offset"),
                                         (datetime.date(2026, 1, 1), "UTC offset")])
def test_datetime_without_offset_is_refused(value, text):
    """A date-time without its offset (local time), a date, a number or a non-date string is refused."""
    err = _err(Table({"t0": value}, "time", ("t0",)).datetime, "t0")
    assert err.field == "flight.toml:time.t0" and text in err.message

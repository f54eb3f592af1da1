"""``sarnav.recording.tables``: the CSV logs of a recording (docs/recording.md §1 "CSV").

Files are written with Python's csv module (or raw text, for malformed ones) and read back; every error is one line
naming the file, the line of the file (the header is line 1) and the column.
"""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.recording import tables
from sarnav.recording.tables import choose_columns, read_columns, write_columns

IMU = ("time_s", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2")


def write_rows(path, rows) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)


def good_rows(n=5):
    return [list(IMU)] + [[repr(0.01 * i), "0.5", "-1e-3", "-9.81"] for i in range(n)]


def refused(path, name="imu.csv", required=IMU, optional=(), time_column="time_s") -> str:
    with pytest.raises(InputDataError) as err:
        read_columns(path, name, required, optional, time_column)
    msg = str(err.value)
    assert "\n" not in msg, msg
    return msg


def test_values_written_with_csv_read_back_bit_for_bit(tmp_path):
    """repr-written float64 values, including extremes and integers, read back exactly as float64 arrays."""
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.001, 0.02, 50))
    x = rng.standard_normal(50) * 10.0 ** rng.integers(-300, 300, 50)
    x[:3] = [5e-324, -1.7976931348623157e308, 0.1 + 0.2]
    rows = [["time_s", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2"]]
    rows += [[repr(float(a)), repr(float(b)), str(i), "-0"] for i, (a, b) in enumerate(zip(t, x))]
    write_rows(tmp_path / "imu.csv", rows)
    got = read_columns(tmp_path / "imu.csv", "imu.csv", IMU, time_column="time_s")
    assert list(got) == list(IMU)
    assert all(v.dtype == np.float64 for v in got.values())
    np.testing.assert_array_equal(got["time_s"], t)
    assert got["accel_x_mps2"].tobytes() == x.tobytes()
    np.testing.assert_array_equal(got["accel_y_mps2"], np.arange(50.0))


def test_write_columns_writes_a_header_and_repr_values(tmp_path):
    """write_columns: one header line of the names, rows of repr floats that Python's float reads back exactly."""
    rng = np.random.default_rng(2)
    cols = {"time_s": np.arange(20) / 7.0, "altitude_m": rng.standard_normal(20) * 1e3, "k": np.arange(20)}
    write_columns(tmp_path / "a.csv", cols)
    with open(tmp_path / "a.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time_s", "altitude_m", "k"]
    assert len(rows) == 21
    got = np.array([[float(v) for v in r] for r in rows[1:]])
    np.testing.assert_array_equal(got[:, 0], cols["time_s"])
    np.testing.assert_array_equal(got[:, 1], cols["altitude_m"])
    assert [r[2] for r in rows[1:]] == [str(i) for i in range(20)]  # integers as integers
    back = read_columns(tmp_path / "a.csv", "a.csv", ("time_s", "altitude_m", "k"), time_column="time_s")
    for name, v in cols.items():
        np.testing.assert_array_equal(back[name], v)


def test_write_columns_refuses_arrays_of_different_lengths_or_2d(tmp_path):
    with pytest.raises(InputDataError, match=r"^columns: must be 1-D arrays of one length"):
        write_columns(tmp_path / "a.csv", {"a": np.zeros(3), "b": np.zeros(4)})
    with pytest.raises(InputDataError, match=r"^columns: must be 1-D arrays of one length"):
        write_columns(tmp_path / "a.csv", {"a": np.zeros((3, 2))})


def test_spaces_around_names_and_values_are_ignored_and_order_is_free(tmp_path):
    (tmp_path / "alt.csv").write_text(" altitude_m , time_s\n 1000.5 ,0.0\n1001.25, 1.0 \n", encoding="utf-8")
    got = read_columns(tmp_path / "alt.csv", "alt.csv", ("time_s", "altitude_m"), time_column="time_s")
    np.testing.assert_array_equal(got["time_s"], [0.0, 1.0])
    np.testing.assert_array_equal(got["altitude_m"], [1000.5, 1001.25])


def test_optional_columns_may_be_absent_or_present(tmp_path):
    write_rows(tmp_path / "a.csv", [["time_s", "x"], ["0", "1"], ["1", "2"]])
    got = read_columns(tmp_path / "a.csv", "a.csv", ("time_s",), ("x", "y"))
    assert set(got) == {"time_s", "x"}
    # an optional column also listed as required is one column
    got = read_columns(tmp_path / "a.csv", "a.csv", ("time_s", "x"), ("x",))
    assert set(got) == {"time_s", "x"}


def test_trailing_blank_lines_are_allowed(tmp_path):
    (tmp_path / "a.csv").write_text("time_s,x\n0,1\n1,2\n\n\n", encoding="utf-8")
    got = read_columns(tmp_path / "a.csv", "a.csv", ("time_s", "x"), time_column="time_s")
    np.testing.assert_array_equal(got["x"], [1.0, 2.0])


def test_without_time_column_times_need_not_increase(tmp_path):
    write_rows(tmp_path / "p.csv", [["aperture", "point"], ["1", "0"], ["0", "0"], ["0", "0"]])
    got = read_columns(tmp_path / "p.csv", "points.csv", ("aperture", "point"))
    np.testing.assert_array_equal(got["aperture"], [1.0, 0.0, 0.0])


# ---- errors: file, line, column ------------------------------------------------------------------------------------


def test_nan_value_names_file_line_and_column(tmp_path):
    """The document's example: imu.csv:14:accel_x_mps2: must be finite, got nan (the header is line 1)."""
    rows = good_rows(20)
    rows[13][1] = "nan"
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv") == "imu.csv:14:accel_x_mps2: must be finite, got nan"
    rows[13][1], rows[3][3] = "0.5", "-inf"
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv") == "imu.csv:4:accel_z_mps2: must be finite, got -inf"


@pytest.mark.parametrize("text", ["1,5", "one", "", "0x10", "1e"])
def test_non_number_names_file_line_and_column(tmp_path, text):
    rows = good_rows()
    rows[3][2] = text
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv") == f"imu.csv:4:accel_y_mps2: must be a number, got {text!r}"


def test_time_earlier_than_the_previous_row_is_named(tmp_path):
    """The document's example: imu.csv:15:time_s: 0.03 is earlier than 0.04 on line 14 (rows must be sorted...)."""
    rows = good_rows(20)
    for k in range(1, 21):
        rows[k][0] = repr(0.002 * (k - 1) if k < 14 else 0.1 * k)
    rows[13][0], rows[14][0] = "0.04", "0.03"  # lines 14 and 15
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv") == \
        "imu.csv:15:time_s: 0.03 is earlier than 0.04 on line 14 (rows must be sorted by time)"


def test_duplicate_time_is_named(tmp_path):
    rows = good_rows()
    rows[3][0] = rows[2][0]
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv") == \
        f"imu.csv:4:time_s: duplicates the time {float(rows[2][0])!r} of line 3 (one row per time)"


def test_unknown_column_is_named_with_the_known_ones(tmp_path):
    rows = good_rows()
    rows[0][1] = "accel_x_g"
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv", optional=("gyro_x_radps",)) == \
        "imu.csv:1:accel_x_g: unknown column (known: time_s, accel_x_mps2, accel_y_mps2, accel_z_mps2, gyro_x_radps)"


def test_repeated_and_missing_columns_are_named(tmp_path):
    write_rows(tmp_path / "imu.csv", [["time_s", "accel_x_mps2", "accel_x_mps2"], ["0", "1", "2"]])
    assert refused(tmp_path / "imu.csv") == "imu.csv:1:accel_x_mps2: appears twice in the header"
    write_rows(tmp_path / "imu.csv", [["time_s", "accel_x_mps2", "accel_z_mps2"], ["0", "1", "2"]])
    assert refused(tmp_path / "imu.csv") == \
        "imu.csv:1:accel_y_mps2: missing column (the header has: time_s, accel_x_mps2, accel_z_mps2)"


def test_row_of_the_wrong_length_is_named(tmp_path):
    rows = good_rows()
    rows[3].pop()
    rows[4].append("1.0")
    write_rows(tmp_path / "imu.csv", rows)
    assert refused(tmp_path / "imu.csv") == "imu.csv:4: has 3 fields, the header 4"


def test_blank_line_between_rows_is_named(tmp_path):
    (tmp_path / "a.csv").write_text("time_s,x\n0,1\n\n1,2\n", encoding="utf-8")
    assert refused(tmp_path / "a.csv", "a.csv", ("time_s", "x")) == "a.csv:3: blank line between data rows"
    (tmp_path / "a.csv").write_text("time_s,x\n0,1\n , \n1,2\n", encoding="utf-8")
    assert refused(tmp_path / "a.csv", "a.csv", ("time_s", "x")) == "a.csv:3: blank line between data rows"


def test_empty_file_and_header_only_are_named(tmp_path):
    (tmp_path / "a.csv").write_text("", encoding="utf-8")
    assert refused(tmp_path / "a.csv", "a.csv", ("time_s",)) == \
        "a.csv: is empty (a header line of column names is required)"
    (tmp_path / "a.csv").write_text("time_s\n\n", encoding="utf-8")
    assert refused(tmp_path / "a.csv", "a.csv", ("time_s",)) == "a.csv: has no data rows"


def test_missing_file_and_folder_are_named(tmp_path):
    msg = refused(tmp_path / "nope.csv", "gnss.csv", ("time_s",))
    assert msg == f"gnss.csv: missing file (expected at {str(tmp_path / 'nope.csv')!r})"
    assert refused(tmp_path, "gnss.csv", ("time_s",)).startswith("gnss.csv: missing file")


def test_not_utf8_is_named(tmp_path):
    (tmp_path / "a.csv").write_bytes(b"time_s,x\n0,1\n1,\xff\xfe\n")
    assert refused(tmp_path / "a.csv", "a.csv", ("time_s", "x")) == "a.csv: is not UTF-8 text"


def test_malformed_csv_names_the_line(tmp_path):
    """A field beyond the csv module's field size limit is a csv.Error: one line naming file and line."""
    big = "1" * (csv.field_size_limit() + 10)
    (tmp_path / "a.csv").write_text(f"time_s,x\n0,1\n1,{big}\n", encoding="utf-8")
    msg = refused(tmp_path / "a.csv", "a.csv", ("time_s", "x"))
    assert msg.startswith("a.csv:3: malformed CSV: "), msg[:80]


def test_log_beyond_the_size_limit_is_refused(tmp_path, monkeypatch):
    write_rows(tmp_path / "imu.csv", good_rows())
    size = (tmp_path / "imu.csv").stat().st_size
    monkeypatch.setattr(tables, "MAX_LOG_BYTES", size - 1)
    assert refused(tmp_path / "imu.csv") == f"imu.csv: is {size} bytes; a log is at most {size - 1} bytes"


def test_default_size_limit_is_8_gib():
    assert tables.MAX_LOG_BYTES == 8 * 2**30


# ---- choose_columns ------------------------------------------------------------------------------------------------

OPTIONS = (("north_m", "east_m", "down_m"), ("latitude_deg", "longitude_deg", "height_m"))


def test_choose_columns_returns_the_index_of_the_one_whole_set():
    assert choose_columns({"time_s": 0, "north_m": 0, "east_m": 0, "down_m": 0}, "gnss.csv", OPTIONS) == 0
    assert choose_columns({"latitude_deg": 0, "longitude_deg": 0, "height_m": 0}, "gnss.csv", OPTIONS) == 1


def test_choose_columns_refuses_none_or_both_sets():
    want = ("gnss.csv:1: must have exactly one of the column sets (north_m, east_m, down_m) or "
            "(latitude_deg, longitude_deg, height_m)")
    with pytest.raises(InputDataError) as err:
        choose_columns({"time_s": 0}, "gnss.csv", OPTIONS)
    assert str(err.value) == want
    with pytest.raises(InputDataError) as err:
        choose_columns({"north_m": 0, "east_m": 0, "down_m": 0, "height_m": 0}, "gnss.csv", OPTIONS)
    assert str(err.value) == want


def test_choose_columns_names_the_missing_column_of_a_partial_set():
    with pytest.raises(InputDataError) as err:
        choose_columns({"north_m": 0, "down_m": 0}, "gnss.csv", OPTIONS)
    assert str(err.value) == "gnss.csv:1:east_m: missing column (with north_m, down_m)"


def test_errors_keep_file_and_field_apart(tmp_path):
    """InputDataError's field is 'file:line:column', its message the rest (the CLI's one line is both)."""
    rows = good_rows()
    rows[2][3] = "inf"
    write_rows(tmp_path / "imu.csv", rows)
    with pytest.raises(InputDataError) as err:
        read_columns(tmp_path / "imu.csv", "imu.csv", IMU)
    assert err.value.field == "imu.csv:3:accel_z_mps2"
    assert err.value.message == "must be finite, got inf"
    assert math.isinf(float(rows[2][3]))

"""``sarnav.recording.imu_formats`` on its own: IMU logs written here independently (the ``csv`` module, netCDF4, h5py)
read back through ``read_imu_columns`` with the same values, bit for bit; the format's checks (units, shapes,
finiteness, time order) as one line naming the file, the variable and the element; ``to_frd`` against the closed
form of a 180 deg rotation about x (y -> -y, z -> -z)."""

from __future__ import annotations

import csv

import h5py
import netCDF4
import numpy as np
import pytest

from sarnav.errors import ConfigError, InputDataError
from sarnav.recording.imu_formats import BODY_AXES, IMU_UNITS, read_imu_columns, to_frd

RATES = ("time_s", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2", "gyro_x_radps", "gyro_y_radps", "gyro_z_radps")
INCREMENTS = ("time_s", "dv_x_mps", "dv_y_mps", "dv_z_mps", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad")


def _values(n: int = 50, seed: int = 3) -> dict[str, np.ndarray]:
    """Random IMU columns with awkward float64 values (no short decimal form); time strictly increasing."""
    rng = np.random.default_rng(seed)
    out = {"time_s": 1.7e9 + np.cumsum(rng.uniform(0.001, 0.02, n))}
    for c in RATES[1:]:
        out[c] = rng.standard_normal(n) * 10.0 ** rng.integers(-6, 3)
    return out


def _write_nc(path, cols: dict, units: dict | None = None, fmt: str = "NETCDF4", extra=None):
    with netCDF4.Dataset(path, "w", format=fmt) as ds:
        ds.createDimension("sample", None)
        for c, v in cols.items():
            var = ds.createVariable(c, np.asarray(v).dtype, ("sample",))
            var[:] = v
            if units and c in units:
                var.units = units[c]
        if extra is not None:
            extra(ds)


def _write_h5(path, cols: dict):
    with h5py.File(path, "w") as f:
        for c, v in cols.items():
            f.create_dataset(c, data=np.asarray(v))


def _write_csv(path, cols: dict):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(cols))
        for row in zip(*cols.values()):
            w.writerow([repr(float(x)) for x in row])


def _assert_same(got: dict, want: dict):
    assert list(got) == list(want)
    for c, v in want.items():
        assert got[c].dtype == np.float64
        np.testing.assert_array_equal(got[c], np.asarray(v, dtype=np.float64))


def test_csv_reads_back_bit_for_bit(tmp_path):
    """A CSV written with the csv module (``repr`` of each float) reads back with the same float64 values."""
    v = _values()
    _write_csv(tmp_path / "imu.csv", v)
    _assert_same(read_imu_columns(tmp_path / "imu.csv", "imu.csv", RATES), v)


@pytest.mark.parametrize("suffix, fmt", [(".nc", "NETCDF4"), (".nc4", "NETCDF4"), (".nc", "NETCDF3_64BIT_OFFSET"),
                                         (".NC", "NETCDF4_CLASSIC")])
def test_netcdf_reads_back_bit_for_bit(tmp_path, suffix, fmt):
    """A netCDF file (netCDF-4 or classic formats, any suffix case) written with netCDF4 reads back the same."""
    v = _values()
    path = tmp_path / f"imu{suffix}"
    _write_nc(path, v, fmt=fmt)
    _assert_same(read_imu_columns(path, path.name, RATES), v)


@pytest.mark.parametrize("suffix", [".h5", ".hdf5"])
def test_plain_hdf5_reads_back_bit_for_bit(tmp_path, suffix):
    """A plain HDF5 file of 1-D datasets (h5py, no netCDF conventions) reads back the same."""
    v = _values()
    path = tmp_path / f"imu{suffix}"
    _write_h5(path, v)
    _assert_same(read_imu_columns(path, path.name, RATES), v)


def test_increment_columns_and_integer_time(tmp_path):
    """Increment columns read the same way; an integer variable (time in whole seconds) becomes float64."""
    rng = np.random.default_rng(0)
    v = {"time_s": np.arange(1, 21, dtype=np.int64)}
    v.update({c: rng.standard_normal(20) * 1e-3 for c in INCREMENTS[1:]})
    _write_nc(tmp_path / "imu.nc", v)
    got = read_imu_columns(tmp_path / "imu.nc", "imu.nc", INCREMENTS)
    _assert_same(got, v)


def test_extra_variables_are_ignored(tmp_path):
    """Variables other than the columns (a temperature, a 2-D matrix) are not read and not refused."""
    v = _values(10)

    def extra(ds):
        ds.createVariable("temperature_c", "f8", ("sample",))[:] = np.arange(10.0)
        ds.createDimension("three", 3)
        ds.createVariable("misalignment", "f8", ("three", "three"))[:] = np.eye(3)

    _write_nc(tmp_path / "imu.nc", v, extra=extra)
    _assert_same(read_imu_columns(tmp_path / "imu.nc", "imu.nc", RATES), v)


def _unit_cases():
    for suffix, spellings in IMU_UNITS.items():
        for s in spellings:
            yield suffix, s


def test_every_listed_unit_spelling_is_accepted(tmp_path):
    """Each spelling of IMU_UNITS is accepted on a column of its suffix (padded with spaces too)."""
    v = _values(5)
    col_of = {"_s": "time_s", "_mps2": "accel_x_mps2", "_radps": "gyro_x_radps"}
    for suffix, spelling in _unit_cases():
        if suffix not in col_of:
            continue
        path = tmp_path / "u.nc"
        _write_nc(path, v, units={col_of[suffix]: f" {spelling} "})
        _assert_same(read_imu_columns(path, "u.nc", RATES), v)


@pytest.mark.parametrize("col, unit", [("accel_x_mps2", "g"), ("gyro_z_radps", "deg/s"), ("time_s", "ms"),
                                       ("accel_y_mps2", "rad/s")])
def test_wrong_units_are_refused_naming_the_variable(tmp_path, col, unit):
    """A ``units`` attribute that is not the column's unit: one line naming ``imu.nc:<variable>`` and the unit."""
    _write_nc(tmp_path / "imu.nc", _values(5), units={col: unit})
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / "imu.nc", "imu.nc", RATES)
    assert exc.value.field == f"imu.nc:{col}" and repr(unit) in exc.value.message and "\n" not in str(exc.value)


def test_missing_variable_is_named_with_the_variables_present(tmp_path):
    """A column missing from the file: ``imu.nc:<column>: missing variable (the file has: ...)``."""
    v = _values(5)
    del v["gyro_y_radps"]
    _write_nc(tmp_path / "imu.nc", v)
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / "imu.nc", "imu.nc", RATES)
    assert exc.value.field == "imu.nc:gyro_y_radps" and "missing variable" in exc.value.message
    assert "accel_x_mps2" in exc.value.message


def test_variables_of_different_lengths_are_refused(tmp_path):
    """A column shorter than time_s is named with both lengths."""
    v = _values(6)
    with h5py.File(tmp_path / "imu.h5", "w") as f:
        for c in RATES:
            f.create_dataset(c, data=v[c][:5] if c == "gyro_x_radps" else v[c])
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / "imu.h5", "imu.h5", RATES)
    assert exc.value.field == "imu.h5:gyro_x_radps" and "has 5 values, time_s 6" in exc.value.message


def test_two_dimensional_or_text_variables_are_refused(tmp_path):
    """A column that is 2-D (or not numeric) is refused naming it."""
    v = _values(6)
    with h5py.File(tmp_path / "imu.h5", "w") as f:
        for c in RATES:
            f.create_dataset(c, data=np.c_[v[c], v[c]] if c == "accel_z_mps2" else v[c])
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / "imu.h5", "imu.h5", RATES)
    assert exc.value.field == "imu.h5:accel_z_mps2" and "1-D numeric" in exc.value.message


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_value_is_named_with_its_element(tmp_path, bad):
    """A NaN / inf at element 13 of a column: ``imu.nc:<column>[13]: must be finite``."""
    v = _values(20)
    v["gyro_y_radps"][13] = bad
    _write_nc(tmp_path / "imu.nc", v)
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / "imu.nc", "imu.nc", RATES)
    assert exc.value.field == "imu.nc:gyro_y_radps[13]" and "must be finite" in exc.value.message


@pytest.mark.parametrize("i, how", [(7, "duplicates"), (12, "is earlier than")])
def test_time_out_of_order_is_named_with_its_element(tmp_path, i, how):
    """Sample i at the time of sample i - 1 (or earlier): ``imu.nc:time_s[i]`` says which."""
    v = _values(20)
    v["time_s"][i] = v["time_s"][i - 1] - (0.0 if how == "duplicates" else 1e-3)
    _write_nc(tmp_path / "imu.nc", v)
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / "imu.nc", "imu.nc", RATES)
    assert exc.value.field == f"imu.nc:time_s[{i}]" and how in exc.value.message
    assert f"sample {i - 1}" in exc.value.message


def test_empty_and_unreadable_files(tmp_path):
    """No samples, a file that is not netCDF / HDF5, and a missing file: one line each naming the log."""
    _write_nc(tmp_path / "empty.nc", {c: np.zeros(0) for c in RATES})
    with pytest.raises(InputDataError, match="has no samples"):
        read_imu_columns(tmp_path / "empty.nc", "empty.nc", RATES)
    (tmp_path / "text.nc").write_text("time_s,accel_x_mps2\n")
    with pytest.raises(InputDataError, match="not a readable netCDF"):
        read_imu_columns(tmp_path / "text.nc", "text.nc", RATES)
    with pytest.raises(InputDataError, match="missing file"):
        read_imu_columns(tmp_path / "absent.h5", "absent.h5", RATES)


@pytest.mark.parametrize("name", ["imu.txt", "imu.json", "imu"])
def test_unknown_suffix_is_refused_listing_the_formats(tmp_path, name):
    """A suffix of no known format (or none) is refused, naming it and the known ones."""
    (tmp_path / name).write_text("x")
    with pytest.raises(InputDataError) as exc:
        read_imu_columns(tmp_path / name, name, RATES)
    assert exc.value.field == name and "unknown IMU log format" in exc.value.message and ".csv" in exc.value.message


def test_a_ros_bag_holds_rates_only(tmp_path):
    """Increment columns from a ROS bag are refused (sensor_msgs/Imu holds rates) naming imu.samples, before the
    file is opened."""
    with pytest.raises(ConfigError) as exc:
        read_imu_columns(tmp_path / "absent.bag", "imu.bag", INCREMENTS)
    assert exc.value.field == "imu.samples" and "'rates'" in exc.value.message


# --- to_frd ------------------------------------------------------------------------------------------------

def test_body_axes():
    """The two body-axis conventions accepted."""
    assert BODY_AXES == ("FRD", "FLU")


def test_flu_to_frd_negates_y_and_z():
    """FLU (x forward, y left, z up) -> FRD: x kept, y -> -y, z -> -z, element for element."""
    v = np.random.default_rng(1).standard_normal((40, 3))
    got = to_frd("FLU", v)
    np.testing.assert_array_equal(got[:, 0], v[:, 0])
    np.testing.assert_array_equal(got[:, 1], -v[:, 1])
    np.testing.assert_array_equal(got[:, 2], -v[:, 2])


def test_flu_to_frd_is_a_half_turn_about_x():
    """The conversion is the rotation by 180 deg about x (a proper rotation, det +1, its own inverse): the level
    specific force +g up (FLU) becomes -g along z down (FRD)."""
    c, s = np.cos(np.pi), np.sin(np.pi)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    v = np.random.default_rng(2).standard_normal((25, 3))
    np.testing.assert_allclose(to_frd("FLU", v), v @ rx.T, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(to_frd("FLU", to_frd("FLU", v)), v)
    np.testing.assert_array_equal(to_frd("FLU", np.array([[0.0, 0.0, 9.80665]])), [[0.0, 0.0, -9.80665]])


def test_frd_is_unchanged():
    """FRD samples are returned as they are."""
    v = np.random.default_rng(3).standard_normal((5, 3))
    np.testing.assert_array_equal(to_frd("FRD", v), v)

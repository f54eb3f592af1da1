"""The IMU log's file formats (docs/recording.md §3): CSV, netCDF / HDF5, ROS 1 and ROS 2 bags.

Every format gives the same named columns (``logs.IMU_COLUMNS``: ``time_s`` and the three axes of the two sensors,
units in the names) checked the same way: finite, the time strictly increasing, one line naming the file, the row
and the column. The format is chosen by the file's name:

* ``.csv``: ``tables.read_columns`` (line numbers of the file in errors: ``imu.csv:14:accel_x_mps2``);
* ``.nc``, ``.nc4``, ``.h5``, ``.hdf5``: one 1-D variable (dataset) per column at the file's root, numeric, all of
  one length; other variables are ignored; a ``units`` attribute, when present, must be the column's unit in UDUNITS
  or plain spelling (``m s-2``, ``m/s^2``); errors name the variable and the element (``imu.nc:accel_x_mps2[13]``).
  Read through netCDF4 (netCDF-4 files are HDF5; a plain HDF5 file of 1-D datasets reads the same);
* ``.bag`` (ROS 1) or ``.db3`` / ``.mcap`` / a folder (ROS 2): the ``sensor_msgs/Imu`` messages of one topic
  (``[imu] topic``; needed only when the bag has more than one), read with the pure-Python ``rosbags`` (optional
  extra ``sarnav[ros]``): ``time_s`` = ``header.stamp`` (seconds, float64: 0.24 µs steps at today's Unix times),
  ``linear_acceleration`` (specific force, REP-145) and ``angular_velocity``, in the message's body axes (REP-103:
  x forward, y left, z up: state ``[imu] body_axes = "FLU"``). Only ``samples = "rates"``; the message covariances
  are not read (the manifest's error model is). Errors name the topic and the message's index in the bag's
  time order (``imu.bag:/imu/data[14]:header.stamp``).

Body axes: ``"FRD"`` (sarnav's) or ``"FLU"`` (ROS's), whatever the format; FLU samples are turned to FRD by
negating y and z (a rotation of 180 deg about x: the same specific force at rest, [0, 0, -g] level).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sarnav.errors import ConfigError, InputDataError, require_extra
from sarnav.recording.tables import MAX_LOG_BYTES, read_columns

__all__ = ["BODY_AXES", "NETCDF_SUFFIXES", "ROS_SUFFIXES", "IMU_UNITS", "read_imu_columns", "to_frd"]

#: the body axes an IMU log may be stated in (``[imu] body_axes``)
BODY_AXES = ("FRD", "FLU")
NETCDF_SUFFIXES = (".nc", ".nc4", ".h5", ".hdf5")
ROS_SUFFIXES = (".bag", ".db3", ".mcap")
#: accepted spellings of each column suffix's unit in a netCDF / HDF5 ``units`` attribute
IMU_UNITS = {
    "_s": ("s", "second", "seconds"),
    "_mps2": ("m s-2", "m/s^2", "m/s2", "m s**-2", "m.s-2"),
    "_radps": ("rad s-1", "rad/s", "radian s-1", "rad.s-1"),
    "_mps": ("m s-1", "m/s", "m.s-1"),
    "_rad": ("rad", "radian", "radians"),
}


def to_frd(axes: str, values: np.ndarray) -> np.ndarray:
    """(N, 3) body-axis samples in ``axes`` ("FRD" or "FLU") as FRD."""
    if axes == "FRD":
        return values
    return values * np.array([1.0, -1.0, -1.0])


def read_imu_columns(path, name: str, columns, topic: str | None = None) -> dict[str, np.ndarray]:
    """``{column: float64 (N,)}`` of the IMU log ``path`` (``name`` in errors) holding ``columns`` (``time_s`` first),
    its format chosen by its suffix (module docstring); ``topic``: a bag's topic."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in NETCDF_SUFFIXES:
        return _checked(_netcdf_columns(path, name, columns), name, columns, lambda c, i: f"{name}:{c}[{i}]")
    if suffix in ROS_SUFFIXES or path.is_dir():
        if tuple(columns[1:4]) != ("accel_x_mps2", "accel_y_mps2", "accel_z_mps2"):
            raise ConfigError("imu.samples", f"{name}: a ROS bag's sensor_msgs/Imu holds rates: must be 'rates'")
        cols, topic = _ros_columns(path, name, columns, topic)
        return _checked(cols, name, columns, lambda c, i: f"{name}:{topic}[{i}]:" + (
            "header.stamp" if c == "time_s" else _ROS_FIELD[c]))
    if suffix != ".csv":
        raise InputDataError(name, f"unknown IMU log format {suffix or '(no suffix)'!r} (known: .csv, "
                             f"{', '.join(NETCDF_SUFFIXES + ROS_SUFFIXES)} or a ROS 2 bag folder)")
    return read_columns(path, name, columns, time_column="time_s")


def _checked(cols: dict, name: str, columns, where) -> dict[str, np.ndarray]:
    """Every value finite, the time strictly increasing (the CSV reader's checks, for arrays)."""
    n = cols[columns[0]].size
    if n == 0:
        raise InputDataError(name, "has no samples")
    for c in columns:
        bad = np.flatnonzero(~np.isfinite(cols[c]))
        if bad.size:
            raise InputDataError(where(c, int(bad[0])), f"must be finite, got {float(cols[c][bad[0]])}")
    t = cols[columns[0]]
    step = np.diff(t)
    bad = np.flatnonzero(step <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        what = "duplicates" if step[i - 1] == 0 else "is earlier than"
        raise InputDataError(where(columns[0], i), f"{float(t[i])!r} {what} {float(t[i - 1])!r} of sample {i - 1} "
                             "(samples must be sorted by time, one per time)")
    return cols


def _unit_ok(column: str, units) -> bool:
    for suffix, spellings in IMU_UNITS.items():
        if column.endswith(suffix):
            return str(units).strip() in spellings
    return True


def _netcdf_columns(path: Path, name: str, columns) -> dict[str, np.ndarray]:
    import netCDF4

    if not path.is_file():
        raise InputDataError(name, f"missing file (expected at {str(path)!r})")
    if path.stat().st_size > MAX_LOG_BYTES:
        raise InputDataError(name, f"is {path.stat().st_size} bytes; a log is at most {MAX_LOG_BYTES} bytes")
    try:
        ds = netCDF4.Dataset(path, "r")
    except OSError as err:
        raise InputDataError(name, f"is not a readable netCDF / HDF5 file ({err})") from None
    with ds:
        ds.set_auto_maskandscale(False)
        out, n = {}, None
        for c in columns:
            if c not in ds.variables:
                raise InputDataError(f"{name}:{c}", f"missing variable (the file has: {', '.join(ds.variables)})")
            v = ds.variables[c]
            if v.ndim != 1 or v.dtype.kind not in "iuf":
                raise InputDataError(f"{name}:{c}", f"must be a 1-D numeric variable, got {v.ndim}-D {v.dtype}")
            if "units" in v.ncattrs() and not _unit_ok(c, v.getncattr("units")):
                raise InputDataError(f"{name}:{c}", f"units {v.getncattr('units')!r} are not the column's "
                                     f"(its name's suffix: {_suffix_units(c)})")
            if n is not None and v.shape[0] != n:
                raise InputDataError(f"{name}:{c}", f"has {v.shape[0]} values, {columns[0]} {n}")
            n = v.shape[0]
            try:
                out[c] = np.asarray(v[:], dtype=np.float64)
            except (OSError, RuntimeError, ValueError) as err:
                raise InputDataError(f"{name}:{c}", f"cannot be read ({err})") from None
    return out


def _suffix_units(column: str) -> str:
    for suffix, spellings in IMU_UNITS.items():
        if column.endswith(suffix):
            return " or ".join(repr(s) for s in spellings[:2])
    return "none"


#: the sensor_msgs/Imu field of each rates column
_ROS_FIELD = {f"{s}_{a}_{u}": f"{m}.{a}" for s, m, u in (("accel", "linear_acceleration", "mps2"),
                                                          ("gyro", "angular_velocity", "radps")) for a in "xyz"}
_IMU_TYPE = "sensor_msgs/msg/Imu"
#: a serialised sensor_msgs/Imu is at least this long (37 float64 values: 296 bytes, plus its header)
_MIN_IMU_MESSAGE_BYTES = 296


def _ros_reader():
    require_extra("imu.file", "ros", "rosbags.highlevel", "rosbags")
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    return AnyReader, get_typestore(Stores.ROS2_HUMBLE)


def _read_messages(reader, conns, values: np.ndarray, name: str, topic: str) -> int:
    """The messages of ``conns`` into ``values`` (rows: time, accel xyz, gyro xyz); how many were read."""
    k = 0
    try:
        for conn, _, raw in reader.messages(connections=conns):
            if k >= values.shape[0]:
                raise InputDataError(f"{name}:{topic}", f"holds more messages than its index's {values.shape[0]}")
            try:
                m = reader.deserialize(raw, conn.msgtype)
                a, g = m.linear_acceleration, m.angular_velocity
                values[k] = (m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec, a.x, a.y, a.z, g.x, g.y, g.z)
            except Exception as err:  # a damaged message: its deserializer's own error
                raise InputDataError(f"{name}:{topic}[{k}]", f"cannot be decoded ({type(err).__name__})") from None
            k += 1
    except InputDataError:
        raise
    except Exception as err:  # a damaged chunk, index or database: rosbags' (or sqlite's) own error
        raise InputDataError(f"{name}:{topic}", f"cannot be read after message {k} ({type(err).__name__}: "
                             f"{str(err)[:120]})") from None
    return k


def _ros_columns(path: Path, name: str, columns, topic: str | None):
    AnyReader, typestore = _ros_reader()
    if not path.exists():
        raise InputDataError(name, f"missing file (expected at {str(path)!r})")
    try:
        reader = AnyReader([path], default_typestore=typestore)
        reader.open()
    except Exception as err:  # rosbags raises its own error classes (and others on a damaged file)
        raise InputDataError(name, f"is not a readable ROS bag ({type(err).__name__}: {err})") from None
    try:
        imus = sorted({c.topic for c in reader.connections if c.msgtype == _IMU_TYPE})
        if topic is None:
            if len(imus) != 1:
                raise ConfigError("imu.topic", f"{name} has {len(imus)} sensor_msgs/Imu topics ({', '.join(imus)}): "
                                  "name one")
            topic = imus[0]
        elif topic not in imus:
            raise ConfigError("imu.topic", f"{topic!r} is not a sensor_msgs/Imu topic of {name} (it has: "
                              f"{', '.join(imus) or 'none'})")
        conns = [c for c in reader.connections if c.topic == topic and c.msgtype == _IMU_TYPE]
        count = sum(c.msgcount for c in conns)
        size = path.stat().st_size if path.is_file() else sum(f.stat().st_size for f in path.rglob("*") if f.is_file())
        if not 0 <= count <= size // _MIN_IMU_MESSAGE_BYTES:  # a damaged index must not size the arrays
            raise InputDataError(f"{name}:{topic}", f"its index claims {count} messages in {size} bytes (a "
                                 f"sensor_msgs/Imu message takes at least {_MIN_IMU_MESSAGE_BYTES} bytes)")
        values = np.empty((count, 7))
        k = _read_messages(reader, conns, values, name, topic)
    finally:
        reader.close()
    names = list(columns)
    return {c: values[:k, j].copy() for j, c in enumerate(names)}, topic


"""The IMU log in every format (docs/recording.md §3, recording.imu_formats): files written here with netCDF4, h5py
and rosbags as other software writes them (never by sarnav), read as the CSV twin; a recording navigates the same
whatever its IMU log's format; bad files are one line naming the variable or message; corrupt CSV and netCDF logs
(hypothesis: 20 files per format by default, 200 under ``-m slow``) are one line or a correct read, never a
traceback."""

from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from foreign_flight import ForeignFlight
from sarnav.errors import ConfigError, InputDataError, SarnavError
from sarnav.recording import read_recording
from sarnav.recording.logs import IMU_COLUMNS, read_imu
from sarnav.recording.navigate import navigate
from sarnav.scenarios.navigate import read_navigate_settings

netCDF4 = pytest.importorskip("netCDF4")
RATES = IMU_COLUMNS["rates"]
UNITS = {"time_s": "s", "accel": "m s-2", "gyro": "rad s-1"}


def _samples(n=200, seed=1):
    """Jittered 100 Hz times (at whole nanoseconds, as a ROS stamp holds them) and FRD rates."""
    rng = np.random.default_rng(seed)
    t = 10.0 + np.round((np.arange(n) + rng.uniform(-0.1, 0.1, n)) * 0.01, 9)
    a = rng.normal([0.1, -0.2, -9.8], 0.05, (n, 3))
    g = rng.normal(0.0, 0.01, (n, 3))
    return t, a, g


def _write_csv(path, t, a, g):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(RATES)
        for k in range(t.size):
            w.writerow([repr(float(v)) for v in (t[k], *a[k], *g[k])])


def _write_nc(path, t, a, g, units=True, fmt="NETCDF4"):
    with netCDF4.Dataset(path, "w", format=fmt) as ds:
        ds.createDimension("sample", t.size)
        for j, c in enumerate(RATES):
            v = ds.createVariable(c, "f8", ("sample",))
            v[:] = t if j == 0 else (a[:, j - 1] if j < 4 else g[:, j - 4])
            if units:
                v.units = UNITS[c.split("_")[0]] if j else "s"


def _write_h5(path, t, a, g):
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w") as f:  # plain HDF5: datasets at the root, no netCDF dimensions
        f["time_s"] = t
        for j, c in enumerate(RATES[1:]):
            f[c] = a[:, j] if j < 3 else g[:, j - 3]


def _ros_types(ros1: bool):
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    return ts, {k: ts.types[k] for k in ("sensor_msgs/msg/Imu", "std_msgs/msg/Header", "builtin_interfaces/msg/Time",
                                         "geometry_msgs/msg/Vector3", "geometry_msgs/msg/Quaternion")}


def _imu_message(T, k, t, a, g, ros1):
    """A sensor_msgs/Imu in REP-103 body axes (FLU: y and z of the FRD samples negated)."""
    sec = int(math.floor(t))
    stamp = T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((t - sec) * 1e9)))
    head = (T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="imu_link") if ros1
            else T["std_msgs/msg/Header"](stamp=stamp, frame_id="imu_link"))
    vec = T["geometry_msgs/msg/Vector3"]
    return T["sensor_msgs/msg/Imu"](
        header=head, orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=np.full(9, -1.0), angular_velocity=vec(x=g[0], y=-g[1], z=-g[2]),
        angular_velocity_covariance=np.zeros(9), linear_acceleration=vec(x=a[0], y=-a[1], z=-a[2]),
        linear_acceleration_covariance=np.zeros(9))


def _write_bag(path, t, a, g, ros1=False, topics=("/imu/data",), extra_topic=None):
    pytest.importorskip("rosbags")
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import Writer as Writer2

    ts, T = _ros_types(ros1)
    imu = T["sensor_msgs/msg/Imu"].__msgtype__
    serialize = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    with (Writer1(Path(path)) if ros1 else Writer2(Path(path), version=8)) as w:
        conns = [w.add_connection(tp, imu, typestore=ts) for tp in topics]
        if extra_topic:
            w.add_connection(extra_topic, "geometry_msgs/msg/Vector3", typestore=ts)
        for k in range(t.size):
            for c in conns:
                w.write(c, int(round(t[k] * 1e9)), serialize(_imu_message(T, k, t[k], a[k], g[k], ros1), imu))


WRITERS = {"imu.nc": _write_nc, "imu.h5": _write_h5, "imu.bag": lambda p, *s: _write_bag(p, *s, ros1=True),
           "imu_ros2": _write_bag}


@pytest.mark.parametrize("name", list(WRITERS))
def test_every_format_reads_as_its_csv_twin(tmp_path, name):
    t, a, g = _samples()
    _write_csv(tmp_path / "imu.csv", t, a, g)
    WRITERS[name](tmp_path / name, t, a, g)
    axes = "FRD" if name in ("imu.nc", "imu.h5") else "FLU"
    ref = read_imu(tmp_path / "imu.csv", "imu.csv", "rates", 0.25, 100.0)
    log = read_imu(tmp_path / name, name, "rates", 0.25, 100.0, body_axes=axes)
    np.testing.assert_array_equal(log.accel, ref.accel)  # FLU -> FRD negates: exact
    np.testing.assert_array_equal(log.gyro, ref.gyro)
    if axes == "FRD":
        np.testing.assert_array_equal(log.time, ref.time)
    else:  # sec + 1e-9 nanosec in float64: within a few ulp of 10 s
        np.testing.assert_allclose(log.time, ref.time, rtol=0, atol=1e-12)


def test_the_level_specific_force_of_a_ros_imu_is_minus_g_down(tmp_path):
    """REP-145: a level IMU at rest reports +g on its z (up) axis; read as FLU it is [0, 0, -g] in FRD, the
    specific force sarnav's strapdown expects at rest."""
    t = 1.0 + np.arange(5) * 0.01
    flu = np.tile([0.0, 0.0, 9.81], (5, 1))
    _write_bag(tmp_path / "b", t, flu * [1, -1, -1], np.zeros((5, 3)))  # the helper writes FRD samples as FLU
    log = read_imu(tmp_path / "b", "b", "rates", 0.0, 100.0, body_axes="FLU")
    np.testing.assert_array_equal(log.accel, np.tile([0.0, 0.0, -9.81], (5, 1)))


def test_a_recording_navigates_the_same_whatever_its_imu_format(tmp_path):
    root = tmp_path / "rec"
    ForeignFlight(3, duration=4, gnss_until=2.0, gap=(2.2, 2.6)).write(root)
    base = navigate(rec := read_recording(root), read_navigate_settings(rec)).estimate()
    cols = {c: v for c, v in zip(RATES, np.loadtxt(root / "imu.csv", delimiter=",", skiprows=1).T)}
    t = cols["time_s"]
    a = np.stack([cols[c] for c in RATES[1:4]], 1)
    g = np.stack([cols[c] for c in RATES[4:]], 1)
    text = (root / "flight.toml").read_text()
    for name, axes in (("imu.nc", "FRD"), ("imu_ros2", "FLU")):
        other = tmp_path / name.replace(".", "_")
        shutil.copytree(root, other)
        WRITERS[name](other / name, t, a, g)
        (other / "imu.csv").unlink()
        new = text.replace('file = "imu.csv"', f'file = "{name}"\nbody_axes = "{axes}"')
        assert new != text
        (other / "flight.toml").write_text(new)
        est = navigate(rec := read_recording(other), read_navigate_settings(rec)).estimate()
        if name == "imu.nc":  # the same float64 values: the same navigation, bit for bit
            for key in ("p", "v", "q", "P"):
                np.testing.assert_array_equal(est[key], base[key])
        else:  # the stamps at whole nanoseconds: times within 5e-10 s of the CSV's
            np.testing.assert_allclose(est["p"], base["p"], rtol=0, atol=1e-4)
            np.testing.assert_allclose(est["sigma"], base["sigma"], rtol=1e-6)


def _error(path, name="imu.nc", kind="rates", **kw):
    with pytest.raises(SarnavError) as err:
        read_imu(path, name, kind, 0.0, 100.0, **kw)
    assert "\n" not in str(err.value)
    return str(err.value)


def test_bad_netcdf_logs_are_one_line_naming_the_variable(tmp_path):
    t, a, g = _samples(20)
    a[3, 0] = np.nan
    _write_nc(tmp_path / "nan.nc", t, a, g)
    assert _error(tmp_path / "nan.nc").startswith("imu.nc:accel_x_mps2[3]: must be finite")
    t2 = t.copy()
    t2[7] = t2[5]
    _write_nc(tmp_path / "sorted.nc", t2, *_samples(20)[1:])
    assert _error(tmp_path / "sorted.nc").startswith("imu.nc:time_s[7]: 10.0498466")
    with netCDF4.Dataset(tmp_path / "units.nc", "w") as ds:
        ds.createDimension("n", 3)
        for c in RATES:
            ds.createVariable(c, "f8", ("n",))[:] = np.arange(3.0)
            ds[c].units = "s"
    assert _error(tmp_path / "units.nc") .startswith("imu.nc:accel_x_mps2: units 's' are not the column's")
    with netCDF4.Dataset(tmp_path / "missing.nc", "w") as ds:
        ds.createDimension("n", 3)
        ds.createVariable("time_s", "f8", ("n",))[:] = np.arange(3.0)
    assert _error(tmp_path / "missing.nc").startswith("imu.nc:accel_x_mps2: missing variable (the file has: time_s)")
    (tmp_path / "text.nc").write_text("time_s,accel_x_mps2\n")
    assert _error(tmp_path / "text.nc").startswith("imu.nc: is not a readable netCDF / HDF5 file")
    assert _error(tmp_path / "imu.txt", "imu.txt").startswith("imu.txt: unknown IMU log format '.txt'")


def test_bad_bags_are_one_line_naming_the_topic_or_the_key(tmp_path, monkeypatch):
    t, a, g = _samples(10)
    _write_bag(tmp_path / "two", t, a, g, topics=("/imu/a", "/imu/b"), extra_topic="/v")
    assert _error(tmp_path / "two", "two").startswith("imu.topic: two has 2 sensor_msgs/Imu topics (/imu/a, /imu/b)")
    assert _error(tmp_path / "two", "two", topic="/v").startswith("imu.topic: '/v' is not a sensor_msgs/Imu topic")
    assert read_imu(tmp_path / "two", "two", "rates", 0.0, 100.0, topic="/imu/b").time.size == 10
    assert _error(tmp_path / "two", "two", kind="increments").startswith("imu.samples: two: a ROS bag's")
    (tmp_path / "bad.bag").write_bytes(b"#ROSBAG V2.0\n" + bytes(range(256)) * 4)
    assert _error(tmp_path / "bad.bag", "bad.bag").startswith("bad.bag: is not a readable ROS bag")
    t[4] = t[2]
    _write_bag(tmp_path / "back.bag", t, a, g, ros1=True)
    msg = _error(tmp_path / "back.bag", "back.bag")
    assert msg.startswith("back.bag:/imu/data[3]:header.stamp: 10.019288319 duplicates")
    monkeypatch.setitem(__import__("sys").modules, "rosbags.highlevel", None)  # the extra not installed
    msg = _error(tmp_path / "two", "two")
    assert msg.startswith("imu.file: needs the optional package rosbags") and "pip install 'sarnav[ros]'" in msg


def test_manifest_states_the_body_axes_and_the_topic(tmp_path):
    root = tmp_path / "rec"
    ForeignFlight(3, duration=2, gnss_until=1.0, gap=(5.0, 5.5)).write(root)
    text = (root / "flight.toml").read_text()
    (root / "flight.toml").write_text(text.replace('file = "imu.csv"', 'file = "imu.csv"\nbody_axes = "ENU"'))
    with pytest.raises(ConfigError, match=r"^flight.toml:imu.body_axes: must be 'FRD' .* or 'FLU'"):
        read_recording(root)
    (root / "flight.toml").write_text(text.replace('file = "imu.csv"', 'file = "imu.csv"\nbody_axes = "FLU"'))
    flu = read_recording(root).imu
    (root / "flight.toml").write_text(text)
    frd = read_recording(root).imu
    np.testing.assert_array_equal(flu.accel, frd.accel * [1, -1, -1])


# --- corrupt logs (hypothesis): one line or a correct read -------------------------------------------------------
hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


def _corrupt(data: bytes, flips, cut) -> bytes:
    b = bytearray(data)
    for pos, val in flips:
        if b:
            b[pos % len(b)] = val
    return bytes(b[: max(0, len(b) - cut)])


def _check(path: Path, name: str):
    try:
        log = read_imu(path, name, "rates", 0.0, 100.0, body_axes="FLU" if name.endswith(".bag") else "FRD")
    except (InputDataError, ConfigError) as err:
        assert "\n" not in str(err)
        return
    assert np.all(np.isfinite(log.accel)) and np.all(np.isfinite(log.gyro)) and np.all(np.diff(log.time) > 0)


@pytest.mark.parametrize("examples", [20, pytest.param(200, marks=pytest.mark.slow)])
@pytest.mark.parametrize("name", ["imu.csv", "imu.nc", "imu.bag"])
def test_corrupt_logs_are_one_line_or_a_correct_read(tmp_path_factory, name, examples):
    folder = tmp_path_factory.mktemp("corrupt")
    t, a, g = _samples(30)
    writer = {"imu.csv": _write_csv, "imu.nc": _write_nc, "imu.bag": WRITERS["imu.bag"]}[name]
    writer(folder / name, t, a, g)
    clean = (folder / name).read_bytes()

    @settings(max_examples=examples, deadline=None, suppress_health_check=list(HealthCheck),
              derandomize=True)
    @given(flips=st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), max_size=8),
           cut=st.integers(0, 64))
    def check(flips, cut):
        (folder / name).write_bytes(_corrupt(clean, flips, cut))
        _check(folder / name, name)

    check()

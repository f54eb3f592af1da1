"""The CSV logs of a recording as typed records on the recording's time axis (docs/recording.md §3-§6).

IMU (rates or increments, body axes FRD), altimeter (altitude above the origin's level, or WGS-84 height), GNSS
(NED or geodetic position, optional velocity, 1-sigma), truth (the issue's columns), the reference points and, for an
exported recording, the offsets its world added to the image-derived measurements. Columns, units and the one-line
errors: ``recording.tables``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sarkit.wgs84 as wgs84

from sarnav.errors import InputDataError
from sarnav.io.frames import ecef_to_ned
from sarnav.recording.imu_formats import read_imu_columns, to_frd
from sarnav.recording.tables import choose_columns, read_columns

__all__ = ["IMU_COLUMNS", "ImuLog", "AltimeterLog", "GnssLog", "TruthLog", "ReferencePoints", "read_imu",
           "read_altimeter", "read_gnss", "read_truth", "read_points", "read_sar_offsets", "TRUTH_COLUMNS",
           "TRUTH_EXTRA", "POINT_COLUMNS", "OFFSET_COLUMNS"]

_XYZ = ("x", "y", "z")
_NED = ("north", "east", "down")
#: the IMU log's columns for each ``imu.samples`` kind (units in the names)
IMU_COLUMNS = {
    "rates": ("time_s",) + tuple(f"accel_{a}_mps2" for a in _XYZ) + tuple(f"gyro_{a}_radps" for a in _XYZ),
    "increments": ("time_s",) + tuple(f"dv_{a}_mps" for a in _XYZ) + tuple(f"dtheta_{a}_rad" for a in _XYZ),
}
TRUTH_COLUMNS = ("time", "north", "east", "down", "v_north", "v_east", "v_down", "roll", "pitch", "yaw")
#: optional truth columns (SI): the truth IMU biases and measurement biases
TRUTH_EXTRA = (tuple(f"accel_bias_{a}" for a in _XYZ) + tuple(f"gyro_bias_{a}" for a in _XYZ)
               + ("b_alt", "b_range", "b_cross"))
POINT_COLUMNS = (("aperture", "point") + tuple(f"anchor_{a}_m" for a in _NED) + tuple(f"map_{a}_m" for a in _NED)
                 + tuple(f"map_sigma_{a}_m" for a in _NED))
OFFSET_COLUMNS = ("aperture", "point", "range_offset_m", "cross_offset_m")
_GNSS_POSITION = (tuple(f"{a}_m" for a in _NED), ("latitude_deg", "longitude_deg", "height_m"))
_GNSS_SIGMA = tuple(f"sigma_{a}_m" for a in _NED)
_GNSS_VELOCITY = tuple(f"v_{a}_mps" for a in _NED)
_GNSS_VSIGMA = tuple(f"sigma_v_{a}_mps" for a in _NED)


def _stack(cols: dict, names) -> np.ndarray:
    return np.stack([cols[n] for n in names], axis=1)


@dataclass(frozen=True)
class ImuLog:
    """IMU samples on the recording's time axis. ``kind`` "rates": ``accel`` [m/s^2] (specific force) and ``gyro``
    [rad/s] (angular rate) measured at ``time``; "increments": ``dv`` [m/s] and ``dtheta`` [rad] integrated over
    (previous time, time] (the first row over the nominal interval 1 / rate_hz). All (N, 3) in body axes FRD."""

    time: np.ndarray
    kind: str
    accel: np.ndarray | None = None
    gyro: np.ndarray | None = None
    dv: np.ndarray | None = None
    dtheta: np.ndarray | None = None
    rate_hz: float = 0.0

    def rates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(times (N,), specific force (N, 3), angular rate (N, 3)): the samples as rates; increments become the mean
        rate of their interval, placed at its middle."""
        if self.kind == "rates":
            return self.time, self.accel, self.gyro
        dt = np.diff(self.time, prepend=self.time[0] - 1.0 / self.rate_hz)
        return self.time - 0.5 * dt, self.dv / dt[:, None], self.dtheta / dt[:, None]


def read_imu(path, name: str, kind: str, clock_offset: float, rate_hz: float, body_axes: str = "FRD",
             topic: str | None = None) -> ImuLog:
    """The IMU log ``path`` (``name`` in errors; CSV, netCDF / HDF5 or a ROS bag: ``imu_formats``) of ``kind``
    ("rates" / "increments") in ``body_axes`` ("FRD" / "FLU"); its times + ``clock_offset``, its samples in FRD."""
    cols = read_imu_columns(path, name, IMU_COLUMNS[kind], topic)
    t = cols["time_s"] + clock_offset
    names = IMU_COLUMNS[kind][1:]
    a, g = to_frd(body_axes, _stack(cols, names[:3])), to_frd(body_axes, _stack(cols, names[3:]))
    if kind == "rates":
        return ImuLog(t, kind, accel=a, gyro=g, rate_hz=rate_hz)
    return ImuLog(t, kind, dv=a, dtheta=g, rate_hz=rate_hz)


@dataclass(frozen=True)
class AltimeterLog:
    """Altimeter measurements: ``altitude`` (N,) [m] above the level plane of the frame's origin (= -down), at
    ``time`` (N,) [s]."""

    time: np.ndarray
    altitude: np.ndarray


def read_altimeter(path, name: str, origin_height: float) -> AltimeterLog:
    """``time_s`` and ``altitude_m`` (above the origin's level) or ``height_m`` (WGS-84, less the origin's height)."""
    cols = read_columns(path, name, ("time_s",), ("altitude_m", "height_m"), time_column="time_s")
    which = choose_columns(cols, name, (("altitude_m",), ("height_m",)))
    alt = cols["altitude_m"] if which == 0 else cols["height_m"] - origin_height
    return AltimeterLog(cols["time_s"], alt)


@dataclass(frozen=True)
class GnssLog:
    """GNSS fixes: ``position`` (N, 3) NED [m] and its 1-sigma ``position_sigma``; ``velocity`` (N, 3) NED [m/s] and
    ``velocity_sigma``, or None."""

    time: np.ndarray
    position: np.ndarray
    position_sigma: np.ndarray
    velocity: np.ndarray | None = None
    velocity_sigma: np.ndarray | None = None


def read_gnss(path, name: str, origin) -> GnssLog:
    """NED (``north_m``...) or geodetic (``latitude_deg``, ``longitude_deg``, ``height_m``, WGS-84) positions,
    converted to the frame at ``origin``; per-axis 1-sigma; optional velocity with its 1-sigma."""
    optional = _GNSS_POSITION[0] + _GNSS_POSITION[1] + _GNSS_VELOCITY + _GNSS_VSIGMA
    cols = read_columns(path, name, ("time_s",) + _GNSS_SIGMA, optional, time_column="time_s")
    which = choose_columns(cols, name, _GNSS_POSITION)
    pos = _stack(cols, _GNSS_POSITION[which])
    if which == 1:
        pos = ecef_to_ned(wgs84.geodetic_to_cartesian(pos), origin)
    sig = _stack(cols, _GNSS_SIGMA)
    _positive(sig, name, _GNSS_SIGMA, cols["time_s"])
    vel = vsig = None
    if any(c in cols for c in _GNSS_VELOCITY + _GNSS_VSIGMA):
        choose_columns(cols, name, (_GNSS_VELOCITY + _GNSS_VSIGMA,))
        vel, vsig = _stack(cols, _GNSS_VELOCITY), _stack(cols, _GNSS_VSIGMA)
        _positive(vsig, name, _GNSS_VSIGMA, cols["time_s"])
    return GnssLog(cols["time_s"], pos, sig, vel, vsig)


def _positive(values: np.ndarray, name: str, columns, time) -> None:
    bad = np.argwhere(~(values > 0))
    if bad.size:
        i, j = bad[0]
        raise InputDataError(f"{name}:{i + 2}:{columns[j]}", f"must be > 0 (a 1-sigma), got {values[i, j]!r}")


@dataclass(frozen=True)
class TruthLog:
    """The true trajectory: ``position`` (N, 3) NED [m], ``velocity`` (N, 3) [m/s], ``rpy`` (N, 3) roll, pitch, yaw
    [rad] (3-2-1, body FRD to NED) at ``time``; ``extra``: the optional columns present (TRUTH_EXTRA)."""

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    rpy: np.ndarray
    extra: dict = field(default_factory=dict)


def read_truth(path, name: str) -> TruthLog:
    cols = read_columns(path, name, TRUTH_COLUMNS, TRUTH_EXTRA, time_column="time")
    return TruthLog(cols["time"], _stack(cols, TRUTH_COLUMNS[1:4]), _stack(cols, TRUTH_COLUMNS[4:7]),
                    _stack(cols, TRUTH_COLUMNS[7:10]), {k: cols[k] for k in TRUTH_EXTRA if k in cols})


@dataclass(frozen=True)
class ReferencePoints:
    """Per aperture u and point k: ``anchors`` (U, T, 3) where the reference product puts the point (NED [m]: the
    chip is cut there in the reference image), ``map`` (U, T, 3) where the map says it is (the position the
    navigator predicts with) and ``map_sigma`` (U, T, 3) that position's 1-sigma [m]."""

    anchors: np.ndarray
    map: np.ndarray
    map_sigma: np.ndarray


def _grid(cols: dict, name: str, apertures: int) -> tuple[np.ndarray, int]:
    """The (aperture, point) rows as indices into a (U, T) grid: every aperture 0..U-1 with points 0..T-1, once."""
    a, k = cols["aperture"], cols["point"]
    for col, v in (("aperture", a), ("point", k)):
        bad = np.flatnonzero((v != np.round(v)) | (v < 0))
        if bad.size:
            raise InputDataError(f"{name}:{bad[0] + 2}:{col}", f"must be an integer >= 0, got {v[bad[0]]!r}")
    a, k = a.astype(np.int64), k.astype(np.int64)
    counts = np.bincount(a, minlength=apertures)
    if a.max() >= apertures:
        i = int(np.argmax(a >= apertures))
        raise InputDataError(f"{name}:{i + 2}:aperture", f"{a[i]} but the manifest has {apertures} apertures")
    if counts.min() == 0:
        raise InputDataError(f"{name}:aperture", f"aperture {int(np.argmin(counts))} has no reference point")
    T = int(counts[0])
    for u in range(apertures):
        got = sorted(k[a == u].tolist())
        if got != list(range(T)):
            raise InputDataError(f"{name}:point", f"aperture {u} has points {got}; every aperture needs points 0 to "
                                 f"{T - 1} (as many as aperture 0), each once")
    return a * T + k, T


def read_points(path, name: str, apertures: int) -> ReferencePoints:
    """The reference points of ``apertures`` apertures (POINT_COLUMNS); sigmas >= 0."""
    cols = read_columns(path, name, POINT_COLUMNS)
    idx, T = _grid(cols, name, apertures)
    out = []
    for prefix in ("anchor", "map", "map_sigma"):
        v = np.empty((apertures * T, 3))
        v[idx] = _stack(cols, [f"{prefix}_{a}_m" for a in _NED])
        out.append(v.reshape(apertures, T, 3))
    bad = np.argwhere(~(out[2].reshape(-1, 3)[idx] >= 0))
    if bad.size:
        raise InputDataError(f"{name}:{bad[0][0] + 2}:map_sigma_{_NED[bad[0][1]]}_m", "must be >= 0 m (a 1-sigma; "
                             "0: the map is exact)")
    return ReferencePoints(*out)


def read_sar_offsets(path, name: str, apertures: int, points: int) -> np.ndarray:
    """(U, T, 2) the range and cross-range offsets [m] an exported recording's world added (OFFSET_COLUMNS)."""
    cols = read_columns(path, name, OFFSET_COLUMNS)
    idx, T = _grid(cols, name, apertures)
    if T != points:
        raise InputDataError(f"{name}:point", f"has {T} points per aperture, the reference points {points}")
    out = np.empty((apertures * T, 2))
    out[idx] = _stack(cols, OFFSET_COLUMNS[2:])
    return out.reshape(apertures, T, 2)

"""CPHD 1.0.1 (NGA.STND.0068-1) writer and reader for monostatic collects, through sarkit.

Written (one channel, FX domain, SGN = -1, CF8 or CF16 samples; docs/io.md lists every field):
the range-compressed pulses are turned into a phase history referred to a fixed scene reference
point (SRP = IARP = the scenario's reference point, ``sarnav.signal.phase_history``), the PVPs
TxTime, TxPos, TxVel, RcvTime, RcvPos, RcvVel, SRPPos, aFDOP, aFRR1, aFRR2, FX1, FX2, TOA1, TOA2,
TDTropoSRP, SC0, SCSS, SIGNAL; SceneCoordinates with a planar reference surface (uIAX = east,
uIAY = north at the SRP), image area, corner points and an image grid; Dwell (constant COD time and
dwell time polynomials) and the ReferenceGeometry sarkit computes from the PVPs.

Stop-and-hop (the simulator's model): TxPos = RcvPos = the pulse's antenna position and RcvTime =
TxTime + 2 R_ref / c; the reader takes the ARP as (TxPos + RcvPos) / 2 and the reference range as
(|TxPos - SRP| + |RcvPos - SRP|) / 2, so a file written here reads back to the same positions.
"""

from __future__ import annotations

import datetime
import math
from dataclasses import replace

import lxml.etree as et
import numpy as np
import sarkit.cphd as skcphd
import sarkit.wgs84 as wgs84

from sarnav.errors import ConfigError, InputDataError
from sarnav.signal.data import PulseData
from sarnav.signal.phase_history import (PhaseHistory, default_range_axis, phase_history_to_pulses,
                                         pulses_to_phase_history)
from sarnav.imaging.grid import PlaneGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.io.cphd_checks import field_name
from sarnav.io.cphd_read import MAX_GRID_AXIS, CphdCollect, conversion_bytes, need, open_collect, read_budget
from sarnav.io.frames import check_reference_point, ned_basis, ned_to_ecef

__all__ = ["write_collect", "read_collect", "read_phase_history", "read_filter", "image_grid", "collect_grid",
           "read_collect_header", "open_collect", "CPHD_NS"]

CPHD_NS = "http://api.nsgreg.nga.mil/schema/cphd/1.0.1"
_C = 299792458.0
_FORMATS = {"CF8": np.complex64, "CF16": np.complex128}
_PVP_FIELDS = (  # (name, words): F8 scalars and XYZ triples, in file order
    ("TxTime", 1), ("TxPos", 3), ("TxVel", 3), ("RcvTime", 1), ("RcvPos", 3), ("RcvVel", 3), ("SRPPos", 3),
    ("aFDOP", 1), ("aFRR1", 1), ("aFRR2", 1), ("FX1", 1), ("FX2", 1), ("TOA1", 1), ("TOA2", 1),
    ("TDTropoSRP", 1), ("SC0", 1), ("SCSS", 1), ("SIGNAL", 1))


def _pvp_xml() -> dict:
    out, offset = {}, 0
    for name, words in _PVP_FIELDS:
        fmt = "X=F8;Y=F8;Z=F8;" if words == 3 else ("I8" if name == "SIGNAL" else "F8")
        out[name] = {"Offset": offset, "Size": words, "dtype": skcphd.binary_format_string_to_dtype(fmt)}
        offset += words
    return out


def _to_ecef(rc: PulseData, reference_point, frame: str, scene_point=None) -> tuple[np.ndarray, np.ndarray]:
    """(antenna positions, SRP) in ECEF: the SRP is the reference point, or ``scene_point`` (NED at the reference
    point when frame = "ned", ECEF when frame = "ecef")."""
    ref = check_reference_point(reference_point)
    pos = np.asarray(rc.positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[1] != 3 or not np.all(np.isfinite(pos)):
        raise InputDataError("pulses.positions", "must be a finite (P, 3) array (found NaN/inf or a bad shape)")
    if frame not in ("ned", "ecef"):
        raise ConfigError("frame", f"must be 'ned' or 'ecef', got {frame!r}")
    if scene_point is None:
        srp = wgs84.geodetic_to_cartesian(ref)
    else:
        sp = np.asarray(scene_point, dtype=np.float64)
        if sp.shape != (3,) or not np.all(np.isfinite(sp)):
            raise ConfigError("scene_point", f"must be 3 finite coordinates [m], got {scene_point!r}")
        srp = ned_to_ecef(sp, ref) if frame == "ned" else sp
    return (ned_to_ecef(pos, ref) if frame == "ned" else pos), srp


def _compressed(pulses: PulseData, params, window) -> PulseData:
    if not isinstance(pulses, PulseData):
        raise InputDataError("pulses", f"must be a PulseData, got {type(pulses).__name__}")
    if pulses.compressed:
        return pulses
    if params is not None and pulses.sample_rate is None:
        pulses = replace(pulses, params=params, **params.pulse_data_fields())
    if pulses.sample_rate is None:
        raise ConfigError("params", "raw (uncompressed) pulses need the RadarParams (or their sample_rate, bandwidth "
                          "and pulse_length) to be range compressed")
    return range_compress(pulses, window=window)


def _pvps(ph: PhaseHistory, ecef: np.ndarray, srp: np.ndarray, times: np.ndarray, chirp_rate, vel=None) -> np.ndarray:
    n = ph.data.shape[1]
    dtype = np.dtype([(name, ">i8" if name == "SIGNAL" else (">f8", (3,)) if words == 3 else ">f8")
                      for name, words in _PVP_FIELDS])
    pvp = np.zeros(ph.n_pulses, dtype=dtype)
    t = times - times[0]
    if vel is None:
        vel = np.gradient(ecef, t, axis=0) if ecef.shape[0] > 1 else np.zeros_like(ecef)
    pvp["TxTime"] = t
    pvp["RcvTime"] = t + 2.0 * ph.ref_range / _C
    pvp["TxPos"] = pvp["RcvPos"] = ecef
    pvp["TxVel"] = pvp["RcvVel"] = vel
    pvp["SRPPos"] = srp
    los = (ecef - srp) / np.linalg.norm(ecef - srp, axis=1)[:, None]
    pvp["aFDOP"] = -2.0 / _C * np.sum(vel * los, axis=1)
    fxc = ph.fx0 + 0.5 * (n - 1) * ph.fx_step
    if chirp_rate:
        pvp["aFRR1"] = 2.0 * fxc / (_C * chirp_rate)
        pvp["aFRR2"] = 2.0 / (_C * chirp_rate)
    pvp["FX1"] = ph.fx0
    pvp["FX2"] = ph.fx0 + (n - 1) * ph.fx_step
    pvp["SC0"] = ph.fx0
    pvp["SCSS"] = ph.fx_step
    pvp["TOA1"] = ph.toa[:, 0]
    pvp["TOA2"] = ph.toa[:, 1]
    pvp["SIGNAL"] = 1
    return pvp


def _image_area(srp_llh, half_x: float, half_y: float):
    origin, rot = ned_basis(srp_llh)
    uiax, uiay = rot[:, 1], rot[:, 0]                           # east, north (uIAX x uIAY = up)
    x1y1, x2y2 = np.array([-half_x, -half_y]), np.array([half_x, half_y])
    verts = np.array([[-half_x, -half_y], [-half_x, half_y], [half_x, half_y], [half_x, -half_y]])
    corners = wgs84.cartesian_to_geodetic(origin + verts[:, :1] * uiax + verts[:, 1:] * uiay)[:, :2]
    area = {"X1Y1": x1y1, "X2Y2": x2y2, "Polygon": verts}
    return uiax, uiay, area, corners


def _xml(ph, pvp, ecef_srp, llh, half, spacing, n_samples, fmt, start) -> et._ElementTree:
    root = et.Element(f"{{{CPHD_NS}}}CPHD")
    ew = skcphd.ElementWrapper(root)
    ew["CollectionID"] = {"CollectorName": "sarnav", "CoreName": "sarnav-simulated-collect",
                          "CollectType": "MONOSTATIC", "RadarMode": {"ModeType": "SPOTLIGHT"},
                          "Classification": "UNCLASSIFIED", "ReleaseInfo": "UNRESTRICTED"}
    ew["Global"] = {"DomainType": "FX", "SGN": -1,
                    "Timeline": {"CollectionStart": start, "TxTime1": float(pvp["TxTime"].min()),
                                 "TxTime2": float(pvp["TxTime"].max())},
                    "FxBand": {"FxMin": float(pvp["FX1"].min()), "FxMax": float(pvp["FX2"].max())},
                    "TOASwath": {"TOAMin": float(pvp["TOA1"].min()), "TOAMax": float(pvp["TOA2"].max())}}
    uiax, uiay, area, corners = _image_area(llh, *half)
    nl = max(2, int(2 * half[0] / spacing) + 1)
    ns = max(2, int(2 * half[1] / spacing) + 1)
    ew["SceneCoordinates"] = {
        "EarthModel": "WGS_84", "IARP": {"ECF": ecef_srp, "LLH": llh},
        "ReferenceSurface": {"Planar": {"uIAX": uiax, "uIAY": uiay}},
        "ImageArea": area, "ImageAreaCornerPoints": corners,
        "ImageGrid": {"IARPLocation": np.array([0.5 * (nl - 1), 0.5 * (ns - 1)]),
                      "IAXExtent": {"LineSpacing": spacing, "FirstLine": 0, "NumLines": nl},
                      "IAYExtent": {"SampleSpacing": spacing, "FirstSample": 0, "NumSamples": ns}}}
    ew["Data"] = {"SignalArrayFormat": fmt, "NumBytesPVP": pvp.dtype.itemsize, "NumCPHDChannels": 1,
                  "Channel": [{"Identifier": "1", "NumVectors": ph.n_pulses, "NumSamples": n_samples,
                               "SignalArrayByteOffset": 0, "PVPArrayByteOffset": 0}],
                  "NumSupportArrays": 0}
    fx1, fx2 = float(pvp["FX1"].min()), float(pvp["FX2"].max())
    ew["Channel"] = {"RefChId": "1", "FXFixedCPHD": True, "TOAFixedCPHD": bool(np.ptp(pvp["TOA1"]) == 0
                                                                                and np.ptp(pvp["TOA2"]) == 0),
                     "SRPFixedCPHD": True,
                     "Parameters": [{"Identifier": "1", "RefVectorIndex": ph.n_pulses // 2, "FXFixed": True,
                                     "TOAFixed": bool(np.ptp(pvp["TOA1"]) == 0 and np.ptp(pvp["TOA2"]) == 0),
                                     "SRPFixed": True, "SignalNormal": True,
                                     "Polarization": {"TxPol": "V", "RcvPol": "V"},
                                     "FxC": 0.5 * (fx1 + fx2), "FxBW": fx2 - fx1,
                                     "TOASaved": float(pvp["TOA2"].max() - pvp["TOA1"].min()),
                                     "DwellTimes": {"CODId": "1", "DwellId": "1"},
                                     "ImageArea": area}]}
    ew["PVP"] = _pvp_xml()
    t_mid = 0.5 * float(pvp["TxTime"].min() + pvp["TxTime"].max())
    ew["Dwell"] = {"NumCODTimes": 1, "CODTime": [{"Identifier": "1", "CODTimePoly": np.array([[t_mid]])}],
                   "NumDwellTimes": 1,
                   "DwellTime": [{"Identifier": "1", "DwellTimePoly": np.array([[float(np.ptp(pvp["TxTime"]))]])}]}
    tree = root.getroottree()
    ew["ReferenceGeometry"] = skcphd.compute_reference_geometry(tree, pvp)
    return tree


def write_collect(path, pulses: PulseData, reference_point, *, params=None, frame: str = "ned",
                  window=None, image_half_extent=None, image_spacing: float | None = None,
                  signal_format: str = "CF8", collection_start: datetime.datetime | None = None,
                  scene_point=None, velocities=None) -> PhaseHistory:
    """Write a collect as a CPHD 1.0.1 file (module doc); returns the phase history written.

    Parameters
    ----------
    path : output file (e.g. ``out / "collect.cphd"``).
    pulses : raw (range compressed here with ``window``: their own radar fields, else ``params``'s) or
        range-compressed ``PulseData``; needs a wavelength (``pulses.carrier_wavelength``).
    reference_point : (lat deg, lon deg, hae m) of the scene reference point: the SRP / IARP, and
        the origin of the NED frame when ``frame="ned"``.
    frame : "ned" (positions relative to the reference point, the simulations' frame) or "ecef".
    scene_point : (3,) the SRP / IARP instead of the reference point itself (NED at the reference
        point, or ECEF with ``frame="ecef"``): the centre of the imaged scene, so that the file's
        image area and grid cover it.
    image_half_extent : (x, y) half sizes [m] of the image area along uIAX (east) and uIAY
        (north); default a square of half the slant swath. image_spacing : image-grid spacing [m];
        default the range sample spacing.
    signal_format : "CF8" (complex64) or "CF16" (complex128).
    velocities : (P, 3) the antenna's velocities [m/s] in the positions' frame (the PVPs TxVel, RcvVel); default
        the positions' gradient.
    """
    if signal_format not in _FORMATS:
        raise ConfigError("signal_format", f"must be one of {tuple(_FORMATS)}, got {signal_format!r}")
    rc = _compressed(pulses, params, window)
    ecef, srp = _to_ecef(rc, reference_point, frame, scene_point)
    llh = wgs84.cartesian_to_geodetic(srp)
    times = np.asarray(rc.pulse_times, dtype=np.float64)
    if times.size > 1 and np.any(np.diff(times) <= 0):
        raise InputDataError("pulses.pulse_times", "must be strictly increasing")
    ph = pulses_to_phase_history(replace(rc, positions=ecef), np.linalg.norm(ecef - srp, axis=1))
    chirp_rate = rc.chirp_rate
    vel = None
    if velocities is not None:
        vel = np.asarray(velocities, dtype=np.float64)
        if vel.shape != ecef.shape or not np.all(np.isfinite(vel)):
            raise InputDataError("velocities", f"must be a finite {ecef.shape} array like the positions")
        vel = vel @ ned_basis(reference_point)[1].T if frame == "ned" else vel
    pvp = _pvps(ph, ecef, srp, times, chirp_rate, vel)
    swath = float(rc.slant_range[-1] - rc.slant_range[0])
    half = (0.25 * swath, 0.25 * swath) if image_half_extent is None else tuple(float(h) for h in image_half_extent)
    spacing = float(rc.slant_range[1] - rc.slant_range[0]) if image_spacing is None else float(image_spacing)
    if not all(math.isfinite(h) and h > 0 for h in half) or len(half) != 2:
        raise ConfigError("image_half_extent", f"must be two finite values > 0 m, got {image_half_extent!r}")
    if not (math.isfinite(spacing) and spacing > 0):
        raise ConfigError("image_spacing", f"must be finite and > 0 m, got {image_spacing!r}")
    start = collection_start or datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)
    tree = _xml(ph, pvp, srp, llh, half, spacing, ph.data.shape[1], signal_format, start)
    with open(path, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=tree)) as w:
        w.write_signal("1", ph.data.astype(_FORMATS[signal_format]))
        w.write_pvp("1", pvp)
    return ph


def read_phase_history(path, *, channel=None, pulses=None, tropo: str = "in-data",
                       ) -> tuple[PhaseHistory, object, np.ndarray]:
    """(PhaseHistory of channel ``channel`` (default the first), vectors ``pulses = (start, stop)`` (default all),
    ECEF; the XML helper; the SRP ECEF of the middle vector). Formats, checks and ``tropo``: ``io.cphd_read``."""
    c = open_collect(path, channel=channel, pulses=pulses, tropo=tropo)
    return c.phase_history(), c.xml, c.srp


def _num(xml, path: str, what: str, integer: bool = False) -> float:
    v = need(xml, path, what)
    ok = isinstance(v, (int, np.integer)) if integer else isinstance(v, (int, float, np.number))
    if not ok or not math.isfinite(v):
        raise InputDataError(field_name(path), f"must be a finite {'integer' if integer else 'number'}, got {v!r}")
    return v if integer else float(v)


def _vec(xml, path: str, n: int, what: str) -> np.ndarray:
    v = need(xml, path, what)
    if not (isinstance(v, np.ndarray) and v.shape == (n,) and np.all(np.isfinite(v))):
        raise InputDataError(field_name(path), f"must be {n} finite numbers, got {v!r}")
    return v


def _grid_axis(xml, g: str, ext: str, spacing: str, first: str, num: str, loc: float) -> np.ndarray:
    sp = _num(xml, g + f"{ext}/{{*}}{spacing}", "grid spacing")
    if not sp > 0:
        raise InputDataError(f"cphd.SceneCoordinates.ImageGrid.{ext}.{spacing}",
                             f"must be finite and > 0 m, got {sp!r}")
    n = _num(xml, g + f"{ext}/{{*}}{num}", "grid size", integer=True)
    if not 1 <= n <= MAX_GRID_AXIS:
        raise InputDataError(f"cphd.SceneCoordinates.ImageGrid.{ext}.{num}", f"must be an integer in [1, "
                             f"{MAX_GRID_AXIS}], got {n!r}")
    f0 = _num(xml, g + f"{ext}/{{*}}{first}", "first index", integer=True)
    if not (abs(loc) <= 2**40 and abs(f0) <= 2**40):
        raise InputDataError("cphd.SceneCoordinates.ImageGrid.IARPLocation", f"must be grid indices within 2^40, got "
                             f"{loc!r} (first {f0!r})")
    return (np.arange(n) + f0 - loc) * sp


def _default_grid(xml, srp) -> PlaneGrid:
    sc = "./{*}SceneCoordinates/{*}"
    iarp = _vec(xml, sc + "IARP/{*}ECF", 3, "SceneCoordinates/IARP/ECF")
    uiax = _vec(xml, sc + "ReferenceSurface/{*}Planar/{*}uIAX", 3, "planar reference surface uIAX")
    uiay = _vec(xml, sc + "ReferenceSurface/{*}Planar/{*}uIAY", 3, "planar reference surface uIAY")
    for name, v in (("uIAX", uiax), ("uIAY", uiay)):
        if abs(np.linalg.norm(v) - 1.0) > 1e-6:
            raise InputDataError(f"cphd.SceneCoordinates.ReferenceSurface.Planar.{name}", f"must be a unit vector, "
                                 f"got {v!r}")
    if abs(float(np.dot(uiax, uiay))) > 1e-6:
        raise InputDataError("cphd.SceneCoordinates.ReferenceSurface.Planar.uIAY", f"must be orthogonal to uIAX "
                             f"(|uIAX . uIAY| <= 1e-6), got {float(np.dot(uiax, uiay)):.3g}")
    if xml.element_tree.find(sc + "ImageGrid") is not None:
        g = sc + "ImageGrid/{*}"
        loc = _vec(xml, g + "IARPLocation", 2, "grid indices of the IARP")
        lines = _grid_axis(xml, g, "IAXExtent", "LineSpacing", "FirstLine", "NumLines", float(loc[0]))
        samples = _grid_axis(xml, g, "IAYExtent", "SampleSpacing", "FirstSample", "NumSamples", float(loc[1]))
    else:
        x1y1 = _vec(xml, sc + "ImageArea/{*}X1Y1", 2, "SceneCoordinates/ImageArea/X1Y1")
        x2y2 = _vec(xml, sc + "ImageArea/{*}X2Y2", 2, "SceneCoordinates/ImageArea/X2Y2")
        bw = _num(xml, "./{*}Channel/{*}Parameters/{*}FxBW", "Channel/Parameters/FxBW")
        sp = _C / (2.0 * bw) if bw > 0 else float("nan")
        size = (x2y2 - x1y1) / sp
        if not (np.all(np.isfinite(size)) and np.all(size > 0) and np.all(size < MAX_GRID_AXIS)):
            raise InputDataError("cphd.SceneCoordinates.ImageArea.X2Y2", f"must exceed X1Y1 by at most {MAX_GRID_AXIS}"
                                 f" samples of c / (2 FxBW) = {sp:.4g} m, got {x1y1!r} to {x2y2!r}")
        lines = np.arange(x1y1[0], x2y2[0] + 0.5 * sp, sp)
        samples = np.arange(x1y1[1], x2y2[1] + 0.5 * sp, sp)
    return PlaneGrid(iarp, uiax, uiay, lines, samples, "iax", "iay")


def collect_grid(c: CphdCollect) -> PlaneGrid:
    """The default image grid of the opened collect ``c`` (``io.cphd_read.open_collect``): its SceneCoordinates
    ImageGrid, else its ImageArea at c / (2 FxBW), in ECEF (:func:`read_collect`)."""
    return _default_grid(c.xml, c.srp)


def read_collect_header(path, *, channel=None, pulses=None, tropo: str = "in-data") -> tuple[CphdCollect, PlaneGrid]:
    """(the checked header and PVPs of ``path``'s channel and vectors, ``io.cphd_read.open_collect``; its default
    image grid, :func:`collect_grid`): what ``io.cphd_stream.image_collect`` images, nothing of the signal read."""
    c = open_collect(path, channel=channel, pulses=pulses, tropo=tropo)
    return c, collect_grid(c)


def read_collect(path, range_axis=None, *, oversample: float = 4.0, filter=None, channel=None, pulses=None,
                 tropo: str = "in-data", budget: float | None = None) -> tuple[PulseData, PlaneGrid]:
    """Read an FX-domain CPHD into memory: (range-compressed PulseData in ECEF, default image grid).

    The pulses land on one absolute range axis (``range_axis`` or the default of
    :func:`sarnav.signal.phase_history.default_range_axis`), wavelength c / FxC. The default grid is
    the file's SceneCoordinates image grid (IARP + line uIAX + sample uIAY, ECEF), or its image area
    sampled at c / (2 FxBW) when the file has no image grid. ``filter``: optional (N,) weights of
    the frequency samples (``phase_history_to_pulses``; a phase history shorter than the filter is
    an error). ``channel`` (identifier, default the first), ``pulses`` = (start, stop) vectors (default all),
    ``tropo`` (TDTropoSRP: "in-data", the default, or "compensated"): ``io.cphd_read``. ``budget`` [bytes]: the
    most memory the read may take (estimated before reading, conservatively); default half the machine's physical
    memory (``io.cphd_read.read_budget``), so that a read too large is one line instead of the kernel killing the
    process; larger collects are imaged in blocks by ``io.cphd_stream.image_collect``.

    Raises
    ------
    InputDataError naming the missing or bad field (``cphd.PVP.SRPPos``, ``cphd.Global.DomainType``, ...);
    ConfigError naming ``channel``, ``pulses``, ``tropo`` or ``budget``.
    """
    c = open_collect(path, channel=channel, pulses=pulses, tropo=tropo)
    m = default_range_axis(c.header(), oversample).size if range_axis is None else np.size(range_axis)
    budget = read_budget() if budget is None else budget
    need_bytes = c.n_pulses * (conversion_bytes(c.n_samples, m, c.raw_itemsize) + 16 * m)
    if not need_bytes <= budget:
        raise ConfigError("budget", f"reading {c.n_pulses} vectors x {c.n_samples} samples into memory takes "
                          f"~{need_bytes / 2**30:.3g} GiB, over the budget of {budget / 2**30:.3g} GiB: read a "
                          "range of vectors (pulses=) or image the file in blocks (io.cphd_stream.image_collect)")
    rc = phase_history_to_pulses(c.phase_history(), range_axis, wavelength=_C / c.fxc, oversample=oversample,
                                 filter=filter, metadata={"source": "cphd", "file": str(path), "channel": c.channel})
    return rc, _default_grid(c.xml, c.srp)


def read_filter(path, field: str = "filter") -> np.ndarray:
    """The frequency-sample weights for :func:`read_collect` from the ``.npy`` file ``path``: a 1-D array of numbers
    (no pickles). ConfigError naming ``field`` for a file that cannot be read or holds anything else."""
    try:
        h = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise ConfigError(field, f"cannot read {str(path)!r} as a .npy array ({err})") from None
    if h.ndim != 1 or h.dtype.kind not in "biufc":
        raise ConfigError(field, f"must hold a 1-D array of weights, got shape {h.shape} dtype {h.dtype}")
    return h


def image_grid(grid: PlaneGrid, spacing=None, extent=None) -> PlaneGrid:
    """``grid`` (a CPHD's image grid, ``read_collect``) resampled on the same plane about the same centre
    (:meth:`~sarnav.imaging.grid.PlaneGrid.resampled`: ``spacing`` [m] along both axes, ``extent`` (x, y) or one
    size [m]; defaults the grid's own)."""
    return grid.resampled(spacing, extent)

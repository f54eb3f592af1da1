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
from sarnav.signal.phase_history import PhaseHistory, phase_history_to_pulses, pulses_to_phase_history
from sarnav.imaging.grid import PlaneGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.io.frames import check_reference_point, ecef_to_ned, ned_basis, ned_to_ecef

__all__ = ["write_collect", "read_collect", "read_phase_history", "read_filter", "image_grid", "CPHD_NS"]

CPHD_NS = "http://api.nsgreg.nga.mil/schema/cphd/1.0.1"
_C = 299792458.0
_FORMATS = {"CF8": np.complex64, "CF16": np.complex128}
_PVP_FIELDS = (  # (name, words): F8 scalars and XYZ triples, in file order
    ("TxTime", 1), ("TxPos", 3), ("TxVel", 3), ("RcvTime", 1), ("RcvPos", 3), ("RcvVel", 3), ("SRPPos", 3),
    ("aFDOP", 1), ("aFRR1", 1), ("aFRR2", 1), ("FX1", 1), ("FX2", 1), ("TOA1", 1), ("TOA2", 1),
    ("TDTropoSRP", 1), ("SC0", 1), ("SCSS", 1), ("SIGNAL", 1))
_REQUIRED_PVPS = ("TxTime", "TxPos", "RcvPos", "SRPPos", "SC0", "SCSS", "TOA1", "TOA2")


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


def _need(xml, path: str, what: str):
    v = xml.load(path)
    if v is None:
        raise InputDataError(f"cphd.{path.replace('./{*}', '').replace('/{*}', '.')}", f"missing required {what}")
    return v


def read_phase_history(path) -> tuple[PhaseHistory, object, np.ndarray]:
    """(PhaseHistory of the first channel (ECEF), the XML helper, SRP ECEF of the reference vector)."""
    try:
        with open(path, "rb") as f, skcphd.Reader(f) as r:
            tree = r.metadata.xmltree
            xml = skcphd.XmlHelper(tree)
            dom = _need(xml, "./{*}Global/{*}DomainType", "Global/DomainType")
            if dom != "FX":
                raise InputDataError("cphd.Global.DomainType", f"only FX-domain CPHD is supported, got {dom!r}")
            ch = _need(xml, "./{*}Data/{*}Channel/{*}Identifier", "Data/Channel/Identifier")
            for name in _REQUIRED_PVPS:
                if tree.find(f"./{{*}}PVP/{{*}}{name}") is None:
                    raise InputDataError(f"cphd.PVP.{name}", "missing required per-vector parameter")
            sig, pvp = r.read_channel(ch)
            sgn = int(_need(xml, "./{*}Global/{*}SGN", "Global/SGN"))
    except InputDataError:
        raise
    except OSError as err:
        raise InputDataError("cphd", f"cannot read {str(path)!r}: {err.strerror or err}") from None
    except Exception as err:  # noqa: BLE001 - sarkit raises many kinds on a file that is not a CPHD
        raise InputDataError("cphd", f"{str(path)!r} is not a readable CPHD 1.x file ({type(err).__name__}: "
                             f"{str(err)[:120]})") from None
    for name in ("TxPos", "RcvPos", "SRPPos", "TxTime", "SC0", "SCSS", "TOA1", "TOA2"):
        bad = ~np.isfinite(np.asarray(pvp[name], dtype=np.float64).reshape(len(pvp), -1)).all(axis=1)
        if bad.any():
            raise InputDataError(f"cphd.PVP.{name}", f"must be finite: NaN/inf in vector {int(np.argmax(bad))}")
    if not np.all(np.isfinite(sig)):
        raise InputDataError("cphd.Signal", "contains NaN/inf samples")
    tx, rx, srp = pvp["TxPos"], pvp["RcvPos"], pvp["SRPPos"]
    ref = 0.5 * (np.linalg.norm(tx - srp, axis=1) + np.linalg.norm(rx - srp, axis=1))
    ph = PhaseHistory(np.asarray(sig), pvp["SC0"], pvp["SCSS"], 0.5 * (tx + rx), ref, pvp["TxTime"],
                      np.stack([pvp["TOA1"], pvp["TOA2"]], axis=1), sgn)
    return ph, xml, srp[len(srp) // 2]


def _default_grid(xml, srp) -> PlaneGrid:
    sc = "./{*}SceneCoordinates/{*}"
    iarp = _need(xml, sc + "IARP/{*}ECF", "SceneCoordinates/IARP/ECF")
    uiax = _need(xml, sc + "ReferenceSurface/{*}Planar/{*}uIAX", "planar reference surface uIAX")
    uiay = _need(xml, sc + "ReferenceSurface/{*}Planar/{*}uIAY", "planar reference surface uIAY")
    if xml.element_tree.find(sc + "ImageGrid") is not None:
        g = sc + "ImageGrid/{*}"
        lsp = float(xml.load(g + "IAXExtent/{*}LineSpacing"))
        ssp = float(xml.load(g + "IAYExtent/{*}SampleSpacing"))
        for name, v in (("IAXExtent.LineSpacing", lsp), ("IAYExtent.SampleSpacing", ssp)):
            if not (math.isfinite(v) and v > 0):
                raise InputDataError(f"cphd.SceneCoordinates.ImageGrid.{name}", f"must be finite and > 0 m, got {v!r}")
        loc = xml.load(g + "IARPLocation")
        lines = (np.arange(int(xml.load(g + "IAXExtent/{*}NumLines"))) + int(xml.load(g + "IAXExtent/{*}FirstLine"))
                 - loc[0]) * lsp
        samples = (np.arange(int(xml.load(g + "IAYExtent/{*}NumSamples")))
                   + int(xml.load(g + "IAYExtent/{*}FirstSample")) - loc[1]) * ssp
    else:
        x1y1 = _need(xml, sc + "ImageArea/{*}X1Y1", "SceneCoordinates/ImageArea/X1Y1")
        x2y2 = _need(xml, sc + "ImageArea/{*}X2Y2", "SceneCoordinates/ImageArea/X2Y2")
        bw = float(_need(xml, "./{*}Channel/{*}Parameters/{*}FxBW", "Channel/Parameters/FxBW"))
        sp = _C / (2.0 * bw)
        lines = np.arange(x1y1[0], x2y2[0] + 0.5 * sp, sp)
        samples = np.arange(x1y1[1], x2y2[1] + 0.5 * sp, sp)
    return PlaneGrid(iarp, uiax, uiay, lines, samples, "iax", "iay")


def read_collect(path, range_axis=None, *, oversample: float = 4.0, filter=None) -> tuple[PulseData, PlaneGrid]:
    """Read a monostatic FX-domain CPHD: (range-compressed PulseData in ECEF, default image grid).

    The pulses land on one absolute range axis (``range_axis`` or the default of
    :func:`sarnav.signal.phase_history.default_range_axis`), wavelength c / FxC. The default grid is
    the file's SceneCoordinates image grid (IARP + line uIAX + sample uIAY, ECEF), or its image area
    sampled at c / (2 FxBW) when the file has no image grid. ``filter``: optional (N,) weights of
    the frequency samples (``phase_history_to_pulses``; a phase history shorter than the filter is
    an error).

    Raises
    ------
    InputDataError naming the missing or bad field (``cphd.PVP.SRPPos``, ``cphd.Global.DomainType``, ...).
    """
    ph, xml, srp = read_phase_history(path)
    fxc = float(_need(xml, "./{*}Channel/{*}Parameters/{*}FxC", "Channel/Parameters/FxC"))
    rc = phase_history_to_pulses(ph, range_axis, wavelength=_C / fxc, oversample=oversample, filter=filter,
                                 metadata={"source": "cphd", "file": str(path)})
    return rc, _default_grid(xml, srp)


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

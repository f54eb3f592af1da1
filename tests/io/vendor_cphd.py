"""CPHD files written with sarkit directly, the way vendors store them (not with sarnav's writer): integer or float
samples with a per-vector AmpSF, SGN -1 or +1, per-vector SC0 / SCSS (FXFixed false), TOA windows, TDTropoSRP, one
or two channels. The phase history of point targets is the CPHD 1.0.1 signal model evaluated directly:

    S_k(f_n) = sum_t a_t exp(j 2 pi SGN f_n dtau_t,k),  dtau = (|Tx - p| + |Rcv - p|) / c - (|Tx - SRP| + |Rcv - SRP|) / c
               (+ TDTropoSRP when the delay is left in the data: tropo "in-data")

so every image formed from these files can be compared with the targets' known positions."""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field

import lxml.etree as et
import numpy as np
import sarkit.cphd as skcphd
import sarkit.wgs84 as wgs84

C = 299792458.0
NS = "http://api.nsgreg.nga.mil/schema/cphd/1.0.1"
REF = (34.0, -118.0, 10.0)
FC = 9.6e9
INT_BITS = {"CI2": 8, "CI4": 16, "CI8": 32, "CI16": 64}


def enu_basis(llh=REF):
    """(origin ECEF, east, north, up) at ``llh``."""
    o = wgs84.geodetic_to_cartesian(np.asarray(llh, float))
    lat, lon = np.radians(llh[0]), np.radians(llh[1])
    e = np.array([-np.sin(lon), np.cos(lon), 0.0])
    n = np.array([-np.sin(lat) * np.cos(lon), -np.sin(lat) * np.sin(lon), np.cos(lat)])
    return o, e, n, np.cross(e, n)


@dataclass
class Collect:
    """A spotlight collect of point targets: geometry in ENU metres about REF, targets (x east, y north, z up)."""

    n_pulses: int = 160
    n_samples: int = 128
    band: float = 150e6              # sampled band N SCSS [Hz]
    length: float = 48.0             # track length [m] (cross-range resolution ~ lambda R / 2L = 0.8 m at 2.5 km)
    targets: np.ndarray = field(default_factory=lambda: np.array([[0.0, 0.0, 0.0], [4.0, -3.0, 0.0]]))
    amps: tuple = (1.0, 0.6)
    tropo: float = 0.0               # TDTropoSRP [s]
    tropo_in_data: bool = True       # the delay is in the signal (else: compensated, the PVP informational)
    bistatic: float = 0.0            # RcvPos - TxPos offset [m] (east)
    scss_jitter: float = 1e-4        # relative per-vector SCSS variation (FXFixed false)

    def geometry(self):
        o, e, n, u = enu_basis()
        k = np.arange(self.n_pulses)
        along = (k / (self.n_pulses - 1) - 0.5) * self.length
        enu = np.stack([-2000.0 + 0 * k, along, 1500.0 + 0 * k], axis=1)        # west of the scene, flying north
        tx = o + enu[:, :1] * e + enu[:, 1:2] * n + enu[:, 2:] * u
        rx = tx + self.bistatic * e
        tgt = o + self.targets[:, :1] * e + self.targets[:, 1:2] * n + self.targets[:, 2:] * u
        return o, (e, n, u), tx, rx, tgt

    def pvps(self, dtype):
        o, _, tx, rx, _ = self.geometry()
        k = np.arange(self.n_pulses)
        scss = self.band / self.n_samples * (1.0 + self.scss_jitter * np.sin(0.7 * k))
        sc0 = FC - 0.5 * self.n_samples * scss + 1e3 * np.cos(0.3 * k)
        p = np.zeros(self.n_pulses, dtype=dtype)
        t = k / 500.0
        rref = np.linalg.norm(tx - o, axis=1) + np.linalg.norm(rx - o, axis=1)
        p["TxTime"], p["RcvTime"] = t, t + rref / C
        p["TxPos"], p["RcvPos"], p["SRPPos"] = tx, rx, o
        vel = np.gradient(tx, t, axis=0)
        p["TxVel"] = p["RcvVel"] = vel
        p["FX1"], p["FX2"] = sc0, sc0 + (self.n_samples - 1) * scss
        p["SC0"], p["SCSS"] = sc0, scss
        p["TOA1"], p["TOA2"] = -0.45 / scss, 0.45 / scss
        p["TDTropoSRP"] = self.tropo
        p["SIGNAL"] = 1
        return p

    def signal(self, pvp, sgn: int, k0: int = 0, k1: int | None = None) -> np.ndarray:
        """(k1 - k0, N) complex128 phase history of the targets (module doc)."""
        _, _, tx, rx, tgt = self.geometry()
        sl = slice(k0, self.n_pulses if k1 is None else k1)
        tx, rx, p = tx[sl], rx[sl], pvp[sl]
        ref = (np.linalg.norm(tx - p["SRPPos"], axis=1) + np.linalg.norm(rx - p["SRPPos"], axis=1)) / C
        f = p["SC0"][:, None] + np.arange(self.n_samples)[None] * p["SCSS"][:, None]
        s = np.zeros(f.shape, np.complex128)
        for a, q in zip(self.amps, tgt):
            dtau = (np.linalg.norm(tx - q, axis=1) + np.linalg.norm(rx - q, axis=1)) / C - ref
            if self.tropo_in_data:
                dtau = dtau + self.tropo
            s += a * np.exp(2j * np.pi * sgn * f * dtau[:, None])
        return s


PVP_LAYOUT = (("TxTime", 1), ("TxPos", 3), ("TxVel", 3), ("RcvTime", 1), ("RcvPos", 3), ("RcvVel", 3),
              ("SRPPos", 3), ("AmpSF", 1), ("aFDOP", 1), ("aFRR1", 1), ("aFRR2", 1), ("FX1", 1), ("FX2", 1),
              ("TOA1", 1), ("TOA2", 1), ("TDTropoSRP", 1), ("SC0", 1), ("SCSS", 1), ("SIGNAL", 1))


def _pvp_xml():
    out, off = {}, 0
    for name, words in PVP_LAYOUT:
        fmt = "X=F8;Y=F8;Z=F8;" if words == 3 else ("I8" if name == "SIGNAL" else "F8")
        out[name] = {"Offset": off, "Size": words, "dtype": skcphd.binary_format_string_to_dtype(fmt)}
        off += words
    return out


def pvp_dtype():
    return np.dtype([(n, ">i8" if n == "SIGNAL" else (">f8", (3,)) if w == 3 else ">f8") for n, w in PVP_LAYOUT])


def metadata(col: Collect, fmt: str, sgn: int, channels=("1",), *, grid=(81, 81, 0.25)) -> et._ElementTree:
    """CPHD 1.0.1 XML of ``col`` (one channel per identifier, the same vectors each)."""
    o, (e, n, _), _, _, _ = col.geometry()
    pvp = col.pvps(pvp_dtype())
    llh = wgs84.cartesian_to_geodetic(o)
    root = et.Element(f"{{{NS}}}CPHD")
    ew = skcphd.ElementWrapper(root)
    ew["CollectionID"] = {"CollectorName": "vendor", "CoreName": "test", "CollectType": "MONOSTATIC",
                          "RadarMode": {"ModeType": "SPOTLIGHT"}, "Classification": "UNCLASSIFIED",
                          "ReleaseInfo": "UNRESTRICTED"}
    fx1, fx2 = float(pvp["FX1"].min()), float(pvp["FX2"].max())
    ew["Global"] = {"DomainType": "FX", "SGN": sgn,
                    "Timeline": {"CollectionStart": datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc),
                                 "TxTime1": float(pvp["TxTime"].min()), "TxTime2": float(pvp["TxTime"].max())},
                    "FxBand": {"FxMin": fx1, "FxMax": fx2},
                    "TOASwath": {"TOAMin": float(pvp["TOA1"].min()), "TOAMax": float(pvp["TOA2"].max())}}
    half = 20.0
    area = {"X1Y1": np.array([-half, -half]), "X2Y2": np.array([half, half]),
            "Polygon": np.array([[-half, -half], [-half, half], [half, half], [half, -half]])}
    verts = area["Polygon"]
    corners = wgs84.cartesian_to_geodetic(o + verts[:, :1] * e + verts[:, 1:] * n)[:, :2]
    nl, ns, sp = grid
    ew["SceneCoordinates"] = {
        "EarthModel": "WGS_84", "IARP": {"ECF": o, "LLH": llh},
        "ReferenceSurface": {"Planar": {"uIAX": e, "uIAY": n}}, "ImageArea": area, "ImageAreaCornerPoints": corners,
        "ImageGrid": {"IARPLocation": np.array([0.5 * (nl - 1), 0.5 * (ns - 1)]),
                      "IAXExtent": {"LineSpacing": sp, "FirstLine": 0, "NumLines": nl},
                      "IAYExtent": {"SampleSpacing": sp, "FirstSample": 0, "NumSamples": ns}}}
    ew["Data"] = {"SignalArrayFormat": fmt, "NumBytesPVP": pvp.dtype.itemsize, "NumCPHDChannels": len(channels),
                  "Channel": [{"Identifier": c, "NumVectors": col.n_pulses, "NumSamples": col.n_samples,
                               "SignalArrayByteOffset": i * col.n_pulses * col.n_samples
                               * skcphd.binary_format_string_to_dtype(fmt).itemsize,
                               "PVPArrayByteOffset": i * pvp.nbytes} for i, c in enumerate(channels)],
                  "NumSupportArrays": 0}
    ew["Channel"] = {"RefChId": channels[0], "FXFixedCPHD": False, "TOAFixedCPHD": False, "SRPFixedCPHD": True,
                     "Parameters": [{"Identifier": c, "RefVectorIndex": col.n_pulses // 2, "FXFixed": False,
                                     "TOAFixed": False, "SRPFixed": True, "SignalNormal": True,
                                     "Polarization": {"TxPol": "V", "RcvPol": "V"}, "FxC": 0.5 * (fx1 + fx2),
                                     "FxBW": fx2 - fx1, "TOASaved": float(pvp["TOA2"].max() - pvp["TOA1"].min()),
                                     "DwellTimes": {"CODId": "1", "DwellId": "1"}, "ImageArea": area}
                                    for c in channels]}
    ew["PVP"] = _pvp_xml()
    t_mid = 0.5 * float(pvp["TxTime"].min() + pvp["TxTime"].max())
    ew["Dwell"] = {"NumCODTimes": 1, "CODTime": [{"Identifier": "1", "CODTimePoly": np.array([[t_mid]])}],
                   "NumDwellTimes": 1,
                   "DwellTime": [{"Identifier": "1", "DwellTimePoly": np.array([[float(np.ptp(pvp["TxTime"]))]])}]}
    tree = root.getroottree()
    ew["ReferenceGeometry"] = skcphd.compute_reference_geometry(tree, pvp)
    return tree


def quantise(s: np.ndarray, fmt: str, rng=None) -> tuple[np.ndarray, np.ndarray]:
    """(stored samples in ``fmt``, AmpSF per vector): integers scaled per vector to the format's full range, floats
    scaled by a per-vector factor too (a vendor's gain), so AmpSF always matters."""
    amp = np.max(np.abs(s), axis=1) * (1.0 + 0.25 * (1.0 + np.sin(np.arange(len(s)))))   # a gain per vector, >= 1
    amp = np.where(amp > 0, amp, 1.0)
    if fmt in INT_BITS:
        full = 2 ** (INT_BITS[fmt] - 1) - 1
        amp = amp / full * 1.0001
        dt = skcphd.binary_format_string_to_dtype(fmt)
        out = np.empty(s.shape, dt)
        q = s / amp[:, None]
        out["real"] = np.round(q.real)
        out["imag"] = np.round(q.imag)
        return out, amp
    out = (s / amp[:, None]).astype(np.complex64 if fmt == "CF8" else np.complex128)
    return out, amp


def write(path, col: Collect, fmt: str = "CF8", sgn: int = -1, *, channels=("1",), tree=None, pvp=None,
          signal=None) -> np.ndarray:
    """Write ``col`` as a CPHD (module doc); ``tree``/``pvp``/``signal`` replace the computed parts (corrupt files).
    Returns the PVPs written."""
    tree = metadata(col, fmt, sgn, channels) if tree is None else tree
    p = col.pvps(pvp_dtype()) if pvp is None else pvp
    s = col.signal(p, sgn) if signal is None else signal
    if signal is None:
        s, amp = quantise(s, fmt)
        p["AmpSF"] = amp
    with open(path, "wb") as f, skcphd.Writer(f, skcphd.Metadata(xmltree=tree)) as w:
        for c in channels:
            w.write_signal(c, s)
            w.write_pvp(c, p)
    return p


def plane_grid(spacing=0.25, n=81):
    """The ground plane about the SRP (east, north) as sarnav's PlaneGrid, ``n`` x ``n`` pixels."""
    from sarnav.imaging.grid import PlaneGrid

    o, e, nn, _ = enu_basis()
    ax = (np.arange(n) - (n - 1) / 2) * spacing
    return PlaneGrid(o, e, nn, ax, ax, "east", "north")

"""Checks of a CPHD file's XML values and per-vector parameters against their valid ranges (``io.cphd_read``), each
failure one InputDataError line naming the file's field (``cphd.PVP.SCSS``, ``cphd.Channel.Parameters.FxC``), and a
light reader of the XML's values (the few fields sarnav uses: numbers, strings and vectors of numbers)."""

from __future__ import annotations

import re

import numpy as np

from sarnav.errors import InputDataError

__all__ = ["XmlValues", "need", "field_name", "check_pvps", "check_band", "check_monostatic", "check_span",
           "MAX_SAMPLE", "MAX_SPAN"]

_C = 299792458.0
#: the largest sample magnitude (AmpSF applied) and AmpSF read: back-projection sums complex64 samples (max 3.4e38)
MAX_SAMPLE = 1e30
#: the vectors' range windows may span at most this many times N samples (a real collect: ~1-2)
MAX_SPAN = 16
_FINITE_PVPS = ("TxTime", "TxPos", "RcvPos", "SRPPos", "SC0", "SCSS", "TOA1", "TOA2", "AmpSF", "TDTropoSRP")


def _number(text: str):
    t = (text or "").strip()
    for kind in (int, float):
        try:
            return kind(t)
        except ValueError:
            pass
    return t


class XmlValues:
    """The values of a CPHD XML tree by path (``load``, as sarkit's ``XmlHelper.load`` for the fields sarnav reads):
    an element with children is the array of their numbers (XYZ, LLH, Line/Sample, X/Y), else its text as an int,
    a float or a string; None when absent. A tenth of XmlHelper's cost (no schema lookups)."""

    def __init__(self, tree):
        self.element_tree = tree

    def load(self, path: str):
        el = self.element_tree.find(path)
        if el is None:
            return None
        if len(el):
            return np.array([float(c.text) for c in el], dtype=np.float64)
        return _number(el.text)


def need(xml, path: str, what: str):
    """The value at ``path`` of the XML helper ``xml``, or InputDataError naming it (``cphd.A.B``)."""
    try:
        v = xml.load(path)
    except Exception as err:  # noqa: BLE001 - a corrupt text raises ValueError, TypeError, IndexError, lxml's...
        raise InputDataError(field_name(path), f"unreadable {what} ({type(err).__name__}: {str(err)[:80]})") from None
    if v is None:
        raise InputDataError(field_name(path), f"missing required {what}")
    return v


def field_name(path: str) -> str:
    return "cphd." + re.sub(r"\[[^]]*\]", "", path).replace("./{*}", "").replace("/{*}", ".")


def check_pvps(pvp: np.ndarray, start: int) -> None:
    for name in _FINITE_PVPS:
        if name in pvp.dtype.names:
            dt = pvp.dtype[name]
            want = (3,) if name.endswith("Pos") else ()
            if dt.shape != want or dt.base.kind != "f" or dt.base.itemsize != 8:  # F8 (CPHD 1.0 Table 10-2)
                raise InputDataError(f"cphd.PVP.{name}", f"must be {'X=F8;Y=F8;Z=F8;' if want else 'F8'}, got a "
                                     f"{dt.base} field of shape {dt.shape}")
    for name in _FINITE_PVPS:
        if name not in pvp.dtype.names:
            continue
        bad = ~np.isfinite(np.asarray(pvp[name], dtype=np.float64).reshape(len(pvp), -1)).all(axis=1)
        if bad.any():
            raise InputDataError(f"cphd.PVP.{name}", f"must be finite: NaN/inf in vector {start + int(np.argmax(bad))}")
    if "AmpSF" in pvp.dtype.names and not np.all(np.abs(pvp["AmpSF"]) < MAX_SAMPLE):
        k = int(np.argmax(~(np.abs(pvp["AmpSF"]) < MAX_SAMPLE)))
        raise InputDataError("cphd.PVP.AmpSF", f"must be below {MAX_SAMPLE:.0e} in magnitude, got "
                             f"{float(pvp['AmpSF'][k])!r} in vector {start + k}")
    if np.any(np.diff(pvp["TxTime"]) < 0):
        k = int(np.argmax(np.diff(pvp["TxTime"]) < 0)) + 1
        raise InputDataError("cphd.PVP.TxTime", f"must not decrease from vector to vector (vector {start + k})")


def check_band(pvp: np.ndarray, n: int, fxc: float, fxbw: float, start: int = 0) -> None:
    """SC0, SCSS > 0; each vector's samples below 2 FxC and spanning at least half the channel's FxBW."""
    sc0, scss = pvp["SC0"], pvp["SCSS"]
    for name, v in (("SC0", sc0), ("SCSS", scss)):
        bad = ~(v > 0)
        if bad.any():
            k = int(np.argmax(bad))
            raise InputDataError(f"cphd.PVP.{name}",
                                 f"must be > 0 Hz (FX domain), got {float(v[k])!r} in vector {start + k}")
    bad = ~((n - 1) * scss >= 0.5 * fxbw)
    if bad.any():
        k = int(np.argmax(bad))
        raise InputDataError("cphd.PVP.SCSS", f"the {n} samples of vector {start + k} span {(n - 1) * scss[k]:.4g} Hz: "
                             f"they must cover at least half the channel's FxBW = {fxbw:.4g} Hz (SCSS >= FxBW / "
                             f"(2 (N - 1)) = {0.5 * fxbw / (n - 1):.4g} Hz), got SCSS = {float(scss[k])!r}")
    top = sc0 + (n - 1) * scss
    bad = ~(top < 2.0 * fxc)
    if bad.any():
        k = int(np.argmax(bad))
        raise InputDataError("cphd.PVP.SCSS", f"the {n} samples of vector {start + k} reach {top[k]:.4g} Hz: "
                             f"SC0 + (N - 1) "
                             f"SCSS must stay below 2 FxC = {2 * fxc:.4g} Hz, got SCSS = {float(scss[k])!r}")
    bad = ~(pvp["TOA2"] > pvp["TOA1"])
    if bad.any():
        raise InputDataError("cphd.PVP.TOA2", f"must be > TOA1 in every vector (vector {start + int(np.argmax(bad))})")


def check_monostatic(pvp: np.ndarray, fxc: float, start: int) -> None:
    """The legs' mean range is exact to |b|^2 / (4 R) (b = RcvPos - TxPos) of two-way range: below lambda / 16."""
    b = np.linalg.norm(pvp["RcvPos"] - pvp["TxPos"], axis=1)
    r = np.minimum(np.linalg.norm(pvp["TxPos"] - pvp["SRPPos"], axis=1),
                   np.linalg.norm(pvp["RcvPos"] - pvp["SRPPos"], axis=1))
    err = b**2 / (4.0 * np.maximum(r, 1e-9))
    lam16 = _C / fxc / 16.0
    if np.any(err > lam16):
        k = int(np.argmax(err))
        raise InputDataError("cphd.PVP.RcvPos", f"is {b[k]:.4g} m from TxPos in vector {start + k}: a bistatic "
                             f"collect (two-leg range error |RcvPos - TxPos|^2 / 4R = {err[k]:.3g} m, at most "
                             f"lambda / 16 = {lam16:.3g} m for the monostatic imaging sarnav does)")


def check_span(pvp: np.ndarray, ref: np.ndarray, n: int, start: int) -> None:
    """The union of the vectors' range windows spans at most MAX_SPAN x N samples; else name the vector and field
    that jump (a flipped byte moving a position by hundreds of km)."""
    p = pvp
    lo = ref + 0.5 * _C * p["TOA1"]
    hi = ref + 0.5 * _C * p["TOA2"]
    dr = _C / (2.0 * n * float(np.min(p["SCSS"])))
    span = (float(np.max(hi)) - float(np.min(lo))) / dr
    if span <= MAX_SPAN * n:
        return
    jumps = {}
    for name in ("TxPos", "RcvPos", "SRPPos", "TOA1", "TOA2", "TDTropoSRP"):
        if name not in p.dtype.names:
            continue
        v = np.asarray(p[name], np.float64).reshape(len(p), -1) * (1.0 if name.endswith("Pos") else 0.5 * _C)
        dev = np.linalg.norm(v - np.median(v, axis=0), axis=1)
        jumps[name] = (float(dev.max()), int(np.argmax(dev)))
    name, (dev, k) = max(jumps.items(), key=lambda kv: kv[1][0])
    raise InputDataError(f"cphd.PVP.{name}", f"vector {start + k} is {dev:.4g} m from the others' median (times "
                         f"as c t / 2): "
                         f"the vectors' range windows span {span:.3g} samples, at most {MAX_SPAN} N = {MAX_SPAN * n} "
                         "(a corrupted vector: read a range of vectors without it)")

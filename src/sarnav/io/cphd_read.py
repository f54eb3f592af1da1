"""The checked header and per-vector parameters of one CPHD channel, and its signal read in blocks of vectors.

:func:`open_collect` reads what a file's XML and PVP block say about one channel (chosen by identifier, default the
first) and a range of its vectors, checks every field sarnav uses against its valid range, and returns a
:class:`CphdCollect`; :meth:`CphdCollect.phase_history` then reads any block of those vectors (only that block is
read from the file) as a :class:`~sarnav.signal.phase_history.PhaseHistory`. Bad input is one line naming the file's
field (``cphd.Channel.Parameters.FxC: must be finite and > 0 Hz, got 0.0``) before anything large is allocated.

Covered (CPHD 1.0.1 and 1.1.0, NGA.STND.0068-1, through sarkit): FX-domain signal arrays of every uncompressed
``SignalArrayFormat`` (CI2, CI4, CI8, CI16 integers, CF8, CF16 floats), the per-vector amplitude scale ``AmpSF``
applied, ``SGN`` -1 or +1, per-vector ``SC0`` / ``SCSS`` (FXFixed false), per-vector ``TOA1`` / ``TOA2``,
``TDTropoSRP`` read one of two ways (``tropo``, below), monostatic geometry with transmit and receive positions that
may differ by the platform's motion during the echo's flight (the two legs' mean: exact to |RcvPos - TxPos|^2 / (4 R)
of two-way range, required below lambda / 16).
Refused (one line each): a TOA-domain file (``Global.DomainType``), a compressed signal array
(``Data.SignalCompressionID``: the compression is vendor-defined), a bistatic geometry, vectors whose range windows
span more than :data:`MAX_SPAN` x N samples (a corrupted position or SRP), an image grid axis over
:data:`MAX_GRID_AXIS` samples, sizes the file cannot hold.

``tropo`` (CPHD 1.0.1 PVP ``TDTropoSRP``, the two-way troposphere delay of the SRP [s]): ``"in-data"`` (default:
the delay is left in the signal and stated in the PVP, the reading the peer FastSAR applies to Umbra collects, whose
25.1 ns mean displaces scatterers by c TDTropoSRP / 2 = 3.8 m when left in: it is removed by taking the reference
range R_ref - c TDTropoSRP / 2) or ``"compensated"`` (the signal is already referred to the SRP's echo including
the delay: the PVP is informational and ignored). Both agree when TDTropoSRP = 0 (sarnav's own files).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sarkit.cphd as skcphd

from sarnav.errors import ConfigError, InputDataError
from sarnav.io.cphd_checks import (MAX_SAMPLE, MAX_SPAN, XmlValues, check_band, check_monostatic, check_pvps,
                                   check_span, field_name, need)
from sarnav.signal.phase_history import PhaseHistory

__all__ = ["CphdCollect", "open_collect", "conversion_bytes", "read_budget", "DEFAULT_BUDGET", "TROPO",
           "SIGNAL_FORMATS", "MAX_SPAN", "MAX_GRID_AXIS", "need"]

_C = 299792458.0
#: the uncompressed signal formats read (sarkit's table; CF16 and the 8-byte integers as complex128)
SIGNAL_FORMATS = {"CI2": np.complex64, "CI4": np.complex64, "CI8": np.complex128, "CI16": np.complex128,
                  "CF8": np.complex64, "CF16": np.complex128}
#: readings of TDTropoSRP (module doc); the first is the default
TROPO = ("in-data", "compensated")
#: the most lines or samples of the file's image grid (its axes only are made: 8 MiB each)
MAX_GRID_AXIS = 2**20
#: the default memory budget of a read or an image [bytes] (1 GiB)
DEFAULT_BUDGET = 2**30
_REQUIRED_PVPS = ("TxTime", "TxPos", "RcvPos", "SRPPos", "SC0", "SCSS", "TOA1", "TOA2")


def read_budget() -> float:
    """The default budget of an in-memory read (``io.cphd.read_collect``): half the machine's physical memory
    (8 GiB where the system does not tell)."""
    try:
        return 0.5 * os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 8.0 * 2**30


def conversion_bytes(n: int, m: int, raw_itemsize: int) -> int:
    """Bytes one vector of N samples takes at the peak of its read and its conversion to M range samples
    (``signal.phase_history.phase_history_to_pulses``): the raw and complex samples, the pre-twiddle and its
    cycles, the chirp-z transform's FFTs (length next power of 2 >= N + M) and the post-twiddle (an upper bound)."""
    fft = 1 << int(math.ceil(math.log2(n + m)))
    return int(n * (raw_itemsize + 100) + 48 * fft + m * 88)


@dataclass
class CphdCollect:
    """One channel of a CPHD file, vectors ``start`` to ``stop`` (exclusive), header and PVPs checked."""

    path: Path
    channel: str
    start: int
    stop: int
    n_samples: int
    signal_format: str
    sgn: int
    fxc: float                       # Channel.Parameters.FxC [Hz]
    fxbw: float                      # Channel.Parameters.FxBW [Hz]
    pvp: np.ndarray                  # the selected vectors' PVPs
    xml: object = field(repr=False)  # the XML's values (io.cphd_checks.XmlValues: load(path), element_tree)
    tropo: str = "in-data"
    signal_offset: int = 0           # byte offset of the channel's vector 0 in the file

    @property
    def n_pulses(self) -> int:
        return self.stop - self.start

    @property
    def positions(self) -> np.ndarray:
        """(P, 3) ARP = (TxPos + RcvPos) / 2, ECEF [m]."""
        return 0.5 * (self.pvp["TxPos"] + self.pvp["RcvPos"])

    @property
    def ref_range(self) -> np.ndarray:
        """(P,) reference range (|TxPos - SRP| + |RcvPos - SRP|) / 2, less c TDTropoSRP / 2 with tropo "in-data"."""
        p = self.pvp
        r = 0.5 * (np.linalg.norm(p["TxPos"] - p["SRPPos"], axis=1) + np.linalg.norm(p["RcvPos"] - p["SRPPos"], axis=1))
        if self.tropo == "in-data" and "TDTropoSRP" in p.dtype.names:
            r = r - 0.5 * _C * p["TDTropoSRP"]
        return r

    @property
    def pulse_times(self) -> np.ndarray:
        """(P,) TxTime [s]."""
        return np.asarray(self.pvp["TxTime"], dtype=np.float64)

    @property
    def srp(self) -> np.ndarray:
        """SRP of the middle vector, ECEF [m]."""
        return np.asarray(self.pvp["SRPPos"][self.n_pulses // 2], dtype=np.float64)

    @property
    def raw_itemsize(self) -> int:
        return skcphd.binary_format_string_to_dtype(self.signal_format).itemsize

    def header(self) -> PhaseHistory:
        """The selected vectors' phase history without their samples (a zero-stride view: no memory): for the
        range axis of every block (``signal.phase_history.default_range_axis``)."""
        ph = PhaseHistory.__new__(PhaseHistory)
        ph.__dict__.update(self._fields(0, self.n_pulses))
        ph.data = np.broadcast_to(np.zeros((), np.complex64), (self.n_pulses, self.n_samples))
        return ph

    def _fields(self, k0: int, k1: int) -> dict:
        p = self.pvp[k0:k1]
        return {"fx0": np.array(p["SC0"], np.float64), "fx_step": np.array(p["SCSS"], np.float64),
                "positions": np.array(self.positions[k0:k1]), "ref_range": np.array(self.ref_range[k0:k1]),
                "pulse_times": np.array(p["TxTime"], np.float64),
                "toa": np.stack([p["TOA1"], p["TOA2"]], axis=1).astype(np.float64), "sgn": self.sgn}

    def read_signal(self, k0: int, k1: int) -> np.ndarray:
        """(k1 - k0, N) complex samples of vectors k0..k1 of the selection, AmpSF applied (only these are read)."""
        raw_dtype = skcphd.binary_format_string_to_dtype(self.signal_format).newbyteorder(">")
        count = (k1 - k0) * self.n_samples
        try:
            with open(self.path, "rb") as f:
                f.seek(self.signal_offset + (self.start + k0) * self.n_samples * raw_dtype.itemsize)
                raw = np.fromfile(f, dtype=raw_dtype, count=count)
        except OSError as err:
            raise InputDataError("cphd", f"cannot read {str(self.path)!r}: {err.strerror or err}") from None
        if raw.size != count:
            raise InputDataError("cphd.Data.Channel.NumVectors", f"the file ends before vector {self.start + k1}")
        raw = raw.reshape(k1 - k0, self.n_samples)
        dtype = SIGNAL_FORMATS[self.signal_format]
        if raw.dtype.names:                                    # CIn: (real, imag) integers
            sig = np.empty(raw.shape, dtype)
            sig.real = raw["real"]
            sig.imag = raw["imag"]
        else:
            sig = raw.astype(dtype)
        del raw
        if "AmpSF" in self.pvp.dtype.names:
            with np.errstate(over="ignore", invalid="ignore"):         # overflows are refused just below
                sig *= self.pvp["AmpSF"][k0:k1, None].astype(sig.real.dtype)
        bad = ~np.isfinite(sig).all(axis=1)
        if bad.any():
            raise InputDataError("cphd.Signal",
                                 f"must be finite: NaN/inf in vector {self.start + k0 + int(np.argmax(bad))}")
        bad = ~(np.abs(sig) < MAX_SAMPLE).all(axis=1)
        if bad.any():
            raise InputDataError("cphd.Signal", f"must be below {MAX_SAMPLE:.0e} in magnitude (AmpSF applied; the "
                                 f"imaging sums in single precision): vector {self.start + k0 + int(np.argmax(bad))}")
        return sig

    def phase_history(self, k0: int = 0, k1: int | None = None) -> PhaseHistory:
        """The :class:`PhaseHistory` of vectors k0..k1 of the selection (default all), ECEF."""
        k1 = self.n_pulses if k1 is None else k1
        f = self._fields(k0, k1)
        return PhaseHistory(self.read_signal(k0, k1), f["fx0"], f["fx_step"], f["positions"], f["ref_range"],
                            f["pulse_times"], f["toa"], f["sgn"])


def _open_error(path, err) -> InputDataError:
    return InputDataError("cphd", f"{str(path)!r} is not a readable CPHD 1.x file ({type(err).__name__}: "
                          f"{str(err)[:120]})")


def _header(path: Path):
    """(file size, header key-values, XML tree) of a CPHD file, or the one-line error."""
    try:
        size = os.path.getsize(path)
        with open(path, "rb") as f:
            _, kvp = skcphd.read_file_header(f)
            f.seek(0)
            with skcphd.Reader(f) as r:
                tree = r.metadata.xmltree
    except OSError as err:
        raise InputDataError("cphd", f"cannot read {str(path)!r}: {err.strerror or err}") from None
    except Exception as err:  # noqa: BLE001 - sarkit / lxml raise many kinds on a file that is not a CPHD
        raise _open_error(path, err) from None
    return size, kvp, tree


def _int(xml, path: str, lo: int, hi: int) -> int:
    v = need(xml, path, "integer")
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
        raise InputDataError(field_name(path), f"must be an integer in [{lo}, {hi}], got {v!r}")
    return int(v)


def _positive(xml, path: str, unit: str) -> float:
    v = need(xml, path, "value")
    try:
        v = float(v)
    except (TypeError, ValueError, OverflowError):
        raise InputDataError(field_name(path), f"must be a number [{unit}], got {v!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputDataError(field_name(path), f"must be finite and > 0 {unit}, got {v!r}")
    return v


def _channel(xml, tree, channel) -> str:
    ids = [e.text for e in tree.findall("./{*}Data/{*}Channel/{*}Identifier")]
    if not ids:
        raise InputDataError("cphd.Data.Channel.Identifier", "missing required channel identifier")
    if channel is None:
        return ids[0]
    if str(channel) not in ids:
        raise ConfigError("channel", f"must be one of the file's channels {tuple(ids)}, got {channel!r}")
    return str(channel)


def _check_sizes(size: int, kvp: dict, xml, ch: str, n_vec: int, n_samp: int, fmt: str):
    """The file holds the channel's signal array and PVPs (a header claiming 10^9 vectors is refused unread)."""
    base = f"./{{*}}Data/{{*}}Channel[{{*}}Identifier='{ch}']/{{*}}"
    itemsize = skcphd.binary_format_string_to_dtype(fmt).itemsize
    try:
        sig0 = int(kvp["SIGNAL_BLOCK_BYTE_OFFSET"]) + int(need(xml, base + "SignalArrayByteOffset", "offset"))
        pvp0 = int(kvp["PVP_BLOCK_BYTE_OFFSET"]) + int(need(xml, base + "PVPArrayByteOffset", "offset"))
        per_pvp = int(need(xml, "./{*}Data/{*}NumBytesPVP", "PVP size"))
    except InputDataError:
        raise
    except (KeyError, ValueError, TypeError, OverflowError) as err:
        raise InputDataError("cphd", f"file header without the block offsets ({type(err).__name__}: {err})") from None
    try:
        dt = skcphd.get_pvp_dtype(xml.element_tree).newbyteorder(">")
        layout = dt.itemsize
    except Exception as err:  # noqa: BLE001 - offsets, sizes or formats that make no dtype
        raise InputDataError("cphd.PVP", f"the per-vector parameters' layout is unreadable ({type(err).__name__}: "
                             f"{str(err)[:80]})") from None
    if not 0 < layout <= per_pvp:
        raise InputDataError("cphd.Data.NumBytesPVP", f"must hold the PVP fields' {layout} bytes per vector (offsets "
                             f"and sizes of the PVP block), got {per_pvp}")
    for end in (sig0 + n_vec * n_samp * itemsize, pvp0 + n_vec * per_pvp):
        if sig0 < 0 or pvp0 < 0 or end > size:
            raise InputDataError("cphd.Data.Channel.NumVectors", f"{n_vec} vectors x {n_samp} samples ({fmt}) need "
                                 f"{end:,} bytes, the file has {size:,}: a truncated file or a corrupt header")
    # the PVP records are NumBytesPVP apart, whatever the fields' own extent
    dt = np.dtype({"names": list(dt.names), "formats": [dt.fields[n][0] for n in dt.names],
                   "offsets": [dt.fields[n][1] for n in dt.names], "itemsize": per_pvp})
    return sig0, pvp0, dt


def _vectors(pulses, n_vec: int) -> tuple[int, int]:
    if pulses is None:
        return 0, n_vec
    try:
        a, b = int(pulses[0]), (n_vec if pulses[1] is None else int(pulses[1]))
    except (TypeError, ValueError, IndexError):
        raise ConfigError("pulses", f"must be (start, stop) vector indices, got {pulses!r}") from None
    if not 0 <= a < b <= n_vec:
        raise ConfigError("pulses", f"must satisfy 0 <= start < stop <= {n_vec} (the channel's vectors), "
                          f"got {a}:{b}")
    return a, b


def _read_pvps(path, pvp0: int, dtype: np.dtype, a: int, b: int) -> np.ndarray:
    try:
        with open(path, "rb") as f:
            f.seek(pvp0 + a * dtype.itemsize)
            pvp = np.fromfile(f, dtype=dtype, count=b - a)
    except OSError as err:
        raise InputDataError("cphd", f"cannot read {str(path)!r}: {err.strerror or err}") from None
    if pvp.size != b - a:
        raise InputDataError("cphd.Data.Channel.NumVectors", f"the file ends before vector {b}")
    return pvp


def open_collect(path, *, channel=None, pulses=None, tropo: str = "in-data") -> CphdCollect:
    """The checked header and PVPs of channel ``channel`` (identifier; default the first) of the CPHD ``path``,
    vectors ``pulses = (start, stop)`` (default all; stop None: to the end); ``tropo`` one of :data:`TROPO` (module
    doc). Raises
    InputDataError naming the file's field, ConfigError naming ``channel`` / ``pulses`` / ``tropo``."""
    if tropo not in TROPO:
        raise ConfigError("tropo", f"must be one of {TROPO}, got {tropo!r}")
    path = Path(path)
    size, kvp, tree = _header(path)
    xml = XmlValues(tree)
    dom = need(xml, "./{*}Global/{*}DomainType", "domain type")
    if not (isinstance(dom, str) and dom == "FX"):
        raise InputDataError("cphd.Global.DomainType", f"must be 'FX' (frequency-domain vectors; TOA-domain files "
                             f"are not read), got {dom!r}")
    comp = tree.findtext("./{*}Data/{*}SignalCompressionID")
    if comp is None and tree.find("./{*}Data/{*}Channel/{*}CompressedSignalSize") is not None:
        comp = "(CompressedSignalSize given)"
    if comp is not None:
        raise InputDataError("cphd.Data.SignalCompressionID", f"compressed signal arrays are not read (the "
                             f"compression is vendor-defined; an uncompressed array is required), got {comp!r}")
    fmt = need(xml, "./{*}Data/{*}SignalArrayFormat", "signal array format")
    if not (isinstance(fmt, str) and fmt in SIGNAL_FORMATS):
        raise InputDataError("cphd.Data.SignalArrayFormat", f"must be one of {tuple(SIGNAL_FORMATS)}, got {fmt!r}")
    ch = _channel(xml, tree, channel)
    base = f"./{{*}}Data/{{*}}Channel[{{*}}Identifier='{ch}']/{{*}}"
    n_vec = _int(xml, base + "NumVectors", 1, 2**40)
    n_samp = _int(xml, base + "NumSamples", 2, 2**31)
    sig0, pvp0, pvp_dtype = _check_sizes(size, kvp, xml, ch, n_vec, n_samp, fmt)
    for name in _REQUIRED_PVPS:
        if tree.find(f"./{{*}}PVP/{{*}}{name}") is None:
            raise InputDataError(f"cphd.PVP.{name}", "missing required per-vector parameter")
    sgn = need(xml, "./{*}Global/{*}SGN", "phase sign")
    if not (isinstance(sgn, (int, np.integer)) and sgn in (-1, 1)):
        raise InputDataError("cphd.Global.SGN", f"must be -1 or +1, got {sgn!r}")
    par = f"./{{*}}Channel/{{*}}Parameters[{{*}}Identifier='{ch}']/{{*}}"
    fxc = _positive(xml, par + "FxC", "Hz")
    fxbw = _positive(xml, par + "FxBW", "Hz")
    a, b = _vectors(pulses, n_vec)
    pvp = _read_pvps(path, pvp0, pvp_dtype, a, b)
    c = CphdCollect(path, ch, a, b, n_samp, fmt, int(sgn), fxc, fxbw, pvp, xml, tropo, sig0)
    with np.errstate(over="ignore", invalid="ignore"):      # huge values: the checks refuse them, one line
        check_pvps(pvp, a)
        check_band(pvp, n_samp, fxc, fxbw, a)
        check_span(pvp, c.ref_range, n_samp, a)
        check_monostatic(pvp, fxc, a)
    return c

"""SICD reader (any SICD NITF sarkit reads: PixelType RE32F_IM32F, RE16I_IM16I, AMP8I_PHS8I; monostatic or
bistatic) with SICD Volume 3 (IPDD) image-to-ground and ground-to-image projection through
``sarkit.sicd.projection`` (re-exported by :mod:`sarnav.io.sicd`).

``read_sicd(path) -> SicdProduct``: the pixels as complex64 (``pixels[i, j]``: array row i, column j), the XML, the
fields projection needs checked first (each error names ``sicd.<path of the field>``, the file and the valid range),
and the geometry checked by projecting the SCP pixel onto the SCP's height: it must land on the SCP. The pixel array
is read only when its size fits :data:`MAX_PIXELS` and the file holds all of it (uncompressed image segments whose
rows and columns agree with ImageData).

Pixel coordinates are those of the array (``FirstRow``/``FirstCol`` of a sub-image are added before SCPPixel is
subtracted): ``xrow = (FirstRow + row - SCPPixel.Row) Row.SS``, ``ycol = (FirstCol + col - SCPPixel.Col) Col.SS``
(SICD Vol. 1 §2.3), fractional values allowed.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sarnav.errors import InputDataError

__all__ = ["MAX_PIXELS", "SicdProduct", "read_sicd"]

#: the largest pixel array read [pixels] (complex64: 1 GiB)
MAX_PIXELS = 2**27
_MAX_SIDE = 10**7
#: height of the SCP above the ellipsoid, valid range [m]
_SCP_HAE = (-12_000.0, 12_000.0)
_PIXEL_TYPES = ("RE32F_IM32F", "RE16I_IM16I", "AMP8I_PHS8I")


def _err(path, fld: str, message: str):
    raise InputDataError(f"sicd.{fld}" if fld else "sicd", f"{message} ({str(path)!r})")


def _line(err: Exception) -> str:
    """The first line of an exception's message (at most 200 characters), or its type's name."""
    return ((str(err).strip().splitlines() or [""])[0] or type(err).__name__)[:200]


def _text(xml, path, fld: str) -> str:
    node = xml.find("./{*}" + fld.replace(".", "/{*}"))
    if node is None or node.text is None or not node.text.strip():
        _err(path, fld, "missing")
    return node.text.strip()


def _number(xml, path, fld: str, lo=-math.inf, hi=math.inf, integer: bool = False) -> float:
    text = _text(xml, path, fld)
    try:
        v = int(text) if integer else float(text)
    except ValueError:
        _err(path, fld, f"must be {'an integer' if integer else 'a number'} in [{lo:g}, {hi:g}], got {text[:40]!r}")
    if not (math.isfinite(v) and lo <= v <= hi):
        _err(path, fld, f"must be finite in [{lo:g}, {hi:g}], got {text[:40]!r}")
    return v


def _xyz(xml, path, fld: str) -> np.ndarray:
    return np.array([_number(xml, path, f"{fld}.{c}") for c in "XYZ"])


def _poly_finite(xml, path, fld: str, required: bool = True):
    node = xml.find("./{*}" + fld.replace(".", "/{*}"))
    if node is None:
        if required:
            _err(path, fld, "missing")
        return
    for coef in node.iter("{*}Coef"):
        try:
            ok = math.isfinite(float(coef.text))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            _err(path, fld, f"coefficients must be finite numbers, got {str(coef.text)[:40]!r}")


def _check_metadata(xml, path) -> dict:
    """The fields projection and reading need, checked (module doc); returns the numbers used here."""
    import sarkit.wgs84 as wgs84

    m = {"rows": _number(xml, path, "ImageData.NumRows", 1, _MAX_SIDE, True),
         "cols": _number(xml, path, "ImageData.NumCols", 1, _MAX_SIDE, True),
         "first_row": _number(xml, path, "ImageData.FirstRow", 0, _MAX_SIDE, True),
         "first_col": _number(xml, path, "ImageData.FirstCol", 0, _MAX_SIDE, True),
         "scp_row": _number(xml, path, "ImageData.SCPPixel.Row", -_MAX_SIDE, 2 * _MAX_SIDE, True),
         "scp_col": _number(xml, path, "ImageData.SCPPixel.Col", -_MAX_SIDE, 2 * _MAX_SIDE, True),
         "row_ss": _number(xml, path, "Grid.Row.SS", 1e-6, 1e4), "col_ss": _number(xml, path, "Grid.Col.SS", 1e-6, 1e4)}
    pixel_type = _text(xml, path, "ImageData.PixelType")
    if pixel_type not in _PIXEL_TYPES:
        _err(path, "ImageData.PixelType", f"must be one of {_PIXEL_TYPES}, got {pixel_type[:40]!r}")
    m["pixel_type"] = pixel_type
    m["scp"] = _xyz(xml, path, "GeoData.SCP.ECF")
    hae = float(wgs84.cartesian_to_geodetic(m["scp"])[2])
    if not _SCP_HAE[0] <= hae <= _SCP_HAE[1]:
        _err(path, "GeoData.SCP.ECF", f"must lie within {_SCP_HAE} m of the WGS-84 ellipsoid, {hae:.6g} m from it")
    m["scp_hae"] = hae
    u = {}
    for ax in ("Row", "Col"):
        u[ax] = _xyz(xml, path, f"Grid.{ax}.UVectECF")
        if abs(np.linalg.norm(u[ax]) - 1.0) > 1e-3:
            _err(path, f"Grid.{ax}.UVectECF", f"must be a unit vector (norm 1 +- 1e-3), norm {np.linalg.norm(u[ax]):.6g}")
    if abs(float(np.dot(u["Row"], u["Col"]))) > 0.99:
        _err(path, "Grid.Col.UVectECF", "must not be parallel to Grid.Row.UVectECF (|cos| <= 0.99)")
    grid_type = _text(xml, path, "Grid.Type")
    if grid_type not in ("RGAZIM", "RGZERO", "XRGYCR", "XCTYAT", "PLANE"):
        _err(path, "Grid.Type", f"must be one of RGAZIM, RGZERO, XRGYCR, XCTYAT, PLANE, got {grid_type[:40]!r}")
    side = _text(xml, path, "SCPCOA.SideOfTrack")
    if side not in ("L", "R"):
        _err(path, "SCPCOA.SideOfTrack", f"must be L or R, got {side[:40]!r}")
    arp = _xyz(xml, path, "SCPCOA.ARPPos")
    _xyz(xml, path, "SCPCOA.ARPVel")
    _number(xml, path, "SCPCOA.SCPTime", -1e7, 1e7)
    if not 1.0 <= np.linalg.norm(arp - m["scp"]) <= 1e8:
        _err(path, "SCPCOA.ARPPos", f"must be 1 m to 1e8 m from the SCP, {np.linalg.norm(arp - m['scp']):.6g} m")
    _poly_finite(xml, path, "Grid.TimeCOAPoly")
    bistatic = (xml.findtext("./{*}CollectionInfo/{*}CollectType") or "MONOSTATIC").strip() == "BISTATIC"
    _poly_finite(xml, path, "Position.ARPPoly", required=not bistatic)
    return m


def _check_segments(reader, path, m: dict):
    """The image segments hold exactly NumRows x NumCols uncompressed pixels, all inside the file."""
    from sarkit.sicd import PIXEL_TYPES

    size = os.path.getsize(path)
    itemsize = PIXEL_TYPES[m["pixel_type"]]["bytes"]
    segs = [s for s in reader.jbp["ImageSegments"] if s["subheader"]["IID1"].value.startswith("SICD")]
    if not segs:
        _err(path, "ImageSegments", "the file has no SICD image segment")
    rows = 0
    for s in segs:
        sub, data = s["subheader"], s["Data"]
        n_r, n_c = int(sub["NROWS"].value), int(sub["NCOLS"].value)
        if sub["IC"].value != "NC":
            _err(path, "ImageSegments.IC", f"compressed or masked pixels are not read, got IC={sub['IC'].value!r}")
        if n_c != m["cols"] or data.size != n_r * n_c * itemsize or data.get_offset() + data.size > size:
            _err(path, "ImageData", f"the image segments must hold NumRows x NumCols = {m['rows']} x {m['cols']} "
                 f"{m['pixel_type']} pixels inside the file (a segment of {n_r} x {n_c} pixels, {data.size} bytes at "
                 f"offset {data.get_offset()}, file of {size} bytes)")
        rows += n_r
    if rows != m["rows"]:
        _err(path, "ImageData.NumRows", f"is {m['rows']}, the image segments hold {rows} rows")


def _to_complex(raw: np.ndarray, pixel_type: str, xml) -> np.ndarray:
    if pixel_type == "RE32F_IM32F":
        return raw.astype(np.complex64)
    if pixel_type == "RE16I_IM16I":
        return (raw["real"].astype(np.float32) + 1j * raw["imag"].astype(np.float32)).astype(np.complex64)
    table = np.arange(256, dtype=np.float64)
    amp_nodes = xml.findall("./{*}ImageData/{*}AmpTable/{*}Amplitude")
    if amp_nodes:
        for node in amp_nodes:
            table[int(node.get("index"))] = float(node.text)
    return (table[raw["amp"]] * np.exp(2j * np.pi * raw["phase"] / 256.0)).astype(np.complex64)


@dataclass
class SicdProduct:
    """A SICD read by :func:`read_sicd`: ``pixels`` (NumRows, NumCols) complex64 (None when not read), ``xml`` (the
    SICD XML as an lxml ElementTree), ``path``, and the projection (SICD Vol. 3 through ``sarkit.sicd.projection``)."""

    pixels: np.ndarray | None
    xml: object
    path: str
    fields: dict = field(repr=False)
    params: object = field(repr=False)

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.fields["rows"]), int(self.fields["cols"]))

    @property
    def scp(self) -> np.ndarray:
        """The scene centre point, ECEF [m]."""
        return self.fields["scp"].copy()

    @property
    def spacing(self) -> tuple[float, float]:
        """(Row.SS, Col.SS) [m]."""
        return (self.fields["row_ss"], self.fields["col_ss"])

    def xrowycol(self, rows, cols) -> np.ndarray:
        """(..., 2) image-grid coordinates [m] of fractional array pixels (module doc)."""
        f = self.fields
        r, c = np.broadcast_arrays(np.asarray(rows, dtype=np.float64), np.asarray(cols, dtype=np.float64))
        return np.stack([(f["first_row"] + r - f["scp_row"]) * f["row_ss"],
                         (f["first_col"] + c - f["scp_col"]) * f["col_ss"]], axis=-1)

    def image_to_ground(self, rows, cols, hae=None, *, tolerance: float = 1e-3, max_iterations: int = 12) -> np.ndarray:
        """(..., 3) ECEF [m] of fractional array pixels (``rows``, ``cols``, broadcast) on the surface of height
        ``hae`` above the WGS-84 ellipsoid [m] (a number or an array; default: the SCP's), or on a terrain given as a
        callable ``hae(lat, lon) -> heights`` (e.g. ``io.geotiff.Dem.height``; NaN outside it), iterated until the
        height moves less than ``tolerance`` [m]. SICD Vol. 3: the pixel's COA projection set, then the R/Rdot contour
        onto the constant-HAE surface (``sarkit.sicd.projection.r_rdot_to_constant_hae_surface``)."""
        import sarkit.sicd.projection as skproj
        import sarkit.wgs84 as wgs84

        locs = self.xrowycol(rows, cols)
        sets = skproj.compute_projection_sets(self.params, locs)

        def onto(h):
            pts, _, _ = skproj.r_rdot_to_constant_hae_surface(self.params.LOOK, self.params.SCP, sets, h,
                                                                delta_hae_max=tolerance, nlim=max_iterations)
            return np.asarray(pts, dtype=np.float64)

        if not callable(hae):
            h = np.asarray(self.fields["scp_hae"] if hae is None else hae, dtype=np.float64)
            try:
                h = np.broadcast_to(h, locs.shape[:-1])
            except ValueError:
                raise InputDataError("hae", f"must broadcast to the pixels' shape {locs.shape[:-1]}, got {h.shape}") from None
            return onto(h)
        h = np.full(locs.shape[:-1], self.fields["scp_hae"])
        for _ in range(max_iterations):
            pts = onto(np.nan_to_num(h, nan=self.fields["scp_hae"]))
            llh = wgs84.cartesian_to_geodetic(pts)
            new = np.asarray(hae(llh[..., 0], llh[..., 1]), dtype=np.float64)
            done = np.all(~(np.abs(new - h) > tolerance))
            h = new
            if done:
                break
        return np.where(np.isfinite(h)[..., None], onto(np.nan_to_num(h, nan=0.0)), np.nan)

    def ground_to_image(self, ecef, *, tolerance: float = 1e-4, max_iterations: int = 20):
        """Fractional array (rows, cols) of ECEF scene points ``(..., 3)`` [m] (SICD Vol. 3 scene-to-image,
        ``sarkit.sicd.projection.scene_to_image``, iterated until the ground-plane step is below ``tolerance`` [m]);
        NaN where it does not converge."""
        import sarkit.sicd.projection as skproj

        pts = np.asarray(ecef, dtype=np.float64)
        if pts.shape[-1:] != (3,) or not np.all(np.isfinite(pts)):
            raise InputDataError("ecef", f"must be finite (..., 3) ECEF points [m], got shape {pts.shape}")
        locs, delta, _ = skproj.scene_to_image(self.params, pts, delta_gp_s2i=tolerance, maxiter=max_iterations)
        f = self.fields
        ok = ~(np.asarray(delta) > 10 * tolerance)
        rows = np.where(ok, locs[..., 0] / f["row_ss"] + f["scp_row"] - f["first_row"], np.nan)
        cols = np.where(ok, locs[..., 1] / f["col_ss"] + f["scp_col"] - f["first_col"], np.nan)
        return rows, cols


@contextlib.contextmanager
def _quiet_jbpy():
    """jbpy logs a damaged NITF header field with its traceback (to stderr when logging is not configured): the
    one-line error says it instead."""
    log = logging.getLogger("jbpy")
    was = log.level
    log.setLevel(logging.CRITICAL + 1)         # its modules' loggers (jbpy.core) inherit the level
    try:
        yield
    finally:
        log.setLevel(was)


def _open(path):
    import sarkit.sicd as sksicd

    f = open(path, "rb")
    try:
        reader = sksicd.NitfReader(f)
        xml = reader.metadata.xmltree
    except Exception as err:       # jbpy / lxml / sarkit report a damaged file through many exception types
        f.close()
        _err(path, "", f"not a readable SICD NITF: {_line(err)}")
    return f, reader, xml


def _params(xml, path, m):
    import sarkit.sicd.projection as skproj

    try:
        params = skproj.MetadataParams.from_xml(xml)
        sets = skproj.compute_projection_sets(params, np.zeros(2))
        pt, _, _ = skproj.r_rdot_to_constant_hae_surface(params.LOOK, params.SCP, sets, m["scp_hae"], nlim=12)
        miss = float(np.linalg.norm(np.asarray(pt) - m["scp"]))
    except InputDataError:
        raise
    except Exception as err:
        _err(path, "", f"the geometry cannot be projected (SICD Vol. 3): {_line(err)}")
    if params.is_monostatic():
        t = float(params.t_SCP_COA)
        arp = np.polynomial.polynomial.polyval(t, np.asarray(params.ARP_Poly, dtype=np.float64))
        gap = float(np.linalg.norm(arp - np.asarray(params.ARP_SCP_COA)))
        if not gap <= 10.0:
            _err(path, "Position.ARPPoly", f"at SCPCOA.SCPTime must be within 10 m of SCPCOA.ARPPos, {gap:.6g} m "
                 "from it: the antenna track is inconsistent")
    if not miss <= max(1.0, 10 * max(m["row_ss"], m["col_ss"])):
        _err(path, "GeoData.SCP", f"the SCP pixel projects {miss:.6g} m from the SCP (at most max(1 m, 10 pixels)): "
             "the geometry (ARPPoly, TimeCOAPoly, Grid) is inconsistent")
    return params


def read_sicd(path, *, pixels: bool = True) -> SicdProduct:
    """Read the SICD NITF ``path`` (module doc); ``pixels=False`` reads the metadata only (no size limit)."""
    path = Path(path)
    if not path.is_file():
        _err(path, "", "not a readable file")
    with _quiet_jbpy():
        return _read(path, pixels)


def _read(path: Path, pixels: bool) -> SicdProduct:
    f, reader, xml = _open(path)
    with f:
        m = _check_metadata(xml, path)
        params = _params(xml, path, m)
        data = None
        if pixels:
            if m["rows"] * m["cols"] > MAX_PIXELS:
                _err(path, "ImageData", f"{m['rows']} x {m['cols']} pixels exceed the {MAX_PIXELS:.3g} read at once")
            try:
                _check_segments(reader, path, m)
            except InputDataError:
                raise
            except Exception as err:    # a damaged image subheader field
                _err(path, "ImageSegments", f"unreadable image subheader: {_line(err)}")
            try:
                data = _to_complex(reader.read_image(), m["pixel_type"], xml)
            except Exception as err:
                _err(path, "", f"pixels unreadable: {_line(err)}")
    return SicdProduct(data, xml, str(path), m, params)

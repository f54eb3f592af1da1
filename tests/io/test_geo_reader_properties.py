"""Property tests of the SICD and GeoTIFF readers (issue 27 item 4): a file written by sarnav, then truncated, with
bytes flipped in every part (file header, XML / IFD, pixels), with a field of its metadata set to an adversarial value
(NaN, inf, 0, negative, 1e300, 10^9 rows or columns, text), or with its XML replaced by an entity bomb, reads to a
correct product or to one ``InputDataError`` line naming ``sicd...`` / ``geotiff...`` — never another exception, a
hang (each read under :data:`SECONDS`) or memory beyond :data:`BUDGET_BYTES` (the process's peak RSS).

20 generated files per format by default, 200 under ``-m slow``; derandomized (the same files every time).
"""

from __future__ import annotations

import re
import resource
from pathlib import Path
import struct
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("sarkit")
pytest.importorskip("rasterio")
import sarkit.sicd as sksicd  # noqa: E402

from sarnav.errors import InputDataError  # noqa: E402
from sarnav.io.geotiff import read_dem, read_orthoimage, write_geotiff, write_plane_geotiff  # noqa: E402
from sarnav.io.sicd import SicdGeometry, read_sicd, write_image  # noqa: E402

#: the most one read may add to the process's peak resident memory [bytes] (the files are ~50 kB)
BUDGET_BYTES = 256 * 2**20
#: the longest one read may take [s]
SECONDS = 20.0
#: adversarial values of a metadata field
VALUES = ["nan", "inf", "-inf", "0", "-1", "1e300", "-1e300", "1e-300", "1000000000", "999999999999", "x", "",
          "0x10", "1e", "  7  ", "4294967297", "-0"]
BOMB = (b'<!DOCTYPE b [<!ENTITY a "aaaaaaaaaa">' + b"".join(
    b'<!ENTITY %s "%s">' % (bytes([98 + i]), (b"&%s;" % bytes([97 + i])) * 10) for i in range(8))
    + b']><SICD xmlns="urn:SICD:1.3.0">&i;</SICD>')
XXE = b'<!DOCTYPE s [<!ENTITY e SYSTEM "file:///etc/passwd">]><SICD xmlns="urn:SICD:1.3.0">&e;</SICD>'


def _property(n):
    return settings(max_examples=n, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def originals(ground_scene, tmp_path_factory):
    g = ground_scene
    out = tmp_path_factory.mktemp("originals")
    write_image(out / "image.nitf", g.image, SicdGeometry(g.grid, g.rc.positions, g.rc.pulse_times, g.rc.wavelength,
                                                          150e6))
    write_plane_geotiff(out / "image.tif", g.image.data[:40, :40], g.grid.resampled(None, (23.4, 23.4)))
    dem = np.add.outer(np.linspace(100, 140, 30), np.linspace(0, 20, 25)).astype(np.float32)
    dem[4, 4] = -9999.0
    write_geotiff(out / "dem.tif", dem, "EPSG:4326", (1e-4, 0, 151.2, 0, -1e-4, -33.9), nodata=-9999.0)
    with open(out / "image.nitf", "rb") as f:
        r = sksicd.NitfReader(f)
        des = r.jbp["DataExtensionSegments"][0]["DESDATA"]
        img = r.jbp["ImageSegments"][0]["Data"]
        sicd_parts = {"header": (0, img.get_offset()), "pixels": (img.get_offset(), img.get_offset() + img.size),
                      "xml": (des.get_offset(), des.get_offset() + des.size)}
    return {"sicd": (out / "image.nitf", sicd_parts), "geotiff": (out / "image.tif", None),
            "dem": (out / "dem.tif", None)}


def _tiff_entries(data: bytes):
    """(offset of each IFD entry, tag) of the first IFD of a little-endian classic TIFF."""
    off = struct.unpack("<I", data[4:8])[0]
    n = struct.unpack("<H", data[off:off + 2])[0]
    return [(off + 2 + 12 * i, struct.unpack("<H", data[off + 2 + 12 * i:off + 4 + 12 * i])[0]) for i in range(n)]


def _tiff_parts(data: bytes):
    entries = _tiff_entries(data)
    ifd = (entries[0][0] - 2, entries[-1][0] + 16)
    return {"header": (0, 8), "ifd": ifd, "rest": (ifd[1], len(data))}


def _set_xml_field(data: bytes, parts, fld: str, value: str, which: int = 0) -> bytes:
    """The SICD with the text of element ``fld`` (its ``which``-th occurrence, modulo their number) set to ``value``,
    CoreName resized so that the XML keeps its length (the NITF header's lengths stay true)."""
    lo, hi = parts["xml"]
    xml = data[lo:hi].decode()
    found = list(re.finditer(rf"(<ns0:{fld}(?: [^>]*)?>)([^<]*)(</ns0:{fld}>)", xml))
    assert found, fld
    m = found[which % len(found)]
    core = re.search(r"(<ns0:CoreName>)([^<]*)(</ns0:CoreName>)", xml)
    slack = len(core.group(2)) - (len(value) - len(m.group(2)))
    if slack < 1:
        return data
    new = xml[:m.start(2)] + value + xml[m.end(2):]
    core = re.search(r"(<ns0:CoreName>)([^<]*)(</ns0:CoreName>)", new)
    new = new[:core.start(2)] + "c" * slack + new[core.end(2):]
    assert len(new.encode()) == hi - lo
    return data[:lo] + new.encode() + data[hi:]


SICD_FIELDS = ["NumRows", "NumCols", "FirstRow", "SS", "X", "Y", "Z", "Row", "Col", "SideOfTrack", "Coef",
               "PixelType", "Type", "SCPTime", "CollectType", "ImpRespBW", "Lat", "ImagePlane"]
TIFF_TAGS = [256, 257, 258, 259, 273, 277, 278, 279, 284, 339, 33550, 33922, 34735, 42113]


@st.composite
def recipes(draw, fmt: str, size: int, parts):
    """A small description of one damage (printed by hypothesis when a case fails), applied by :func:`_apply`."""
    kind = draw(st.sampled_from(["truncate", "flip", "field"]))
    if kind == "truncate":
        return ("truncate", draw(st.integers(0, size - 1)))
    if kind == "flip":
        region = draw(st.sampled_from(sorted(parts)))
        lo, hi = parts[region]
        flips = draw(st.lists(st.tuples(st.integers(lo, hi - 1), st.integers(1, 255)), min_size=1, max_size=8))
        return ("flip", region, tuple(flips))
    if fmt == "sicd":
        return ("field", draw(st.sampled_from(SICD_FIELDS)), draw(st.sampled_from(VALUES)), draw(st.integers(0, 7)))
    return ("tag", draw(st.sampled_from(TIFF_TAGS)), draw(st.sampled_from([1, 1, 2, 10**6])),
            draw(st.sampled_from([0, 1, 3, 2**16, 10**9, 2**32 - 1, size + 10])))


def _apply(recipe, data: bytes, parts) -> bytes:
    if recipe[0] == "truncate":
        return data[:recipe[1]]
    buf = bytearray(data)
    if recipe[0] == "flip":
        for pos, mask in recipe[2]:
            buf[pos] ^= mask
        return bytes(buf)
    if recipe[0] == "field":
        return _set_xml_field(data, parts, *recipe[1:])
    entries = {tag: off for off, tag in _tiff_entries(data)}
    off = entries.get(recipe[1])
    if off is not None:      # type LONG, the drawn count and value (10^9 pixels wide, offsets past the end, ...)
        buf[off + 2:off + 12] = struct.pack("<HII", 4, recipe[2], recipe[3])
    return bytes(buf)


def _read(fmt, path):
    if fmt == "sicd":
        prod = read_sicd(path)
        assert prod.pixels.shape == prod.shape and prod.pixels.dtype == np.complex64
        assert np.all(np.isfinite(prod.image_to_ground(prod.shape[0] / 2, prod.shape[1] / 2)))
        return prod
    prod = (read_dem if fmt == "dem" else read_orthoimage)(path)
    assert prod.values.ndim == 2 and prod.values.size <= 2**27 and prod.crs is not None
    t = prod.transform
    assert np.isfinite([t.a, t.b, t.c, t.d, t.e, t.f]).all() and t.a * t.e - t.b * t.d != 0
    return prod


def _check(fmt, data: bytes, tmp_path, stats):
    path = tmp_path / ("x.nitf" if fmt == "sicd" else "x.tif")
    path.write_bytes(data)
    peak0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    t0 = time.perf_counter()
    try:
        _read(fmt, path)
        stats["read"] += 1
    except InputDataError as err:
        line = str(err)
        assert "\n" not in line and line.startswith("sicd" if fmt == "sicd" else "geotiff"), line
        stats["refused"] += 1
    assert time.perf_counter() - t0 < SECONDS
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - peak0 < BUDGET_BYTES


def _run(fmt, originals, tmp_path, n):
    path, parts = originals[fmt]
    data = path.read_bytes()
    parts = parts or _tiff_parts(data)
    stats = {"read": 0, "refused": 0}

    @_property(n)
    @given(recipe=recipes(fmt, len(data), parts))
    def prop(recipe):
        _check(fmt, _apply(recipe, data, parts), tmp_path, stats)

    prop()
    print(f"{fmt}: {stats}")
    assert stats["refused"] > 0


@pytest.mark.parametrize("fmt", ["sicd", "geotiff", "dem"])
def test_damaged_files_read_or_refuse_in_one_line(fmt, originals, tmp_path):
    _run(fmt, originals, tmp_path, 20)


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["sicd", "geotiff", "dem"])
def test_damaged_files_read_or_refuse_in_one_line_200(fmt, originals, tmp_path):
    _run(fmt, originals, tmp_path, 200)


def test_the_originals_read(originals):
    for fmt in originals:
        _read(fmt, originals[fmt][0])


@pytest.mark.parametrize("xml", [BOMB, XXE])
def test_entity_bombs_and_external_entities_are_refused_quickly(originals, tmp_path, xml):
    path, parts = originals["sicd"]
    data = path.read_bytes()
    lo, hi = parts["xml"]
    bad = tmp_path / "bomb.nitf"
    bad.write_bytes(data[:lo] + xml + b" " * (hi - lo - len(xml)) + data[hi:])
    t0 = time.perf_counter()
    with pytest.raises(InputDataError, match=r"^sicd") as err:
        read_sicd(bad)
    assert time.perf_counter() - t0 < 5.0 and "root:" not in str(err.value)


def test_a_header_claiming_a_billion_rows_is_refused_before_reading(originals, tmp_path):
    path, parts = originals["sicd"]
    bad = tmp_path / "huge.nitf"
    bad.write_bytes(_set_xml_field(path.read_bytes(), parts, "NumRows", "1000000000"))
    for pixels in (True, False):
        with pytest.raises(InputDataError, match=r"^sicd.ImageData.NumRows: .*\[1, 1e\+07\], got '1000000000'"):
            read_sicd(bad, pixels=pixels)
    bad.write_bytes(_set_xml_field(path.read_bytes(), parts, "NumRows", "9000000"))     # within the range
    with pytest.raises(InputDataError, match=r"^sicd.ImageData: 9000000 x 66 pixels exceed"):
        read_sicd(bad)
    tif = originals["geotiff"][0].read_bytes()
    buf = bytearray(tif)
    for off, tag in _tiff_entries(tif):
        if tag in (256, 257):
            buf[off + 2:off + 12] = struct.pack("<HII", 4, 1, 10**9)
    (tmp_path / "huge.tif").write_bytes(bytes(buf))
    with pytest.raises(InputDataError, match=r"^geotiff"):
        read_orthoimage(tmp_path / "huge.tif")


def test_damaged_files_print_nothing_in_a_plain_process(originals, tmp_path):
    """Outside pytest (no log capture): reading damaged files writes nothing to stderr (no traceback, no GDAL or jbpy
    log lines); each read gives a product or one error line."""
    import subprocess
    import sys

    rng = np.random.default_rng(3)
    files = []
    for fmt in ("sicd", "geotiff"):
        path, parts = originals[fmt]
        data = path.read_bytes()
        parts = parts or _tiff_parts(data)
        for k in range(40):
            region = sorted(parts)[k % len(parts)]
            lo, hi = parts[region]
            flips = tuple((int(rng.integers(lo, hi)), int(rng.integers(1, 256))) for _ in range(6))
            f = tmp_path / f"{fmt}{k}.{'nitf' if fmt == 'sicd' else 'tif'}"
            f.write_bytes(_apply(("flip", region, flips), data, parts))
            files.append(str(f))
    code = ("import sys\nfrom sarnav.errors import InputDataError\nfrom sarnav.io.sicd import read_sicd\n"
            "from sarnav.io.geotiff import read_orthoimage\n"
            "for f in sys.argv[1:]:\n    try:\n        (read_sicd if f.endswith('.nitf') else read_orthoimage)(f)\n"
            "        print('read')\n    except InputDataError as e:\n        print(str(e).splitlines()[0])\n")
    res = subprocess.run([sys.executable, "-c", code, *files], capture_output=True, text=True, timeout=300,
                         env={**__import__("os").environ, "PYTHONPATH": str(Path(__file__).parents[2] / "src")})
    assert res.returncode == 0 and res.stderr == "", res.stderr[-2000:]
    lines = res.stdout.splitlines()
    assert len(lines) == len(files) and all(x == "read" or x.startswith(("sicd", "geotiff")) for x in lines)

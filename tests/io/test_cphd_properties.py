"""Property tests of the CPHD reader (hypothesis): files corrupted in every block (header, XML, PVP, signal), truncated,
with bad numbers in the XML and the PVPs (NaN, inf, 0, negative, 1e300, 10^9), an XML bomb, changed header sizes:
reading and imaging each gives the one-line error (``SarnavError``, one line) or a finite result, never another
exception or a hang (a 10 s deadline per file), and ``tracemalloc`` never sees more than :data:`BUDGET`.

20 files per signal format by default, 200 under ``-m slow``."""

from __future__ import annotations

import re
import struct
import tempfile
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sarkit")
hypothesis = pytest.importorskip("hypothesis")
import sarkit.cphd as skcphd  # noqa: E402
import vendor_cphd as V  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from sarnav.errors import SarnavError  # noqa: E402
from sarnav.io.cphd import collect_grid, read_collect  # noqa: E402
from sarnav.io.cphd_read import open_collect  # noqa: E402
from sarnav.io.cphd_stream import image_collect  # noqa: E402

FORMATS = ("CF8", "CF16", "CI2", "CI4", "CI8")
BUDGET = 64 * 2**20
COL = V.Collect(n_pulses=16, n_samples=32, scss_jitter=0.0)
GRID = V.plane_grid(0.5, 21)
PAD = 24                                          # numeric XML texts padded to this width: edits keep the file's size
NUMERIC = ("FxC", "FxBW", "NumVectors", "NumSamples", "SGN", "LineSpacing", "SampleSpacing", "NumLines", "FirstLine",
           "Line", "NumBytesPVP", "SignalArrayByteOffset", "PVPArrayByteOffset", "Offset", "Size", "TOASaved")
VALUES = ("0", "-1", "NaN", "inf", "-inf", "1e300", "1e-300", "1000000000", "abc", "", "2.5", "-0", "3", "17")
PVP_VALUES = (np.nan, np.inf, -np.inf, 0.0, -1.0, 1e300, -1e300, 1e-300, 5.24288e5, 1e9)
_BASE: dict = {}


def base(fmt: str) -> bytes:
    """A good file's bytes, its numeric XML texts padded with spaces to PAD characters."""
    if fmt not in _BASE:
        tree = V.metadata(COL, fmt, -1)
        for el in tree.iter():
            name = et_name(el)
            if name in NUMERIC and el.text is not None and len(el) == 0:
                el.text = el.text.strip().ljust(PAD)
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "b.cphd"
            V.write(path, COL, fmt, -1, tree=tree)
            _BASE[fmt] = path.read_bytes()
    return _BASE[fmt]


def et_name(el) -> str:
    return el.tag.split("}")[-1] if isinstance(el.tag, str) else ""


def blocks(data: bytes) -> dict:
    """{block: (start, stop)} of the file's header, XML, PVP and signal blocks."""
    with tempfile.TemporaryFile() as f:
        f.write(data)
        f.seek(0)
        _, kvp = skcphd.read_file_header(f)
    out = {"header": (0, int(kvp["XML_BLOCK_BYTE_OFFSET"]))}
    for name in ("XML", "PVP", "SIGNAL"):
        a = int(kvp[f"{name}_BLOCK_BYTE_OFFSET"])
        out[name] = (a, a + int(kvp[f"{name}_BLOCK_SIZE"]))
    return out


def flips(data: bytes, block: str, spots) -> bytes:
    a, b = blocks(data)[block]
    out = bytearray(data)
    for frac, bit in spots:
        out[a + int(frac * (b - a - 1))] ^= 1 << bit
    return bytes(out)


def xml_value(data: bytes, name: str, which: int, value: str) -> bytes:
    hits = [m for m in re.finditer(rb"<(?:\w+:)?" + name.encode() + rb">([^<]{%d})</" % PAD, data)]
    if not hits:
        return data
    m = hits[which % len(hits)]
    return data[:m.start(1)] + value.encode().ljust(PAD)[:PAD] + data[m.end(1):]


def pvp_value(data: bytes, name: str, vector: int, component: int, value: float) -> bytes:
    a, _ = blocks(data)["PVP"]
    dt = V.pvp_dtype()
    off = a + vector * dt.itemsize + dt.fields[name][1] + 8 * (component % (3 if name.endswith("Pos") else 1))
    if name == "SIGNAL":
        return data
    return data[:off] + struct.pack(">d", value) + data[off + 8:]


def header_digits(data: bytes, key: str, digits: str) -> bytes:
    m = re.search(rb"^" + key.encode() + rb" := (\d+)$", data, re.M)
    if m is None:
        return data
    new = (digits * 20)[:len(m.group(1))].encode()
    return data[:m.start(1)] + new + data[m.end(1):]


def bomb(data: bytes) -> bytes:
    a, b = blocks(data)["XML"]
    ents = '<!ENTITY a0 "lol">' + "".join(f'<!ENTITY a{i} "{("&a%d;" % (i - 1)) * 10}">' for i in range(1, 10))
    doc = f'<?xml version="1.0"?><!DOCTYPE CPHD [{ents}]><CPHD xmlns="{V.NS}">&a9;</CPHD>'.encode()
    doc = doc + b" " * (b - a - len(doc))
    return data[:a] + doc[:b - a] + data[b:]


MUTATION = st.one_of(
    st.tuples(st.just("flips"), st.sampled_from(("header", "XML", "PVP", "SIGNAL")),
              st.lists(st.tuples(st.floats(0, 1), st.integers(0, 7)), min_size=1, max_size=8)),
    st.tuples(st.just("truncate"), st.floats(0, 1)),
    st.tuples(st.just("xml"), st.sampled_from(NUMERIC), st.integers(0, 3), st.sampled_from(VALUES)),
    st.tuples(st.just("pvp"), st.sampled_from([n for n, _ in V.PVP_LAYOUT]), st.integers(0, COL.n_pulses - 1),
              st.integers(0, 2), st.sampled_from(PVP_VALUES)),
    st.tuples(st.just("header"), st.sampled_from(("XML_BLOCK_SIZE", "PVP_BLOCK_SIZE", "SIGNAL_BLOCK_SIZE",
                                                  "PVP_BLOCK_BYTE_OFFSET", "SIGNAL_BLOCK_BYTE_OFFSET")),
              st.sampled_from(("9", "0", "1"))),
    st.tuples(st.just("bomb")),
)


def mutate(data: bytes, m) -> bytes:
    kind = m[0]
    if kind == "flips":
        return flips(data, m[1], m[2])
    if kind == "truncate":
        return data[:int(m[1] * len(data))]
    if kind == "xml":
        return xml_value(data, *m[1:])
    if kind == "pvp":
        return pvp_value(data, *m[1:])
    if kind == "header":
        return header_digits(data, m[1], m[2])
    return bomb(data)


def one_line(err: Exception) -> None:
    assert isinstance(err, SarnavError) and "\n" not in str(err) and re.match(r"^[\w.\-]+: ", str(err)), repr(err)


def read_and_image(path: Path) -> None:
    """The property: a finite result or one SarnavError line, within BUDGET."""
    tracemalloc.start()
    try:
        try:
            rc, _ = read_collect(path, budget=BUDGET)
        except SarnavError as err:
            one_line(err)
        else:
            assert np.all(np.isfinite(rc.data)) and rc.n_pulses >= 1
        try:
            c = open_collect(path)
            collect_grid(c)
            img = image_collect(c, GRID, budget=BUDGET)[0]
        except SarnavError as err:
            one_line(err)
        else:
            assert np.all(np.isfinite(img.data))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < BUDGET, peak


def _property(fmt: str, m) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "x.cphd"
        path.write_bytes(mutate(base(fmt), m))
        read_and_image(path)


@pytest.fixture(scope="module", autouse=True)
def warm():
    """Compile the kernels once (numba) outside the deadline and the memory measurement."""
    for fmt in FORMATS:
        base(fmt)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "w.cphd"
        path.write_bytes(base("CF8"))
        image_collect(open_collect(path), GRID)
        image_collect(open_collect(path), GRID, "ffbp")


def test_the_unmutated_files_image_their_target():
    from sarnav.signal.metrics import peak_location

    for fmt in FORMATS:
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "g.cphd"
            path.write_bytes(base(fmt))
            img = image_collect(open_collect(path), GRID)[0]
            assert np.max(np.abs(np.subtract(peak_location(img.data), (10.0, 10.0)))) < 0.1


_FAST = settings(max_examples=20, deadline=10000, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
_SLOW = settings(max_examples=200, deadline=10000, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.parametrize("fmt", FORMATS)
def test_reader_never_fails_otherwise(fmt):
    _FAST(given(m=MUTATION)(lambda m: _property(fmt, m)))()


@pytest.mark.slow
@pytest.mark.parametrize("fmt", FORMATS)
def test_reader_never_fails_otherwise_200(fmt):
    _SLOW(given(m=MUTATION)(lambda m: _property(fmt, m)))()

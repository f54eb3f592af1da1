"""Fields a CPHD file can carry that used to crash sarnav or take the machine down (issue 27): each is now one line,
an InputDataError naming the file's field and its valid range, raised before anything large is allocated; through the
command line one ``sarnav: error:`` line (exit 2)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

pytest.importorskip("sarkit")
import sarkit.cphd as skcphd  # noqa: E402
import vendor_cphd as V  # noqa: E402

from sarnav.cli.main import main  # noqa: E402
from sarnav.errors import InputDataError  # noqa: E402
from sarnav.io.cphd import read_collect  # noqa: E402
from sarnav.io.cphd_read import open_collect  # noqa: E402
from sarnav.io.cphd_stream import image_collect  # noqa: E402

COL = V.Collect(n_pulses=64, n_samples=64)


def parts(col=COL, fmt="CI4", sgn=-1):
    """(XML tree, PVPs, stored signal) of a good file, to corrupt before writing."""
    pvp = col.pvps(V.pvp_dtype())
    sig, amp = V.quantise(col.signal(pvp, sgn), fmt)
    pvp["AmpSF"] = amp
    return V.metadata(col, fmt, sgn), pvp, sig


def write(path, tree, pvp, sig, col=COL):
    V.write(path, col, tree=tree, pvp=pvp, signal=sig)
    return path


def set_text(tree, path, text):
    tree.find(path).text = text
    return tree


def drop(tree, path):
    el = tree.find(path)
    el.getparent().remove(el)
    return tree


FXC = "./{*}Channel/{*}Parameters/{*}FxC"
GRID = "./{*}SceneCoordinates/{*}ImageGrid/{*}"


def cases():
    """(name, corrupt(tree, pvp, sig) -> (tree, pvp, sig), field, message regex)."""
    def xml(f):
        return lambda t, p, s: (f(t), p, s)

    def pvp(f):
        def g(t, p, s):
            f(p)
            return t, p, s
        return g

    return [
        ("FxC = 0", xml(lambda t: set_text(t, FXC, "0")), "cphd.Channel.Parameters.FxC",
         r"must be finite and > 0 Hz, got 0.0$"),
        ("FxC = NaN", xml(lambda t: set_text(t, FXC, "NaN")), "cphd.Channel.Parameters.FxC",
         r"must be finite and > 0 Hz, got nan$"),
        ("no IARPLocation", xml(lambda t: drop(t, GRID + "IARPLocation")), "cphd.SceneCoordinates.ImageGrid.IARPLocation",
         "missing required"),
        ("no LineSpacing", xml(lambda t: drop(t, GRID + "IAXExtent/{*}LineSpacing")),
         "cphd.SceneCoordinates.ImageGrid.IAXExtent.LineSpacing", "missing required"),
        ("10^9 lines", xml(lambda t: set_text(t, GRID + "IAXExtent/{*}NumLines", "1000000000")),
         "cphd.SceneCoordinates.ImageGrid.IAXExtent.NumLines", r"must be an integer in \[1, 1048576\], got 1000000000"),
        ("SCSS = 1e300", pvp(lambda p: p["SCSS"].__setitem__(7, 1e300)), "cphd.PVP.SCSS",
         r"the 64 samples of vector 7 reach .* must stay below 2 FxC = .*, got SCSS = 1e\+300"),
        ("SCSS = 1e-300", pvp(lambda p: p["SCSS"].__setitem__(5, 1e-300)), "cphd.PVP.SCSS",
         r"the 64 samples of vector 5 span 6.3e-299 Hz: they must cover at least half the channel's FxBW"),
        ("TOA domain", xml(lambda t: set_text(t, "./{*}Global/{*}DomainType", "TOA")), "cphd.Global.DomainType",
         r"must be 'FX' .* got 'TOA'"),
        ("all at one position", pvp(lambda p: [p[k].__setitem__(n, p[0][n]) for k in range(len(p))
                                                for n in ("TxPos", "RcvPos")]),
         "cphd.PVP.TxPos", r"the 64 vectors span 0 m of track: no synthetic aperture \(at least one wavelength"),
        ("bistatic", pvp(lambda p: p["RcvPos"].__setitem__(slice(None), p["RcvPos"] + [0.0, 0.0, 300.0])),
         "cphd.PVP.RcvPos", r"is 300 m from TxPos in vector \d+: a bistatic collect .* at most lambda / 16"),
        ("SGN = 0", xml(lambda t: set_text(t, "./{*}Global/{*}SGN", "0")), "cphd.Global.SGN", r"must be -1 or \+1"),
        ("TOA2 <= TOA1", pvp(lambda p: p["TOA2"].__setitem__(3, p["TOA1"][3])), "cphd.PVP.TOA2",
         r"must be > TOA1 in every vector \(vector 3\)"),
        ("NaN TDTropoSRP", pvp(lambda p: p["TDTropoSRP"].__setitem__(9, np.nan)), "cphd.PVP.TDTropoSRP",
         "must be finite: NaN/inf in vector 9"),
        ("NaN AmpSF", pvp(lambda p: p["AmpSF"].__setitem__(2, np.inf)), "cphd.PVP.AmpSF",
         "must be finite: NaN/inf in vector 2"),
    ]


CASES = cases()


def _image(path):
    c = open_collect(path)
    from sarnav.io.cphd import collect_grid

    return image_collect(c, collect_grid(c))


@pytest.mark.parametrize("name, corrupt, field, message", CASES, ids=[c[0] for c in CASES])
def test_corrupt_field_is_one_line_naming_it(tmp_path, name, corrupt, field, message):
    path = write(tmp_path / "bad.cphd", *corrupt(*parts()))
    with pytest.raises(InputDataError) as info:
        _image(path)
    err = info.value
    assert err.field == field and "\n" not in str(err), str(err)
    assert __import__("re").search(message, err.message), str(err)


def _flip(path, byte_offset, bit):
    data = bytearray(path.read_bytes())
    data[byte_offset] ^= 1 << bit
    path.write_bytes(bytes(data))


def test_one_flipped_bit_moving_a_position_524_km(tmp_path):
    """Bit 50 of TxPos.X (|X| in [2^21, 2^22) m) is worth 2^19 m = 524 km: the old reader made a 1.75e6-sample range
    axis and was killed for memory; now the vector and field are named."""
    path = write(tmp_path / "flip.cphd", *parts())
    with open(path, "rb") as f:
        _, kvp = skcphd.read_file_header(f)
    k = 17
    off = int(kvp["PVP_BLOCK_BYTE_OFFSET"]) + k * V.pvp_dtype().itemsize + 8 * 1     # TxPos follows TxTime
    before = struct.unpack(">d", path.read_bytes()[off:off + 8])[0]
    _flip(path, off + 1, 2)                                      # big-endian: bit 50 is in byte 1, bit 2
    after = struct.unpack(">d", path.read_bytes()[off:off + 8])[0]
    assert abs(abs(after - before) - 2**19) < 1e-6
    with pytest.raises(InputDataError, match=r"^cphd.PVP.TxPos: vector 17 is 5.243e\+05 m from the others' "
                                             r"median \(times as c t / 2\): the vectors' range windows span .* samples, at most 16 N = 1024"):
        read_collect(path)


def test_header_claiming_a_billion_vectors(tmp_path):
    """NumVectors written as 0000000064 (a valid xs:positiveInteger), then patched to 1000000000 in place: refused
    from the file's size, nothing allocated."""
    tree, pvp, sig = parts()
    set_text(tree, "./{*}Data/{*}Channel/{*}NumVectors", "0000000064")
    path = write(tmp_path / "big.cphd", tree, pvp, sig)
    data = path.read_bytes()
    assert data.count(b">0000000064<") == 1
    path.write_bytes(data.replace(b">0000000064<", b">1000000000<"))
    with pytest.raises(InputDataError, match=r"^cphd.Data.Channel.NumVectors: 1000000000 vectors x 64 samples \(CI4\) "
                                             r"need [\d,]+ bytes, the file has [\d,]+"):
        read_collect(path)


def test_truncated_file_and_compressed_signal(tmp_path):
    path = write(tmp_path / "t.cphd", *parts())
    path.write_bytes(path.read_bytes()[:-100])
    with pytest.raises(InputDataError, match=r"^cphd.Data.Channel.NumVectors: 64 vectors x 64 samples \(CI4\) need "
                                             r"[\d,]+ bytes, the file has [\d,]+: a truncated file"):
        read_collect(path)
    tree, pvp, sig = parts()
    data = tree.find("./{*}Data")
    el = data.makeelement(data[0].tag.replace("SignalArrayFormat", "SignalCompressionID"))
    el.text = "vendor-zip"
    data.insert(list(data).index(data.find("./{*}NumSupportArrays")) + 1, el)
    write(tmp_path / "c.cphd", tree, pvp, sig)
    with pytest.raises(InputDataError, match=r"^cphd.Data.SignalCompressionID: compressed signal arrays are not read "
                                             r".* got 'vendor-zip'$"):
        read_collect(tmp_path / "c.cphd")


def test_command_line_prints_one_line(tmp_path, capsys):
    tree, pvp, sig = parts()
    path = write(tmp_path / "fxc.cphd", set_text(tree, FXC, "0"), pvp, sig)
    assert main(["image", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["sarnav: error: cphd.Channel.Parameters.FxC: must be finite and > 0 Hz, got 0.0"]
    good = write(tmp_path / "good.cphd", *parts())
    for flags, field in ((["--channel", "2"], "--channel"), (["--pulses", "10:5"], "--pulses"),
                         (["--pulses", "a:b"], "--pulses"), (["--budget", "1K"], "--budget"),
                         (["--budget", "lots"], "--budget")):
        assert main(["image", str(good), *flags, "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"sarnav: error: {field}: "), err

"""``sarnav.io.cphd_checks``: a CPHD header's values read by path, and the per-vector parameters checked against their
valid ranges, each failure one InputDataError line naming the file's field (``cphd.PVP.SCSS``) and the vector.

The PVP arrays are numpy structured arrays built here (the CPHD standard's F8 fields); the thresholds are computed
by hand from the checks' documented rules.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from sarnav.errors import InputDataError
from sarnav.io.cphd_checks import (MAX_SAMPLE, MAX_SPAN, XmlValues, check_band, check_monostatic, check_pvps,
                                   check_span, field_name, need)

C = 299792458.0
NS = "http://api.nsgreg.nga.mil/schema/cphd/1.0.1"
FXC, N, SCSS = 9.75e9, 64, 0.5e6
FXBW = (N - 1) * SCSS

XML = f"""<CPHD xmlns="{NS}">
  <Global><DomainType>FX</DomainType><SGN>-1</SGN></Global>
  <Data><SignalArrayFormat>CF8</SignalArrayFormat><NumBytesPVP>184</NumBytesPVP>
    <Channel><Identifier>A</Identifier><NumVectors>10</NumVectors></Channel>
    <Channel><Identifier>B</Identifier><NumVectors>20</NumVectors></Channel></Data>
  <Channel><Parameters><Identifier>A</Identifier><FxC>9.75e9</FxC><FxBW>3.15e7</FxBW></Parameters></Channel>
  <SceneCoordinates><IARP><ECF><X>1.5</X><Y>-2</Y><Z>3e6</Z></ECF></IARP>
    <Bad><X>1.0</X><Y>north</Y></Bad></SceneCoordinates>
</CPHD>"""


@pytest.fixture
def xml():
    return XmlValues(ET.ElementTree(ET.fromstring(XML)))


def pvps(n_vec=8, start_time=0.0, **extra) -> np.ndarray:
    """A monostatic collect of ``n_vec`` vectors: antenna flying north 2 km east and 1 km above the SRP (origin),
    TOA window +-1 us, FX samples over the band centred on FXC."""
    fields = [("TxTime", "f8"), ("TxPos", "f8", (3,)), ("RcvPos", "f8", (3,)), ("SRPPos", "f8", (3,)),
              ("SC0", "f8"), ("SCSS", "f8"), ("TOA1", "f8"), ("TOA2", "f8"), ("TDTropoSRP", "f8")]
    fields += [(name, "f8") for name in extra]
    p = np.zeros(n_vec, dtype=fields)
    p["TxTime"] = start_time + np.arange(n_vec) / 100.0
    pos = np.column_stack([np.full(n_vec, 2000.0), 10.0 * np.arange(n_vec), np.full(n_vec, 1000.0)])
    p["TxPos"] = p["RcvPos"] = pos
    p["SC0"] = FXC - 0.5 * FXBW
    p["SCSS"] = SCSS
    p["TOA1"], p["TOA2"] = -1e-6, 1e-6
    for name, value in extra.items():
        p[name] = value
    return p


def ref_range(p) -> np.ndarray:
    """(|TxPos - SRPPos| + |RcvPos - SRPPos|) / 2 (docs/recording.md §5)."""
    return 0.5 * (np.linalg.norm(p["TxPos"] - p["SRPPos"], axis=1) + np.linalg.norm(p["RcvPos"] - p["SRPPos"], axis=1))


def refused(fn, *args) -> InputDataError:
    with pytest.raises(InputDataError) as err:
        fn(*args)
    assert "\n" not in str(err.value)
    return err.value


# ---- XmlValues, need, field_name -----------------------------------------------------------------------------------


def test_xml_values_are_ints_floats_strings_and_vectors(xml):
    assert xml.load("./{*}Global/{*}DomainType") == "FX"
    sgn = xml.load("./{*}Global/{*}SGN")
    assert sgn == -1 and isinstance(sgn, int)
    fxc = xml.load("./{*}Channel/{*}Parameters[{*}Identifier='A']/{*}FxC")
    assert fxc == 9.75e9 and isinstance(fxc, float)
    iarp = xml.load("./{*}SceneCoordinates/{*}IARP/{*}ECF")
    assert iarp.dtype == np.float64
    np.testing.assert_array_equal(iarp, [1.5, -2.0, 3e6])
    assert xml.load("./{*}Data/{*}Channel[{*}Identifier='B']/{*}NumVectors") == 20
    assert xml.load("./{*}Global/{*}CollectType") is None


def test_need_returns_the_value_or_names_the_missing_field(xml):
    assert need(xml, "./{*}Data/{*}SignalArrayFormat", "signal array format") == "CF8"
    err = refused(need, xml, "./{*}Global/{*}Timeline", "timeline")
    assert str(err) == "cphd.Global.Timeline: missing required timeline"


def test_need_names_an_unreadable_value(xml):
    err = refused(need, xml, "./{*}SceneCoordinates/{*}Bad", "vector")
    assert err.field == "cphd.SceneCoordinates.Bad"
    assert err.message.startswith("unreadable vector (ValueError: ")


@pytest.mark.parametrize("path, name", [
    ("./{*}Global/{*}DomainType", "cphd.Global.DomainType"),
    ("./{*}Channel/{*}Parameters[{*}Identifier='1']/{*}FxC", "cphd.Channel.Parameters.FxC"),
    ("./{*}Data/{*}Channel[{*}Identifier='CH 2']/{*}NumVectors", "cphd.Data.Channel.NumVectors"),
    ("./{*}PVP/{*}TxPos", "cphd.PVP.TxPos"),
])
def test_field_name_drops_namespaces_and_predicates(path, name):
    assert field_name(path) == name


# ---- check_pvps ----------------------------------------------------------------------------------------------------


def test_good_pvps_pass_every_check():
    p = pvps(AmpSF=1.0)
    check_pvps(p, 0)
    check_band(p, N, FXC, FXBW, 0)
    check_span(p, ref_range(p), N, 0)
    check_monostatic(p, FXC, 0)


@pytest.mark.parametrize("name, index", [("TxPos", 3), ("SRPPos", 0), ("TOA2", 7), ("SC0", 5), ("TxTime", 2)])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_pvp_names_field_and_vector(name, index, bad):
    p = pvps()
    if p.dtype[name].shape:
        p[name][index, 1] = bad
    else:
        p[name][index] = bad
    err = refused(check_pvps, p, 100)
    assert str(err) == f"cphd.PVP.{name}: must be finite: NaN/inf in vector {100 + index}"


def test_pvp_of_the_wrong_type_or_shape_is_named():
    p = pvps()
    fields = [(n, "f8", (2,) if n == "RcvPos" else p.dtype[n].shape) for n in p.dtype.names]
    err = refused(check_pvps, np.zeros(len(p), dtype=fields), 0)
    assert str(err) == "cphd.PVP.RcvPos: must be X=F8;Y=F8;Z=F8;, got a float64 field of shape (2,)"
    fields = [(n, "i8" if n == "TOA1" else p.dtype[n].base, p.dtype[n].shape) for n in p.dtype.names]
    err = refused(check_pvps, np.zeros(len(p), dtype=fields), 0)
    assert str(err) == "cphd.PVP.TOA1: must be F8, got a int64 field of shape ()"
    fields = [(n, "f8", (3,) if n == "SCSS" else p.dtype[n].shape) for n in p.dtype.names]
    assert refused(check_pvps, np.zeros(len(p), dtype=fields), 0).field == "cphd.PVP.SCSS"


def test_float32_pvp_is_refused_as_not_f8():
    p = pvps()
    fields = [(n, "f4" if n == "TxPos" else p.dtype[n].base, p.dtype[n].shape) for n in p.dtype.names]
    q = np.zeros(len(p), dtype=fields)
    for n in p.dtype.names:
        q[n] = p[n]
    err = refused(check_pvps, q, 0)
    assert err.field == "cphd.PVP.TxPos"


def test_ampsf_at_or_beyond_the_sample_limit_is_named():
    p = pvps(AmpSF=1.0)
    p["AmpSF"][4] = -MAX_SAMPLE
    err = refused(check_pvps, p, 10)
    assert str(err) == f"cphd.PVP.AmpSF: must be below {MAX_SAMPLE:.0e} in magnitude, got {-MAX_SAMPLE!r} in vector 14"
    p["AmpSF"][4] = 0.999 * MAX_SAMPLE
    check_pvps(p, 10)


def test_decreasing_tx_time_is_named_and_equal_times_pass():
    p = pvps()
    p["TxTime"][5] = p["TxTime"][4]
    check_pvps(p, 0)
    p["TxTime"][6] = p["TxTime"][4] - 1e-9
    assert str(refused(check_pvps, p, 20)) == "cphd.PVP.TxTime: must not decrease from vector to vector (vector 26)"


# ---- check_band ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["SC0", "SCSS"])
@pytest.mark.parametrize("value", [0.0, -1.0, np.nan])
def test_start_frequency_and_spacing_must_be_positive(name, value):
    p = pvps()
    p[name][2] = value
    err = refused(check_band, p, N, FXC, FXBW, 40)
    assert err.field == f"cphd.PVP.{name}"
    assert err.message == f"must be > 0 Hz (FX domain), got {float(value)!r} in vector 42"


def test_samples_must_span_half_the_channel_bandwidth():
    """(N - 1) SCSS >= FxBW / 2: the spacing FxBW / (2 (N - 1)) passes, just below it is named."""
    p = pvps()
    p["SCSS"][3] = 0.5 * FXBW / (N - 1)
    check_band(p, N, FXC, FXBW, 0)
    p["SCSS"][3] = 0.5 * FXBW / (N - 1) * (1 - 1e-9)
    err = refused(check_band, p, N, FXC, FXBW, 0)
    assert err.field == "cphd.PVP.SCSS"
    assert err.message.startswith(f"the {N} samples of vector 3 span ")
    assert "they must cover at least half the channel's FxBW" in err.message


def test_samples_must_stay_below_twice_the_carrier():
    """SC0 + (N - 1) SCSS < 2 FxC."""
    p = pvps()
    p["SC0"][1] = 2 * FXC - (N - 1) * SCSS
    err = refused(check_band, p, N, FXC, FXBW, 0)
    assert err.field == "cphd.PVP.SCSS"
    assert err.message.startswith(f"the {N} samples of vector 1 reach ")
    assert "must stay below 2 FxC" in err.message
    p["SC0"][1] = 2 * FXC - (N - 1) * SCSS - 1e3
    check_band(p, N, FXC, FXBW, 0)


def test_toa_window_must_be_open():
    p = pvps()
    p["TOA2"][6] = p["TOA1"][6]
    assert str(refused(check_band, p, N, FXC, FXBW, 1)) == "cphd.PVP.TOA2: must be > TOA1 in every vector (vector 7)"


# ---- check_monostatic ----------------------------------------------------------------------------------------------


def test_receive_position_apart_from_transmit_is_bistatic_beyond_lambda_over_16():
    """|b|^2 / (4 R) <= lambda / 16 passes (R the shorter leg to the SRP); beyond it RcvPos is named."""
    p = pvps()
    lam16 = C / FXC / 16.0
    r = np.linalg.norm(p["TxPos"][2])  # SRP at the origin
    b_ok = np.sqrt(4 * r * lam16) * 0.9  # the receive leg is a little longer than r: R = r
    p["RcvPos"][2] = p["TxPos"][2] + [0.0, b_ok, 0.0]
    check_monostatic(p, FXC, 0)
    b_bad = np.sqrt(4 * r * lam16) * 1.2
    p["RcvPos"][2] = p["TxPos"][2] + [0.0, b_bad, 0.0]
    err = refused(check_monostatic, p, FXC, 30)
    assert err.field == "cphd.PVP.RcvPos"
    assert err.message.startswith(f"is {b_bad:.4g} m from TxPos in vector 32: a bistatic collect")
    assert f"lambda / 16 = {lam16:.3g} m" in err.message


# ---- check_span ----------------------------------------------------------------------------------------------------


def test_span_within_the_limit_passes_and_a_jumped_vector_is_named():
    """A position moved by 500 km in one vector spreads the range windows over far more than MAX_SPAN x N samples:
    the field and the vector that jump are named."""
    p = pvps()
    p["SRPPos"][5] = [0.0, 5e5, 0.0]
    err = refused(check_span, p, ref_range(p), N, 200)
    assert err.field == "cphd.PVP.SRPPos"
    assert err.message.startswith("vector 205 is ")
    assert f"at most {MAX_SPAN} N = {MAX_SPAN * N}" in err.message


def test_span_limit_is_max_span_times_n_samples():
    """The windows' union [min(ref + c TOA1 / 2), max(ref + c TOA2 / 2)] in range cells c / (2 N SCSS)."""
    p = pvps()
    dr = C / (2.0 * N * SCSS)
    ref = np.full(len(p), 3000.0)
    base = (p["TOA2"][0] - p["TOA1"][0]) * 0.5 * C
    limit = MAX_SPAN * N * dr
    ref[3] = 3000.0 + (limit - base) * 0.99  # still inside
    check_span(p, ref, N, 0)
    p["TOA2"][4] = p["TOA2"][4] + 2.0 * (limit - base) * 1.05 / C  # the union now exceeds the limit
    err = refused(check_span, p, ref, N, 0)
    assert err.field == "cphd.PVP.TOA2"
    assert err.message.startswith("vector 4 is ")

"""CPHD files written the way vendors write them (sarkit directly, tests/io/vendor_cphd.py): every signal format with
a per-vector AmpSF, SGN +-1, per-vector SC0 / SCSS, TDTropoSRP both ways, a chosen channel and a range of vectors,
a near-monostatic geometry. Each image is checked against the targets' known positions and against the CF8 image."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sarkit")
import vendor_cphd as V  # noqa: E402  (tests/io is on sys.path)

from sarnav.errors import ConfigError, InputDataError  # noqa: E402
from sarnav.imaging.backprojection import backproject  # noqa: E402
from sarnav.io.cphd import read_collect, read_phase_history  # noqa: E402
from sarnav.io.cphd_read import open_collect  # noqa: E402
from sarnav.io.cphd_stream import image_collect  # noqa: E402
from sarnav.signal.metrics import peak_location  # noqa: E402

GRID = V.plane_grid()                 # 81 x 81 at 0.25 m, east (rows) x north (cols) about the SRP
CENTRE = 40.0                         # the pixel of the SRP, where target 0 lies


def error_db(a, b):
    return float(10 * np.log10(max(np.sum(np.abs(a - b) ** 2), 1e-300) / np.sum(np.abs(b) ** 2)))


def gained(a, ref):
    """``a`` times the one complex gain that best matches ``ref`` (least squares)."""
    return a * (np.vdot(a, ref) / np.vdot(a, a))


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    root = tmp_path_factory.mktemp("formats")
    out = {}
    for fmt in ("CF8", "CF16", "CI2", "CI4", "CI8", "CI16"):
        for sgn in (-1, 1):
            path = root / f"{fmt}{sgn:+d}.cphd"
            V.write(path, V.Collect(), fmt, sgn)
            out[fmt, sgn] = image_collect(open_collect(path), GRID)[0].data
    return out


@pytest.mark.parametrize("fmt", ["CF8", "CF16", "CI2", "CI4", "CI8", "CI16"])
@pytest.mark.parametrize("sgn", [-1, 1])
def test_every_format_and_sign_gives_the_same_image(images, fmt, sgn):
    ref = images["CF8", -1]
    img = images[fmt, sgn]
    err = error_db(gained(img, ref), ref)
    p_ref, p = peak_location(ref), peak_location(img)
    print(f"{fmt} SGN {sgn:+d}: {err:.1f} dB against CF8, peak {p}")
    assert err < -60.0
    assert np.max(np.abs(np.subtract(p, p_ref))) < 0.01
    assert np.max(np.abs(np.subtract(p, (CENTRE, CENTRE)))) < 0.05          # the target where it is


def test_amplitude_scale_is_applied(tmp_path):
    """Without AmpSF the integer image would be a sum of vectors at unequal gains: compare the read samples with the
    model's directly (CI4, quantisation ~1e-4 of full scale)."""
    col = V.Collect(n_pulses=16)
    pvp = V.write(tmp_path / "a.cphd", col, "CI4", -1)
    ph, _, _ = read_phase_history(tmp_path / "a.cphd")
    truth = col.signal(pvp, -1)
    assert np.ptp(pvp["AmpSF"]) > 0.3 * np.max(pvp["AmpSF"])                 # the gains differ
    assert np.max(np.abs(ph.data - truth)) < 2e-4 * np.max(np.abs(truth))


def test_channel_and_range_of_vectors(tmp_path):
    path = tmp_path / "two.cphd"
    V.write(path, V.Collect(), "CI4", -1, channels=("HH", "VV"))
    whole = open_collect(path, channel="VV")
    part = open_collect(path, channel="VV", pulses=(40, 120))
    assert (whole.channel, part.n_pulses) == ("VV", 80)
    np.testing.assert_array_equal(part.phase_history().data, whole.phase_history(40, 120).data)
    np.testing.assert_array_equal(part.positions, whole.positions[40:120])
    rc, _ = read_collect(path, channel="HH", pulses=(0, 100))
    assert rc.n_pulses == 100 and rc.metadata["channel"] == "HH"
    with pytest.raises(ConfigError, match=r"^channel: must be one of the file's channels \('HH', 'VV'\), got 'X'$"):
        open_collect(path, channel="X")
    with pytest.raises(ConfigError, match=r"^pulses: must satisfy 0 <= start < stop <= 160"):
        open_collect(path, pulses=(100, 200))


def test_a_range_of_vectors_skips_a_bad_vector_outside_it(tmp_path):
    col = V.Collect()
    pvp = col.pvps(V.pvp_dtype())
    s = col.signal(pvp, -1).astype(np.complex64)
    s[10, 3] = np.nan
    pvp["AmpSF"] = 1.0
    V.write(tmp_path / "nan.cphd", col, "CF8", -1, pvp=pvp, signal=s)
    with pytest.raises(InputDataError, match=r"^cphd.Signal: must be finite: NaN/inf in vector 10$"):
        read_collect(tmp_path / "nan.cphd")
    rc, _ = read_collect(tmp_path / "nan.cphd", pulses=(11, 160))
    assert rc.n_pulses == 149 and np.all(np.isfinite(rc.data))


@pytest.mark.parametrize("in_data", [True, False])
def test_tropo_delay_both_readings(tmp_path, in_data):
    """25 ns of two-way troposphere delay (3.75 m of range): the reading that matches how the file was made puts the
    target on its pixel; the other displaces it by c TDTropoSRP / 2 in slant range, 3.75 / cos(graze) m on the
    ground (graze = atan(1500 / 2000)), along +east when the delay is left in and -east when it was compensated."""
    col = V.Collect(tropo=25e-9, tropo_in_data=in_data)
    path = tmp_path / "tropo.cphd"
    V.write(path, col, "CI4", -1)
    right, wrong = ("in-data", "compensated") if in_data else ("compensated", "in-data")
    p_right = peak_location(image_collect(open_collect(path, tropo=right), GRID)[0].data)
    p_wrong = peak_location(image_collect(open_collect(path, tropo=wrong), GRID)[0].data)
    shift = 0.5 * V.C * 25e-9 / 0.8 / 0.25 * (1 if in_data else -1)           # cells along east (rows)
    print(f"tropo in data {in_data}: right {p_right}, wrong {p_wrong}, expected shift {shift:.2f} cells")
    assert np.max(np.abs(np.subtract(p_right, (CENTRE, CENTRE)))) < 0.05
    assert abs(p_wrong[0] - CENTRE - shift) < 0.3 and abs(p_wrong[1] - CENTRE) < 0.3
    with pytest.raises(ConfigError, match=r"^tropo: must be one of \('in-data', 'compensated'\)"):
        open_collect(path, tropo="ignore")


def test_transmit_and_receive_apart_by_motion_image_with_the_two_leg_mean(tmp_path):
    """RcvPos 1 m from TxPos (a platform's motion during the echo's flight): the legs' mean is exact to
    b^2 / 4R = 1e-4 m, and the target stays on its pixel; 200 m apart (bistatic) is refused naming RcvPos."""
    V.write(tmp_path / "near.cphd", V.Collect(bistatic=1.0), "CF8", -1)
    p = peak_location(image_collect(open_collect(tmp_path / "near.cphd"), GRID)[0].data)
    assert np.max(np.abs(np.subtract(p, (CENTRE, CENTRE)))) < 0.05
    V.write(tmp_path / "far.cphd", V.Collect(bistatic=200.0), "CF8", -1)
    with pytest.raises(InputDataError, match=r"^cphd.PVP.RcvPos: is 200 m from TxPos in vector \d+: a bistatic collect "
                                             r".* at most lambda / 16 = 0.00195 m"):
        open_collect(tmp_path / "far.cphd")


def test_in_memory_read_and_stream_agree_with_bpa(tmp_path):
    path = tmp_path / "m.cphd"
    V.write(path, V.Collect(), "CI2", 1)
    c = open_collect(path)
    img, _, metrics = image_collect(c, GRID, "bpa", budget=5 * 2**20)
    assert metrics["stream"]["blocks"] > 1
    rc, _ = read_collect(path)
    ref = backproject(rc, GRID, interpolation=img.metadata["interpolation"], upsample=img.metadata.get("upsample", 4))
    assert error_db(img.data, ref.data) < -100.0

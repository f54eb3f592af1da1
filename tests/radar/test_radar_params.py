"""RadarParams: derived quantities against the sources and one-line errors for bad values."""

import dataclasses
import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.signal.windows import Window
from sarnav.radar.params import RadarParams
from sarnav.radar.presets import FLEXSAR_RANGES, NAV_PAPER_SIM_RANGES, flexsar, nav_paper_sim

C = 299_792_458.0


def _base(**kw):
    d = dict(carrier_frequency=9.75e9, bandwidth=500e6, pulse_length=1e-6, sample_rate=1e9, prf=100.0,
             near_range=2000.0, n_range_samples=2048, antenna_length=0.2)
    d.update(kw)
    return RadarParams(**d)


def test_derived_quantities():
    p = _base()
    assert p.wavelength == pytest.approx(0.030748, abs=1e-6)  # thesis §9.4
    assert p.chirp_rate == pytest.approx(5e14)
    assert p.range_resolution == pytest.approx(0.886 * C / 1e9)
    assert p.range_bin_spacing == pytest.approx(0.1499, abs=1e-4)  # Table 5.1 "0.15 m"
    ax = p.slant_range_axis
    assert ax.dtype == np.float64 and ax.shape == (2048,)
    assert ax[0] == 2000.0 and ax[-1] == pytest.approx(p.far_range)
    assert np.diff(ax) == pytest.approx(C / 2e9)
    assert p.beamwidth == pytest.approx(0.886 * p.wavelength / 0.2)
    # Doppler bandwidth (4V/lambda) sin(theta/2) ~ 0.886 * 2V/L for a narrow beam
    assert p.doppler_bandwidth(10.0) == pytest.approx(0.886 * 2 * 10 / 0.2, rel=1e-3)
    # with squint: (2V/lambda) [sin(sq + bw/2) - sin(sq - bw/2)] (Cumming & Wong eq. 4.36)
    sq, bw = 0.3, p.beamwidth
    expected = 2 * 10.0 / p.wavelength * (np.sin(sq + bw / 2) - np.sin(sq - bw / 2))
    assert p.doppler_bandwidth(10.0, squint=sq) == pytest.approx(expected, rel=1e-12)
    with pytest.raises(ConfigError, match="^squint"):
        p.validate(speed=1.0, squint=2.0)
    q = _base(antenna_length=None, azimuth_beamwidth=p.beamwidth)
    assert q.effective_antenna_length == pytest.approx(0.2)


def test_presets_match_source_tables():
    s = nav_paper_sim()
    assert (s.carrier_frequency, s.bandwidth, s.sample_rate, s.prf) == (9.75e9, 500e6, 1e9, 100.0)
    lo, hi = s.target_range_limits
    assert lo <= NAV_PAPER_SIM_RANGES[0] + 1e-9 and hi >= NAV_PAPER_SIM_RANGES[1]
    assert hi - NAV_PAPER_SIM_RANGES[1] < s.range_bin_spacing
    f = flexsar()
    assert f.sample_rate == f.bandwidth == 500e6  # over-sample 1 allowed with equality
    assert f.range_bin_spacing == pytest.approx(0.2998, abs=1e-4)  # Table 5.3
    assert f.prf == pytest.approx(1667, abs=0.5)
    lo, hi = f.target_range_limits
    assert lo <= FLEXSAR_RANGES[0] + 1e-9 and hi >= FLEXSAR_RANGES[1]
    s.validate(speed=10.0)
    f.validate(speed=60.0)
    assert nav_paper_sim(prf=200.0).prf == 200.0


@pytest.mark.parametrize("field,value", [
    ("carrier_frequency", -1.0), ("bandwidth", 0.0), ("pulse_length", float("nan")),
    ("sample_rate", float("inf")), ("prf", -5.0), ("near_range", 0.0),
])
def test_non_positive_values(field, value):
    with pytest.raises(ConfigError, match=f"^{field}: must be finite and > 0"):
        _base(**{field: value})


def test_other_bad_values():
    with pytest.raises(ConfigError, match="^sample_rate: must be >= bandwidth"):
        _base(sample_rate=400e6)
    with pytest.raises(ConfigError, match="^pulse_length: must be shorter than the receive window"):
        _base(n_range_samples=900)
    with pytest.raises(ConfigError, match="^n_range_samples"):
        _base(n_range_samples=10.5)
    with pytest.raises(ConfigError, match="^antenna_length: give exactly one"):
        _base(azimuth_beamwidth=0.1)
    with pytest.raises(ConfigError, match="^look_side"):
        _base(look_side="up")
    with pytest.raises(ConfigError, match="^range_window"):
        _base(range_window="blackman")
    with pytest.raises(ConfigError, match=r"^azimuth_window\[2\]: "):  # the list entry the user wrote
        _base(azimuth_window=("taylor", 4, 35))
    with pytest.raises(ConfigError, match=r"^azimuth_window.sll_db: "):  # a table's key
        _base(azimuth_window={"name": "taylor", "sll_db": 35.0})
    with pytest.raises(ConfigError, match=r"^azimuth_window: "):  # a name (was azimuth_window.name)
        _base(azimuth_window="")
    with pytest.raises(ConfigError, match="^azimuth_beamwidth"):
        _base(antenna_length=None, azimuth_beamwidth=4.0)
    # non-physical combinations (were accepted): band reaching 0 Hz, duty cycle >= 1, beam >= pi
    with pytest.raises(ConfigError, match="^bandwidth: must be < 2 x carrier_frequency"):
        _base(carrier_frequency=200e6)
    with pytest.raises(ConfigError, match="^pulse_length: must be shorter than the pulse repetition"):
        _base(pulse_length=0.02, n_range_samples=40_000_000)  # 20 ms pulse at PRF 100 Hz
    lam = 299_792_458.0 / 9.75e9
    with pytest.raises(ConfigError, match="^antenna_length: must be > 0.886 lambda / pi"):
        _base(antenna_length=0.886 * lam / np.pi * 0.99)
    _base(antenna_length=0.886 * lam / np.pi * 1.01).validate(speed=0.1)  # just above: accepted
    # error message is one line and names the bound
    try:
        _base(sample_rate=400e6)
    except ConfigError as err:
        assert "\n" not in str(err) and "5e+08" in str(err)


def test_validate_prf_and_scene():
    p = _base()
    p.validate(speed=11.0)  # 97.5 Hz <= 100 Hz
    with pytest.raises(ConfigError, match=r"^prf: must be >= the Doppler bandwidth"):
        p.validate(speed=12.0)
    lo, hi = p.target_range_limits
    assert lo == pytest.approx(2000.0 + C * 1e-6 / 4)
    p.validate(scene_ranges=[lo, hi])
    with pytest.raises(ConfigError, match="^near_range"):
        p.validate(scene_ranges=[lo - 0.01, hi])
    with pytest.raises(ConfigError, match="^near_range"):
        p.validate(scene_ranges=np.array([[lo, hi + 0.01]]))
    with pytest.raises(ConfigError, match="^scene"):
        p.validate(scene_ranges=[np.nan])
    with pytest.raises(ConfigError, match="^speed"):
        p.validate(speed=-1.0)


def test_windows_normalised_and_frozen():
    p = _base(range_window="hamming", azimuth_window=("taylor", 5, -40))
    assert p.range_window == Window("hamming")
    assert p.azimuth_window == Window("taylor", nbar=5, sll_db=-40.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.prf = 1.0
    assert math.isclose(dataclasses.replace(p, prf=50.0).prf, 50.0)


def test_dict_round_trip_and_errors():
    import json

    p = nav_paper_sim(range_window=("taylor", 5, -40))
    d = p.to_dict()
    json.dumps(d)
    assert RadarParams.from_dict(d) == p
    with pytest.raises(ConfigError, match="^radar.carrier: unknown radar parameter"):
        RadarParams.from_dict({**d, "carrier": 1.0})
    d.pop("prf")
    with pytest.raises(ConfigError, match="^radar.prf: missing"):
        RadarParams.from_dict(d)

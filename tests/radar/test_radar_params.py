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


def test_from_dict_names_a_bad_value_as_the_table_key():
    d = nav_paper_sim().to_dict()
    with pytest.raises(ConfigError, match=r"^radar.prf: must be finite and > 0"):
        RadarParams.from_dict({**d, "prf": -1.0})
    with pytest.raises(ConfigError, match=r"^radar.azimuth_window\[2\]: "):
        RadarParams.from_dict({**d, "azimuth_window": ["taylor", 4, 35]})


# ---- the pulse clock, the receive window and the Doppler/PRF check: one formula each ---------------------------
@pytest.mark.parametrize("n, t0, ref", [(7, 0.0, 0), (8, 3.25, 4), (8, -1.0, 3.5), (5, 12.0, 4), (1, 2.0, 0)])
def test_pulse_clock_against_exact_arithmetic(n, t0, ref):
    from fractions import Fraction

    p = _base(prf=300.0)
    t = p.pulse_times(n, t0, ref)
    assert t.shape == (n,) and t.dtype == np.float64
    # exact rational t0 + (k - ref) / prf, rounded once: the float clock is within an ulp of the rounding of each step
    exact = [Fraction(t0) + (k - Fraction(ref)) / Fraction(300) for k in range(n)]
    for got, want in zip(t, exact):
        assert abs(Fraction(float(got)) - want) <= 2 * Fraction(np.spacing(max(abs(float(want)), 1.0)))
    if n > 1:
        np.testing.assert_allclose(np.diff(t), 1.0 / 300.0, rtol=1e-9)  # constant PRI 1/prf
    if float(ref).is_integer():
        assert t[int(ref)] == t0  # the reference pulse is sent at t0 exactly
    else:
        assert t.mean() == pytest.approx(t0, abs=1e-12)  # (n - 1) / 2: symmetric about t0


def test_pulse_clock_bad_values():
    from sarnav.radar.params import pulse_clock

    assert pulse_clock(0, 100.0).shape == (0,)
    with pytest.raises(ConfigError, match="^n: "):
        pulse_clock(2.5, 100.0)
    with pytest.raises(ConfigError, match="^prf: "):
        pulse_clock(3, 0.0)
    with pytest.raises(ConfigError, match="^t0: "):
        pulse_clock(3, 100.0, float("nan"))


@pytest.mark.parametrize("span, t_p, fs, margin", [
    ((2000.0, 2210.0), 1e-6, 1e9, 0.0), ((1948.0, 2112.0), 1e-6, 500e6, 30.0), ((17.0, 24.0), 0.2e-6, 600e6, 0.0),
    ((5000.0, 5000.0), 2e-6, 250e6, 12.5), ((123.456, 789.012), 0.37e-6, 333e6, 0.1),
])
def test_receive_window_covers_the_span_and_equals_the_formula(span, t_p, fs, margin):
    from sarnav.radar.params import window_over

    p = _base(pulse_length=t_p, sample_rate=fs, bandwidth=min(500e6, fs), near_range=10.0, n_range_samples=2**16)
    w = p.receive_window(span, margin)
    assert w == window_over(span, t_p, fs, margin)
    # the formula rda_nav_world.receive_window used (and the presets, the image scenarios, the quality scenes)
    pad = C * t_p / 4.0 + margin
    dr = C / (2.0 * fs)
    assert w == {"near_range": span[0] - pad, "n_range_samples": int(math.ceil((span[1] - span[0] + 2 * pad) / dr)) + 1}
    # the radar recording this window holds the whole chirp of every scatterer of the span (plus the margin), and the
    # window overshoots the far edge by less than one bin
    q = dataclasses.replace(p, **w)
    lo, hi = q.target_range_limits
    assert lo <= span[0] - margin + 1e-9 and hi >= span[1] + margin - 1e-9
    assert hi - (span[1] + margin) < dr
    q.validate(scene_ranges=np.array(span))


def test_receive_window_bad_values():
    from sarnav.radar.params import window_over

    with pytest.raises(ConfigError, match="^span: "):
        window_over((2000.0, 1999.0), 1e-6, 1e9)
    with pytest.raises(ConfigError, match="^pulse_length: must be finite and > 0"):
        window_over((1.0, 2.0), -1e-6, 1e9)
    with pytest.raises(ConfigError, match="^sample_rate: "):
        window_over((1.0, 2.0), 1e-6, 0.0)
    with pytest.raises(ConfigError, match="^margin: "):
        window_over((1.0, 2.0), 1e-6, 1e9, -1.0)
    assert window_over((10.0, 20.0), 0.0, 1e9)["near_range"] == 10.0  # no chirp: no padding
    # a margin that alone pushes the window's start to <= 0 m is named by the caller's key, with its bound
    with pytest.raises(ConfigError, match=r"^radar\.range_margin_m: must be < 10 m"):
        window_over((10.0, 20.0), 0.0, 1e9, 10.0, "radar.range_margin_m")
    assert window_over((10.0, 20.0), 0.0, 1e9, 9.5, "radar.range_margin_m")["near_range"] == 0.5


@pytest.mark.parametrize("beam", [dict(antenna_length=0.2), dict(antenna_length=None, azimuth_beamwidth=0.5)])
def test_doppler_check_at_its_boundary(beam):
    p = _base(**beam)
    # the beam edges theta = +-theta_bw/2 have the Doppler +-2V sin(theta_bw/2)/lambda (f = 2V sin(theta)/lambda):
    # B_D = 4V sin(theta_bw/2)/lambda; the PRF covers it up to V* = prf lambda / (4 sin(theta_bw/2))
    lam = C / 9.75e9
    theta = 0.886 * lam / 0.2 if beam.get("antenna_length") else 0.5
    v_star = 100.0 * lam / (4.0 * math.sin(theta / 2.0))
    assert p.doppler_bandwidth(v_star) == pytest.approx(100.0, rel=1e-12)
    assert p.check_doppler(v_star * (1 - 1e-9)) is p
    with pytest.raises(ConfigError) as err:
        p.check_doppler(v_star * (1 + 1e-9))
    assert err.value.field == "prf" and f"= {p.doppler_bandwidth(v_star * (1 + 1e-9)):.6g} Hz" in err.value.message
    assert "got 100 Hz" in err.value.message
    with pytest.raises(ConfigError, match="^prf: "):
        p.validate(speed=v_star * (1 + 1e-9))  # validate checks the same
    if beam.get("antenna_length"):  # ~ 0.886 * 2V / L (docs/radar.md), short by sin(x)/x ~ 1 - x^2/6, x = theta_bw/2
        assert p.doppler_bandwidth(10.0) == pytest.approx(0.886 * 2 * 10.0 / 0.2 * (1 - (theta / 2) ** 2 / 6), rel=1e-6)

"""``sarnav.scenarios.nav_focus``: the ``nav-source-focus`` kind parses its packaged defaults (read here independently
with ``tomllib``) into ``FocusParams``; the radar's receive window covers every reflector's slant range along the
aperture (checked against the ranges of every pulse, by Pythagoras); every bad key is one ConfigError line naming the
key and its range. Parsing only: no run is simulated."""

from __future__ import annotations


import numpy as np
import pytest
from helpers import packaged_toml, packaged_with

from sarnav.errors import ConfigError
from sarnav.radar.presets import sun_ku_cart
from sarnav.scenarios.nav_focus import RANGE_MARGIN, NavFocusKind, parse
from sarnav.scenarios.registry import packaged
from sarnav.units import C

NAME = "nav-source-focus"


def _toml() -> dict:
    return packaged_toml(NAME)


def _cfg(**changes) -> dict:
    """The packaged defaults with ``table__key=value`` changes (``None`` deletes the key)."""
    return packaged_with(NAME, **changes)


def _error(**changes) -> ConfigError:
    with pytest.raises(ConfigError) as exc:
        parse(_cfg(**changes))
    assert "\n" not in str(exc.value)
    return exc.value


def _pulse_ranges(prm) -> np.ndarray:
    """(pulses, reflectors) slant ranges [m]: antenna at along-track x_p = (p - (P - 1) / 2) V / PRF from the
    aperture centre, reflector k at (a_k, g_k) and ``antenna_height`` below the antenna."""
    g = prm.geometry
    x = (np.arange(g.n_pulses) - 0.5 * (g.n_pulses - 1)) * g.speed / g.radar.prf
    a = np.array([r[0] for r in g.reflectors])
    gr = np.array([r[1] for r in g.reflectors])
    return np.sqrt((a[None] - x[:, None]) ** 2 + gr[None] ** 2 + g.antenna_height**2)


def test_defaults_parse_to_the_file_values():
    """Every parsed field equals the shipped file's value (SI: GHz, MHz converted)."""
    t = _toml()
    prm = parse(packaged(NAME))
    g = prm.geometry
    assert prm.runs == t["campaign"]["runs"]
    assert (g.speed, g.run_in, g.antenna_height) == (t["cart"]["speed"], t["cart"]["run_in_s"],
                                                     t["cart"]["antenna_height_m"])
    assert g.n_pulses == t["aperture"]["n_pulses"]
    assert g.reflectors == tuple(zip(t["scene"]["along_track_m"], t["scene"]["ground_range_m"]))
    assert (g.chip_half, g.spacing) == (t["image"]["chip_half_m"], t["image"]["spacing_m"])
    assert prm.sources == tuple(t["navigation"]["sources"])
    assert prm.n_particles == t["navigation"]["n_particles"]
    assert prm.adis_particles == t["navigation"]["adis_particles"]
    assert prm.fix_sigma == tuple(t["navigation"]["fix_sigma_m"])
    assert prm.fix_correlated == tuple(t["navigation"]["fix_correlated_sigma_m"])
    assert prm.fix_tau == t["navigation"]["fix_correlation_time_s"]
    r = g.radar
    assert r.carrier_frequency == pytest.approx(t["radar"]["carrier_ghz"] * 1e9, rel=1e-15)
    assert r.bandwidth == pytest.approx(t["radar"]["bandwidth_mhz"] * 1e6, rel=1e-15)
    assert r.prf == t["radar"]["prf_hz"]
    assert prm.filters() == ["upf", "kf-interp"]


def test_receive_window_covers_the_default_reflectors():
    """Default scene: every pulse's slant range to every reflector lies in the window's whole-echo limits with the
    3 m margin to spare, and the window starts (within one pulse step) at the nearest range minus cT/4 + margin."""
    prm = parse(packaged(NAME))
    r = _pulse_ranges(prm)
    lo, hi = prm.geometry.radar.target_range_limits
    assert lo <= r.min() - RANGE_MARGIN + 1e-9 and r.max() + RANGE_MARGIN <= hi + 1e-9
    radar = prm.geometry.radar
    ideal = r.min() - C * radar.pulse_length / 4 - RANGE_MARGIN
    step = prm.geometry.speed / radar.prf  # the window's aperture ends may lie up to half a pulse step beyond
    assert ideal - step <= radar.near_range <= ideal + 1e-9
    assert radar.far_range < r.max() + C * radar.pulse_length / 4 + RANGE_MARGIN + radar.range_bin_spacing + 1e-9


def test_receive_window_covers_a_reflector_inside_a_long_aperture():
    """A reflector 25 m along track inside a 100-m aperture (10 m/s, 30000 pulses at 3 kHz): its closest approach
    (20.06 m) must lie within the receive window's whole-echo limits."""
    prm = parse(_cfg(scene__along_track_m=[25.0], scene__ground_range_m=[20.0], cart__speed=10.0,
                     aperture__n_pulses=30000))
    r = _pulse_ranges(prm)
    lo, hi = prm.geometry.radar.target_range_limits
    assert lo <= r.min() and r.max() <= hi


def test_reflector_too_close_for_the_pulse_is_refused():
    """A reflector within cT/4 + margin (15 m + 3 m for sun-ku-cart) of the radar is refused naming
    scene.ground_range_m and the limit."""
    ku = sun_ku_cart()
    limit = C * ku.pulse_length / 4 + RANGE_MARGIN
    err = _error(scene__along_track_m=[0.0], scene__ground_range_m=[10.0])
    assert err.field == "scene.ground_range_m" and f"{limit:.3g} m" in err.message


def test_reflector_lists_must_pair_up():
    """scene.ground_range_m needs one entry per scene.along_track_m."""
    err = _error(scene__ground_range_m=[19.5, 20.0])
    assert err.field == "scene.ground_range_m" and "one entry per scene.along_track_m (3)" in err.message


def test_sources_must_include_truth():
    """navigation.sources without truth (the reference image) is refused."""
    err = _error(navigation__sources=["upf", "kf-interp"])
    assert err.field == "navigation.sources" and "'truth'" in err.message


def test_sources_must_include_a_filter_with_a_covariance():
    """navigation.sources without upf / kf-interp / spline-pf / spline-kf is refused."""
    err = _error(navigation__sources=["truth", "spline-gps", "novatel"])
    assert err.field == "navigation.sources" and "covariance" in err.message


@pytest.mark.parametrize("sources, filters", [(["truth", "spline-pf"], ["upf"]), (["truth", "spline-kf"], ["kf-interp"]),
                                              (["truth", "upf", "spline-kf"], ["upf", "kf-interp"])])
def test_filters_are_those_carried_by_the_sources(sources, filters):
    """The states are the filters carried by a source: upf by upf / spline-pf, kf-interp by kf-interp / spline-kf."""
    assert parse(_cfg(navigation__sources=sources)).filters() == filters


@pytest.mark.parametrize("chip, spacing, ok", [(0.32, 0.04, True), (0.31, 0.04, False), (20.0, 0.04, True),
                                               (20.0, 0.039, False)])
def test_chip_holds_8_to_500_pixels(chip, spacing, ok):
    """image.chip_half_m / image.spacing_m must be 8 to 500 pixels."""
    cfg = _cfg(image__chip_half_m=chip, image__spacing_m=spacing)
    if ok:
        assert parse(cfg).geometry.chip_half == chip
    else:
        with pytest.raises(ConfigError) as exc:
            parse(cfg)
        assert exc.value.field == "image.chip_half_m" and "8 to 500 pixels" in exc.value.message


BAD = [
    ("cart__speed", 0.01, "cart.speed", "[0.05, 50] m/s"),
    ("cart__run_in_s", 0.5, "cart.run_in_s", "[1, 600] s"),
    ("cart__antenna_height_m", -1.0, "cart.antenna_height_m", "[0, 100] m"),
    ("aperture__n_pulses", 15, "aperture.n_pulses", "[16, 30000]"),
    ("scene__along_track_m", [0.0, 51.0, 1.0], "scene.along_track_m", "[-50, 50] m"),
    ("scene__ground_range_m", [19.5, 501.0, 20.5], "scene.ground_range_m", "[2, 500] m"),
    ("image__spacing_m", 2.0, "image.spacing_m", "[0.001, 1] m"),
    ("image__chip_half_m", 21.0, "image.chip_half_m", "[0.05, 20] m"),
    ("navigation__sources", ["truth", "upf", "gps"], "navigation.sources", "must be one of"),
    ("navigation__n_particles", 6, "navigation.n_particles", "[7, 100000]"),
    ("navigation__adis_particles", 100_001, "navigation.adis_particles", "[7, 100000]"),
    ("navigation__fix_sigma_m", [0.3, 0.3, 0.0], "navigation.fix_sigma_m", "[0.001, 100] m"),
    ("navigation__fix_correlated_sigma_m", [-0.1, 0.0, 0.0], "navigation.fix_correlated_sigma_m", "[0, 100] m"),
    ("navigation__fix_correlation_time_s", 0.5, "navigation.fix_correlation_time_s", "[1, 1e+06] s"),
    ("radar__prf_hz", 50.0, "radar.prf_hz", "Doppler"),  # azimuth Nyquist at 1 m/s needs ~55 Hz
    ("campaign__seed", -1, "campaign.seed", ""),
]


@pytest.mark.parametrize("change, value, key, text", BAD, ids=[b[2] + "=" + repr(b[1]) for b in BAD])
def test_bad_value_is_one_line_naming_key_and_range(change, value, key, text):
    """Each bad value is one ConfigError line naming the key (a list entry with its index) and its range."""
    err = _error(**{change: value})
    assert err.field.split("[")[0] == key
    assert text in err.message and str(err).startswith(f"{err.field}: ")


def test_speed_beyond_the_doppler_limit_is_refused_as_the_prf():
    """1 % above the azimuth Nyquist speed PRF lambda / (4 sin(theta_bw / 2)) is refused naming radar.prf_hz, 1 %
    below parses."""
    prm = parse(_cfg(radar__prf_hz=1000.0))
    r = prm.geometry.radar
    v_max = r.prf * r.wavelength / (4.0 * np.sin(0.5 * r.beamwidth))
    assert v_max < 50.0  # inside cart.speed's range, else this test checks nothing
    parse(_cfg(radar__prf_hz=1000.0, cart__speed=0.99 * v_max))
    assert _error(radar__prf_hz=1000.0, cart__speed=1.01 * v_max).field == "radar.prf_hz"


def test_kind_coordinates_follow_the_parameters():
    """extra_coords: sources, one reflector index each, the metrics, the pulse times (run-in + p / PRF)."""
    kind = NavFocusKind()
    cfg = packaged(NAME)
    prm = kind.parse(cfg)
    co = kind.extra_coords(cfg)
    assert co["source"][0] == list(prm.sources)
    assert co["reflector"][0] == [0, 1, 2]
    pt = np.asarray(co["pulse"][0])
    g = prm.geometry
    np.testing.assert_allclose(pt, g.run_in + np.arange(g.n_pulses) / g.radar.prf, rtol=0, atol=1e-12)
    assert kind.sources(prm) == list(prm.sources)

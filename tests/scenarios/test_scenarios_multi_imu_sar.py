"""``sarnav.scenarios.multi_imu_sar``: the ``multi-imu-sar`` kind parses its packaged defaults (scenario
``multi-imu-sar-fix``, read here independently with ``tomllib``) into a ``SarFixSetup`` and a settling time; the
scene's ground ranges must keep the imager's search window (+-12 m of slant range) inside the radar's receive window;
only the ``nav-paper-sim`` radar is accepted; the flight lasts whole 1-s sub-apertures; every bad key is one
ConfigError line naming the key. Parsing only: no run is simulated."""

from __future__ import annotations

import math

import pytest
from helpers import packaged_toml, packaged_with

from sarnav.errors import ConfigError
from sarnav.radar.presets import nav_paper_sim
from sarnav.scenarios.multi_imu_sar import SEARCH_HALF_RANGE, MultiImuSarKind, parse
from sarnav.scenarios.registry import packaged

NAME = "multi-imu-sar-fix"


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


def test_defaults_parse_to_the_file_values():
    """Every parsed field equals the shipped file's value (3-sigma initial errors divided by 3)."""
    t = _toml()
    setup, settle = parse(packaged(NAME))
    assert settle == t["filter"]["settle_s"]
    assert (setup.duration, setup.speed, setup.altitude) == (t["flight"]["duration"], t["flight"]["speed"],
                                                             t["flight"]["altitude"])
    assert setup.ground_range == (t["scene"]["ground_range_min"], t["scene"]["ground_range_max"])
    assert setup.scene_seed == t["scene"]["seed"] and setup.clutter == t["scene"]["clutter_per_image"]
    assert setup.toc_jitter == t["scene"]["toc_jitter_s"]
    assert setup.clutter_per_run is t["scene"]["clutter_per_run"]
    assert setup.reflector_amplitude == t["scene"]["reflector_amplitude"]
    assert setup.sar_sigma == tuple(t["sar"]["registration_sigma_m"])
    assert setup.alt_sigma == t["sar"]["altimeter_sigma_m"]
    assert setup.snr_db == t["radar"]["snr_db"]
    assert setup.fix_source == t["fix"]["source"] and setup.gps_rate == t["fix"]["gps_rate_hz"]
    assert setup.gps_sigma == tuple(t["fix"]["gps_sigma_m"])
    assert setup.n_adis == t["imu"]["n_adis"] and setup.n_particles == t["filter"]["n_particles"]
    assert setup.update == t["filter"]["sar_update"] and setup.n_draws == t["fusion"]["n_draws"]
    want = [x / 3.0 for x in t["initial"]["p_3sigma"] + t["initial"]["v_3sigma"]]
    assert setup.p0_sigma == pytest.approx(want, rel=1e-15)
    assert setup.radar == nav_paper_sim()  # the preset with no [radar] overrides
    assert setup.n_apertures == int(t["flight"]["duration"])


def _ground_limits(altitude: float = 1000.0):
    """(smallest ground_range_min, largest ground_range_max) [m] whose slant range -+ the search half-window stays
    in nav-paper-sim's target range limits, by Pythagoras."""
    lo, hi = nav_paper_sim().target_range_limits
    return (math.sqrt((lo + SEARCH_HALF_RANGE) ** 2 - altitude**2),
            math.sqrt((hi - SEARCH_HALF_RANGE) ** 2 - altitude**2))


def test_ground_range_min_at_the_receive_window_edge():
    """ground_range_min just inside the window's near edge (+ 12 m search) parses; 1 cm closer is refused, naming
    the key and the window's nearest target range."""
    gmin, _ = _ground_limits()
    setup, _ = parse(_cfg(scene__ground_range_min=gmin + 0.01))
    assert setup.ground_range[0] == gmin + 0.01
    err = _error(scene__ground_range_min=gmin - 0.01)
    lo = nav_paper_sim().target_range_limits[0]
    assert err.field == "scene.ground_range_min"
    assert "leaves the receive window" in err.message and f"{lo:.1f} m" in err.message


def test_ground_range_max_at_the_receive_window_edge():
    """ground_range_max just inside the window's far edge (- 12 m search) parses; 1 cm farther is refused."""
    _, gmax = _ground_limits()
    setup, _ = parse(_cfg(scene__ground_range_max=gmax - 0.01))
    assert setup.ground_range[1] == gmax - 0.01
    err = _error(scene__ground_range_max=gmax + 0.01)
    hi = nav_paper_sim().target_range_limits[1]
    assert err.field == "scene.ground_range_max"
    assert "leaves the receive window" in err.message and f"{hi:.1f} m" in err.message


def test_window_limits_follow_the_altitude():
    """Flown at 1500 m the default ground_range_max = 1940 m is at slant range 2452 m, beyond the far edge: refused."""
    err = _error(flight__altitude=1500.0)
    assert err.field == "scene.ground_range_max"


def test_ground_range_max_must_exceed_min():
    """ground_range_max <= ground_range_min is refused, naming the max and the min's value."""
    err = _error(scene__ground_range_max=1760.0)
    assert err.field == "scene.ground_range_max" and "scene.ground_range_min = 1760.0 m" in err.message


@pytest.mark.parametrize("preset", ["flexsar", "sun-ku-cart", None])
def test_only_the_nav_paper_sim_radar_is_accepted(preset):
    """radar.preset other than nav-paper-sim (another preset, or none) is refused naming radar.preset."""
    err = _error(radar__preset=preset)
    assert err.field == "radar.preset" and "'nav-paper-sim'" in err.message


def test_unknown_radar_preset_is_refused():
    """A preset name that is no preset at all is refused naming radar.preset."""
    assert _error(radar__preset="no-such-radar").field == "radar.preset"


@pytest.mark.parametrize("duration", [10.5, 2.25, 49.999])
def test_duration_must_be_whole_seconds(duration):
    """flight.duration must be a whole number of 1-s sub-apertures."""
    err = _error(flight__duration=duration)
    assert err.field == "flight.duration" and "whole number" in err.message


@pytest.mark.parametrize("duration", [2.0, 7.0, 600.0])
def test_whole_second_durations_parse(duration):
    """Whole seconds within [2, 600] parse to as many sub-apertures."""
    setup, _ = parse(_cfg(flight__duration=duration, filter__settle_s=0.0))
    assert setup.duration == duration and setup.n_apertures == int(duration)


def test_speed_beyond_the_doppler_limit_is_refused():
    """The azimuth Nyquist speed of nav-paper-sim, PRF lambda / (4 sin(beamwidth / 2)) (~11.3 m/s): 1 % below
    parses, 1 % above is refused naming flight.speed and radar.prf_hz."""
    r = nav_paper_sim()
    v_max = r.prf * r.wavelength / (4.0 * math.sin(0.5 * 0.886 * r.wavelength / r.antenna_length))
    parse(_cfg(flight__speed=0.99 * v_max))
    err = _error(flight__speed=1.01 * v_max)
    assert err.field == "flight.speed" and "radar.prf_hz" in err.message


BAD = [
    ("flight__duration", 1.0, "flight.duration", "[2, 600] s"),
    ("flight__altitude", 50.0, "flight.altitude", "[100, 20000] m"),
    ("flight__speed", 0.5, "flight.speed", "[1, 100] m/s"),
    ("scene__seed", -1, "scene.seed", "[0, "),
    ("scene__ground_range_min", 0.0, "scene.ground_range_min", "[1, 100000] m"),
    ("scene__toc_jitter_s", 0.5, "scene.toc_jitter_s", "[0, 0.4] s"),
    ("scene__clutter_per_image", 1001, "scene.clutter_per_image", "[0, 1000]"),
    ("scene__clutter_per_run", "yes", "scene.clutter_per_run", "true or false"),
    ("sar__registration_sigma_m", [0.001, 0.03, 0.1], "sar.registration_sigma_m", "list of 2"),
    ("sar__altimeter_sigma_m", 0.0, "sar.altimeter_sigma_m", "[0.001, 100] m"),
    ("radar__snr_db", 101.0, "radar.snr_db", "[-60, 100] dB"),
    ("fix__source", "glonass", "fix.source", "['sar', 'oracle', 'gps']"),
    ("fix__gps_rate_hz", 0.5, "fix.gps_rate_hz", "[1, 100] Hz"),
    ("imu__n_adis", 0, "imu.n_adis", "[1, "),
    ("filter__n_particles", 6, "filter.n_particles", "[7, 100000]"),
    ("filter__sar_update", "ekf", "filter.sar_update", "one of"),
    ("filter__settle_s", 49.5, "filter.settle_s", "one epoch (1 s)"),
    ("initial__p_3sigma", [1.9, 1.9], "initial.p_3sigma", "list of 3"),
    ("fusion__per_axis", 1, "fusion.per_axis", "true or false"),
    ("campaign__runs", 0, "campaign.runs", "[1, "),
]


@pytest.mark.parametrize("change, value, key, text", BAD, ids=[b[2] + "=" + repr(b[1]) for b in BAD])
def test_bad_value_is_one_line_naming_key_and_range(change, value, key, text):
    """Each bad value is one ConfigError line naming the key and its range (or the rule broken)."""
    err = _error(**{change: value})
    assert err.field.split("[")[0] == key
    assert text in err.message and str(err).startswith(f"{err.field}: ")


def test_kind_names_sources_and_coordinates():
    """The kind's filters are the IMUs' particle filters; sources add mean and SIR; one aperture coordinate per
    second of flight."""
    kind = MultiImuSarKind()
    cfg = packaged(NAME)
    setup, _ = kind.parse(cfg)
    assert kind.sources(kind.parse(cfg)) == setup.sensor_names + ["mean", "sir"]
    assert kind.filters(kind.parse(cfg)) == setup.sensor_names
    coords = kind.extra_coords(cfg)
    assert coords["aperture"][0] == list(range(int(cfg["flight"]["duration"])))
    assert coords["sar_axis"][0] == ["range", "along_track"]

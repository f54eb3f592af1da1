"""The default configurations shipped as data (``src/sarnav/scenarios/defaults/<name>.toml``): one file per registered
scenario, each valid, the values the code also knows (constants of the library) the same, and the scenarios written
as another's variant different from it exactly where their description says."""

from importlib import resources

import pytest

from sarnav.analysis.bpa_sensitivity import THESIS_SIM_ERRORS
from sarnav.measurements.focus_search import TABLE41_BIAS
from sarnav.scenarios.config import validate_scenario
from sarnav.scenarios.registry import SCENARIOS, get_scenario, packaged
from sarnav.scenarios.vocabulary import EARTH_DEFAULT
from sarnav.simulation.multi_imu import PATH1_SIGMAS
from sarnav.simulation.nav_sources import NAV_SOURCES

NAMES = [e.name for e in SCENARIOS]


def _leaves(cfg: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in cfg.items():
        field = f"{prefix}{key}"
        out.update(_leaves(value, field + ".") if isinstance(value, dict) else {field: value})
    return out


def _changed(name: str, base: str) -> set[str]:
    a, b = _leaves(get_scenario(name)), _leaves(get_scenario(base))
    return {k for k in a.keys() | b.keys() if a.get(k) != b.get(k)} - {"scenario.name", "scenario.description"}


def test_one_file_per_registered_scenario():
    files = {p.name[:-5] for p in resources.files("sarnav.scenarios").joinpath("defaults").iterdir()
             if p.name.endswith(".toml")}
    assert files == set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_each_file_is_a_valid_scenario_named_like_the_file(name):
    cfg = packaged(name)
    assert cfg["scenario"]["name"] == name
    assert cfg["scenario"]["kind"] == next(e.kind for e in SCENARIOS if e.name == name)
    validate_scenario(get_scenario(name))


def test_values_the_library_also_knows():
    assert get_scenario("bpa-sensitivity")["errors"] == {k: v[2] for k, v in THESIS_SIM_ERRORS.items()}
    assert get_scenario("gpsd-search")["search"]["bias"] == TABLE41_BIAS
    assert get_scenario("multi-imu-path1")["sensors"]["sigma_m"] == list(PATH1_SIGMAS)
    assert get_scenario("nav-source-focus")["navigation"]["sources"] == list(NAV_SOURCES)
    for name in ("telemetry", "rda-nav", "rda-nav-flexsar", "rda-nav-terrain", "quality-nav"):
        assert get_scenario(name)["earth"] == EARTH_DEFAULT, name


@pytest.mark.parametrize("name, base, changed", [
    ("rda-nav-flexsar", "rda-nav", {"trajectory.speed", "imu.gyro_bias_3sigma", "altimeter.sigma_3sigma",
                                    "sar.range_3sigma", "sar.cross_3sigma", "radar.preset",
                                    "scene.ground_range_min", "scene.ground_range_max"}),
    ("rda-nav-terrain", "rda-nav", {"scene.type", "scene.reference_offset_m", "scene.geolocation_sigma_m",
                                    "scene.reference_coherence"}),
    ("spacecraft-tc1", "spacecraft-tc2", {"initial.sigma_mu0_deg", "mekf.underweight_beta"}),
    ("scatterers", "point-target", {"scene.type", "radar.antenna_pattern"}),
    ("gpsd-search-table41", "gpsd-search", {"search.candidates", "search.block_pulses", "search.spacings"}),
])
def test_a_variant_differs_from_its_base_where_it_says(name, base, changed):
    assert _changed(name, base) == changed


def test_the_closed_loop_flies_the_tc2_orbit_and_filter():
    cl, tc2 = get_scenario("spacecraft-closed-loop"), get_scenario("spacecraft-tc2")
    for table in ("orbit", "initial", "mekf"):
        assert cl[table] == tc2[table], table
    assert cl["antenna"] == dict(tc2["antenna"], steering="zero-doppler")


def test_studies_take_their_base_scenario_and_its_seed():
    rob, rda = get_scenario("rda-nav-robustness"), get_scenario("rda-nav")
    assert rob["campaign"]["seed"] == rda.pop("campaign")["seed"]
    assert rob["base"] == rda
    snr = next(s for s in rob["sweeps"] if s["name"] == "snr")
    sets = {c["label"]: c["set"] for c in rob["cases"]}
    assert [sets[lab]["radar.snr_db"] for lab in snr["cases"]] == [rda["radar"]["snr_db"] - x for x in snr["x"]]
    for name in ("telemetry-imu-grade", "telemetry-noise", "telemetry-geometry"):
        study, tel = get_scenario(name), get_scenario("telemetry")
        assert study["campaign"]["seed"] == tel.pop("campaign")["seed"] and study["base"] == tel

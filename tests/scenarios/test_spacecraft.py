"""``scenarios.spacecraft``: the open-loop spacecraft kind's parser: the packaged defaults parse into SI parameters
(checked against the TOML values converted here), each bad key is a one-line ConfigError naming the key and its valid
range, and the pieces (elements, noise, MEKF, antenna, initial, simulation) read their tables."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.frames.earth import WGS84_A
from sarnav.scenarios import spacecraft as sc


@pytest.fixture(scope="module")
def defaults():
    return sc.SpacecraftKind().default_config()


@pytest.fixture
def cfg(defaults):
    return copy.deepcopy(defaults)


def test_defaults_parse_to_si(defaults):
    """Every TOML value lands in OpenLoopParams converted to SI (km -> m, deg -> rad); n_updates 0 means every
    update (None); the underweighting is off with beta = 0."""
    p = sc.parse(copy.deepcopy(defaults))
    o, a, s, i, m, k = (defaults[t] for t in ("orbit", "antenna", "simulation", "initial", "measurement", "mekf"))
    assert p.elements.a == pytest.approx(WGS84_A + 1e3 * o["altitude_km"], rel=1e-15)
    assert p.elements.e == o["eccentricity"] and p.elements.i == pytest.approx(math.radians(o["inclination_deg"]))
    assert p.look_angle == pytest.approx(math.radians(a["look_angle_deg"])) and p.squint == 0.0
    assert p.steering == a["steering"]
    assert (p.duration, p.update_interval, p.record_interval, p.truth_dt) == \
        (s["duration"], s["update_interval"], s["record_interval"], s["truth_dt"])
    assert p.n_updates is None
    assert (p.sigma_r0, p.sigma_v0) == (i["sigma_r0"], i["sigma_v0"])
    assert p.sigma_mu0 == pytest.approx(math.radians(i["sigma_mu0_deg"]))
    assert p.noise.sigma_range == m["sigma_range"] and p.noise.sigma_vic == m["sigma_vic"]
    np.testing.assert_array_equal(p.noise.D, np.array(m["D"]))
    assert p.mekf.q_accel == k["q_accel"] and p.mekf.dt == k["dt"] and p.mekf.literal_q is k["literal_q"]
    assert p.underweighting is None and p.truth_misalignment_psd == defaults["truth"]["misalignment_psd"]


def test_elements_place_the_satellite_at_the_given_latitude(cfg):
    """The epoch position's geocentric latitude is orbit.latitude_deg: sin(lat) = sin(i) sin(u), u = argp + nu."""
    cfg["orbit"].update(latitude_deg=-20.0, inclination_deg=60.0)
    el = sc.read_elements(cfg)
    assert math.sin(el.i) * math.sin(el.argp + el.nu) == pytest.approx(math.sin(math.radians(-20.0)), abs=1e-12)


def test_underweighting_and_n_updates_when_switched_on(cfg):
    """beta > 0 with updates > 0 gives LearUnderweighting(beta, first_updates); simulation.n_updates k > 0 is kept."""
    cfg["mekf"].update(underweight_beta=0.3, underweight_updates=7)
    cfg["simulation"]["n_updates"] = 12
    p = sc.parse(cfg)
    assert p.underweighting.beta == 0.3 and p.underweighting.first_updates == 7 and p.n_updates == 12
    cfg["mekf"]["underweight_updates"] = 0
    assert sc.read_mekf(cfg)[1] is None


BAD = [  # (table, key, value, field, words of the message: the range or reason)
    ("orbit", "eccentricity", 1.0, "orbit.eccentricity", "[0, 1)"),
    ("orbit", "eccentricity", -0.1, "orbit.eccentricity", "0"),
    ("orbit", "altitude_km", 99.0, "orbit.altitude_km", "R_e + 100 km"),
    ("orbit", "altitude_km", 2e6, "orbit.altitude_km", "1e+06"),
    ("orbit", "inclination_deg", 181.0, "orbit.inclination_deg", "180"),
    ("orbit", "latitude_deg", 85.0, "orbit.latitude_deg", "inclination's reach (81.84 deg)"),
    ("orbit", "longitude_deg", 400.0, "orbit.longitude_deg", "360"),
    ("orbit", "argp_deg", float("nan"), "orbit.argp_deg", "finite"),
    ("antenna", "look_angle_deg", 90.0, "antenna.look_angle_deg", "89"),
    ("antenna", "squint_deg", 50.0, "antenna.squint_deg", "45"),
    ("antenna", "steering", "nadir", "antenna.steering", "lvlh"),
    ("simulation", "duration", 1e6, "simulation.duration", "86400"),
    ("simulation", "n_updates", -1, "simulation.n_updates", "[0, 100000]"),
    ("simulation", "truth_dt", 20.0, "simulation.truth_dt", "10"),
    ("initial", "sigma_mu0_deg", 11.0, "initial.sigma_mu0_deg", "10"),
    ("initial", "sigma_v0", 2e4, "initial.sigma_v0", "10000"),
    ("measurement", "mode", "image", "measurement.mode", "must be 'oracle'"),
    ("measurement", "D", [[25.0, 0.0], [0.0, 25.0]], "measurement.D", "3 x 3"),
    ("measurement", "D", [[25.0, 0, 0], [0, float("inf"), 0], [0, 0, 25.0]], "measurement.D[1][1]", "finite"),
    ("measurement", "sigma_range", 2e5, "measurement.sigma_range", "100000"),
    ("mekf", "q_accel", 2.0, "mekf.q_accel", "1"),
    ("mekf", "dt", 5e-5, "mekf.dt", "0.0001"),
    ("mekf", "literal_q", 1, "mekf.literal_q", "true or false"),
    ("mekf", "underweight_beta", 1e4, "mekf.underweight_beta", "1000"),
    ("truth", "misalignment_psd", -1e-9, "truth.misalignment_psd", "0"),
]


@pytest.mark.parametrize("table, key, value, field, words", BAD, ids=[f"{b[3]}={b[2]!r}" for b in BAD])
def test_each_bad_key_is_one_line_naming_it_and_its_range(cfg, table, key, value, field, words):
    """parse refuses the value with one line: the key, then its valid range or the reason."""
    cfg[table][key] = value
    with pytest.raises(ConfigError) as err:
        sc.parse(cfg)
    text = str(err.value)
    assert err.value.field == field and text.startswith(f"{field}: ") and "\n" not in text, text
    assert words in err.value.message, text


def test_record_interval_bounds_the_records_per_run(cfg):
    """duration / record_interval over 200000 is refused on simulation.record_interval (1 day at 0.4 s: 216000)."""
    cfg["simulation"].update(duration=86400.0, record_interval=0.4)
    with pytest.raises(ConfigError) as err:
        sc.read_simulation(cfg)
    assert err.value.field == "simulation.record_interval" and "2.16e+05 records" in err.value.message
    cfg["simulation"]["record_interval"] = 0.5  # 172800: accepted
    assert sc.read_simulation(cfg)["record_interval"] == 0.5


def test_a_missing_key_is_named(cfg):
    """A table without one of its keys: the error names that key."""
    del cfg["antenna"]["squint_deg"]
    with pytest.raises(ConfigError) as err:
        sc.parse(cfg)
    assert err.value.field == "antenna.squint_deg"


def test_kind_names_and_coordinates():
    """The kind's states, measurements and extra coordinates have one unit per name."""
    k = sc.SpacecraftKind()
    cfg = k.default_config()
    assert len(k.state_names(cfg)) == len(k.state_units(cfg)) == 9
    assert len(k.meas_names(cfg)) == len(k.meas_units(cfg))
    ric = k.extra_coords(cfg)["ric"]
    assert len(ric[0]) == len(ric[1]["units"]) == 6
    assert k.simulate(cfg, [], []) == []

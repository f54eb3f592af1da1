"""``sarnav.scenarios.multi_imu``: the kinds ``multi-imu-path1``, ``multi-imu`` and ``upf-flight`` parse their packaged
defaults (``scenarios/defaults/<name>.toml``, read here independently with ``tomllib``) into the SI parameters, and
every bad key is one ConfigError line naming the key and its valid range. Parsing only: no run is simulated."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources

import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios.multi_imu import (
    MAX_PARTICLES,
    MIN_PARTICLES,
    MultiImuKind,
    MultiImuPath1Kind,
    UpfFlightKind,
    settle_time,
)
from sarnav.scenarios.registry import packaged

KINDS = {"multi-imu-path1": MultiImuPath1Kind(), "multi-imu-adis": MultiImuKind(), "upf-flight": UpfFlightKind()}


def _toml(name: str) -> dict:
    """The shipped defaults file read with the standard library (independent of ``packaged``)."""
    text = resources.files("sarnav.scenarios").joinpath("defaults", f"{name}.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def _with(name: str, dotted: str, value) -> dict:
    cfg = copy.deepcopy(packaged(name))
    table, key = dotted.split(".")
    cfg[table][key] = value
    return cfg


def _error(name: str, dotted: str, value) -> ConfigError:
    with pytest.raises(ConfigError) as exc:
        KINDS[name].parse(_with(name, dotted, value))
    return exc.value


@pytest.mark.parametrize("name", sorted(KINDS))
def test_default_config_is_the_packaged_file(name):
    """Each kind's default configuration is its scenario's shipped TOML file, value for value."""
    assert KINDS[name].default_config() == _toml(name)


def test_path1_defaults_parse_to_the_file_values():
    """multi-imu-path1: every parsed parameter is the file's value (SI already)."""
    t = _toml("multi-imu-path1")
    p = KINDS["multi-imu-path1"].parse(packaged("multi-imu-path1"))
    assert p.runs == t["campaign"]["runs"]
    assert p.duration == t["path"]["duration"]
    assert p.sensor_sigmas == tuple(t["sensors"]["sigma_m"])
    assert p.rate == t["sensors"]["rate_hz"]
    assert p.n_particles == t["filter"]["n_particles"]
    assert p.accel_psd == t["filter"]["accel_psd"]
    assert p.settle == t["filter"]["settle_s"]
    assert p.fix_sigma == t["fusion"]["fix_sigma_m"]
    assert p.n_draws == t["fusion"]["n_draws"] and p.per_axis is t["fusion"]["per_axis"]
    n = len(t["sensors"]["sigma_m"])
    assert KINDS["multi-imu-path1"].sources(p) == [f"sensor{i + 1}" for i in range(n)] + ["mean", "sir", "fix"]


def test_multi_imu_adis_defaults_parse_to_the_file_values():
    """multi-imu-adis: parsed values equal the file's; the record stride is the 20 Hz fix rate over record_rate_hz."""
    t = _toml("multi-imu-adis")
    p = KINDS["multi-imu-adis"].parse(packaged("multi-imu-adis"))
    assert (p.runs, p.duration, p.speed) == (t["campaign"]["runs"], t["flight"]["duration"], t["flight"]["speed"])
    assert p.n_adis == t["imu"]["n_adis"]
    assert p.fix_sigma == tuple(t["fix"]["sigma_m"]) and p.fix_bias == tuple(t["fix"]["bias_m"])
    assert p.shared_fix is t["fix"]["shared"]
    assert p.n_particles == t["filter"]["n_particles"] and p.psd_scale == t["filter"]["accel_psd_scale"]
    assert p.settle == t["filter"]["settle_s"]
    assert p.virtual is t["fusion"]["virtual_imu"]
    assert p.stride == 20.0 / t["output"]["record_rate_hz"]  # 20 Hz / 5 Hz = 4


def test_upf_flight_defaults_parse_to_the_file_values():
    """upf-flight: parsed values equal the file's."""
    t = _toml("upf-flight")
    p = KINDS["upf-flight"].parse(packaged("upf-flight"))
    assert (p.duration, p.speed, p.climb) == (t["flight"]["duration"], t["flight"]["speed"], t["flight"]["climb_rate"])
    assert (p.imu, p.imu_rate) == (t["imu"]["preset"], t["imu"]["rate_hz"])
    assert p.fix_sigma == tuple(t["fix"]["sigma_m"]) and p.fix_rate == t["fix"]["rate_hz"]
    assert p.n_particles == t["filter"]["n_particles"] and p.noise_at == t["filter"]["noise_at"]
    assert p.settle == t["filter"]["settle_s"] and p.kf_coriolis is t["filter"]["kf_coriolis"]
    assert (p.out_rate, p.record_rate) == (t["output"]["rate_hz"], t["output"]["record_rate_hz"])


# (scenario, key, bad value, text the message must hold: the range or the rule)
BAD = [
    ("multi-imu-path1", "path.duration", 0.5, "[1, 600] s"),
    ("multi-imu-path1", "path.duration", 601.0, "[1, 600] s"),
    ("multi-imu-path1", "sensors.rate_hz", 0.0, "[1, 100] Hz"),
    ("multi-imu-path1", "sensors.sigma_m", [], "1 to 10"),
    ("multi-imu-path1", "filter.n_particles", MIN_PARTICLES - 1, f"[{MIN_PARTICLES}, {MAX_PARTICLES}]"),
    ("multi-imu-path1", "filter.n_particles", MAX_PARTICLES + 1, f"[{MIN_PARTICLES}, {MAX_PARTICLES}]"),
    ("multi-imu-path1", "filter.n_particles", 1000.0, f"[{MIN_PARTICLES}, {MAX_PARTICLES}]"),
    ("multi-imu-path1", "filter.accel_psd", 0.0, "[1e-08, 10000]"),
    ("multi-imu-path1", "fusion.n_draws", 0, "[1, 10000]"),
    ("multi-imu-path1", "fusion.per_axis", 1, "true or false"),
    ("multi-imu-path1", "filter.settle_s", -1.0, "[0, 600] s"),
    ("multi-imu-adis", "flight.duration", 9.0, "[10, 1800] s"),
    ("multi-imu-adis", "flight.speed", 151.0, "[5, 150] m/s"),
    ("multi-imu-adis", "imu.n_adis", 0, "[1, "),
    ("multi-imu-adis", "fix.sigma_m", [0.3, 0.3], "list of 3"),
    ("multi-imu-adis", "fix.bias_m", [0.0, 0.0, 101.0], "[-100, 100] m"),  # named fix.bias_m[2]
    ("multi-imu-adis", "fix.shared", "no", "true or false"),
    ("multi-imu-adis", "output.record_rate_hz", 3.0, "divide the 20 Hz"),
    ("multi-imu-adis", "output.record_rate_hz", 21.0, "[0.1, 20] Hz"),
    ("upf-flight", "flight.duration", 119.0, "[120, 7200] s"),
    ("upf-flight", "flight.climb_rate", -1.0, "[0, 20] m/s"),
    ("upf-flight", "imu.preset", "adis", "one of ['novatel-isa-100c', 'adis16465']"),
    ("upf-flight", "imu.rate_hz", 5.0, "[10, 2000] Hz"),
    ("upf-flight", "output.rate_hz", 20_001.0, "[1, 20000] Hz"),
    ("upf-flight", "output.record_rate_hz", 30.0, "[0.01, 20] Hz"),  # above fix.rate_hz = 20 Hz
    ("upf-flight", "output.record_rate_hz", 3.0, "divide fix.rate_hz"),
    ("upf-flight", "filter.noise_at", "pulse", "one of ['fix', 'imu']"),
    ("upf-flight", "filter.kf_coriolis", 0, "true or false"),
]


@pytest.mark.parametrize("name, key, value, text", BAD, ids=[f"{b[0]}:{b[1]}={b[2]!r}" for b in BAD])
def test_bad_value_is_one_line_naming_key_and_range(name, key, value, text):
    """A bad value raises one ConfigError line ``key: ...`` that states the valid range (or the rule broken)."""
    err = _error(name, key, value)
    assert err.field.split("[")[0] == key  # a list's bad entry is named with its index, fix.bias_m[2]
    assert text in err.message
    assert str(err).startswith(f"{err.field}: ") and "\n" not in str(err)


@pytest.mark.parametrize("name", sorted(KINDS))
def test_missing_key_is_named(name):
    """Removing ``filter.n_particles`` gives ``filter.n_particles: missing``."""
    cfg = copy.deepcopy(packaged(name))
    del cfg["filter"]["n_particles"]
    with pytest.raises(ConfigError) as exc:
        KINDS[name].parse(cfg)
    assert exc.value.field == "filter.n_particles" and "missing" in exc.value.message


def test_record_rates_dividing_the_fix_rate_are_accepted():
    """multi-imu: 20 / rate must be a whole number: 10, 4, 2, 1, 0.5 Hz give strides 2, 5, 10, 20, 40."""
    for rate, stride in [(10.0, 2), (4.0, 5), (2.0, 10), (1.0, 20), (0.5, 40)]:
        assert KINDS["multi-imu-adis"].parse(_with("multi-imu-adis", "output.record_rate_hz", rate)).stride == stride


def test_settle_time_leaves_one_epoch():
    """settle_s <= duration - epoch is accepted at the boundary, refused beyond it (naming the duration key)."""
    cfg = {"filter": {"settle_s": 99.95}}
    assert settle_time(cfg, 600.0, 100.0, 0.05, "path.duration") == 99.95
    cfg["filter"]["settle_s"] = 99.96
    with pytest.raises(ConfigError) as exc:
        settle_time(cfg, 600.0, 100.0, 0.05, "path.duration")
    assert exc.value.field == "filter.settle_s" and "path.duration = 100.0 s" in exc.value.message
    cfg["filter"]["settle_s"] = 700.0  # beyond hi: the range error
    with pytest.raises(ConfigError, match=r"\[0, 600\] s"):
        settle_time(cfg, 600.0, 1000.0, 0.05, "path.duration")


def test_path1_settle_must_leave_one_sensor_epoch():
    """multi-imu-path1: settle_s = duration is refused (the epoch is 1 / sensors.rate_hz)."""
    err = _error("multi-imu-path1", "filter.settle_s", 100.0)
    assert err.field == "filter.settle_s" and "0.05 s" in err.message


def test_upf_flight_longest_fastest_flight_is_accepted():
    """upf-flight: the longest flight (7200 s) at the fastest fix (100 Hz) and output (20 kHz) rates is within the
    size limits (7.2e5 fixes <= 1e6, 1.44e8 epochs <= 1e9), so it parses."""
    cfg = _with("upf-flight", "flight.duration", 7200.0)
    cfg["fix"]["rate_hz"] = 100.0
    cfg["output"]["record_rate_hz"] = 1.0
    cfg["output"]["rate_hz"] = 20_000.0
    p = KINDS["upf-flight"].parse(cfg)
    assert (p.duration, p.fix_rate, p.out_rate) == (7200.0, 100.0, 20_000.0)


def test_gains_use_the_pairs_of_the_kind():
    """``gains``: each pair is the ratio of the two sources' RMS; "sensors" is the mean of the single sensors' RMS."""
    rmse = {"sensor1": 2.0, "sensor2": 4.0, "mean": 1.5, "sir": 1.0, "fix": 0.5}
    g = KINDS["multi-imu-path1"].gains(rmse)
    assert set(g) == set(MultiImuPath1Kind.gain_pairs)
    assert g["mean_over_sir"] == pytest.approx(1.5)
    assert g["sir_over_fix"] == pytest.approx(2.0)
    assert g["single_over_mean"] == pytest.approx(3.0 / 1.5)


def test_state_names_are_filter_axes():
    """The records' states: every filter with a covariance x the three NED position axes."""
    cfg = packaged("multi-imu-path1")
    names = KINDS["multi-imu-path1"].state_names(cfg)
    n = len(cfg["sensors"]["sigma_m"])
    assert len(names) == 3 * n and names[0].startswith("sensor1_p")
    assert KINDS["multi-imu-path1"].state_units(cfg) == ["m"] * (3 * n)

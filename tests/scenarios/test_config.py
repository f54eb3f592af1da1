"""Scenario config: TOML round trip, --set parsing and type checks, unknown keys, NaN/inf,
malformed TOML, registry resolution. Uses a small kind defined here, registered for the test."""

from __future__ import annotations

import math

import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios import registry
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.scenarios.config import (
    apply_overrides,
    check_finite,
    dump_toml,
    load_scenario,
    merge_onto,
    parse_toml,
    validate_common,
)

KIND = "test_config:CfgKind"


class CfgKind(ScenarioKind):
    kind = KIND

    def validate(self, cfg):
        if cfg["imu"]["tau_accel"] <= 0:
            raise ConfigError("imu.tau_accel", f"must be > 0 s, got {cfg['imu']['tau_accel']!r}")

    def state_names(self, cfg):
        return ["x"]

    def meas_names(self, cfg):
        return ["z"]

    def simulate(self, cfg, run_ids, seeds):  # pragma: no cover - not used here
        raise NotImplementedError

    def optional_keys(self):
        return {"imu.vrw_3sigma"}


def cfg_default():
    return {
        "scenario": {"name": "cfg-test", "kind": KIND, "description": "config test"},
        "campaign": {"runs": 5, "seed": 1},
        "imu": {"grade": "tactical", "tau_accel": 3600.0, "rate_hz": 100},
        "target": {"position_ned": [500.0, 0.0, 0.0]},
        "flags": {"earth_rate": False},
    }


@pytest.fixture
def registered(monkeypatch):
    entry = registry.ScenarioEntry("cfg-test", KIND, "config test", "test_config:cfg_default")
    monkeypatch.setattr(registry, "SCENARIOS", registry.SCENARIOS + (entry,))
    return "cfg-test"


def test_toml_round_trip():
    cfg = cfg_default()
    assert parse_toml(dump_toml(cfg)) == cfg


def test_set_parses_toml_values_and_bare_strings(registered):
    cfg = load_scenario(
        registered,
        ["imu.grade=consumer", 'imu.grade="navigation"', "target.position_ned=[500,500,0]", "campaign.runs=20",
         "imu.tau_accel=100", "flags.earth_rate=true", "imu.rate_hz=200"],
    )
    assert cfg["imu"]["grade"] == "navigation"
    assert cfg["target"]["position_ned"] == [500.0, 500.0, 0.0] and all(isinstance(v, float) for v in cfg["target"]["position_ned"])
    assert cfg["campaign"]["runs"] == 20
    assert cfg["imu"]["tau_accel"] == 100.0 and isinstance(cfg["imu"]["tau_accel"], float)
    assert cfg["flags"]["earth_rate"] is True and cfg["imu"]["rate_hz"] == 200
    # optional key declared by the kind
    assert load_scenario(registered, ["imu.vrw_3sigma=0.06"])["imu"]["vrw_3sigma"] == 0.06


@pytest.mark.parametrize(
    "item, field, pattern",
    [
        ("imu.nope=1", "imu.nope", "unknown key"),
        ("nope.grade=1", "nope.grade", "unknown key"),
        ("imu.grade.x=1", "imu.grade.x", "not a table"),
        ("campaign.runs=2.5", "campaign.runs", "must be an integer"),
        ("imu.tau_accel=fast", "imu.tau_accel", "cannot parse"),
        ("imu.tau_accel=nan", "imu.tau_accel", "finite"),
        ("imu.tau_accel=inf", "imu.tau_accel", "finite"),
        ("target.position_ned=[1,nan,0]", r"target.position_ned\[1\]", "finite"),
        ("target.position_ned=[1,'a',0]", r"target.position_ned\[1\]", "must be a number"),
        ("target.position_ned=5", "target.position_ned", "must be a list"),
        ("flags.earth_rate=1", "flags.earth_rate", "must be a boolean"),
        ("imu=1", "imu", "is a table"),
        ("imu.tau_accel", "--set", "key=value"),
        ("imu.tau_accel=-1", "imu.tau_accel", "must be > 0"),
        ("campaign.runs=-3", "campaign.runs", r"in \[1, 100000\]"),
        ("campaign.seed=-1", "campaign.seed", r"in \[0, 2\^63 - 1\]"),
    ],
)
def test_bad_overrides_name_the_field(registered, item, field, pattern):
    with pytest.raises(ConfigError, match=rf"^{field}: .*({pattern})"):
        load_scenario(registered, [item])


def test_file_merges_onto_kind_template_and_rejects_unknown_keys(registered, tmp_path):
    p = tmp_path / "mine.toml"
    p.write_text(f'[scenario]\nname = "mine"\nkind = "{KIND}"\n\n[imu]\ngrade = "consumer"\n')
    cfg = load_scenario(p)
    assert cfg["scenario"]["name"] == "mine" and cfg["imu"]["grade"] == "consumer"
    assert cfg["imu"]["tau_accel"] == 3600.0  # from the template
    p.write_text(f'[scenario]\nname = "mine"\nkind = "{KIND}"\n\n[imu]\ngrde = "consumer"\n')
    with pytest.raises(ConfigError, match=r"^imu\.grde: unknown key"):
        load_scenario(p)
    p.write_text(f'[scenario]\nname = "mine"\nkind = "{KIND}"\n[extra]\na = 1\n')
    with pytest.raises(ConfigError, match=r"^extra: unknown key"):
        load_scenario(p)
    p.write_text(f'[scenario]\nname = "mine"\nkind = "{KIND}"\n[imu]\ntau_accel = nan\n')
    with pytest.raises(ConfigError, match=r"^imu\.tau_accel: must be a finite number"):
        load_scenario(p)


def test_malformed_toml_names_file_and_line(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('[scenario]\nname = "x"\nkind = \n')
    with pytest.raises(ConfigError) as exc:
        load_scenario(p)
    assert exc.value.field == str(p)
    assert "malformed TOML" in exc.value.message and "line 3" in exc.value.message


def test_missing_kind_and_unknown_scenario_and_kind(tmp_path):
    p = tmp_path / "nokind.toml"
    p.write_text('[scenario]\nname = "x"\n')
    with pytest.raises(ConfigError, match=r"^scenario\.kind: missing"):
        load_scenario(p)
    with pytest.raises(ConfigError, match=r"^scenario: unknown scenario 'no-such'"):
        load_scenario("no-such")
    assert load_scenario("point-target")["scenario"]["kind"] == "image"  # image scenarios are in the one registry
    with pytest.raises(ConfigError, match=r"^scenario\.kind: unknown kind 'martian'"):
        registry.get_kind("martian")
    p.write_text('[scenario]\nname = "x"\nkind = "martian"\n')  # was reported as campaign.seed missing
    with pytest.raises(ConfigError, match=r"^scenario\.kind: unknown kind 'martian'"):
        load_scenario(p, runs=1)
    with pytest.raises(ConfigError, match=r"^scenario\.kind: cannot import"):
        registry.get_kind("no_such_module_xyz:Kind")


def test_validate_common_and_check_finite():
    cfg = cfg_default()
    validate_common(cfg)
    for bad, field in [({"runs": 0, "seed": 1}, "campaign.runs"), ({"runs": True, "seed": 1}, "campaign.runs"),
                       ({"runs": 2, "seed": 1.5}, "campaign.seed")]:
        c = cfg_default()
        c["campaign"] = bad
        with pytest.raises(ConfigError, match=rf"^{field}:"):
            validate_common(c)
    with pytest.raises(ConfigError, match=r"^a\.b\[2\]: must be a finite"):
        check_finite({"a": {"b": [1.0, 2.0, -math.inf]}})


def test_merge_onto_replaces_lists_whole():
    out = merge_onto({"t": {"v": [1.0, 2.0, 3.0], "w": 1}}, {"t": {"v": [4.0]}})
    assert out == {"t": {"v": [4.0], "w": 1}}
    assert apply_overrides({"a": {"b": "x"}}, ["a.b=hello world"]) == {"a": {"b": "hello world"}}


def test_registry_lists_one_line_per_scenario():
    names = [n for n, _ in registry.list_scenarios()]
    assert names[:4] == ["telemetry", "telemetry-imu-grade", "telemetry-noise", "telemetry-geometry"]
    assert all(desc and "\n" not in desc for _, desc in registry.list_scenarios())


def test_require_helpers_reject_booleans():
    """float(True) == 1.0: a boolean must not pass as a number (e.g. ``--set imu.vrw_3sigma=true``)."""
    import numpy as np

    from sarnav.errors import require_finite, require_positive

    for v in (True, False, np.True_):
        with pytest.raises(ConfigError, match="^x: must be a number"):
            require_positive("x", v)
        with pytest.raises(ConfigError, match="^x: must be a number"):
            require_finite("x", v)
    assert require_positive("x", 2) == 2.0 and require_finite("x", np.float32(-1.5)) == -1.5

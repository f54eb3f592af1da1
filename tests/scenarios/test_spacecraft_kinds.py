"""The spacecraft scenario kinds (issue 11): spacecraft-tc1/tc2 (open loop) and spacecraft-closed-loop through the
registry, the reader and the campaign engine: one-line errors naming the key for bad orbits, pointing and noise;
bit-identical results for any executor and number of workers; underweighting switched by [mekf]."""

import copy

import numpy as np
import pytest
import xarray as xr

from sarnav.errors import ConfigError
from sarnav.montecarlo.campaign import run_campaign
from sarnav.scenarios.registry import get_kind, get_scenario


def _short(name="spacecraft-tc2", duration=20.0, runs=4):
    cfg = get_scenario(name)
    cfg["simulation"]["duration"] = duration
    cfg["campaign"]["runs"] = runs
    return cfg


@pytest.mark.parametrize("name", ["spacecraft-tc1", "spacecraft-tc2", "spacecraft-closed-loop"])
def test_registered_scenarios_validate(name):
    cfg = get_scenario(name)
    get_kind(cfg["scenario"]["kind"]).validate(cfg)
    assert cfg["campaign"]["runs"] == (20 if name == "spacecraft-closed-loop" else 100)


BAD = [
    (("orbit", "altitude_km"), 50.0, "orbit.altitude_km"),  # perigee inside the Earth (+100 km)
    (("orbit", "eccentricity"), 1.2, "orbit.eccentricity"),  # escapes
    (("orbit", "eccentricity"), 0.5, "orbit.altitude_km"),  # perigee 0.5 a: intersects the Earth
    (("antenna", "look_angle_deg"), 75.0, "antenna.look_angle_deg"),  # beyond the limb: misses the ellipsoid
    (("antenna", "steering"), "yaw", "antenna.steering"),
    (("measurement", "D"), [[0.0, 0, 0], [0, 25.0, 0], [0, 0, 25.0]], "measurement.D"),
    (("measurement", "D"), [[25.0, 30.0, 0], [30.0, 25.0, 0], [0, 0, 25.0]], "measurement.D"),
    (("measurement", "D"), [[-1.0, 0, 0], [0, 25.0, 0], [0, 0, 25.0]], "measurement.D"),
    (("measurement", "sigma_range"), 0.0, "measurement.sigma_range"),
    (("measurement", "sigma_vic"), -0.5, "measurement.sigma_vic"),
    (("measurement", "mode"), "image", "measurement.mode"),
    (("mekf", "underweight_beta"), -0.2, "mekf.underweight_beta"),
    (("mekf", "underweight_updates"), 2.5, "mekf.underweight_updates"),
    (("initial", "sigma_r0"), 0.0, "initial.sigma_r0"),
    (("simulation", "update_interval"), 8.205, "simulation.update_interval"),
]


@pytest.mark.parametrize("path,value,field", BAD)
def test_bad_input_is_one_line_naming_the_key(path, value, field):
    for name in ("spacecraft-tc2", "spacecraft-closed-loop"):
        if name == "spacecraft-closed-loop" and path == ("measurement", "mode"):
            value = "open-loop"
        cfg = get_scenario(name)
        cfg[path[0]][path[1]] = value
        with pytest.raises(ConfigError) as err:
            get_kind(cfg["scenario"]["kind"]).validate(cfg)
        assert err.value.field == field, (name, str(err.value))
        assert "\n" not in str(err.value)


@pytest.mark.parametrize("path,value,field", [
    (("terrain", "half_range_m"), 2000.0, "terrain.half_range_m"),
    (("radar", "sample_rate_mhz"), 20.0, "radar.sample_rate_mhz"),
    (("radar", "pulse_length_us"), 500.0, "radar.pulse_length_us"),
    (("radar", "n_range_samples"), 64, "radar.n_range_samples"),
    (("radar", "n_range_samples"), 384.0, "radar.n_range_samples"),
    (("radar", "antenna_length_m"), 0.5, "radar.antenna_length_m"),
    (("aperture", "duration"), 10.0, "aperture.duration"),
    (("registration", "method"), "surf", "registration.method"),
    (("registration", "min_inliers"), 2, "registration.min_inliers"),
    (("autofocus", "refine"), [0.5, 2.0], "autofocus.refine[1]"),
    (("simulation", "duration"), 1200.0, "simulation.duration"),
    (("terrain", "reference_look_offset_deg"), 12.0, "terrain.reference_look_offset_deg"),
])
def test_closed_loop_bad_input(path, value, field):
    cfg = get_scenario("spacecraft-closed-loop")
    cfg[path[0]][path[1]] = value
    with pytest.raises(ConfigError) as err:
        get_kind("spacecraft-closed-loop").validate(cfg)
    assert err.value.field == field, str(err.value)


def test_results_are_bit_identical_for_any_executor_and_workers(tmp_path):
    cfg = _short(runs=5)
    kind = get_kind("spacecraft")
    a = run_campaign(cfg, tmp_path / "serial", kind, executor="serial", quiet=True, chunk_size=5)
    b = run_campaign(copy.deepcopy(cfg), tmp_path / "proc", kind, executor="processes", workers=2, quiet=True,
                     chunk_size=2)
    da, db = xr.open_dataset(a.results_path), xr.open_dataset(b.results_path)
    for v in ("error", "sigma", "nees", "residual", "nis", "error_ric", "sigma_ric", "nees_block", "beta"):
        assert np.array_equal(da[v].values, db[v].values, equal_nan=True), v
    assert list(da["state"].values) == ["rX", "rY", "rZ", "vX", "vY", "vZ", "muX", "muY", "muZ"]
    assert list(da["state_units"].values) == ["m", "m", "m", "m/s", "m/s", "m/s", "rad", "rad", "rad"]
    st = a.summary["states"]["rY"]
    assert st["final_sample_sigma"] == pytest.approx(np.std(da["error"].values[:, -1, 1], ddof=1), rel=1e-12)
    assert st["final_sigma"] == pytest.approx(np.mean(da["sigma"].values[:, -1, 1]), rel=1e-12)


def test_underweighting_is_switched_by_the_mekf_table():
    kind = get_kind("spacecraft")
    seeds = np.random.SeedSequence(5).spawn(2)
    cfg = _short("spacecraft-tc1", duration=30.0, runs=2)
    cfg["mekf"]["underweight_updates"] = 2
    rec = kind.simulate(cfg, [0, 1], seeds)
    assert np.array_equal(rec[0].extras["beta"][1], [0.2, 0.2, 0.0])  # 3 updates in 30 s, the first two underweighted
    off = copy.deepcopy(cfg)
    off["mekf"]["underweight_beta"] = 0.0
    rec_off = kind.simulate(off, [0, 1], seeds)
    assert np.all(rec_off[0].extras["beta"][1] == 0.0)
    # underweighting keeps more covariance (Joseph with R' = beta H P H^T + R, eq. 42-43)
    assert np.all(rec[0].sigma[-1] >= rec_off[0].sigma[-1] * (1 - 1e-9))
    assert not np.array_equal(rec[0].sigma[-1], rec_off[0].sigma[-1])


def test_closed_loop_without_updates_runs_and_stores(tmp_path):
    cfg = _short("spacecraft-closed-loop", duration=5.0, runs=2)  # before the first image (8.2 s): no echoes
    res = run_campaign(cfg, tmp_path / "cl", get_kind("spacecraft-closed-loop"), executor="serial", quiet=True)
    assert res.dataset.sizes["update"] == 0 and np.all(np.isfinite(res.dataset["nees"].values))

"""The ``quality-nav`` kind: the INS aided by the best-focus along-track velocity of its own BPA images.

Fast: the contract of the records, batch independence (bit-identical), the oracle mode's consistency (the filter
wiring: the acceleration coupling, the delayed state), the free INS, named configuration errors.
Slow (``python -m pytest -q -m slow -s tests/scenarios/test_quality_nav.py``: 25 min CPU, 76 min wall on 2 cores
shared with four sessions): the
100-run campaign of the default scenario in image mode: NEES and NIS in their bands, the along-track velocity
3-sigma against the free INS, the fix errors against the sigma the filter gives them, mapdrift on the same pulses.
"""

import copy

import numpy as np
import pytest
from scipy.stats import chi2

from sarnav.errors import ConfigError
from sarnav.scenarios import quality_nav as qn
from helpers import spawn_seeds

KIND = qn.QualityNavKind()


def _tiny(**focus):
    """Two 1-s updates, a 32 x 32 grid, two calibration apertures: seconds, not minutes."""
    cfg = qn.default_config()
    cfg["trajectory"]["duration"] = 2.0
    cfg["scene"].update(length=40.0, point_density=0.15)
    cfg["focus"].update(pixels=32, pixel_m=0.15, calibration_apertures=2, **focus)
    return cfg


@pytest.fixture(scope="module")
def tiny_records():
    cfg = _tiny()
    return cfg, KIND.simulate(cfg, [0, 1], spawn_seeds(2, 5))


def test_records_follow_the_contract(tiny_records):
    cfg, recs = tiny_records
    assert KIND.state_names(cfg) == "pN pE pD vN vE vD thN thE thD baX baY baZ bgX bgY bgZ".split()
    assert KIND.meas_names(cfg) == ["v_focus"] and KIND.meas_units(cfg) == ["m/s"]
    for r in recs:
        r.check(15, 1)
        assert set(r.extras) == set(qn.EXTRA_ATTRS)
        used = r.extras["focus_used"][1].astype(bool)
        assert np.all(r.nis_dof == used) and np.all(np.isfinite(r.residual[used, 0]))
        assert np.all(np.isfinite(r.extras["focus_error"][1][used]))
        assert np.all(np.isfinite(r.error)) and np.all(r.sigma > 0)
    np.testing.assert_allclose(recs[0].update_time, [1.0, 2.0])


def test_a_run_does_not_depend_on_its_batch(tiny_records):
    cfg, recs = tiny_records
    alone = KIND.simulate(cfg, [1], spawn_seeds(2, 5)[1:])[0]
    np.testing.assert_array_equal(alone.error, recs[1].error)
    np.testing.assert_array_equal(alone.extras["focus_error"][1], recs[1].extras["focus_error"][1])


def test_oracle_mode_is_consistent():
    """Oracle fixes h(truth) + sigma n: the EKF with the coupled H and the delayed state must be consistent
    (40 runs, 10 updates: NEES time average and pooled NIS inside their 99 % bands)."""
    cfg = qn.default_config()
    cfg["trajectory"]["duration"] = 10.0
    cfg["focus"]["measurement"] = "oracle"
    recs = KIND.simulate(cfg, list(range(40)), spawn_seeds(40, 11))
    nees = np.stack([r.nees for r in recs])[:, 1:]
    lo, hi = chi2.ppf([0.005, 0.995], 15 * 40) / 40
    assert lo <= nees.mean(axis=0).mean() <= hi
    nis = np.stack([r.nis for r in recs])
    n = nis.size
    lo, hi = chi2.ppf([0.005, 0.995], n) / n
    assert lo <= nis.mean() <= hi
    # the fixes see the line-of-sight acceleration error: it is part of the model, not of the noise
    accel = np.stack([r.extras["focus_accel_term"][1] for r in recs])
    assert np.std(accel[:, 0]) > 0.2  # lever R / 2V = 17 s x (sigma of u . da ~ 0.03 m/s^2)
    err = np.concatenate([r.extras["focus_error"][1] for r in recs])
    assert np.std(err) == pytest.approx(cfg["focus"]["oracle_sigma"], rel=0.15)


def test_the_fixes_reduce_the_along_track_velocity_uncertainty_against_the_free_ins():
    cfg = qn.default_config()
    cfg["trajectory"]["duration"] = 10.0
    cfg["focus"]["measurement"] = "oracle"
    aided = KIND.simulate(cfg, [0], spawn_seeds(1, 5))[0]
    off = copy.deepcopy(cfg)
    off["focus"]["enabled"] = False
    free = KIND.simulate(off, [0], spawn_seeds(1, 5))[0]
    j = KIND.state_names(cfg).index("vN")
    assert np.all(free.nis_dof == 0)
    assert aided.sigma[-1, j] < 0.5 * free.sigma[-1, j]
    np.testing.assert_array_equal(free.sigma[0], aided.sigma[0])


@pytest.mark.parametrize("key,value,field", [
    ("focus.measurement", "truth", "focus.measurement"),
    ("focus.interval_s", 0.25, "focus.interval_s"),
    ("aperture.n_pulses", 5000, "aperture.n_pulses"),
    ("focus.n_grid", 10, "focus.n_grid"),
    ("focus.measure", "sharpness", "focus.measure"),
    ("focus.calibration_apertures", 1, "focus.calibration_apertures"),
    ("focus.span_max", 0.1, "focus.span_max"),
    ("focus.pixels", 512, "focus.pixels"),
    ("scene.clutter_density", 90.0, "scene.clutter_density"),
    ("scene.point_density", 0.0, None),
    ("trajectory.duration", 2.5, "trajectory.duration"),
    ("radar.preset", "xband", "radar.preset"),
])
def test_bad_configuration_names_the_key(key, value, field):
    cfg = qn.default_config()
    sec, name = key.split(".")
    cfg[sec][name] = value
    if field is None:  # points only over nothing: clutter alone still has scatterers
        cfg["scene"]["clutter_density"] = 0.0
        field = "scene.point_density"
    with pytest.raises(ConfigError) as err:
        KIND.validate(cfg)
    assert err.value.field == field


# --- the campaign (slow) ----------------------------------------------------------------------------------------

@pytest.mark.slow
def test_campaign_of_100_runs_is_consistent_and_beats_the_free_ins(tmp_path):
    from sarnav.montecarlo.campaign import run_campaign
    from sarnav.simulation.quality_nav import kappa_for

    cfg = qn.default_config()
    # serial: kappa is calibrated once, in this process (numba uses both cores inside each fix)
    res = run_campaign(cfg, tmp_path / "qn", KIND, executor="serial", quiet=True)
    ds, summary = res.dataset, res.summary
    focus, nis, nees = summary["focus"], summary["nis"], summary["nees"]
    kappa = kappa_for(qn.parse(cfg))
    print("\nquality-nav summary: nees", nees, "\nnis", nis, "\nfocus", focus, "\nkappa", kappa["kappa"],
          "used", kappa["used"], "rel SE", kappa["relative_se"])
    runs = ds.sizes["run"]
    lo, hi = chi2.ppf([0.005, 0.995], 15 * runs) / runs
    assert lo <= nees["time_average"] <= hi and nees["fraction_in_band"] > 0.8
    # the NIS band widened by the calibration's own uncertainty of kappa (sampling SE of mean(err^2 c) with the
    # calibration errors' kurtosis): R is only as well known as kappa
    z2 = kappa["errors"] ** 2 * kappa["curvatures"] / kappa["kappa"]
    se = np.std(z2, ddof=1) / np.sqrt(z2.size)
    lo, hi = nis["per_dof_band"]
    print("NIS per dof", nis["per_dof"], "chi2 band", (lo, hi), "calibration SE", se)
    assert lo * (1 - 2 * se) <= nis["per_dof"] <= hi * (1 + 2 * se)
    assert np.mean(ds["focus_used"].values) > 0.9
    # along-track velocity 3-sigma against the free INS (same seeds, no fixes)
    off = copy.deepcopy(cfg)
    off["focus"]["enabled"] = False
    free = KIND.simulate(off, [0], spawn_seeds(1, 5))[0]
    j = KIND.state_names(cfg).index("vN")
    aided = ds["sigma"].values[:, -1, j].mean()
    print("vN final 3 sigma: focus-aided", 3 * aided, "free INS", 3 * free.sigma[-1, j])
    assert aided < 0.5 * free.sigma[-1, j]

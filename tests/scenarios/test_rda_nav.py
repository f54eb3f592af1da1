"""rda-nav kind: oracle and altimeter-only Monte Carlo on small batches (default suite), the paper's claims
on the full 200-run campaigns (``slow``):

    python -m pytest -q -m slow tests/test_rda_nav.py        # or: sarnav run rda-nav
"""


import numpy as np
import pytest
from scipy.stats import chi2

from sarnav.errors import ConfigError, InputDataError
from sarnav.filters import correlated_update
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.registry import get_scenario
from sarnav.simulation.rda_nav import measurement_sigma, reference_targets

KIND = rn.RdaNavKind()


def _run(cfg, n, seed=1, ids=None):
    seeds = np.random.SeedSequence(seed).spawn(n)
    ids = list(range(n)) if ids is None else ids
    recs = KIND.simulate(cfg, ids, [seeds[i] for i in ids])
    for r in recs:
        r.check(18, 3)
    return recs


def _stack(recs, name):
    return np.stack([getattr(r, name) for r in recs])


def _cfg(**sar):
    cfg = rn.default_config()
    cfg["sar"]["measurement"] = "oracle"
    cfg["sar"].update(sar)
    return cfg


@pytest.fixture(scope="module")
def paper_oracle():
    return _run(_cfg(cross_range_model="paper"), 16)


@pytest.fixture(scope="module")
def zero_doppler_oracle():
    return _run(_cfg(cross_range_model="zero-doppler"), 16)


def _mean_nees_in_band(recs, runs):
    nees = _stack(recs, "nees")[:, 1:]
    # epochs of one run are correlated: count each run's time average as (at most) one chi2(18) sample,
    # a band wider than the truth, so a failure is a real inconsistency (99 %, two-sided)
    lo, hi = chi2.ppf([0.005, 0.995], 18 * runs) / runs
    return lo <= nees.mean() <= hi, nees.mean(), (lo, hi)


@pytest.mark.parametrize("which", ["paper_oracle", "zero_doppler_oracle"])
def test_oracle_filter_is_consistent(which, request):
    recs = request.getfixturevalue(which)
    ok, mean, band = _mean_nees_in_band(recs, len(recs))
    assert ok, f"mean NEES {mean:.2f} outside {band}"
    nis, dof = _stack(recs, "nis"), _stack(recs, "nis_dof")
    total = dof.sum()
    lo, hi = chi2.ppf([0.005, 0.995], total)
    assert lo <= nis.sum() <= hi
    err, sig = _stack(recs, "error"), _stack(recs, "sigma")
    assert np.mean(np.abs(err) <= 3 * sig) > 0.99


def test_oracle_residuals_are_zero_mean_and_normalised(paper_oracle):
    res, rs = _stack(paper_oracle, "residual"), _stack(paper_oracle, "residual_sigma")
    z = (res / rs).reshape(-1, 3)
    n = z.shape[0]
    assert np.all(np.abs(z.mean(axis=0)) < 4.0 / np.sqrt(n))
    assert np.all(np.abs(z.std(axis=0) - 1.0) < 0.1)


def test_paper_model_covariance_matches_the_extraction_covariance_run(paper_oracle):
    # extraction seed-001 §4.5 (independent numpy covariance run, paper F/B/Q/H, h = 1000 m, tau = 3600 s):
    # 3-sigma at 50 s: position N/E/D 0.46 / 1.02 / 1.64 m, velocity 0.07 / 0.12 / 0.17 m/s, yaw 6.12 mrad
    s3 = 3 * paper_oracle[0].sigma[-1]
    np.testing.assert_allclose(s3[:3], [0.46, 1.02, 1.64], rtol=0.12)
    np.testing.assert_allclose(s3[3:6], [0.07, 0.12, 0.17], rtol=0.15)
    assert s3[8] == pytest.approx(6.12e-3, rel=0.05)


def test_paper_claims_hold_in_the_paper_model_oracle(paper_oracle):
    err, sig = _stack(paper_oracle, "error"), _stack(paper_oracle, "sigma")
    t = paper_oracle[0].time
    assert np.max(np.abs(err[:, t >= 5.0, :3])) < 3.0  # P3
    s0, s1 = sig[0, 0], sig[0, -1]
    assert s1[0] < 0.5 * s0[0] and s1[2] < 0.5 * s0[2]  # P4: N and D reduced
    assert s1[8] > 0.95 * s0[8]  # P7: yaw not reduced


def test_zero_doppler_cross_range_confounds_along_track_position_and_cross_velocity(zero_doppler_oracle):
    """The physical model: the cross-range measurement sees u.dp + (y dv_perp)/V, so the along-track position
    is not pinned down as in the paper's model (docs/scenarios/rda-nav.md §2)."""
    sig = zero_doppler_oracle[0].sigma
    assert sig[-1, 4] < 0.3 * sig[0, 4]  # east velocity strongly observed through the 185-s lever
    assert sig[-1, 0] > sig[0, 0]  # north position 3-sigma not reduced


def test_altimeter_only_north_east_grow_and_down_stays_bounded():
    recs = _run(_cfg(enabled=False), 2)
    s3 = 3 * recs[0].sigma[-1]
    # extraction seed-001 §3.5: 1/2 (0.0981)(50^2) = 123 m from the accelerometer bias, 126 m in total
    assert s3[0] == pytest.approx(126.0, rel=0.02) and s3[1] == pytest.approx(126.0, rel=0.02)
    assert s3[2] < 2.0
    assert np.all(np.isnan(recs[0].residual[:, 1:])) and np.all(recs[0].nis_dof == 1)


def test_runs_are_reproducible_and_independent_of_the_batch():
    cfg = _cfg()
    cfg["trajectory"]["duration"] = 3.0
    a = _run(cfg, 3)
    b = _run(cfg, 3, ids=[2])
    assert np.array_equal(a[2].error, b[0].error)
    assert np.array_equal(a[2].residual, b[0].residual)
    c = _run(cfg, 3)
    assert all(np.array_equal(x.nees, y.nees) for x, y in zip(a, c))


def test_second_order_terms_inflate_the_cross_range_innovation_only_where_the_lever_is_nonlinear():
    """The zero-Doppler lever is divided by the estimated speed: the Gaussian second-order terms add
    tr(A P A P)/2 to R (docs/scenarios/rda-nav.md §2); same draws, so the difference is the model alone."""
    out = {}
    for model in ("zero-doppler", "paper"):
        for so in (True, False):
            cfg = _cfg(cross_range_model=model, second_order=so)
            cfg["trajectory"]["duration"] = 4.0
            out[model, so] = _run(cfg, 2)
    zd_on, zd_off = out["zero-doppler", True], out["zero-doppler", False]
    s_on = np.stack([r.residual_sigma[:, 2] for r in zd_on])
    s_off = np.stack([r.residual_sigma[:, 2] for r in zd_off])
    # first update: (y sigma_vE, h sigma_vD) ~ (185, 167) m/s lever times sigma_vN / V^2 = 0.1 / 100: ~0.25 m std
    assert np.all(s_on[:, 0] ** 2 - s_off[:, 0] ** 2 > 0.03)
    assert np.all(s_on >= s_off - 1e-6)
    pp_on = np.stack([r.residual_sigma for r in out["paper", True]])
    pp_off = np.stack([r.residual_sigma for r in out["paper", False]])
    np.testing.assert_allclose(pp_on, pp_off, rtol=1e-3)  # linear cross-range, range curvature ~ mm


def test_correlated_update_reduces_to_joseph_and_matches_the_joint_covariance():
    from sarnav.filters import joseph_update

    rng = np.random.default_rng(3)
    n, m = 6, 2
    A = rng.standard_normal((n + m, n + m))
    joint = A @ A.T + 0.5 * np.eye(n + m)  # cov of [dx; nu]
    P, C, Rm = joint[:n, :n][None], joint[:n, n:][None], joint[n:, n:][None]
    H = rng.standard_normal((1, m, n))
    r = rng.standard_normal((1, m))
    dx0, P0, S0 = correlated_update(P, H, Rm, np.zeros_like(C), r)
    dxj, Pj, Sj = joseph_update(P, H, Rm, r)
    np.testing.assert_allclose(P0, Pj, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(dx0, dxj, rtol=1e-10, atol=1e-12)
    dx, Pp, S = correlated_update(P, H, Rm, C, r)
    # independent: e+ = [I - K H, -K] [dx; nu]  ->  P+ = M joint M^T, and S = cov(H dx + nu)
    K = np.linalg.solve(S[0], (P[0] @ H[0].T + C[0]).T).T
    M = np.hstack([np.eye(n) - K @ H[0], -K])
    np.testing.assert_allclose(Pp[0], M @ joint @ M.T, rtol=1e-10, atol=1e-12)
    G = np.hstack([H[0], np.eye(m)])
    np.testing.assert_allclose(S[0], G @ joint @ G.T, rtol=1e-10, atol=1e-12)
    # the gain is optimal: perturbing it increases the trace of P+
    for _ in range(5):
        Kp = K + 1e-3 * rng.standard_normal(K.shape)
        Mp = np.hstack([np.eye(n) - Kp @ H[0], -Kp])
        assert np.trace(Mp @ joint @ Mp.T) > np.trace(Pp[0])


@pytest.fixture(scope="module")
def image_runs():
    cfg = rn.default_config()
    assert cfg["sar"]["measurement"] == "image"
    cfg["trajectory"]["duration"] = 8.0
    return _run(cfg, 2, seed=5)


def test_image_mode_registration_error_is_small_and_justifies_r(image_runs):
    reg = np.stack([r.extras["registration_error"][1] for r in image_runs])
    assert np.all(np.isnan(reg[..., 0]))
    # measured minus geometric truth: range from radar timing (sub-bin peak of 0.15-m bins, receiver noise of two
    # independent acquisitions), along-track from the azimuth registration of a ~3-resolution-cell chip
    assert np.all(np.abs(reg[..., 1]) < 0.01)
    assert np.all(np.abs(reg[..., 2]) < 0.2)
    assert 1e-4 < np.sqrt(np.mean(reg[..., 1] ** 2)) < 0.005  # receiver noise is there (noise-free: 0.2 mm)
    assert np.sqrt(np.mean(reg[..., 2] ** 2)) < 0.05


def test_image_mode_measurement_sigma_comes_from_each_image_unless_overridden():
    prm = rn.parse(rn.default_config())
    assert prm.registration_sigma is None  # R from each image's predicted registration sigma
    sig, add = measurement_sigma(prm, image=False)  # oracle: Table 2
    np.testing.assert_allclose(sig, [0.25, 0.25])
    assert add == 1.0
    cfg = rn.default_config()
    cfg["sar"]["registration_sigma_m"] = [0.002, 0.03]  # the optional constant override
    prm = rn.parse(cfg)
    sig, add = measurement_sigma(prm, image=True)
    np.testing.assert_array_equal(sig, [0.002, 0.03])
    assert add == 0.0
    cfg["sar"]["image_added_noise"] = True
    prm = rn.parse(cfg)
    sig, add = measurement_sigma(prm, image=True)
    np.testing.assert_allclose(sig, np.hypot([0.25, 0.25], [0.002, 0.03]))
    assert add == 1.0


def test_image_mode_predicted_registration_sigma_is_recorded_and_matches_the_errors(image_runs):
    reg = np.concatenate([r.extras["registration_error"][1][:, 1:] for r in image_runs])
    sig = np.concatenate([r.extras["registration_sigma"][1][:, 1:] for r in image_runs])
    assert np.all(np.isfinite(sig)) and np.all(sig > 0)
    # range ~2 mm, along track ~20 mm predicted; 16 samples per axis: the mean of z^2 is chi2_16 / 16 for a right
    # prediction (99.9 % interval 0.25 .. 2.5), a sigma wrong by 2x in either direction fails
    z2 = np.mean((reg / sig) ** 2, axis=0)
    assert np.all((z2 > 0.25) & (z2 < 2.5)), z2
    assert np.all(np.concatenate([r.extras["update_rejected"][1] for r in image_runs]) == 0)
    assert np.all(np.concatenate([r.extras["pairs_fused"][1] for r in image_runs]) == 1)


def test_image_mode_measured_toc_is_the_true_zero_doppler_time(image_runs):
    prm = rn.parse(rn.default_config())
    toc_true = reference_targets(prm)[:8, 0] / prm.trajectory.speed
    for r in image_runs:
        toc = r.extras["toc"][1]
        assert np.all(np.abs(toc - toc_true) < 0.03)  # 0.3 m at 10 m/s


def test_image_mode_records_stages_residuals_and_autofocus(image_runs):
    r = image_runs[0]
    st = r.extras["stage_seconds"][1]
    assert st.shape == (8, len(rn.STAGES)) and np.all(st[:, 1:] > 0)
    assert np.all(np.isfinite(r.extras["autofocus_dk"][1]))
    z = r.residual / r.residual_sigma
    assert np.all(np.isfinite(z)) and np.all(np.abs(z) < 4.5)


def test_image_mode_is_reproducible():
    cfg = rn.default_config()
    cfg["trajectory"]["duration"] = 2.0
    a, b = _run(cfg, 1, seed=9), _run(cfg, 1, seed=9)
    assert np.array_equal(a[0].residual, b[0].residual) and np.array_equal(a[0].error, b[0].error)


def test_fixed_scene_shares_the_reference_pass_but_not_the_in_flight_noise():
    from sarnav.simulation.sar_echoes import simulated_imager
    from sarnav.simulation import rda_nav_world as world

    cfg = rn.default_config()
    cfg["trajectory"]["duration"] = 2.0
    cfg["scene"]["clutter_per_run"] = False
    prm = rn.parse(cfg)
    targets = world.reference_targets(prm)

    def imager(**kw):
        return simulated_imager(radar=prm.radar, truth=prm.trajectory, targets=targets,
                                 scene_for=world.scene_factory(prm, targets), reflector_amplitude=3.16,
                                 snr_db=prm.snr_db, reference_seed=prm.scene["seed"], **kw)

    im = imager(noise_seeds=[11, 12])
    assert im.aperture(1, 0) is im.aperture(1, 1)  # reference pass computed once for all runs
    recs = _run(cfg, 2, seed=3)
    reg = np.stack([r.extras["registration_error"][1][:, 1:] for r in recs])
    assert np.all(np.isfinite(reg)) and np.all(np.abs(reg[..., 0]) < 0.01) and np.all(np.abs(reg[..., 1]) < 0.2)
    assert not np.array_equal(reg[0], reg[1])  # same scene, different receiver noise per run
    with pytest.raises(InputDataError, match="^source"):
        imager(noise_seeds=[11, 12]).measure(0, None, np.zeros((1, 2, 3)), None, None)


def test_reference_targets_lie_in_the_swath_with_toc_inside_each_aperture():
    prm = rn.parse(rn.default_config())
    t = reference_targets(prm)
    assert t.shape == (50, 3)
    toc = t[:, 0] / 10.0
    assert np.all((toc > np.arange(50) + 0.25 - 1e-12) & (toc < np.arange(50) + 0.75 + 1e-12))
    slant = np.hypot(t[:, 1], 1000.0)
    assert np.all((slant > 2000.0) & (slant < 2210.0))


@pytest.mark.parametrize("field,value", [
    ("sar.measurement", "radar"), ("sar.cross_range_model", "doppler"), ("trajectory.duration", 2.5),
    ("imu.rate_hz", 105.0), ("scene.toc_jitter_s", 0.6), ("radar.preset", "xband"), ("sar.enabled", "yes"),
    ("sar.second_order", 1), ("sar.registration_sigma_m", 0.02), ("sar.registration_sigma_m", [0.0, 0.02]),
    ("sar.image_added_noise", "no"), ("radar.snr_db", float("nan")), ("radar.snr_db", 200.0),
    ("radar.carrier_ghz", -1.0), ("imu.grade", "military"), ("filter.imu", {"grade": "military"}),
    ("sar.algorithm", "omega-k"), ("sar.focus", "sharpest"), ("sar.gate_probability", 0.7),
    ("sar.min_correlation", 1.5), ("scene.type", "forest"), ("scene.targets_per_image", 0),
    ("scene.geolocation_sigma_m", [0.3, -0.1, 0.0]), ("scene.reference_coherence", 1.2),
    ("scene.terrain_relief_m", -5.0), ("scene.clutter_density_m2", 0.0), ("radar.look_side", "up"),
    ("radar.prf_hz", 50.0), ("radar.prf_hz", 2.0e5), ("radar.range_margin_m", -1.0), ("trajectory.type", "loop"),
])
def test_bad_config_names_the_field(field, value):
    cfg = rn.default_config()
    t, k = field.split(".")
    cfg.setdefault(t, {})[k] = value
    want = "filter.imu.grade" if t == "filter" else field
    with pytest.raises(ConfigError, match=want.replace(".", r"\.")):
        KIND.validate(cfg)


def test_paper_cross_range_model_is_refused_in_image_mode():
    cfg = rn.default_config()
    cfg["sar"].update(measurement="image", cross_range_model="paper")
    with pytest.raises(ConfigError, match="sar.cross_range_model"):
        KIND.validate(cfg)


# --- full campaigns (slow): python -m pytest -q -m slow tests/test_rda_nav.py -------------------------------

def _campaign(tmp_path_factory, name, **sar):
    from sarnav.montecarlo.campaign import run_campaign

    cfg = rn.default_config()
    cfg["sar"].update(sar)
    out = tmp_path_factory.mktemp(name)
    return run_campaign(cfg, out, KIND, executor="processes", workers=2, quiet=True).dataset


def _nees_in_band(ds):
    from sarnav.analysis.consistency import nees_statistics

    runs = ds.sizes["run"]
    ne = nees_statistics(ds["nees"].values[:, 1:], 18)
    lo, hi = chi2.ppf([0.005, 0.995], 18 * runs) / runs
    assert lo <= ne["time_average"] <= hi, ne["time_average"]
    assert ne["fraction_in_band"] > 0.8


def _nis_in_band(ds):
    from sarnav.analysis.consistency import nis_statistics

    ni = nis_statistics(ds["nis"].values, ds["nis_dof"].values)
    assert ni["per_dof_band"][0] <= ni["per_dof"] <= ni["per_dof_band"][1], ni["per_dof"]


def _residual_means_zero(ds):
    z = (ds["residual"] / ds["residual_sigma"]).values.reshape(-1, 3)
    ok = np.isfinite(z)
    for m in range(3):
        if ok[:, m].any():
            zm = z[ok[:, m], m]
            assert abs(zm.mean()) < 3.0 / np.sqrt(zm.size) * max(1.0, zm.std()), (m, zm.mean())


def _claims_common(ds, consistency=True):
    from sarnav.analysis.consistency import sigma_containment

    if consistency:
        _nees_in_band(ds)
        _nis_in_band(ds)
        _residual_means_zero(ds)
    # >= 99 % inside +-3 sigma pooled over states; per state >= 98 %: runs are the independent samples (errors are
    # correlated in time) and an unobservable state (yaw) keeps its initial draw, so one run of 200 beyond 3 sigma
    # (expected 0.54) costs 0.5 % of a state's samples
    contain = sigma_containment(ds["error"].values, ds["sigma"].values)
    assert np.mean(contain) >= 0.99 and np.all(contain >= 0.98), contain
    sig = ds["sigma"].values[0]
    assert sig[-1, 8] > 0.95 * sig[0, 8]  # P7: yaw not observable


@pytest.mark.slow
def test_campaign_paper_model_oracle_reproduces_the_paper_claims(tmp_path_factory):
    ds = _campaign(tmp_path_factory, "oracle", measurement="oracle", cross_range_model="paper")
    _claims_common(ds)
    t = ds["time"].values
    # P3 (< 3 m after 5 s, read from the paper's figure): the D 3-sigma is 2.2-2.7 m over 5-15 s, so among 200 runs
    # a few 4-sigma samples exceed 3 m (measured max 3.08 m and 3.62 m = 4.1 sigma for two draws): assert it for
    # 99.9 % of the samples, and that every larger error is within 4.5 sigma
    a = np.abs(ds["error"].values[:, t >= 5.0, :3])
    s = ds["sigma"].values[:, t >= 5.0, :3]
    assert np.mean(a < 3.0) > 0.999 and np.all((a < 3.0) | (a < 4.5 * s))
    sig = ds["sigma"].values[0]
    assert sig[-1, 0] < sig[0, 0] and sig[-1, 2] < sig[0, 2]  # P4
    alt = _campaign(tmp_path_factory, "alt", enabled=False, measurement="oracle")
    s_alt = 3 * alt["sigma"].values[0, -1]
    assert s_alt[0] > 50 and s_alt[1] > 50  # P9 / Fig 15
    assert np.all(3 * sig[-1, :3] < 3.0)


@pytest.fixture(scope="module")
def image_campaign(tmp_path_factory):
    return _campaign(tmp_path_factory, "image", measurement="image")


@pytest.mark.slow
def test_campaign_image_mode_is_consistent_and_registration_justifies_r(image_campaign):
    ds = image_campaign
    _claims_common(ds)  # NEES, NIS in their bands, residual means 0, >= 99 % inside 3 sigma, yaw not reduced
    # R from each image: over the fused images the measured registration errors have the std the images predicted
    # (within 20 %, issue 10) and a mean below a tenth of it
    _registration_matches_prediction(ds, 0.2)


@pytest.mark.slow
def test_campaign_image_mode_paper_claims(image_campaign):
    ds = image_campaign
    t = ds["time"].values
    # P3: every position error below 3 m after the first 5 s (measured max N/E/D 1.81 / 0.42 / 0.80 m)
    assert np.max(np.abs(ds["error"].values[:, t >= 5.0, :3])) < 3.0
    sig = ds["sigma"].values[0]
    assert sig[-1, 0] < sig[0, 0] and sig[-1, 2] < sig[0, 2]  # P4: N and D 3 sigma reduced
    assert np.all(3 * sig[-1, :3] < 3.0)  # Fig. 15: SAR-aided below 3 m (altimeter only > 50 m: oracle test)
    assert sig[-1, 4] < 0.3 * sig[0, 4]  # cross-track velocity through the zero-Doppler lever


@pytest.mark.slow
def test_campaign_image_mode_with_table2_noise_leaves_north_weakly_observable(tmp_path_factory):
    """``sar.image_added_noise = true``: Table 2's 0.25 m white noise on the image-derived range and cross-range.
    The filter stays consistent, but north is only known through the lever y/V ~ 185 s times the cross-track
    velocity, which 0.25-m ranges determine poorly (docs/scenarios/rda-nav.md §5): N 3 sigma ~ 7.5 m at 50 s."""
    from sarnav.montecarlo.campaign import run_campaign

    cfg = rn.default_config()
    cfg["sar"]["image_added_noise"] = True
    cfg["campaign"]["runs"] = 50
    ds = run_campaign(cfg, tmp_path_factory.mktemp("added"), executor="processes", workers=2, quiet=True,
                      kind=KIND).dataset
    # time-averaged NEES inside its band; the per-epoch band holds for only 76 % of the epochs (the time-correlated
    # second-order remainder of §5), so the per-epoch check of _nees_in_band is not asserted here
    from sarnav.analysis.consistency import nees_statistics

    ne = nees_statistics(ds["nees"].values[:, 1:], 18)
    lo, hi = chi2.ppf([0.005, 0.995], 18 * 50) / 50
    assert lo <= ne["time_average"] <= hi, ne["time_average"]
    sig = ds["sigma"].values[0]
    assert 3 * sig[-1, 0] > 3.0 and 3 * np.max(sig[:, 0]) > 2 * 1.9  # N 3 sigma grows past 2x its initial 1.9 m
    assert 3 * sig[-1, 1] < 1.5 and 3 * sig[-1, 2] < 2.0  # E and D stay determined


@pytest.mark.slow
def test_campaign_flexsar_image_mode_is_consistent(tmp_path_factory):
    """``rda-nav-flexsar`` (paper Tables 4-6, 1667 pulses per image), 20 runs in image mode (≈ 4 min on 2 cores)."""
    from sarnav.analysis.consistency import sigma_containment
    from sarnav.montecarlo.campaign import run_campaign

    cfg = get_scenario("rda-nav-flexsar")
    cfg["campaign"]["runs"] = 20
    ds = run_campaign(cfg, tmp_path_factory.mktemp("flexsar"), executor="processes", workers=2, quiet=True,
                      kind=KIND).dataset
    _nees_in_band(ds)
    _nis_in_band(ds)
    _residual_means_zero(ds)
    # pooled >= 99 % inside 3 sigma; per state >= 95 %: with 20 runs one run's unobservable draw is 5 %
    contain = sigma_containment(ds["error"].values, ds["sigma"].values)
    assert np.mean(contain) >= 0.99 and np.all(contain >= 0.95), contain
    t = ds["time"].values
    assert np.max(np.abs(ds["error"].values[:, t >= 5.0, :3])) < 3.0
    sig = ds["sigma"].values[0]
    assert np.all(sig[-1, :3] < sig[0, :3])  # N, E, D 3 sigma reduced
    # the along-track error is heavy-tailed (50 runs: max 63 mm against a 2.5-mm std), so 20 runs pin its std to
    # about +-30 %
    _registration_matches_prediction(ds, 0.3)


def _registration_matches_prediction(ds, tol):
    from sarnav.analysis.consistency import summarize

    reg = summarize(ds)["registration"]
    for axis in ("range", "cross"):
        r = reg[axis]
        assert 1 - tol <= r["std_over_predicted"] <= 1 + tol, (axis, r)
        assert abs(r["mean"]) < 0.1 * r["predicted_sigma_rms"] + 3 * r["stderr"], (axis, r)


def _inject_wrong_peaks(monkeypatch, updates):
    """Every run's image of the given updates matches the wrong place: the range by +3 m, the TOC by +0.3 s (a clutter
    scatterer taken for the reference target); nothing about it looks wrong to the imager itself."""
    from sarnav.measurements import sar_image

    measure = sar_image.SubApertureImager.measure

    def wrong(self, u, *a, **k):
        am = measure(self, u, *a, **k)
        if u in updates:
            am.range += 3.0
            am.toc += 0.3
        return am

    monkeypatch.setattr(sar_image.SubApertureImager, "measure", wrong)


def test_an_injected_wrong_peak_is_gated_and_the_filter_stays_consistent(monkeypatch):
    cfg = rn.default_config()
    cfg["trajectory"]["duration"] = 16.0
    bad = (8, 12)
    _inject_wrong_peaks(monkeypatch, bad)
    recs = _run(cfg, 4, seed=21)
    rej = np.stack([r.extras["update_rejected"][1] for r in recs])
    gate = rn.REJECTIONS.index("innovation gate")
    assert np.all(rej[:, list(bad)] == gate)  # every wrong match refused by the chi-square gate
    assert np.mean(rej == 0) > 0.8  # and the good ones fused
    err, sig = _stack(recs, "error"), _stack(recs, "sigma")
    assert np.mean(np.abs(err) <= 3 * sig) > 0.99
    # the same wrong matches fused (gate off): the filter is driven metres off and far outside its 3 sigma
    cfg["sar"]["gate_probability"] = 0.0
    recs = _run(cfg, 4, seed=21)
    err, sig = _stack(recs, "error"), _stack(recs, "sigma")
    assert np.mean(np.abs(err[:, -1, :3]) > 3 * sig[:, -1, :3]) > 0.3


@pytest.mark.slow
def test_p6_roll_and_pitch_within_about_2_mrad_but_their_3_sigma_does_not_decrease(tmp_path_factory):
    """NAVIGATION P6 (docs/claims.md: refuted in its second half), default image mode, 50 runs: roll and pitch errors
    stay near 2 mrad (measured max 2.17 / 2.21 mrad, RMS 0.72 / 0.67), but their 3-sigma does not decrease over the
    straight level flight (2.00 -> 2.20 / 2.26 mrad at 50 s): tilt is reached only through g dtheta, which an
    accelerometer bias mimics."""
    from sarnav.montecarlo.campaign import run_campaign

    cfg = rn.default_config()
    cfg["campaign"]["runs"] = 50
    ds = run_campaign(cfg, tmp_path_factory.mktemp("p6"), KIND, executor="processes", workers=2, quiet=True).dataset
    att = ds["error"].values[:, :, 6:8] * 1e3                    # roll, pitch [mrad]
    s3 = 3e3 * ds["sigma"].values[0, :, 6:8]
    print("P6: max", np.max(np.abs(att), axis=(0, 1)), "rms", np.sqrt(np.mean(att ** 2, axis=(0, 1))),
          "3 sigma start / end", s3[0], s3[-1])
    assert np.all(np.max(np.abs(att), axis=(0, 1)) < 2.5) and np.all(np.sqrt(np.mean(att ** 2, axis=(0, 1))) < 1.0)
    assert np.all(s3[-1] >= s3[0])                              # the "slight decrease" is not seen


@pytest.mark.slow
@pytest.mark.parametrize("speed, runs", [(10.0, 20), (60.0, 10)])
def test_p16_a_15_deg_per_hour_gyro_bias_sigma_covers_the_earth_rate(speed, runs, tmp_path_factory):
    """NAVIGATION P16 (docs/navigation.md "Rotating Earth"): rotating truth, the flat filter (Earth rate and Coriolis
    not modelled) with a 15 deg/hr gyro-bias 3-sigma: the navigation states stay consistent (10 m/s, 20 runs: position
    (error/sigma)^2 1.10 / 0.74 / 0.88, NIS/dof 1.024 in its band) while the x gyro-bias state absorbs Omega cos L (its
    (error/sigma)^2 ~8: the 18-state NEES is high for that state alone). At the paper's 60 m/s (PRF 600 Hz, 10 runs)
    the Coriolis acceleration (2 Omega V sin L = 0.00057 g at 40 deg, below the 0.01 g accelerometer-bias 3-sigma) is
    absorbed by the accelerometer-bias states, which stay consistent."""
    from sarnav.montecarlo.campaign import run_campaign
    from sarnav.scenarios.config import load_scenario

    sets = ["earth.rotation=true", "earth.modelled=false", "filter.imu.gyro_bias_3sigma=15.0"]
    if speed != 10.0:
        sets += [f"trajectory.speed={speed}", f"radar.prf_hz={10.0 * speed}"]
    cfg = load_scenario("rda-nav", sets, runs=runs)
    res = run_campaign(cfg, tmp_path_factory.mktemp("p16"), KIND, executor="processes", workers=2, quiet=True)
    ds, s = res.dataset, res.summary
    z2 = np.mean((ds["error"].values[:, 1:] / ds["sigma"].values[:, 1:]) ** 2, axis=(0, 1))
    print(f"P16 at {speed} m/s: (error/sigma)^2 per state", np.round(z2, 2), "NIS/dof", s["nis"]["per_dof"],
          s["nis"]["per_dof_band"])
    assert np.all(z2[:12] < 1.6)                                 # position, velocity, attitude, accelerometer bias
    assert s["nis"]["per_dof_band"][0] <= s["nis"]["per_dof"] <= s["nis"]["per_dof_band"][1]
    assert np.max(z2[12:15]) > 4.0                               # a gyro-bias state carries the Earth rate

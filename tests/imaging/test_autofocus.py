"""Mapdrift and contrast autofocus recover a speed-induced FM-rate error (paper eqs. 14–16)."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.signal import metrics
from sarnav.imaging.autofocus import contrast_autofocus, mapdrift
from sarnav.imaging.rda import range_doppler
from test_rda import LAM, R0, V, synth_rc


@pytest.fixture(scope="module")
def point():
    rc = synth_rc([(30.0, R0, 1.0)], nr=96, r_near=1993.0)
    focused = metrics.point_target_metrics(range_doppler(rc, V))
    return rc, focused


def _true_dk(rc, v_hat):
    # K_amf - K_a at mid-swath, K_a = 2 V^2 / (lambda R0)  (paper eq. 7, eq. 15 sign)
    r_mid = 0.5 * (rc.slant_range[0] + rc.slant_range[-1])
    return 2.0 * (v_hat**2 - V**2) / (LAM * r_mid)


@pytest.mark.parametrize("dv", [2.0, -1.5])
def test_mapdrift_recovers_fm_rate_error_and_refocuses(point, dv):
    rc, focused = point
    v_hat = V + dv
    blurred = metrics.point_target_metrics(range_doppler(rc, v_hat), n_sidelobes=2)
    assert blurred["y"]["irw_m"] > 2.0 * focused["y"]["irw_m"]  # premise: the error at least doubles the IRW
    res = mapdrift(rc, v_hat)
    assert res.fm_rate_error == pytest.approx(_true_dk(rc, v_hat), rel=0.10)
    assert res.speed == pytest.approx(V, abs=0.1 * abs(dv))
    refocused = metrics.point_target_metrics(res.image)
    assert refocused["y"]["irw_m"] == pytest.approx(focused["y"]["irw_m"], rel=0.05)
    # first look pair: |Delta_eta| ~ (T/2) |1 - K_a/K_amf| (two half-band looks, seed-001 §2.2 identity)
    k_ratio = V**2 / v_hat**2
    assert abs(res.misregistration[0]) == pytest.approx(0.5 * rc.n_pulses / 250.0 * abs(1 - k_ratio), rel=0.15)
    assert abs(res.misregistration[-1]) * 250.0 < 0.05  # looks aligned at the end


def test_single_pass_is_the_paper_estimate(point):
    rc, _ = point
    one = mapdrift(rc, V + 2.0, max_iterations=1)
    assert one.iterations == 1
    assert one.fm_rate_error == pytest.approx(_true_dk(rc, V + 2.0), rel=0.10)


@pytest.mark.parametrize("metric", ["normalised_variance", "intensity_contrast"])
def test_contrast_autofocus_converges_on_the_same_case(point, metric):
    rc, focused = point
    v_hat = V + 2.0
    res = contrast_autofocus(rc, v_hat, metric=metric)
    assert res.speed == pytest.approx(V, abs=0.05 * 2.0)
    assert res.fm_rate_error == pytest.approx(_true_dk(rc, v_hat), rel=0.10)
    assert metrics.point_target_metrics(res.image)["y"]["irw_m"] == pytest.approx(focused["y"]["irw_m"], rel=0.05)
    speeds, values = res.evaluations
    assert res.metric >= max(values) - 1e-12 * abs(max(values))


def test_mapdrift_on_a_scatterer_field():
    rng = np.random.default_rng(np.random.SeedSequence(31))
    targets = [(y, r, a) for y, r, a in zip(rng.uniform(12, 48, 6), rng.uniform(1992, 2008, 6), rng.uniform(0.5, 1, 6))]
    rc = synth_rc(targets, nr=160, r_near=1988.0)
    res = mapdrift(rc, V - 1.5)
    assert res.speed == pytest.approx(V, abs=0.15)


def test_bad_settings_are_named(point):
    rc, _ = point
    with pytest.raises(ConfigError, match="max_iterations"):
        mapdrift(rc, V, max_iterations=0)
    with pytest.raises(ConfigError, match="look_bandwidth"):
        mapdrift(rc, V, looks="doppler", look_bandwidth=1e6)
    with pytest.raises(ConfigError, match="looks"):
        mapdrift(rc, V, looks="three")
    with pytest.raises(ConfigError, match="metric"):
        contrast_autofocus(rc, V, metric="sharpest")
    with pytest.raises(ConfigError, match="search"):
        contrast_autofocus(rc, V, search=0.9)


def test_doppler_looks_literal_paper_form_in_the_strong_chirp_case(point):
    rc, focused = point
    res = mapdrift(rc, V + 2.0, looks="doppler")
    assert res.fm_rate_error == pytest.approx(_true_dk(rc, V + 2.0), rel=0.10)
    assert metrics.point_target_metrics(res.image)["y"]["irw_m"] == pytest.approx(focused["y"]["irw_m"], rel=0.05)


def test_mapdrift_in_the_papers_weak_chirp_regime():
    # paper sim: 10 m/s, PRF 100 Hz, 1-s block, R0 ~ 2100 m: K_a T^2 ~ 3 (notes/seed-001 §3.5)
    v, prf = 10.0, 100.0
    rc = synth_rc([(5.0, 2100.0, 1.0)], speed=v, prf=prf, duration=1.0, r_near=2090.0, nr=128)
    r_mid = 0.5 * (rc.slant_range[0] + rc.slant_range[-1])
    assert 2 * v**2 / (LAM * r_mid) * 1.0**2 < 4.0  # premise: weak chirp
    for dv in (0.3, -0.5):
        res = mapdrift(rc, v + dv)
        assert res.speed == pytest.approx(v, abs=0.03)  # measured 0.01-0.03 m/s

"""Linear covariance study of rda-nav against the Monte Carlo filter, and the range-noise law of north."""

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.rda_nav import covariance_study


def _filter_sigma(**sar):
    cfg = rn.default_config()
    cfg["sar"].update(measurement="oracle", **sar)
    cfg["trajectory"]["duration"] = 30.0
    seeds = np.random.SeedSequence(3).spawn(1)
    rec = rn.RdaNavKind().simulate(cfg, [0], seeds)[0]
    return rec.sigma[::int(round(1 / rn.COV_STEP))], rn.parse(cfg)


@pytest.mark.parametrize("model", ["paper", "zero-doppler"])
def test_covariance_study_reproduces_the_filter_covariance(model):
    # the filter without the delayed-state mapping and second-order terms (which the study leaves out) linearises
    # at its estimate, the study at the truth: position 1-sigma agree within 12 % at every second (measured:
    # paper 1.1 %, zero-Doppler 9.2 %, whose lever depends on the estimated velocity)
    sig_mc, prm = _filter_sigma(cross_range_model=model, delayed_state=False, second_order=False)
    st = covariance_study(prm, *prm.sar_sigma)
    assert st["states"][:3] == ["pN", "pE", "pD"] and st["sigma"].shape == sig_mc.shape
    np.testing.assert_allclose(st["sigma"][:, :3], sig_mc[:, :3], rtol=0.12)


def test_north_needs_precise_ranges_not_more_targets():
    prm = rn.parse(rn.default_config())
    n3 = [3 * covariance_study(prm, rs, 0.0315)["sigma"][-1, 0] for rs in (0.25, 0.05, 0.01, 0.00125)]
    assert all(a > b for a, b in zip(n3, n3[1:]))  # north 3-sigma falls with the range noise
    assert n3[0] > 3.0 and n3[-1] < 1.0
    # ten targets per image across the 180-m swath instead of one: their lines of sight differ by 2 deg,
    # the north 3-sigma at 0.25-m noise stays above 3 m
    many = covariance_study(prm, 0.25, 0.25, ground_ranges=np.linspace(1760.0, 1940.0, 10))
    assert 3 * many["sigma"][-1, 0] > 3.0
    paper = covariance_study(prm, 0.25, 0.25, cross_model="paper")
    assert 3 * paper["sigma"][-1, 0] < 0.6


def test_bad_input_names_the_field():
    prm = rn.parse(rn.default_config())
    with pytest.raises(ConfigError, match="^range_sigma"):
        covariance_study(prm, 0.0, 0.1)
    with pytest.raises(ConfigError, match="^ground_ranges"):
        covariance_study(prm, 0.1, 0.1, ground_ranges=[])

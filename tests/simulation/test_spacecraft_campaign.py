"""100-run open-loop campaigns of the spacecraft SAR navigation against the paper (Pogorelsky et al. 2022, §VII;
claims T13-T18 of extraction seed-002). Slow (about 40 s):

    .venv/bin/python -m pytest -q -p no:xdist -m slow tests/simulation/test_spacecraft_campaign.py

D = 5^2 I m^2 (G8 default), 73 updates (G11), seeds SeedSequence(20220901).spawn(100) for every case (same initial
draws in every case). "paper" = the paper's filter (eq. 13 without Coriolis, literal Q) on a truth whose
misalignment is constant (L269); "model" = F with the Coriolis terms (G7) on a truth whose misalignment follows the
filter's own random walk Q_mu (G18), i.e. a truth that matches the filter's model.
"""

import math

import numpy as np
import pytest

from sarnav.analysis.consistency import chi2_band
from sarnav.filters.mekf import MekfModel
from sarnav.simulation.spacecraft import OpenLoopParams, radial_intrack_crosstrack, run_open_loop

pytestmark = pytest.mark.slow
N = 100
DEG = math.pi / 180
CASES = {
    "tc2": lambda: OpenLoopParams.tc2(),
    "tc2_model": lambda: OpenLoopParams.tc2(mekf=MekfModel(coriolis=True), truth_misalignment_psd=3.4e-13),
    "tc1": lambda: OpenLoopParams.tc1(),
    "tc1_model": lambda: OpenLoopParams.tc1(mekf=MekfModel(coriolis=True), truth_misalignment_psd=3.4e-13),
    "tc1_no_uw": lambda: OpenLoopParams.tc1(underweighting=None),
}
_CACHE = {}


def campaign(name):
    if name not in _CACHE:
        _CACHE[name] = run_open_loop(CASES[name](), np.random.SeedSequence(20220901).spawn(N))
    return _CACHE[name]


def final(res, k=-1):
    """(sample sigma, mean predicted sigma, sample mean) of the 9 states at record k."""
    e = res.error[:, k]
    return np.std(e, axis=0, ddof=1), np.mean(res.sigma[:, k], axis=0), np.mean(e, axis=0)


def at(res, t):
    return int(np.argmin(np.abs(res.time - t)))


def test_tc2_final_sigma_against_paper():
    """T14: 1-sigma at 10 min about 12 m (x) and 138 m (y)."""
    s, p, _ = final(campaign("tc2"))
    print(f"TC-2 final sigma x/y/z sample {s[:3].round(1)} predicted {p[:3].round(1)} m")
    assert p[1] == pytest.approx(138.0, rel=0.15) and s[1] == pytest.approx(138.0, rel=0.15)
    assert 6.0 < p[0] < 36.0 and 6.0 < s[0] < 36.0  # "of the order of 12 m"; with D = 25 I it is ~20 m (G8)
    assert p[0] < p[2] < p[1]  # z lies between x and y (L535 "ranges from ... to ...")


def test_boresight_misalignment_is_not_observed_t15():
    for name, sig0 in (("tc2", 0.01 * DEG), ("tc1", 0.1 * DEG)):
        res = campaign(name)
        s_end, p_end, _ = final(res)
        s_0, _, _ = final(res, 0)
        assert p_end[8] >= 0.995 * sig0  # the predicted sigma about z does not decrease (0.5 %: essentially kept)
        assert s_end[8] / s_0[8] == pytest.approx(1.0, abs=0.03)  # the estimate about z does not move
        assert p_end[6] < 0.5 * sig0  # while the azimuth axis (x) is well observed


def test_tc2_consistency():
    """NEES (9 dof) of 100 runs against its chi-square band, averaged over the records of the run."""
    lo, hi = chi2_band(9 * N, N)
    model, paper = campaign("tc2_model"), campaign("tc2")
    avg_model, avg_paper = model.nees[:, 1:].mean(), paper.nees[:, 1:].mean()
    print(f"TC-2 mean NEES over the run: model {avg_model:.2f}, paper {avg_paper:.2f}, band [{lo:.2f}, {hi:.2f}]")
    assert lo < avg_model < hi
    # the paper's setup is conservative in mid-run: its Q_mu has no counterpart in a constant true misalignment, so
    # the filter over-states the cross-track velocity (extraction §8.3: NEES 7.0 at 328 s)
    assert avg_paper < lo
    er, sr = radial_intrack_crosstrack(paper)
    k = at(paper, 328.0)
    assert np.var(er[:, k, 5], ddof=1) / np.mean(sr[:, k, 5] ** 2) < 0.6
    erm, srm = radial_intrack_crosstrack(model)
    assert np.var(erm[:, k, 5], ddof=1) / np.mean(srm[:, k, 5] ** 2) > 0.7


def test_sample_means():
    """Sample means within 3 sigma / sqrt(N) of zero per axis, except the unobservable boresight axis whose mean
    is the mean of the initial draws and persists (extraction §8.3)."""
    for name in ("tc2", "tc1"):
        res = campaign(name)
        s, _, m = final(res)
        z = m / (s / math.sqrt(N))
        print(name, "final mean / standard error", z.round(2))
        assert np.all(np.abs(z[:8]) < 3.0)
        assert m[8] == pytest.approx(np.mean(res.error[:, 0, 8]), abs=0.1 * s[8] / math.sqrt(N))


def test_tc1_final_sigma_and_consistency_with_underweighting():
    """T13: 1-sigma at 10 min about 20 m (x) and 740 m (y); sample ~ predicted (the paper's by-eye criterion)."""
    s, p, _ = final(campaign("tc1"))
    print(f"TC-1 final sigma x/y/z sample {s[:3].round(1)} predicted {p[:3].round(1)} m")
    assert p[1] == pytest.approx(740.0, rel=0.15) and s[1] == pytest.approx(740.0, rel=0.15)
    assert 7.0 < p[0] < 60.0  # "roughly 20 m"; the x axis depends on D and geometry (G8, G20)
    assert np.all((s / p > 0.6) & (s / p < 1.4))
    for name in ("tc1_model",):  # with the full F and the model's truth every axis matches within sampling error
        for t in (164.0, 328.0, 598.6):
            s, p, _ = final(campaign(name), at(campaign(name), t))
            assert np.all((s / p > 0.75) & (s / p < 1.3)), (t, (s / p).round(2))


def test_t18_underweighting_is_needed_in_tc1():
    uw, raw = campaign("tc1"), campaign("tc1_no_uw")
    _, hi3 = chi2_band(3 * N, N)
    s_uw, p_uw, _ = final(uw)
    s_raw, p_raw, _ = final(raw)
    s_0, _, _ = final(raw, 0)
    mu_uw, mu_raw = uw.nees_blocks[:, -1, 2].mean(), raw.nees_blocks[:, -1, 2].mean()
    print(f"TC-1 mu_z sigma: no UW sample {s_raw[8] / DEG:.4f} predicted {p_raw[8] / DEG:.4f} deg; "
          f"UW sample {s_uw[8] / DEG:.4f} predicted {p_uw[8] / DEG:.4f}; mu-block NEES no UW {mu_raw:.2f}, UW "
          f"{mu_uw:.2f} (band upper {hi3:.2f})")
    # without underweighting: predicted boresight sigma shrinks, sample sigma grows, the block NEES leaves its band
    assert p_raw[8] < 0.95 * 0.1 * DEG
    assert s_raw[8] > s_0[8] and s_raw[8] > 1.15 * p_raw[8]
    assert mu_raw > hi3
    # with underweighting the boresight sigma is kept and the block NEES is lower
    assert p_uw[8] >= 0.995 * 0.1 * DEG and mu_uw < mu_raw
    assert raw.nees[:, -1].mean() > uw.nees[:, -1].mean()


def test_scenarios_run_the_campaigns_asserted_above():
    """spacecraft-tc1/tc2 (sarnav run) are the campaigns of this file: same seeds (SeedSequence(20220901).spawn(100)),
    same parameters, bit-identical records; so every claim above holds for ``sarnav run spacecraft-tc1/tc2``."""
    from sarnav.montecarlo.seeding import run_seeds
    from sarnav.scenarios.registry import get_kind, get_scenario

    for name, case in (("spacecraft-tc2", "tc2"), ("spacecraft-tc1", "tc1")):
        cfg = get_scenario(name)
        seeds = run_seeds(cfg["campaign"]["seed"], cfg["campaign"]["runs"])
        recs = get_kind("spacecraft").simulate(cfg, list(range(N)), seeds)
        lib = campaign(case)
        assert np.array_equal(np.stack([r.error for r in recs]), lib.error)
        assert np.array_equal(np.stack([r.sigma for r in recs]), lib.sigma)

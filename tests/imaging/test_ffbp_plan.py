"""FFBP's plan (``sarnav.imaging.ffbp_plan``): the cost model chooses the subaperture length and the merges; the error
model counts the interpolation stages; bad options are named."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.imaging.ffbp_plan import (BASE_CHOICES, ERROR_KERNELS, FFBP_KERNELS, OVERSAMPLE_CHOICES, TABLE_STEPS,
                                     child_margin, ffbp_error_model, ffbp_plan, merge_cost, plan_cost, plan_for_error,
                                     polar_margins,
                                     stage_error, table_error, track_error)
from sarnav.imaging.interpolation_error import interpolation_error_2d


def test_the_plan_is_the_least_cost_pair_of_base_and_levels():
    """Without base_pulses the plan is the (base, levels) of least cost over BASE_CHOICES x every number of merges
    that fits; a given base or number of levels is kept."""
    calls = []

    def cost(base, levels):                       # any function: the plan must take its minimum
        calls.append((base, levels))
        return (math.log2(base) - 5) ** 2 + (levels - 2) ** 2

    plan = ffbp_plan(2048, bandwidth=1e8, cost=cost)
    assert (plan.base_pulses, plan.levels) == (32, 2) and plan.final_pulses == 512
    assert {b for b, _ in calls} == set(BASE_CHOICES)
    assert all(b * 4 ** lev <= 2048 for b, lev in calls)            # only factorisations that fit
    assert (64, 2) in calls and (64, 3) not in calls                  # 64 x 4^3 = 4096 > 2048 pulses
    assert (ffbp_plan(2048, bandwidth=1e8, cost=cost, base_pulses=16).base_pulses,
            ffbp_plan(2048, bandwidth=1e8, cost=cost, base_pulses=16).levels) == (16, 2)
    assert ffbp_plan(2048, bandwidth=1e8, cost=cost, levels=1).levels == 1
    # without a cost model: 16 pulses and as many merges as fit (the former default)
    plan = ffbp_plan(2048, bandwidth=1e8)
    assert (plan.base_pulses, plan.levels) == (16, 3)


def test_plan_cost_counts_the_level0_points_merges_and_final_evaluations():
    """plan_cost against its terms written out: level 0 P x n_r x n_u(base); each merge (P / size) x n_r x n_u(size) x
    merge evaluations; the final (P / final) x pixels evaluations, each evaluation (1 + taps^2 / 4) units."""
    p, npx = 1024, 256 * 256
    pos = np.zeros((p, 3))
    pos[:, 0] = np.arange(p) * 0.1
    pos[:, 2] = 1000.0
    v = np.array([1.0, 0.0, 0.0])
    hull = np.array([[20.0, 3000.0, 0.0], [80.0, 3000.0, 0.0], [20.0, 3100.0, 0.0], [80.0, 3100.0, 0.0]])
    bw, os_, lam_eff = 1e8, 2.0, 0.03
    cost = plan_cost(p, npx, pos, v, hull, bw, os_, 0.1, lam_eff, 4, 6)
    c = pos.mean(axis=0)
    r = np.linalg.norm(hull - c, axis=1)
    u = (hull - c) @ v / r
    n_r = np.ptp(r) * 2 * bw * os_ / 299792458.0 + 8
    n_u = lambda n: np.ptp(u) * 2 * n * 0.1 * os_ / lam_eff + 8     # noqa: E731
    ev = 1 + 36 / 4
    want = p * n_r * n_u(32) + ev * (p / 128) * n_r * n_u(128) * 4 + ev * npx * (p // 128)
    assert cost(32, 1) == pytest.approx(want, rel=1e-12)
    # two-pass merges (ffbp_merge): 3 + N (1 + 1 / merge) / 4 units a merge point; level 0 and the final unchanged
    two = plan_cost(p, npx, pos, v, hull, bw, os_, 0.1, lam_eff, 4, 6, two_pass=True)
    assert merge_cost(6, 4, True) == 3 + 6 * 1.25 / 4 and merge_cost(6, 4, False) == ev
    assert two(32, 1) == pytest.approx(want - (ev - merge_cost(6, 4, True)) * (p / 128) * n_r * n_u(128) * 4, rel=1e-12)


def test_error_model_counts_stages_and_bad_options_are_named():
    eps = stage_error("kaiser6", 2.0)
    assert eps == interpolation_error_2d("kaiser6", 2.0, 2.0) + 2 * table_error(2.0, TABLE_STEPS["kaiser6"])
    assert table_error(2.5, 2048) == pytest.approx(10 ** -7.98, rel=0.01)          # -79.8 dB a 1-D interpolation
    assert ffbp_error_model(2.0, 3) == pytest.approx(10 * math.log10(3 * eps))
    assert ffbp_error_model(2.0, 3, 1e-6) == pytest.approx(10 * math.log10(3 * eps + 1e-6))
    plan = ffbp_plan(1024, bandwidth=1e8, base_pulses=16, levels=2)
    assert plan.n_stages == 3 and plan.predicted_error_db == pytest.approx(10 * math.log10(3 * eps))
    for kw, key in ((dict(base_pulses=0), "^base_pulses"), (dict(merge=1), "^merge"), (dict(levels=-1), "^levels"),
                    (dict(oversample=1.2), "^oversample"), (dict(kernel="sinc"), "^kernel")):
        with pytest.raises(ConfigError, match=key):
            ffbp_plan(1024, bandwidth=1e8, **kw)


def test_a_target_error_gets_the_least_cost_plan_that_meets_it():
    """``plan_for_error`` against a brute-force search over the same grid: of every (os, base, levels) whose predicted
    error, the range share included, is within the target, the one of least cost (a toy cost rising with os and with
    the merges' count); a looser target never costs more; given base and levels are kept; an unreachable target and a
    bad one name ``error_db``."""
    def cost_at(os_, kernel):
        taps = FFBP_KERNELS[kernel]
        return lambda base, levels: (os_ ** 2 * (1.0 + 0.3 * levels * taps / 6) * (1.0 + abs(math.log2(base) - 5) / 4)
                                     * (1.0 + taps / 60) * 1e9)

    def brute(target, share, kernels, bases=BASE_CHOICES):
        ok = [(cost_at(o, k)(b, lev), o, b, lev, k) for k in kernels for o in OVERSAMPLE_CHOICES for b in bases
              for lev in range(6) if b * 4 ** lev <= 2048
              and 10 * math.log10((1 + share) * 10 ** (ffbp_error_model(o, lev + 1, kernel=k) / 10)) <= target]
        return min(ok)[1:]

    last = 0.0
    for target in (-40.0, -45.0, -50.0, -55.0, -60.0):
        got = plan_for_error(target, 2048, cost_at, base_pulses=None, merge=4, levels=None, kernel="kaiser6",
                             data_share=1 / 3)
        assert got == brute(target, 1 / 3, ["kaiser6"]), target
        cost = cost_at(got[0], got[3])(got[1], got[2])
        assert cost >= last
        last = cost
    # no kernel given: the cheapest of kaiser6, kaiser8 and kaiser10; below kaiser6's reach a longer kernel
    for target in (-50.0, -70.0, -90.0):
        got = plan_for_error(target, 2048, cost_at, base_pulses=None, merge=4, levels=None, kernel=None,
                             data_share=1 / 3)
        assert got == brute(target, 1 / 3, ERROR_KERNELS), target
        assert got[3] != "kaiser6" or target > -67
    os_, base, levels, kern = plan_for_error(-50.0, 2048, cost_at, base_pulses=16, merge=4, levels=1,
                                             kernel="kaiser6")
    assert kern == "kaiser6"
    assert (base, levels) == (16, 1) and 10 ** (ffbp_error_model(os_, 2) / 10) <= 1e-5
    with pytest.raises(ConfigError, match=r"^error_db: must be >= -6\d\.\d dB \(the least error a kaiser6 plan predicts"):
        plan_for_error(-90.0, 2048, cost_at, base_pulses=None, merge=4, levels=None, kernel="kaiser6")
    with pytest.raises(ConfigError, match=r"^error_db: must be >= -9\d\.\d dB \(the least error a kaiser6 / kaiser8 / kaiser10 plan"):
        plan_for_error(-200.0, 2048, cost_at, base_pulses=None, merge=4, levels=None, kernel=None)
    with pytest.raises(ConfigError, match=r"^error_db: must be a finite number of dB"):
        plan_for_error(float("nan"), 2048, cost_at, base_pulses=None, merge=4, levels=None, kernel="kaiser6")
    with pytest.raises(ConfigError, match=r"^merge"):
        plan_for_error(-50.0, 2048, cost_at, base_pulses=None, merge=1, levels=None, kernel="kaiser6")


def test_polar_margins_cover_every_tap_a_parent_margin_reads():
    """Range: the child has the parent's dr, so a level down needs the parent's margin plus the half-width h; angle:
    the parent's margin is ``merge`` times finer, so m_child >= ceil(m_parent / merge) + h; the final image keeps
    h + 1 (at least 4, kaiser6's and cubic's margin as before)."""
    for kernel, taps in FFBP_KERNELS.items():
        h = taps // 2
        for merge in (2, 4, 8):
            m = polar_margins(kernel, merge, 3)
            assert len(m) == 4 and m[-1] == (max(4, h + 1), max(4, h + 1))
            for (cr, cu), (pr, pu) in zip(m[:-1], m[1:]):          # child (one level down), parent
                assert cr == pr + h and cu == max(math.ceil(pu / merge) + h, 4) and cu >= pu
    assert polar_margins("kaiser6", 4, 2) == [(10, 4), (7, 4), (4, 4)]
    # an uneven split: a child of 32 of its parent's 33 pulses has angle samples 32/33 of the parent's
    assert child_margin((6, 6), 33, 32, 5) == (11, 11) and child_margin((6, 6), 33, 1, 5) == (11, 6)
    assert child_margin((6, 6), 128, 32, 5) == (11, 7)
    assert polar_margins("kaiser10", 4, 1) == [(11, 7), (6, 6)]


def test_a_track_off_its_line_gets_fewer_merges_and_the_unreachable_target_says_so():
    """``track(top_pulses)`` (the track's error for last-level subapertures of that many pulses, ``track_error``) adds to
    every plan's prediction: a track whose error grows with the top subaperture gets a plan with fewer merges than a
    straight one, every plan it is given predicts within the target with the track counted, and a target under the
    track's own error names the track."""
    def cost_at(os_, kernel):
        return lambda base, levels: os_ ** 2 * (1.0 + levels) * 1e9 / (1.0 + levels) ** 2   # merges pay

    def track(n):
        return 1e-9 * n ** 2                                                # -60 dB at 32 pulses, -48 dB at 128
    straight = plan_for_error(-58.0, 2048, cost_at, base_pulses=8, merge=4, levels=None, kernel="kaiser8")
    bent = plan_for_error(-58.0, 2048, cost_at, base_pulses=8, merge=4, levels=None, kernel="kaiser8", track=track)
    assert bent[2] < straight[2]
    os_, base, lev, kern = bent
    assert 10 * math.log10(10 ** (ffbp_error_model(os_, lev + 1, kernel=kern) / 10) + track(base * 4 ** lev)) <= -58
    plan = ffbp_plan(2048, bandwidth=1e8, base_pulses=8, levels=1, oversample=os_, kernel=kern, track=track)
    assert plan.track_error_db == pytest.approx(10 * math.log10(track(32)))
    assert plan.predicted_error_db == pytest.approx(
        10 * math.log10(10 ** (ffbp_error_model(os_, 2, kernel=kern) / 10) + track(32)))
    with pytest.raises(ConfigError, match=r"^error_db: must be >= -\d\d\.\d dB .* on this track\), got -90"):
        plan_for_error(-90.0, 2048, cost_at, base_pulses=8, merge=4, levels=None, kernel=None, track=track)


def test_track_error_is_the_same_in_chunks_of_pulses_as_in_one():
    """``track_error`` sums over pulses in chunks (bounded memory): on a 1300-pulse bent track the result equals the
    sum over one chunk (the chunk made larger than the track) to 1e-12, for tops shorter and longer than a chunk."""
    import sarnav.imaging.ffbp_plan as fp

    rng = np.random.default_rng(np.random.SeedSequence(2))
    pos = np.column_stack([np.linspace(-300, 300, 1300), 0.02 * rng.standard_normal(1300), np.full(1300, -2500.0)])
    sample = np.column_stack([rng.uniform(-40, 40, 50), 4330 + rng.uniform(-40, 40, 50), np.zeros(50)])
    v, centre = np.array([1.0, 0.0, 0.0]), np.array([0.0, 4330.0, 0.0])
    chunked = [track_error(pos, sample, v, centre, 0.03, n) for n in (100, 1300)]
    saved = fp._TRACK_CHUNK
    try:
        fp._TRACK_CHUNK = 10**6
        whole = [track_error(pos, sample, v, centre, 0.03, n) for n in (100, 1300)]
    finally:
        fp._TRACK_CHUNK = saved
    assert chunked == pytest.approx(whole, rel=1e-12) and all(e > 0 for e in whole)

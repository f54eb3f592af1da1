"""``simulation.gpsd_search``: the Alg. 3.3 velocity-offset sweep on a tiny problem (800 pulses, 16 x 16 images):
the rows it yields per configuration (counted from the documented sweep), the L = 1 control, the summary recomputed
from the rows, the progress callback, the order of the configurations and Fig. 4.25's noise drifts."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from sarnav.errors import ConfigError
from sarnav.measurements import focus_search as fs
from sarnav.scenarios import gpsd_search as scenario
from sarnav.simulation import gpsd_search as gs


@pytest.fixture(scope="module")
def tiny():
    """(params, result, progress calls) of a 4-realisation sweep: S_i = 200, L = 3, 2 sigmas x 2 spacings,
    methods source + grid, every control."""
    cfg = scenario.default_config()
    cfg["campaign"]["runs"] = 4
    cfg["aperture"]["n_pulses"] = 800
    cfg["scene"]["extent"] = 12.0
    cfg["image"]["size"] = 16
    cfg["search"].update(initial_pulses=200, block_pulses=[200], candidates=[3], sigmas=2, spacings=2,
                         method=["source", "grid"], controls=["one", "oracle", "random"])
    prm = scenario.parse(cfg)
    calls = []
    res = gs.run(prm, progress=lambda n, s: calls.append((n, s)))
    return prm, res, calls


def test_rows_follow_the_documented_sweep(tiny):
    """Per realisation and sigma: one L = 1 row, one row per spacing for each scorer of the thesis' grid (source,
    oracle, random) and one row per spanning search (grid): runs x sigmas x (3 spacings + 2) rows, with exactly the
    ROW_COLUMNS + DIAGNOSTIC_COLUMNS."""
    prm, res, _ = tiny
    assert len(res.rows) == prm.runs * prm.sigmas * (3 * prm.spacings + 2)
    assert all(set(r) == set(fs.ROW_COLUMNS + fs.DIAGNOSTIC_COLUMNS) for r in res.rows)
    methods = {r["method"] for r in res.rows}
    assert methods == {"source", "source-oracle", "source-random", "grid"}
    assert {r["realisation"] for r in res.rows} == set(range(prm.runs))
    np.testing.assert_allclose(sorted({r["sigma"] for r in res.rows}), fs.table41_sigmas(prm.sigmas))
    assert not any(r["error"] for r in res.rows)


def test_single_candidate_control_has_rho_exactly_one(tiny):
    """The "one" control (L = 1): the only candidate is the nominal offset, so rho = 1 exactly."""
    _, res, _ = tiny
    one = [r for r in res.rows if r["candidates"] == 1]
    assert len(one) == 4 * 2 and all(r["rho"] == 1.0 for r in one)


def test_oracle_never_worsens_the_variance(tiny):
    """The oracle scorer picks the candidate closest to the truth: rho <= 1 on every row (it may keep the nominal)."""
    _, res, _ = tiny
    rho = [r["rho"] for r in res.rows if r["method"] == "source-oracle"]
    assert rho and max(rho) <= 1.0 + 1e-12


def test_summary_is_recomputed_from_the_rows(tiny):
    """summary: the source's numbers, the row count, no failed run, per-sigma means of rho per method and the largest
    finite reach bound of the thesis' search, recomputed here from the rows."""
    prm, res, _ = tiny
    s = res.summary
    assert s["source"] == gs.SOURCE_RHO and s["rows"] == len(res.rows) and s["failed_runs"] == []
    assert s["seconds"] > 0 and list(s["configurations"]) == ["S_i=200,L=3"]
    conf = s["configurations"]["S_i=200,L=3"]
    sig = sorted({r["sigma"] for r in res.rows})
    for m in ("source", "source-oracle", "source-random", "grid"):
        want = [np.mean([r["rho"] for r in res.rows if r["method"] == m and r["sigma"] == x and r["candidates"] == 3])
                for x in sig]
        np.testing.assert_allclose(conf["per_sigma_mean"][m], want, rtol=1e-12)
    reach = max(r["reach"] for r in res.rows if r["method"] == "source" and math.isfinite(r["reach"]))
    assert conf["source_reach_max"] == reach
    assert all("rho" not in v for v in conf.values() if isinstance(v, dict))  # the per-row lists are dropped


def test_progress_is_called_every_fifty_rows(tiny):
    """64 rows: one progress call, at 50 rows, with a positive elapsed time."""
    _, res, calls = tiny
    assert len(res.rows) // 50 == len(calls) == 1 and calls[0][0] == 50 and calls[0][1] > 0


def test_search_rows_equal_the_rows_of_run(tiny):
    """search_rows on the same search problem yields the rows run returned (the sweep is deterministic)."""
    from sarnav.simulation.quality_scene import make_scene

    prm, res, _ = tiny
    prm1 = dataclasses.replace(prm, runs=1)
    scene, rng, snr = make_scene(prm.scene, prm.geometry)
    problem = fs.search_problem(prm.geometry, scene, prm.size, prm.initial_pulses, prm.measure, snr, rng)
    rows = list(gs.search_rows(prm1, problem))
    first = [r for r in res.rows if r["realisation"] == 0]
    assert len(rows) == len(first)
    for a, b in zip(rows, first):
        assert a["method"] == b["method"] and a["sigma"] == b["sigma"] and a["spacing"] == b["spacing"]
        np.testing.assert_allclose(a["rho"], b["rho"], rtol=1e-12)


def test_configurations_run_per_block_length_then_candidates(tiny):
    """configurations: for each S_i in order, each L in order."""
    prm = dataclasses.replace(tiny[0], block_pulses=(100, 200), candidates=(3, 11))
    assert prm.configurations == ((100, 3), (100, 11), (200, 3), (200, 11))


def test_noise_drifts_use_table41s_fourth_sigma_and_three_realisations(tiny):
    """With Table 4.1's 10 sigmas (linspace(8.1641e-6, 8.1641e-5, 10)) the drift is the fourth, 3.266e-5, for
    realisations 0-2 only; each drift is (P,) and equals focus_search.noise_drift of that realisation."""
    prm = dataclasses.replace(tiny[0], sigmas=10, runs=5)
    sigma, drifts = prm.noise_drifts()
    assert sigma == pytest.approx(8.1641e-6 + 3 * (8.1641e-5 - 8.1641e-6) / 9, rel=1e-12)
    assert sigma == pytest.approx(3.266e-5, rel=1e-3)
    assert sorted(drifts) == [0, 1, 2]
    assert all(d.shape == (prm.geometry.n_pulses,) for d in drifts.values())
    np.testing.assert_array_equal(drifts[1], fs.noise_drift(prm.seed, 1, 3, 10, prm.geometry.n_pulses,
                                                            prm.initial_pulses, prm.bias, sigma))
    assert not np.allclose(drifts[0], drifts[1])  # independent noise per realisation
    few = dataclasses.replace(tiny[0], sigmas=2, runs=1)
    s2, d2 = few.noise_drifts()
    assert s2 == fs.table41_sigmas(2)[1] and sorted(d2) == [0]


def test_vocabularies():
    """The methods and controls the module documents."""
    assert gs.SEARCH_METHODS == ("source", "source-carry", "grid", "brent", "viterbi")
    assert gs.SEARCH_CONTROLS == ("one", "oracle", "random", "anti-oracle", "oracle-carry", "anti-oracle-carry")


def test_image_runs_count_a_viterbi_run_by_its_trellis(tiny):
    """The work bound of the scenario: each thesis-grid scorer that forms images counts once per spacing, a spanning
    search once, a Viterbi run (L // 2)(n_blocks - 1) + 1 times (here 800 pulses, S_0 = S_i = 200: 3 blocks, L = 3:
    3 greedy runs' work); the bound refuses what it counts."""
    prm, _, _ = tiny
    assert prm.image_runs() == prm.runs * prm.sigmas * (prm.spacings * 1 + 1)      # source + grid
    vit = dataclasses.replace(prm, methods=("viterbi",))
    assert vit.image_runs() == prm.runs * prm.sigmas * (1 * (3 - 1) + 1)
    cfg = scenario.default_config()
    cfg["search"].update(method=["viterbi"], candidates=[199], sigmas=10)
    cfg["campaign"]["runs"] = 40
    with pytest.raises(ConfigError, match="campaign.runs"):
        scenario.parse(cfg)

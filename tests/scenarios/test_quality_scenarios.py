"""Scenarios ``quality-sweep``, ``gpsd-search`` and ``gpsd-search-table41`` (Hathaway 2023; docs/quality.md).

Fast: tiny versions through ``sarnav run`` (files, columns, labels, the L = 1 and oracle controls, claims.json),
``sarnav show`` round trips, named errors. Slow (``python -m pytest -q -m slow -s tests/scenarios/test_quality_scenarios.py``):
``sarnav run gpsd-search`` (the reduced Table 4.1 sweep: 2 min wall, 83 s CPU on 2 shared cores) and ``sarnav run
quality-sweep`` (Figs. 4.1-4.8 and T16: 3.5 min), their claims asserted from the files they write.
"""

import csv
import json
import math

import numpy as np
import pytest
import xarray as xr

from sarnav.cli.main import main
from sarnav.errors import ConfigError
from sarnav.measurements import focus_search as fs
from sarnav.scenarios import gpsd_search, quality_sweep
from sarnav.scenarios.config import load_scenario
from sarnav.scenarios.registry import get_scenario

TINY_SEARCH = ["--set", "aperture.n_pulses=1600", "--set", "scene.extent=12.0", "--set", "image.size=40",
               "--set", "search.initial_pulses=400", "--set", "search.block_pulses=[400]", "--set", "search.sigmas=2",
               "--set", "search.spacings=2", "--set", 'search.method=["source","source-carry","grid","brent","viterbi"]']
TINY_SWEEP = ["--set", "aperture.n_pulses=1200", "--set", "sweep.sizes=[16,32]", "--set", "sweep.steps=3",
              "--set", "sweep.figure_size=32", "--set", "reliability.scenes=2", "--set", "reliability.size=16"]


def _rows(path):
    with open(path, newline="") as fh:
        return [{k: (v if k in ("method", "scorer", "error") else float(v) if v else math.nan) for k, v in r.items()}
                for r in csv.DictReader(fh)]


@pytest.fixture(scope="module")
def tiny_search(tmp_path_factory):
    out = tmp_path_factory.mktemp("gs")
    assert main(["run", "gpsd-search", "--out", str(out), "--quiet", *TINY_SEARCH]) == 0
    return out


def test_search_writes_rho_csv_with_exactly_the_issue_columns(tiny_search):
    with open(tiny_search / "rho.csv", newline="") as fh:
        header = next(csv.reader(fh))
    assert header == ["method", "block_pulses", "candidates", "sigma", "spacing", "realisation", "rho"]
    rows = _rows(tiny_search / "rho.csv")
    assert {r["method"] for r in rows} == {"source", "source-carry", "source-oracle", "source-random", "grid", "brent",
                                           "viterbi"}
    one = [r for r in rows if r["candidates"] == 1]
    assert len(one) == 2 and all(r["rho"] == 1.0 and r["method"] == "source" for r in one)   # L = 1: exactly 1
    assert all(r["rho"] < 1.0 for r in rows if r["method"] == "source-oracle")                  # oracle improves
    assert not (tiny_search / "INCOMPLETE").exists() and not (tiny_search / "rho.csv.partial").exists()
    for name in ("whiskers_Si400_L11.png", "failure_analysis.png", "methods.png"):
        assert (tiny_search / "figures" / name).stat().st_size > 5000


def test_search_rows_respect_the_reach_bound_and_the_summary_says_so(tiny_search):
    diag = _rows(tiny_search / "rho_diagnostics.csv")
    for r in diag:
        b = r["reach"]
        assert (max(1 - b, 0.0) ** 2) * (1 - 1e-9) <= r["rho"] <= (1 + b) ** 2 * (1 + 1e-9), r
    summary = json.loads((tiny_search / "search.json").read_text())
    conf = summary["configurations"]["S_i=400,L=11"]
    assert conf["source (L=1)"]["max_rho"] == 1.0 and conf["source-oracle"]["agreement"] == 1.0
    assert summary["source"]["min"] == 0.2735 and summary["source"]["max"] == 2.7707
    assert len(conf["per_sigma_mean"]["source"]) == 2


def test_sweep_writes_the_dataset_claims_and_figures(tmp_path):
    out = tmp_path / "qs"
    assert main(["run", "quality-sweep", "--out", str(out), "--quiet", *TINY_SWEEP]) == 0
    ds = xr.open_dataset(out / "sweep.nc")
    assert list(ds["direction"].values) == ["along", "cross"] and ds.sizes["step"] == 7
    assert ds["kurtosis"].dims == ("direction", "size", "step")
    assert ds["entropy_magnitude"].dims == ("direction", "size", "bins", "step")
    np.testing.assert_allclose(ds["error"].sel(direction="along", step=0), 0.0, atol=1e-15)
    claims = json.loads((out / "claims.json").read_text())
    for key in ("T3", "T7", "T8", "T9", "T10", "T11", "T12", "T13", "T14", "T15", "T16", "T17"):
        assert key in claims and key in claims["source"], key
    assert claims["T16"]["scenes"] == 2
    assert claims["T16"]["conditions"] == {"scene": "point-clutter", "span_depths": 6.0, "clutter_density": 0.5,
                                           "step": pytest.approx(ds["error"].sel(direction="along").values[1]
                                                                 - ds["error"].sel(direction="along").values[0])}
    assert set(claims["T7"]["kurtosis_max_step"]) == {"16", "32"}
    names = {p.name for p in (out / "figures").iterdir()}
    assert {"fig4_1_images.png", "fig4_2_along_32.png", "fig4_3-4_6_sizes.png", "fig4_7_bins_along.png",
            "fig4_8_bins_cross.png", "t16_reliability.png"} <= names


@pytest.mark.parametrize("name", ["quality-sweep", "gpsd-search", "gpsd-search-table41", "quality-nav"])
def test_show_prints_a_file_that_runs_as_the_same_scenario(name, tmp_path, capsys):
    assert main(["show", name]) == 0
    text = capsys.readouterr().out
    f = tmp_path / f"{name}.toml"
    f.write_text(text)
    assert load_scenario(str(f)) == get_scenario(name)


@pytest.mark.parametrize("module,key,value,field", [
    (gpsd_search, "search.candidates", [0], "search.candidates[0]"),
    (gpsd_search, "search.block_pulses", [5000], "search.block_pulses[0]"),
    (gpsd_search, "search.method", ["annealing"], "search.method[0]"),
    (gpsd_search, "search.controls", ["truth"], "search.controls[0]"),
    (gpsd_search, "search.measure", "sharpness", "search.measure"),
    (gpsd_search, "search.initial_pulses", 4000, "search.initial_pulses"),
    (gpsd_search, "image.size", 1, "image.size"),
    (gpsd_search, "aperture.n_pulses", 10**6, "aperture.n_pulses"),
    (gpsd_search, "trajectory.start_ned", [0.0, 5.0, -1000.0], "trajectory.start_ned[1]"),
    (gpsd_search, "trajectory.start_ned", [0.0, 0.0, -5.0], "trajectory.start_ned[2]"),
    (gpsd_search, "trajectory.speed", 200.0, "trajectory.speed"),  # the source's PRF no longer covers the Doppler band
    (gpsd_search, "scene.extent", 900.0, "scene.ground_range"),
    (gpsd_search, "radar.preset", "nav-paper-sim", "radar.preset"),
    (gpsd_search, "radar.prf_hz", 1000.0, "radar.prf_hz"),  # the radar is the thesis' own
    (gpsd_search, "radar.snr_db", 200.0, "radar.snr_db"),
    (gpsd_search, "scene.type", "city", "scene.type"),
    (gpsd_search, "scene.clutter_density", 1e3, "scene.clutter_density"),
    (quality_sweep, "sweep.sizes", [1], "sweep.sizes[0]"),
    (quality_sweep, "sweep.bins", [1], "sweep.bins[0]"),
    (quality_sweep, "sweep.measures", ["sharpness"], "sweep.measures[0]"),
    (quality_sweep, "sweep.directions", ["up"], "sweep.directions[0]"),
    (quality_sweep, "sweep.pivot", "last", "sweep.pivot"),
    (quality_sweep, "sweep.sizes", list(range(400, 388, -1)), "sweep.sizes"),
    (quality_sweep, "reliability.scenes", 201, "reliability.scenes"),
    (quality_sweep, "reliability.scene", "sea-ice", "reliability.scene"),
    (quality_sweep, "reliability.contrast_db", -1.0, "reliability.contrast_db"),
    (quality_sweep, "reliability.correlation_m", 0.0, "reliability.correlation_m"),
    (quality_sweep, "reliability.span_depths", -0.5, "reliability.span_depths"),
])
def test_errors_name_the_key(module, key, value, field):
    """The field of the ConfigError of ``module.parse`` on its default configuration with ``key`` set to ``value``."""
    cfg = module.default_config()
    sec, k = key.split(".")
    cfg[sec][k] = value
    with pytest.raises(ConfigError) as err:
        module.parse(cfg)
    assert err.value.field == field


def test_reliability_reads_the_textured_scene_and_its_own_span():
    """[reliability] scene = "textured" draws textured clutter (no bright point) at texture_density; span_depths 0
    follows [sweep] span_depths, another value is the study's own (the zoomed-in view); the work bound names the
    density of the scene in use."""
    from sarnav.analysis.quality_sweep import reliability_scenes

    cfg = quality_sweep.default_config()
    assert quality_sweep.parse(cfg).reliability.span_depths is None
    cfg["reliability"].update(scene="textured", contrast_db=4.0, correlation_m=2.0, span_depths=1.2, scenes=2)
    prm = quality_sweep.parse(cfg)
    rel, geo = prm.reliability, prm.geometry
    assert (rel.scene, rel.contrast_db, rel.correlation_m, rel.span_depths) == ("textured", 4.0, 2.0, 1.2)
    scenes = reliability_scenes(rel, geo)
    expected = rel.texture_density * geo.scene_extent ** 2
    assert len(scenes) == 2 and all(abs(sc.amplitudes.size - expected) < 5 * math.sqrt(expected) for sc in scenes)
    points = reliability_scenes(quality_sweep.parse(quality_sweep.default_config()).reliability, geo)
    bright = lambda sc: int(np.sum(np.isclose(np.abs(sc.amplitudes) ** 2, 100.0)))  # noqa: E731 - points 20 dB up
    assert bright(points[0]) == 12 and all(bright(sc) == 0 for sc in scenes)
    cfg["reliability"]["texture_density"] = 500.0
    with pytest.raises(ConfigError, match=r"reliability.texture_density: .* scatterers x pulses; at most 1e\+08"):
        quality_sweep.parse(cfg)


def test_t20_the_thesis_range_needs_the_carry_reading_and_a_scorer_against_the_truth():
    """Hathaway T20 per reading (issue 29, docs/quality.md §5 "T20 per case and reading"): on Table 4.1's S_i = 100,
    L = 11 with its largest spacing, restarting each block keeps every scorer -- even the anti-oracle, which picks the
    candidate farthest from the truth -- inside [(1 - B)^2, (1 + B)^2], far from 0.2735 and 2.7707; keeping the chosen
    offsets, the oracle goes below 0.2735 and the anti-oracle above 2.7707 (the controls form no image: ~2 s)."""
    from sarnav.simulation.gpsd_search import run

    cfg = get_scenario("gpsd-search-table41")
    cfg["campaign"]["runs"] = 2
    cfg["search"].update({"method": [], "controls": ["oracle", "anti-oracle", "oracle-carry", "anti-oracle-carry"],
                          "block_pulses": [100], "candidates": [11], "spacings": 2})
    res = run(gpsd_search.parse(cfg))
    rows = [r for r in res.rows if math.isfinite(r["rho"])]
    assert len(rows) == 2 * 10 * 2 * 4

    def rho(label):
        return np.array([r["rho"] for r in rows if r["method"] == label])

    for r in rows:
        assert max(1 - r["reach"], 0) ** 2 * (1 - 1e-9) <= r["rho"] <= (1 + r["reach"]) ** 2 * (1 + 1e-9)
    restart = max(r["reach"] for r in rows if not r["method"].endswith("-carry"))
    assert (1 + restart) ** 2 < 2.7707 and (1 - restart) ** 2 > 0.2735  # out of reach of any scorer
    assert rho("source-anti-oracle").max() > 1.2 and rho("source-oracle").min() < 0.8
    assert rho("source-oracle-carry").min() < 0.2735 and rho("source-anti-oracle-carry").max() > 2.7707
    reach = res.summary["configurations"]["S_i=100,L=11"]["per_sigma_reach_max"]
    assert len(reach["restart"]) == len(reach["carry"]) == 10 and max(reach["carry"]) > 1.0 > max(reach["restart"])


# --- the scenarios as registered (slow) ---------------------------------------------------------------------------

@pytest.mark.slow
def test_gpsd_search_reduced_sweep_claims(tmp_path):
    """T20-T22 and the better searches on the thesis' geometry: ``sarnav run gpsd-search`` with the Viterbi search
    added (``--set 'search.method=["source", "grid", "brent", "viterbi"]'``; it takes ~26x a greedy run)."""
    out = tmp_path / "gpsd"
    assert main(["run", "gpsd-search", "--out", str(out), "--quiet",
                 "--set", 'search.method=["source", "grid", "brent", "viterbi"]']) == 0
    rows = [r for r in _rows(out / "rho_diagnostics.csv") if math.isfinite(r["rho"])]
    by = {m: np.array([r["rho"] for r in rows if r["method"] == m and r["candidates"] > 1])
          for m in {r["method"] for r in rows}}
    print({m: (v.min(), np.median(v), v.max()) for m, v in by.items()})
    assert all(r["rho"] == 1.0 for r in rows if r["candidates"] == 1)                     # L = 1
    assert np.all(by["source-oracle"] < 1.0)                                               # the oracle improves
    means = [np.mean([r["rho"] for r in rows if r["method"] == "source" and r["sigma"] == s and r["candidates"] > 1])
             for s in fs.table41_sigmas()]
    print("per-sigma mean rho of the thesis' search", np.round(means, 3))
    # per-sigma mean rho near 1 (the thesis's T20 range 0.27-2.77 is not reached: docs/claims.md)
    assert 0.8 <= min(means) and max(means) <= 1.2
    assert abs(np.mean(by["source-random"]) - 1.0) < 0.05
    # why the range is narrower than the thesis' [0.27, 2.77]: no correction the grid can make reaches it
    b = max(r["reach"] for r in rows if r["method"] == "source")
    print("largest reach bound B of the thesis' grid", b, "-> rho in", ((1 - b) ** 2, (1 + b) ** 2))
    assert (1 + b) ** 2 < 2.7707 and (1 - b) ** 2 > 0.2735
    for r in rows:
        assert (max(1 - r["reach"], 0) ** 2) * (1 - 1e-9) <= r["rho"] <= (1 + r["reach"]) ** 2 * (1 + 1e-9)
    print("improved searches: median rho grid", np.median(by["grid"]), "brent", np.median(by["brent"]),
          "viterbi", np.median(by["viterbi"]))
    assert np.median(by["grid"]) < 0.5 and np.median(by["brent"]) < 0.5
    # the Viterbi trellis (the thesis' future work) on the same grid and noise works too; on this scene it is not
    # better than the greedy grid (median 0.102 against 0.092), on three other scene draws and the library's it is
    # (docs/quality.md §6: 40 of 50 runs, pooled median 0.043 against 0.124)
    assert np.median(by["viterbi"]) < 0.5


@pytest.mark.slow
def test_quality_sweep_claims(tmp_path):
    """T7, T9-T17 from ``sarnav run quality-sweep`` (USU-like picture; T16 over 20 point/clutter scenes)."""
    out = tmp_path / "qs"
    assert main(["run", "quality-sweep", "--out", str(out), "--quiet"]) == 0
    c = json.loads((out / "claims.json").read_text())
    print(json.dumps({k: v for k, v in c.items() if k != "source"}, indent=1))
    assert all(abs(c["T7"]["kurtosis_max_step"][n]) <= 1 for n in ("50", "100", "200"))     # T7
    assert c["T9"]["monotone_steps"] >= 3                                                  # T9
    rough = c["T10"]["kurtosis_local_extrema"]
    assert rough["10"] >= max(rough["50"], rough["100"], rough["200"])                     # T10
    assert all(c["T13"]["trough_within_one_step"].values())                               # T11, T13
    # T15 (sum never better than magnitude) holds at N = 10 only: at N = 100 and 1000 the sum curve has fewer local
    # extrema and a deeper trough (docs/quality.md §3: not reproduced there)
    s10, m10 = c["T15"]["local_extrema_sum_magnitude"]["10"]
    assert s10 >= m10
    assert all(not v for v in c["T14"]["trough_at_zero"].values())                         # T14
    assert all(r == c["T14"]["errors"] - 1 for r in c["T14"]["rank_of_zero"].values())     # zero is the maximum
    assert all(r > 0.99 for n, r in c["T17"]["curve_correlation"].items() if n != "10")   # T17
    t16 = c["T16"]
    assert all(v == 1.0 for v in t16["within_one_step"].values())                          # T16 (our ordering)
    assert t16["exactly_at_zero"]["entropy_magnitude"] >= t16["exactly_at_zero"]["kurtosis"]

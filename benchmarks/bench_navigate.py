"""Benchmark: ``sarnav navigate`` on the 50-s rda-nav recording, against the campaign's cost of the same run.

Usage::

    python benchmarks/bench_navigate.py                    # rda-nav, 50 s, run 1 of seed 2022
    python benchmarks/bench_navigate.py --duration 20 --scenario terrain
    python benchmarks/bench_navigate.py --set sar.algorithm=bpa --set trajectory.type=turning

Times (wall clock, one process, after a 2-s warm-up that compiles the numba kernels):

* ``campaign``: one run of the campaign, ``RdaNavKind.simulate`` with one seed (what ``sarnav run rda-nav --runs 1``
  spends on its run: the world's echoes and noise, the images, the navigator);
* ``export``: ``sarnav export`` of that run (the same run flown with the exporter watching, plus the CPHD files);
* ``navigate``: ``sarnav navigate`` of the recording, as the command runs it: reading the recording, the settings,
  the navigator (its images from the CPHD pulses), every output file; and the part of it that is the navigation
  loop (``recording.navigate.navigate``) alone, and per update the stages: reading the CPHD apertures, imaging.

Prints the real-time factor (flight seconds / navigate's wall seconds; goal >= 10 on 2 cores, issue 26) and
navigate against the campaign's per-run cost; checks that navigate gives the campaign's run (final position within
1 mm of the campaign's estimate).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from sarnav.montecarlo.seeding import run_seeds
from sarnav.recording import read_recording
from sarnav.recording.navigate import navigate
from sarnav.report.navigate_files import run_navigate
from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.config import load_scenario
from sarnav.scenarios.navigate import read_navigate_settings
from sarnav.simulation.export import export_rda_nav
from sarnav.tomlio import dump_toml

SCENARIOS = {"paper": "rda-nav", "terrain": "rda-nav-terrain", "flexsar": "rda-nav-flexsar"}


def _cfg(scenario: str, duration: float, sets, runs: int) -> dict:
    return load_scenario(SCENARIOS[scenario], [f"trajectory.duration={duration}", *sets], runs=runs)


def _export(cfg, run, folder):
    seed = run_seeds(cfg["campaign"]["seed"], cfg["campaign"]["runs"])[run]
    t0 = time.perf_counter()
    done = export_rda_nav(rn.parse(cfg), folder, seed, run=run, runs=cfg["campaign"]["runs"],
                          campaign_seed=cfg["campaign"]["seed"], scenario_name=cfg["scenario"]["name"],
                          scenario_text=dump_toml(cfg))
    return time.perf_counter() - t0, done.record


def _navigate(folder, out):
    t0 = time.perf_counter()
    rec = read_recording(folder)
    doc = run_navigate(rec, out, read_navigate_settings(rec), overwrite=True)
    return time.perf_counter() - t0, doc


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", choices=tuple(SCENARIOS), default="paper")
    ap.add_argument("--duration", type=float, default=50.0)
    ap.add_argument("--run", type=int, default=1)
    ap.add_argument("--runs", type=int, default=200, help="the campaign's runs (its seeds)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        warm = _cfg(args.scenario, 2.0, args.sets, args.runs)  # numba compilation, imports
        _export(warm, args.run, tmp / "warm")
        _navigate(tmp / "warm", tmp / "warm-out")

        cfg = _cfg(args.scenario, args.duration, args.sets, args.runs)
        seed = run_seeds(cfg["campaign"]["seed"], args.runs)[args.run]
        t0 = time.perf_counter()
        campaign = rn.RdaNavKind().simulate(cfg, [args.run], [seed])[0]
        t_campaign = time.perf_counter() - t0
        t_export, record = _export(cfg, args.run, tmp / "rec")
        t_nav, doc = _navigate(tmp / "rec", tmp / "out")
        rec = read_recording(tmp / "rec")
        t0 = time.perf_counter()
        nav = navigate(rec, read_navigate_settings(rec))
        t_loop = time.perf_counter() - t0
        size = sum(f.stat().st_size for f in (tmp / "rec").rglob("*") if f.is_file())

    flight = doc["flight_seconds"]
    est = nav.estimate()
    truth_p = rec.truth.position[-1]
    dp = np.abs(est["p"][-1] - (truth_p - campaign.error[-1, 0:3])).max()
    print(f"{' '.join([SCENARIOS[args.scenario], *args.sets])}: run {args.run}, {flight:.0f} s of flight, "
          f"{doc['updates']} updates, {doc['pairs_fused']} pairs fused (recording {size / 1e6:.1f} MB)")
    print(f"  campaign, one run       {t_campaign:8.2f} s")
    print(f"  export                  {t_export:8.2f} s")
    print(f"  navigate (command)      {t_nav:8.2f} s   real-time factor {flight / t_nav:6.2f}   "
          f"navigate / campaign run {t_nav / t_campaign:5.2f}")
    print(f"  navigate (loop only)    {t_loop:8.2f} s   real-time factor {flight / t_loop:6.2f}   "
          f"{t_loop / max(doc['updates'], 1) * 1e3:7.1f} ms per update")
    stages = {k: np.mean([u["seconds"][k] for u in nav.updates]) for k in nav.updates[0]["seconds"]}
    stages["read"] = stages["images"] - stages["rda"] - stages["autofocus"] - stages["registration"]
    names = {"propagate": "INS + covariance", "images": "images (the extractor), of which",
             "read": "  CPHD read, reference chip, its noise model", "rda": "  in-flight image",
             "autofocus": "  mapdrift, focus sensitivity", "registration": "  registration",
             "update": "prediction, gate, update"}
    for k in ("propagate", "images", "read", "rda", "autofocus", "registration", "update"):
        v = stages[k]
        print(f"    {names.get(k, k):48s} {v * 1e3:7.1f} ms per update")
    print(f"  final position: navigate - campaign = {dp:.2e} m; same record as export's: "
          f"{np.array_equal(campaign.error, record.error)}")
    print(f"  goal: >= 10x real time; {'met' if flight / t_nav >= 10 else 'not met'}")


if __name__ == "__main__":
    main()

"""Benchmark: ``sarnav navigate`` on the 50-s rda-nav recording, against the campaign's cost of the same run.

Usage::

    python benchmarks/bench_navigate.py                    # rda-nav, 50 s, run 1 of seed 2022
    python benchmarks/bench_navigate.py --duration 20 --scenario terrain
    python benchmarks/bench_navigate.py --set sar.algorithm=bpa --set trajectory.type=turning
    python benchmarks/bench_navigate.py --baseline /tmp/base/src   # also time another tree's navigate, same run

Times (wall clock, one process, after a 2-s warm-up that compiles the numba kernels):

* ``campaign``: one run of the campaign, ``RdaNavKind.simulate`` with one seed (what ``sarnav run rda-nav --runs 1``
  spends on its run: the world's echoes and noise, the images, the navigator);
* ``export``: ``sarnav export`` of that run (the same run flown with the exporter watching, plus the CPHD files);
* ``navigate``: ``sarnav navigate`` of the recording, as the command runs it: reading the recording, the settings,
  the navigator (its images from the CPHD pulses), every output file; and the part of it that is the navigation
  loop (``recording.navigate.navigate``) alone, with its CPU seconds (all threads) beside the wall seconds (the
  machine may be shared);
* per update, the stages, from the loop run once more without reading ahead (``RecordedApertures.read_ahead``
  off: every stage on one thread, so the wall seconds split): reading the CPHD apertures with the reference chips
  and their noise model, the in-flight image, mapdrift, registration; the INS, the update;
* with ``--baseline SRC``: the loop and the command of the tree whose ``src`` folder is SRC (e.g. the commit before
  a speed change, ``git archive``), on the same recording in a subprocess, right after this tree's.

Prints the real-time factor (flight seconds / navigate's wall seconds; goal >= 10 on 2 cores, issue 26), navigate
against the campaign's per-run cost and the load average at the start and the end; checks that navigate gives the
campaign's run (final position within 1 mm of the campaign's estimate), that the loop without reading ahead gives
the same numbers bit for bit, and with ``--baseline`` how far the other tree's final estimate and 1-sigma are.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sarnav.montecarlo.seeding import run_seeds
from sarnav.recording import read_recording
from sarnav.recording.apertures import RecordedApertures
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


def _loop(folder, read_ahead: bool = True):
    """(wall s, CPU s of all threads, the Navigation) of the navigation loop alone; without reading ahead:
    ``RecordedApertures.read_ahead`` = 0 for the call (its own depth, 2, otherwise)."""
    depth = RecordedApertures.read_ahead
    RecordedApertures.read_ahead = depth if read_ahead else 0
    try:
        rec = read_recording(folder)
        settings = read_navigate_settings(rec)
        t0, c0 = time.perf_counter(), time.process_time()
        nav = navigate(rec, settings)
        return time.perf_counter() - t0, time.process_time() - c0, nav
    finally:
        RecordedApertures.read_ahead = depth


#: run by ``--baseline`` in a subprocess with the other tree's src first on the path: its loop and command times
BASELINE = """
import json, sys, time
import numpy as np
from sarnav.recording import read_recording
from sarnav.recording.navigate import navigate
from sarnav.report.navigate_files import run_navigate
from sarnav.scenarios.navigate import read_navigate_settings
rec = read_recording(sys.argv[1])
warm = read_recording(sys.argv[3])
run_navigate(warm, sys.argv[2], read_navigate_settings(warm), overwrite=True)  # warm-up: numba, imports
t0, c0 = time.perf_counter(), time.process_time()
nav = navigate(rec, read_navigate_settings(rec))
loop, cpu = time.perf_counter() - t0, time.process_time() - c0
t0 = time.perf_counter()
run_navigate(read_recording(sys.argv[1]), sys.argv[2], read_navigate_settings(rec), overwrite=True)
est = nav.estimate()
print(json.dumps({"loop": loop, "cpu": cpu, "command": time.perf_counter() - t0,
                  "p": est["p"][-1].tolist(), "sigma": est["sigma"][-1].tolist(), "stages": {
                      k: float(np.mean([u["seconds"][k] for u in nav.updates])) for k in nav.updates[0]["seconds"]}}))
"""


def _baseline(src, folder, out, warm):
    env = dict(os.environ, PYTHONPATH=str(Path(src).resolve()))
    done = subprocess.run([sys.executable, "-c", BASELINE, str(folder), str(out), str(warm)], env=env,
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _stages(nav) -> dict:
    """Mean seconds per update of each stage; ``read`` the images' remainder (CPHD, reference chips, noise model)."""
    stages = {k: float(np.mean([u["seconds"][k] for u in nav.updates])) for k in nav.updates[0]["seconds"]}
    stages["read"] = stages["images"] - stages["rda"] - stages["autofocus"] - stages["registration"]
    return stages


NAMES = {"propagate": "INS + covariance", "images": "images (the extractor), of which",
         "read": "  CPHD read, reference chip, its noise model", "rda": "  in-flight image",
         "autofocus": "  mapdrift, focus sensitivity", "registration": "  registration",
         "update": "prediction, gate, update"}


def _same_bits(a, b) -> bool:
    ea, eb = a.estimate(), b.estimate()
    return all(np.array_equal(ea[k], eb[k]) for k in ea) and all(
        np.array_equal(np.asarray(u[k]), np.asarray(v[k])) for u, v in zip(a.updates, b.updates) for k in u
        if k != "seconds")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", choices=tuple(SCENARIOS), default="paper")
    ap.add_argument("--duration", type=float, default=50.0)
    ap.add_argument("--run", type=int, default=1)
    ap.add_argument("--runs", type=int, default=200, help="the campaign's runs (its seeds)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--baseline", metavar="SRC", help="another tree's src folder to time on the same recording")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()

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
        getattr(os, "sync", lambda: None)()  # (POSIX) the export's ~0.5 GB written out before navigate is timed (not its disk writeback)
        t_nav, doc = _navigate(tmp / "rec", tmp / "out")
        t_loop, c_loop, nav = _loop(tmp / "rec")
        t_serial, c_serial, serial = _loop(tmp / "rec", read_ahead=False)
        base = None if args.baseline is None else _baseline(args.baseline, tmp / "rec", tmp / "base-out", tmp / "warm")
        rec = read_recording(tmp / "rec")
        size = sum(f.stat().st_size for f in (tmp / "rec").rglob("*") if f.is_file())
    _print(args, doc, nav, serial, base, campaign, record, rec, size, load0,
           dict(campaign=t_campaign, export=t_export, nav=t_nav, loop=t_loop, cpu=c_loop, serial=t_serial,
                serial_cpu=c_serial))


def _print(args, doc, nav, serial, base, campaign, record, rec, size, load0, t) -> None:
    flight, n_up = doc["flight_seconds"], max(doc["updates"], 1)
    est = nav.estimate()
    dp = np.abs(est["p"][-1] - (rec.truth.position[-1] - campaign.error[-1, 0:3])).max()
    print(f"{' '.join([SCENARIOS[args.scenario], *args.sets])}: run {args.run}, {flight:.0f} s of flight, "
          f"{doc['updates']} updates, {doc['pairs_fused']} pairs fused (recording {size / 1e6:.1f} MB); "
          f"load average {load0[0]:.1f} at the start, {os.getloadavg()[0]:.1f} at the end ({os.cpu_count()} cores)")
    print(f"  campaign, one run       {t['campaign']:8.2f} s")
    print(f"  export                  {t['export']:8.2f} s")
    print(f"  navigate (command)      {t['nav']:8.2f} s   real-time factor {flight / t['nav']:6.2f}   "
          f"navigate / campaign run {t['nav'] / t['campaign']:5.2f}")
    print(f"  navigate (loop only)    {t['loop']:8.2f} s   real-time factor {flight / t['loop']:6.2f}   "
          f"{t['loop'] / n_up * 1e3:7.1f} ms per update; CPU {t['cpu']:.2f} s")
    print(f"  loop, no read-ahead     {t['serial']:8.2f} s   real-time factor {flight / t['serial']:6.2f}   "
          f"{t['serial'] / n_up * 1e3:7.1f} ms per update; CPU {t['serial_cpu']:.2f} s; per update:")
    stages = _stages(serial)
    base_stages = None
    if base is not None:
        base_stages = dict(base["stages"])
        base_stages["read"] = (base_stages["images"] - base_stages["rda"] - base_stages["autofocus"]
                               - base_stages["registration"])
    for k in ("propagate", "images", "read", "rda", "autofocus", "registration", "update"):
        line = f"    {NAMES.get(k, k):48s} {stages[k] * 1e3:7.1f} ms"
        if base_stages is not None:
            line += f"   baseline {base_stages[k] * 1e3:7.1f} ms"
        print(line)
    if base is not None:
        dp_base = np.abs(np.asarray(base["p"]) - est["p"][-1]).max()
        ds_base = np.abs(np.asarray(base["sigma"]) / est["sigma"][-1] - 1.0).max()
        print(f"  baseline {args.baseline}: loop {base['loop']:.2f} s (CPU {base['cpu']:.2f} s), command "
              f"{base['command']:.2f} s, real-time factor {flight / base['command']:.2f}; this tree / baseline: "
              f"loop {t['loop'] / base['loop']:.2f} (CPU {t['cpu'] / base['cpu']:.2f}), command "
              f"{t['nav'] / base['command']:.2f}; final position - baseline's {dp_base:.1e} m, 1-sigma "
              f"{ds_base:.1e} relative (0: the same bits; BLAS on two threads in the baseline's extractor may "
              f"change the last bits)")
    print(f"  final position: navigate - campaign = {dp:.2e} m; same record as export's: "
          f"{np.array_equal(campaign.error, record.error)}; read-ahead changes no bit: {_same_bits(nav, serial)}")
    print(f"  goal: >= 10x real time; {'met' if flight / t['nav'] >= 10 else 'not met'}")


if __name__ == "__main__":
    main()

"""Benchmark: the rda-nav Monte Carlo, per stage and per run, against the oracle run timed in the same process.

Usage::

    python benchmarks/bench_rda_nav.py                       # 4 runs x 50 s, paper sim
    python benchmarks/bench_rda_nav.py --runs 8 --duration 20 --scenario flexsar
    python benchmarks/bench_rda_nav.py --runs 2 --duration 20 --scenario terrain   # the terrain scene's cost

Times (wall clock, one process, after a 1-run warm-up that compiles the numba kernels):

* ``oracle``: ``RdaNavKind.simulate`` with ``sar.measurement = "oracle"`` (INS, covariance, EKF and the
  measurement algebra, no images) — the baseline;
* ``image``: the same runs with ``sar.measurement = "image"`` (per run and image: echoes of the run's scene,
  the reference pass and the in-flight pass, each with its receiver noise and range compression, RDA +
  mapdrift + registration);
* per-stage seconds per image from the ``stage_seconds`` extra (``echoes`` holds the echo simulation, both
  noisy acquisitions, their range compression and the reference chip);

and prints the ratio image/oracle, the cost per image of the imaging chain, and the projected time of the
full 200-run x 50-image campaign on ``--workers`` processes. Part of the imaging cost is shared by the runs of one
process (the receiver-noise model of each aperture's reference chip, cached; since issue 32 kept across a worker's
chunks, ``simulation.rda_nav``): the image campaign is timed cold with 1 run and with ``--runs`` runs,
``t(R) = S + R c`` gives the shared cost S and the per-run cost c, and the projection is
``(200 c + workers S) / workers`` (each worker pays S once; independent chunks scale linearly on the process
executor). Goal (docs/scenarios/rda-nav.md §3): 200 x 50 images within 10 min on 2 cores, i.e. <= 0.12 s per image
per core.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sarnav.scenarios import rda_nav as rn
from sarnav.simulation.rda_nav import forget_shared_noise_models
from sarnav.scenarios.registry import get_scenario


def _cfg(scenario: str, duration: float, mode: str) -> dict:
    cfg = get_scenario({"flexsar": "rda-nav-flexsar", "terrain": "rda-nav-terrain"}.get(scenario, "rda-nav"))
    cfg["trajectory"]["duration"] = float(duration)
    cfg["sar"]["measurement"] = mode
    return cfg


def _time(cfg, runs, seed=0):
    seeds = np.random.SeedSequence(seed).spawn(runs)
    forget_shared_noise_models()  # every timing cold, as a worker's first chunk
    t0 = time.perf_counter()
    recs = rn.RdaNavKind().simulate(cfg, list(range(runs)), seeds)
    return time.perf_counter() - t0, recs


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--duration", type=float, default=50.0)
    ap.add_argument("--scenario", choices=("paper", "flexsar", "terrain"), default="paper")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)

    _time(_cfg(args.scenario, 2.0, "image"), 1)  # warm-up: numba compilation
    t_or, _ = _time(_cfg(args.scenario, args.duration, "oracle"), args.runs)
    t_im, recs = _time(_cfg(args.scenario, args.duration, "image"), args.runs)
    t_1, _ = _time(_cfg(args.scenario, args.duration, "image"), 1)
    n_img = args.runs * int(args.duration)
    st = np.stack([r.extras["stage_seconds"][1] for r in recs])  # (R, U, stages)
    per_stage = st.sum(axis=(0, 1)) / n_img
    print(f"scenario {args.scenario}: {args.runs} runs x {int(args.duration)} images")
    print(f"  oracle (baseline) {t_or:8.2f} s   {t_or / n_img * 1e3:7.1f} ms per update")
    print(f"  image             {t_im:8.2f} s   {t_im / n_img * 1e3:7.1f} ms per image   ratio image/oracle {t_im / t_or:5.1f}")
    for name, s in zip(rn.STAGES, per_stage):
        print(f"    {name:13s} {s * 1e3:7.2f} ms per image")
    print(f"  imaging chain     {(t_im - t_or) / n_img * 1e3:7.1f} ms per image (image minus oracle)")
    per_run = (t_im - t_1) / max(args.runs - 1, 1)  # c: the cost of one more run
    shared = max(t_1 - per_run, 0.0)  # S: paid once per process and aperture
    workers = max(args.workers, 1)
    scale = 50.0 / args.duration
    full = (200 * per_run + workers * shared) * scale / workers
    print(f"  per run {per_run / args.duration * 1e3:7.1f} ms per image, shared by a process's runs "
          f"{shared / args.duration * 1e3:7.1f} ms per aperture (1 run: {t_1:.2f} s)")
    print(f"  projected 200 runs x 50 images on {workers} workers (each paying the shared cost once): {full:7.0f} s "
          f"(goal 600 s; without the sharing {t_im / n_img * 200 * 50 / workers:7.0f} s)")


if __name__ == "__main__":
    main()

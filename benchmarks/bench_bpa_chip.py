"""Benchmark: the BPA sub-aperture extractor with its chip registered on one and on two ground lattices, same run.

Usage::

    python benchmarks/bench_bpa_chip.py                      # turning flight, 8 runs, apertures 11 and 14, 4 rounds
    python benchmarks/bench_bpa_chip.py --runs 4 --apertures 3 --straight

Times ``SubApertureImager.measure`` (the simulated source's echoes of the aperture, range compression, the search
grid's back-projection, registration, the refocus that models the focusing speed, and the chip formed again on
``ImagingSettings.range_lattices`` lattices; docs/scenarios/rda-nav.md §6) on the truth track, with
``range_lattices`` = 1 (the baseline) and 2 (the default), alternating, after one untimed call of each that builds
the reference chips and compiles the kernels. Prints the median time per aperture and the ratio two / one.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from sarnav.scenarios import rda_nav as rn
from sarnav.scenarios.config import load_scenario
from sarnav.simulation import rda_nav_world as world


def imager(runs: int, lattices: int, straight: bool):
    sets = ["sar.algorithm=bpa"] + ([] if straight else ["trajectory.type=turning"])
    prm = rn.parse(load_scenario("rda-nav", sets, runs=runs))
    return prm, world.world_imager(prm, list(range(500, 500 + runs)), replace(prm.imaging, range_lattices=lattices))[1]


def measure(prm, im, u: int, runs: int) -> None:
    ap_t = u + np.linspace(0.0, 1.0, 11)
    st = prm.trajectory.state(ap_t)
    b = lambda x: np.broadcast_to(x, (runs,) + x.shape)  # noqa: E731
    am = im.measure(u, ap_t, b(st.position), b(st.velocity), np.full(runs, 1e-3), ap_q=b(st.quaternion),
                    along_sigma=np.full(runs, 0.5))
    if not np.all(am.status == 0):
        raise SystemExit(f"aperture {u}: a match failed ({am.status.tolist()}): nothing fair to time")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--apertures", type=int, nargs="+", default=[11, 14])
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--straight", action="store_true", help="the straight flight instead of the turning one")
    args = ap.parse_args(argv)
    if args.rounds < 1 or args.runs < 1:
        ap.error(f"--rounds and --runs must be >= 1, got {args.rounds} and {args.runs}")
    made = {n: imager(args.runs, n, args.straight) for n in (1, 2)}
    times = {1: [], 2: []}
    for rnd in range(args.rounds + 1):
        for n in (1, 2):
            prm, im = made[n]
            for u in args.apertures:
                t0 = time.perf_counter()
                measure(prm, im, u, args.runs)
                if rnd > 0:  # round 0 builds the reference chips and compiles
                    times[n].append(time.perf_counter() - t0)
    one, two = float(np.median(times[1])), float(np.median(times[2]))
    print(f"{'straight' if args.straight else 'turning'} flight, {args.runs} runs, apertures {args.apertures}, "
          f"{args.rounds} rounds: one lattice {one:.3f} s, two lattices {two:.3f} s per aperture; two / one "
          f"{two / one:.3f}")


if __name__ == "__main__":
    main()

"""Benchmark: candidate images of the velocity-offset search, three ways, timed in the same run.

Usage::

    python benchmarks/bench_quality_search.py                 # S_i = 500, L = 11 and 22, 200 x 200 pixels
    python benchmarks/bench_quality_search.py --block 100 --size 100   # quick

For one block of S_i pulses after S_0 = 1000 initial pulses (Hathaway 2023 Alg. 3.3, notes/seed-004 §2.6) on the
thesis' geometry (:class:`sarnav.radar.quality_scenes.QualityGeometry`, PRF 1667 Hz, 200 x 200 pixels), prints
candidate images per second ("cand/s") of

* ``scratch``: each candidate image formed from scratch (BPA of all S_0 + S_i pulses along the candidate track);
  every BPA here uses linear range interpolation, the interpolation the expansion is exact for (BPA's default
  "auto" upsamples these critically sampled pulses, fs = B, and would make a different image);
* ``incremental``: the thesis' way, the block back-projected along each candidate and added to the kept image;
* ``expansion``: :mod:`sarnav.imaging.offset_bpa`, one pass over the block's pulses for all L candidates;

the ratios against ``scratch``, the expansion's image error against the exact incremental image, and the time of
one full search run (``run_search``, the thesis' grid, kurtosis) with the projected time of the Table 4.1 sweep for
one (S_i, L): 10 sigma x 30 spacings = 300 runs plus the 20 runs of the two improved searches (controls need no
image). Numba uses every core it is given (``NUMBA_NUM_THREADS``).
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numba
import numpy as np

from sarnav.imaging.backprojection import backproject
from sarnav.imaging.offset_bpa import offset_moments
from sarnav.measurements import focus_search as fs
from sarnav.radar.quality_scenes import QualityGeometry, point_clutter_scene
from timing import best_time


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--block", type=int, default=500, help="S_i pulses per block")
    ap.add_argument("--size", type=int, default=200, help="image size n (n x n pixels)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--runs", type=int, default=1, help="search runs timed for the sweep projection")
    args = ap.parse_args(argv)

    geo = QualityGeometry()
    scene = point_clutter_scene(np.random.default_rng(np.random.SeedSequence(5)), geo.scene_center,
                                geo.scene_extent, clutter_density=0.5)
    prob = fs.search_problem(geo, scene, size=args.size)
    s0, si = prob.initial_pulses, args.block
    rc, grid, e = prob.rc, prob.grid, prob.direction
    sigma = fs.table41_sigmas()[3]
    noisy = fs.inject_velocity_noise(prob.truth, e, s0, fs.TABLE41_BIAS, sigma,
                                     np.random.default_rng(np.random.SeedSequence(1)).standard_normal(rc.n_pulses))
    lin = fs.linearise(noisy, fs.block_knots(rc.n_pulses, s0, si))
    tau = np.arange(1.0, si + 1.0)
    base = lin[s0:s0 + si]
    block = replace(rc, data=rc.data[s0:s0 + si], pulse_times=rc.pulse_times[s0:s0 + si], positions=base)
    head = replace(rc, data=rc.data[:s0 + si], pulse_times=rc.pulse_times[:s0 + si], positions=rc.positions[:s0 + si])
    acc = prob.image0()
    print(f"threads {numba.get_num_threads()}  image {args.size}^2  S_0 {s0}  S_i {si}")
    for L in (11, 22):
        deltas = fs.candidate_offsets("grid", L, span=fs.TABLE41_BIAS + 3 * sigma / np.sqrt(si))

        def scratch_one():
            pos = np.concatenate([prob.truth[:s0], base + (deltas[-1] * tau)[:, None] * e])
            backproject(head, grid, positions=pos, interpolation="linear")

        def incremental():
            return [acc + backproject(block, grid, positions=base + (d * tau)[:, None] * e, interpolation="linear").data
                    for d in deltas]

        def expansion():
            mom = offset_moments(block, grid, base, e, tau, 6)
            return acc[None] + mom.images(deltas)

        scratch_one()
        t_scr = best_time(scratch_one, args.repeat)                      # one candidate; L of them cost L x
        t_inc = best_time(incremental, args.repeat)
        t_exp = best_time(expansion, args.repeat)
        exact, fast = np.array(incremental()), expansion()
        err = 10 * np.log10(np.sum(np.abs(fast - exact) ** 2) / np.sum(np.abs(exact - acc) ** 2))
        print(f"L={L:2d}  scratch {1 / t_scr:8.2f} cand/s   incremental {L / t_inc:8.2f} cand/s "
              f"({L / t_inc * t_scr:5.1f}x)   expansion {L / t_exp:8.2f} cand/s ({L / t_exp * t_scr:5.1f}x)   "
              f"expansion error {err:6.1f} dB")
    _sweep_projection(prob, noisy, si, sigma, args.runs)


def _sweep_projection(prob, noisy, si, sigma, runs) -> None:
    spacing = fs.table41_spacings(sigma)[15]
    fs.run_search(prob, noisy, si, "source", 11, spacing=spacing)
    t = best_time(lambda: fs.run_search(prob, noisy, si, "source", 11, spacing=spacing), runs)
    span = fs.TABLE41_BIAS + 3 * sigma / np.sqrt(si)
    t_imp = best_time(lambda: (fs.run_search(prob, noisy, si, "grid", 11, span=span),
                              fs.run_search(prob, noisy, si, "brent", 11, span=span)), runs)
    total = 300 * t + 10 * t_imp
    print(f"one search run (S_i={si}, L=11, kurtosis): {t:.2f} s; grid + brent: {t_imp:.2f} s; "
          f"projected Table 4.1 sweep for one (S_i, L): {total / 60:.1f} min (controls add < 1 %)")


if __name__ == "__main__":
    main()

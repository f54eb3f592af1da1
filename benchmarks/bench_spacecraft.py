"""Benchmark: the 100-run open-loop spacecraft campaign (paper §VI.B, TC-2: 600 s, 100 Hz mechanization and
covariance, 73 updates) batched over runs against a per-run loop, timed in the same run.

Usage::

    python benchmarks/bench_spacecraft.py                     # 100 runs batched, 100 runs one at a time
    python benchmarks/bench_spacecraft.py --runs 100 --loop-runs 20 --case tc1

``batched``: one :func:`sarnav.simulation.spacecraft.run_open_loop` call with all seeds (numba kernels loop over
runs inside each inter-record interval; the updates are numpy stacks). ``per-run loop``: the same function called
once per seed. The per-run time is scaled to ``--runs``. The numba kernels are compiled (or loaded from the cache)
before timing. Goal (issue 11): 100 runs in under 1 minute on 2 cores.

``--images N`` (default 3) then times the closed loop's image chain (scenario ``spacecraft-closed-loop``, first
update): the shared world (echoes of this and the reference pass, the geocoded reference) once, and N images (one run
each) by stage: focusing (receiver noise, range compression, final RDA), autofocus (hill climb), registration.
Goal: under 10 s per image.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sarnav.simulation.spacecraft import OpenLoopParams, run_open_loop


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--loop-runs", type=int, default=100)
    ap.add_argument("--case", choices=("tc1", "tc2"), default="tc2")
    ap.add_argument("--images", type=int, default=3)
    args = ap.parse_args(argv)
    params = OpenLoopParams.tc1() if args.case == "tc1" else OpenLoopParams.tc2()
    seeds = np.random.SeedSequence(1).spawn(max(args.runs, args.loop_runs))
    run_open_loop(OpenLoopParams.tc2(duration=10.0), seeds[:2])  # compile / load the numba kernels

    t0 = time.perf_counter()
    batched = run_open_loop(params, seeds[: args.runs])
    t_batch = time.perf_counter() - t0

    t0 = time.perf_counter()
    for s in seeds[: args.loop_runs]:
        one = run_open_loop(params, [s])
    t_loop = (time.perf_counter() - t0) * args.runs / args.loop_runs
    assert np.array_equal(one.error[0], batched.error[args.loop_runs - 1]) if args.loop_runs <= args.runs else True

    steps = args.runs * round(params.duration / params.mekf.dt)
    print(f"case {args.case}: {args.runs} runs x {params.duration:.0f} s at {1 / params.mekf.dt:.0f} Hz, "
          f"{batched.update_time.size} updates")
    print(f"batched        {t_batch:8.2f} s   {steps / t_batch / 1e6:6.2f} M run-steps/s")
    print(f"per-run loop   {t_loop:8.2f} s   {steps / t_loop / 1e6:6.2f} M run-steps/s "
          f"({args.loop_runs} runs timed, scaled to {args.runs})")
    print(f"ratio batched/loop speed: {t_loop / t_batch:.2f}x; goal 100 runs < 60 s: "
          f"{'met' if t_batch * 100 / args.runs < 60 else 'NOT met'}")
    if args.images > 0:
        closed_loop_stages(args.images)


def closed_loop_stages(n_images: int):
    from sarnav.scenarios.registry import get_scenario
    from sarnav.scenarios.spacecraft_closed_loop import parse
    from sarnav.simulation.spacecraft_closed_loop import imager_for

    p = parse(get_scenario("spacecraft-closed-loop"))
    im = imager_for(p)
    chip = im.chip(0, 8.2)
    secs = []
    for i in range(n_images):
        g = np.random.default_rng(i)
        m = im.measure(chip, chip.r + g.normal(0, 1000, 3), chip.v + g.normal(0, 10, 3), np.array([1.0, 0, 0, 0]), g)
        secs.append(m.seconds)
    s = np.mean(secs, axis=0)
    print(f"closed loop, {n_images} images: world (echoes x 2 passes + reference) {chip.seconds:.2f} s per update; "
          f"per image focusing {s[1]:.2f} s, autofocus {s[2]:.2f} s, registration {s[3]:.2f} s; "
          f"total with the world {chip.seconds + s[1:].sum():.2f} s (goal < 10 s: "
          f"{'met' if chip.seconds + s[1:].sum() < 10 else 'NOT met'})")


if __name__ == "__main__":
    main()

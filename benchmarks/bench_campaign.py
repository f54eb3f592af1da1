"""Benchmark: INS + covariance propagation batched over runs vs a per-run Python loop, and the
wall time of the 200-run ``telemetry`` campaign, timed in the same run.

Usage::

    python benchmarks/bench_campaign.py                  # 200 runs, 2 s of 100 Hz IMU data
    python benchmarks/bench_campaign.py --runs 100 --seconds 5 --loop-runs 10

``batched``: one :func:`sarnav.ins.mechanize` call per covariance step on (R, ...) arrays, then
the closed-form discretisation and ``P <- Phi P Phi^T + Q_d`` for all R runs at once.
``per-run loop``: the same calls with R = 1, looped over ``--loop-runs`` runs in Python.
Both print IMU samples per second (runs x samples / time) and the ratio batched / loop (best of
``--repeat``). Then ``TelemetryKind().simulate`` of the default 200-run configuration.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sarnav.filters import ErrorStateModel, propagate_covariance
from sarnav.ins import NavState, mechanize
from sarnav.rotations import quat_normalize, quat_to_dcm
from sarnav.scenarios.telemetry import STATE_LAYOUT, TelemetryKind
from sarnav.sensors import IMU_GRADES
from sarnav.trajectory import Maneuvering
from timing import best_time

RATE, COV_SAMPLES = 100.0, 10


def _setup(runs, seconds, seed=0):
    traj = Maneuvering.s_turn_climb([0.0, -200.0, -500.0], 50.0, 0.0, max(seconds, 1.0))
    t = np.arange(int(round(seconds * RATE)) + 1) / RATE
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    nu = traj.specific_force(t)[None] + 1e-3 * rng.standard_normal((runs, t.size, 3))
    om = traj.angular_rate(t)[None] + 1e-5 * rng.standard_normal((runs, t.size, 3))
    s = traj.state(t[:1])
    z = np.zeros((runs, 3))
    nav = NavState(np.repeat(s.position, runs, 0), np.repeat(s.velocity, runs, 0), np.repeat(s.quaternion, runs, 0),
                   z, z.copy(), np.zeros((runs, 3)))
    g = IMU_GRADES["tactical"]
    model = ErrorStateModel(STATE_LAYOUT, g.vrw, g.arw, g.accel_bias, g.gyro_bias, 3600.0, 3600.0, (0.03,) * 3, (300.0,) * 3)
    return t, nu, om, nav, model


def propagate(t, nu, om, nav, model):
    runs = nav.runs
    P = np.broadcast_to(np.eye(STATE_LAYOUT.n), (runs, STATE_LAYOUT.n, STATE_LAYOUT.n)).copy()
    hist = None
    dt = COV_SAMPLES / RATE
    for k0 in range(0, t.size - 1, COV_SAMPLES):
        sl = slice(k0, k0 + COV_SAMPLES + 1)
        q0 = nav.q
        nav, f_mean, hist = mechanize(nav, t[sl], nu[:, sl], om[:, sl], 3600.0, 3600.0, (300.0,) * 3, hist)
        Phi, Qd = model.discretize(quat_to_dcm(quat_normalize(q0 + nav.q)), f_mean, dt)
        P = propagate_covariance(P, Phi, Qd)
    return nav, P


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--loop-runs", type=int, default=20, help="runs timed in the per-run loop (rate is per sample)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)

    t, nu, om, nav, model = _setup(args.runs, args.seconds)
    samples = t.size - 1
    tb = best_time(lambda: propagate(t, nu, om, nav, model), args.repeat)

    def loop():
        for i in range(args.loop_runs):
            one = NavState(nav.p[i:i + 1], nav.v[i:i + 1], nav.q[i:i + 1], nav.ba[i:i + 1], nav.bg[i:i + 1], nav.bm[i:i + 1])
            propagate(t, nu[i:i + 1], om[i:i + 1], one, model)

    tl = best_time(loop, args.repeat)
    rate_b = args.runs * samples / tb
    rate_l = args.loop_runs * samples / tl
    print(f"INS + covariance propagation, {samples} IMU samples at {RATE:g} Hz, covariance every {COV_SAMPLES} samples")
    print(f"  batched over {args.runs} runs : {rate_b:12.0f} IMU samples/s ({tb:.3f} s)")
    print(f"  per-run Python loop ({args.loop_runs} runs): {rate_l:12.0f} IMU samples/s ({tl:.3f} s)")
    print(f"  ratio batched / loop      : {rate_b / rate_l:.1f}x")

    kind = TelemetryKind()
    cfg = kind.default_config()
    n = cfg["campaign"]["runs"]
    seeds = np.random.SeedSequence(cfg["campaign"]["seed"]).spawn(n)
    t0 = time.perf_counter()
    kind.simulate(cfg, list(range(n)), seeds)
    print(f"telemetry simulate, default config ({n} runs, {cfg['trajectory']['duration']:g} s, "
          f"IMU {cfg['imu']['rate_hz']:g} Hz, updates {cfg['measurements']['rate_hz']:g} Hz): {time.perf_counter() - t0:.2f} s wall")


if __name__ == "__main__":
    main()

"""Benchmark: particle-steps per second of the batched particle filter, and the UPF against real time.

Usage::

    python benchmarks/bench_particles.py                 # defaults below
    python benchmarks/bench_particles.py --flight 20 --particles 2000 --rate 3000

Timed in the same run, on one core (numba kernels are serial; BLAS limited to one thread):

* ``batched``: ``GridParticleFilter`` (geodetic model = the Earth-rate strapdown of every particle, eqs.
  2.48-2.59) propagated on the 3 kHz pulse grid between 20 Hz fixes, with the SIR updates, resampling and
  regularisation; particle-steps = particles x grid epochs;
* ``loop``: the same geodetic translational step written as a straightforward per-particle Python loop
  (``math`` module, no numpy, no numba) over a few grid epochs — propagation only, which flatters it;
* ``UPF real-time ratio``: seconds of flight per second of wall time of the 2000-particle UPF at 3 kHz with a
  200 Hz NovAtel-model IMU and 20 Hz fixes (goal > 1: one hour of flight in under one hour);
* ``PF/KF cost ratio`` (T12): time per grid epoch of the UPF over that of the interpolated KF (the source:
  0.5 ms / 0.1 ms = 5 in MATLAB, Table 5.3).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from threadpoolctl import threadpool_limits

from sarnav.filters.grid_kalman import GridKalmanFilter
from sarnav.filters.grid_particle import GridParticleFilter
from sarnav.filters.pulse_grid import ImuStream, NavFrame, uniform_times
from sarnav.frames.earth import OMEGA_EARTH, WGS84_A, WGS84_E2
from sarnav.simulation.multi_imu import ORIGIN, gnss_ins_sim_imu, simulate_fixes, spec_accel_psd, survey_flight
from sarnav.trajectory.geodetic import GeodeticFlight


def python_step(x, f, dt):
    """The geodetic translational step for one particle in plain Python (the per-particle baseline)."""
    lat, lon, h, vn, ve, vd = x
    sl, cl = math.sin(lat), math.cos(lat)
    w = 1.0 - WGS84_E2 * sl * sl
    rn = WGS84_A * (1.0 - WGS84_E2) / (w * math.sqrt(w))
    re = WGS84_A / math.sqrt(w)
    ox, oy, oz = 2 * OMEGA_EARTH * cl + ve / (re + h), -vn / (rn + h), -2 * OMEGA_EARTH * sl - ve * sl / cl / (re + h)
    g = 9.80665
    vn1 = vn + (f[0] - (oy * vd - oz * ve)) * dt
    ve1 = ve + (f[1] - (oz * vn - ox * vd)) * dt
    vd1 = vd + (f[2] + g - (ox * ve - oy * vn)) * dt
    h1 = h - 0.5 * dt * (vd + vd1)
    lat1 = lat + 0.5 * dt * (vn / (rn + h) + vn1 / (rn + h1))
    lon1 = lon + 0.5 * dt * (ve / ((re + h) * cl) + ve1 / ((re + h1) * math.cos(lat1)))
    return [lat1, lon1, h1, vn1, ve1, vd1]


def setup(flight_s, rate):
    geo = GeodeticFlight(survey_flight(3600.0), *ORIGIN)
    t_imu = uniform_times(0.0, flight_s, 200.0)
    model = gnss_ins_sim_imu("novatel-isa-100c", 200.0)
    rngs = [np.random.default_rng(1)]
    ba, bg = model.initial_biases(rngs)
    f, w = geo.imu(t_imu)
    nu, om, *_ = model.measure(f, w, ba, bg, rngs)
    fixes = simulate_fixes(geo, uniform_times(0.0, flight_s, 20.0), np.array([0.3, 0.3, 0.5]), [np.random.default_rng(2)])
    return geo, ImuStream(t_imu, nu, om), fixes, uniform_times(0.0, flight_s, rate)


def make_filters(geo, fixes, n):
    frame = NavFrame(geodetic=True, origin=ORIGIN)
    s0 = geo.state(0.0)
    p0 = np.diag([0.09, 0.09, 0.25, 0.0025, 0.0025, 0.0025])
    q = spec_accel_psd("novatel-isa-100c", 200.0)
    pf = GridParticleFilter(frame, n, q, model="geodetic", noise_at="imu", ess_threshold=0.5, kernel_h=0.3)
    pf.initialize(0.0, fixes.position[:, 0], s0.velocity[None], s0.quaternion, p0, [np.random.default_rng(3)])
    kf = GridKalmanFilter(frame, q).initialize(0.0, fixes.position[:, 0], s0.velocity[None], s0.quaternion, p0)
    return pf, kf


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--flight", type=float, default=20.0, help="seconds of flight timed [s]")
    ap.add_argument("--particles", type=int, default=2000)
    ap.add_argument("--rate", type=float, default=3000.0, help="output (pulse) rate [Hz]")
    ap.add_argument("--loop-epochs", type=int, default=30, help="grid epochs of the per-particle loop")
    args = ap.parse_args(argv)
    with threadpool_limits(1):
        geo, imu, fixes, grid = setup(args.flight, args.rate)
        pf, kf = make_filters(geo, fixes, args.particles)
        pf.run(imu, 0.2, fixes, grid[grid <= 0.2])  # warm-up: numba compilation
        kf.run(imu, 0.2, fixes, grid[grid <= 0.2])
        rest = grid[grid > 0.2]
        t0 = time.perf_counter()
        pf.run(imu, args.flight, fixes, rest)
        t_pf = time.perf_counter() - t0
        t0 = time.perf_counter()
        kf.run(imu, args.flight, fixes, rest)
        t_kf = time.perf_counter() - t0
        epochs = rest.size
        batched = args.particles * epochs / t_pf
        x = [list(p) for p in pf.parts[0]]
        f = [0.1, -0.2, -9.8]
        dt = 1.0 / args.rate
        t0 = time.perf_counter()
        for _ in range(args.loop_epochs):
            x = [python_step(p, f, dt) for p in x]
        t_loop = time.perf_counter() - t0
        loop = args.particles * args.loop_epochs / t_loop
    flight = args.flight - 0.2
    print(f"grid: {epochs} epochs at {args.rate:g} Hz over {flight:g} s of flight, {args.particles} particles, one core")
    print(f"batched PF (propagation + SIR updates): {batched:.3g} particle-steps/s")
    print(f"per-particle Python loop (propagation only): {loop:.3g} particle-steps/s")
    print(f"speed-up batched / loop: {batched / loop:.0f}x")
    print(f"UPF real-time ratio (flight s per wall s): {flight / t_pf:.2f}  (one hour of flight in {3600 * t_pf / flight / 60:.1f} min)")
    print(f"interpolated KF real-time ratio: {flight / t_kf:.1f}")
    print(f"PF/KF cost per grid epoch (T12; source 5): {t_pf / t_kf:.1f}  ({1e6 * t_pf / epochs:.1f} us vs {1e6 * t_kf / epochs:.2f} us per epoch)")


if __name__ == "__main__":
    main()

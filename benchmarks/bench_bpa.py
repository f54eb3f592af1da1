"""Benchmark: compiled back-projection vs a vectorised numpy BPA, timed in the same run.

Usage::

    python benchmarks/bench_bpa.py                      # 1024 x 1024 pixels, 1024 pulses
    python benchmarks/bench_bpa.py --size 256 --pulses 256   # quick

Prints pixel-pulses per second ("backprojections/s", one pixel x one pulse) of
``sarnav.imaging.backprojection.backproject`` for each interpolation, of the float64 numpy
reference ``backproject_numpy`` (timed on ``--numpy-pulses`` pulses and scaled linearly: its cost
is exactly proportional to the number of pulses), their ratio, and the image error
``10 log10(||a - b||^2 / ||b||^2)`` of the compiled image ``a`` against the numpy float64 reference
``b`` with the same interpolation (on a ``--check`` x ``--check`` block of pixels, all pulses).
It also prints each interpolation's error against the *exact* band-limited image (pulse samples
evaluated analytically at every pixel range, no interpolation), on a small image.

Data: an ideal range-compressed scene synthesised analytically (no dependency on the echo
simulator): for each target at range R_k, ``sinc(2 B (r - R_k) / c) exp(-j 4 pi R_k / lambda)``
(docs/conventions.md), X band (9.75 GHz), B = 150 MHz, fs = 1.25 B, 50 m/s, 1000 m altitude,
random targets with a fixed seed.
"""

from __future__ import annotations

import argparse
import os
import time
from types import SimpleNamespace

import numba
import numpy as np

from sarnav.imaging.backprojection import INTERPOLATIONS, backproject, backproject_numpy
from sarnav.signal.data import PulseData
from sarnav.imaging.grid import GroundGrid, PointGrid
from sarnav.units import C

FC = 9.75e9
BANDWIDTH = 150e6
FS = 1.25 * BANDWIDTH
SPEED = 50.0
PRF = 400.0
ALTITUDE = 1000.0
GROUND_RANGE = 1800.0
SPACING = 0.5


def geometry(n_pulses: int):
    times = (np.arange(n_pulses) - 0.5 * (n_pulses - 1)) / PRF
    pos = np.zeros((n_pulses, 3))
    pos[:, 0] = SPEED * times
    pos[:, 2] = -ALTITUDE
    return times, pos


def compressed_pulse(ranges: np.ndarray, target_ranges: np.ndarray, amplitudes: np.ndarray, wavelength: float):
    """Ideal range-compressed samples at ``ranges`` (..., N) for targets at ``target_ranges`` (..., T)."""
    out = np.zeros(np.broadcast_shapes(ranges.shape[:-1], target_ranges.shape[:-1]) + ranges.shape[-1:],
                  dtype=np.complex128)
    for t in range(target_ranges.shape[-1]):
        rt = target_ranges[..., t:t + 1]
        out += amplitudes[t] * np.sinc(2.0 * BANDWIDTH / C * (ranges - rt)) * np.exp(-4j * np.pi * rt / (C / FC))
    return out


def scene(n_pulses: int, half_extent: float, n_targets: int, seed: int = 0, fs: float = FS):
    """Range-compressed data (complex64) of random targets inside a square of the given half extent."""
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    lam = C / FC
    times, pos = geometry(n_pulses)
    tg = np.zeros((n_targets, 3))
    tg[:, 0] = rng.uniform(-half_extent, half_extent, n_targets)
    tg[:, 1] = GROUND_RANGE + rng.uniform(-half_extent, half_extent, n_targets)
    amp = rng.standard_normal(n_targets) + 1j * rng.standard_normal(n_targets)
    r_t = np.linalg.norm(tg[None, :, :] - pos[:, None, :], axis=2)            # (P, T)
    dr = C / (2 * fs)
    r0 = r_t.min() - 20 * dr - half_extent * 0.2
    n = int(np.ceil((r_t.max() + 20 * dr + half_extent * 0.2 - r0) / dr))
    ranges = r0 + np.arange(n) * dr
    data = np.empty((n_pulses, n), dtype=np.complex64)
    for k in range(n_pulses):
        data[k] = compressed_pulse(ranges, r_t[k], amp, lam)
    rc = PulseData(data, ranges, times, pos, SimpleNamespace(wavelength=lam), compressed=True)
    return rc, tg, amp


def error_db(a, b) -> float:
    return float(10 * np.log10(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2)))


def best_time(fn, repeat: int, threads: int = 1) -> tuple[float, float]:
    """Best wall time and best CPU time / threads over ``repeat`` calls [s].

    CPU time per thread is reported too because the machine is shared: when other processes load
    the cores the wall time grows while the CPU time the kernel really used grows much less.
    """
    wall, cpu = np.inf, np.inf
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, (time.process_time() - c0) / threads)
    return wall, cpu


def exact_image(rc, grid, tg, amp):
    """BPA with every pulse sample evaluated analytically at the pixel range (no interpolation)."""
    lam = C / FC
    pts = grid.points().reshape(-1, 3)
    r_t = np.linalg.norm(tg[None, :, :] - rc.positions[:, None, :], axis=2)
    out = np.zeros(pts.shape[0], dtype=np.complex128)
    for k in range(rc.n_pulses):
        r = np.linalg.norm(pts - rc.positions[k], axis=1)
        s = np.zeros(r.shape, dtype=np.complex128)
        for t in range(tg.shape[0]):
            s = s + amp[t] * np.sinc(2 * BANDWIDTH / C * (r - r_t[k, t])) * np.exp(-4j * np.pi * r_t[k, t] / lam)
        out += s * np.exp(4j * np.pi * r / lam)
    return out.reshape(grid.shape)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="image is size x size pixels")
    ap.add_argument("--pulses", type=int, default=1024)
    ap.add_argument("--numpy-pulses", type=int, default=32, help="pulses the numpy baseline is timed on")
    ap.add_argument("--check", type=int, default=128, help="side of the pixel block compared with numpy")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--targets", type=int, default=20)
    args = ap.parse_args(argv)

    print(f"numba {numba.__version__}, threads {numba.get_num_threads()}, cpus {os.cpu_count()}, "
          f"SVML {numba.config.USING_SVML}")
    half = 0.5 * args.size * SPACING
    rc, tg, amp = scene(args.pulses, half, args.targets)
    grid = GroundGrid.centered(0.0, GROUND_RANGE, SPACING, (args.size, args.size))
    work = args.size * args.size * args.pulses
    print(f"image {args.size}x{args.size}, {args.pulses} pulses, {rc.data.shape[1]} range samples")

    # numpy float64 baseline, timed on fewer pulses and scaled (cost is linear in pulses)
    npulses = min(args.numpy_pulses, args.pulses)
    t_np, _ = best_time(lambda: backproject_numpy(rc, grid, interpolation="linear", pulses=slice(0, npulses)),
                        max(1, args.repeat - 1))
    rate_np = args.size * args.size * npulses / t_np
    print(f"numpy float64 linear : {rate_np:10.3e} pixel-pulses/s (timed on {npulses} pulses, scaled)")

    c = min(args.check, args.size)
    i0 = (args.size - c) // 2
    sub = PointGrid(grid.points()[i0:i0 + c, i0:i0 + c])
    rates = {}
    for interp in INTERPOLATIONS:
        backproject(rc, GroundGrid.centered(0.0, GROUND_RANGE, SPACING, (8, 8)), interpolation=interp)  # compile
        img = {}
        t, t_cpu = best_time(lambda: img.__setitem__("a", backproject(rc, grid, interpolation=interp)), args.repeat,
                             numba.get_num_threads())
        rates[interp] = work / t
        ref = backproject_numpy(rc, sub, interpolation=interp).data
        err = error_db(img["a"].data[i0:i0 + c, i0:i0 + c], ref)
        print(f"numba {interp:9s}      : {rates[interp]:10.3e} pixel-pulses/s  ({t:6.2f} s; from CPU time per "
              f"thread {work / t_cpu:9.3e})  ratio to numpy {rates[interp] / rate_np:6.1f}x  "
              f"error vs float64 numpy {err:7.1f} dB")
    goal = 0.36e9
    print(f"goal 0.36e9 pixel-pulses/s (linear): {'MET' if rates['linear'] >= goal else 'NOT MET'} "
          f"({rates['linear'] / goal:.2f} x goal)")

    # interpolation accuracy against the exact band-limited image (small image, fewer pulses)
    small = GroundGrid.centered(0.0, GROUND_RANGE, SPACING, (64, 64))
    print("interpolation error vs exact band-limited image (64x64 px, 128 pulses, 5 targets):")
    for osr in (1.25, 2.0, 4.0):
        rc_s, tg_s, amp_s = scene(128, 16.0, 5, seed=1, fs=osr * BANDWIDTH)
        exact = exact_image(rc_s, small, tg_s, amp_s)
        row = []
        for interp, up in (("nearest", 0), ("linear", 0), ("cubic", 0), ("upsample", 2), ("upsample", 4),
                           ("upsample", 8), ("upsample", 16)):
            a = backproject(rc_s, small, interpolation=interp, upsample=max(up, 2)).data
            row.append(f"{interp}{up if up else ''} {error_db(a, exact):6.1f}")
        print(f"  fs/B = {osr:4.2f}: " + ", ".join(row) + " dB")

if __name__ == "__main__":
    main()

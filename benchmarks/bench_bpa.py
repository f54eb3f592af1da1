"""Benchmark: compiled back-projection vs FastSAR's C++/OpenMP exact BP and a numpy BPA, same run.

Usage::

    python benchmarks/bench_bpa.py                      # 1024 x 1024 pixels, 1024 pulses
    python benchmarks/bench_bpa.py --size 256 --pulses 256 --rounds 2   # quick
    pip install -e '.[bench]'                            # FastSAR (optional), the C++ peer

FastSAR (MIT, PyPI ``fastsar``): ``fastsar.form_image(S, ant, fmin, df, n, n, sp, sp, e1, e2,
algorithm="bp")`` from the phase history of the same pulses (``sarnav.signal.phase_history``;
FastSAR's grid pixel i sits at (i - n/2) sp, so sarnav's grid is shifted by half a pixel to match),
timed on its default cubic x8 and on linear x8; its image is compared with sarnav's (error after
one fitted complex gain). Both use the same threads (``NUMBA_NUM_THREADS`` / ``OMP_NUM_THREADS``).
The machine may be shared: every configuration is timed once per round, sarnav and FastSAR interleaved,
and the rates and the per-round ratios are printed as median [min, max] over ``--rounds``, from wall
time and from CPU time (work / (process CPU time / threads): what the kernels used, less sensitive to
other processes than the wall time).

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

import numba
import numpy as np

from sarnav.imaging.backprojection import backproject, backproject_numpy
from sarnav.signal.data import PulseData
from sarnav.imaging.grid import GroundGrid, PointGrid, regular_axis
from sarnav.signal.phase_history import pulses_to_phase_history
from sarnav.imaging.interpolation_error import interpolation_error
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
    rc = PulseData(data, ranges, times, pos, None, compressed=True, wavelength=lam)
    return rc, tg, amp


def error_db(a, b) -> float:
    return float(10 * np.log10(np.sum(np.abs(a - b) ** 2) / np.sum(np.abs(b) ** 2)))


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


def fastsar_former(rc, size: int):
    """{interp: callable forming FastSAR's exact BP image of the same pulses} (cubic x8 default, linear x8), or {}."""
    try:
        import fastsar
    except ImportError:
        print("fastsar not installed (pip install -e '.[bench]'): C++ peer skipped")
        return {}
    centre = np.array([0.0, GROUND_RANGE, 0.0])
    ant = rc.positions - centre
    ph = pulses_to_phase_history(rc, np.linalg.norm(ant, axis=1))
    s = ph.data.astype(np.complex64)

    def make(interp):
        return lambda: fastsar.form_image(s, ant, ph.fx0[0], ph.fx_step[0], size, size, SPACING, SPACING,
                                          (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), algorithm="bp", window=False,
                                          interp=interp)
    return {"fastsar cubic x8": make("cubic"), "fastsar linear x8": make("linear")}


def timed(fn) -> tuple[float, float, object]:
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - t0, time.process_time() - c0, out


#: (sarnav configuration, FastSAR configuration) ratios printed: same interpolation first, then the defaults
PAIRS = (("sarnav upsample x8", "fastsar linear x8"), ("sarnav linear", "fastsar linear x8"),
         ("sarnav cubic", "fastsar cubic x8"), ("sarnav upsample x4", "fastsar cubic x8"))


def rounds(rc, grid, size: int, n_rounds: int, work: int) -> tuple[dict, dict]:
    """Every configuration timed once per round, sarnav and FastSAR interleaved (the same load on both):
    {name: [(wall, cpu), ...]} and {name: image of the last round}."""
    confs = {f"sarnav {m}": (lambda m=m: backproject(rc, grid, interpolation=m).data)
             for m in ("nearest", "linear", "cubic")}
    for up in (4, 8):
        confs[f"sarnav upsample x{up}"] = (lambda up=up: backproject(rc, grid, interpolation="upsample",
                                                                    upsample=up).data)
    confs.update(fastsar_former(rc, size))
    times = {k: [] for k in confs}
    images = {}
    for k, fn in confs.items():                      # compile / warm up
        images[k] = np.asarray(fn())
    for r in range(n_rounds):
        for k, fn in confs.items():
            wall, cpu, images[k] = timed(fn)
            times[k].append((wall, cpu))
        print(f"  round {r + 1}/{n_rounds}: " + ", ".join(f"{k} {work / t[-1][0]:.3g}" for k, t in times.items()),
              flush=True)
    return times, images


def report(times: dict, work: int, threads: int, rate_np: float) -> None:
    print(f"pixel-pulses/s over {len(next(iter(times.values())))} rounds: median [min, max]; CPU = work / (CPU time / "
          f"{threads} threads)")
    for k, t in times.items():
        wall = np.array([work / a for a, _ in t])
        cpu = np.array([work / (b / threads) for _, b in t])
        print(f"  {k:20s} wall {np.median(wall):9.3e} [{wall.min():9.3e}, {wall.max():9.3e}]  CPU {np.median(cpu):9.3e} "
              f"[{cpu.min():9.3e}, {cpu.max():9.3e}]  x numpy {np.median(wall) / rate_np:6.1f}")
    for a, b in PAIRS:
        if a in times and b in times:
            rw = np.array([tb[0] / ta[0] for ta, tb in zip(times[a], times[b])])      # per-round rate ratios
            rc_ = np.array([tb[1] / ta[1] for ta, tb in zip(times[a], times[b])])
            print(f"  {a} / {b}: wall {np.median(rw):.2f} [{rw.min():.2f}, {rw.max():.2f}], CPU {np.median(rc_):.2f} "
                  f"[{rc_.min():.2f}, {rc_.max():.2f}] (goal >= 1.0)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="image is size x size pixels")
    ap.add_argument("--pulses", type=int, default=1024)
    ap.add_argument("--numpy-pulses", type=int, default=32, help="pulses the numpy baseline is timed on")
    ap.add_argument("--check", type=int, default=128, help="side of the pixel block compared with numpy")
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds (every configuration once per round)")
    ap.add_argument("--targets", type=int, default=20)
    ap.add_argument("--no-table", action="store_true", help="skip the interpolation-error table")
    args = ap.parse_args(argv)

    threads = numba.get_num_threads()
    print(f"numba {numba.__version__}, threads {threads}, OMP_NUM_THREADS {os.environ.get('OMP_NUM_THREADS')}, "
          f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
    half = 0.5 * args.size * SPACING
    rc, tg, amp = scene(args.pulses, half, args.targets)
    # FastSAR's pixel i is at (i - n/2) * spacing: shift sarnav's centred grid by half a pixel to match
    grid = GroundGrid(regular_axis(-0.5 * SPACING, SPACING, args.size, "grid.north"),
                      regular_axis(GROUND_RANGE - 0.5 * SPACING, SPACING, args.size, "grid.east"))
    work = args.size * args.size * args.pulses
    print(f"image {args.size}x{args.size}, {args.pulses} pulses, {rc.data.shape[1]} range samples, fs/B = "
          f"{FS / BANDWIDTH:g}")

    # numpy float64 baseline, timed on fewer pulses and scaled (cost is linear in pulses)
    npulses = min(args.numpy_pulses, args.pulses)
    t_np = min(timed(lambda: backproject_numpy(rc, grid, interpolation="linear", pulses=slice(0, npulses)))[0]
               for _ in range(2))
    rate_np = args.size * args.size * npulses / t_np
    print(f"numpy float64 linear : {rate_np:10.3e} pixel-pulses/s (timed on {npulses} pulses, scaled)")

    times, images = rounds(rc, grid, args.size, args.rounds, work)
    report(times, work, threads, rate_np)
    c = min(args.check, args.size)
    i0 = (args.size - c) // 2
    sub = PointGrid(grid.points()[i0:i0 + c, i0:i0 + c])
    for k, img in images.items():
        if k.startswith("sarnav"):
            mode = k.split()[1]
            up = int(k.split("x")[-1]) if "upsample" in k else 4
            ref = backproject_numpy(rc, sub, interpolation=mode, upsample=up).data
            print(f"  {k:20s} error vs float64 numpy (same interpolation) "
                  f"{error_db(img[i0:i0 + c, i0:i0 + c], ref):7.1f} dB")
        else:
            ref = images["sarnav upsample x8"]
            g = np.vdot(img, ref) / np.vdot(img, img)
            print(f"  {k:20s} error vs sarnav upsample x8 {error_db(g * img, ref):7.1f} dB")
    if not args.no_table:
        interpolation_table()


def interpolation_table() -> None:
    """Each interpolation's error against the exact band-limited image (small image, fewer pulses)."""
    small = GroundGrid.centered(0.0, GROUND_RANGE, SPACING, (64, 64))
    print("interpolation error vs exact band-limited image (64x64 px, 128 pulses, 5 targets):")
    for osr in (1.25, 2.0, 4.0):
        rc_s, tg_s, amp_s = scene(128, 16.0, 5, seed=1, fs=osr * BANDWIDTH)
        exact = exact_image(rc_s, small, tg_s, amp_s)
        row = []
        for interp, up in (("nearest", 0), ("linear", 0), ("cubic", 0), ("upsample", 2), ("upsample", 4),
                           ("upsample", 8), ("upsample", 16)):
            a = backproject(rc_s, small, interpolation=interp, upsample=max(up, 2)).data
            kernel, os_eff = ("linear", osr * up) if interp == "upsample" else (interp, osr)
            pred = 10 * np.log10(interpolation_error(kernel, os_eff))
            row.append(f"{interp}{up if up else ''} {error_db(a, exact):6.1f} ({pred:5.1f})")
        print(f"  fs/B = {osr:4.2f}: " + ", ".join(row) + " dB  (predicted, sarnav.imaging.interpolation_error)")


if __name__ == "__main__":
    main()

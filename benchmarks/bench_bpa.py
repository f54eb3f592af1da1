"""Benchmark: compiled back-projection vs FastSAR's C++/OpenMP exact BP and a numpy BPA, same run.

Usage::

    python benchmarks/bench_bpa.py                      # 1024 x 1024 pixels, 1024 pulses; peer collect at 1024^2
    python benchmarks/bench_bpa.py --size 256 --pulses 256 --rounds 2 --peer-sizes 256   # quick
    python benchmarks/bench_bpa.py --peer-sizes 1024 2048 --rounds 0 --no-table          # the peer's collect only
    pip install -e '.[bench]'                            # FastSAR (optional), the C++ peer

Two collects, every mode of both tools (sarnav: auto, precise, nearest, linear, cubic, lagrange, upsample x8;
FastSAR: bp cubic x8, bp linear x8), each printed with its time, pixel-pulses/s and its error against the exact
float64 image on a uniform 16 x 16 pixel sample after one complex gain:

* sarnav's own (below): ideal range-compressed pulses, the exact image evaluates every pulse analytically at every
  pixel range; FastSAR gets their phase history (``pulses_to_phase_history``);
* the peer's (``benchmarks/peer_collect.py``, ``--peer-sizes``): FastSAR's simulated X-band spotlight (9.6 GHz,
  300 MHz, 5 km, 30 deg, 0.25 m pixels, 200 point targets, phase history by NUFFT), read by sarnav through its CPHD
  path (``phase_history_to_pulses`` with its default range axis); the exact image is the float64 sum over every
  pulse and frequency sample. Skipped with a note when fastsar or finufft is not installed. Each sarnav mode also
  prints the peak memory of a call on the 64^2 warm-up grid (``tracemalloc``: the upsampled, zero-padded pulses,
  ``kernels.padded_pulses``, which dominate; FastSAR's C++ allocations are not traced, so it prints none).

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
import tracemalloc

import numba
import numpy as np

from sarnav.imaging.backprojection import backproject, backproject_numpy, resolve_interpolation
from sarnav.errors import ConfigError
from sarnav.imaging.collect_image import auto_image
from sarnav.imaging.ffbp import ffbp
from sarnav.signal.data import PulseData
from sarnav.imaging.grid import GroundGrid, PointGrid, regular_axis
from sarnav.signal.phase_history import phase_history_to_pulses, pulses_to_phase_history
from sarnav.imaging.interpolation_error import interpolation_error
from sarnav.imaging.kernels import RANGE_KERNEL, UPSAMPLED
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
PAIRS = (("sarnav auto", "fastsar linear x8"), ("sarnav precise", "fastsar cubic x8"),
         ("sarnav linear", "fastsar linear x8"), ("sarnav cubic", "fastsar cubic x8"))


#: sarnav's modes timed on both collects: (label, interpolation, upsample)
MODES = (("auto", "auto", 4), ("precise", "precise", 4), ("nearest", "nearest", 4), ("linear", "linear", 4),
         ("cubic", "cubic", 4), ("lagrange", "lagrange", 4), ("upsample x8", "upsample", 8))


def sarnav_confs(rc, grid, pixels=None) -> dict:
    """{name: callable forming sarnav's image of ``rc`` on ``grid``} for every mode of :data:`MODES`; with ``pixels``,
    "auto" and "precise" resolved for an image of that many pixels (a warm-up on a small grid then runs the mode and
    FFT length the full-size image will use)."""
    confs = {}
    for label, m, up in MODES:
        if pixels is not None:
            m, up = resolve_interpolation(rc, m, up, None, pixels)
        confs[f"sarnav {label}"] = lambda m=m, up=up: backproject(rc, grid, interpolation=m, upsample=up).data
    return confs


def rounds(rc, grid, size: int, n_rounds: int, work: int) -> tuple[dict, dict]:
    """Every configuration timed once per round, sarnav and FastSAR interleaved (the same load on both):
    {name: [(wall, cpu), ...]} and {name: image of the last round}."""
    confs = sarnav_confs(rc, grid)
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


def own_collect(args, threads: int) -> None:
    """sarnav's own collect: timing rounds of every mode of both tools, then each image's error against the exact
    image on the uniform 16 x 16 sample and (sarnav) against the float64 numpy reference with the same interpolation."""
    half = 0.5 * args.size * SPACING
    rc, tg, amp = scene(args.pulses, half, args.targets)
    # FastSAR's pixel i is at (i - n/2) * spacing: shift sarnav's centred grid by half a pixel to match
    grid = GroundGrid(regular_axis(-0.5 * SPACING, SPACING, args.size, "grid.north"),
                      regular_axis(GROUND_RANGE - 0.5 * SPACING, SPACING, args.size, "grid.east"))
    work = args.size * args.size * args.pulses
    print(f"own collect: image {args.size}x{args.size}, {args.pulses} pulses, {rc.data.shape[1]} range samples, "
          f"fs/B = {FS / BANDWIDTH:g}")

    # numpy float64 baseline, timed on fewer pulses and scaled (cost is linear in pulses)
    npulses = min(args.numpy_pulses, args.pulses)
    t_np = min(timed(lambda: backproject_numpy(rc, grid, interpolation="linear", pulses=slice(0, npulses)))[0]
               for _ in range(2))
    rate_np = args.size * args.size * npulses / t_np
    print(f"numpy float64 linear : {rate_np:10.3e} pixel-pulses/s (timed on {npulses} pulses, scaled)")

    times, images = rounds(rc, grid, args.size, args.rounds, work)
    report(times, work, threads, rate_np)
    st = max(1, args.size // 16)
    sample = (slice(st // 2, None, st), slice(st // 2, None, st))
    exact = exact_image(rc, PointGrid(grid.points()[sample]), tg, amp)
    c = min(args.check, args.size)
    i0 = (args.size - c) // 2
    sub = PointGrid(grid.points()[i0:i0 + c, i0:i0 + c])
    for k, img in images.items():
        wall = float(np.median([a for a, _ in times[k]]))
        line = (f"  {k:20s} {wall:8.2f} s {work / wall:9.3e} px-pulse/s  error vs exact (16x16 sample, one gain) "
                f"{gain_error_db(img[sample], exact):7.1f} dB")
        if k.startswith("sarnav"):
            label = k[len("sarnav "):]
            _, mode, up = next(m for m in MODES if m[0] == label)
            ref = backproject_numpy(rc, sub, interpolation=mode, upsample=up).data
            line += f"; vs float64 numpy (same interpolation) {error_db(img[i0:i0 + c, i0:i0 + c], ref):7.1f} dB"
        print(line)


def gain_error_db(img, ref) -> float:
    g = np.vdot(img, ref) / np.vdot(img, img)
    return error_db(g * img, ref)


def peak_mib(fn) -> float:
    """Peak of the memory allocated through Python and numpy while fn() runs (``tracemalloc``), in MiB; the compiled
    kernels' own work arrays (numba's allocator) are not counted."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def peer_collect_table(npx: int, modes=None, ffbp_errors=(), plane: bool = False) -> None:
    """The peer's simulated collect through sarnav's CPHD path: every mode of both tools, one timed call each (after
    a warm-up at 64^2), time, pixel-pulses/s and error against the exact float64 sum on the 16 x 16 sample; with
    ``ffbp_errors`` (dB) also sarnav's FFBP planned for each target error (``ffbp(rc, grid, error_db=...)``), the
    nearest thing to an exact mode at that error."""
    import peer_collect as pc

    t_sim, made = pc.timed(lambda: pc.peer_collect(npx))
    if made is None:
        print(f"peer collect {npx}^2: {pc.peer_available()}")
        return
    ph, _ = made
    t_rc, rc = pc.timed(lambda: phase_history_to_pulses(ph))
    t_ex, exact = pc.timed(lambda: pc.exact_sample(ph, npx))
    sample = pc.sample_index(npx)
    work = npx * npx * ph.n_pulses
    print(f"peer collect {npx}^2 x {ph.n_pulses} pulses, {ph.data.shape[1]} frequency samples (simulated in "
          f"{t_sim:.1f} s); sarnav pulses: {rc.data.shape[1]} range samples at fs/B = "
          f"{C / (2 * (rc.slant_range[1] - rc.slant_range[0])) / rc.metadata['stored_band_hz']:.2f} ({t_rc:.2f} s, not in the times "
          f"below); exact 16x16 sample in {t_ex:.1f} s", flush=True)
    grid = pc.plane_grid(npx)
    small = pc.plane_grid(64)
    confs = {k: (fn, sarnav_confs(rc, small, npx * npx)[k]) for k, fn in sarnav_confs(rc, grid).items()
             if modes is None or k[len("sarnav "):] in modes}
    resolved = {f"sarnav {label}": resolve_interpolation(rc, m, up, None, npx * npx) for label, m, up in MODES}
    if modes is None or "default" in modes:   # sarnav image FILE.cphd's default: the faster image within -60 dB
        confs["sarnav default (auto_image)"] = (lambda: auto_image(rc, grid), lambda: auto_image(rc, small))
    for e in ffbp_errors:
        confs[f"sarnav ffbp error_db {e:g}"] = (lambda e=e: ffbp(rc, grid, error_db=e),
                                                lambda e=e: ffbp(rc, small, error_db=e))
        if plane:                          # the polar images on the grid's plane (a bent track's surface) for the cost
            confs[f"sarnav ffbp error_db {e:g} plane"] = (lambda e=e: ffbp(rc, grid, error_db=e, surface="plane"),
                                                          lambda e=e: ffbp(rc, small, error_db=e, surface="plane"))
    if pc.peer_available() is None:
        for interp in ("cubic", "linear"):
            confs[f"fastsar bp {interp} x8"] = (lambda i=interp: pc.fastsar_image(ph, npx, "bp", interp=i),
                                                lambda i=interp: pc.fastsar_image(ph, 64, "bp", interp=i))
    for k, (fn, warm) in confs.items():
        try:
            warm()
        except ConfigError as e:  # e.g. an FFBP error target no plan reaches: say so and go on
            print(f"  {k:24s} refused: {e}", flush=True)
            continue
        wall, img = pc.timed(fn)
        md = ""
        if k in resolved:                # the interpolation this image size resolves to ("auto" and "precise" vary)
            m, up = resolved[k]
            md = f"  [{m}" + (f" x{up}]" if m in UPSAMPLED else "]")
        elif k.startswith("sarnav"):
            md = f"  [{img.metadata['interpolation']}" if hasattr(img, "metadata") else ""
            if "algorithm_choice" in getattr(img, "metadata", {}):
                md += f", {img.metadata['algorithm_choice']}"
            if "ffbp_oversample" in getattr(img, "metadata", {}):
                md += (f", {img.metadata['ffbp_kernel']} os {img.metadata['ffbp_oversample']:g}, predicted "
                       f"{img.metadata['ffbp_predicted_error_db']:.1f} dB (whole image)")
            md += "]" if md else ""
        img = np.asarray(getattr(img, "data", img))
        # the pulses' buffers (upsampled, padded) dominate a call's memory: measured on the 64^2 warm-up grid
        mem = f"; peak {peak_mib(warm):6.0f} MiB on 64^2" if k.startswith("sarnav") else ""
        print(f"  {k:24s} {wall:8.2f} s {work / wall:9.3e} px-pulse/s  error vs exact "
              f"{pc.gain_error_db(img[sample], exact):7.1f} dB{md}{mem}", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1024, help="own collect: image is size x size pixels")
    ap.add_argument("--pulses", type=int, default=1024)
    ap.add_argument("--numpy-pulses", type=int, default=32, help="pulses the numpy baseline is timed on")
    ap.add_argument("--check", type=int, default=128, help="side of the pixel block compared with numpy")
    ap.add_argument("--rounds", type=int, default=5, help="timing rounds on the own collect (0: skip it)")
    ap.add_argument("--targets", type=int, default=20)
    ap.add_argument("--peer-sizes", type=int, nargs="*", default=[1024], help="image sizes on the peer's collect")
    ap.add_argument("--peer-modes", nargs="*", default=None,
                    help="sarnav modes timed on the peer's collect (labels of MODES, e.g. auto precise, or default: "
                         "imaging.collect_image.auto_image, sarnav image FILE.cphd's default; default all)")
    ap.add_argument("--no-table", action="store_true", help="skip the interpolation-error table")
    ap.add_argument("--peer-plane", action="store_true",
                    help="also time each --peer-ffbp-error-db plan with its polar images on the grid's plane "
                         "(surface='plane': what a bent track gets)")
    ap.add_argument("--peer-ffbp-error-db", type=float, nargs="*", default=[],
                    help="also sarnav's FFBP planned for these target errors [dB] on the peer's collect")
    args = ap.parse_args(argv)

    threads = numba.get_num_threads()
    print(f"numba {numba.__version__}, threads {threads}, OMP_NUM_THREADS {os.environ.get('OMP_NUM_THREADS')}, "
          f"cpus {os.cpu_count()}, load average {os.getloadavg()[0]:.1f}")
    if args.rounds > 0:
        own_collect(args, threads)
    for npx in args.peer_sizes:
        peer_collect_table(npx, args.peer_modes, args.peer_ffbp_error_db, args.peer_plane)
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
        for interp, up in (("nearest", 0), ("linear", 0), ("cubic", 0), ("lagrange", 0), ("upsample", 2),
                           ("upsample", 4), ("upsample", 8), ("upsample", 16), ("upsample-lagrange", 2),
                           ("upsample-lagrange", 4)):
            a = backproject(rc_s, small, interpolation=interp, upsample=max(up, 2)).data
            kernel, os_eff = (RANGE_KERNEL[interp], osr * up) if up else (interp, osr)
            pred = 10 * np.log10(interpolation_error(kernel, os_eff))
            row.append(f"{interp}{up if up else ''} {error_db(a, exact):6.1f} ({pred:5.1f})")
        print(f"  fs/B = {osr:4.2f}: " + ", ".join(row) + " dB  (predicted, sarnav.imaging.interpolation_error)")


if __name__ == "__main__":
    main()

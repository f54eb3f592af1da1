"""Benchmark: fast factorised back-projection (sarnav.imaging.ffbp) against sarnav's exact BP, same run.

Usage::

    python benchmarks/bench_ffbp.py                   # 2048^2 and 4096^2 pixels (exact BP timed on a subset)
    python benchmarks/bench_ffbp.py --sizes 512 --peer-sizes 512      # quick
    python benchmarks/bench_ffbp.py --sizes --peer-sizes 2048 4096    # the peer's collect only

Peer collect (``--peer-sizes``, ``benchmarks/peer_collect.py``; skipped with a note without fastsar and finufft):
FastSAR's simulated X-band spotlight (9.6 GHz, 300 MHz, 5 km, 30 deg, 0.25 m pixels, 200 point targets) through
sarnav's CPHD path (``phase_history_to_pulses``, default axis); printed for sarnav's FFBP (kaiser6 and cubic polar
kernels, B = the stored band; and ``ffbp(rc, grid)`` as a user calls it, B from the pulses), sarnav's exact BP (default "auto", timed on ``--exact-pulses`` pulses and scaled) and
FastSAR's FFBP and exact BP (cubic x8; ``--peer-exact`` to time it, it takes as long as sarnav's): time,
pixel-pulses/s, and the error after one complex gain against the exact float64 sum over every pulse and frequency
sample on a uniform 16 x 16 pixel sample.

Scene: X band (9.75 GHz), B = 150 MHz, fs = 2 B, 5 km slant range at 30 deg depression, 0.5 m pixels,
aperture for 0.5 m azimuth resolution with as many pulses as pixels per side (pulse spacing at the
azimuth Nyquist of the scene: the scene fills the PRF band), 300 random point targets.

For each size prints the FFBP time and pixel-pulses/s (image pixels x pulses / time), the exact BP's
pixel-pulses/s (``backproject``, the default interpolation, timed on ``--exact-pulses`` pulses and
scaled: its cost is linear in the pulses), the speed-up, and the FFBP error after one fitted complex
gain against the exact image next to the error model's prediction. The error is the image's: it is
computed with all pulses on a uniform sample of ``--check`` x ``--check`` pixels spread over the whole image
(every npx/check-th pixel in both directions). A central block is not a fair sample on wide scenes: with 300
targets in 2 km x 2 km, the central 128-m block of the 4096^2 scene holds no target, and its error relative to
the sidelobe energy that fills it read -19 dB. FastSAR's FFBP (``fastsar.form_image``, algorithm="ffbp") is timed on
the same phase history when installed (``pip install -e '.[bench]'``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

from sarnav.imaging.backprojection import backproject
from sarnav.imaging.ffbp import ffbp
from sarnav.imaging.grid import GroundGrid, PointGrid, regular_axis
from sarnav.signal.data import PulseData
from sarnav.signal.phase_history import phase_history_to_pulses, pulses_to_phase_history

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from helpers import random_point_scene  # noqa: E402  (the FFBP tests' scene, larger)

C = 299792458.0
FC, BW = 9.75e9, 150e6
LAM = C / FC
SLANT, PX = 5000.0, 0.5


def scene(npx: int, n_targets: int = 300, seed: int = 0, walk: float = 0.0):
    """The own collect; ``walk`` [m]: the antennas on a seeded 3-D random walk of at most that much about the straight
    track (a recorded flight's bent track: FFBP puts its polar images on the grid's plane, ``imaging.ffbp_surface``)."""
    p, w = npx, npx * PX
    pos, tg, amp, rt, east = random_point_scene(npx, p, SLANT, PX, n_targets, seed, LAM)
    if walk > 0:
        steps = np.cumsum(np.random.default_rng(np.random.SeedSequence(seed + 1)).standard_normal((p, 3)), axis=0)
        steps -= steps.mean(axis=0)
        pos = pos + walk * steps / np.abs(steps).max()
        rt = np.linalg.norm(tg[None] - pos[:, None], axis=2)
    dr = C / (4 * BW)
    # the receive window covers every pixel (not only the targets): pixels outside it see no data at all
    corners = np.array([[a, east + b, 0.0] for a in (-w / 2, w / 2) for b in (-w / 2, w / 2)] + [[0.0, east - w / 2, 0.0]])
    rp = np.linalg.norm(corners[None] - pos[[0, p // 2, -1]][:, None], axis=2)
    r0 = min(rt.min(), rp.min()) - 30 * dr
    n = int((max(rt.max(), rp.max()) - r0) / dr) + 30
    data = np.zeros((p, n), np.complex64)
    centre = np.floor((rt - r0) / dr).astype(int)
    for j in range(-48, 49):                      # truncated sinc (the same data feed both algorithms)
        idx = np.clip(centre + j, 0, n - 1)
        val = (amp[None] * np.sinc(2 * BW / C * (r0 + idx * dr - rt)) * np.exp(-4j * np.pi * rt / LAM))
        np.add.at(data, (np.repeat(np.arange(p), n_targets), idx.ravel()), val.ravel().astype(np.complex64))
    rc = PulseData(data, r0 + np.arange(n) * dr, np.arange(p) * 1e-3, pos, None, compressed=True, wavelength=LAM)
    grid = GroundGrid(regular_axis(-0.5 * PX, PX, npx, "grid.north"), regular_axis(east - 0.5 * PX, PX, npx, "grid.east"))
    return rc, grid, east


def gain_error_db(img, ref) -> float:
    g = np.vdot(img, ref) / np.vdot(img, img)
    return float(10 * np.log10(np.sum(np.abs(g * img - ref) ** 2) / np.sum(np.abs(ref) ** 2)))


def timed(fn, repeat: int = 1):
    """(best wall [s], best CPU time / threads [s], result) over ``repeat`` calls (the machine may be shared)."""
    best_w, best_c, out = np.inf, np.inf, None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        best_w = min(best_w, time.perf_counter() - t0)
        best_c = min(best_c, (time.process_time() - c0) / numba.get_num_threads())
    return best_w, best_c, out


def fastsar_ffbp(rc, npx, east):
    try:
        import fastsar
    except ImportError:
        return None
    centre = np.array([0.0, east, 0.0])
    ant = rc.positions - centre
    ph = pulses_to_phase_history(rc, np.linalg.norm(ant, axis=1))
    s = ph.data.astype(np.complex64)

    def run():
        return fastsar.form_image(s, ant, ph.fx0[0], ph.fx_step[0], npx, npx, PX, PX, (1.0, 0.0, 0.0),
                                  (0.0, 1.0, 0.0), algorithm="ffbp", window=False, target_db=-40.0)
    run()
    return timed(run)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[2048, 4096], help="own collect sizes (none: skip it)")
    ap.add_argument("--exact-pulses", type=int, default=64, help="pulses the exact BP is timed on")
    ap.add_argument("--check", type=int, default=256, help="pixels per side of the uniform sample compared with exact BP")
    ap.add_argument("--oversample", type=float, default=2.0, help="polar samples per Nyquist sample (ffbp's default)")
    ap.add_argument("--kernel", default="kaiser6", help="polar interpolation kernel: kaiser6 (default) or cubic")
    ap.add_argument("--interpolation", default="auto", help="level-0 range interpolation (ffbp's default: auto)")
    ap.add_argument("--upsample", type=int, default=8, help="range upsampling under --interpolation upsample*")
    ap.add_argument("--peer-oversample", type=float, nargs="*", default=[2.0, 2.4],
                    help="FFBP os values on the peer's collect (kaiser6)")
    ap.add_argument("--peer-whole", action="store_true", help="also the whole-image error on the peer's collect, "
                    "against sarnav's 'precise' exact BP (-86 dB; one more exact image)")
    ap.add_argument("--track-walk", type=float, default=0.0, metavar="M",
                    help="own collect: the antennas on a 3-D random walk of at most M metres (a bent track)")
    ap.add_argument("--repeat", type=int, default=2, help="FFBP and FastSAR calls timed (best of; the own exact BP is "
                    "best of 2, the peer-collect exact BP one call)")
    ap.add_argument("--no-fastsar", action="store_true", help="skip FastSAR's FFBP")
    ap.add_argument("--peer-error-db", type=float, nargs="*", default=[],
                    help="on the peer collect, also time ffbp(..., error_db=T) for each target T (the plan it picks)")
    ap.add_argument("--peer-sizes", type=int, nargs="*", default=[2048], help="image sizes on the peer's collect")
    ap.add_argument("--peer-exact", action="store_true", help="time FastSAR's exact BP (cubic x8) on the peer collect")
    args = ap.parse_args(argv)
    print(f"numba {numba.__version__}, threads {numba.get_num_threads()}, load average {os.getloadavg()[0]:.1f}")
    for npx in args.sizes:
        rc, grid, east = scene(npx, walk=args.track_walk)
        p = rc.n_pulses
        work = npx * npx * p
        kw = dict(bandwidth=BW, oversample=args.oversample, kernel=args.kernel, interpolation=args.interpolation,
                  upsample=args.upsample)
        ffbp(rc, GroundGrid.centered(0.0, east, PX, (16, 16)), **kw)      # compile
        t_f, c_f, img = timed(lambda: ffbp(rc, grid, **kw), args.repeat)
        sub = slice(0, min(args.exact_pulses, p))
        rc_sub = PulseData(rc.data[sub], rc.slant_range, rc.pulse_times[sub], rc.positions[sub], None, True,
                           wavelength=LAM)
        backproject(rc_sub, GroundGrid.centered(0.0, east, PX, (8, 8)))
        t_e, c_e, _ = timed(lambda: backproject(rc_sub, grid), 2)
        t_e, c_e = t_e * p / rc_sub.n_pulses, c_e * p / rc_sub.n_pulses
        stride = max(1, npx // args.check)
        sample = (slice(stride // 2, None, stride), slice(stride // 2, None, stride))
        # reference: exact BP with the pulses upsampled x16 (linear at 32 x Nyquist: -68 dB, an ideal reference for
        # the FFBP's error, which includes its own level-0 range interpolation)
        ref = backproject(rc, PointGrid(grid.points()[sample]), interpolation="upsample", upsample=16).data
        err = gain_error_db(img.data[sample], ref)
        md = img.metadata
        final = md["ffbp_base_pulses"] * md["ffbp_merge"] ** md["ffbp_levels"]
        print(f"{npx}^2 px x {p} pulses: ffbp {t_f:7.2f} s wall, {c_f:7.2f} s CPU/thread ({work / t_f:9.3e} px-pulse/s); "
              f"exact BP {t_e:8.2f} s wall, {c_e:8.2f} s CPU/thread ({work / t_e:9.3e}); speed-up {t_e / t_f:5.1f}x wall, "
              f"{c_e / c_f:5.1f}x CPU (goal >= 10x at 2048^2); error {err:6.1f} dB (predicted "
              f"{md['ffbp_predicted_error_db']:6.1f}); tile: subapertures of {md['ffbp_base_pulses']} pulses, "
              f"{md['ffbp_levels']} merges of {md['ffbp_merge']} -> {final} pulses, polar cell c/(2B os) x "
              f"lambda/(2 l os), os {md['ffbp_oversample']}, kernel {md['ffbp_kernel']}, range {_range(md)}, polar "
              f"images on the {md['ffbp_surface']}" + (f" (track: {args.track_walk:g} m random walk)"
                                                      if args.track_walk else ""), flush=True)
        peer = fastsar_ffbp(rc, npx, east) if not args.no_fastsar else None
        if peer is not None:
            t_p, c_p, img_p = peer
            print(f"    fastsar ffbp {t_p:7.2f} s wall, {c_p:7.2f} s CPU/thread ({work / t_p:9.3e}); sarnav / fastsar "
                  f"time {t_f / t_p:5.2f} wall, {c_f / c_p:5.2f} CPU (goal <= 2); fastsar error vs sarnav exact "
                  f"{gain_error_db(np.asarray(img_p)[sample], ref):6.1f} dB", flush=True)
    for npx in args.peer_sizes:
        peer_table(npx, args)


def _range(md) -> str:
    """The level-0 range interpolation an FFBP image used and its plan (its metadata): subaperture pulses, merges and
    how they interpolated (two 1-D passes or the 2-D kernel, ``ffbp_merge``)."""
    mode = md.get("interpolation")
    rng = f"{mode} x{md.get('upsample')}" if str(mode).startswith("upsample") else str(mode)
    passes = {2: "two-pass", 1: "2-D"}.get(md.get("ffbp_merge_passes"), "?")
    return f"{rng}; base {md.get('ffbp_base_pulses')}, {md.get('ffbp_levels')} {passes} merges"


def peer_table(npx: int, args) -> None:
    """sarnav's FFBP and exact BP and FastSAR's on the peer's collect (module doc)."""
    import peer_collect as pc

    made = pc.peer_collect(npx)
    if made is None:
        print(f"peer collect {npx}^2: {pc.peer_available()}")
        return
    ph, _ = made
    rc = phase_history_to_pulses(ph)
    exact = pc.exact_sample(ph, npx)
    sample = pc.sample_index(npx)
    p = ph.n_pulses
    work = npx * npx * p
    grid, small = pc.plane_grid(npx), pc.plane_grid(32)
    print(f"peer collect {npx}^2 x {p} pulses, {ph.data.shape[1]} frequency samples; sarnav pulses "
          f"{rc.data.shape[1]} range samples (fs/B {C / (2 * (rc.slant_range[1] - rc.slant_range[0])) / rc.metadata['stored_band_hz']:.2f})",
          flush=True)
    sub = slice(0, min(args.exact_pulses, p))
    rc_sub = PulseData(rc.data[sub], rc.slant_range, rc.pulse_times[sub], rc.positions[sub], None, True,
                       wavelength=rc.wavelength)
    backproject(rc_sub, small)
    t_e, _, exact_img = timed(lambda: backproject(rc_sub, grid), 1)
    t_e *= p / rc_sub.n_pulses
    scaled = f"timed on {rc_sub.n_pulses} pulses, scaled" if rc_sub.n_pulses < p else "all pulses"
    err_e = f"{pc.gain_error_db(exact_img.data[sample], exact):7.1f} dB" if rc_sub.n_pulses == p else "see bench_bpa.py"
    print(f"  {'sarnav exact BP auto':26s} {t_e:8.2f} s {work / t_e:9.3e} px-pulse/s ({scaled})  error vs exact: "
          f"{err_e}", flush=True)
    whole = backproject(rc, grid, interpolation="precise").data if args.peer_whole else None
    runs = [("kaiser6", o) for o in args.peer_oversample] + [("cubic", 2.0)]
    for kernel, os_ in runs:
        kw = dict(bandwidth=rc.metadata["stored_band_hz"], kernel=kernel, oversample=os_)
        ffbp(rc, small, **kw)
        t_f, _, img = timed(lambda: ffbp(rc, grid, **kw), args.repeat)
        also = "" if whole is None else f", whole image vs precise BP {pc.gain_error_db(img.data, whole):6.1f} dB"
        print(f"  {f'sarnav ffbp {kernel} os {os_:g}':26s} {t_f:8.2f} s {work / t_f:9.3e} px-pulse/s  error vs exact "
              f"{pc.gain_error_db(img.data[sample], exact):7.1f} dB (predicted {img.metadata['ffbp_predicted_error_db']:.1f}"
              f"{also}); {t_e / t_f:5.1f}x sarnav's exact BP; range {_range(img.metadata)}", flush=True)
    for target in args.peer_error_db:
        kw = dict(bandwidth=rc.metadata["stored_band_hz"], error_db=target)
        ffbp(rc, small, **kw)
        t_f, _, img = timed(lambda: ffbp(rc, grid, **kw), args.repeat)
        md = img.metadata
        also = "" if whole is None else f", whole image vs precise BP {pc.gain_error_db(img.data, whole):6.1f} dB"
        print(f"  {f'sarnav ffbp error_db {target:g}':26s} {t_f:8.2f} s {work / t_f:9.3e} px-pulse/s  error vs exact "
              f"{pc.gain_error_db(img.data[sample], exact):7.1f} dB (predicted {md['ffbp_predicted_error_db']:.1f}"
              f"{also}); {t_e / t_f:5.1f}x sarnav's exact BP; {md['ffbp_kernel']} os {md['ffbp_oversample']:g}, "
              f"range {_range(md)}", flush=True)
    # the call as a user writes it: no band given, ffbp takes the pulses' (ffbp_bandwidth_hz); before 2026-12-06 it took
    # the sample rate (fs/B 4 here), which made every polar grid 4x finer in range
    t_d, _, img = timed(lambda: ffbp(rc, grid), args.repeat)
    print(f"  {'sarnav ffbp(rc, grid)':26s} {t_d:8.2f} s {work / t_d:9.3e} px-pulse/s  error vs exact "
          f"{pc.gain_error_db(img.data[sample], exact):7.1f} dB (predicted {img.metadata['ffbp_predicted_error_db']:.1f}); "
          f"{t_e / t_d:5.1f}x sarnav's exact BP; band {img.metadata['ffbp_bandwidth_hz'] / 1e6:.1f} MHz (stored "
          f"{rc.metadata['stored_band_hz'] / 1e6:.1f}); range {_range(img.metadata)}", flush=True)
    if args.no_fastsar or pc.peer_available() is not None:
        print("  fastsar skipped" + ("" if args.no_fastsar else f": {pc.peer_available()}"))
        return
    peer = [("fastsar ffbp", dict(algorithm="ffbp"))]
    if args.peer_exact:
        peer.append(("fastsar bp cubic x8", dict(algorithm="bp", interp="cubic")))
    for name, kw in peer:
        pc.fastsar_image(ph, 32, **kw)
        t_p, img = min((pc.timed(lambda: pc.fastsar_image(ph, npx, **kw)) for _ in range(args.repeat)),
                       key=lambda t: t[0])
        print(f"  {name:26s} {t_p:8.2f} s {work / t_p:9.3e} px-pulse/s  error vs exact "
              f"{pc.gain_error_db(np.asarray(img)[sample], exact):7.1f} dB", flush=True)


if __name__ == "__main__":
    main()

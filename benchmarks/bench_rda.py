"""Benchmark: RDA time against the time of the azimuth FFTs it needs, timed in the same run.

Usage::

    python benchmarks/bench_rda.py                         # the three default sizes
    python benchmarks/bench_rda.py --sizes 1024x2048 --repeat 5

For each size P x N (pulses x range bins) it times, best of ``--repeat`` after one warm-up call
(numba compilation excluded):

* ``rda``: ``sarnav.imaging.rda.range_doppler`` (azimuth FFT, 8-tap RCMC + matched filter,
  inverse FFT, axes and metadata);
* ``ffts``: the forward and inverse azimuth FFTs of a P x N complex128 array with ``scipy.fft``
  (same call, same axis, default workers) — the floor any FFT-based RDA must pay;

and prints both and their ratio (goal: within 3x). The PRF is chosen so that the Doppler band of
the block, K_a T, fills 80 % of it (every row is processed). Also ``rda full band``
(``band_limit=0``: every range-Doppler sample interpolated and filtered, the worst case) and
``rda no RCMC`` (``rcmc_kernel="none"``, phase multiply only) to show what the interpolation costs. Default sizes: the paper's simulation
block (100 x 1401, thesis Table 5.1), a FlexSAR-like block (1667 x 547, Table 5.3) and a
2048 x 2048 block. Data: random complex values (timing does not depend on content).
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.fft as sfft

from sarnav.signal.data import PulseData
from sarnav.imaging.rda import range_doppler
from sarnav.units import C
from timing import best_time

FC, FS, SPEED, R_NEAR = 9.75e9, 1e9, 60.0, 1950.0


def make_pulses(p: int, n: int, seed: int = 0) -> PulseData:
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    data = rng.standard_normal((p, n)) + 1j * rng.standard_normal((p, n))
    r_mid = R_NEAR + 0.5 * n * C / (2 * FS)
    k_a = 2 * SPEED**2 / (C / FC * r_mid)
    prf = float(np.sqrt(k_a * p / 0.8))  # K_a T = K_a p / prf = 0.8 prf
    t = np.arange(p) / prf
    pos = np.zeros((p, 3))
    pos[:, 0] = SPEED * t
    r = R_NEAR + np.arange(n) * C / (2 * FS)
    return PulseData(data, r, t, pos, compressed=True, wavelength=C / FC, bandwidth=500e6)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["100x1401", "1667x547", "2048x2048"])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    print(f"{'P x N':>11} {'ffts [ms]':>10} {'rda [ms]':>9} {'ratio':>6} {'full band [ms]':>15} {'ratio':>6} "
          f"{'no RCMC [ms]':>13} {'ratio':>6}")
    for size in args.sizes:
        p, n = (int(v) for v in size.lower().split("x"))
        rc = make_pulses(p, n)
        x = rc.data

        def ffts():
            sfft.ifft(sfft.fft(x, axis=0), axis=0)

        t_fft = best_time(ffts, args.repeat, warm_up=True)
        t_rda = best_time(lambda: range_doppler(rc, SPEED, window="none"), args.repeat, warm_up=True)
        t_full = best_time(lambda: range_doppler(rc, SPEED, window="none", band_limit=0.0), args.repeat,
                           warm_up=True)
        t_nor = best_time(lambda: range_doppler(rc, SPEED, window="none", rcmc_kernel="none"), args.repeat, warm_up=True)
        print(f"{size:>11} {1e3 * t_fft:10.2f} {1e3 * t_rda:9.2f} {t_rda / t_fft:6.2f} {1e3 * t_full:15.2f} "
              f"{t_full / t_fft:6.2f} {1e3 * t_nor:13.2f} {t_nor / t_fft:6.2f}")


if __name__ == "__main__":
    main()

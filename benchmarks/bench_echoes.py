"""Throughput of the compiled echo simulator against a vectorised numpy version of the same model.

Run:  python benchmarks/bench_echoes.py [--pulses 1024 --samples 2048 --targets 50]

Prints target-pulse-samples per second (P * K * N / wall time) of both, their ratio, and the
maximum absolute difference of the outputs. Both are timed in the same run (the numba kernel after
one warm-up call, so compilation is excluded).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sarnav.radar.antenna import along_track_directions, gain
from sarnav.radar.echoes import simulate_echoes
from sarnav.radar.params import RadarParams
from sarnav.radar.scene import random_scatterers
from sarnav.units import C


def simulate_numpy(params, positions, times, scene, chunk=8):
    """Same model as ``simulate_echoes`` (pattern on), vectorised over (pulses, targets, samples)."""
    t = 2 * params.near_range / C + np.arange(params.n_range_samples) / params.sample_rate
    along = along_track_directions(positions, times)
    out = np.empty((positions.shape[0], t.size), np.complex128)
    for s in range(0, positions.shape[0], chunk):
        pos = positions[s:s + chunk]
        r = np.linalg.norm(scene.positions[None] - pos[:, None], axis=-1)  # (p,K)
        g = gain(pos, along[s:s + chunk], scene.positions, params.effective_antenna_length,
                 params.wavelength, params.look_side)
        a = scene.amplitudes[None] * g * np.exp(-4j * np.pi * params.carrier_frequency * r / C)
        dt = t[None, None, :] - (2 * r / C)[..., None]  # (p,K,N)
        chirp = np.where(np.abs(dt) <= 0.5 * params.pulse_length,
                         np.exp(1j * np.pi * params.chirp_rate * dt * dt), 0)
        out[s:s + chunk] = np.einsum("pk,pkn->pn", a, chirp)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pulses", type=int, default=1024)
    ap.add_argument("--samples", type=int, default=2048)
    ap.add_argument("--targets", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    p = RadarParams(carrier_frequency=9.75e9, bandwidth=500e6, pulse_length=1e-6, sample_rate=1e9,
                    prf=100.0, near_range=2000.0, n_range_samples=args.samples, antenna_length=0.2)
    lo, hi = p.target_range_limits
    rng = np.random.default_rng(np.random.SeedSequence(args.seed))
    alt = 1000.0
    n = args.pulses
    times = np.arange(n) / p.prf
    pos = np.column_stack([10.0 * times, np.zeros(n), -alt * np.ones(n)])
    # targets on the ground, inside the receive window at every pulse, along the aperture
    g_lo, g_hi = np.sqrt((lo + 1) ** 2 - alt**2), np.sqrt((hi - 3) ** 2 - alt**2)
    density = args.targets / ((pos[-1, 0] - pos[0, 0] + 1.0) * (g_hi - g_lo))
    scene = random_scatterers(rng, ((pos[0, 0], pos[-1, 0] + 1.0), (g_lo, g_hi)), density)
    k = len(scene)

    simulate_echoes(p, pos[:4], times[:4], scene)  # warm-up / compile
    t0 = time.perf_counter()
    fast = simulate_echoes(p, pos, times, scene).data
    t_numba = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref = simulate_numpy(p, pos, times, scene)
    t_numpy = time.perf_counter() - t0

    work = n * k * p.n_range_samples
    print(f"pulses={n} samples={p.n_range_samples} targets={k} (pulse {p.pulse_length * p.sample_rate:.0f} samples)")
    print(f"numba : {t_numba:8.3f} s  {work / t_numba:10.3e} target-pulse-samples/s")
    print(f"numpy : {t_numpy:8.3f} s  {work / t_numpy:10.3e} target-pulse-samples/s")
    print(f"speed-up numba/numpy: {t_numpy / t_numba:.1f}x")
    print(f"max |difference|: {np.max(np.abs(fast - ref)):.3e} (peak |echo| {np.max(np.abs(ref)):.3f})")


if __name__ == "__main__":
    main()

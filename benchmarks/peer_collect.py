"""The peer's simulated collect for bench_bpa.py and bench_ffbp.py, and the exact image both tools are measured against.

FastSAR's simulator (``fastsar.sim``, MIT, PyPI ``fastsar``; its phase history by NUFFT needs ``finufft``): an X-band
spotlight, 9.6 GHz, 300 MHz (0.5 m resolution), 5 km, 30 deg graze, 0.25 m pixels, an npx x npx ground image, 200
unit-modulus point targets spread over 90 % of it. sarnav reads it through its own user path: the ``PhaseHistory`` its
CPHD reader builds from such a file (``fastsar.sim.write_cphd``: FX domain, SGN -1, compensated to the scene centre,
TOA1/2 = -+0.45 / SCSS), then ``phase_history_to_pulses`` with its default range axis.

Exact image: ``A(p) = sum_k sum_n S_k(f_n) exp(+j 4 pi f_n (|p - a_k| - |a_k|) / c)``, a float64 numpy sum over
every pulse and frequency sample, on a uniform 16 x 16 sample of the pixels (every npx/16-th pixel, from the
middle of the first block); error ``10 log10(|g a - b|^2 / |b|^2)`` after one fitted complex gain g.
Without fastsar (or finufft) :func:`peer_collect` returns None and the callers skip the peer's collect and
columns with a note.
"""

from __future__ import annotations

import time

import numpy as np

C = 299792458.0
PIXEL = 0.25


def peer_available() -> str | None:
    """None when fastsar and finufft import, else the reason (a note to print)."""
    try:
        import fastsar  # noqa: F401
        import finufft  # noqa: F401
    except ImportError as err:
        return f"{err.name} not installed (pip install -e '.[bench]'): the peer's collect and columns are skipped"
    return None


def peer_collect(npx: int, n_targets: int = 200, seed: int = 0):
    """(PhaseHistory, fastsar Collect) of FastSAR's simulated spotlight for an npx x npx image, or None. With the
    environment variable ``SARNAV_PEER_CACHE`` set to a folder, the simulated phase history is kept there as .npy
    (the NUFFT of a 4096^2 collect takes minutes on a loaded machine; bench_bpa and bench_ffbp share it)."""
    if peer_available() is not None:
        return None
    import os
    from pathlib import Path

    from fastsar import sim

    from sarnav.signal.phase_history import PhaseHistory

    col = sim.make_collect(res=0.5, scene=npx * PIXEL, r0=5000.0, graze_deg=30.0, fc=9.6e9)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    half = 0.45 * npx * PIXEL
    tg = np.column_stack([rng.uniform(-half, half, n_targets), rng.uniform(-half, half, n_targets), np.zeros(n_targets)])
    amp = np.exp(2j * np.pi * rng.uniform(size=n_targets))
    cache = os.environ.get("SARNAV_PEER_CACHE")
    path = Path(cache) / f"peer_{npx}_{n_targets}_{seed}.npy" if cache else None
    if path is not None and path.exists():
        s = np.load(path)
    else:
        s = sim.simulate(col, tg, amp)
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            np.save(path, s)
    p = s.shape[0]
    toa = np.column_stack([np.full(p, -0.45 / col.df), np.full(p, 0.45 / col.df)])
    ph = PhaseHistory(s, col.fmin, col.df, col.ant, np.linalg.norm(col.ant, axis=1), np.arange(p) * 1e-3, toa, -1)
    return ph, col


def axis(npx: int) -> np.ndarray:
    """Pixel coordinates of FastSAR's grid along either axis: (i - npx/2) * 0.25 m."""
    return (np.arange(npx) - npx / 2) * PIXEL


def plane_grid(npx: int):
    """sarnav's PlaneGrid of the same pixels (x across track, y along track, z up; the scene centre at the origin)."""
    from sarnav.imaging.grid import PlaneGrid

    return PlaneGrid(np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), axis(npx), axis(npx), "x", "y")


def sample_index(npx: int, n: int = 16) -> tuple[slice, slice]:
    """The uniform n x n pixel sample: every npx/n-th pixel in both directions."""
    st = max(1, npx // n)
    return slice(st // 2, None, st), slice(st // 2, None, st)


def exact_at(ph, pts: np.ndarray) -> np.ndarray:
    """The exact image (module doc) at points (M, 3), complex128: per point and pulse the sum over the frequency
    samples f_n = f_0 + n df by Horner's rule in w = exp(j 4 pi df d / c) (float64 d = |p - a_k| - R_ref,k; the
    rounding grows as N eps, 1e-12 for N = 4096), times exp(j 4 pi f_0 d / c)."""
    d = np.linalg.norm(pts[:, None, :] - ph.positions[None], axis=2) - ph.ref_range[None]      # (M, P)
    w = np.exp(4j * np.pi * ph.fx_step[None] * d / C)
    acc = np.zeros(d.shape, complex)
    for n in range(ph.data.shape[1] - 1, -1, -1):
        acc *= w
        acc += ph.data[None, :, n]
    return np.sum(acc * np.exp(4j * np.pi * ph.fx0[None] * d / C), axis=1)


def exact_sample(ph, npx: int) -> np.ndarray:
    """The exact image on the uniform 16 x 16 sample (:func:`sample_index`), (16, 16)."""
    ax = axis(npx)[sample_index(npx)[0]]
    x, y = np.meshgrid(ax, ax, indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    return exact_at(ph, pts).reshape(x.shape)


def gain_error_db(img, ref) -> float:
    img, ref = np.asarray(img).ravel(), np.asarray(ref).ravel()
    g = np.vdot(img, ref) / np.vdot(img, img)
    return float(10 * np.log10(np.sum(np.abs(g * img - ref) ** 2) / np.sum(np.abs(ref) ** 2)))


def fastsar_image(ph, npx: int, algorithm: str, **kw):
    """FastSAR's image of the phase history on the grid of :func:`axis` (complex64 (npx, npx), x first)."""
    import fastsar

    s = np.ascontiguousarray(ph.data.astype(np.complex64))
    return fastsar.form_image(s, ph.positions, float(ph.fx0[0]), float(ph.fx_step[0]), npx, npx, PIXEL, PIXEL,
                              (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), algorithm=algorithm, window=False, **kw)


def timed(fn):
    """(wall seconds, result) of one call."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out

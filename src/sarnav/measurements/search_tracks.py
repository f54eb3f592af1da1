"""The track arithmetic of Hathaway (2023) Alg. 3.3 (notes/seed-004 §2.6): the Table 4.1 grids, the knots and the
end-point linearisation, the injected velocity noise, the candidate offsets, rho and the bounds on what a search can
reach. Pure numpy on (P, 3) tracks; :mod:`sarnav.measurements.focus_search` runs the searches on them.
"""

from __future__ import annotations

import math

import numpy as np

from sarnav.errors import ConfigError, InputDataError

__all__ = ["METHODS", "TABLE41_BIAS", "table41_sigmas", "table41_spacings", "checked_int", "block_knots", "linearise",
           "inject_velocity_noise", "candidate_offsets", "variance_ratio", "coverage", "reach_bound"]

#: search methods: the thesis' grid, the spanning grid with parabola refinement, Brent, and the Viterbi search over
#: candidate positions (the thesis' future work, L730)
METHODS = ("source", "grid", "brent", "viterbi")
#: Table 4.1 (L656-670): the velocity bias [m/sample]
TABLE41_BIAS = 8.1641e-6


def table41_sigmas(n: int = 10) -> np.ndarray:
    """sigma = linspace(8.1641e-6, 8.1641e-5, 10) [m/sample] (Table 4.1; VRW 0.02..0.2 m/s/sqrt(h) at 1667 Hz)."""
    return np.linspace(8.1641e-6, 8.1641e-5, n)


def table41_spacings(sigma: float, n: int = 30) -> np.ndarray:
    """Delta = linspace(sigma/1e4, 30 sigma/1e4, 30) [m/sample] (Table 4.1, L652)."""
    return np.linspace(sigma / 1e4, 30.0 * sigma / 1e4, n)


def checked_int(name: str, value, lo: int) -> int:
    """``value`` as an int, or a ConfigError naming ``name`` unless it is an integer >= ``lo``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo:
        raise ConfigError(name, f"must be an integer >= {lo}, got {value!r}")
    return int(value)


def block_knots(n_pulses: int, initial_pulses: int, block_pulses: int) -> np.ndarray:
    """Knots of the linearisation: S_0 - 1 + k S_i forward to the last sample and backward to 0 (both included)."""
    n = checked_int("n_pulses", n_pulses, 2)
    s0 = checked_int("search.initial_pulses", initial_pulses, 1)
    si = checked_int("search.block_pulses", block_pulses, 1)
    if s0 >= n:
        raise ConfigError("search.initial_pulses", f"must be < the number of pulses {n}, got {s0}")
    if si > n - s0:
        raise ConfigError("search.block_pulses", f"block of {si} pulses is longer than the {n - s0} pulses after "
                          f"the initial {s0}; must be <= {n - s0}")
    fwd = np.arange(s0 - 1, n - 1, si)
    back = np.arange(s0 - 1 - si, 0, -si)[::-1]
    return np.unique(np.concatenate([[0], back, fwd, [n - 1]]))


def linearise(positions, knots) -> np.ndarray:
    """End-point piecewise-linear track through ``positions[knots]`` (Alg. 3.3 step 1, L414/L457); exact at knots."""
    p = np.asarray(positions, dtype=np.float64)
    k = np.asarray(knots)
    out = np.empty_like(p)
    for a, b in zip(k[:-1], k[1:]):
        frac = (np.arange(a, b + 1) - a) / float(b - a)
        out[a:b + 1] = p[a] + frac[:, None] * (p[b] - p[a])[None, :]
    out[k] = p[k]
    return out


def inject_velocity_noise(positions, direction, initial_pulses: int, bias: float, sigma: float, w) -> np.ndarray:
    """Noisy track of Alg. 3.3 steps 2-4: ``p~[t] = p[t] + e sum_{s=S_0}^{t} (b + sigma w[s])``, t >= S_0.

    ``w`` is the (P,) standard normal vector (entries before S_0 unused).
    """
    p = np.asarray(positions, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    if w.shape != (p.shape[0],):
        raise InputDataError("w", f"must have shape ({p.shape[0]},), got {w.shape}")
    e = np.asarray(direction, dtype=np.float64)
    out = p.copy()
    drift = np.cumsum(bias + sigma * w[initial_pulses:])
    out[initial_pulses:] += drift[:, None] * e[None, :]
    return out


def candidate_offsets(method: str, candidates: int, spacing: float = 0.0, span: float = 0.0) -> np.ndarray:
    """(L,) velocity offsets [m/sample]: ``(l - floor(L/2)) Delta`` ("source", L651) or linspace(-span, span, L)."""
    n = checked_int("search.candidates", candidates, 1)
    if method == "source":
        return (np.arange(n) - n // 2) * float(spacing)
    if method in ("grid", "brent", "viterbi"):
        return np.linspace(-span, span, n) if n > 1 else np.zeros(1)
    raise ConfigError("search.method", f"must be one of {METHODS}, got {method!r}")


def variance_ratio(corrected, noisy, truth, direction, initial_pulses: int) -> float:
    """rho = var(e.(p_corr - p_true)) / var(e.(p_noisy - p_true)) over t >= S_0, ddof = 1 (L668, gap 12)."""
    e = np.asarray(direction, dtype=np.float64)
    s = slice(initial_pulses, None)
    num = np.var((np.asarray(corrected)[s] - np.asarray(truth)[s]) @ e, ddof=1)
    den = np.var((np.asarray(noisy)[s] - np.asarray(truth)[s]) @ e, ddof=1)
    if den == 0:
        raise InputDataError("noisy", "has no along-track error after the initial pulses; rho undefined")
    return float(num / den)


def coverage(candidates: int, spacing: float, bias: float, sigma: float, block_pulses: int) -> float:
    """Largest candidate offset over the offset it must reach: floor(L/2) Delta / (|b| + 2 sigma / sqrt(S_i))
    (notes/seed-004 §3.3: the grid cannot cancel the bias unless this is >~ 1)."""
    return (candidates // 2) * spacing / (abs(bias) + 2.0 * sigma / math.sqrt(block_pulses))


def reach_bound(noisy, truth, direction, initial_pulses: int, max_slope) -> float:
    """B such that every correction the search can make gives (1 - B)^2 <= rho <= (1 + B)^2 (docs/quality.md §5).

    The correction c[t] = e.(p_corr - p~_lin)[t] starts at 0 at S_0 - 1 and changes by at most ``max_slope`` per
    sample: a number (the largest |offset| the search can choose, the thesis restarting each block) or an array of
    one bound per sample after S_0 (keeping the chosen offsets: k times the largest offset in the k-th block). With
    C[t] = the running sum of those bounds, |c[x] - c[y]| <= |C[x] - C[y]| for every pair of samples, so var(c) =
    mean over pairs of (c[x] - c[y])^2 / 2 <= var(C) (for a constant bound m, C = m t: the ramp is the extreme);
    with a = e.(p~_lin - p_lin), the triangle inequality of the standard deviation gives |std(a + c) - std(a)| <=
    std(c), i.e. |sqrt(rho) - 1| <= B = std(C) / std(a).
    """
    e = np.asarray(direction, dtype=np.float64)
    a = (np.asarray(noisy)[initial_pulses:] - np.asarray(truth)[initial_pulses:]) @ e
    t = np.arange(a.size, dtype=np.float64)
    den = np.std(a, ddof=1)
    if den == 0:
        raise InputDataError("noisy", "has no along-track error after the initial pulses; rho undefined")
    if np.ndim(max_slope) == 0:
        return float(abs(max_slope) * np.std(t, ddof=1) / den)
    slopes = np.abs(np.asarray(max_slope, dtype=np.float64))
    if slopes.shape != a.shape:
        raise InputDataError("max_slope", f"must be a number or one bound per sample after S_0 ({a.size}), got "
                             f"shape {slopes.shape}")
    return float(np.std(np.cumsum(slopes), ddof=1) / den)

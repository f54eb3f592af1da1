"""The GPS-denied velocity-offset search of Hathaway (2023), Algorithms 3.2/3.3, its controls and better searches.

Algorithm 3.3 (thesis L412-459; notes/seed-004 §2.6), exactly:

1. end-point linearisation of the true track in chunks of S_i samples (L414, L457): knots t_k, and
   ``p_lin[t] = p[t_k] + (t - t_k)/(t_{k+1} - t_k) (p[t_{k+1}] - p[t_k])``;
2.-4. per-sample "velocity" v[t] = p[t] - p[t-1] plus along-track noise ``(b + sigma w[t]) e`` from sample
   S_0 on, re-integrated: ``p~[t] = p[t] + e sum_{s=S_0}^{t} (b + sigma w[s])`` (GPS until S_0, L459);
5. the noisy track linearised on the same knots;
6.-7. the initial image: BPA of pulses 0..S_0-1 with the true positions, copied into the L slots;
8. for each block of S_i pulses t_k+1..t_{k+1}: candidate l has velocity offset
   ``delta_l = (l - floor(L/2)) Delta`` [m/sample] (L651-652; L even: -L/2 .. L/2 - 1) and positions
   ``p_l[t] = p_best[t_k] + sum_{s=t_k+1}^{t} (v~_lin[s] + delta_l e)`` (L443); each image is the accumulated
   image plus the block back-projected along p_l; all are scored; the best image and track are copied into
   every slot (greedy, L451);
9. ``rho = var(e.(p_corr - p_lin)) / var(e.(p~_lin - p_lin))`` over the samples t >= S_0 (L668).

Decisions on the gaps (docs/quality.md): knots at S_0 - 1 + k S_i (so every block is one chunk), the scorer
is kurtosis (3.5), arg max (gap 11); rho uses the along-track component, samples t >= S_0 and the sample
variance (ddof = 1, MATLAB ``var``) (gap 12); one noise vector w per realisation and sigma, shared by the 30
spacings (gap 13, Fig. 4.25b); sigma and b are per-sample position-increment statistics as in the thesis
(gap 14).

The candidate images come from :mod:`sarnav.imaging.offset_bpa` (one pass over a block's pulses for every
offset, exact to a stated phase tolerance). Methods (``method``):

* ``"source"``: the grid above, the thesis' algorithm;
* ``"grid"``: L candidates spanning +- ``span`` (a grid that covers the bias and the block noise), best
  candidate refined by the vertex of the parabola through it and its neighbours;
* ``"brent"``: the best of the spanning grid, then bounded Brent (scipy) on the score between its neighbours.

Scorers (``scorer``): any name of :data:`sarnav.imaging.quality.QUALITY_MEASURES`, or the controls
``"oracle"`` (the candidate closest to the true track over the block: knows the truth), ``"anti-oracle"`` (the
candidate farthest from it: the most biased scorer there is, what bounds rho from above) and ``"random"`` (a
uniformly drawn candidate). With one candidate (L = 1) the corrected track is the noisy linearised one
and rho = 1 exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import minimize_scalar

from sarnav.errors import ConfigError, InputDataError, SarnavError
from sarnav.imaging.backprojection import backproject
from sarnav.imaging.grid import GroundGrid
from sarnav.imaging.range_compression import range_compress
from sarnav.imaging.offset_bpa import offset_moments, order_for
from sarnav.imaging.quality import QUALITY_MEASURES, quality_measure
from sarnav.measurements.search_tracks import (METHODS, TABLE41_BIAS, block_knots, candidate_offsets, checked_int,
                                               coverage, inject_velocity_noise, linearise, reach_bound, table41_sigmas,
                                               table41_spacings, variance_ratio)
from sarnav.radar.quality_scenes import simulate_pulses

__all__ = ["METHODS", "CONTROL_SCORERS", "ROW_COLUMNS", "DIAGNOSTIC_COLUMNS", "SearchProblem", "SearchResult",
           "SearchRun", "search_problem", "table41_rows", "failure_analysis", "linearise", "block_knots",
           "inject_velocity_noise", "candidate_offsets", "variance_ratio", "coverage", "run_search", "reach_bound",
           "table41_sigmas", "table41_spacings", "noise_drift", "TABLE41_BIAS"]

CONTROL_SCORERS = ("oracle", "anti-oracle", "random")


@dataclass
class SearchProblem:
    """Everything a search run needs that does not depend on the noise realisation.

    Attributes
    ----------
    rc : range-compressed pulses (P pulses), recorded along ``truth``.
    grid : image grid (e.g. ``GroundGrid``), 200 x 200 in the thesis (L642).
    truth : (P, 3) true antenna positions; direction : (3,) along-track unit vector e.
    initial_pulses : S_0 (1000, L642). measure : quality measure name; tolerance : phase tolerance of the
    candidate images [rad]; initial_image : BPA of pulses 0..S_0-1 along the truth (formed on first use).
    """

    rc: object
    grid: object
    truth: np.ndarray
    direction: np.ndarray
    initial_pulses: int = 1000
    measure: str = "kurtosis"
    n_bins: int = 1000
    tolerance: float = 1e-3
    initial_image: np.ndarray | None = None
    _g_max: float | None = field(default=None, repr=False)
    _cache: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        self.truth = np.asarray(self.truth, dtype=np.float64)
        if self.truth.shape != (self.rc.n_pulses, 3):
            raise InputDataError("truth", f"must have shape ({self.rc.n_pulses}, 3), got {self.truth.shape}")
        e = np.asarray(self.direction, dtype=np.float64)
        self.direction = e / np.linalg.norm(e)
        checked_int("search.initial_pulses", self.initial_pulses, 1)
        if self.initial_pulses >= self.rc.n_pulses:
            raise ConfigError("search.initial_pulses", f"must be < {self.rc.n_pulses} pulses, got {self.initial_pulses}")
        if self.measure not in CONTROL_SCORERS:
            quality_measure(self.measure, "search.measure")

    def along(self, direction) -> "SearchProblem":
        """The same problem searched along another unit ``direction`` (3,): same pulses, grid, truth and initial
        image, its own expansion bound and moment-image cache (``measurements.search_axes``)."""
        return SearchProblem(self.rc, self.grid, self.truth, direction, self.initial_pulses, self.measure, self.n_bins,
                             self.tolerance, self.initial_image)

    def image0(self) -> np.ndarray:
        """The initial image (Alg. 3.3 step 7), back-projected with linear range interpolation like the block images
        of ``imaging.offset_bpa`` that are added to it (BPA's default "auto" would upsample: a different image)."""
        if self.initial_image is None:
            s0 = self.initial_pulses
            self.initial_image = backproject(_pulses(self.rc, 0, s0), self.grid, positions=self.truth[:s0],
                                             interpolation="linear").data
        return self.initial_image

    def g_max(self) -> float:
        """Largest |direction cosine along e| between a pixel and an antenna position (for the expansion order)."""
        if self._g_max is None:
            pts = np.asarray(self.grid.points(), dtype=np.float64).reshape(-1, 3)
            corners = np.array([[pts[:, i].min() if b else pts[:, i].max() for i, b in enumerate(bits)]
                                for bits in np.ndindex(2, 2, 2)])
            ends = self.truth[[0, -1]]
            d = corners[None, :, :] - ends[:, None, :]
            self._g_max = float(np.max(np.abs(d @ self.direction) / np.linalg.norm(d, axis=-1)))
        return self._g_max


def _pulses(rc, start: int, stop: int):
    return replace(rc, data=rc.data[start:stop], pulse_times=rc.pulse_times[start:stop],
                   positions=rc.positions[start:stop])


@dataclass
class SearchRun:
    """Diagnostics of a run: chosen offset, chosen and oracle candidate index per block."""

    offsets: list = field(default_factory=list)
    chosen_index: list = field(default_factory=list)
    oracle_index: list = field(default_factory=list)


@dataclass
class SearchResult:
    """Outcome of one run: corrected track (P, 3), chosen offset per block [m/sample], rho, final image
    (``keep_image``), per-block diagnostics, and ``reach``: the bound B of :func:`reach_bound` for this run's
    largest possible correction slope."""

    corrected: np.ndarray
    offsets: np.ndarray
    rho: float
    image: np.ndarray | None = None
    run: SearchRun | None = None
    reach: float = float("nan")


# ---------------------------------------------------------------------------------------------
# one block: score the candidates, choose one

@dataclass
class _Block:
    """One block of the search: pulses start..stop-1, its lever and base track, the truth over it."""

    start: int
    stop: int
    tau: np.ndarray
    base: np.ndarray
    truth: np.ndarray


def _oracle_errors(block: _Block, e: np.ndarray, deltas: np.ndarray) -> np.ndarray:
    """Sum of squared along-track errors of each candidate over the block (what an oracle minimises)."""
    r = (block.base - block.truth) @ e
    return np.array([np.sum((r + d * block.tau) ** 2) for d in deltas])


def _oracle_continuous(block: _Block, e: np.ndarray, span: float) -> float:
    r = (block.base - block.truth) @ e
    return float(np.clip(-np.sum(block.tau * r) / np.sum(block.tau**2), -span, span))


#: moment images kept per problem (the first block of every run of one noise realisation is the same)
_CACHE_SIZE = 2


def _moments(problem: SearchProblem, block: _Block, max_offset: float):
    """Moment images of a block; order from the largest offset (at least 2), cached by block and base track."""
    k = 4.0 * math.pi / problem.rc.wavelength
    x = k * max_offset * float(np.max(block.tau)) * problem.g_max() * 1.05
    order = max(2, order_for(x, 0.1 * problem.tolerance))
    key = (block.start, block.stop, hash(block.base.tobytes()))
    hit = problem._cache.get(key)
    if hit is not None and hit[1].order >= order and np.array_equal(hit[0], block.base):
        return hit[1]
    mom = offset_moments(_pulses(problem.rc, block.start, block.stop), problem.grid, block.base, problem.direction,
                         block.tau, order)
    if len(problem._cache) >= _CACHE_SIZE:
        problem._cache.pop(next(iter(problem._cache)))
    problem._cache[key] = (block.base.copy(), mom)
    return mom


def _parabola_vertex(d, s, i: int) -> float | None:
    """Vertex of the parabola through (d[i-1], s[i-1]), (d[i], s[i]), (d[i+1], s[i+1]) when it is a maximum."""
    if i == 0 or i == len(d) - 1:
        return None
    h = d[i + 1] - d[i]
    den = s[i - 1] - 2.0 * s[i] + s[i + 1]
    if den >= 0:
        return None
    return float(d[i] + 0.5 * h * (s[i - 1] - s[i + 1]) / den)


def _choose_by_measure(problem: SearchProblem, block: _Block, acc: np.ndarray, deltas: np.ndarray, method: str,
                       measure: str):
    """(chosen offset, its block image) by the quality measure: grid arg max, parabola or Brent refinement."""
    m = QUALITY_MEASURES[measure]
    mom = _moments(problem, block, float(np.max(np.abs(deltas))))

    def score(d):
        return m.better(acc + mom.image(d, problem.tolerance), problem.n_bins)

    imgs = mom.images(deltas, problem.tolerance)
    s = np.array([m.better(acc + im, problem.n_bins) for im in imgs])
    i = int(np.argmax(s))
    best, best_s = float(deltas[i]), float(s[i])
    if method == "grid":
        v = _parabola_vertex(deltas, s, i)
        if v is not None and score(v) > best_s:
            best = v
    elif method == "brent" and len(deltas) > 1:
        lo, hi = deltas[max(i - 1, 0)], deltas[min(i + 1, len(deltas) - 1)]
        res = minimize_scalar(lambda d: -score(d), bounds=(lo, hi), method="bounded",
                              options={"xatol": 1e-3 * (deltas[1] - deltas[0])})
        if -res.fun > best_s:
            best = float(res.x)
    return best, mom.image(best, problem.tolerance)


def _choose(problem, block, acc, deltas, method, scorer, rng, span):
    """(chosen offset, block image or None, oracle candidate index) for one block."""
    e = problem.direction
    errors = _oracle_errors(block, e, deltas)
    oracle_index = int(np.argmin(errors))
    if scorer == "oracle":
        d = _oracle_continuous(block, e, span) if method == "brent" else float(deltas[oracle_index])
        return d, None, oracle_index
    if scorer == "anti-oracle":
        return float(deltas[int(np.argmax(errors))]), None, oracle_index
    if scorer == "random":
        return float(deltas[int(rng.integers(len(deltas)))]), None, oracle_index
    d, img = _choose_by_measure(problem, block, acc, deltas, method, scorer)
    return d, img, oracle_index


# ---------------------------------------------------------------------------------------------
# the run

def _check_run(problem: SearchProblem, noisy, method, candidates, spacing, span, scorer, rng) -> np.ndarray:
    if method not in METHODS:
        raise ConfigError("search.method", f"must be one of {METHODS}, got {method!r}")
    checked_int("search.candidates", candidates, 1)
    if method == "source" and not (math.isfinite(spacing) and spacing >= 0):
        raise ConfigError("search.spacing", f"must be finite and >= 0 m/sample, got {spacing!r}")
    if method != "source" and not (math.isfinite(span) and span > 0):
        raise ConfigError("search.span", f"must be finite and > 0 m/sample for method {method!r}, got {span!r}")
    if scorer not in CONTROL_SCORERS:
        quality_measure(scorer, "search.scorer")
    if scorer == "random" and not isinstance(rng, np.random.Generator):
        raise ConfigError("rng", "a numpy.random.Generator is required for the random scorer")
    if method == "viterbi" and scorer in ("random", "anti-oracle"):
        raise ConfigError("search.scorer", f"the {scorer} control has no path metric: use a quality measure or "
                          "'oracle' with method 'viterbi'")
    p = np.asarray(noisy, dtype=np.float64)
    if p.shape != problem.truth.shape or not np.all(np.isfinite(p)):
        raise InputDataError("noisy", f"must be a finite array of shape {problem.truth.shape}")
    return p


def run_search(problem: SearchProblem, noisy, block_pulses: int = 1000, method: str = "source", candidates: int = 11,
               spacing: float = 0.0, span: float = 0.0, scorer: str | None = None,
               rng: np.random.Generator | None = None, keep_image: bool = False, carry: bool = False,
               states: int | None = None) -> SearchResult:
    """One run of Alg. 3.3 (module docstring) on the noisy track ``noisy`` (P, 3).

    Parameters
    ----------
    block_pulses : S_i; method : "source", "grid" or "brent"; candidates : L >= 1;
    spacing : Delta of the "source" grid [m/sample]; span : half-width of the "grid"/"brent" candidates [m/sample];
    scorer : quality measure name or "oracle"/"random" (default ``problem.measure``); rng : for "random".
    carry : keep the chosen offsets for the next blocks (gap 10's other reading; the thesis restarts every block
        from the noisy velocity, L443). Not with "viterbi".
    states : "viterbi" only: the most position states kept at a knot (odd; corrections within +-(states // 2) grid
        steps x S_i samples); default every state the candidates can reach.

    Returns
    -------
    SearchResult with ``corrected`` (P, 3), ``offsets`` (n_blocks,), ``rho``, the per-block diagnostics ``run``
    and, with ``keep_image``, the final accumulated image.
    """
    scorer = problem.measure if scorer is None else scorer
    noisy = _check_run(problem, noisy, method, candidates, spacing, span, scorer, rng)
    if carry and method == "viterbi":
        raise ConfigError("search.method", "'viterbi' keeps position states, not offsets: carry applies to 'source', "
                          "'grid' and 'brent' only")
    s0, e = problem.initial_pulses, problem.direction
    knots = block_knots(problem.rc.n_pulses, s0, block_pulses)
    truth_lin, noisy_lin = linearise(problem.truth, knots), linearise(noisy, knots)
    deltas = candidate_offsets(method, candidates, spacing, span)
    corrected = noisy_lin.copy()
    diag = SearchRun()
    acc = None
    if candidates > 1 or method != "source":
        acc = problem.image0().copy() if scorer not in CONTROL_SCORERS else None
        if method == "viterbi":
            acc = _viterbi_blocks(problem, knots, noisy_lin, truth_lin, deltas, scorer, acc, corrected, diag, states)
        else:
            _search_blocks(problem, knots, noisy_lin, truth_lin, deltas, method, scorer, rng, span, carry, acc,
                           corrected, diag)
    rho = variance_ratio(corrected, noisy_lin, truth_lin, e, s0)
    slope = float(np.max(np.abs(deltas))) if diag.offsets else 0.0
    if carry and diag.offsets:  # the k-th block's slope is at most k times the largest offset
        slope = slope * np.searchsorted(knots[knots >= s0 - 1], np.arange(s0, problem.rc.n_pulses), side="left")
    reach = reach_bound(noisy_lin, truth_lin, e, s0, slope)
    return SearchResult(corrected, np.array(diag.offsets), rho, acc if keep_image else None, diag, reach)


def _search_blocks(problem, knots, noisy_lin, truth_lin, deltas, method, scorer, rng, span, carry, acc, corrected,
                   diag) -> None:
    """The block loop of Alg. 3.3 step 8 (greedy): fills ``corrected``, adds the kept block images to ``acc``.

    Each block starts from the last accepted sample (position continuity, L443) with the noisy linearised velocity
    plus, with ``carry``, the sum of the offsets chosen so far (the other reading of gap 10)."""
    s0, e = problem.initial_pulses, problem.direction
    corr, kept = np.zeros(3), 0.0
    for a, b in zip(knots[:-1], knots[1:]):
        if a < s0 - 1:
            continue
        tau = np.arange(1.0, b - a + 1.0)
        base = noisy_lin[a + 1:b + 1] + corr + (kept * tau)[:, None] * e[None, :]
        block = _Block(a + 1, b + 1, tau, base, truth_lin[a + 1:b + 1])
        d, img, oi = _choose(problem, block, acc, deltas, method, scorer, rng, span)
        corrected[a + 1:b + 1] = block.base + (d * tau)[:, None] * e[None, :]
        if img is not None:
            acc += img
        corr = corr + (kept + d) * (b - a) * e
        if carry:
            kept += d
        diag.offsets.append(d)
        diag.chosen_index.append(int(np.argmin(np.abs(deltas - d))))
        diag.oracle_index.append(oi)


def _viterbi_blocks(problem, knots, noisy_lin, truth_lin, deltas, scorer, acc, corrected, diag, states):
    """The Viterbi search the thesis proposes (L730): a state is the along-track position correction at a knot, on
    the lattice of the candidates' step x the samples per block; from each state every candidate offset leads to
    the state at the next knot; each state keeps its best incoming path (survivor) and that path's accumulated
    image. Path metric: the quality measure of the survivor's image after the block (a measure is not a sum over
    blocks, so the survivor is the best path into the state by the score after this block: the usual adaptation),
    or for the "oracle" scorer the sum of squared along-track errors (additive: the globally best path of the
    lattice). The best final state's path is traced back into ``corrected``; returns its image (None: oracle)."""
    s0, e = problem.initial_pulses, problem.direction
    step = float(deltas[1] - deltas[0]) if len(deltas) > 1 else 1.0
    jumps = np.rint(deltas / step).astype(np.int64)
    limit = None if states is None else (checked_int("search.states", states, 1) // 2) * float(np.max(np.diff(knots)))
    oracle = scorer == "oracle"
    m = None if oracle else QUALITY_MEASURES[scorer]
    surv = {0: (0.0, acc, ())}          # integer correction K (x step) -> (path metric, higher better; image; path)
    for a, b in zip(knots[:-1], knots[1:]):
        if a < s0 - 1:
            continue
        tau = np.arange(1.0, b - a + 1.0)
        new: dict = {}
        for k, (value, img, path) in sorted(surv.items()):
            base = noisy_lin[a + 1:b + 1] + (k * step) * e[None, :]
            block = _Block(a + 1, b + 1, tau, base, truth_lin[a + 1:b + 1])
            if oracle:
                scores, imgs = value - _oracle_errors(block, e, deltas), [None] * len(deltas)
            else:
                mom = _moments(problem, block, float(np.max(np.abs(deltas))))
                imgs = [img + im for im in mom.images(deltas, problem.tolerance)]
                scores = np.array([m.better(im, problem.n_bins) for im in imgs])
            for jump, sc, im, d in zip(jumps, scores, imgs, deltas):
                k2 = int(k + jump * (b - a))
                if (limit is None or abs(k2) <= limit) and (k2 not in new or sc > new[k2][0]):
                    new[k2] = (float(sc), im, path + ((a, b, k, float(d)),))
        surv = new
    best = max(surv.values(), key=lambda v: v[0])
    for a, b, k, d in best[2]:
        tau = np.arange(1.0, b - a + 1.0)
        base = noisy_lin[a + 1:b + 1] + (k * step) * e[None, :]
        corrected[a + 1:b + 1] = base + (d * tau)[:, None] * e[None, :]
        block = _Block(a + 1, b + 1, tau, base, truth_lin[a + 1:b + 1])
        diag.offsets.append(d)
        diag.chosen_index.append(int(np.argmin(np.abs(deltas - d))))
        diag.oracle_index.append(int(np.argmin(_oracle_errors(block, e, deltas))))
    return best[1]


# ---------------------------------------------------------------------------------------------
# the Table 4.1 sweep and its controls

#: columns of rho.csv (issue 13); DIAGNOSTIC_COLUMNS are added to every row as well
ROW_COLUMNS = ("method", "block_pulses", "candidates", "sigma", "spacing", "realisation", "rho")
DIAGNOSTIC_COLUMNS = ("scorer", "coverage", "agreement", "reach", "error")


def _noise(seed: int, realisation: int, sigma_index: int, n_sigmas: int, n_pulses: int):
    """(w, random-scorer generator) of one realisation and sigma: independent of how runs are batched."""
    ss = np.random.SeedSequence(seed).spawn(realisation + 1)[realisation].spawn(n_sigmas)[sigma_index]
    w_ss, r_ss = ss.spawn(2)
    return np.random.default_rng(w_ss).standard_normal(n_pulses), np.random.default_rng(r_ss)


def noise_drift(seed: int, realisation: int, sigma_index: int, n_sigmas: int, n_pulses: int, initial_pulses: int,
                bias: float, sigma: float) -> np.ndarray:
    """(P,) along-track position error [m] that the noise of one realisation and sigma of ``table41_rows`` makes:
    0 before S_0, then sum (b + sigma w) (Alg. 3.3 steps 2-4; Fig. 4.25b)."""
    w = _noise(seed, realisation, sigma_index, n_sigmas, n_pulses)[0]
    out = np.zeros(n_pulses)
    out[initial_pulses:] = np.cumsum(bias + sigma * w[initial_pulses:])
    return out


def _row(label, scorer, block_pulses, candidates, sigma, spacing, realisation, res, cov):
    agree = (float(np.mean(np.array(res.run.chosen_index) == np.array(res.run.oracle_index)))
             if res is not None and res.run is not None and res.run.chosen_index else float("nan"))
    nan = float("nan")
    return {"method": label, "block_pulses": int(block_pulses), "candidates": int(candidates), "sigma": float(sigma),
            "spacing": float(spacing), "realisation": int(realisation), "rho": nan if res is None else float(res.rho),
            "scorer": scorer, "coverage": float(cov), "agreement": agree, "reach": nan if res is None else res.reach,
            "error": ""}


def table41_rows(problem: SearchProblem, block_pulses: int, candidates: int, realisations=(0,), seed: int = 0,
                 sigmas=None, n_spacings: int = 30, bias: float = TABLE41_BIAS,
                 scorers=None, improved=("grid", "brent"), span_sigmas: float = 3.0, carry: bool = False,
                 single: bool = False, carry_scorers=()):
    """Rows of the Table 4.1 sweep for one (S_i, L) (L656-670): yields one dict per run (``ROW_COLUMNS`` +
    ``DIAGNOSTIC_COLUMNS``).

    For every realisation r and sigma (Table 4.1: ten values), one noise vector w (gap 13) and (``scorers`` default:
    ``problem.measure``, "oracle", "random")

    * the thesis' search (``method="source"``) for each of the ``n_spacings`` spacings and each scorer in
      ``scorers`` (kurtosis = the thesis; "oracle", "random": the controls; label ``source`` for
      ``problem.measure``, ``source-<scorer>`` for any other scorer, e.g. ``source-oracle``);
    * with ``carry``, the thesis' grid with the chosen offsets kept for the next blocks (label ``source-carry``),
      and so for each control of ``carry_scorers`` (label ``source-<scorer>-carry``, e.g. ``source-oracle-carry``);
    * with ``single``, the L = 1 control once (label ``source``, ``candidates`` 1, ``spacing`` 0: rho = 1 exactly);
    * each improved method once, candidates spanning +- (|b| + span_sigmas sigma / sqrt(S_i)) (the bias bound and
      the block noise an IMU specification gives), scored by ``problem.measure``; ``spacing`` is its grid step.

    ``realisations`` are indices (``range(10)`` for Figs. 4.22-4.24); the noise of a row depends only on (seed, r,
    sigma index, number of sigmas). A run that fails (``SarnavError``, e.g. an offset beyond the candidate images'
    phase tolerance) gives a row with rho NaN and the message in ``error``: the sweep goes on.
    """
    sig = table41_sigmas() if sigmas is None else np.asarray(sigmas, dtype=np.float64)
    scorers = (problem.measure, "oracle", "random") if scorers is None else tuple(scorers)
    checked_int("search.candidates", candidates, 1)
    block_knots(problem.rc.n_pulses, problem.initial_pulses, block_pulses)
    for r in realisations:
        for i, s in enumerate(sig):
            w, rand = _noise(seed, int(r), i, sig.size, problem.rc.n_pulses)
            noisy = inject_velocity_noise(problem.truth, problem.direction, problem.initial_pulses, bias, s, w)
            if single:
                yield _safe_row("source", problem.measure, block_pulses, 1, s, 0.0, r, 0.0,
                                lambda: run_search(problem, noisy, block_pulses, "source", 1))
            for spacing in table41_spacings(s, n_spacings):
                cov = coverage(candidates, spacing, bias, s, block_pulses)
                runs = ([(sc, False) for sc in scorers] + ([(problem.measure, True)] if carry else [])
                        + [(sc, True) for sc in carry_scorers])
                for sc, keep in runs:
                    label = "source" if sc == problem.measure else f"source-{sc}"
                    label = ("source-carry" if sc == problem.measure else f"{label}-carry") if keep else label
                    yield _safe_row(label, sc, block_pulses, candidates, s, spacing, r, cov, lambda: run_search(
                        problem, noisy, block_pulses, "source", candidates, spacing=spacing, scorer=sc, rng=rand,
                        carry=keep))
            span = abs(bias) + span_sigmas * s / math.sqrt(block_pulses)
            step = 2.0 * span / max(candidates - 1, 1)
            for method in improved:
                yield _safe_row(method, problem.measure, block_pulses, candidates, s, step, r,
                                coverage(candidates, step, bias, s, block_pulses),
                                lambda: run_search(problem, noisy, block_pulses, method, candidates, span=span))


def _safe_row(label, scorer, block_pulses, candidates, sigma, spacing, realisation, cov, run) -> dict:
    """The row of ``run()``; a failed run (SarnavError) is recorded with rho NaN and its message."""
    try:
        return _row(label, scorer, block_pulses, candidates, sigma, spacing, realisation, run(), cov)
    except SarnavError as err:
        row = _row(label, scorer, block_pulses, candidates, sigma, spacing, realisation, None, cov)
        row["error"] = str(err)
        return row


def failure_analysis(rows) -> dict:
    """Why the thesis' search fails, from ``table41_rows`` output (docs/quality.md "failure analysis").

    Returns per method label (rows with L = 1 under ``"<method> (L=1)"``; failed runs left out): ``rho`` (all
    values), ``median_rho``, ``mean_rho``, ``coverage`` (median grid coverage) and ``agreement`` (mean fraction of
    blocks where the scorer chose the oracle's candidate); and
    ``by_coverage``: for the thesis' grid, median rho of the quality measure and of the oracle in coverage bins
    (grid coverage limits the oracle; the gap between the two is the quality measure's own failure).
    """
    out = {}
    rows = [r for r in rows if np.isfinite(r["rho"])]
    key = {id(r): r["method"] if r["candidates"] > 1 else f"{r['method']} (L=1)" for r in rows}
    for lab in sorted(set(key.values())):
        sel = [r for r in rows if key[id(r)] == lab]
        rho = np.array([r["rho"] for r in sel])
        agree = [r["agreement"] for r in sel if np.isfinite(r["agreement"])]
        out[lab] = {"rho": rho, "median_rho": float(np.median(rho)), "mean_rho": float(np.mean(rho)),
                    "min_rho": float(rho.min()), "max_rho": float(rho.max()),
                    "coverage": float(np.median([r["coverage"] for r in sel])),
                    "agreement": float(np.mean(agree)) if agree else float("nan")}
    edges = np.array([0.0, 0.05, 0.1, 0.2, 0.5, 1.0, np.inf])
    by = {}
    for lab in ("source", "source-oracle", "source-random"):
        sel = [r for r in rows if key[id(r)] == lab]
        if sel:
            cov = np.array([r["coverage"] for r in sel])
            rho = np.array([r["rho"] for r in sel])
            idx = np.digitize(cov, edges) - 1
            by[lab] = np.array([np.median(rho[idx == k]) if np.any(idx == k) else np.nan for k in range(edges.size - 1)])
    out["by_coverage"] = {"edges": edges, **by}
    return out


def search_problem(geometry, scene, size: int = 200, initial_pulses: int = 1000, measure: str = "kurtosis",
                   snr_db: float | None = None, rng: np.random.Generator | None = None) -> SearchProblem:
    """The search problem of a :class:`~sarnav.radar.quality_scenes.QualityGeometry` and scene: echoes along the
    true track, range compression, a ``size`` x ``size`` ground grid over the scene square (200 x 200, L642)."""
    size = checked_int("search.size", size, 2)
    rc = range_compress(simulate_pulses(geometry, scene, snr_db, rng))
    c = geometry.scene_center
    grid = GroundGrid.centered(float(c[0]), float(c[1]), geometry.grid_spacing(size), (size, size))
    return SearchProblem(rc, grid, geometry.positions(), geometry.along_track, initial_pulses, measure)

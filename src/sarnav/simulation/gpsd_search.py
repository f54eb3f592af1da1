"""The velocity-offset search sweep of Hathaway (2023) Alg. 3.3, its controls and searches that work (Table 4.1;
docs/quality.md §4-§6): one search problem (echoes of the scene along the true track, range compressed), then per
(S_i, L) the rows of ``measurements.focus_search.table41_rows``, and their summary per configuration.

``runs`` is the number of noise realisations (one noise vector per realisation and sigma, shared by the spacings:
gap 13), ``seed`` their seed. ``methods`` are searches, each scored by ``measure``: ``"source"`` the thesis'
algorithm, ``"source-carry"`` the same grid keeping the chosen offsets (gap 10's other reading), ``"grid"`` and
``"brent"`` the searches spanning the bias, ``"viterbi"`` the trellis over position states on the spanning grid
(the thesis' future work, L730); ``controls``: ``"one"`` (L = 1, rho = 1 exactly), ``"oracle"``, ``"random"``
and ``"anti-oracle"`` (the candidate farthest from the truth: the largest rho the grid allows a scorer) scorers on
the thesis' grid, and ``"oracle-carry"``, ``"anti-oracle-carry"`` the two extremes with the chosen offsets kept
(gap 10's other reading; issue 29: where the thesis' rho range is reachable).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from sarnav.measurements import focus_search as fs
from sarnav.radar.quality_scenes import QualityGeometry
from sarnav.simulation.quality_scene import QualitySceneSpec, make_scene

__all__ = ["SEARCH_METHODS", "SEARCH_CONTROLS", "SOURCE_RHO", "GpsdSearchParams", "SearchResult", "run",
           "search_rows", "summary"]

SEARCH_METHODS = ("source", "source-carry", "grid", "brent", "viterbi")
SEARCH_CONTROLS = ("one", "oracle", "random", "anti-oracle", "oracle-carry", "anti-oracle-carry")
#: the thesis' numbers (L712, L722-724)
SOURCE_RHO = {"min": 0.2735, "max": 2.7707, "per_sigma_mean_min": 0.8110, "per_sigma_mean_max": 1.3918}


@dataclass(frozen=True)
class GpsdSearchParams:
    """The sweep: ``runs`` noise realisations from ``seed``; the geometry and scene; ``size`` x ``size`` images;
    ``methods`` (of :data:`SEARCH_METHODS`) and ``controls`` (of :data:`SEARCH_CONTROLS`); the candidates L and block
    lengths S_i of each configuration; S_0 = ``initial_pulses``; the first ``sigmas`` of Table 4.1's sigma and
    ``spacings`` of its spacings; the velocity bias [m/sample]; the spanning searches cover +-(|b| + ``span_sigmas``
    sigma / sqrt(S_i)); the focus ``measure``."""

    runs: int
    seed: int
    geometry: QualityGeometry
    scene: QualitySceneSpec
    size: int
    methods: tuple[str, ...]
    controls: tuple[str, ...]
    candidates: tuple[int, ...]
    block_pulses: tuple[int, ...]
    initial_pulses: int
    sigmas: int
    spacings: int
    bias: float
    span_sigmas: float
    measure: str

    @property
    def configurations(self) -> tuple[tuple[int, int], ...]:
        """The (S_i, L) of the sweep in the order it runs them: per block length, each candidate count."""
        return tuple((si, L) for si in self.block_pulses for L in self.candidates)

    def image_runs(self) -> int:
        """Search runs that form images (the controls form none), in greedy-run equivalents: a Viterbi run scores
        the candidates from every live state, about (L // 2) (n_blocks - 1) + 1 times a greedy run's work (the states
        grow by L // 2 a block on each side)."""
        per = 0
        for si, L in self.configurations:
            n_blocks = -(-(self.geometry.n_pulses - self.initial_pulses) // si)
            per += (self.spacings * sum(m.startswith("source") for m in self.methods)
                    + sum(m in ("grid", "brent") for m in self.methods)
                    + ("viterbi" in self.methods) * ((L // 2) * (n_blocks - 1) + 1))
        return self.runs * self.sigmas * per

    def noise_drifts(self) -> tuple[float, dict]:
        """(sigma, {realisation: (P,) along-track drift [m]}) of Fig. 4.25: the fourth sigma of Table 4.1 (3.266e-5,
        L694; the last one swept if fewer), the first three realisations (``focus_search.noise_drift``)."""
        k = min(3, self.sigmas - 1)
        sigma = float(fs.table41_sigmas(self.sigmas)[k])
        return sigma, {r: fs.noise_drift(self.seed, r, k, self.sigmas, self.geometry.n_pulses, self.initial_pulses,
                                         self.bias, sigma) for r in range(min(self.runs, 3))}


@dataclass(frozen=True)
class SearchResult:
    """Every row of the sweep (``focus_search.ROW_COLUMNS`` + ``DIAGNOSTIC_COLUMNS``) and their :func:`summary`."""

    rows: list
    summary: dict


def search_rows(prm: GpsdSearchParams, problem):
    """Every row of the sweep, in order: per (S_i, L), the rows of ``focus_search.table41_rows``."""
    scorers = ([prm.measure] if "source" in prm.methods else []) + [c for c in ("oracle", "random", "anti-oracle")
                                                                   if c in prm.controls]
    carry_scorers = tuple(c for c in ("oracle", "anti-oracle") if f"{c}-carry" in prm.controls)
    improved = tuple(m for m in prm.methods if m in ("grid", "brent", "viterbi"))
    sigmas = fs.table41_sigmas(prm.sigmas)
    for si, L in prm.configurations:
        yield from fs.table41_rows(problem, si, L, realisations=range(prm.runs), seed=prm.seed,
                                   sigmas=sigmas, n_spacings=prm.spacings, bias=prm.bias, scorers=scorers,
                                   improved=improved, span_sigmas=prm.span_sigmas,
                                   carry="source-carry" in prm.methods, single="one" in prm.controls,
                                   carry_scorers=carry_scorers)


def run(prm: GpsdSearchParams, progress: Callable[[int, float], None] | None = None) -> SearchResult:
    """The sweep: the search problem of the geometry and scene, every row, the summary; ``progress(rows, seconds)``
    is called every 50 rows."""
    t0 = time.perf_counter()
    scene, rng, snr = make_scene(prm.scene, prm.geometry)
    problem = fs.search_problem(prm.geometry, scene, prm.size, prm.initial_pulses, prm.measure, snr, rng)
    rows = []
    for row in search_rows(prm, problem):
        rows.append(row)
        if progress is not None and len(rows) % 50 == 0:
            progress(len(rows), time.perf_counter() - t0)
    return SearchResult(rows, summary(rows, prm, time.perf_counter() - t0))


def summary(rows: list[dict], prm: GpsdSearchParams, seconds: float) -> dict:
    """Per (S_i, L): the failure analysis of ``focus_search.failure_analysis`` and per-sigma means; the source's
    numbers; the widest reach bound; failed runs."""
    out = {"source": SOURCE_RHO, "seconds": seconds, "rows": len(rows),
           "failed_runs": [r for r in rows if r["error"]][:20], "configurations": {}}
    for si, L in prm.configurations:
        sel = [r for r in rows if r["block_pulses"] == si and r["candidates"] in (L, 1)]
        fa = fs.failure_analysis(sel)
        per_sigma = {}
        for lab in {r["method"] for r in sel if r["candidates"] == L}:
            sig = sorted({r["sigma"] for r in sel if r["method"] == lab})
            per_sigma[lab] = [float(np.nanmean([r["rho"] for r in sel if r["method"] == lab and r["sigma"] == x
                                                and r["candidates"] == L])) for x in sig]
        reach = [r["reach"] for r in sel if r["method"] == "source" and np.isfinite(r["reach"])]
        fa["per_sigma_mean"] = per_sigma
        fa["source_reach_max"] = float(max(reach)) if reach else float("nan")
        fa["per_sigma_reach_max"] = _reach_per_sigma(sel, L)
        for lab in list(fa):
            if isinstance(fa[lab], dict) and "rho" in fa[lab]:
                fa[lab].pop("rho")
        out["configurations"][f"S_i={si},L={L}"] = fa
    return out


def _reach_per_sigma(rows, candidates) -> dict:
    """Per reading of gap 10 ("restart": the thesis restarting each block; "carry": the offsets kept), the largest
    reach bound B over the rows of each sigma (spacings and realisations): no scorer leaves [(1 - B)^2, (1 + B)^2]."""
    out = {}
    for reading, carry in (("restart", False), ("carry", True)):
        sel = [r for r in rows if r["candidates"] == candidates and r["method"].startswith("source")
               and r["method"].endswith("-carry") == carry and np.isfinite(r["reach"])]
        sig = sorted({r["sigma"] for r in sel})
        if sig:
            out[reading] = [float(max(r["reach"] for r in sel if r["sigma"] == x)) for x in sig]
    return out

"""The velocity-offset search along more than one axis (issue 29, Hathaway 2023 Build 2(c): the thesis searches the
along-track velocity only, L414-L457).

Each axis is searched by Alg. 3.3 (``focus_search.run_search``, any method and scorer) along its own unit direction,
on the track the other axes' latest searches left: a coordinate search, sweep after sweep (``sweeps``), each pass
forming its image from the initial one again. A search along an axis corrects only the error's component on it,
and the moment images of ``imaging.offset_bpa`` expand the image in one direction at a time, which is why the axes
take turns rather than a joint grid (L^2 candidates per block). The result reports rho per axis against the noisy
track's error on that axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import ConfigError
from sarnav.measurements.focus_search import SearchProblem, run_search
from sarnav.measurements.search_tracks import block_knots, checked_int, linearise, variance_ratio

__all__ = ["AxesResult", "run_search_axes"]


@dataclass(frozen=True)
class AxesResult:
    """``corrected`` (P, 3) track after the last sweep; ``rho`` (n_axes,) per axis (variance of the corrected track's
    error on the axis over the noisy one's, after S_0); ``offsets`` (sweeps, n_axes, n_blocks) [m/sample]."""

    corrected: np.ndarray
    rho: np.ndarray
    offsets: np.ndarray


def run_search_axes(problem: SearchProblem, noisy, directions, block_pulses: int = 500, method: str = "grid",
                    candidates: int = 11, spans=None, spacing: float = 0.0, sweeps: int = 2,
                    scorer: str | None = None) -> AxesResult:
    """Search the velocity offset along each of ``directions`` (n_axes, 3) in turn, ``sweeps`` times (module
    docstring); ``spans`` (n_axes,) the half-widths of the spanning grids [m/sample] (``method`` "grid", "brent"),
    ``spacing`` the thesis' grid step ("source"); the rest as ``focus_search.run_search``."""
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != 3 or not np.all(np.isfinite(d)) or np.any(np.linalg.norm(d, axis=1) == 0):
        raise ConfigError("search.axes", f"must be a list of non-zero 3-vectors, got {np.asarray(directions).tolist()}")
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    spans = np.zeros(len(d)) if spans is None else np.atleast_1d(np.asarray(spans, dtype=np.float64))
    if spans.size == 1:
        spans = np.full(len(d), float(spans[0]))
    if spans.shape != (len(d),):
        raise ConfigError("search.span", f"must be one half-width [m/sample] per axis ({len(d)}), got {spans.tolist()}")
    checked_int("search.sweeps", sweeps, 1)
    axes = [problem.along(e) for e in d]
    knots = block_knots(problem.rc.n_pulses, problem.initial_pulses, block_pulses)
    start = linearise(noisy, knots)
    track, offsets = start, []
    for _ in range(sweeps):
        row = []
        for p, span in zip(axes, spans):
            res = run_search(p, track, block_pulses, method, candidates, spacing=spacing, span=float(span),
                             scorer=scorer)
            track = res.corrected
            row.append(res.offsets)
        offsets.append(row)
    truth = linearise(problem.truth, knots)
    rho = np.array([variance_ratio(track, start, truth, e, problem.initial_pulses) for e in d])
    return AxesResult(track, rho, np.asarray(offsets, dtype=np.float64))

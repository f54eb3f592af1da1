"""Seeds and chunks: one ``SeedSequence`` child per run, runs grouped into batches.

Run i always gets ``SeedSequence(seed).spawn(N)[i]`` (design/architecture.md §3 "Random numbers"),
whatever the executor, the chunking or a resume, so a run's numbers depend only on (seed, i).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["run_seeds", "make_chunks", "default_chunk_size"]


def run_seeds(seed: int, n_runs: int) -> list[np.random.SeedSequence]:
    """The N per-run children of ``SeedSequence(seed)`` (child i has ``spawn_key == (i,)``)."""
    return np.random.SeedSequence(seed).spawn(n_runs)


def default_chunk_size(n_todo: int, workers: int) -> int:
    """About two chunks per worker, at most 50 runs per chunk.

    Kinds batch over runs (one vectorised pass per chunk), so a chunk costs little more than a
    single run: few large chunks are fastest; two per worker keeps some load balance and stores
    runs several times during a long campaign.
    """
    return max(1, min(50, math.ceil(n_todo / (2 * max(1, workers)))))


def make_chunks(run_ids: Sequence[int], chunk_size: int) -> list[list[int]]:
    """Consecutive groups of ``chunk_size`` run ids (the last may be shorter)."""
    if chunk_size < 1:
        raise ValueError(f"chunk_size: must be >= 1, got {chunk_size}")
    ids = list(run_ids)
    return [ids[i : i + chunk_size] for i in range(0, len(ids), chunk_size)]

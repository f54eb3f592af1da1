"""Seeds and chunks: one ``SeedSequence`` child per run, runs grouped into batches.

Run i always gets ``SeedSequence(seed).spawn(N)[i]`` (design/architecture.md §3 "Random numbers"),
whatever the executor, the chunking or a resume, so a run's numbers depend only on (seed, i).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["run_seeds", "make_chunks", "ChunkPlan", "FixedChunks", "TARGET_CHUNK_SECONDS", "MAX_CHUNK"]

#: wall time a chunk should take once the per-run cost is known [s] (issue 32: files stored and the progress shown
#: every 10-30 s, so a kill loses at most that much work per worker)
TARGET_CHUNK_SECONDS = 20.0
#: most runs in one chunk (a batched kind gains little beyond: its vectorised pass is long enough)
MAX_CHUNK = 50
#: runs in each worker's first chunk, before any cost is measured
PROBE_CHUNK = 1
#: a chunk has at most this many times the runs of the largest chunk measured so far (one fast, unrepresentative
#: chunk must not produce a chunk of many minutes)
GROWTH = 4


def run_seeds(seed: int, n_runs: int) -> list[np.random.SeedSequence]:
    """The N per-run children of ``SeedSequence(seed)`` (child i has ``spawn_key == (i,)``)."""
    return np.random.SeedSequence(seed).spawn(n_runs)


class ChunkPlan:
    """Chunks sized by work: each worker's first chunk has :data:`PROBE_CHUNK` run(s); every later one about
    ``target_s`` seconds of work at the per-run cost measured so far (the chunk of most runs finished: its fixed
    costs, e.g. a first call's compilation, weigh least), between 1 and :data:`MAX_CHUNK` runs, at most
    :data:`GROWTH` times the largest measured chunk, and no more than an even share of what is left per worker (the
    last chunks end together). ``size`` fixes every chunk's size instead (``--chunk-size``).

    Which runs form a chunk never changes a run's numbers (run i uses seed child i; kinds batch runs independently),
    so any plan gives bit-identical results. The executors ask :meth:`next_chunk` whenever a worker is free and
    report each finished chunk's compute time to :meth:`finished`.
    """

    def __init__(self, run_ids: Sequence[int], workers: int = 1, size: int | None = None,
                 target_s: float = TARGET_CHUNK_SECONDS):
        if size is not None and size < 1:
            raise ValueError(f"chunk_size: must be >= 1, got {size}")
        self._todo = list(run_ids)
        self._pos = 0
        self.workers, self.size, self.target_s = max(1, int(workers)), size, float(target_s)
        self._probes = self.workers if size is None else 0
        self._measured: tuple[int, float] | None = None  # (runs, seconds) of the largest chunk finished
        self.sizes: list[int] = []  #: the sizes handed out, in order

    @property
    def remaining(self) -> int:
        return len(self._todo) - self._pos

    def seconds_per_run(self) -> float | None:
        """The per-run cost measured so far [s] (None before the first chunk ends)."""
        return None if self._measured is None else self._measured[1] / self._measured[0]

    def _next_size(self) -> int:
        if self.size is not None:
            return self.size
        if self._probes > 0 or self._measured is None:
            self._probes = max(0, self._probes - 1)
            return PROBE_CHUNK
        runs, seconds = self._measured
        n = int(self.target_s * runs / max(seconds, 1e-9))
        share = math.ceil(self.remaining / self.workers)
        return max(1, min(n, MAX_CHUNK, GROWTH * runs, share))

    def next_chunk(self) -> list[int] | None:
        """The run ids of the next chunk, or None when every run has been handed out."""
        if self.remaining <= 0:
            return None
        n = self._next_size()
        ids = self._todo[self._pos : self._pos + n]
        self._pos += len(ids)
        self.sizes.append(len(ids))
        return ids

    def finished(self, n_runs: int, seconds: float) -> None:
        """A chunk of ``n_runs`` took ``seconds`` of compute."""
        if n_runs > 0 and (self._measured is None or n_runs >= self._measured[0]):
            self._measured = (int(n_runs), float(seconds))


class FixedChunks(ChunkPlan):
    """The plan of a given list of chunks (in that order)."""

    def __init__(self, chunks: Sequence[Sequence[int]]):
        super().__init__([])
        self._chunks = [list(c) for c in chunks]

    @property
    def remaining(self) -> int:
        return sum(len(c) for c in self._chunks)

    def next_chunk(self) -> list[int] | None:
        if not self._chunks:
            return None
        ids = self._chunks.pop(0)
        self.sizes.append(len(ids))
        return ids


def make_chunks(run_ids: Sequence[int], chunk_size: int) -> list[list[int]]:
    """Consecutive groups of ``chunk_size`` run ids (the last may be shorter)."""
    if chunk_size < 1:
        raise ValueError(f"chunk_size: must be >= 1, got {chunk_size}")
    ids = list(run_ids)
    return [ids[i : i + chunk_size] for i in range(0, len(ids), chunk_size)]

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
GROWTH = 16


def run_seeds(seed: int, n_runs: int) -> list[np.random.SeedSequence]:
    """The N per-run children of ``SeedSequence(seed)`` (child i has ``spawn_key == (i,)``)."""
    return np.random.SeedSequence(seed).spawn(n_runs)


class ChunkPlan:
    """Chunks sized by work. A chunk of n runs costs about ``a + b n`` seconds (``a``: what a kind does once per
    chunk, e.g. a batched kind's vectorised set-up; ``b``: each run). Each worker's first chunk has
    ``probe`` runs (:data:`PROBE_CHUNK`; a kind that batches its runs into one vectorised pass states more,
    ``ScenarioKind.probe_chunk``, at most an even share of the runs per worker); the cost of every finished chunk is recorded, and ``a``, ``b`` are fitted by least
    squares over the chunks of different sizes (the workers' first chunks, which also pay one-off costs such as
    compilation, only while no other chunk has ended; with one size only: ``a = 0``). A later chunk has the runs that
    fill ``target_s`` seconds, or more where ``a`` would otherwise exceed a tenth of the chunk's time (batched kinds: the batching is what makes them fast), at most :data:`MAX_CHUNK` runs and :data:`GROWTH` times the largest chunk
    measured (while the finished chunks have one size, the next has one run more if that stays within 1.5
    ``target_s``, so that ``a`` can be told from ``b``), and no more than an even share of what is left per worker unless that share is too small to pay for
    ``a`` (so the last chunks end together). ``size`` fixes every chunk's size instead (``--chunk-size``).

    Which runs form a chunk never changes a run's numbers (run i uses seed child i; kinds batch runs independently),
    so any plan gives bit-identical results. The executors ask :meth:`next_chunk` whenever a worker is free and
    report each finished chunk's compute time to :meth:`finished`.
    """

    def __init__(self, run_ids: Sequence[int], workers: int = 1, size: int | None = None,
                 target_s: float = TARGET_CHUNK_SECONDS, probe: int = PROBE_CHUNK):
        if size is not None and size < 1:
            raise ValueError(f"chunk_size: must be >= 1, got {size}")
        if not 1 <= probe <= MAX_CHUNK:
            raise ValueError(f"probe: must be in [1, {MAX_CHUNK}], got {probe}")
        self._todo = list(run_ids)
        self._pos = 0
        self.workers, self.size, self.target_s = max(1, int(workers)), size, float(target_s)
        self.probe = min(int(probe), max(1, math.ceil(len(self._todo) / self.workers)))  # an even share at most
        self._probes = self.workers if size is None else 0
        self._warm: list[tuple[int, float]] = []  # (runs, seconds) of chunks a worker ran after its first
        self._cold: list[tuple[int, float]] = []  # the same of each worker's first chunk
        self.sizes: list[int] = []  #: the sizes handed out, in order

    @property
    def remaining(self) -> int:
        return len(self._todo) - self._pos

    def cost(self) -> tuple[float, float] | None:
        """``(a, b)``: the fitted cost of a chunk of n runs, ``a + b n`` [s] (None before any chunk ended)."""
        points = self._warm or self._cold
        if not points:
            return None
        if len({n for n, _ in points}) < 2:
            return 0.0, min(t / n for n, t in points)
        n = np.array([p[0] for p in points], dtype=float)
        t = np.array([p[1] for p in points], dtype=float)
        b, a = np.polyfit(n, t, 1)
        floor = 1e-3 * float(np.min(t / n))  # noisy timings of a kind whose runs cost nearly nothing
        return max(float(a), 0.0), max(float(b), floor)

    def _next_size(self) -> int:
        if self.size is not None:
            return self.size
        fit = self.cost()
        if self._probes > 0 or fit is None:
            self._probes = max(0, self._probes - 1)
            return self.probe
        a, b = fit
        efficient = math.ceil(round(9.0 * a / b, 6))  # a is at most a tenth of such a chunk's time
        n = max(int((self.target_s - a) / b), efficient, 1)
        largest = max(m for m, _ in self._warm + self._cold)
        n = min(n, MAX_CHUNK, GROWTH * largest)
        warm_sizes = {m for m, _ in self._warm}
        if warm_sizes == {n} and n < MAX_CHUNK and a + b * (n + 1) <= 1.5 * self.target_s:
            n += 1  # one size cannot tell a from b: one run more (if still a chunk of about target_s), to learn a
        share = math.ceil(self.remaining / self.workers)
        # the tail is split evenly between the workers, but not below what keeps the batching: the fitted efficient
        # size, and a batched kind's probe size (its a cannot be fitted while every chunk has the probe's size)
        return max(1, min(n, max(share, min(efficient, MAX_CHUNK), self.probe)))

    def next_chunk(self) -> list[int] | None:
        """The run ids of the next chunk, or None when every run has been handed out."""
        if self.remaining <= 0:
            return None
        n = self._next_size()
        ids = self._todo[self._pos : self._pos + n]
        self._pos += len(ids)
        self.sizes.append(len(ids))
        return ids

    def finished(self, n_runs: int, seconds: float, first_in_worker: bool = False) -> None:
        """A chunk of ``n_runs`` took ``seconds`` of compute (``first_in_worker``: the worker's first chunk)."""
        if n_runs > 0:
            (self._cold if first_in_worker else self._warm).append((int(n_runs), max(float(seconds), 0.0)))


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

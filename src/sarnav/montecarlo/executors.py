"""Where the chunks of a campaign run: in this process, in local processes, or on dask.distributed.

Each executor takes the chunk list and yields ``(run_ids, records)`` as chunks finish (in completion
order). The work item is :func:`simulate_chunk`, a pure function of (kind, cfg, run_ids, seeds), so
all executors give bit-identical records.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Iterator, Sequence

import numpy as np

from sarnav.errors import ConfigError
from sarnav.montecarlo.record import RunRecord
from sarnav.scenarios.base import ScenarioKind

__all__ = ["EXECUTORS", "simulate_chunk", "iter_serial", "iter_processes", "iter_dask", "iter_chunks"]

EXECUTORS = ("serial", "processes", "dask")


def simulate_chunk(
    kind: ScenarioKind, cfg: dict, run_ids: Sequence[int], seeds: Sequence[np.random.SeedSequence]
) -> list[RunRecord]:
    """Run ``kind.simulate`` on one chunk and check each record against the contract."""
    records = kind.simulate(cfg, list(run_ids), list(seeds))
    n_state, n_meas = len(kind.state_names(cfg)), len(kind.meas_names(cfg))
    if len(records) != len(run_ids):
        raise RuntimeError(f"{type(kind).__name__}.simulate returned {len(records)} records for {len(run_ids)} runs")
    for rid, rec in zip(run_ids, records):
        if rec.run != rid:
            raise RuntimeError(f"{type(kind).__name__}.simulate: record for run {rec.run}, expected {rid}")
        rec.check(n_state, n_meas)
    return records


def iter_serial(kind, cfg, chunks, seeds) -> Iterator[tuple[list[int], list[RunRecord]]]:
    for ids in chunks:
        yield ids, simulate_chunk(kind, cfg, ids, [seeds[i] for i in ids])


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop the workers now (ProcessPoolExecutor has no public terminate before Python 3.14)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5)


def iter_processes(kind, cfg, chunks, seeds, workers: int) -> Iterator[tuple[list[int], list[RunRecord]]]:
    """Local worker processes (``spawn``: no inherited threads or locks), one chunk per task."""
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))
    clean = False
    try:
        pending = {pool.submit(simulate_chunk, kind, cfg, ids, [seeds[i] for i in ids]): ids for ids in chunks}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                ids = pending.pop(fut)
                yield ids, fut.result()
        clean = True
    finally:
        if clean:
            pool.shutdown(wait=True)
        else:
            _terminate(pool)


def iter_dask(kind, cfg, chunks, seeds, scheduler: str | None, workers: int) -> Iterator[tuple[list[int], list[RunRecord]]]:
    """dask.distributed: ``scheduler`` address, or a LocalCluster of ``workers`` processes."""
    from dask.distributed import Client, LocalCluster, as_completed

    cluster = None
    try:
        if scheduler:
            client = Client(scheduler, timeout="20s")
        else:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
            client = Client(cluster)
    except OSError as err:
        raise ConfigError("--scheduler", f"cannot connect to dask scheduler {scheduler!r}: {err}") from None
    futures = []
    try:
        owner = {}
        for ids in chunks:
            f = client.submit(simulate_chunk, kind, cfg, ids, [seeds[i] for i in ids], pure=False)
            futures.append(f)
            owner[f.key] = ids
        for fut in as_completed(futures):
            yield owner[fut.key], fut.result()
    finally:
        for f in futures:
            f.cancel()
        client.close()
        if cluster is not None:
            cluster.close()


def iter_chunks(kind, cfg, chunks, seeds, executor: str = "processes", workers: int | None = None, scheduler: str | None = None):
    """Dispatch to the named executor; ``workers`` defaults to the number of cores."""
    if executor not in EXECUTORS:
        raise ConfigError("--executor", f"must be one of {', '.join(EXECUTORS)}, got {executor!r}")
    workers = workers if workers is not None else (os.cpu_count() or 1)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError("--workers", f"must be an integer >= 1, got {workers!r}")
    if executor == "serial":
        return iter_serial(kind, cfg, chunks, seeds)
    if executor == "processes":
        return iter_processes(kind, cfg, chunks, seeds, workers)
    return iter_dask(kind, cfg, chunks, seeds, scheduler, workers)

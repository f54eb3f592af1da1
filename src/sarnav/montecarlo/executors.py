"""Where the chunks of a campaign run: in this process, in local processes, or on dask.distributed.

A :class:`ChunkRunner` holds the workers (a process pool, or a dask client and perhaps the
LocalCluster it started) so that several campaigns — the cases of a study — share them; its
:meth:`~ChunkRunner.run` yields ``(run_ids, records)`` as chunks finish (in completion order). The
work item is :func:`simulate_chunk`, a pure function of (kind, cfg, run_ids, seeds), so every
executor gives bit-identical records.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Iterator, Sequence

import numpy as np

from sarnav.errors import ConfigError, InputDataError, RunFault, SarnavError, deferred_signals, require_extra
from sarnav.montecarlo.record import RunRecord
from sarnav.montecarlo.kind import ScenarioKind
from sarnav.montecarlo.seeding import ChunkPlan, FixedChunks

__all__ = ["EXECUTORS", "simulate_chunk", "ChunkRunner", "WorkerInputError"]

EXECUTORS = ("serial", "processes", "dask")


class WorkerInputError(Exception):
    """A :class:`SarnavError` raised in a worker, returned as a value.

    ``ConfigError``/``InputDataError`` pickle through their ``__reduce__`` (sarnav.errors); returning
    the error as the task's *result* instead of raising it keeps dask workers from logging it as a
    task failure with a traceback, and :func:`reraise_input_error` rebuilds the original in the
    caller, so the CLI still prints one line.
    """

    def __init__(self, module: str, qualname: str, field, message: str):
        super().__init__(module, qualname, field, message)


def reraise_input_error(err: WorkerInputError):
    """Raise the SarnavError that :class:`WorkerInputError` describes."""
    import importlib

    module, qualname, field, message = err.args
    cls = getattr(importlib.import_module(module), qualname, None)
    if isinstance(cls, type) and issubclass(cls, (ConfigError, InputDataError)) and field is not None:
        raise cls(field, message) from None
    raise SarnavError(message) from None


def _check_address(address: str) -> None:
    """A dask scheduler address must be ``protocol://host:port`` (e.g. tcp://10.0.0.5:8786)."""
    import re

    m = re.match(r"^(tcp|tls|ucx|ws|wss)://([^/:\s]+|\[[0-9a-fA-F:]+\]):(\d{1,5})$", str(address))
    if not m or not 0 < int(m.group(3)) < 65536:
        raise ConfigError("--scheduler", f"must be an address like tcp://host:8786 (protocol tcp, tls, ucx, ws or wss; "
                          f"port 1-65535), got {address!r}")


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


def _chunk_task(kind, cfg, run_ids, seeds):
    """The work item sent to workers: ``(records, seconds of compute, worker pid)``, or the input error as a picklable *value*
    (so that neither pickling nor the workers' error logging gets in the way of a one-line message)."""
    try:
        t0 = time.perf_counter()
        records = simulate_chunk(kind, cfg, run_ids, seeds)
        return records, time.perf_counter() - t0, os.getpid()
    except SarnavError as err:
        cls = type(err)
        return WorkerInputError(cls.__module__, cls.__qualname__, getattr(err, "field", None),
                                getattr(err, "message", str(err)))


#: the end of every fault message of a campaign: what was kept and how to finish
RESUME_HINT = "the runs stored so far are kept: finish with the same command and --resume"


def _runs(ids) -> str:
    return f"run {ids[0]}" if len(ids) == 1 else f"runs {ids[0]}-{ids[-1]}"


def _dask_faults() -> tuple:
    """The exceptions of a dask cluster that failed (not of a kind's code)."""
    import asyncio
    import concurrent.futures

    from distributed.comm.core import CommClosedError
    from distributed.scheduler import KilledWorker

    return (KilledWorker, CommClosedError, asyncio.CancelledError, concurrent.futures.CancelledError, TimeoutError,
            OSError)


def worker_died(ids) -> RunFault:
    """The one line for a local worker process that died while ``ids`` (the runs in flight) were simulated."""
    return RunFault("--workers", f"a worker process died (killed, or out of memory) while simulating "
                    f"{_runs(sorted(ids))}; " + RESUME_HINT)


def _result(fut, ids, executor: str):
    """A finished future's result; a worker that died, or a dask scheduler or worker lost, becomes one
    :class:`RunFault` line (issue 31: a ``BrokenProcessPool`` traceback)."""
    try:
        return fut.result()
    except BrokenProcessPool:
        raise worker_died(ids) from None
    except Exception as err:  # noqa: BLE001 - dask: KilledWorker, CommClosedError, CancelledError, timeouts
        if executor != "dask" or not isinstance(err, _dask_faults()):
            raise
        raise RunFault("--executor dask", f"the dask cluster failed while simulating {_runs(ids)} "
                       f"({type(err).__name__}: {str(err)[:200] or 'no detail'}); " + RESUME_HINT) from None


def _checked(result, plan: ChunkPlan, ids, seen: set) -> list[RunRecord]:
    """The records of a finished task (its compute time goes to the plan; ``seen``: the worker pids that finished a
    chunk before), or its input error raised."""
    if isinstance(result, WorkerInputError):
        reraise_input_error(result)
    records, seconds, worker = result
    plan.finished(len(ids), seconds, first_in_worker=worker not in seen)
    seen.add(worker)
    return records


#: Linux prctl option: the signal a process gets when the thread that started it ends (prctl(2))
_PR_SET_PDEATHSIG = 1


def _watch_parent(parent: int, period: float = 0.5) -> None:
    """Daemon thread of a worker: leave at once when ``parent`` is no longer this process's parent (it died and the
    worker was re-parented), for systems without a parent-death signal."""
    import threading

    def watch():
        while os.getppid() == parent:
            time.sleep(period)
        os._exit(1)

    threading.Thread(target=watch, name="sarnav-parent-watch", daemon=True).start()


def _die_with_parent(parent: int) -> None:
    """A worker dies with the process that started it, whatever kills that one (``kill -9`` included): on Linux the
    kernel's parent-death signal (SIGKILL, even in the middle of compiled code that holds the GIL), everywhere a
    watchdog thread polling the parent (issue 31: orphaned workers of ~165 MB computed on for minutes)."""
    if parent <= 1:
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        pass
    _watch_parent(parent)
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)


def _limit_worker_threads(threads: int, parent: int = 0) -> None:
    """Worker-process initializer: ``threads`` BLAS and numba threads per worker, so that K worker
    processes on K cores do not oversubscribe them (each would otherwise start one thread per core;
    small complex matrix products then ran ~50x slower on a loaded 2-core machine). Thread counts
    do not change any run's numbers: kinds never reduce across threads. The worker dies with ``parent``, the main
    process (:func:`_die_with_parent`)."""
    import signal

    from threadpoolctl import threadpool_limits

    # the main process decides what a SIGINT means (it terminates the workers): a ^C to the process group must
    # not print a KeyboardInterrupt traceback from every worker
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent)
    threadpool_limits(threads)
    try:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    except ImportError:  # pragma: no cover
        pass


@contextmanager
def _children_start_with_sigint_blocked():
    """Processes started inside (the pool's workers and multiprocessing's resource tracker, both spawned from this
    thread by ``submit``) inherit SIGINT blocked: the signal mask survives fork and exec (POSIX). Without it a ^C to
    the process group that arrives while a child is still importing ``multiprocessing`` (before the worker initializer
    ignores SIGINT) prints that child's KeyboardInterrupt traceback (seen once on a loaded 2-core machine,
    tests/cli/test_signals.py). The main process decides what a SIGINT means and terminates the workers; in this thread
    the signal stays pending while blocked and is delivered when the block ends (or at once to another thread:
    Python runs its handler in the main thread either way), so none is lost."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop the workers now (ProcessPoolExecutor has no public terminate before Python 3.14)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5)


class ChunkRunner:
    """Executes chunks of runs; a context manager that owns its workers.

    Parameters
    ----------
    executor : ``"serial"``, ``"processes"`` (local ``spawn`` processes: no inherited threads or
        locks) or ``"dask"`` (dask.distributed).
    workers : worker processes (default: number of cores); for dask without ``scheduler``, the size
        of the LocalCluster started.
    scheduler : dask scheduler address (``tcp://host:port``); only with ``executor="dask"``.
    """

    def __init__(self, executor: str = "processes", workers: int | None = None, scheduler: str | None = None):
        if executor not in EXECUTORS:
            raise ConfigError("--executor", f"must be one of {', '.join(EXECUTORS)}, got {executor!r}")
        workers = workers if workers is not None else (os.cpu_count() or 1)
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ConfigError("--workers", f"must be an integer >= 1, got {workers!r}")
        if scheduler and executor != "dask":
            raise ConfigError("--scheduler", f"needs --executor dask, got --executor {executor}")
        if executor == "dask":  # an optional dependency: one line naming the extra, before anything is written
            require_extra("--executor", "dask", "distributed", "dask[distributed]")
        if scheduler:
            _check_address(scheduler)
        self.executor = executor
        self.workers = 1 if executor == "serial" else workers
        self.scheduler = scheduler
        self._pool: ProcessPoolExecutor | None = None
        self._client = None
        self._cluster = None

    # -- lifetime
    def __enter__(self) -> "ChunkRunner":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.close(abort=exc_type is not None)
        return False

    def close(self, abort: bool = False, futures=()) -> None:
        """Release the workers (``abort``: terminate local worker processes at once, quietly; ``futures``: dask
        futures to cancel on a scheduler this runner did not start)."""
        if self._pool is not None:
            if abort:
                _terminate(self._pool)
            else:
                self._pool.shutdown(wait=True)
            self._pool = None
        if abort and (self._client is not None or self._cluster is not None):
            self._abort_dask(futures)
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def _abort_dask(self, futures) -> None:
        """Stop dask at once without a word: the LocalCluster's worker processes are killed (SIGKILL: a worker told
        to stop would log the cancelled tasks and the closed connections, pages of tracebacks on the user's
        terminal), the futures of an outside scheduler cancelled, this process's ``distributed`` logging silenced
        while client and cluster close."""
        import logging
        import signal

        previous = logging.root.manager.disable
        logging.disable(logging.CRITICAL)
        try:
            if self._cluster is not None:
                for nanny in list(getattr(self._cluster, "workers", {}).values()):
                    pid = getattr(nanny, "pid", None)
                    if pid:
                        try:
                            os.kill(pid, signal.SIGKILL)
                        except OSError:
                            pass
            elif self._client is not None and futures:
                try:
                    self._client.cancel(list(futures))
                except Exception:  # noqa: BLE001 - leaving anyway: the scheduler drops them with the client
                    pass
            for obj in (self._client, self._cluster):
                if obj is not None:
                    try:
                        obj.close(timeout=5)
                    except Exception:  # noqa: BLE001 - the workers are gone; nothing left to report
                        pass
            self._client = self._cluster = None
        finally:
            logging.disable(previous)

    def _ensure_pool(self) -> ProcessPoolExecutor:
        if self._pool is None:
            threads = max(1, (os.cpu_count() or 1) // self.workers)
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context("spawn"),
                                             initializer=_limit_worker_threads, initargs=(threads, os.getpid()))
        return self._pool

    def _ensure_client(self):
        if self._client is None:
            with deferred_signals():
                import logging

                from dask.distributed import Client, LocalCluster

            try:
                if self.scheduler:
                    self._client = Client(self.scheduler, timeout="20s")
                else:
                    # worker processes log errors only (their warnings, e.g. of cancelled tasks, are not the user's);
                    # the dashboard on any free port (None means 8787: a second cluster on the machine, e.g. a
                    # parallel test, printed "Port 8787 is already in use" on stderr)
                    self._cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                                 dashboard_address=":0", silence_logs=logging.ERROR)
                    self._client = Client(self._cluster)
            except OSError as err:
                raise ConfigError("--scheduler", f"cannot connect to dask scheduler {self.scheduler!r}: {err}") from None
        return self._client

    # -- work
    def run(self, kind, cfg, chunks, seeds) -> Iterator[tuple[list[int], list[RunRecord]]]:
        """Yield ``(run_ids, records)`` for each chunk as it finishes. ``chunks``: a list of run-id lists, or a
        :class:`~sarnav.montecarlo.seeding.ChunkPlan` asked for the next chunk whenever a worker is free (one chunk
        in flight per worker, so a chunk's runs are stored as soon as it ends and the plan sizes the next one from
        the compute times measured so far)."""
        plan = chunks if isinstance(chunks, ChunkPlan) else FixedChunks(chunks)
        seen: set = set()
        if self.executor == "serial":
            plan_first = None
            while (ids := plan.next_chunk()) is not None:
                plan_first = ids if plan_first is None else plan_first
                t0 = time.perf_counter()
                records = simulate_chunk(kind, cfg, ids, [seeds[i] for i in ids])
                plan.finished(len(ids), time.perf_counter() - t0, first_in_worker=ids is plan_first)
                yield ids, records
        elif self.executor == "processes":
            yield from self._run_processes(kind, cfg, plan, seeds, seen)
        else:
            yield from self._run_dask(kind, cfg, plan, seeds, seen)

    def _run_processes(self, kind, cfg, plan, seeds, seen):
        pool = self._ensure_pool()
        clean = False
        pending = {}

        def submit():
            ids = plan.next_chunk()
            if ids is not None:  # a signal is answered after the submit: a worker half spawned (its start-up data not
                # yet written to it) is not in the pool's list the abort terminates, and reads EOF once this process
                # leaves (an EOFError traceback on the terminal; CI, 2026-12-06)
                with deferred_signals(), _children_start_with_sigint_blocked():
                    try:
                        pending[pool.submit(_chunk_task, kind, cfg, ids, [seeds[i] for i in ids])] = ids
                    except BrokenProcessPool:  # a worker died after the last chunk finished: the pool refuses more
                        raise worker_died([i for chunk in pending.values() for i in chunk] or ids) from None

        try:
            for _ in range(self.workers):
                submit()
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    ids = pending.pop(fut)
                    records = _checked(_result(fut, ids, "processes"), plan, ids, seen)
                    submit()
                    yield ids, records
            clean = True
        finally:
            if not clean:  # interrupted or failed: do not leave workers computing
                self.close(abort=True)

    def _dask_slots(self, client) -> int:
        """Chunks kept in flight on dask: one per worker thread of the cluster (at least ``workers``)."""
        try:
            return max(self.workers, sum(client.nthreads().values()))
        except Exception:  # noqa: BLE001 - a scheduler that cannot say: the requested workers
            return self.workers

    def _run_dask(self, kind, cfg, plan, seeds, seen):
        from dask.distributed import as_completed

        client = self._ensure_client()
        futures, owner = [], {}
        clean = False

        def submit():
            ids = plan.next_chunk()
            if ids is None:
                return None
            f = client.submit(_chunk_task, kind, cfg, ids, [seeds[i] for i in ids], pure=False)
            futures.append(f)
            owner[f.key] = ids
            return f

        try:
            queue = as_completed([f for f in (submit() for _ in range(self._dask_slots(client))) if f is not None])
            for fut in queue:
                ids = owner[fut.key]
                records = _checked(_result(fut, ids, "dask"), plan, ids, seen)
                nxt = submit()
                if nxt is not None:
                    queue.add(nxt)
                yield ids, records
            clean = True
        finally:
            if not clean:
                self.close(abort=True, futures=futures)

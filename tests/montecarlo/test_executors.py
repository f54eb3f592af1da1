"""The process executor's workers start with SIGINT blocked (a ^C to the process group is the main process's to
handle: a worker or resource tracker still importing ``multiprocessing`` must not print a KeyboardInterrupt
traceback; tests/cli/test_signals.py sends the signals)."""

import multiprocessing
import os
import signal
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

from sarnav.montecarlo import executors as ex

pytestmark = pytest.mark.skipif(not Path("/proc/self/status").exists() or not hasattr(signal, "pthread_sigmask"),
                                reason="needs Linux /proc and POSIX signal masks")


def _blocked(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(status.split("SigBlk:")[1].split()[0], 16)


def test_children_spawned_inside_inherit_sigint_blocked_and_the_mask_is_restored():
    before = signal.pthread_sigmask(signal.SIG_BLOCK, set())
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        with ex._children_start_with_sigint_blocked():
            assert signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, set())
            future = pool.submit(os.getpid)  # the worker is spawned here
        pid = future.result(timeout=60)
        assert _blocked(pid) & (1 << (signal.SIGINT - 1))
    assert signal.pthread_sigmask(signal.SIG_BLOCK, set()) == before


def test_a_pool_started_outside_does_not_block_sigint():
    """The control: the mask comes from the context manager, not from the pool."""
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        pid = pool.submit(os.getpid).result(timeout=60)
        assert not _blocked(pid) & (1 << (signal.SIGINT - 1))


def test_a_pool_that_breaks_between_chunks_is_the_worker_line_not_a_traceback():
    """A worker killed just after another chunk finished: the pool refuses the next submit with BrokenProcessPool
    (tests/cli/test_faults.py met this once under load, a traceback instead of the one line). The submit's refusal is
    the same RunFault as a broken future's, naming the runs in flight."""
    from concurrent.futures import Future
    from concurrent.futures.process import BrokenProcessPool

    import numpy as np

    from sarnav.errors import RunFault
    from sarnav.montecarlo.executors import ChunkRunner

    class BreaksOnThirdSubmit:
        _processes: dict = {}

        def __init__(self):
            self.calls = 0

        def submit(self, fn, kind, cfg, ids, seeds):
            self.calls += 1
            if self.calls == 3:
                raise BrokenProcessPool("A child process terminated abruptly")
            fut = Future()
            if self.calls == 1:
                fut.set_result(([], 0.01, 1234))      # the first chunk finishes; the second stays in flight
            return fut

        def shutdown(self, wait=True, cancel_futures=False):
            pass

    runner = ChunkRunner("processes", workers=2)
    runner._pool = BreaksOnThirdSubmit()
    seeds = np.random.SeedSequence(0).spawn(6)
    with pytest.raises(RunFault, match=r"^--workers: a worker process died .* simulating runs 2-3; .*--resume"):
        for _ in runner.run(None, {}, [[0, 1], [2, 3], [4, 5]], seeds):
            pass

"""The timer the benchmark scripts share (imported as ``from timing import best_time``: a script's own folder is on
``sys.path`` when it runs)."""

from __future__ import annotations

import time


def best_time(fn, repeat: int, warm_up: bool = False) -> float:
    """The shortest wall time [s] of ``repeat`` calls of ``fn()`` (after one untimed call when ``warm_up``: compiled
    kernels, caches)."""
    if warm_up:
        fn()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best

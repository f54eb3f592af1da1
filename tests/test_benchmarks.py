"""The benchmark scripts still run against the library (they are not part of the timed suite: one tiny call each of
the ones that build their own inputs from library types; bench_rda broke silently when PulseData lost its radar
fallback in issue 25)."""

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.mark.parametrize("script, args", [
    ("bench_rda.py", ["--sizes", "64x256", "--repeat", "1"]),
    ("bench_echoes.py", ["--pulses", "16", "--targets", "2"]),
])
def test_benchmark_runs(script, args):
    done = subprocess.run([sys.executable, str(BENCH / script), *args], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]

"""The benchmark scripts still run against the library (they are not part of the timed suite: one tiny call each of
the ones that build their own inputs from library types; bench_rda broke silently when PulseData lost its radar
fallback in issue 25; bench_particles, whose tiny run is mostly compilation, is left out). bench_bpa and bench_ffbp also run on the peer's simulated collect (FastSAR, optional): once
as installed, once with fastsar made unimportable (the peer's collect and columns skipped with a note)."""

import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.mark.parametrize("script, args", [
    ("bench_rda.py", ["--sizes", "64x256", "--repeat", "1"]),
    ("bench_echoes.py", ["--pulses", "16", "--targets", "2"]),
    ("bench_rda_nav.py", ["--runs", "2", "--duration", "2"]),
    ("bench_campaign.py", ["--runs", "10", "--seconds", "1", "--loop-runs", "2"]),
    ("bench_bpa.py", ["--size", "32", "--pulses", "32", "--rounds", "1", "--no-table", "--peer-sizes", "64"]),
    ("bench_ffbp.py", ["--sizes", "128", "--exact-pulses", "16", "--check", "32", "--peer-sizes", "64"]),
    ("bench_navigate.py", ["--duration", "3", "--runs", "2"]),
    ("bench_quality_search.py", ["--block", "200", "--size", "16", "--repeat", "1", "--runs", "1"]),
    ("bench_spacecraft.py", ["--runs", "2", "--loop-runs", "2", "--images", "1"]),
    ("bench_bpa.py", ["--rounds", "0", "--no-table", "--peer-sizes", "64", "--peer-modes", "auto", "default",
                      "--peer-ffbp-error-db", "-45", "-99", "--peer-plane"]),
    ("bench_ffbp.py", ["--sizes", "128", "--exact-pulses", "16", "--check", "32", "--peer-sizes", "--no-fastsar",
                       "--track-walk", "0.3"]),
    ("bench_bpa_chip.py", ["--runs", "1", "--apertures", "3", "--rounds", "1", "--straight"]),
])
def test_benchmark_runs(script, args):
    done = subprocess.run([sys.executable, str(BENCH / script), *args], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]


@pytest.mark.parametrize("script, args", [
    ("bench_bpa.py", ["--size", "32", "--pulses", "32", "--rounds", "1", "--no-table", "--peer-sizes", "64"]),
    ("bench_ffbp.py", ["--sizes", "128", "--exact-pulses", "16", "--check", "32", "--peer-sizes", "64"]),
])
def test_benchmark_runs_without_the_peer(script, args):
    code = ("import runpy, sys; sys.modules['fastsar'] = None; sys.path.insert(0, sys.argv[1]); "
            "sys.argv = sys.argv[2:]; runpy.run_path(sys.argv[0], run_name='__main__')")
    done = subprocess.run([sys.executable, "-c", code, str(BENCH), str(BENCH / script), *args], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "fastsar not installed" in done.stdout
